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
//! cable-drag spring q − qeq (columns q and 1); friction position bias \[q < qeq\]·(sign q̇, q̇)
//! (qeq on a grid of position quantiles); tendon input coupling j → i, y_j. A plant-gain
//! error is not a torque-space candidate: with every parameter of W refitted, scaling the
//! torque scales θ (its column y⊥ is the residual itself); it shows in output space. Refitting the plant's own parameters (W) is reported first as
//! "refit existing parameters" with the share of the residual it removes.
//!
//! Position-measured data go through [`super::output`] instead.
//!
//! [`apply_finding`] adds a finding whose effect is linear in its parameters and refits the
//! whole inverse model (IDIM-LS on the base parameters, [`refit_torque`]);
//! [`apply_all_significant`] repeats diagnosis and step until nothing significant is
//! missing.

use super::{fit, Finding, LoopEnd};
use crate::effects::{sign, Effect, EffectKind};
use crate::identify::idim::{observation, predict, IdimOptions, Observation};
use crate::identify::refit::{refit_torque, TorqueRefit};
use crate::measurement::Measurement;
use crate::plant::Plant;
use anyhow::{bail, Context, Result};
use nalgebra::{DMatrix, DVector};

/// A candidate before fitting: name, effect kind, source joint, symbols, signature columns.
type Candidate = (
    String,
    Option<EffectKind>,
    Option<usize>,
    Vec<String>,
    Vec<Vec<f64>>,
);

/// Rank the catalogue against the residual of `plant` on the prepared observation `obs`
/// (one record), per joint, best first.
///
/// # Errors
/// A parameter of the plant without value (from [`predict`]).
pub fn diagnose_torque(plant: &Plant, obs: &Observation) -> Result<Vec<Finding>> {
    diagnosis(plant, obs).map(|d| d.findings)
}

/// A torque-space diagnosis: the findings and what the residual shows that is not noise.
#[derive(Debug, Clone)]
pub struct TorqueDiagnosis {
    /// Candidates, best (lowest ΔBIC) first ([`diagnose_torque`]).
    pub findings: Vec<Finding>,
    /// Joints whose residual, with the plant's own parameters refitted (projected off the
    /// regressor), is not white ([`super::not_white`], each record a segment): with no
    /// significant finding, something is left that neither the catalogue nor the library
    /// explains ([`super::verdict`]).
    pub not_white: Vec<String>,
}

impl TorqueDiagnosis {
    /// The ranking (top `k`) and the verdict as text.
    pub fn table(&self, k: usize) -> String {
        super::table_with(&self.findings, k, &self.not_white)
    }
}

/// [`diagnose_torque`] with the whiteness of each joint's residual ([`TorqueDiagnosis`]).
///
/// # Errors
/// As [`diagnose_torque`].
pub fn diagnosis(plant: &Plant, obs: &Observation) -> Result<TorqueDiagnosis> {
    diagnosis_with(plant, obs, &[])
}

