//! Which physical effect is missing: a catalogue of candidate effects, each with a physical
//! meaning and a signature, tested against the residual of a plant on measurements and
//! ranked by the Bayesian information criterion change and the share of the residual it
//! explains (anchor: sparse regression over a library of candidate terms, SINDy, one term
//! group at a time; MATLAB's `resid` for the residual tests in [`crate::compare`]).
//!
//! Two spaces:
//! - [`torque`]: torque-measured data through the inverse model (IDIM observation); a
//!   candidate's signature is its regressor columns.
//! - [`output`]: position-measured data through the simulator; a candidate's signature is
//!   the sensitivity of the simulated positions to the candidate's size, and the leading
//!   candidates are confirmed by a nonlinear output-error fit.
//!
//! For both, with n residual samples, SST the residual energy and SSE_c what is left after
//! fitting candidate c with p_c free numbers:
//!
//! ΔBIC = n ln(SSE_c / SST) + p_c ln n,   explained = 1 − SSE_c / SST,
//!
//! and a candidate is significant when ΔBIC < −10 (decisive evidence) and it explains at
//! least 5 % of the residual energy. When none is, nothing significant is missing.
//! A [`Finding`] carries the plant edit that implements it ([`Finding::apply`]): the effect
//! to add (or the existing parameter to change) and the estimated parameter values.

pub mod apply;
pub mod output;
pub mod torque;

pub use apply::{apply_all_significant, apply_finding, AppliedLoop, LoopEnd, LoopStep};
pub use output::{diagnose_output, OutputDiagnosis, OutputOptions};
pub use torque::diagnose_torque;

use crate::effects::{Effect, EffectKind};
use crate::plant::Plant;
use anyhow::{bail, Result};
use nalgebra::{DMatrix, DVector};
use serde::Serialize;

/// Significance: ΔBIC below this …
pub const SIGNIFICANT_DELTA_BIC: f64 = -10.0;
/// … and at least this share of the residual energy explained.
pub const SIGNIFICANT_EXPLAINED: f64 = 0.05;

/// One candidate's fit to a residual.
#[derive(Debug, Clone, Serialize)]
pub struct Finding {
    /// Joint name (the joint the effect acts on; for a coupling, the receiving joint).
    pub joint: String,
    /// Candidate name (`coulomb`, `stribeck`, `input_coupling from q5`, `Kp_2 off`,
    /// `refit existing parameters`, …).
    pub name: String,
    /// The plant effect that implements it (None for "refit existing parameters").
    pub kind: Option<EffectKind>,
    /// Source joint of a coupling.
    pub from: Option<String>,
    /// Estimated sizes: (symbol, value) in SI units.
    pub estimate: Vec<(String, f64)>,
    /// Fraction of the residual energy explained, 1 − SSE/SST.
    pub explained: f64,
    /// ΔBIC against "nothing missing" (negative: evidence for the candidate).
    pub delta_bic: f64,
    /// ΔBIC < −10 and explained ≥ 5 %.
    pub significant: bool,
    /// One line of physics.
    pub meaning: String,
    /// The plant edit: the effect to add (None: existing parameters change).
    #[serde(skip)]
    pub effect: Option<Effect>,
    /// A friction law on the joint that the effect replaces (Coulomb → Stribeck).
    #[serde(skip)]
    pub replaces: Option<EffectKind>,
    /// Plant parameter values (full names, e.g. `Ks_3`) that implement the finding; empty
    /// when the finding is not a plant edit.
    pub values: Vec<(String, f64)>,
    /// Bounds for refitting `values` (same order).
    pub bounds: Vec<(f64, f64)>,
    /// Confirmed by a nonlinear fit (output space): the figures are those of the fitted
    /// plant, not of the linearisation.
    pub confirmed: bool,
    /// Other candidates whose signatures the data cannot tell apart from this one's
    /// (output space: sensitivities with |cos| ≥ [`output::ALIKE_COSINE`]), as
    /// `name on joint`.
    pub alike: Vec<String>,
    /// What to do instead of a plant edit (a finding about how the input was applied).
    pub advice: Option<String>,
}

impl Finding {
    /// A finding with the figures and meaning filled from a fit of `p` numbers leaving
    /// `sse` of `sst` over `n` samples.
    fn new(
        joint: &str,
        name: String,
        kind: Option<EffectKind>,
        from: Option<String>,
        estimate: Vec<(String, f64)>,
        (sse, sst, n, p): (f64, f64, usize, usize),
    ) -> Finding {
        let (delta_bic, explained) = bic(sse, sst, n, p);
        Finding {
            joint: joint.to_string(),
            meaning: kind.map_or(String::new(), |k| k.meaning().to_string()),
            name,
            kind,
            from,
            estimate,
            explained,
            delta_bic,
            significant: significant(delta_bic, explained),
            effect: None,
            replaces: None,
            values: Vec::new(),
            bounds: Vec::new(),
            confirmed: false,
            alike: Vec::new(),
            advice: None,
        }
    }

