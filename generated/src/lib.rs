//! lockstep's dynamics kernels, generated at build time from `model/*.toml` by the
//! symbolic generator (`lockstep-codegen`, Symbolica).
//!
//! For every model and every configuration (set of free joints F; locked joints have
//! q̇ = q̈ = 0 and their positions are inputs) a module holds straight-line f64 functions:
//!
//! | function | shape | equation (thesis) |
//! |---|---|---|
//! | `mass_matrix(q, p)` | `[[f64; NF]; NF]` | D_FF(q) (3.2) |
//! | `christoffel_matrix(q, qd, p)` | `[[f64; NF]; NF]` | C_FF(q, q̇) (3.3) |
//! | `coriolis(q, qd, p)` | `[f64; NF]` | C_FF q̇_F |
//! | `gravity(q, p)` | `[f64; NF]` | φ_F(q) (3.4) |
//! | `inverse_dynamics(q, qd, qdd, p)` | `[f64; NF]` | τ_F = D q̈ + C q̇ + φ (3.5) |
//! | `forward_dynamics(q, qd, tau, p)` | `[f64; NF]` | q̈_F = D⁻¹(τ − C q̇ − φ) (Cholesky) |
//! | `dynamics_derivatives(q, qd, qdd, p)` | `[[f64; 3NF]; NF]` | [D, ∂τ_F/∂q_F, ∂τ_F/∂q̇_F] at fixed q̈ |
//! | `regressor(q, qd, qdd)` | `[[f64; NP]; NF]` | τ_F = Y_F p |
//!
//! Each has a `_trig` form (`forward_dynamics_trig(q, sc, qd, tau, p)`, …) that reads the
//! joints' sines and cosines from a table `sc` (`[f64; 2 NJ]`, `sc[2k] = sin q_k`,
//! `sc[2k + 1] = cos q_k`, the joints in the module's `TRIG`) instead of computing them: a
//! simulation computes a locked joint's once per run and a free joint's once per stage.
//!
//! Forward dynamics also comes split for a simulation: `forward_dynamics_invariants(q, sc,
//! p)` returns the intermediates that read only the locked joints and `p` (computed once per
//! run), and `forward_dynamics_trig_inv(q, sc, qd, tau, p, inv)` computes the rest, with
//! the same bits as `forward_dynamics_trig`. Links held by locked joints are folded into
//! composite bodies before the recursive algorithms run, so a configuration's kernels do no
//! work per locked link (the regressor excepted: it is formed link by link).
//!
//! `q` is the full joint vector `[f64; NJ]` (rad or m); `qd`, `qdd`, `tau` hold the free
//! joints only, in ascending joint order; `p` is the barycentric parameter vector
//! `[f64; NP]` of the model (per link: mass m (kg), first moments m·c (kg·m), inertia about
//! the link-frame origin (kg·m²)), named in [`Model::params`].
//!
//! The [`Model`] table gives the same kernels behind slices for code that picks a model and a
//! configuration at run time.

pub mod inertia;

/// A kernel `(q[NJ], p[NP], out)`.
pub type PositionKernel = fn(&[f64], &[f64], &mut [f64]);
/// A kernel `(q[NJ], v[NF], p[NP], out)`.
pub type VelocityKernel = fn(&[f64], &[f64], &[f64], &mut [f64]);
/// A kernel `(q[NJ], v[NF], w[NF], p[NP], out)`.
pub type StateKernel = fn(&[f64], &[f64], &[f64], &[f64], &mut [f64]);
/// The regressor kernel `(q[NJ], qd[NF], qdd[NF], out[NF·NP])`.
pub type RegressorKernel = fn(&[f64], &[f64], &[f64], &mut [f64]);
/// A [`PositionKernel`] reading the trigonometric table: `(q[NJ], sc[2NJ], p[NP], out)`.
pub type TrigPositionKernel = fn(&[f64], &[f64], &[f64], &mut [f64]);
/// A [`StateKernel`] reading the trigonometric table: `(q[NJ], sc[2NJ], v[NF], w[NF], p[NP], out)`.
pub type TrigStateKernel = fn(&[f64], &[f64], &[f64], &[f64], &[f64], &mut [f64]);
/// The [`RegressorKernel`] reading the trigonometric table: `(q[NJ], sc[2NJ], qd[NF], qdd[NF], out)`.
pub type TrigRegressorKernel = fn(&[f64], &[f64], &[f64], &[f64], &mut [f64]);
/// A [`TrigStateKernel`] reading its loop invariants too:
/// `(q[NJ], sc[2NJ], v[NF], w[NF], p[NP], inv, out)`.
pub type TrigStateInvKernel = fn(&[f64], &[f64], &[f64], &[f64], &[f64], &[f64], &mut [f64]);

