//! Candidate effects the user gives (`lockstep diagnose --candidates my_effects.toml`,
//! issue 54 item 1): user-defined effects ([`crate::expression`]) with start values and
//! bounds, tested beside the catalogue and ranked with it by the same ΔBIC and share of
//! the residual ([`super::bic`]).
//!
//! The file:
//!
//! ```toml
//! [[candidate]]
//! name = "cogging_q3"              # unique in the file; the effect's name once added
//! joints = ["q3"]                  # the joints it takes torque from
//! torque = "A*sin(6*q3 + phi)"     # an expression of qk, qdk, tauk, zk, t, its parameters
//! meaning = "detent torque of the motor's magnets, 6 per turn"   # optional
//! parameters = { A = { start = 0.01, bounds = [-1.0, 1.0] }, phi = { start = 0.0, bounds = [-3.2, 3.2] } }
//! ```
//!
//! Output space: each candidate is added at its start values and its parameters are
//! fitted by output error within their bounds (beside the configuration's values, as the
//! catalogue's confirmations are); its figures are those of the fitted plant. Torque
//! space: each candidate linear in its parameters gives one regressor column per
//! parameter through the same filter and decimation as the plant's own (`column_sets`),
//! fitted by least squares together with the plant's parameters; a candidate not linear
//! in its parameters is refused there (named), as torque space refits only such effects.

use super::Finding;
use crate::names;
use crate::plant::{ExpressionSpec, Plant};
use anyhow::{anyhow, bail, Context, Result};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::Path;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct CandidatesFile {
    #[serde(rename = "candidate", default)]
    candidates: Vec<CandidateSpec>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct CandidateSpec {
    name: String,
    joints: Vec<String>,
    torque: String,
    #[serde(default)]
    meaning: String,
    #[serde(default)]
    parameters: BTreeMap<String, ParameterSpec>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ParameterSpec {
    start: f64,
    bounds: [f64; 2],
}

/// One candidate of a candidates file.
#[derive(Debug, Clone)]
pub struct UserCandidate {
    /// The user-defined effect it adds (name, joints, torque, parameter names).
    pub spec: ExpressionSpec,
    /// One line of physics (the file's `meaning`, else the torque).
    pub meaning: String,
    /// Start value of each parameter (same order as `spec.parameters`; SI).
    pub start: Vec<f64>,
    /// Bounds of each parameter (same order).
    pub bounds: Vec<(f64, f64)>,
}

/// Read a candidates file.
///
/// # Errors
/// The file unreadable or not TOML (line and column named), an unknown field, no
/// `[[candidate]]`, a name given twice, a parameter whose bounds are not lower < upper or
/// whose start lies outside them, a non-finite number — each naming the file and the
/// candidate.
pub fn read(path: &Path) -> Result<Vec<UserCandidate>> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("cannot read candidates file {}", path.display()))?;
    let file: CandidatesFile = toml::from_str(&text)
        .map_err(|e| anyhow!("{}: {}", path.display(), e.to_string().trim_end()))?;
    if file.candidates.is_empty() {
        bail!(
            "{}: no [[candidate]] given (each has name, joints, torque, parameters)",
            path.display()
        );
    }
    let mut seen: Vec<&str> = Vec::new();
    let mut out = Vec::new();
    for c in &file.candidates {
        let at = |what: String| anyhow!("{}: candidate '{}': {what}", path.display(), c.name);
        if seen.contains(&c.name.as_str()) {
            return Err(at(
                "the name is given twice (candidate names are unique)".into()
            ));
        }
        seen.push(&c.name);
        if c.joints.is_empty() {
            return Err(at(
                "joints is empty (give the joints it acts on, e.g. [\"q3\"])".into(),
            ));
        }
        let mut start = Vec::new();
        let mut bounds = Vec::new();
        for (p, s) in &c.parameters {
            let [lo, hi] = s.bounds;
            if !(s.start.is_finite() && lo.is_finite() && hi.is_finite()) {
                return Err(at(format!(
                    "parameter '{p}': start and bounds must be finite numbers"
                )));
            }
            if lo >= hi {
                return Err(at(format!(
                    "parameter '{p}': bounds [{lo}, {hi}] are not lower < upper"
                )));
            }
            if !(lo..=hi).contains(&s.start) {
                return Err(at(format!(
                    "parameter '{p}': start {} is outside its bounds [{lo}, {hi}]",
                    s.start
                )));
            }
            start.push(s.start);
            bounds.push((lo, hi));
        }
        out.push(UserCandidate {
            spec: ExpressionSpec {
                name: c.name.clone(),
                joints: c.joints.clone(),
                torque: c.torque.clone(),
                parameters: c.parameters.keys().cloned().collect(),
            },
            meaning: if c.meaning.is_empty() {
                format!("a candidate of the user's file: torque = {}", c.torque)
            } else {
                c.meaning.clone()
            },
            start,
            bounds,
        });
    }
    Ok(out)
}

