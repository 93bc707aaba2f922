//! Structure outside the catalogue (issue 54 item 3): when what is missing is no catalogued
//! effect, the residual still says what it is. A sparse regression of a joint's torque
//! residual onto a library of candidate functions — polynomials in q and q̇ up to degree 3,
//! q̇|q̇|, sign(q̇), |τ| sign(q̇), sin and cos of k·q (k = 1…6), the other free joints' q̇ and τ; the
//! catalogue's own signatures (1, q, q̇, sign q̇, τ of another joint) only complete a model,
//! they do not lead one — as in
//! SINDy (Brunton, Proctor and Kutz, PNAS 113 (2016) 3932–3937), the support chosen by
//! stepwise regression (Efroymson 1960: forward additions and backward removals) on the
//! Bayesian information criterion over the residual's effective number of independent
//! samples ([`super::effective_samples`]). SINDy's sequentially thresholded least squares
//! fails on this library: q, q³ and sin(kq) are nearly collinear over a joint's range, the
//! full least squares gives cancelling coefficients of 1e4 that no threshold removes (a
//! cubic in q came back as 16 terms, measured).
//!
//! Each library function is an expression ([`crate::expression`]) of the joint's states, so
//! the terms found are a ready user-defined effect: `Σ c_k · term_k`, its coefficients
//! parameters ([`Structure::effect`]).
//!
//! The residual regressed is a torque residual: in torque space the inverse model's; in
//! output space the equation error of the measured positions
//! ([`crate::identify::equation_error`]: filtered, differentiated), whose terms the
//! output-space diagnosis then confirms by an output-error fit of their coefficients.

use crate::expression::{Expression, Program, Symbol};
use nalgebra::{DMatrix, DVector};

/// Largest harmonic k of the sin(k q), cos(k q) terms.
pub const HARMONICS: usize = 6;

/// One library function of a joint.
#[derive(Debug, Clone)]
pub struct LibraryTerm {
    /// As written in an expression, e.g. `q3^3`, `qd3*abs(qd3)`, `sin(6*q3)`.
    pub text: String,
    /// The signature of a catalogued effect (1: offset, q: spring, q̇: viscous, sign(q̇):
    /// Coulomb, another joint's τ: input coupling): it completes a model (the polynomial
    /// hierarchy) but does not lead one — structure the catalogue lacks is the other
    /// terms.
    pub catalogued: bool,
    /// Compiled.
    program: Program,
}

impl LibraryTerm {
    /// The term's value at the states of the free joints `free` (model indices; `q`,
    /// `qd`, `tau` NF each).
    pub fn value(&self, free: &[usize], q: &[f64], qd: &[f64], tau: &[f64]) -> f64 {
        let at = |k: usize| free.iter().position(|&f| f == k).unwrap_or(0);
        self.program.eval_at(|s| match s {
            Symbol::Q(k) => q[at(k)],
            Symbol::Qd(k) => qd[at(k)],
            Symbol::Tau(k) => tau[at(k)],
            _ => 0.0,
        })
    }
}

/// The library of joint `j` (model index) among the free joints `free`, for a model of
/// `joints` joints: its own 1, q, q², q³, q̇, q̇|q̇|, q̇³, sign(q̇), |τ| sign(q̇), sin(kq),
/// cos(kq) (k = 1…[`HARMONICS`]) and the other free joints' q̇ and τ.
pub fn library(j: usize, free: &[usize], joints: &[&str]) -> Vec<LibraryTerm> {
    let mut texts: Vec<String> = vec![
        "1".into(),
        format!("q{j}"),
        format!("q{j}^2"),
        format!("q{j}^3"),
        format!("qd{j}"),
        format!("qd{j}*abs(qd{j})"),
        format!("qd{j}^3"),
        format!("sign(qd{j})"),
        format!("abs(tau{j})*sign(qd{j})"),
    ];
    for k in 1..=HARMONICS {
        let arg = if k == 1 {
            format!("q{j}")
        } else {
            format!("{k}*q{j}")
        };
        texts.push(format!("sin({arg})"));
        texts.push(format!("cos({arg})"));
    }
    for &b in free.iter().filter(|&&b| b != j) {
        texts.push(format!("qd{b}"));
        texts.push(format!("tau{b}"));
    }
    let catalogued: Vec<String> = vec![
        "1".into(),
        format!("q{j}"),
        format!("qd{j}"),
        format!("sign(qd{j})"),
    ];
    texts
        .into_iter()
        .filter_map(|text| {
            let e = Expression::parse(&text, joints, &[]).ok()?;
            let program = Program::compile(&e.root, &|_| None).ok()?;
            Some(LibraryTerm {
                catalogued: catalogued.contains(&text) || text.starts_with("tau"),
                text,
                program,
            })
        })
        .collect()
}

