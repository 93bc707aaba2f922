//! Which physical effect is missing (torque space, inverse model): every candidate effect of
//! a catalogue has a signature, the regressor columns C it would add to τ = W θ. Adding it
//! means refitting θ together with the candidate, so both the residual and the signature are
//! first made orthogonal to the plant's own columns (Frisch–Waugh: e⊥ = (I − W W⁺) e,
//! C⊥ = (I − W W⁺) C); otherwise an already fitted viscous term that absorbed part of a
//! missing Coulomb step would make the residual look like a Stribeck hump. e⊥ is fitted on C⊥
//! by least squares, and the candidates are ranked by the Bayesian information criterion
//! change
//!
//! ΔBIC = n ln(SSE_c / n) + p_c ln n − n ln(SST / n),  SST = Σ e⊥²,  SSE_c the residual after
//! fitting candidate c with p_c columns,
//!
//! with the explained fraction 1 − SSE_c/SST beside it. A candidate is significant when
//! ΔBIC < −10 (decisive evidence) and it explains at least 5 % of the residual energy; when
//! none is, nothing significant is missing. Candidates whose effect the plant already has on
//! that joint are left out. Anchor: sparse regression over a library of candidate terms
//! (SINDy), one term group at a time.
//!
//! Catalogue (per joint i; `kind` names the plant effect that implements it):
//! Coulomb sign(q̇); viscous q̇; offset 1; Stribeck e^{−(q̇/vs)²} sign(q̇) (vs on a grid);
//! cable-drag spring q − qeq (columns q and 1); friction position bias [q < qeq]·(sign q̇, q̇)
//! (qeq on a grid of position quantiles); tendon input coupling j → i, y_j. A plant-gain
//! error is not a torque-space candidate: with every parameter of W refitted, scaling the
//! torque scales θ (its column y⊥ is the residual itself); it shows in output space. Refitting the plant's own parameters (W) is reported first as
//! "refit existing parameters" with the share of the residual it removes.
//!
//! Output-space diagnosis (position-only data through the simulator's sensitivities) is not
//! here yet.

use crate::effects::{sign, EffectKind};
use crate::identify::idim::{predict, Observation};
use crate::plant::Plant;
use anyhow::Result;
use nalgebra::{DMatrix, DVector};

/// A candidate before fitting: name, effect kind, source joint, symbols, signature columns.
type Candidate = (
    String,
    Option<EffectKind>,
    Option<usize>,
    Vec<String>,
    Vec<Vec<f64>>,
);

/// One candidate's fit to a joint's residual.
#[derive(Debug, Clone)]
pub struct Finding {
    /// Joint name.
    pub joint: String,
    /// Candidate name (`coulomb`, `stribeck`, `input_coupling from q5`, `refit existing
    /// parameters`, …).
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
}

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