/// [`diagnosis`] with the user's candidates ([`super::candidates::columns`]: each with its
/// regressor columns, rows as `obs`), each fitted by least squares on every joint it acts
/// on, together with the plant's own parameters (projected as the catalogue's are).
///
/// # Errors
/// As [`diagnose_torque`].
pub fn diagnosis_with(
    plant: &Plant,
    obs: &Observation,
    user: &[super::candidates::CandidateColumns],
) -> Result<TorqueDiagnosis> {
    let yhat = predict(plant, obs)?;
    let m = plant.model;
    let mut out = Vec::new();
    let mut not_white = Vec::new();
    let by_joint = crate::identify::idim::rows_by_joint(obs);
    for (j, idx) in by_joint.iter().map(|(j, idx)| (*j, idx.clone())) {
        let n = idx.len();
        let e0: Vec<f64> = idx.iter().map(|&i| obs.y[i] - yhat[i]).collect();
        // The columns that act on this joint's rows (on a six-joint arm most parameters
        // and effects of the other joints do not: 73 columns, many zero, for the wrist's
        // rows; nalgebra's SVD of the whole block returned NaN vectors, measured).
        let active: Vec<usize> = (0..obs.w.ncols())
            .filter(|&c| idx.iter().any(|&i| obs.w[(i, c)] != 0.0))
            .collect();
        let pw = active.len();
        let wj = DMatrix::from_fn(n, pw, |r, c| obs.w[(idx[r], active[c])]);
        let w_svd = crate::util::svd(wj.clone()).with_context(|| {
            format!(
                "joint {}: the regressor of the plant's parameters is not finite or its decomposition did not converge",
                m.joints[j]
            )
        })?;
        let tol = 1e-12 * w_svd.singular_values.max();
        // (I − W W⁺) v: what refitting the plant's own parameters cannot explain.
        let project = |v: &[f64]| -> Vec<f64> {
            let b = DVector::from_column_slice(v);
            match w_svd.solve(&b, tol) {
                Ok(x) => (b - &wj * x).iter().copied().collect(),
                Err(_) => v.to_vec(),
            }
        };
        // A column projected, where the plant's own columns leave at least 1 % of its norm
        // (None: they span it).
        let unspanned = |v: &[f64]| -> Option<Vec<f64>> {
            let norm = |x: &[f64]| x.iter().map(|a| a * a).sum::<f64>().sqrt();
            let p = project(v);
            (norm(&p) > 1e-2 * norm(v)).then_some(p)
        };
        let e = project(&e0);
        let sst0: f64 = e0.iter().map(|x| x * x).sum();
        let sst: f64 = e.iter().map(|x| x * x).sum();
        if !(sst.is_finite() && sst0.is_finite()) {
            bail!(
                "joint {}: the torque residual is not finite (a parameter without a finite value, or a regressor column that is not finite at the data)",
                m.joints[j]
            );
        }
        if n < 10 || sst <= 0.0 || sst0 <= 0.0 {
            continue;
        }
        let segments: Vec<&[f64]> = {
            let mut s: Vec<&[f64]> = Vec::new();
            let mut start = 0;
            for k in 1..=n {
                if k == n || obs.rows[idx[k]].record != obs.rows[idx[k - 1]].record {
                    s.push(&e[start..k]);
                    start = k;
                }
            }
            s
        };
        if let Some(w) = super::not_white(m.joints[j], &segments) {
            not_white.push(w);
        }
        if 1.0 - sst / sst0 > 1e-6 {
            let mut f = Finding::new(
                m.joints[j],
                "refit existing parameters".into(),
                None,
                None,
                vec![],
                (sst, sst0, n as f64, pw),
            );
            f.significant = f.explained >= 0.05;
            f.meaning = "the plant's own parameters are not at their least-squares values: refit (identify) before adding effects".into();
            out.push(f);
        }
        let q: Vec<f64> = idx.iter().map(|&i| obs.rows[i].q).collect();
        let qd: Vec<f64> = idx.iter().map(|&i| obs.rows[i].qd).collect();
        let has = |k: EffectKind| plant.has_effect(j, k);
        // (name, kind, from, symbols, columns)
        let mut cands: Vec<Candidate> = Vec::new();
        // The rest angle of the friction-bias candidate, from its grid.
        let mut bias_qeq: Option<f64> = None;
        if plant.friction_law(j).is_none() {
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
        // Armature: a q̈ column, where the plant's own columns leave 1 % of it (a joint
        // whose inertia is one free constant, as EMPS's mass, spans it: Ia is not separate
        // from that constant there).
        if !has(EffectKind::Armature) {
            let qdd: Vec<f64> = idx.iter().map(|&i| obs.rows[i].qdd).collect();
            if unspanned(&qdd).is_some() {
                cands.push((
                    "armature".into(),
                    Some(EffectKind::Armature),
                    None,
                    vec!["Ia".into()],
                    vec![qdd],
                ));
            }
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
                bias_qeq = Some(qeq);
                cands.push((
                    format!("friction_bias (qeq = {qeq:.4})"),
                    Some(EffectKind::FrictionBias),
                    None,
                    vec!["extra Fc below qeq".into(), "extra Fv below qeq".into()],
                    cols,
                ));
            }
        }
        for (k, other) in by_joint.iter().filter(|(k, _)| *k != j) {
            let k = *k;
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
        for (u, columns) in user
            .iter()
            .filter(|(u, _)| u.spec.joints.iter().any(|x| x == m.joints[j]))
        {
            let cols: Vec<Vec<f64>> = columns
                .iter()
                .map(|c| project(&idx.iter().map(|&i| c[i]).collect::<Vec<_>>()))
                .collect();
            if cols.iter().all(|c| c.iter().all(|x| x.abs() < 1e-12)) {
                continue;
            }
            if let Some((x, sse)) = fit(&cols, &e) {
                let mut f = u.finding(x.as_slice(), (sse, sst, n as f64));
                f.joint = m.joints[j].to_string();
                out.push(f);
            }
        }
        for (name, kind, from, symbols, cols) in cands {
            let cols: Vec<Vec<f64>> = cols.iter().map(|c| project(c)).collect();
            if cols.iter().all(|c| c.iter().all(|x| x.abs() < 1e-12)) {
                continue;
            }
            let Some((x, sse)) = fit(&cols, &e) else {
                continue;
            };
            let mut f = Finding::new(
                m.joints[j],
                name,
                kind,
                from.map(|k| m.joints[k].to_string()),
                symbols.into_iter().zip(x.iter().copied()).collect(),
                (sse, sst, n as f64, cols.len()),
            );
            // The plant edit, where the inverse-model coefficients map onto the effect's
            // parameters: τ = … + Fc sign q̇ + Fv q̇ + offset + Ks (q − qeq); the command
            // of a coupled joint reaching joint j lowers the torque j needs, c = −G.
            let effect = match (kind, from) {
                (Some(EffectKind::InputCoupling), Some(k)) => Some(Effect::coupling(k, j)),
                (Some(k), None) => Some(Effect::on(k, j)),
                _ => None,
            };
            let values: Option<Vec<f64>> = match kind {
                Some(
                    EffectKind::Coulomb
                    | EffectKind::Viscous
                    | EffectKind::Offset
                    | EffectKind::Armature,
                ) => Some(vec![x[0]]),
                Some(EffectKind::Spring) if x[0].abs() > 0.0 => Some(vec![x[0], -x[1] / x[0]]),
                Some(EffectKind::InputCoupling) => Some(vec![-x[0]]),
                // The extra friction below qeq as a factor on the joint's own: FrictionBias =
                // 1 + ΔFc/Fc (or ΔFv/Fv without Coulomb friction), qeq from the grid; the
                // refit then fits both by variable projection.
                Some(EffectKind::FrictionBias) => bias_qeq.and_then(|qeq| {
                    let own = |s: &str| {
                        plant
                            .parameters
                            .get(&crate::names::parameter(s, plant.model.joints[j]))
                            .copied()
                            .filter(|v| *v > 0.0)
                    };
                    let b = match (own("Fc"), own("Fv")) {
                        (Some(fc), _) => 1.0 + x[0] / fc,
                        (None, Some(fv)) => 1.0 + x[1] / fv,
                        _ => return None,
                    };
                    (b > 0.0).then_some(vec![b, qeq])
                }),
                _ => None,
            };
            // A spring whose rest angle lies outside the motion acts here as an offset plus a
            // stiffness: the data cannot say it is a spring (it is listed, not proposed).
            if let (Some(EffectKind::Spring), Some(v)) = (kind, &values) {
                let (lo, hi) = q
                    .iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
                        (a.min(x), b.max(x))
                    });
                if !(lo..=hi).contains(&v[1]) {
                    f.significant = false;
                    f.meaning = format!(
                        "{}; its rest angle {:.4} lies outside the motion [{lo:.4}, {hi:.4}], so these data see an offset plus a stiffness, not a spring",
                        f.meaning, v[1]
                    );
                }
            }
            if let (Some(e), Some(v)) = (effect, values) {
                f.values = e
                    .parameter_names(plant.model.joints)
                    .into_iter()
                    .zip(v)
                    .collect();
                f.bounds = f
                    .values
                    .iter()
                    .map(|&(_, v)| super::bounds_about(v, 1.0))
                    .collect();
                f.effect = Some(e);
            }
            out.push(f);
        }
        // Structure outside the catalogue: the projected residual's sparse model on the
        // joint's own library terms, projected too ([`super::structure`]); linear in its
        // coefficients, so the refit of `--apply` fits it with the rest.
        let lib = super::structure::library(j, &[j], m.joints);
        let texts: Vec<String> = lib.iter().map(|t| t.text.clone()).collect();
        let lead: Vec<bool> = lib.iter().map(|t| !t.catalogued).collect();
        // The joint's torque at the rows for τ in a term: the model's, not the measured
        // one, whose noise a term such as |τ| sign(q̇) would carry into its column (18.7 %
        // of the truth's residual "explained" on EMPS-like data, measured).
        let tau: Vec<f64> = idx.iter().map(|&i| yhat[i]).collect();
        let cols: Vec<Vec<f64>> = lib
            .iter()
            .map(|t| {
                let v: Vec<f64> = (0..n)
                    .map(|r| t.value(&[j], &[q[r]], &[qd[r]], &[tau[r]]))
                    .collect();
                // A term the plant's columns already span (its viscous q̇) projects to
                // what differs between the term at the decimated rows and the column
                // decimated through the filter — which normalised fits the filter's own
                // residual (a q̇ "explaining" 17 % of EMPS's truth data): left out when
                // 99 % of it is spanned.
                unspanned(&v).unwrap_or_else(|| vec![0.0; v.len()])
            })
            .collect();
        // Only where no significant catalogued effect explains STRUCTURE_SEARCH_BELOW of
        // the joint's residual (what it leaves is searched once it is added).
        let catalogue_suffices = out.iter().any(|f| {
            f.joint == m.joints[j]
                && f.significant
                && (f.kind.is_some() || f.expression.is_some())
                && f.explained >= super::STRUCTURE_SEARCH_BELOW
        });
        if catalogue_suffices {
            continue;
        }
        // The built-ins the terms span ([`super::structure::Named`]), the best significant
        // one, linear in its parameters (the cubic's centre held at its estimate, its
        // column (q − qc)³ fitted as it is).
        let span = q.iter().fold(f64::NEG_INFINITY, |a, &b| a.max(b))
            - q.iter().fold(f64::INFINITY, |a, &b| a.min(b));
        let named = super::structure::named_fits(j, &e, &cols, &texts, span)
            .into_iter()
            .filter_map(|(named, c, _)| {
                let effect = named.effect(j, m.joints, &c, true)?;
                if plant.expressions.iter().any(|x| x.name == effect.name)
                    || effect
                        .parameters
                        .iter()
                        .any(|p| plant.parameters.contains_key(p))
                {
                    return None;
                }
                let columns: Vec<Vec<f64>> = match named {
                    super::structure::Named::CubicStiffness => {
                        let qc = -c[1] / (3.0 * c[0]);
                        vec![project(
                            &q.iter().map(|x| (x - qc).powi(3)).collect::<Vec<_>>(),
                        )]
                    }
                    _ => named
                        .terms(j)
                        .iter()
                        .filter_map(|t| texts.iter().position(|x| x == t))
                        .map(|i| cols[i].clone())
                        .collect(),
                };
                let (x, sse) = fit(&columns, &e)?;
                let mut f = Finding::new(
                    m.joints[j],
                    named.name(),
                    None,
                    None,
                    effect
                        .parameters
                        .iter()
                        .cloned()
                        .zip(x.iter().copied())
                        .collect(),
                    (sse, sst, n as f64, x.len()),
                );
                f.meaning = named.meaning().to_string();
                f.values = f.estimate.clone();
                f.bounds = f
                    .values
                    .iter()
                    .map(|&(_, v)| super::bounds_about(v, 1.0))
                    .collect();
                f.expression = Some(crate::plant::ExpressionSpec {
                    name: effect.name,
                    joints: vec![m.joints[j].to_string()],
                    torque: effect.torque,
                    parameters: effect.parameters,
                });
                Some(f)
            })
            .filter(|f| f.significant)
            .min_by(|a, b| a.delta_bic.total_cmp(&b.delta_bic));
        out.extend(named);
        if let Some(st) = super::structure::sparse_model(j, &e, &[n], &cols, (&texts, &lead))
            .filter(|st| st.significant())
        {
            out.push(Finding::of_structure(plant, &st, (sst, n), 1.0));
        }
    }
    super::refuse_unphysical_signs(&mut out);
    super::sort_findings(&mut out);
    super::prefer_the_catalogue(&mut out);
    Ok(TorqueDiagnosis {
        findings: out,
        not_white,
    })
}