/// Kernels of one configuration behind slices (row-major matrices).
#[derive(Debug, Clone, Copy)]
pub struct Configuration {
    /// Name (`full`, `c1`, `k3`, …).
    pub name: &'static str,
    /// Free joint indices, ascending.
    pub free: &'static [usize],
    /// Indices of the barycentric parameters that appear in this configuration's equations.
    pub params_present: &'static [usize],
    /// D_FF: `(q[NJ], p[NP], out[NF·NF])`.
    pub mass_matrix: PositionKernel,
    /// C_FF: `(q[NJ], qd[NF], p[NP], out[NF·NF])`.
    pub christoffel_matrix: VelocityKernel,
    /// C_FF q̇_F: `(q[NJ], qd[NF], p[NP], out[NF])`.
    pub coriolis: VelocityKernel,
    /// φ_F: `(q[NJ], p[NP], out[NF])`.
    pub gravity: PositionKernel,
    /// τ_F: `(q[NJ], qd[NF], qdd[NF], p[NP], out[NF])`.
    pub inverse_dynamics: StateKernel,
    /// q̈_F: `(q[NJ], qd[NF], tau[NF], p[NP], out[NF])`.
    pub forward_dynamics: StateKernel,
    /// Row a of `[D_FF | ∂τ_F/∂q_F | ∂τ_F/∂q̇_F]` at fixed q̈ (τ_F the inverse dynamics):
    /// `(q[NJ], qd[NF], qdd[NF], p[NP], out[NF·3NF])`.
    pub dynamics_derivatives: StateKernel,
    /// Y_F: `(q[NJ], qd[NF], qdd[NF], out[NF·NP])`.
    pub regressor: RegressorKernel,
    /// Joints whose sine and cosine the kernels read: the entries of the trigonometric
    /// table `sc` the `_trig` forms need (`sc[2k] = sin q_k`, `sc[2k + 1] = cos q_k`, length
    /// 2·NJ; the others are not read). A simulation fills the locked joints' entries once
    /// and the free joints' once per stage, where each kernel would recompute them all.
    pub trig: &'static [usize],
    /// [`Configuration::mass_matrix`] reading `sc`: `(q[NJ], sc[2NJ], p[NP], out[NF·NF])`.
    pub mass_matrix_trig: TrigPositionKernel,
    /// [`Configuration::forward_dynamics`] reading `sc`:
    /// `(q[NJ], sc[2NJ], qd[NF], tau[NF], p[NP], out[NF])`.
    pub forward_dynamics_trig: TrigStateKernel,
    /// The number of [`Configuration::forward_dynamics_invariants`]' values.
    pub forward_dynamics_invariant_count: usize,
    /// The intermediates of forward dynamics that depend only on the locked joints'
    /// positions and on p (loop invariants of a simulation): `(q[NJ], sc[2NJ], p[NP],
    /// out[forward_dynamics_invariant_count])`.
    pub forward_dynamics_invariants: TrigPositionKernel,
    /// [`Configuration::forward_dynamics_trig`] reading those invariants:
    /// `(q[NJ], sc[2NJ], qd[NF], tau[NF], p[NP], inv, out[NF])`; the same values.
    pub forward_dynamics_trig_inv: TrigStateInvKernel,
    /// [`Configuration::dynamics_derivatives`] reading `sc`:
    /// `(q[NJ], sc[2NJ], qd[NF], qdd[NF], p[NP], out[NF·3NF])`.
    pub dynamics_derivatives_trig: TrigStateKernel,
    /// [`Configuration::regressor`] reading `sc`: `(q[NJ], sc[2NJ], qd[NF], qdd[NF], out[NF·NP])`.
    pub regressor_trig: TrigRegressorKernel,
}

/// A generated model.
#[derive(Debug, Clone, Copy)]
pub struct Model {
    /// Model name (the `[robot] name` of its file).
    pub name: &'static str,
    /// Joint variable names (NJ).
    pub joints: &'static [&'static str],
    /// Barycentric parameter names (NP).
    pub params: &'static [&'static str],
    /// Link of each barycentric parameter (index into [`Model::links`]).
    pub param_link: &'static [usize],
    /// Kind of each barycentric parameter: index into [`inertia::BARYCENTRIC_KINDS`]
    /// (0 = m, 1..=3 = m·c, 4..=9 = inertia about the frame origin).
    pub param_kind: &'static [usize],
    /// Link names.
    pub links: &'static [&'static str],
    /// Inertial symbols of the model file (thesis form: m, centroid, inertia about it).
    pub inertial_symbols: &'static [&'static str],
    /// Link of each inertial symbol (index into [`Model::links`]).
    pub symbol_link: &'static [usize],
    /// Role of each inertial symbol: 0 = mass (kg), 1 = centroid coordinate (m),
    /// 2 = inertia about the centroid (kg·m²) (the model-file field it appears in).
    pub symbol_role: &'static [usize],
    /// Default value of each inertial symbol (the model file's `[defaults]` or its URDF's
    /// `<inertial>` numbers: the prior), `None` where it has none.
    pub symbol_defaults: &'static [Option<f64>],
    /// What the generator read (joints, frames, links and default values, configurations),
    /// as `lockstep model show` prints it.
    pub description: &'static str,
    /// The equivalent modified (Craig) DH table as model-file TOML, checked against the
    /// model's kinematics, or why none exists (a tree, a coupled joint).
    pub dh_table: Result<&'static str, &'static str>,
    /// Barycentric parameters from the model file's inertial symbols:
    /// `(symbols[NI], out[NP])`.
    pub barycentric_from_symbols: fn(&[f64], &mut [f64]),
    /// Configurations.
    pub configurations: &'static [Configuration],
    /// Locking sequences of the model file (thesis Tables 4.2, 4.6): name and the
    /// configuration names in order.
    pub sequences: &'static [(&'static str, &'static [&'static str])],
}

impl Model {
    /// Configuration by name.
    pub fn configuration(&self, name: &str) -> Option<&'static Configuration> {
        self.configurations.iter().find(|c| c.name == name)
    }
}

include!(concat!(env!("OUT_DIR"), "/models.rs"));

/// Model by name.
pub fn model(name: &str) -> Option<&'static Model> {
    MODELS.iter().copied().find(|m| m.name == name)
}