/// A built-in effect recognised among a joint's library terms (issue 54 item 2): physics
/// with a name and a signature, written as a user-defined effect when found. Each is
/// spanned by library terms, so the structure search's columns fit it at no extra cost; the
/// output-space diagnosis confirms the leading one by an output-error fit of its own
/// parameters. (Backlash needs a state of the transmission, and armature inertia and a
/// coupled motor's inertia a term of the inertia matrix: neither is a function of the
/// joints' states, so neither is here.)
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Named {
    /// τ = K3 (q − qc)³: a hardening (K3 > 0) or softening spring beyond its linear range
    /// (a cable, a flexure); signature: a residual cubic in position, odd about qc.
    CubicStiffness,
    /// τ = A sin(k q) + B cos(k q), k per turn: cogging of a motor's magnets or a gear's
    /// ripple, amplitude √(A² + B²); signature: a residual periodic in position.
    Cogging(usize),
    /// τ = c q̇|q̇|: aerodynamic or fluid drag; signature: a residual growing with the square
    /// of the speed, odd in q̇.
    QuadraticDrag,
    /// τ = μ |τ| sign(q̇): Coulomb friction growing with the transmitted torque (a gear
    /// mesh, bearings under load); signature: a step at q̇ = 0 whose height follows |τ|.
    LoadFriction,
}

impl Named {
    /// Every built-in: the cubic stiffness, the drag, the load-dependent friction and the
    /// cogging of each harmonic 1…[`HARMONICS`].
    pub fn all() -> Vec<Named> {
        let mut v = vec![
            Named::CubicStiffness,
            Named::QuadraticDrag,
            Named::LoadFriction,
        ];
        v.extend((1..=HARMONICS).map(Named::Cogging));
        v
    }

    /// The finding's name: `cubic stiffness`, `cogging (6 per turn)`, ….
    pub fn name(&self) -> String {
        match self {
            Named::CubicStiffness => "cubic stiffness".into(),
            Named::Cogging(k) => format!("cogging ({k} per turn)"),
            Named::QuadraticDrag => "quadratic drag".into(),
            Named::LoadFriction => "load-dependent friction".into(),
        }
    }