    /// The plant with the finding applied: the effect added (replacing the friction law it
    /// replaces), the estimated values set and their bounds stored for a refit.
    ///
    /// # Errors
    /// The finding is not a plant edit ("refit existing parameters"), or the plant refuses
    /// the effect (a conflicting effect on that joint, named).
    pub fn apply(&self, plant: &Plant) -> Result<Plant> {
        if let (true, Some(advice)) = (self.values.is_empty(), &self.advice) {
            bail!(
                "'{}' is not a plant edit: it is about the data's input: {advice}",
                self.name
            );
        }
        if self.values.is_empty() {
            bail!(
                "'{}' on {} is not a plant edit: refit (identify) the plant's parameters instead",
                self.name,
                self.joint
            );
        }
        let mut p = plant.clone();
        if let Some(e) = self.effect {
            if let Some(old) = self.replaces {
                p.effects.retain(|x| !(x.joint == e.joint && x.kind == old));
            }
            p.add_effect(e)?;
        }
        for ((n, v), b) in self.values.iter().zip(&self.bounds) {
            p.parameters.insert(n.clone(), *v);
            p.bounds.insert(n.clone(), *b);
        }
        Ok(p)
    }

    /// The estimate as `name = value, …`.
    pub fn estimate_text(&self) -> String {
        self.estimate
            .iter()
            .map(|(n, v)| format!("{n} = {v:.4e}"))
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// Names of the plant parameters the finding sets (to refit after applying it).
    pub fn parameter_names(&self) -> Vec<String> {
        self.values.iter().map(|(n, _)| n.clone()).collect()
    }
}

/// (ΔBIC, explained) of a fit of `p` numbers leaving `sse` of `sst` over `n` samples.
pub fn bic(sse: f64, sst: f64, n: usize, p: usize) -> (f64, f64) {
    let nf = n as f64;
    let sse = sse.clamp(1e-300 * sst.max(1e-300), sst);
    (nf * (sse / sst).ln() + p as f64 * nf.ln(), 1.0 - sse / sst)
}

/// The significance rule: ΔBIC < −10 and explained ≥ 5 %.
pub fn significant(delta_bic: f64, explained: f64) -> bool {
    delta_bic < SIGNIFICANT_DELTA_BIC && explained >= SIGNIFICANT_EXPLAINED
}

/// Least squares e ≈ Σ β_c col_c: (β, SSE); None when there are too few samples or the
/// problem is degenerate.
fn fit(cols: &[Vec<f64>], e: &[f64]) -> Option<(Vec<f64>, f64)> {
    let n = e.len();
    let p = cols.len();
    if n <= p + 1 {
        return None;
    }
    let a = DMatrix::from_fn(n, p, |r, c| cols[c][r]);
    let b = DVector::from_column_slice(e);
    let svd = a.clone().svd(true, true);
    let x = svd.solve(&b, 1e-12 * svd.singular_values.max()).ok()?;
    let sse = (b - a * &x).norm_squared();
    Some((x.iter().copied().collect(), sse))
}

/// The ranking as text: the top `k` candidates and the verdict.
pub fn table(findings: &[Finding], k: usize) -> String {
    let mut s = format!(
        "{:<4} {:<6} {:<36} {:>10} {:>11}  {}\n",
        "rank", "joint", "candidate", "explained", "ΔBIC", "estimate"
    );
    for (r, f) in findings.iter().take(k).enumerate() {
        let est = f.estimate_text();
        s += &format!(
            "{:<4} {:<6} {:<36} {:>9.1}% {:>11.1}  {est}{}{}\n       {}\n",
            r + 1,
            f.joint,
            f.name,
            100.0 * f.explained,
            f.delta_bic,
            if f.confirmed { "  (fitted)" } else { "" },
            if f.significant {
                ""
            } else {
                "  (not significant)"
            },
            f.meaning
        );
        if !f.alike.is_empty() && f.significant {
            s += &format!(
                "       indistinguishable in these data from: {} (a record that excites them differently would tell them apart)\n",
                f.alike.join(", ")
            );
        }
        if let (Some(a), true) = (&f.advice, f.significant) {
            s += &format!("       {a}\n");
        }
    }
    match findings.first() {
        Some(f) if f.significant => s += &format!("most likely missing: {} on {}\n", f.name, f.joint),
        _ => s += "nothing significant is missing (no candidate has ΔBIC < -10 and explains >= 5 % of the residual)\n",
    }
    s
}
