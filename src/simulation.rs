//! Fixed-step RK4 simulation of one configuration of a plant: the generated rigid-body
//! kernels plus the joint effects of thesis 3.3–3.5 and Figure 3.5 (docs/src/design/digest.md §2).
//!
//! Per free joint i the rigid body receives
//! Q_i = Kp_i·τ'_i − b_i(q_i)·F_i(q̇_i, z_i) − Ks_i (q_i − qeq_i) − offset_i − Σ u_i(q, q̇, z, τ),
//! with u_i the user-defined terms on the joint ([`TorqueTerm`], [`crate::expression`]), where τ' is the
//! commanded torque after the tendon input couplings (4.5–4.6), τ'_i = τ_i + Σ G_{j→i} τ_j,
//! F_i is viscous + Coulomb + static Stribeck (3.3.1) + LuGre friction (3.6–3.8), and
//! b_i = FrictionBias_i where q_i < qeq_i, else 1 (4.3.5). The state is (q_F, q̇_F, z_F) with
//! z the LuGre bristle deflection (z(0) = 0).
//!
//! The integrator is fixed-step, chosen by [`Integrator`]: classical RK4 at a step h chosen by
//! the user (thesis: 0.5 ms for the isolated joints, 1/6000 s for the coupled ones), or an
//! exponential RK4 (ETDRK4) that takes the friction's own damping exactly and so runs the
//! Freedom 6S's wrist at steps RK4 cannot (its joint 4's LuGre damping over its small inertia
//! puts an eigenvalue near −2.5e4 s⁻¹ on the state Jacobian: RK4 needs h < 1/9600 s). The
//! commanded torques are sampled
//! at each stage time, so a zero-order hold or a linear interpolation of a torque file
//! ([`InputSignal`]) is followed exactly. [`PlantModel::simulate_at`] reports the state at
//! given output times (a measurement's sample times) by cubic Hermite interpolation between
//! steps, exact where a step lands on a sample.
//!
//! Units: rad, rad/s, N·m (m, m/s, N for prismatic joints), s.

use crate::expression::Program;
use generated::Configuration;

mod etdrk4;
mod friction;
mod input;
mod sensitivity;
pub use etdrk4::phi1234;
use etdrk4::EtdScratch;
pub use friction::*;
pub use input::*;
pub use sensitivity::*;

/// A user-defined torque term on one free joint ([`crate::expression`]), compiled with the
/// plant's parameter values and the locked joints' states folded in
/// ([`crate::plant::Plant::simulator`]).
#[derive(Debug, Clone, PartialEq)]
pub struct TorqueTerm {
    /// Name of the user-defined effect.
    pub name: String,
    /// The torque it takes from the joint (N·m or N).
    pub torque: Program,
    /// Where each input of `torque` comes from.
    pub inputs: Vec<TermInput>,
    /// ∂torque/∂q̇ of this joint, with its inputs (the damping [`Integrator::Etdrk4`] takes
    /// exactly); None when the torque does not read this joint's velocity.
    pub slope: Option<(Program, Vec<TermInput>)>,
    /// The inertia the term adds: per free joint k whose acceleration it reads, ∂torque/∂q̈_k
    /// with its inputs, taken into row `joint`, column k of the inertia matrix (`torque` is
    /// then the rest, at q̈ = 0).
    pub inertia: Vec<(usize, Program, Vec<TermInput>)>,
}

/// An input of a [`TorqueTerm`]: a state or command of a free joint (free index).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TermInput {
    /// Position q.
    Q(usize),
    /// Velocity q̇.
    Qd(usize),
    /// LuGre bristle deflection z.
    Z(usize),
    /// Commanded torque τ (before gain and input couplings).
    Tau(usize),
    /// Time t (s).
    T,
}

impl TorqueTerm {
    /// The torque at time `t` (s), positions `q`, velocities `qd`, deflections `z` and
    /// commands `tau` (free joints, NF each).
    #[inline]
    pub fn torque(&self, t: f64, q: &[f64], qd: &[f64], z: &[f64], tau: &[f64]) -> f64 {
        eval_term(&self.torque, &self.inputs, t, (q, qd, z, tau))
    }

    /// A coefficient program of [`TorqueTerm::inertia`] (or any program on the term's kind
    /// of inputs) at time `t` and positions, velocities, deflections and commands of the
    /// free joints.
    #[inline]
    pub fn coefficient(
        program: &Program,
        inputs: &[TermInput],
        t: f64,
        state: (&[f64], &[f64], &[f64], &[f64]),
    ) -> f64 {
        eval_term(program, inputs, t, state)
    }

    /// ∂torque/∂q̇ of its joint at the same arguments (0 when it does not read it).
    #[inline]
    pub fn slope(&self, t: f64, q: &[f64], qd: &[f64], z: &[f64], tau: &[f64]) -> f64 {
        self.slope
            .as_ref()
            .map_or(0.0, |(p, i)| eval_term(p, i, t, (q, qd, z, tau)))
    }
}

#[inline]
fn eval_term(
    program: &Program,
    inputs: &[TermInput],
    t: f64,
    (q, qd, z, tau): (&[f64], &[f64], &[f64], &[f64]),
) -> f64 {
    program.eval_with(|i| match inputs[i] {
        TermInput::Q(a) => q[a],
        TermInput::Qd(a) => qd[a],
        TermInput::Z(a) => z[a],
        TermInput::Tau(a) => tau[a],
        TermInput::T => t,
    })
}

/// The effects on one free joint.
#[derive(Debug, Clone, PartialEq)]
pub struct JointTerms {
    /// Plant gain Kp (commanded to applied torque).
    pub gain: f64,
    /// Viscous friction Fv (N·m·s/rad).
    pub viscous: f64,
    /// Coulomb friction Fc·sign(q̇) (N·m).
    pub coulomb: f64,
    /// Constant offset (N·m), subtracted from the applied torque.
    pub offset: f64,
    /// Static Stribeck friction (3.3.1).
    pub stribeck: Option<Stribeck>,
    /// LuGre friction.
    pub lugre: Option<LuGre>,
    /// Cable-drag spring (Ks (N·m/rad), qeq (rad)) (thesis 3.9).
    pub spring: Option<(f64, f64)>,
    /// Friction position bias (FrictionBias, qeq (rad)) (thesis 4.3.5): all friction of the
    /// joint is multiplied by FrictionBias where q < qeq.
    pub bias: Option<(f64, f64)>,
    /// User-defined torque terms ([`crate::expression`]), taken from the joint as the
    /// spring is.
    pub extra: Vec<TorqueTerm>,
    /// Armature (rotor) inertia Ia (kg·m² or kg), added to the joint's diagonal entry of the
    /// inertia matrix D_FF(q).
    pub armature: f64,
    /// Backlash: half the play of the transmission between the drive and the position
    /// sensor (rad or m; 0 = none): the sensed position is the play operator of q
    /// ([`crate::effects::EffectKind::Backlash`]), applied to the outputs of
    /// [`PlantModel::predict_at`].
    pub backlash: f64,
}