impl UserCandidate {
    /// `plant` with the candidate added at its start values, its bounds stored.
    ///
    /// # Errors
    /// An unknown joint; the expression refused ([`Plant::add_expression`]: syntax,
    /// unknown symbol, a division by a parameter whose bounds hold 0; position named); a
    /// parameter name the plant already uses.
    pub fn plant(&self, plant: &Plant) -> Result<Plant> {
        let s = &self.spec;
        if let Some(p) = s
            .parameters
            .iter()
            .find(|p| plant.parameters.contains_key(*p))
        {
            bail!(
                "candidate '{}': parameter '{p}' is already a parameter of plant {} (give the candidate's parameters names of their own)",
                s.name,
                plant.name()
            );
        }
        let mut p = plant.clone();
        for ((name, v), b) in s.parameters.iter().zip(&self.start).zip(&self.bounds) {
            p.parameters.insert(name.clone(), *v);
            p.bounds.insert(name.clone(), *b);
        }
        p.add_expression_spec(s, &format!("expression '{}'", s.name))
            .with_context(|| format!("candidate '{}'", s.name))?;
        Ok(p)
    }

    /// The finding of the candidate fitted to `values` (same order as its parameters),
    /// leaving `sse` of the residual energy `sst` over `n` samples.
    pub fn finding(&self, values: &[f64], (sse, sst, n): (f64, f64, f64)) -> Finding {
        let s = &self.spec;
        let estimate: Vec<(String, f64)> = s
            .parameters
            .iter()
            .cloned()
            .zip(values.iter().copied())
            .collect();
        let mut f = Finding::new(
            &s.joints[0],
            format!("candidate {}", s.name),
            None,
            None,
            estimate.clone(),
            (sse, sst, n, s.parameters.len()),
        );
        f.meaning = self.meaning.clone();
        f.expression = Some(s.clone());
        f.values = estimate;
        f.bounds = self.bounds.clone();
        f
    }
}

/// The candidates of `candidates` that `plant` does not have yet (an effect of that name),
/// each checked against the plant ([`UserCandidate::plant`]), and a line for each one left
/// out.
///
/// # Errors
/// As [`UserCandidate::plant`], for the first candidate refused.
pub fn for_plant<'a>(
    candidates: &'a [UserCandidate],
    plant: &Plant,
) -> Result<(Vec<&'a UserCandidate>, Vec<String>)> {
    let mut kept = Vec::new();
    let mut left_out = Vec::new();
    for c in candidates {
        if plant.expressions.iter().any(|x| x.name == c.spec.name) {
            left_out.push(format!(
                "candidate '{}': the plant has this effect already (not tested)",
                c.spec.name
            ));
            continue;
        }
        c.plant(plant)?;
        kept.push(c);
    }
    Ok((kept, left_out))
}

/// A candidate and its regressor columns (one per parameter, rows as the observation).
pub type CandidateColumns<'a> = (&'a UserCandidate, Vec<Vec<f64>>);

/// Torque space: each candidate's regressor columns (one per parameter, rows as the
/// observation of `plant` on `records`), built through the same filter and decimation as
/// the plant's own ([`crate::identify::idim::observation`] of the plant with the candidate
/// added), and a line for each candidate left out (not linear in its parameters, reading
/// a LuGre deflection, acting on no joint of the configuration).
///
/// # Errors
/// As [`for_plant`].
pub fn columns<'a>(
    candidates: &'a [UserCandidate],
    plant: &Plant,
    config: &str,
    records: &[crate::measurement::Measurement],
    options: &crate::identify::idim::IdimOptions,
) -> Result<(Vec<CandidateColumns<'a>>, Vec<String>)> {
    let (kept, mut left_out) = for_plant(candidates, plant)?;
    let mut out = Vec::new();
    for c in kept {
        let with = c.plant(plant)?;
        match crate::identify::idim::observation(&with, config, records, options) {
            Ok(obs) => {
                let cols = parameter_columns(c, &obs);
                if cols.len() == c.spec.parameters.len() && !cols.is_empty() {
                    out.push((c, cols));
                } else {
                    left_out.push(format!(
                        "candidate '{}': it acts on no free joint of configuration {config} (not tested)",
                        c.spec.name
                    ));
                }
            }
            Err(e) => left_out.push(format!(
                "candidate '{}' (torque space): {e:#} (not tested; output space tests it)",
                c.spec.name
            )),
        }
    }
    Ok((out, left_out))
}