/// Rank the catalogue against the residual of `plant` on the prepared observation `obs`
/// (one record), per joint, best first.
///
/// # Errors
/// A parameter of the plant without value (from [`predict`]).
pub fn diagnose_torque(plant: &Plant, obs: &Observation) -> Result<Vec<Finding>> {
    let yhat = predict(plant, obs)?;
    let m = plant.model;
    let mut joints: Vec<usize> = obs.rows.iter().map(|r| r.joint).collect();
    joints.sort_unstable();
    joints.dedup();
    let rows_of = |j: usize| -> Vec<usize> {
        (0..obs.rows.len())
            .filter(|&i| obs.rows[i].joint == j)
            .collect()
    };
    let mut out = Vec::new();
    for &j in &joints {
        let idx = rows_of(j);
        let n = idx.len();
        let e0: Vec<f64> = idx.iter().map(|&i| obs.y[i] - yhat[i]).collect();
        let pw = obs.w.ncols();
        let wj = DMatrix::from_fn(n, pw, |r, c| obs.w[(idx[r], c)]);
        let w_svd = wj.clone().svd(true, true);
        let tol = 1e-12 * w_svd.singular_values.max();
        // (I − W W⁺) v: what refitting the plant's own parameters cannot explain.
        let project = |v: &[f64]| -> Vec<f64> {
            let b = DVector::from_column_slice(v);
            match w_svd.solve(&b, tol) {
                Ok(x) => (b - &wj * x).iter().copied().collect(),
                Err(_) => v.to_vec(),
            }
        };
        let e = project(&e0);
        let sst0: f64 = e0.iter().map(|x| x * x).sum();
        let sst: f64 = e.iter().map(|x| x * x).sum();
        if n < 10 || sst <= 0.0 || sst0 <= 0.0 {
            continue;
        }
        if 1.0 - sst / sst0 > 1e-6 {
            let nf = n as f64;
            let explained = 1.0 - sst / sst0;
            out.push(Finding {
                joint: m.joints[j].to_string(),
                name: "refit existing parameters".into(),
                kind: None,
                from: None,
                estimate: vec![],
                explained,
                delta_bic: nf * (sst / nf).ln() + pw as f64 * nf.ln() - nf * (sst0 / nf).ln(),
                significant: explained >= 0.05,
                meaning: "the plant's own parameters are not at their least-squares values: refit (identify) before adding effects".into(),
            });
        }
        let q: Vec<f64> = idx.iter().map(|&i| obs.rows[i].q).collect();
        let qd: Vec<f64> = idx.iter().map(|&i| obs.rows[i].qd).collect();
        let has = |k: EffectKind| {
            plant
                .effects
                .iter()
                .any(|x| x.joint == j && x.kind == k && x.from.is_none())
        };
        let has_friction = plant
            .effects
            .iter()
            .any(|x| x.joint == j && x.kind.is_friction_law());
        // (name, kind, from, symbols, columns)
        let mut cands: Vec<Candidate> = Vec::new();
        if !has_friction {
            cands.push((
                "coulomb".into(),
                Some(EffectKind::Coulomb),
                None,
                vec!["Fc".into()],
                vec![qd.iter().map(|&v| sign(v)).collect()],
            ));
        }
        if !has(EffectKind::Viscous)
            && !has(EffectKind::Lugre)
            && !has(EffectKind::AsymmetricFriction)
        {
            cands.push((
                "viscous".into(),
                Some(EffectKind::Viscous),
                None,
                vec!["Fv".into()],
                vec![qd.clone()],
            ));
        }
        if !has(EffectKind::Offset) {
            cands.push((
                "offset".into(),
                Some(EffectKind::Offset),
                None,
                vec!["offset".into()],
                vec![vec![1.0; n]],
            ));
        }
        if !has(EffectKind::Stribeck) && !has(EffectKind::Lugre) {
            let vmax = qd.iter().fold(0.0f64, |a, v| a.max(v.abs())).max(1e-12);
            let mut best: Option<(f64, Vec<f64>, f64)> = None;
            for f in [0.003, 0.01, 0.03, 0.1, 0.3] {
                let vs = f * vmax;
                let col: Vec<f64> = qd
                    .iter()
                    .map(|&v| (-(v / vs).powi(2)).exp() * sign(v))
                    .collect();
                if let Some((_, sse)) = fit(std::slice::from_ref(&project(&col)), &e) {
                    if best.as_ref().is_none_or(|b| sse < b.2) {
                        best = Some((vs, col, sse));
                    }
                }
            }
            if let Some((vs, col, _)) = best {
                cands.push((
                    format!("stribeck (vs = {vs:.3e})"),
                    Some(EffectKind::Stribeck),
                    None,
                    vec!["Fs - Fc".into()],
                    vec![col],
                ));
            }
        }
        if !has(EffectKind::Spring) {
            cands.push((
                "spring".into(),
                Some(EffectKind::Spring),
                None,
                vec!["Ks".into(), "-Ks*qeq".into()],
                vec![q.clone(), vec![1.0; n]],
            ));
        }
        if !has(EffectKind::FrictionBias) {
            let mut sorted = q.clone();
            sorted.sort_by(f64::total_cmp);
            let mut best: Option<(f64, Vec<Vec<f64>>, f64)> = None;
            for f in [0.2, 0.35, 0.5, 0.65, 0.8] {
                let qeq = sorted[((n - 1) as f64 * f) as usize];
                let cols: Vec<Vec<f64>> = vec![
                    q.iter()
                        .zip(&qd)
                        .map(|(&x, &v)| if x < qeq { sign(v) } else { 0.0 })
                        .collect(),
                    q.iter()
                        .zip(&qd)
                        .map(|(&x, &v)| if x < qeq { v } else { 0.0 })
                        .collect(),
                ];
                let pc: Vec<Vec<f64>> = cols.iter().map(|c| project(c)).collect();
                if let Some((_, sse)) = fit(&pc, &e) {
                    if best.as_ref().is_none_or(|b| sse < b.2) {
                        best = Some((qeq, cols, sse));
                    }
                }
            }
            if let Some((qeq, cols, _)) = best {
                cands.push((
                    format!("friction_bias (qeq = {qeq:.4})"),
                    Some(EffectKind::FrictionBias),
                    None,
                    vec!["extra Fc below qeq".into(), "extra Fv below qeq".into()],
                    cols,
                ));
            }
        }
        for &k in joints.iter().filter(|&&k| k != j) {
            let other = rows_of(k);
            if other.len() == n {
                let y: Vec<f64> = other.iter().map(|&i| obs.y[i]).collect();
                cands.push((
                    format!("input_coupling from {}", m.joints[k]),
                    Some(EffectKind::InputCoupling),
                    Some(k),
                    vec!["G".into()],
                    vec![y],
                ));
            }
        }
        let nf = n as f64;
        let bic0 = nf * (sst / nf).ln();
        for (name, kind, from, symbols, cols) in cands {
            let cols: Vec<Vec<f64>> = cols.iter().map(|c| project(c)).collect();
            if cols.iter().all(|c| c.iter().all(|x| x.abs() < 1e-12)) {
                continue;
            }
            let Some((x, sse)) = fit(&cols, &e) else {
                continue;
            };
            let p = cols.len() as f64;
            let delta_bic = nf * (sse.max(1e-300) / nf).ln() + p * nf.ln() - bic0;
            let explained = 1.0 - sse / sst;
            out.push(Finding {
                joint: m.joints[j].to_string(),
                meaning: kind.map_or(String::new(), |k| k.meaning().to_string()),
                name,
                kind,
                from: from.map(|k| m.joints[k].to_string()),
                estimate: symbols.into_iter().zip(x).collect(),
                explained,
                delta_bic,
                significant: delta_bic < -10.0 && explained >= 0.05,
            });
        }
    }
    out.sort_by(|a, b| a.delta_bic.total_cmp(&b.delta_bic));
    Ok(out)
}

/// The ranking as text: the top `k` candidates and the verdict.
pub fn table(findings: &[Finding], k: usize) -> String {
    let mut s = format!(
        "{:<4} {:<6} {:<34} {:>10} {:>11}  {}\n",
        "rank", "joint", "candidate", "explained", "ΔBIC", "estimate"
    );
    for (r, f) in findings.iter().take(k).enumerate() {
        let est = f
            .estimate
            .iter()
            .map(|(n, v)| format!("{n} = {v:.4e}"))
            .collect::<Vec<_>>()
            .join(", ");
        s += &format!(
            "{:<4} {:<6} {:<34} {:>9.1}% {:>11.1}  {est}{}\n       {}\n",
            r + 1,
            f.joint,
            f.name,
            100.0 * f.explained,
            f.delta_bic,
            if f.significant {
                ""
            } else {
                "  (not significant)"
            },
            f.meaning
        );
    }
    match findings.first() {
        Some(f) if f.significant => s += &format!("most likely missing: {} on {}\n", f.name, f.joint),
        _ => s += "nothing significant is missing (no candidate has ΔBIC < -10 and explains >= 5 % of the residual)\n",
    }
    s
}
