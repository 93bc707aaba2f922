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
//! with n the number of residual samples (output space also reports the effective number
//! of independent samples, [`effective_samples`], of what all candidates together leave);
//! and a candidate is significant when ΔBIC < −10 (decisive evidence) and it explains at
//! least 5 % of the residual energy. When none is, nothing significant is missing.
//! A [`Finding`] carries the plant edit that implements it ([`Finding::apply`]): the effect
//! to add (or the existing parameter to change) and the estimated parameter values.

pub mod apply;
pub mod candidates;
pub mod output;
pub mod structure;
pub mod torque;

pub use apply::{apply_all_significant, apply_finding, AppliedLoop, LoopEnd, LoopStep, Turn};
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
    /// Candidate name (`coulomb`, `stribeck`, `input_coupling from q5`, `Kp_q2 off`,
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
    /// Plant parameter values (full names, e.g. `Ks_q3`) that implement the finding; empty
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
    /// A user-defined effect to add ([`structure`]: terms outside the catalogue, or a
    /// user's candidate, [`candidates`]); its parameters are `values`.
    pub expression: Option<crate::plant::ExpressionSpec>,
    /// Terms outside the catalogue found by the sparse regression ([`structure`]), not
    /// an effect the catalogue or the user named.
    pub structure: bool,
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
        (sse, sst, n, p): (f64, f64, f64, usize),
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
            expression: None,
            structure: false,
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
            replace_law(&mut p, e, self.replaces);
            p.add_effect(e)?;
        }
        if let Some(x) = &self.expression {
            p.add_expression_spec(x, &format!("expression '{}'", x.name))?;
        }
        for ((n, v), b) in self.values.iter().zip(&self.bounds) {
            p.parameters.insert(n.clone(), *v);
            p.bounds.insert(n.clone(), *b);
        }
        Ok(p)
    }

    /// The finding of a sparse model `st` of a joint's residual (energy `sst` over `n`
    /// samples, [`structure`]): the user-defined effect `structure_qj` with coefficients
    /// `sj_1`, … (a free prefix where the plant has those), bounds ±(10 |c| + `pad`) about
    /// each coefficient c, its figures those of the sparse model.
    pub fn of_structure(
        plant: &Plant,
        st: &structure::Structure,
        (sst, n): (f64, usize),
        pad: f64,
    ) -> Finding {
        let joints = plant.model.joints;
        let joint = joints[st.joint];
        let (name, prefix) = structure::free_names(plant, st.joint);
        let (torque, params, values) = st.effect(&prefix);
        // The library's terms are numbered (`q2`); users read the joints' names (`q_q3`).
        let torque = crate::names::expression_text(&torque, joints);
        let mut f = Finding::new(
            joint,
            crate::names::expression_text(&st.name(), joints),
            None,
            None,
            st.terms
                .iter()
                .map(|t| {
                    (
                        crate::names::expression_text(&t.text, joints),
                        t.coefficient,
                    )
                })
                .collect(),
            (sst * (1.0 - st.explained), sst, n as f64, st.terms.len()),
        );
        f.delta_bic = st.delta_bic;
        f.significant = st.significant();
        f.meaning = structure::MEANING.to_string();
        f.structure = true;
        f.expression = Some(crate::plant::ExpressionSpec {
            name,
            joints: vec![joint.to_string()],
            torque,
            parameters: params.clone(),
        });
        f.bounds = values.iter().map(|&v| bounds_about(v, pad)).collect();
        f.values = params.into_iter().zip(values).collect();
        f
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

/// The structure search ([`structure`]) runs only where no significant catalogued
/// candidate explains this share of the residual: a catalogued effect that explains
/// nearly all of it is applied first, and what it leaves is searched in the next round
/// (on a coupling hidden in k1, a library model — the coupling's τ5 and two harmonics
/// under 1e-4 N·m — had outranked the coupling it restated).
pub const STRUCTURE_SEARCH_BELOW: f64 = 0.95;

/// A structure outside the catalogue ([`structure`]) leads only where it beats
/// every significant catalogued finding by more than this ΔBIC (Kass and Raftery 1995:
/// above 10, very strong evidence): a library model that only restates a catalogued
/// effect (q + 1 is a spring) or does not clearly beat one is not preferred to the
/// effect with a physical name.
pub const STRUCTURE_MARGIN: f64 = 10.0;

/// Sizes that a dissipative or inertial term cannot have negative: Coulomb and viscous
/// friction, armature and coupled-motor inertia, quadratic drag, load-dependent and
/// coupled-motor friction, backlash (by the estimate's name, with or without its joint
/// suffix).
const NOT_NEGATIVE: [&str; 10] = [
    "Fc", "Fv", "Ia", "cd_", "mu_", "Fm_", "Fvm_", "Jm_", "Ks_", "backlash",
];

/// A finding whose estimate of such a size is negative ([`NOT_NEGATIVE`]) is not
/// significant, and says why: a negative drag or rotor inertia is a fit of noise or of
/// another effect's shadow, not the physics it is named for (on a Puma with Coulomb
/// friction hidden on two joints, "armature on q1" at Ia = −1.41 kg·m² had led).
pub(crate) fn refuse_unphysical_signs(findings: &mut [Finding]) {
    for f in findings {
        if let Some((name, v)) = negative_size(f) {
            f.significant = false;
            f.meaning = format!(
                "{} (not physical here: {name} = {v:.4e} is negative, which a dissipative or inertial term cannot be)",
                f.meaning
            );
        }
    }
}

/// The estimate of `f` that [`NOT_NEGATIVE`] says cannot be negative and is, if any.
fn negative_size(f: &Finding) -> Option<(String, f64)> {
    f.estimate
        .iter()
        .find(|(name, v)| {
            *v < 0.0
                && NOT_NEGATIVE.iter().any(|p| {
                    name == p || name.starts_with(&format!("{}_", p.trim_end_matches('_')))
                })
        })
        .cloned()
}

/// Sort findings by ΔBIC, those refused as not physical ([`refuse_unphysical_signs`])
/// after the rest.
pub(crate) fn sort_findings(findings: &mut [Finding]) {
    findings.sort_by(|a, b| {
        negative_size(a)
            .is_some()
            .cmp(&negative_size(b).is_some())
            .then(a.delta_bic.total_cmp(&b.delta_bic))
    });
}

/// Move the best significant catalogued finding ahead of structure findings that do not
/// beat it by [`STRUCTURE_MARGIN`]. `findings` is sorted by ΔBIC.
pub(crate) fn prefer_the_catalogue(findings: &mut Vec<Finding>) {
    let Some(c) = findings.iter().position(|f| f.significant && !f.structure) else {
        return;
    };
    let bar = findings[c].delta_bic - STRUCTURE_MARGIN;
    let ahead = findings[..c]
        .iter()
        .position(|f| f.structure && f.delta_bic >= bar);
    if let Some(i) = ahead {
        let f = findings.remove(c);
        findings.insert(i, f);
    }
}

/// Remove from `plant` what effect `e` replaces: the friction law `old` on its joint, and
/// for LuGre, whose σ2 is the viscous friction, the joint's viscous effect and its value
/// too (the candidate's σ2 carries it). The replaced law's values stay: its Fc, Fs and vs
/// are the new law's.
pub(crate) fn replace_law(plant: &mut Plant, e: crate::effects::Effect, old: Option<EffectKind>) {
    let Some(old) = old else { return };
    let lugre = e.kind == EffectKind::Lugre;
    plant.effects.retain(|x| {
        !(x.joint == e.joint
            && x.from.is_none()
            && (x.kind == old || (lugre && x.kind == EffectKind::Viscous)))
    });
    if lugre {
        let name = crate::names::parameter("Fv", plant.model.joints[e.joint]);
        plant.parameters.remove(&name);
        plant.bounds.remove(&name);
    }
}

/// The bounds a finding's refit gets about a value v: v ± (10 |v| + `pad`), a tenfold
/// growth and a change of sign within reach, `pad` keeping a value near 0 free.
pub(crate) fn bounds_about(v: f64, pad: f64) -> (f64, f64) {
    (v - 10.0 * v.abs() - pad, v + 10.0 * v.abs() + pad)
}

/// (ΔBIC, explained) of a fit of `p` numbers leaving `sse` of `sst` over `n` samples
/// (`n` may be an effective number of independent samples, [`effective_samples`]).
pub fn bic(sse: f64, sst: f64, n: f64, p: usize) -> (f64, f64) {
    // A residual without finite energy explains nothing (and is no evidence).
    if !(sst.is_finite() && sst > 0.0) {
        return (0.0, 0.0);
    }
    let n = n.max(1.0);
    let sse = if sse.is_finite() {
        sse.clamp(1e-300 * sst.max(1e-300), sst)
    } else {
        sst
    };
    (n * (sse / sst).ln() + p as f64 * n.ln(), 1.0 - sse / sst)
}

/// The number of independent samples a residual is worth: Σ over its segments of
/// n_s / τ_s, τ_s = 1 + 2 Σ_{k≥1} ρ_k the integrated autocorrelation time of the segment
/// (Bayley and Hammersley 1946), the sum over lags stopped at the first ρ_k ≤ 0 (Geyer's
/// initial positive sequence, 1992) and at n_s / 4. `residual` is the segments stacked,
/// `segments` their lengths (a file's joint each). White noise gives about Σ n_s; a
/// residual that wanders slowly (a model error the fit left, a drift) far fewer. Reported
/// by the output-space diagnosis, not counted in its ΔBIC (module docs).
pub fn effective_samples(residual: &[f64], segments: &[usize]) -> f64 {
    let mut total = 0.0;
    let mut start = 0;
    for &len in segments {
        let end = (start + len).min(residual.len());
        let seg = &residual[start..end];
        start = end;
        let n = seg.len();
        if n < 8 {
            total += n as f64;
            continue;
        }
        let mean = seg.iter().sum::<f64>() / n as f64;
        let c0: f64 = seg.iter().map(|x| (x - mean).powi(2)).sum();
        if c0 <= 0.0 {
            total += n as f64;
            continue;
        }
        let mut tau = 1.0;
        for k in 1..n / 4 {
            let ck: f64 = seg[k..]
                .iter()
                .zip(seg)
                .map(|(a, b)| (a - mean) * (b - mean))
                .sum();
            let rho = ck / c0;
            if rho <= 0.0 {
                break;
            }
            tau += 2.0 * rho;
        }
        total += n as f64 / tau;
    }
    total.max(1.0)
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
    let svd = crate::util::svd(a.clone())?;
    let x = svd.solve(&b, 1e-12 * svd.singular_values.max()).ok()?;
    let sse = (b - a * &x).norm_squared();
    Some((x.iter().copied().collect(), sse))
}

/// The residual e − A x̂ of the least-squares fit of e on the columns `cols` (SVD, columns
/// that are nearly dependent dropped at 1e-10 of the largest singular value); None when
/// there are too few samples or the problem is degenerate.
pub fn least_squares_residual(cols: &[&[f64]], e: &[f64]) -> Option<Vec<f64>> {
    let n = e.len();
    let p = cols.len();
    if p == 0 || n <= p + 1 {
        return None;
    }
    // Columns scaled to unit norm so that the rank cut does not depend on units.
    let norms: Vec<f64> = cols
        .iter()
        .map(|c| c.iter().map(|x| x * x).sum::<f64>().sqrt())
        .collect();
    let a = DMatrix::from_fn(n, p, |r, c| {
        if norms[c] > 0.0 {
            cols[c][r] / norms[c]
        } else {
            0.0
        }
    });
    let b = DVector::from_column_slice(e);
    let svd = crate::util::svd(a.clone())?;
    let x = svd.solve(&b, 1e-10 * svd.singular_values.max()).ok()?;
    Some((b - a * x).iter().copied().collect())
}

/// The ranking as text: the top `k` candidates and the verdict (no joint known to be
/// above its noise: [`table_with`]).
pub fn table(findings: &[Finding], k: usize) -> String {
    table_with(findings, k, &[])
}

/// The ranking as text: the top `k` candidates and the [`verdict`] given what the residual
/// shows that is not noise (`left`: joints above their noise, joints whose residual is
/// not white).
pub fn table_with(findings: &[Finding], k: usize, left: &[String]) -> String {
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
    s += &verdict(findings, left);
    s.push('\n');
    s
}

/// Lags of the whiteness test of a joint's residual (MATLAB `resid`'s default, as
/// [`crate::compare`]).
pub const WHITENESS_LAGS: usize = 25;

/// The smallest coloured share of a residual
/// ([`crate::compare::Whiteness::coloured_share`]) that makes a residual that fails the
/// whiteness test "not noise" for the verdict: a fit that stopped a little short of its
/// optimum (the truth refitted from 10 % off to 1.03 σ on c3, 800 samples: Ljung–Box Q =
/// 56.5 over a critical 44.3, largest |ρ_k| 0.13, of which 3/√800 = 0.11 is chance) fails
/// the test with nothing missing; a missing effect that leaves the residual at 1.5 σ has a
/// coloured share above 0.5.
pub const NOT_WHITE_SHARE: f64 = 0.1;

/// "q3 not white: Ljung–Box Q = 310.2 > 44.3 over 25 lags, largest |ρ| 0.82" when the
/// residual of `joint`, given as `segments` (one per file, in time order), fails the
/// whiteness test ([`crate::compare::whiteness`], [`WHITENESS_LAGS`] lags) with a
/// coloured share of at least [`NOT_WHITE_SHARE`] beyond chance; None otherwise.
pub fn not_white(joint: &str, segments: &[&[f64]]) -> Option<String> {
    let w = crate::compare::whiteness(segments, WHITENESS_LAGS);
    (!w.white() && w.coloured_share() >= NOT_WHITE_SHARE).then(|| {
        format!(
            "{joint} not white: {}, largest |ρ| {:.2}",
            w.text(),
            w.largest
        )
    })
}

/// The verdict in one line, one of three outcomes (issue 54): the leading finding when it
/// is significant (a catalogued effect, or terms outside the catalogue, [`structure`],
/// said as such); else, when `left` (what the residual shows that is not noise: joints
/// whose error is above their noise, e.g. "q3 9.0 σ̂", or whose residual is not white,
/// [`not_white`]) is not empty, that the residual is unexplained: an effect outside the
/// catalogue and the library, coloured noise, or plant values far off that a refit would
/// move; "nothing significant is missing" only when `left` is empty.
pub fn verdict(findings: &[Finding], left: &[String]) -> String {
    match findings.first() {
        Some(f) if f.significant && f.structure => format!(
            "the residual has structure the catalogue lacks, on {}: {} (--apply adds it as a user-defined effect)",
            f.joint,
            f.estimate_text()
        ),
        Some(f) if f.significant => format!("most likely missing: {} on {}", f.name, f.joint),
        _ if !left.is_empty() => format!(
            "unexplained: what is left is not noise ({}) but no candidate, built-in or library term explains a significant share of it. Likely: an effect with a state of its own (a resonance, hysteresis, backlash, a delay), coloured measurement noise (a filtered sensor: compare's residual spectrum shows it), or values far off (refit them: lockstep refit or identify; output space refits the values the plant bounds first, within those bounds)",
            left.join("; ")
        ),
        _ => "nothing significant is missing (no candidate has ΔBIC < -10 and explains >= 5 % of the residual, and the residual is white or its coloured part is under 10 % of it)".to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::effective_samples;

    /// SplitMix64 + Box–Muller: reproducible Gaussian samples for the tests.
    fn gaussian(n: usize, mut state: u64) -> Vec<f64> {
        let mut uniform = || {
            state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
        };
        (0..n)
            .map(|_| {
                let (u1, u2) = (uniform().max(1e-300), uniform());
                (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
            })
            .collect()
    }

    /// White noise is worth about its own length; an AR(1) process x_k = φ x_{k−1} + e_k
    /// has τ = (1 + φ)/(1 − φ) (19 for φ = 0.9), so it is worth n/19.
    #[test]
    fn effective_samples_of_white_noise_and_of_an_ar1_process() {
        let n = 20_000;
        let white = gaussian(n, 3);
        let w = effective_samples(&white, &[n / 2, n / 2]);
        assert!((w / n as f64 - 1.0).abs() < 0.1, "white: {w}");
        let phi = 0.9;
        let mut ar = Vec::with_capacity(n);
        let mut x = 0.0;
        for e in gaussian(n, 5) {
            x = phi * x + e;
            ar.push(x);
        }
        let a = effective_samples(&ar, &[n]);
        let expected = n as f64 * (1.0 - phi) / (1.0 + phi);
        assert!(
            (a / expected - 1.0).abs() < 0.25,
            "AR(1): {a}, expected {expected}"
        );
    }
}