    /// One line of physics.
    pub fn meaning(&self) -> &'static str {
        match self {
            Named::CubicStiffness => "a spring beyond its linear range: K3 (q - qc)^3, hardening for K3 > 0 (a cable, a flexure)",
            Named::Cogging(_) => "a torque periodic in position, A sin(kq) + B cos(kq): cogging of the motor's magnets, a gear's ripple",
            Named::QuadraticDrag => "drag growing with the square of the speed, c qd|qd|: aerodynamic or fluid drag",
            Named::LoadFriction => "Coulomb friction growing with the transmitted torque, mu |tau| sign(qd): a gear mesh, bearings under load",
        }
    }

    /// The library terms of joint `j` that span it.
    pub fn terms(&self, j: usize) -> Vec<String> {
        match self {
            Named::CubicStiffness => vec![
                format!("q{j}^3"),
                format!("q{j}^2"),
                format!("q{j}"),
                "1".into(),
            ],
            Named::Cogging(k) => {
                let arg = if *k == 1 {
                    format!("q{j}")
                } else {
                    format!("{k}*q{j}")
                };
                vec![format!("sin({arg})"), format!("cos({arg})")]
            }
            Named::QuadraticDrag => vec![format!("qd{j}*abs(qd{j})")],
            Named::LoadFriction => vec![format!("abs(tau{j})*sign(qd{j})")],
        }
    }

    /// The user-defined effect on joint `j` (of the model's joints `joints`) whose terms' least-squares
    /// coefficients are `c` (same order as [`Named::terms`]): its name, torque, parameters,
    /// their values and bounds (±10 times each value's size about it, the cogging's both
    /// ±10 times its amplitude; the cubic's centre qc = −c₂/(3 c₃), within ±10 rad, ±1 rad
    /// about it). `fixed_centre`: the cubic's qc
    /// written as a number (one parameter, linear: torque space). None when the cubic has
    /// no cubic coefficient.
    pub fn effect(
        &self,
        j: usize,
        joints: &[&str],
        c: &[f64],
        fixed_centre: bool,
    ) -> Option<NamedEffect> {
        let joint = *joints.get(j)?;
        let (key, torque, parameters, values) = match self {
            Named::CubicStiffness => {
                let (a3, a2) = (*c.first()?, *c.get(1)?);
                if a3 == 0.0 || !a3.is_finite() {
                    return None;
                }
                let qc = (-a2 / (3.0 * a3)).clamp(-10.0, 10.0);
                if fixed_centre {
                    (
                        "cubic_stiffness",
                        format!("K3_{joint}*(q{j} - ({qc:e}))^3"),
                        vec![format!("K3_{joint}")],
                        vec![a3],
                    )
                } else {
                    (
                        "cubic_stiffness",
                        format!("K3_{joint}*(q{j} - qc_{joint})^3"),
                        vec![format!("K3_{joint}"), format!("qc_{joint}")],
                        vec![a3, qc],
                    )
                }
            }
            Named::Cogging(_) => {
                let [s, co]: [String; 2] = self.terms(j).try_into().ok()?;
                (
                    "cogging",
                    format!("Acog_{joint}*{s} + Bcog_{joint}*{co}"),
                    vec![format!("Acog_{joint}"), format!("Bcog_{joint}")],
                    vec![*c.first()?, *c.get(1)?],
                )
            }
            Named::QuadraticDrag => (
                "quadratic_drag",
                format!("cd_{joint}*qd{j}*abs(qd{j})"),
                vec![format!("cd_{joint}")],
                vec![*c.first()?],
            ),
            Named::LoadFriction => (
                "load_friction",
                format!("mu_{joint}*abs(tau{j})*sign(qd{j})"),
                vec![format!("mu_{joint}")],
                vec![*c.first()?],
            ),
        };
        // The cogging's two coefficients share one scale, its amplitude (a phase near 0
        // leaves B near 0, which must stay free).
        let amplitude = values.iter().map(|v| v * v).sum::<f64>().sqrt();
        let bounds = parameters
            .iter()
            .zip(&values)
            .map(|(p, &v)| {
                if p.starts_with("qc_") {
                    (v - 1.0, v + 1.0)
                } else if matches!(self, Named::Cogging(_)) {
                    (-10.0 * amplitude, 10.0 * amplitude)
                } else {
                    super::bounds_about(v, 1e-12)
                }
            })
            .collect();
        Some(NamedEffect {
            name: format!("{key}_{joint}"),
            torque: crate::names::expression_text(&torque, joints),
            parameters,
            values,
            bounds,
        })
    }
}

/// A [`Named`] built-in written as a user-defined effect.
#[derive(Debug, Clone)]
pub struct NamedEffect {
    /// Effect name, e.g. `cogging_q3`.
    pub name: String,
    /// Torque expression.
    pub torque: String,
    /// Parameter names.
    pub parameters: Vec<String>,
    /// Their values (SI).
    pub values: Vec<f64>,
    /// Their bounds.
    pub bounds: Vec<(f64, f64)>,
}