impl Default for JointTerms {
    fn default() -> Self {
        JointTerms {
            gain: 1.0,
            viscous: 0.0,
            coulomb: 0.0,
            offset: 0.0,
            stribeck: None,
            lugre: None,
            spring: None,
            bias: None,
            extra: Vec::new(),
            armature: 0.0,
            backlash: 0.0,
        }
    }
}

/// Tendon input coupling (thesis 4.5–4.6): free joint `to` receives `g` times the command
/// of free joint `from`, τ'_to = τ_to + g τ_from (indices into the free joints). The thesis's
/// pair is `{from: 5, to: 4, g: −G54}` and `{from: 4, to: 5, g: G45}`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InputCoupling {
    /// Free index of the joint whose command is passed on.
    pub from: usize,
    /// Free index of the joint that receives it.
    pub to: usize,
    /// Share G (dimensionless).
    pub g: f64,
}

/// Largest growth λh of a mode that [`Integrator::Etdrk4`] takes exactly (e¹⁰ per step); a
/// faster one (a steep negative Stribeck slope over a tiny inertia) keeps the rest explicit.
const GROWTH_MAX: f64 = 10.0;

/// The fixed-step integration scheme of a simulation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Integrator {
    /// Classical fourth-order Runge–Kutta (the thesis's integrator). Stable for h·|λ| < 2.78
    /// on the real axis, λ the state Jacobian's eigenvalues.
    #[default]
    Rk4,
    /// Exponential time differencing RK4 (Cox & Matthews, J. Comput. Phys. 176 (2002), (26)–(29);
    /// coefficients as φ-functions after Hochbruck & Ostermann, Acta Numerica 19 (2010), (2.40)):
    /// the state is split as ẋ = A x + N(x), A frozen and taken exactly, N = f − A x by the
    /// four RK stages. A holds the friction's own damping: on the
    /// velocities −D_FF⁻¹ C (D_FF the inertia matrix (3.2), C = diag(∂F_i/∂q̇_i) with F_i all
    /// friction of joint i and its bias, at the current (q̇_i, z_i); growth capped at
    /// λh = 10), the positions integrated along that same flow, and ∂ż_i/∂z_i = −σ0|q̇_i|/g on
    /// each LuGre deflection (`PlantModel::etd_lambda`); springs, gravity, Coriolis terms
    /// stay in N. A step in which a joint's friction switches regime is redone in substeps
    /// (`PlantModel::etdrk4_with_switches`). Fourth order where A h is small, exact for a
    /// joint whose damping dominates under a constant force, and within 2.3e-5 rad of a
    /// converged RK4 on the Freedom 6S's wrist at 1/2000 s over 10 s, where RK4 diverges.
    /// Its local error is far above RK4's at RK4's stable step, though: on a 40 s Table 4.7
    /// run of k3, whose trajectory amplifies early errors a thousandfold, it deviates by
    /// 3.0e-3 rad at 1/2000 s and 2.4e-4 rad at 1/4000 s, RK4 at 1/12000 s by 2.1e-6 rad
    /// (`tests/plant_simulation.rs`). Per step on top of RK4's four right-hand sides: the
    /// inertia matrix and the friction slopes; the velocity block's decomposition (Cholesky
    /// factor, inverse, symmetric eigendecomposition) only when it has drifted
    /// (`REFREEZE`; ≈ 1 step in 7 on the Freedom 6S runs). A 40 s file at 1/2000 s costs
    /// 0.3–0.4 × RK4 at 1/12000 s.
    Etdrk4,
}

impl std::str::FromStr for Integrator {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "rk4" => Ok(Integrator::Rk4),
            "etdrk4" => Ok(Integrator::Etdrk4),
            _ => Err(format!("expected `rk4` or `etdrk4`, got `{s}`")),
        }
    }
}

impl std::fmt::Display for Integrator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Integrator::Rk4 => "rk4",
            Integrator::Etdrk4 => "etdrk4",
        })
    }
}

/// A configuration of a plant ready to simulate.
#[derive(Debug, Clone)]
pub struct PlantModel {
    /// The generated kernels of the configuration.
    pub conf: &'static Configuration,
    /// Barycentric parameters (NP).
    pub p: Vec<f64>,
    /// Joint positions (NJ); locked joints keep these values.
    pub q_locked: Vec<f64>,
    /// Effects per free joint (NF).
    pub terms: Vec<JointTerms>,
    /// Tendon input couplings between free joints.
    pub couplings: Vec<InputCoupling>,
    /// The integration scheme of the simulations.
    pub integrator: Integrator,
}

/// Simulation state: positions and velocities of the free joints and LuGre deflections.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct State {
    /// q_F (rad or m).
    pub q: Vec<f64>,
    /// q̇_F (rad/s or m/s).
    pub qd: Vec<f64>,
    /// z_F (rad); zero where a joint has no LuGre term.
    pub z: Vec<f64>,
}

impl State {
    /// At rest at `q` with z = 0.
    pub fn at_rest(q: Vec<f64>) -> State {
        let n = q.len();
        State {
            q,
            qd: vec![0.0; n],
            z: vec![0.0; n],
        }
    }

    fn copy_from(&mut self, o: &State) {
        self.q.copy_from_slice(&o.q);
        self.qd.copy_from_slice(&o.qd);
        self.z.copy_from_slice(&o.z);
    }

    /// `out` = self + h·d, component-wise (all three of the same length).
    pub fn axpy_into(&self, h: f64, d: &State, out: &mut State) {
        let f = |o: &mut [f64], a: &[f64], b: &[f64]| {
            for i in 0..o.len() {
                o[i] = a[i] + h * b[i];
            }
        };
        f(&mut out.q, &self.q, &d.q);
        f(&mut out.qd, &self.qd, &d.qd);
        f(&mut out.z, &self.z, &d.z);
    }

    /// RK4's update self += c (k₀ + 2k₁ + 2k₂ + k₃), component-wise (c = h/6).
    #[inline(always)]
    fn add_rk4(&mut self, c: f64, k: &[State; 4]) {
        rk4_combine(&mut self.q, c, [&k[0].q, &k[1].q, &k[2].q, &k[3].q]);
        rk4_combine(&mut self.qd, c, [&k[0].qd, &k[1].qd, &k[2].qd, &k[3].qd]);
        rk4_combine(&mut self.z, c, [&k[0].z, &k[1].z, &k[2].z, &k[3].z]);
    }
}