/// Add `finding` (from [`diagnose_torque`]) to `plant` and refit in torque space
/// ([`refit_torque`]: every parameter of the inverse model, one linear least squares); the
/// returned plant carries the step as a history entry.
///
/// # Errors
/// The finding is not a plant edit; its effect is not linear in its parameters (named:
/// such effects are added and refitted in output space); as [`refit_torque`].
pub fn apply_finding(
    plant: &Plant,
    finding: &Finding,
    conf_name: &str,
    records: &[Measurement],
    options: &IdimOptions,
) -> Result<TorqueRefit> {
    if let Some(e) = finding.effect.filter(|e| !e.kind.in_torque_space()) {
        bail!(
            "'{}' on {}: torque space refits the effects linear in their parameters, springs, \
             Stribeck and LuGre friction and the friction bias, not a {}; apply it in output \
             space (position data), or add it with `effect add` and fixed values",
            finding.name,
            finding.joint,
            e.kind
        );
    }
    let changed = finding.apply(plant)?;
    let mut r = refit_torque(plant, &changed, conf_name, records, options)?;
    let entry = r.history(&super::apply::change_text(finding), conf_name, records);
    r.plant.history.push(entry);
    Ok(r)
}

/// One turn of [`apply_all_significant`], as it ends.
#[derive(Debug)]
pub enum Turn<'a> {
    /// A diagnosis of the plant as it is (all records together; before each step, and the
    /// last).
    Diagnosed(&'a TorqueDiagnosis),
    /// A step kept: the finding applied and the refit.
    Applied(&'a Finding, &'a TorqueRefit),
}