/// The built-ins of joint `j` the columns `columns` (one per library term `texts`) span,
/// each fitted by least squares to the residual `r`: (built-in, coefficients of its terms,
/// SSE), the cogging only at its best harmonic, best (lowest SSE) first. A harmonic k is
/// offered only where the joint's motion spans a period of it (k · `span` ≥ 2π, `span` the
/// range of q): over less, sin(kq) and cos(kq) are a polynomial in q (a prismatic axis's
/// 0.2 m of motion made "cogging (6 per turn)" a spring and an offset, measured on EMPS).
pub fn named_fits(
    j: usize,
    r: &[f64],
    columns: &[Vec<f64>],
    texts: &[String],
    span: f64,
) -> Vec<(Named, Vec<f64>, f64)> {
    let mut out: Vec<(Named, Vec<f64>, f64)> = Vec::new();
    for named in Named::all() {
        if let Named::Cogging(k) = named {
            if (k as f64) * span < std::f64::consts::TAU {
                continue;
            }
        }
        let idx: Option<Vec<usize>> = named
            .terms(j)
            .iter()
            .map(|t| texts.iter().position(|x| x == t))
            .collect();
        let Some(idx) = idx else { continue };
        let cols: Vec<Vec<f64>> = idx.iter().map(|&i| columns[i].clone()).collect();
        let Some((x, sse)) = super::fit(&cols, r) else {
            continue;
        };
        if let (Named::Cogging(_), Some(k)) = (
            named,
            out.iter()
                .position(|(n, _, _)| matches!(n, Named::Cogging(_))),
        ) {
            if sse < out[k].2 {
                out[k] = (named, x, sse);
            }
            continue;
        }
        out.push((named, x, sse));
    }
    out.sort_by(|a, b| a.2.total_cmp(&b.2));
    out
}

/// One term of a sparse model.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Term {
    /// The library function, e.g. `q3^3`.
    pub text: String,
    /// Its coefficient (torque units per unit of the function).
    pub coefficient: f64,
    /// The share of the residual's energy the model loses without it (drop-one).
    pub share: f64,
}

/// The sparse model of one joint's torque residual.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Structure {
    /// Model index of the joint.
    pub joint: usize,
    /// The terms, largest share first.
    pub terms: Vec<Term>,
    /// Share of the residual energy the terms explain together, 1 − SSE/SST.
    pub explained: f64,
    /// ΔBIC against nothing, over the effective samples.
    pub delta_bic: f64,
    /// The effective number of independent samples of what the whole library leaves.
    pub effective_samples: f64,
}

/// The one line of physics of a structure finding.
pub const MEANING: &str = "the residual has structure the catalogue lacks: a sparse regression of it onto a library of functions of the joints' states (polynomials, q̇|q̇|, sign, |τ| sign(q̇), harmonics of q, the other joints' q̇ and τ), written as a user-defined effect";

/// A name `structure_J` and a parameter prefix `s_J` for a structure on joint `j` (named
/// J) that `plant` does not use yet (`structure_J_2`, `s_Jv2`, … when it does).
pub fn free_names(plant: &crate::plant::Plant, j: usize) -> (String, String) {
    let joint = plant.model.joints[j];
    let taken = plant.known_names();
    let mut prefix = format!("s_{joint}");
    let mut name = format!("structure_{joint}");
    let mut k = 2;
    while plant.expressions.iter().any(|x| x.name == name)
        || taken.iter().any(|t| t.starts_with(&format!("{prefix}_")))
    {
        prefix = format!("s_{joint}v{k}");
        name = format!("structure_{joint}_{k}");
        k += 1;
    }
    (name, prefix)
}

impl Structure {
    /// The finding's name: `structure: q3^3 + q3^2 + …`.
    pub fn name(&self) -> String {
        format!(
            "structure: {}",
            self.terms
                .iter()
                .map(|t| t.text.as_str())
                .collect::<Vec<_>>()
                .join(" + ")
        )
    }

    /// Whether the model passes the significance rule ([`super::significant`]).
    pub fn significant(&self) -> bool {
        super::significant(self.delta_bic, self.explained)
    }