/// RK4's combination y += c (k₀ + 2k₁ + 2k₂ + k₃), element by element (c = h/6): the
/// state's ([`State::add_rk4`]) and the sensitivities' tangent's.
#[inline(always)]
fn rk4_combine(y: &mut [f64], c: f64, [a, b, cc, d]: [&[f64]; 4]) {
    for ((y, a), ((b, cc), d)) in y.iter_mut().zip(a).zip(b.iter().zip(cc).zip(d)) {
        *y += c * (a + 2.0 * b + 2.0 * cc + d);
    }
}

/// The simulation left the valid region.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{}", self.message(&self.joint.to_string()))]
pub struct Divergence {
    /// Time of the first invalid state (s).
    pub t: f64,
    /// Free-joint index.
    pub joint: usize,
    /// What was found.
    pub what: String,
    /// The step used (s).
    pub h: f64,
    /// Smallest eigenvalue of the inertia matrix D_FF(q) (kg·m² or kg) at the state before
    /// the divergent step, when D_FF is not positive definite there: the
    /// rigid-body parameters are not physical in this configuration and no step helps.
    /// `None`: D_FF was positive definite (or the divergence is a speed bound).
    pub inertia_min_eigenvalue: Option<f64>,
    /// A user-defined effect that is not finite within the divergent step (at the positions
    /// the velocities before it reach). A smaller step does not help: the expression is not
    /// defined there.
    pub expression: Option<Box<UndefinedTerm>>,
}

/// A user-defined effect whose torque is not finite at a state ([`Divergence::expression`]).
#[derive(Debug, Clone, PartialEq)]
pub struct UndefinedTerm {
    /// The effect's name.
    pub name: String,
    /// The free joint it acts on (free index).
    pub joint: usize,
    /// Its value there (NaN or ±∞).
    pub value: f64,
    /// The free joints' positions (rad or m).
    pub q: Vec<f64>,
    /// The free joints' velocities (rad/s or m/s).
    pub qd: Vec<f64>,
}

/// [`PlantModel::simulate_from`] in pieces: the plant stepped by RK4 from one call to the
/// next with its work space kept (no allocation per call), for a loop that computes each
/// piece's input from the last one's end (a digital controller's sample).
#[derive(Debug, Clone)]
pub struct Stepper<'m> {
    model: &'m PlantModel,
    w: Scratch,
    prev: State,
}

impl Stepper<'_> {
    /// `steps` RK4 steps of `h` (s) of `x` (NF positions, velocities, friction states)
    /// from time `t0` (s), in place; `input(t, tau)` writes the commanded torques (NF,
    /// N·m or N) at each stage time, `observe(t, x)` sees the state after every step.
    ///
    /// # Errors
    /// As [`PlantModel::simulate`]; `x` then holds the last state stepped to.
    #[allow(clippy::too_many_arguments)]
    pub fn advance(
        &mut self,
        t0: f64,
        x: &mut State,
        h: f64,
        steps: usize,
        max_speed: f64,
        mut input: impl FnMut(f64, &mut [f64]),
        mut observe: impl FnMut(f64, &State),
    ) -> Result<(), Divergence> {
        let (m, w, prev) = (self.model, &mut self.w, &mut self.prev);
        for n in 0..steps {
            let t = t0 + n as f64 * h;
            w.time = [t, t + h / 2.0, t + h];
            input(t, &mut w.tau[0]);
            input(t + h / 2.0, &mut w.tau[1]);
            input(t + h, &mut w.tau[2]);
            prev.copy_from(x);
            m.step_in_place(x, h, w);
            let t1 = t0 + (n + 1) as f64 * h;
            m.check_step((prev, &w.tau[0]), x, t1, h, max_speed)?;
            observe(t1, x);
        }
        Ok(())
    }

    /// [`PlantModel::derivative_with_external`] into `out` (NF, with the stepper's work
    /// space: no allocation), for a caller that integrates the plant beside states of its
    /// own (a hand on a haptic wall).
    pub fn derivative_into(
        &mut self,
        t: f64,
        x: &State,
        tau: &[f64],
        q_ext: &[f64],
        out: &mut State,
    ) {
        self.model
            .derivative_into((t, x, tau), q_ext, &mut self.w, out);
    }
}

/// Scratch buffers of one simulation (no allocation per step).
#[derive(Debug, Clone)]
struct Scratch {
    q_full: Vec<f64>,
    /// The trigonometric table of `q_full` the kernels' `_trig` forms read (2·NJ: sin, cos
    /// of each joint in the configuration's `trig`): the locked joints' filled once, the
    /// free joints' with `q_full` ([`Scratch::put_free`]).
    sc: Vec<f64>,
    /// (free index a, joint k) of the free joints in the configuration's `trig`.
    trig_free: Vec<(usize, usize)>,
    /// Forward dynamics' loop invariants: its intermediates that depend only on the locked
    /// joints' positions and on p, computed once
    /// ([`generated::Configuration::forward_dynamics_invariants`]).
    inv: Vec<f64>,
    /// D_FF(q) (NF × NF, column-major) for the armatures.
    mass: Vec<f64>,
    tau_c: Vec<f64>,
    applied: Vec<f64>,
    k: [State; 4],
    stage: State,
    /// The rest of [`Integrator::Etdrk4`]'s work space.
    etd: EtdScratch,
    /// The state and stage inputs at the start of a step redone in substeps
    /// ([`PlantModel::etdrk4_with_switches`]).
    redo: (State, [Vec<f64>; 3], [Vec<f64>; 3]),
    tau: [Vec<f64>; 3],
    /// The times of the stage inputs `tau` (s): t, t + h/2, t + h of the step.
    time: [f64; 3],
    /// Output injection gains (L1, L2) and the measured positions at the stage times.
    injection: Option<(f64, f64)>,
    y: [Vec<f64>; 3],
    /// Side of qeq each joint's friction bias is locked to during a step (None: by q).
    sides: Vec<Option<bool>>,
    /// Fraction of the step at which each joint's bias switches (∞: it does not).
    crossing: Vec<f64>,
    /// The state at the start of a step being split at a bias switch.
    start: State,
    /// The run's stage inputs formed once ([`StageInputs::cached`]), and the index of the
    /// step being taken: [`Scratch::load`] reads a whole step's inputs from them.
    stages: Option<std::sync::Arc<StageInputs>>,
    step: usize,
}