/// The result of [`apply_all_significant`].
#[derive(Debug, Clone)]
pub struct AppliedLoop {
    /// The plant after the last kept step (the starting plant's values refitted first when
    /// they were not at their least-squares values).
    pub plant: Plant,
    /// The diagnosis of the starting plant.
    pub first: Vec<Finding>,
    /// The steps kept, in order: the finding (None for the refit of the plant's own
    /// values) and its refit.
    pub steps: Vec<(Option<Finding>, TorqueRefit)>,
    /// The diagnosis of the final plant.
    pub last: Vec<Finding>,
    /// Why the loop stopped.
    pub end: LoopEnd,
}

/// The least relative fall of the summed squared RMS torque error for which
/// [`apply_all_significant`] keeps a step (1 %): on real data a candidate can be
/// significant by ΔBIC over a thousand rows yet change the error by a few parts in ten
/// thousand (a coupled rotor between joints no motor couples, absorbing what the model lacks
/// elsewhere); such a step is declined and the next finding tried.
pub const MIN_STEP_GAIN: f64 = 0.01;

/// `diagnose --apply all-significant` in torque space: diagnose `plant` on all `records`
/// of configuration `conf_name` together (beside the user's `candidates`), and while the leading plant edit is significant,
/// apply it and refit ([`apply_finding`]). When the plant's own parameters are not at their
/// least-squares values ("refit existing parameters" significant), they are refitted first,
/// as a step of its own. Stops when nothing significant is missing, when the leading
/// finding's effect is not linear in its parameters ([`LoopEnd::NotLinear`]), when a step
/// does not lower the summed squared RMS residual (not kept), or after `max_steps` steps.
///
/// # Errors
/// As [`observation`], [`diagnose_torque`] and [`refit_torque`].
pub fn apply_all_significant(
    plant: &Plant,
    conf_name: &str,
    records: &[Measurement],
    (options, candidates): (&IdimOptions, &[super::candidates::UserCandidate]),
    max_steps: usize,
    progress: &dyn Fn(Turn),
) -> Result<AppliedLoop> {
    let conf = crate::util::configuration(plant.model, conf_name)?;
    let diagnosed = |p: &Plant| -> Result<TorqueDiagnosis> {
        let obs = observation(p, conf_name, records, options)?;
        let (mut user, _) = super::candidates::columns(candidates, p, conf_name, records, options)?;
        let builtin = super::candidates::coupled_motor_candidates(p, conf);
        user.extend(super::candidates::columns_together(
            &builtin, p, conf_name, records, options,
        )?);
        let d = diagnosis_with(p, &obs, &user)?;
        progress(Turn::Diagnosed(&d));
        Ok(d)
    };
    let squared = |rms: &[(String, f64)]| rms.iter().map(|(_, e)| e * e).sum::<f64>();
    let mut current = plant.clone();
    let mut steps: Vec<(Option<Finding>, TorqueRefit)> = Vec::new();
    let mut d = diagnosed(&current)?;
    let first = d.findings.clone();
    if let Some(refit_values) = d
        .findings
        .iter()
        .find(|f| f.significant && f.values.is_empty() && f.kind.is_none())
        .cloned()
    {
        let mut r = refit_torque(&current, &current, conf_name, records, options)?;
        let entry = r.history("refitted the configuration's values", conf_name, records);
        r.plant.history.push(entry);
        progress(Turn::Applied(&refit_values, &r));
        current = r.plant.clone();
        steps.push((None, r));
        d = diagnosed(&current)?;
    }
    let nothing = |d: &TorqueDiagnosis| {
        if d.not_white.is_empty() {
            LoopEnd::NothingMissing
        } else {
            LoopEnd::Unexplained(d.not_white.clone())
        }
    };
    // Findings whose step did not lower the error by MIN_STEP_GAIN: not kept, and the
    // next significant finding is tried instead.
    let mut declined: Vec<String> = Vec::new();
    let key = |f: &Finding| format!("{} on {}", f.name, f.joint);
    let end = loop {
        // A catalogue effect, or a candidate's (the user's or a built-in coupled motor):
        // the sparse regression's structure is shown, never added without the user.
        let edit = |f: &&Finding| {
            (f.effect.is_some() || (f.expression.is_some() && !f.structure))
                && !declined.contains(&key(f))
        };
        // The leading significant edit (a listed but unproposed finding — a spring whose
        // rest angle lies outside the motion — does not stop the search).
        let Some(top) = d
            .findings
            .iter()
            .filter(edit)
            .find(|f| f.significant)
            .cloned()
        else {
            break if declined.is_empty() {
                nothing(&d)
            } else {
                LoopEnd::NoImprovement(declined.join(", "))
            };
        };
        if top.effect.is_some_and(|e| !e.kind.in_torque_space()) {
            break LoopEnd::NotLinear(format!("{} on {}", top.name, top.joint));
        }
        if steps.iter().filter(|(f, _)| f.is_some()).count() >= max_steps {
            break LoopEnd::StepLimit(max_steps);
        }
        let r = apply_finding(&current, &top, conf_name, records, options)?;
        if squared(&r.after) > (1.0 - MIN_STEP_GAIN) * squared(&r.before) {
            declined.push(key(&top));
            continue;
        }
        progress(Turn::Applied(&top, &r));
        current = r.plant.clone();
        steps.push((Some(top), r));
        d = diagnosed(&current)?;
    };
    Ok(AppliedLoop {
        plant: current,
        first,
        steps,
        last: d.findings,
        end,
    })
}