    /// The terms as one line, e.g. `2.0e-2·q3^3 − 6.0e-3·q3^2 (97 %, 2 %)`.
    pub fn text(&self) -> String {
        self.terms
            .iter()
            .map(|t| {
                format!(
                    "{:+.3e}*{} ({:.0} %)",
                    t.coefficient,
                    t.text,
                    100.0 * t.share
                )
            })
            .collect::<Vec<_>>()
            .join(" ")
    }

    /// The user-defined effect that implements it: torque `prefix_1*term_1 + …`, its
    /// parameters `prefix_k` and their values (the coefficients).
    pub fn effect(&self, prefix: &str) -> (String, Vec<String>, Vec<f64>) {
        let params: Vec<String> = (1..=self.terms.len())
            .map(|k| format!("{prefix}_{k}"))
            .collect();
        let torque = self
            .terms
            .iter()
            .zip(&params)
            .map(|(t, p)| {
                if t.text == "1" {
                    p.clone()
                } else {
                    format!("{p}*{}", t.text)
                }
            })
            .collect::<Vec<_>>()
            .join(" + ");
        let values = self.terms.iter().map(|t| t.coefficient).collect();
        (torque, params, values)
    }
}

/// The sparse model of `r` (one joint's torque residual, segments of lengths `segments`)
/// on the columns `columns` (one per library term `texts`, aligned with `r`): the support
/// by stepwise regression on the BIC over the effective samples (module docs), only the
/// terms `lead` marks entering on their own (the others through the polynomial
/// hierarchy). None when no term lowers the BIC or the residual is 0.
pub fn sparse_model(
    joint: usize,
    r: &[f64],
    segments: &[usize],
    columns: &[Vec<f64>],
    (texts, lead): (&[String], &[bool]),
) -> Option<Structure> {
    let n = r.len();
    let sst: f64 = r.iter().map(|x| x * x).sum();
    if n < 2 * columns.len() + 8 || sst <= 0.0 || !sst.is_finite() {
        return None;
    }
    // Columns scaled to unit norm; empty ones left out.
    let norms: Vec<f64> = columns
        .iter()
        .map(|c| c.iter().map(|x| x * x).sum::<f64>().sqrt())
        .collect();
    let usable: Vec<usize> = (0..columns.len())
        .filter(|&k| norms[k] > 0.0 && norms[k].is_finite())
        .collect();
    let fit = |support: &[usize]| -> Option<(Vec<f64>, f64)> {
        if support.is_empty() {
            return Some((Vec::new(), sst));
        }
        let a = DMatrix::from_fn(n, support.len(), |i, c| {
            columns[support[c]][i] / norms[support[c]]
        });
        let b = DVector::from_column_slice(r);
        let svd = crate::util::svd(a.clone())?;
        let x = svd.solve(&b, 1e-10 * svd.singular_values.max()).ok()?;
        let sse = (b - a * &x).norm_squared();
        Some((x.iter().copied().collect(), sse))
    };
    // The effective samples of what the whole library leaves.
    let (_, sse_all) = fit(&usable)?;
    let left: Vec<f64> = {
        let cols: Vec<&[f64]> = usable.iter().map(|&k| columns[k].as_slice()).collect();
        super::least_squares_residual(&cols, r).unwrap_or_else(|| r.to_vec())
    };
    let n_eff = super::effective_samples(&left, segments);
    let _ = sse_all;
    let bic_of = |sse: f64, p: usize| super::bic(sse, sst, n_eff, p).0;
    // Forward: add the column that lowers the SSE most while the BIC falls; backward:
    // drop a term while that lowers the BIC; until neither changes the support.
    let mut support: Vec<usize> = Vec::new();
    let (mut x, mut sse) = (Vec::new(), sst);
    let mut score = 0.0;
    for _ in 0..4 * usable.len() {
        let mut changed = false;
        let trial = usable
            .iter()
            .filter(|&&k| lead.get(k).copied().unwrap_or(true))
            .filter(|k| !support.contains(k))
            .filter_map(|&k| {
                let mut s = support.clone();
                s.push(k);
                fit(&s).map(|(xs, e)| (s, xs, e))
            })
            .min_by(|a, b| a.2.total_cmp(&b.2));
        if let Some((s, xs, e)) = trial {
            let b = bic_of(e, s.len());
            if b < score {
                (support, x, sse, score) = (s, xs, e, b);
                changed = true;
            }
        }
        loop {
            let drop = (0..support.len())
                .filter_map(|i| {
                    let mut s = support.clone();
                    s.remove(i);
                    fit(&s).map(|(xs, e)| (s, xs, e))
                })
                .map(|(s, xs, e)| {
                    let b = bic_of(e, s.len());
                    (s, xs, e, b)
                })
                .min_by(|a, b| a.3.total_cmp(&b.3));
            match drop {
                Some((s, xs, e, b)) if b < score => {
                    (support, x, sse, score) = (s, xs, e, b);
                    changed = true;
                }
                _ => break,
            }
        }
        if !changed {
            break;
        }
    }
    if support.is_empty() {
        return None;
    }
    // Polynomial hierarchy (Peixoto, "Hierarchical variable selection in polynomial
    // regression models", Am. Stat. 41 (1987) 311–313): a power of q kept brings the lower
    // powers and the constant, q̇³ brings q̇. Without it the model depends on where q = 0
    // is: a cubic about qc came back as q³ + 1, its q² term (30 % of the torque) left to
    // a later round that named another effect (measured, c3).
    let lower = |t: &str| -> Vec<String> {
        let j = t.trim_start_matches(|c: char| !c.is_ascii_digit());
        let j: String = j.chars().take_while(|c| c.is_ascii_digit()).collect();
        match t {
            _ if t == format!("q{j}^3") => vec![format!("q{j}^2"), format!("q{j}"), "1".into()],
            _ if t == format!("q{j}^2") => vec![format!("q{j}"), "1".into()],
            _ if t == format!("q{j}") => vec!["1".into()],
            _ if t == format!("qd{j}^3") => vec![format!("qd{j}")],
            _ => Vec::new(),
        }
    };
    let mut completed = support.clone();
    for &k in &support {
        for l in lower(&texts[k]) {
            if let Some(i) = usable.iter().copied().find(|&i| texts[i] == l) {
                if !completed.contains(&i) {
                    completed.push(i);
                }
            }
        }
    }
    if completed.len() > support.len() {
        if let Some((xs, e)) = fit(&completed) {
            score = bic_of(e, completed.len());
            (support, x, sse) = (completed, xs, e);
        }
        // Terms the completed powers make redundant (sin(2q) standing in for q) go again;
        // a power another kept power needs stays.
        loop {
            let needed: Vec<String> = support.iter().flat_map(|&k| lower(&texts[k])).collect();
            let drop = (0..support.len())
                .filter(|&i| !needed.contains(&texts[support[i]]))
                .filter_map(|i| {
                    let mut s = support.clone();
                    s.remove(i);
                    fit(&s).map(|(xs, e)| {
                        let b = bic_of(e, s.len());
                        (s, xs, e, b)
                    })
                })
                .min_by(|a, b| a.3.total_cmp(&b.3));
            match drop {
                Some((s, xs, e, b)) if b < score && !s.is_empty() => {
                    (support, x, sse, score) = (s, xs, e, b);
                }
                _ => break,
            }
        }
    }
    let best = Some((score, support, x, sse));
    let (delta_bic, support, x, sse) = best?;
    let mut terms: Vec<Term> = support
        .iter()
        .zip(&x)
        .enumerate()
        .map(|(i, (&k, &v))| {
            let without: Vec<usize> = support
                .iter()
                .enumerate()
                .filter(|&(m, _)| m != i)
                .map(|(_, &s)| s)
                .collect();
            let sse_without = fit(&without).map_or(sst, |f| f.1);
            Term {
                text: texts[k].clone(),
                coefficient: v / norms[k],
                share: ((sse_without - sse) / sst).max(0.0),
            }
        })
        .collect();
    terms.sort_by(|a, b| b.share.total_cmp(&a.share));
    Some(Structure {
        joint,
        terms,
        explained: 1.0 - sse / sst,
        delta_bic,
        effective_samples: n_eff,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 4000 samples at 100 Hz of joint 3 moving as `motion(t) = (q, q̇)`: the sparse model
    /// of `torque(q) + uniform noise of width `noise`` on the whole library.
    fn model_of(
        motion: impl Fn(f64) -> (f64, f64),
        torque: impl Fn(f64) -> f64,
        (noise, seed): (f64, u64),
    ) -> Option<Structure> {
        let n = 4000;
        let mut state = seed;
        let mut uniform = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let free = [3usize];
        let lib = library(3, &free, &["q0", "q1", "q2", "q3", "q4", "q5"]);
        let texts: Vec<String> = lib.iter().map(|t| t.text.clone()).collect();
        let lead: Vec<bool> = lib.iter().map(|t| !t.catalogued).collect();
        let mut columns = vec![Vec::with_capacity(n); lib.len()];
        let mut r = Vec::with_capacity(n);
        for k in 0..n {
            let (q, qd) = motion(k as f64 * 0.01);
            for (c, term) in columns.iter_mut().zip(&lib) {
                c.push(term.value(&free, &[q], &[qd], &[0.0]));
            }
            r.push(torque(q) + noise * uniform());
        }
        sparse_model(3, &r, &[n], &columns, (&texts, &lead))
    }

    /// A cubic in q with noise, among the whole library: the stepwise regression keeps the
    /// cubic's own terms and their coefficients (least squares on the exact support).
    #[test]
    fn a_cubic_among_the_library_is_found_with_its_coefficients() {
        let s = model_of(
            |t| {
                (
                    0.8 * (0.7 * t).sin() + 0.3 * (2.3 * t).sin(),
                    0.56 * (0.7 * t).cos() + 0.69 * (2.3 * t).cos(),
                )
            },
            |q| 0.02 * (q - 0.1f64).powi(3),
            (2e-3, 7),
        )
        .unwrap();
        eprintln!(
            "{} explained {:.4} ΔBIC {:.1}",
            s.text(),
            s.explained,
            s.delta_bic
        );
        // 0.02 (q − 0.1)³ = 0.02 q³ − 0.006 q² + 6e-4 q − 2e-5: q³ leads, the hierarchy
        // brings the lower powers, and nothing else enters.
        let found: Vec<&str> = s.terms.iter().map(|t| t.text.as_str()).collect();
        assert!(
            found.contains(&"q3^3") && found.contains(&"q3^2"),
            "{found:?}"
        );
        assert!(
            found
                .iter()
                .all(|t| ["1", "q3", "q3^2", "q3^3"].contains(t)),
            "{}",
            s.text()
        );
        let c = |x: &str| s.terms.iter().find(|t| t.text == x).unwrap().coefficient;
        assert!((c("q3^3") / 0.02 - 1.0).abs() < 0.01, "{}", c("q3^3"));
        assert!((c("q3^2") / (-0.006) - 1.0).abs() < 0.01, "{}", c("q3^2"));
        assert!(s.significant());
        let (torque, params, values) = s.effect("s3");
        assert_eq!(params.len(), s.terms.len());
        let first = s.terms[0].text.clone();
        assert!(torque.starts_with(&format!("s3_1*{first}")), "{torque}");
        assert_eq!(values[0], c(&first));
    }

    /// Noise alone: no term passes the significance rule.
    #[test]
    fn noise_alone_gives_nothing_significant() {
        let s = model_of(
            |t| (0.8 * (0.7 * t).sin(), 0.56 * (0.7 * t).cos()),
            |_| 0.0,
            (1.0, 11),
        );
        assert!(
            s.as_ref().is_none_or(|s| !s.significant()),
            "{:?}",
            s.map(|s| s.text())
        );
    }
}