impl Scratch {
    /// Write the free joints' positions `q_f` (NF) into `q_full`
    /// ([`PlantModel::put_free`]) and their sines and cosines into the table `sc`.
    fn put_free(&mut self, model: &PlantModel, q_f: &[f64]) {
        model.put_free(q_f, &mut self.q_full);
        for &(a, k) in &self.trig_free {
            let (s, c) = q_f[a].sin_cos();
            if let [sk, ck] = &mut self.sc[2 * k..2 * k + 2] {
                (*sk, *ck) = (s, c);
            }
        }
    }

    /// The stage inputs of a step of `hs` from `t0` (s): the commands `input` and the
    /// measured positions `measured` at t0, t0 + hs/2 and just before t0 + hs.
    fn load(&mut self, input: &InputSignal, measured: Option<&InputSignal>, t0: f64, hs: f64) {
        self.time = [t0, t0 + hs / 2.0, t0 + hs];
        let stored = self.stages.as_ref().and_then(|s| s.step(self.step, t0, hs));
        if let Some(v) = stored {
            for (tau, v) in self.tau.iter_mut().zip(v.chunks_exact(v.len() / 3)) {
                tau.copy_from_slice(v);
            }
        } else {
            let [a, b, c] = &mut self.tau;
            input.stage_inputs(t0, hs, [a.as_mut_slice(), b, c]);
        }
        if let Some(y) = measured {
            let [a, b, c] = &mut self.y;
            y.stage_inputs(t0, hs, [a.as_mut_slice(), b, c]);
        }
    }

    /// Every joint that reaches qeq at the switch fraction `first` (within rounding)
    /// switches its friction-bias side.
    fn switch_sides(&mut self, first: f64) {
        for (side, &c) in self.sides.iter_mut().zip(&self.crossing) {
            if c <= first + 1e-9 {
                *side = side.map(|below| !below);
            }
        }
    }

    /// The predictor's measured positions `observer` = (ω, y) as a signal on `input`'s
    /// samples, linearly interpolated, with the injection gains (2ω, ω²) set; None (and no
    /// injection) for ω = 0 or no observer ([`PlantModel::predict_at`]).
    fn observe<'y>(
        &mut self,
        observer: Option<(f64, &'y [Vec<f64>])>,
        input: &InputSignal,
    ) -> Option<InputSignal<'y>> {
        let (omega, y) = observer.filter(|(omega, _)| *omega > 0.0)?;
        self.injection = Some((2.0 * omega, omega * omega));
        Some(InputSignal {
            t0: input.t0,
            dt: input.dt,
            tau: y,
            hold: Hold::Linear,
        })
    }

    /// Adds the output injection L1 (y − q) to dq/dt and L2 (y − q) to dq̇/dt of `d`,
    /// the derivative at `x`, with y the measured positions at stage time `s`.
    fn inject(&self, x: &State, s: usize, d: &mut State) {
        if let Some((l1, l2)) = self.injection {
            for (i, &y) in self.y[s].iter().enumerate() {
                let e = y - x.q[i];
                d.q[i] += l1 * e;
                d.qd[i] += l2 * e;
            }
        }
    }

    fn new(model: &PlantModel) -> Scratch {
        let nf = model.nf();
        let z = || State::at_rest(vec![0.0; nf]);
        let conf = model.conf;
        let mut sc = vec![0.0; 2 * model.q_locked.len()];
        for &k in conf.trig {
            (sc[2 * k], sc[2 * k + 1]) = model.q_locked[k].sin_cos();
        }
        let trig_free = conf
            .free
            .iter()
            .enumerate()
            .filter(|(_, k)| conf.trig.contains(k))
            .map(|(a, &k)| (a, k))
            .collect();
        let mut inv = vec![0.0; conf.forward_dynamics_invariant_count];
        (conf.forward_dynamics_invariants)(&model.q_locked, &sc, &model.p, &mut inv);
        Scratch {
            q_full: model.q_locked.clone(),
            sc,
            trig_free,
            inv,
            mass: vec![0.0; nf * nf],
            tau_c: vec![0.0; nf],
            applied: vec![0.0; nf],
            k: [z(), z(), z(), z()],
            stage: z(),
            redo: (
                z(),
                [vec![0.0; nf], vec![0.0; nf], vec![0.0; nf]],
                [vec![0.0; nf], vec![0.0; nf], vec![0.0; nf]],
            ),
            etd: EtdScratch {
                u: std::array::from_fn(|_| vec![0.0; 3 * nf]),
                n: std::array::from_fn(|_| vec![0.0; 3 * nf]),
                t: vec![0.0; nf * nf],
                t_inv: vec![0.0; nf * nf],
                coef: vec![[0.0; 6]; 3 * nf],
                cross: vec![[0.0; 6]; nf],
                lambda: vec![0.0; 3 * nf],
                g: vec![0.0; nf],
                c: vec![0.0; nf],
                mass: vec![0.0; nf * nf],
                frozen_c: vec![f64::NAN; nf],
                frozen_mass: vec![f64::NAN; nf * nf],
                mu: vec![0.0; nf],
                d_inv_diag: vec![0.0; nf],
                coef_h: f64::NAN,
                work: vec![0.0; nf * nf],
            },
            tau: [vec![0.0; nf], vec![0.0; nf], vec![0.0; nf]],
            time: [0.0; 3],
            injection: None,
            y: [vec![0.0; nf], vec![0.0; nf], vec![0.0; nf]],
            sides: vec![None; nf],
            crossing: vec![f64::INFINITY; nf],
            start: z(),
            stages: None,
            step: 0,
        }
    }
}

/// States at the requested output times.
#[derive(Debug, Clone, PartialEq)]
pub struct Trajectory {
    /// Output times (s).
    pub t: Vec<f64>,
    /// Positions per free joint, `q[a][k]` (rad or m).
    pub q: Vec<Vec<f64>>,
    /// Velocities per free joint (rad/s or m/s).
    pub qd: Vec<Vec<f64>>,
    /// LuGre deflections per free joint (rad).
    pub z: Vec<Vec<f64>>,
}