/// The built-in coupled-motor candidates of torque space, one set per pair of free joints
/// (a, b) of configuration `conf` (issue 57: a motor driving both joints through a
/// differential, as the TX40's motor 6 turns with q5 + q6): its friction at the motor's
/// speed, `Fvm_ab (q̇a + q̇b) + Fm_ab sign(q̇a + q̇b)`, and its rotor's inertia
/// `Jm_ab (q̈a + q̈b)`, each taken from both joints (the transmission's transpose). Pairs the
/// plant already has an effect of that name for are left out.
pub fn coupled_motor_candidates(
    plant: &Plant,
    conf: &generated::Configuration,
) -> Vec<UserCandidate> {
    let m = plant.model;
    let mut out = Vec::new();
    let nf = conf.free.len();
    for a in 0..nf {
        for b in a + 1..nf {
            let (ja, jb) = (conf.free[a], conf.free[b]);
            let (qa, qb) = (m.joints[ja], m.joints[jb]);
            let (fvm, fm, jm) = (
                names::pair_parameter("Fvm", qa, qb),
                names::pair_parameter("Fm", qa, qb),
                names::pair_parameter("Jm", qa, qb),
            );
            let friction = UserCandidate {
                spec: ExpressionSpec {
                    name: format!("coupled_motor_{qa}_{qb}"),
                    joints: vec![qa.to_string(), qb.to_string()],
                    torque: format!(
                        "{fvm}*(qd_{qa} + qd_{qb}) + {fm}*sign(qd_{qa} + qd_{qb})"
                    ),
                    parameters: vec![fvm, fm],
                },
                meaning: format!(
                    "a motor driving {qa} and {qb} through a differential: its viscous and Coulomb friction at the motor's speed qd_a + qd_b, taken from both"
                ),
                start: vec![0.0, 0.0],
                bounds: vec![(0.0, 1e6), (0.0, 1e6)],
            };
            let inertia = UserCandidate {
                spec: ExpressionSpec {
                    name: format!("coupled_rotor_{qa}_{qb}"),
                    joints: vec![qa.to_string(), qb.to_string()],
                    torque: format!("{jm}*(qdd_{qa} + qdd_{qb})"),
                    parameters: vec![jm],
                },
                meaning: format!(
                    "a motor driving {qa} and {qb} through a differential: its rotor's inertia at the motor's acceleration qdd_a + qdd_b, taken from both"
                ),
                start: vec![0.0],
                bounds: vec![(0.0, 1e6)],
            };
            for c in [friction, inertia] {
                let taken = plant.expressions.iter().any(|x| x.name == c.spec.name)
                    || c.spec
                        .parameters
                        .iter()
                        .any(|p| plant.parameters.contains_key(p));
                if !taken {
                    out.push(c);
                }
            }
        }
    }
    out
}

/// As [`columns`] for candidates whose names and parameters are all distinct (the built-in
/// ones): every candidate is added to one probe plant and the regressor built once.
///
/// # Errors
/// As [`crate::identify::idim::observation`].
pub fn columns_together<'a>(
    candidates: &'a [UserCandidate],
    plant: &Plant,
    config: &str,
    records: &[crate::measurement::Measurement],
    options: &crate::identify::idim::IdimOptions,
) -> Result<Vec<CandidateColumns<'a>>> {
    let mut probe = plant.clone();
    let mut kept = Vec::new();
    for c in candidates {
        if probe
            .add_expression_spec(&c.spec, "built-in candidate")
            .is_ok()
        {
            for (p, v) in c.spec.parameters.iter().zip(&c.start) {
                probe.parameters.insert(p.clone(), *v);
            }
            kept.push(c);
        }
    }
    if kept.is_empty() {
        return Ok(Vec::new());
    }
    let obs = crate::identify::idim::observation(&probe, config, records, options)?;
    Ok(kept
        .into_iter()
        .filter_map(|c| {
            let cols = parameter_columns(c, &obs);
            (cols.len() == c.spec.parameters.len()).then_some((c, cols))
        })
        .collect())
}

/// The observation's columns of a candidate's parameters, in the candidate's order (those
/// the observation has).
fn parameter_columns(c: &UserCandidate, obs: &crate::identify::idim::Observation) -> Vec<Vec<f64>> {
    c.spec
        .parameters
        .iter()
        .filter_map(|p| obs.names.iter().position(|x| x == p))
        .map(|k| obs.w.column(k).iter().copied().collect())
        .collect()
}