impl Divergence {
    /// The report with the joint called `joint` (a name where the caller knows it).
    pub fn message(&self, joint: &str) -> String {
        if let Some(u) = &self.expression {
            let UndefinedTerm {
                name, value, q, qd, ..
            } = u.as_ref();
            let list = |v: &[f64]| {
                v.iter()
                    .map(|x| format!("{x:.6}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            };
            return format!(
                "simulation diverged at t = {:.6} s: the user-defined effect '{name}' is {value} \
                 within that step (free joints' q = [{}], q̇ = [{}]): its expression is not \
                 defined there (a root or logarithm of a negative number, a division by 0); a \
                 smaller step will not help",
                self.t,
                list(q),
                list(qd)
            );
        }
        match self.inertia_min_eigenvalue {
            Some(lambda) => format!(
                "simulation diverged at t = {:.6} s: joint {joint} has {}: the inertia matrix \
                 D(q) of the free joints is not positive definite before that step \
                 (smallest eigenvalue {lambda:.4e}), so q̈ = D⁻¹(…) does not exist: the \
                 rigid-body parameters are not physical in this configuration (`lockstep check` \
                 lists the links); a smaller step will not help",
                self.t, self.what
            ),
            None => format!(
                "simulation diverged at t = {:.6} s: joint {joint} has {} (step {} s)",
                self.t, self.what, self.h
            ),
        }
    }
}

impl PlantModel {
    /// Number of free joints.
    pub fn nf(&self) -> usize {
        self.terms.len()
    }

    /// Friction of free joint `i` at position `q`, velocity `v` and deflection `z`, and the
    /// bristle rate ż.
    pub fn friction(&self, i: usize, q: f64, v: f64, z: f64) -> (f64, f64) {
        self.friction_on_side(i, q, v, z, None)
    }

    /// [`PlantModel::friction`] with the side of the friction position bias given:
    /// `below = Some(b)` applies the bias factor when `b` whatever `q` (an integration step
    /// locked to one side of qeq, [`PlantModel::rk4_with_events`]); `None` decides by q < qeq.
    fn friction_on_side(
        &self,
        i: usize,
        q: f64,
        v: f64,
        z: f64,
        below: Option<bool>,
    ) -> (f64, f64) {
        let t = &self.terms[i];
        let mut f = t.viscous * v + t.coulomb * crate::effects::sign(v);
        if let Some(s) = &t.stribeck {
            f += s.force(v);
        }
        let mut zd = 0.0;
        if let Some(l) = &t.lugre {
            let (fl, d) = l.force(v, z);
            f += fl;
            zd = d;
        }
        (f * self.bias_factor(i, q, below), zd)
    }

    /// Commanded torques after the input couplings, τ'_i = τ_i + Σ G_{j→i} τ_j (NF).
    pub fn coupled_command(&self, tau: &[f64], out: &mut [f64]) {
        out.copy_from_slice(tau);
        for c in &self.couplings {
            out[c.to] += c.g * tau[c.from];
        }
    }

    /// Generalised forces on the rigid body, Q = Kp τ' − b F − Ks (q − qeq) − offset − the
    /// user-defined terms, and the LuGre bristle rates, at time `t` (s) for commanded torques
    /// `tau` (NF each).
    pub fn applied(&self, t: f64, x: &State, tau: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let nf = self.nf();
        let mut tc = vec![0.0; nf];
        let mut q_applied = vec![0.0; nf];
        let mut zd = vec![0.0; nf];
        self.applied_into((t, x, tau), &[], &mut tc, &mut q_applied, &mut zd);
        (q_applied, zd)
    }

    fn applied_into(
        &self,
        (time, x, tau): (f64, &State, &[f64]),
        sides: &[Option<bool>],
        tc: &mut [f64],
        out: &mut [f64],
        zd: &mut [f64],
    ) {
        self.coupled_command(tau, tc);
        for (i, t) in self.terms.iter().enumerate() {
            let side = sides.get(i).copied().flatten();
            let (f, d) = self.friction_on_side(i, x.q[i], x.qd[i], x.z[i], side);
            zd[i] = d;
            let spring = t.spring.map_or(0.0, |(ks, qeq)| ks * (x.q[i] - qeq));
            let extra: f64 = t
                .extra
                .iter()
                .map(|e| e.torque(time, &x.q, &x.qd, &x.z, tau))
                .sum();
            out[i] = t.gain * tc[i] - f - spring - t.offset - extra;
        }
    }

    /// Write the free joints' positions `q_f` (NF) into the all-joint vector `q_full`.
    fn put_free(&self, q_f: &[f64], q_full: &mut [f64]) {
        for (a, &k) in self.conf.free.iter().enumerate() {
            q_full[k] = q_f[a];
        }
    }

    fn derivative_into(
        &self,
        (t, x, tau): (f64, &State, &[f64]),
        q_ext: &[f64],
        w: &mut Scratch,
        out: &mut State,
    ) {
        w.put_free(self, &x.q);
        self.applied_into(
            (t, x, tau),
            &w.sides,
            &mut w.tau_c,
            &mut w.applied,
            &mut out.z,
        );
        for (q, e) in w.applied.iter_mut().zip(q_ext) {
            *q += e;
        }
        out.q.copy_from_slice(&x.qd);
        (self.conf.forward_dynamics_trig_inv)(
            &w.q_full,
            &w.sc,
            &x.qd,
            &w.applied,
            &self.p,
            &w.inv,
            &mut out.qd,
        );
        if self.adds_inertia() {
            self.with_added_inertia(w, (t, x, tau), &mut out.qd);
        }
    }

    /// Whether an armature or a user-defined term adds to the inertia matrix.
    fn adds_inertia(&self) -> bool {
        self.terms
            .iter()
            .any(|t| t.armature != 0.0 || t.extra.iter().any(|e| !e.inertia.is_empty()))
    }

    /// The inertia the effects add at time `t`, state `x` under commands `tau`, A (NF × NF,
    /// column-major), added into `mass`: each joint's armature on the diagonal, and each
    /// user-defined term's ∂u/∂q̈_k in its joint's row, column k.
    fn add_inertia(&self, (t, x, tau): (f64, &State, &[f64]), mass: &mut [f64]) {
        let nf = self.nf();
        for (i, terms) in self.terms.iter().enumerate() {
            mass[i * nf + i] += terms.armature;
            for e in &terms.extra {
                for (k, program, inputs) in &e.inertia {
                    mass[k * nf + i] += eval_term(program, inputs, t, (&x.q, &x.qd, &x.z, tau));
                }
            }
        }
    }

    /// The accelerations with the inertia the effects add: the generated kernel gives q̈₀ =
    /// D⁻¹ (Q − C q̇ − φ), so D q̈₀ is the right-hand side and q̈ = (D + A)⁻¹ D q̈₀ (`qdd`
    /// holds q̈₀ on entry; A of [`PlantModel::add_inertia`]). Where D + A is singular q̈₀ is
    /// left (the divergence check then names the inertia matrix).
    fn with_added_inertia(&self, w: &mut Scratch, at: (f64, &State, &[f64]), qdd: &mut [f64]) {
        let nf = self.nf();
        (self.conf.mass_matrix_trig)(&w.q_full, &w.sc, &self.p, &mut w.mass);
        let d = nalgebra::DMatrix::from_column_slice(nf, nf, &w.mass);
        let rhs = &d * nalgebra::DVector::from_column_slice(qdd);
        self.add_inertia(at, &mut w.mass);
        let with = nalgebra::DMatrix::from_column_slice(nf, nf, &w.mass);
        if let Some(v) = with.lu().solve(&rhs) {
            qdd.copy_from_slice(v.as_slice());
        }
    }

    /// D_FF(q) + A into `mass` (NF × NF, column-major) at the all-joint positions `q_full`
    /// and, at time `t`, the state `x` under commands `tau` (A of
    /// [`PlantModel::add_inertia`]): the inertia matrix the simulator integrates with.
    pub(crate) fn mass_matrix_into(
        &self,
        q_full: &[f64],
        at: (f64, &State, &[f64]),
        mass: &mut [f64],
    ) {
        (self.conf.mass_matrix)(q_full, &self.p, mass);
        self.add_inertia(at, mass);
    }

    /// dx/dt at time `t` (s; read only by user-defined effects that name `t`), state `x`
    /// under commanded torques `tau` (NF).
    pub fn derivative(&self, t: f64, x: &State, tau: &[f64]) -> State {
        self.derivative_with_external(t, x, tau, &[])
    }

    /// dx/dt at time `t`, state `x` under commanded torques `tau` (NF) and an external
    /// generalised force `q_ext` (NF, N·m or N; empty for none) added to the applied torques
    /// Q: a hand holding the end point, a contact. The plant gain does not act on `q_ext`.
    pub fn derivative_with_external(&self, t: f64, x: &State, tau: &[f64], q_ext: &[f64]) -> State {
        let mut w = Scratch::new(self);
        let mut out = State::at_rest(vec![0.0; self.nf()]);
        self.derivative_into((t, x, tau), q_ext, &mut w, &mut out);
        out
    }

    /// One step of the model's [`Integrator`] on `x` with the stage torques in `w.tau` (at
    /// the times `w.time`: t, t + h/2, t + h).
    fn step_in_place(&self, x: &mut State, h: f64, w: &mut Scratch) {
        match self.integrator {
            Integrator::Rk4 => self.rk4_in_place(x, h, w),
            Integrator::Etdrk4 => self.etdrk4_with_switches(x, h, w),
        }
    }

    /// RK4 on `x` with the stage torques in `w.tau` (at t, t + h/2, t + h).
    fn rk4_in_place(&self, x: &mut State, h: f64, w: &mut Scratch) {
        let mut k = std::mem::take(&mut w.k);
        let mut stage = std::mem::take(&mut w.stage);
        let tau = std::mem::take(&mut w.tau);
        let time = w.time;
        self.derivative_into((time[0], x, &tau[0]), &[], w, &mut k[0]);
        w.inject(x, 0, &mut k[0]);
        x.axpy_into(h / 2.0, &k[0], &mut stage);
        self.derivative_into((time[1], &stage, &tau[1]), &[], w, &mut k[1]);
        w.inject(&stage, 1, &mut k[1]);
        x.axpy_into(h / 2.0, &k[1], &mut stage);
        self.derivative_into((time[1], &stage, &tau[1]), &[], w, &mut k[2]);
        w.inject(&stage, 1, &mut k[2]);
        x.axpy_into(h, &k[2], &mut stage);
        self.derivative_into((time[2], &stage, &tau[2]), &[], w, &mut k[3]);
        w.inject(&stage, 2, &mut k[3]);
        x.add_rk4(h / 6.0, &k);
        w.k = k;
        w.stage = stage;
        w.tau = tau;
    }

    /// One RK4 step of `h` from time `t` with the stage inputs (and measured positions of
    /// the predictor) taken from the signals, split where a joint's friction position bias
    /// switches (q crosses qeq, thesis 4.3.5).
    ///
    /// The bias multiplies the friction by a factor on one side of qeq: a jump of the right-hand
    /// side. An RK4 step across it loses its order, and worse for identification, its result
    /// jumps as a parameter moves a stage point across qeq: the simulated positions are then
    /// not a differentiable function of the parameters, and finite-difference Jacobians are
    /// wrong by orders of magnitude (on the Freedom 6S's joint 2 the cost's slopes from steps
    /// of 1e-6 and 1e-9 of the bounds differed ten-fold). So every step runs with each
    /// joint's side locked to where it starts; if a joint ends on the other side, the crossing
    /// fraction θ is found on the step's cubic Hermite interpolant (q, q̇ at both ends), the
    /// step is redone to θ h, the joint's side flips, and the rest of the step follows (at
    /// most 8 switches per step, then the rest is taken as is).
    fn rk4_with_events(
        &self,
        x: &mut State,
        t: f64,
        h: f64,
        input: &InputSignal,
        measured: Option<&InputSignal>,
        w: &mut Scratch,
    ) {
        let (mut t0, mut rest) = (t, h);
        if self.lock_sides(x, w) {
            let mut start = std::mem::take(&mut w.start);
            for _ in 0..8 {
                start.copy_from(x);
                w.load(input, measured, t0, rest);
                self.step_in_place(x, rest, w);
                let Some((first, _)) = self.crossings(&start, x, rest, w) else {
                    w.start = start;
                    return;
                };
                x.copy_from(&start);
                let hs = first * rest;
                if hs > 1e-12 * h {
                    w.load(input, measured, t0, hs);
                    self.step_in_place(x, hs, w);
                }
                w.switch_sides(first);
                t0 += hs;
                rest -= hs;
                if rest <= 1e-12 * h {
                    w.start = start;
                    return;
                }
            }
            w.start = start;
        }
        w.load(input, measured, t0, rest);
        self.step_in_place(x, rest, w);
    }

    /// Locks each joint's friction-bias side to where `x` is ([`Scratch::sides`]); whether
    /// any joint has a bias.
    fn lock_sides(&self, x: &State, w: &mut Scratch) -> bool {
        let mut any = false;
        for (i, term) in self.terms.iter().enumerate() {
            w.sides[i] = term.bias.map(|(_, qeq)| x.q[i] < qeq);
            any |= w.sides[i].is_some();
        }
        any
    }

    /// The switch fraction of every joint that a step of `rest` from `start` to `x` took
    /// across its qeq, into [`Scratch::crossing`] (∞ for the others), and the first of them
    /// with its joint; None when no joint switched.
    fn crossings(
        &self,
        start: &State,
        x: &State,
        rest: f64,
        w: &mut Scratch,
    ) -> Option<(f64, usize)> {
        let mut first: Option<(f64, usize)> = None;
        for (i, term) in self.terms.iter().enumerate() {
            w.crossing[i] = f64::INFINITY;
            if let (Some(below), Some((_, qeq))) = (w.sides[i], term.bias) {
                if (x.q[i] < qeq) != below {
                    w.crossing[i] = hermite_crossing(start, x, i, rest, qeq);
                    if first.is_none_or(|(f, _)| w.crossing[i] < f) {
                        first = Some((w.crossing[i], i));
                    }
                }
            }
        }
        first
    }

    fn check(&self, x: &State, t: f64, h: f64, max_speed: f64) -> Result<(), Divergence> {
        for i in 0..self.nf() {
            let what = if !(x.q[i].is_finite() && x.qd[i].is_finite() && x.z[i].is_finite()) {
                "a non-finite state".to_string()
            } else if x.qd[i].abs() > max_speed {
                format!("speed {:.4e} beyond {max_speed:.4e}", x.qd[i])
            } else {
                continue;
            };
            return Err(Divergence {
                t,
                joint: i,
                what,
                h,
                inertia_min_eigenvalue: None,
                expression: None,
            });
        }
        Ok(())
    }

    /// The inertia matrix D_FF(q) of the free joints at free-joint positions `q_f` (NF; the
    /// locked joints at [`PlantModel::q_locked`]), with the inertia the effects add (the
    /// armatures; user-defined terms at rest, without command), NF × NF (kg·m² or kg).
    pub fn inertia_matrix(&self, q_f: &[f64]) -> nalgebra::DMatrix<f64> {
        let nf = self.nf();
        let mut q_full = self.q_locked.clone();
        self.put_free(q_f, &mut q_full);
        let mut d = vec![0.0; nf * nf];
        let at_rest = State::at_rest(q_f.to_vec());
        self.mass_matrix_into(&q_full, (0.0, &at_rest, &vec![0.0; nf]), &mut d);
        nalgebra::DMatrix::from_vec(nf, nf, d)
    }

    /// [`PlantModel::check`] after a step from `last`; a divergence is traced to an inertia
    /// matrix that is not positive definite at `last` where it is one.
    fn check_step(
        &self,
        (last, tau): (&State, &[f64]),
        x: &State,
        t: f64,
        h: f64,
        max_speed: f64,
    ) -> Result<(), Divergence> {
        self.check(x, t, h, max_speed).map_err(|mut d| {
            // A user-defined term not finite within the step (at the positions the last
            // state's velocities reach over 0, h/2 and h, with the step's first command) is
            // the cause, whatever the step.
            if last.q.iter().all(|v| v.is_finite()) && last.qd.iter().all(|v| v.is_finite()) {
                d.expression = [0.0, 0.5, 1.0].iter().find_map(|&s| {
                    let q: Vec<f64> = last
                        .q
                        .iter()
                        .zip(&last.qd)
                        .map(|(q, qd)| q + s * h * qd)
                        .collect();
                    self.terms.iter().enumerate().find_map(|(i, terms)| {
                        terms.extra.iter().find_map(|e| {
                            let v = e.torque(t - h + s * h, &q, &last.qd, &last.z, tau);
                            (!v.is_finite()).then(|| {
                                Box::new(UndefinedTerm {
                                    name: e.name.clone(),
                                    joint: i,
                                    value: v,
                                    q: q.clone(),
                                    qd: last.qd.clone(),
                                })
                            })
                        })
                    })
                });
            }
            if last.q.iter().all(|v| v.is_finite()) {
                let lambda = self.inertia_matrix(&last.q).symmetric_eigenvalues().min();
                if lambda <= 0.0 || lambda.is_nan() {
                    d.inertia_min_eigenvalue = Some(lambda);
                }
            }
            d
        })
    }

    /// Simulate `steps` RK4 steps of `h` from `x0` at t = 0; `input(t, tau)` writes the
    /// commanded torques (NF) at time t (called at each RK4 stage time). Calls
    /// `observe(t, x)` after every step.
    ///
    /// # Errors
    /// [`Divergence`] at the first non-finite state or velocity beyond `max_speed`, naming
    /// the time and joint.
    pub fn simulate(
        &self,
        x0: State,
        h: f64,
        steps: usize,
        max_speed: f64,
        input: impl FnMut(f64, &mut [f64]),
        observe: impl FnMut(f64, &State),
    ) -> Result<State, Divergence> {
        self.simulate_from(0.0, x0, h, steps, max_speed, input, observe)
    }

    /// [`PlantModel::simulate`] from `x0` at time `t0` (s): the times given to `input`,
    /// `observe` and the user-defined effects run from `t0`.
    ///
    /// # Errors
    /// As [`PlantModel::simulate`].
    #[allow(clippy::too_many_arguments)]
    pub fn simulate_from(
        &self,
        t0: f64,
        x0: State,
        h: f64,
        steps: usize,
        max_speed: f64,
        input: impl FnMut(f64, &mut [f64]),
        observe: impl FnMut(f64, &State),
    ) -> Result<State, Divergence> {
        let mut x = x0;
        self.stepper()
            .advance(t0, &mut x, h, steps, max_speed, input, observe)?;
        Ok(x)
    }

    /// A simulation to be run in pieces ([`Stepper::advance`]), its work space allocated
    /// once: a closed loop steps the plant one controller sample at a time.
    pub fn stepper(&self) -> Stepper<'_> {
        Stepper {
            model: self,
            w: Scratch::new(self),
            prev: State::at_rest(vec![0.0; self.nf()]),
        }
    }

    /// Simulate from `x0` at `times[0]` to `times[last]` with RK4 steps of (at most) `h`
    /// under the sampled `input`, and return the state at every time of `times` (strictly
    /// increasing). Between steps, q is interpolated by cubic Hermite (from q and q̇ at both
    /// ends, error O(h⁴)), q̇ and z linearly; a step that lands on an output time (within
    /// 1e-9 h) gives it exactly. A joint with backlash ([`JointTerms::backlash`]) returns
    /// the sensed position, the play operator run over every step's end and output time
    /// (y(t₀) = q(t₀)), and the sensed velocity (q̇ while the drive pushes the sensor, 0
    /// while the gap is crossed).
    ///
    /// # Errors
    /// [`Divergence`] as in [`PlantModel::simulate`].
    pub fn simulate_at(
        &self,
        x0: State,
        h: f64,
        input: &InputSignal,
        times: &[f64],
        max_speed: f64,
    ) -> Result<Trajectory, Divergence> {
        self.predict_at(x0, h, input, None, times, max_speed)
    }

    /// [`PlantModel::simulate_at`] with the state pulled toward measured positions: the
    /// predictor (Luenberger observer with output injection)
    ///
    ///   dq/dt = q̇ + 2ω (y − q),   dq̇/dt = q̈(q, q̇, z, τ) + ω² (y − q),
    ///
    /// y(t) the measured positions of the free joints, interpolated linearly between their
    /// samples (`observer.1`: NF columns at the input's t0 and dt). For a model equal to the
    /// plant the prediction error e = y − q obeys ë + 2ω ė + ω² e = 0 (poles at −ω, critically
    /// damped); a model error Δq̈ leaves e ≈ Δq̈ / ω² below ω rad/s: an equation error
    /// low-passed at ω, with no differentiated data, and ω → 0 is the simulation error. The
    /// one-step predictor of a prediction-error method with a disturbance model (Ljung,
    /// *System Identification*, 7.2), with a fixed gain. `observer = None` or ω = 0:
    /// [`PlantModel::simulate_at`].
    ///
    /// # Errors
    /// [`Divergence`] as in [`PlantModel::simulate`].
    pub fn predict_at(
        &self,
        x0: State,
        h: f64,
        input: &InputSignal,
        observer: Option<(f64, &[Vec<f64>])>,
        times: &[f64],
        max_speed: f64,
    ) -> Result<Trajectory, Divergence> {
        let nf = self.nf();
        let mut out = Trajectory {
            t: times.to_vec(),
            q: vec![Vec::with_capacity(times.len()); nf],
            qd: vec![Vec::with_capacity(times.len()); nf],
            z: vec![Vec::with_capacity(times.len()); nf],
        };
        let Some(&t_start) = times.first() else {
            return Ok(out);
        };
        let t_end = *times.last().unwrap_or(&t_start);
        let steps = ((t_end - t_start) / h - 1e-9).ceil().max(0.0) as usize;
        let mut w = Scratch::new(self);
        w.stages = StageInputs::cached(input, (t_start, t_end), h, steps);
        let measured = w.observe(observer, input);
        // The sensed positions behind each joint's backlash (the play operator's state),
        // centred on the drive at the start.
        let gaps: Vec<f64> = self.terms.iter().map(|t| t.backlash).collect();
        let mut sensed = x0.q.clone();
        let mut x = x0;
        let mut prev = x.clone();
        let mut next_out = 0;
        let push = |out: &mut Trajectory,
                    sensed: &mut [f64],
                    a: &State,
                    b: &State,
                    (ta, tb, t): (f64, f64, f64)| {
            let hh = tb - ta;
            let s = step_fraction(ta, tb, t);
            let [h00, h10, h01, h11] = hermite_weights(s);
            for i in 0..nf {
                let q = h00 * a.q[i] + h10 * hh * a.qd[i] + h01 * b.q[i] + h11 * hh * b.qd[i];
                let qd = a.qd[i] + s * (b.qd[i] - a.qd[i]);
                if gaps[i] > 0.0 {
                    // The play operator: the sensor moves only when the drive pushes it.
                    let y = sensed[i].max(q - gaps[i]).min(q + gaps[i]);
                    let engaged = y != sensed[i];
                    sensed[i] = y;
                    out.q[i].push(y);
                    out.qd[i].push(if engaged { qd } else { 0.0 });
                } else {
                    out.q[i].push(q);
                    out.qd[i].push(qd);
                }
                out.z[i].push(a.z[i] + s * (b.z[i] - a.z[i]));
            }
        };
        // Output times at the start.
        while next_out < times.len() && times[next_out] <= t_start + 1e-9 * h {
            push(&mut out, &mut sensed, &x, &x, (t_start, t_start, t_start));
            next_out += 1;
        }
        for n in 0..steps {
            let (t, t1, hs) = step_span(t_start, t_end, h, n);
            w.step = n;
            prev.copy_from(&x);
            self.rk4_with_events(&mut x, t, hs, input, measured.as_ref(), &mut w);
            self.check_step((&prev, &w.tau[0]), &x, t1, h, max_speed)?;
            while next_out < times.len() && times[next_out] <= t1 + 1e-9 * h {
                push(&mut out, &mut sensed, &prev, &x, (t, t1, times[next_out]));
                next_out += 1;
            }
            for i in 0..nf {
                if gaps[i] > 0.0 {
                    sensed[i] = sensed[i].max(x.q[i] - gaps[i]).min(x.q[i] + gaps[i]);
                }
            }
        }
        Ok(out)
    }
}

/// The cubic Hermite basis at s ∈ [0, 1]: (h00, h10, h01, h11), the weights of q(0),
/// h q̇(0), q(1), h q̇(1).
pub(crate) fn hermite_weights(s: f64) -> [f64; 4] {
    [
        2.0 * s * s * s - 3.0 * s * s + 1.0,
        s * s * s - 2.0 * s * s + s,
        -2.0 * s * s * s + 3.0 * s * s,
        s * s * s - s * s,
    ]
}

/// d/ds of [`hermite_weights`].
pub(crate) fn hermite_slopes(s: f64) -> [f64; 4] {
    let s2 = s * s;
    [
        6.0 * s2 - 6.0 * s,
        3.0 * s2 - 4.0 * s + 1.0,
        -6.0 * s2 + 6.0 * s,
        3.0 * s2 - 2.0 * s,
    ]
}

/// Where output time `t` lies in the step from `ta` to `tb`: its fraction s ∈ [0, 1] (1 for
/// a step of no length).
pub(crate) fn step_fraction(ta: f64, tb: f64, t: f64) -> f64 {
    let hh = tb - ta;
    if hh > 0.0 {
        ((t - ta) / hh).clamp(0.0, 1.0)
    } else {
        1.0
    }
}

/// Fraction θ ∈ [0, 1] of a step of length `h` from `a` to `b` at which joint `i` reaches
/// `qeq`, on the cubic Hermite interpolant of its position (q and q̇ at both ends); the ends
/// lie on opposite sides of `qeq`. Bisection to 1e-12 on the bracket, which the interpolant
/// keeps because its values at the ends are the ends' positions.
fn hermite_crossing(a: &State, b: &State, i: usize, h: f64, qeq: f64) -> f64 {
    let (q0, q1, m0, m1) = (a.q[i], b.q[i], h * a.qd[i], h * b.qd[i]);
    let f = |s: f64| {
        let [h00, h10, h01, h11] = hermite_weights(s);
        h00 * q0 + h10 * m0 + h01 * q1 + h11 * m1 - qeq
    };
    let (mut lo, mut hi) = (0.0, 1.0);
    let below_at_lo = f(0.0) < 0.0;
    while hi - lo > 1e-12 {
        let mid = 0.5 * (lo + hi);
        if (f(mid) < 0.0) == below_at_lo {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}
