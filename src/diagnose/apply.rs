//! Acting on an output-space diagnosis: add a finding to the plant and refit, and the loop
//! that does so until nothing significant is missing.
//!
//! A finding's values come from a fit of its own parameters with everything else held. An
//! effect added earlier was fitted the same way, while the effect found now was still
//! missing, so its values carry the missing effect's share (a tendon coupling fitted in one
//! direction while the other was absent comes out 10–25 % off). [`apply_finding`]
//! therefore refits the new effect's parameters **jointly** with those of every change
//! recorded earlier on the same configuration (the plant's `[[history]]` entries), and
//! records the step in the history. [`apply_all_significant`] repeats diagnose → apply
//! until the leading finding is not significant, is about the data's input rather than
//! the plant, or stops lowering the error.

use super::output::{diagnose_output, quantile, OutputDiagnosis, OutputOptions};
use super::Finding;
use crate::effects::EffectKind;
use crate::identify::output_error::{Record, FLOOR_FACTOR};
use crate::identify::refit::{refit, Refit, RefitOptions};
use crate::plant::Plant;
use anyhow::{anyhow, Result};
use rayon::prelude::*;

/// The parameters a refit after adding `finding` to `plant` fits, for data of
/// configuration `conf_name`, each once and only where the plant gives it bounds
/// (lower < upper):
/// 1. the finding's own;
/// 2. those fitted by earlier changes on the same configuration (the plant's history,
///    oldest first) that the plant still has;
/// 3. the values the configuration determines: the parameters of every effect acting on
///    its free joints (friction laws, springs, biases, couplings between free joints; not
///    the plant gains, which set the scale the others are fitted in), and a set of the model's inertial symbols that spans its base parameters
///    ([`crate::identify::identifiability::spanning_symbols`]; the others trade with them
///    exactly here and stay held).
///
/// A plant file without bounds for 3 (the thesis's result tables) refits 1 and 2 only.
///
/// # Errors
/// Unknown configuration; the plant's barycentric parameters cannot be formed.
pub fn joint_refit_names(
    plant: &Plant,
    conf_name: &str,
    finding: &Finding,
    records: &[Record],
) -> Result<Vec<String>> {
    let mut names = finding.parameter_names();
    let earlier = plant
        .history
        .iter()
        .filter(|e| e.configuration == conf_name)
        .flat_map(|e| e.fitted.keys().cloned());
    let values = configuration_values(plant, conf_name, records)?;
    for n in earlier.chain(values) {
        if fittable(plant, &n) && !names.contains(&n) {
            names.push(n);
        }
    }
    Ok(names)
}

/// A parameter the plant has a value for and bounds (lower < upper) to refit it in.
fn fittable(plant: &Plant, name: &str) -> bool {
    plant.bounds.get(name).is_some_and(|&(lo, hi)| lo < hi) && plant.parameters.contains_key(name)
}

/// The values of `plant` that the data of configuration `conf_name` (`records`) determine
/// and that the plant gives bounds for (item 3 of [`joint_refit_names`]): the parameters of
/// every effect acting on its free joints except the plant gains, and a set of the model's
/// inertial symbols that spans the configuration's base parameters. Empty for a plant file
/// without bounds.
///
/// # Errors
/// Unknown configuration; the plant's barycentric parameters cannot be formed.
pub fn configuration_values(
    plant: &Plant,
    conf_name: &str,
    records: &[Record],
) -> Result<Vec<String>> {
    let conf = crate::util::configuration(plant.model, conf_name).map_err(|e| anyhow!("{e}"))?;
    let mut names: Vec<String> = Vec::new();
    // The plant gain is left out: scaling every gain and every torque-side value of a
    // joint together changes nothing, so the gains are the scale the others are fitted in.
    for e in plant
        .effects
        .iter()
        .filter(|e| e.acts_with(conf.free) && e.kind != EffectKind::Gain)
    {
        for name in e.parameter_names(plant.model.joints) {
            if fittable(plant, &name) && !names.contains(&name) {
                names.push(name);
            }
        }
    }
    for name in plant.expression_parameters_with(conf.free) {
        if fittable(plant, &name) && !names.contains(&name) {
            names.push(name);
        }
    }
    let rigid: Vec<String> = plant
        .model
        .inertial_symbols
        .iter()
        .map(|s| s.to_string())
        .filter(|s| fittable(plant, s))
        .collect();
    if !rigid.is_empty() {
        let width = |i: usize| {
            plant
                .bounds
                .get(&rigid[i])
                .map_or(1.0, |&(lo, hi)| (hi - lo).abs().max(1e-300))
        };
        let locked_at: Vec<Vec<f64>> = records.iter().map(|r| r.q_all.clone()).collect();
        let keep = crate::identify::identifiability::spanning_symbols(
            plant, conf, &rigid, &width, &locked_at,
        )?;
        for i in keep {
            if !names.contains(&rigid[i]) {
                names.push(rigid[i].clone());
            }
        }
    }
    Ok(names)
}

/// The history text of applying `finding`, e.g. "added spring on q3", "replaced coulomb
/// by stribeck on q5", "added input_coupling from q5 to q4", "refitted gain (Kp off) on
/// q2".
pub fn change_text(finding: &Finding) -> String {
    match (&finding.effect, &finding.from) {
        (Some(e), Some(from)) => format!("added {} from {from} to {}", e.kind, finding.joint),
        (Some(e), None) => match finding.replaces {
            Some(old) if e.kind == EffectKind::Lugre => format!(
                "replaced {old} (and viscous friction, now σ2) by {} on {}",
                finding.name, finding.joint
            ),
            Some(old) => format!("replaced {old} by {} on {}", finding.name, finding.joint),
            None => format!("added {} on {}", finding.name, finding.joint),
        },
        (None, _) => match &finding.expression {
            Some(x) => format!(
                "added {} on {} (user-defined effect {})",
                finding.name, finding.joint, x.name
            ),
            None => format!("refitted {} on {}", finding.name, finding.joint),
        },
    }
}

/// Add `finding` to `plant` and refit its parameters jointly with the earlier changes'
/// ([`joint_refit_names`]) by output error on `records` of configuration `conf_name`; the
/// returned plant carries the step as a new history entry.
///
/// # Errors
/// The finding is not a plant edit (an input-timing finding: its advice is the message),
/// the plant refuses the effect, or the refit fails ([`refit`]).
pub fn apply_finding(
    plant: &Plant,
    finding: &Finding,
    conf_name: &str,
    records: &[Record],
    options: &RefitOptions,
) -> Result<Refit> {
    let changed = finding.apply(plant)?;
    let names = joint_refit_names(&changed, conf_name, finding, records)?;
    // An equilibrium position is profiled first: the refit is run with it held at the
    // finding's value and at each quantile of the joint's measured motion (a spring's
    // rest angle trades with the gravity terms, and where it starts far off the joint
    // refit stops at a bound of the rigid-body values), and then released from the
    // lowest of those costs.
    let (starts, held) = equilibrium_starts(&changed, conf_name, finding, records)?;
    let profile: Vec<String> = names
        .iter()
        .filter(|n| Some(*n) != held.as_ref())
        .cloned()
        .collect();
    let mut r = if held.is_none() {
        escalated(options, |o| {
            refit(plant, &changed, conf_name, records, &names, o)
        })?
    } else {
        // The profile's refits go through the growing horizons only (the warm-ups, once per
        // start, would cost as much as the rest); the released refit takes `options`.
        let profiled = RefitOptions {
            warm_ups: false,
            ..options.clone()
        };
        if profile.is_empty() {
            // qeq is all there is to fit: refit it from every start, keep the lowest.
            let fits = starts
                .par_iter()
                .map(|start| refit(plant, start, conf_name, records, &names, &profiled))
                .collect();
            let mut r = lowest(fits)?;
            let entry = r.history(&change_text(finding), records);
            r.plant.history.push(entry);
            return Ok(r);
        }
        let fits: Vec<Result<Refit>> = starts
            .par_iter()
            .map(|start| refit(plant, start, conf_name, records, &profile, &profiled))
            .collect();
        let start = lowest(fits)?.plant;
        escalated(options, |o| {
            refit(plant, &start, conf_name, records, &names, o)
        })?
    };
    let entry = r.history(&change_text(finding), records);
    r.plant.history.push(entry);
    Ok(r)
}

/// `fit` through the growing horizons; where `options` asks for the warm-ups and that fit
/// ends above the noise on some joint ([`FLOOR_FACTOR`] × σ̂), again with them (they cost
/// as much again), keeping the lower cost.
///
/// # Errors
/// The first error of `fit`.
pub fn escalated(
    options: &RefitOptions,
    fit: impl Fn(&RefitOptions) -> Result<Refit>,
) -> Result<Refit> {
    let horizons = fit(&RefitOptions {
        warm_ups: false,
        ..options.clone()
    })?;
    let above = horizons
        .fit
        .statistics
        .joints
        .iter()
        .any(|j| j.noise > 0.0 && j.rms > FLOOR_FACTOR * j.noise);
    if !(options.warm_ups && above) {
        return Ok(horizons);
    }
    let warm = fit(options)?;
    Ok(if warm.fit.cost_after < horizons.fit.cost_after {
        warm
    } else {
        horizons
    })
}

/// Quantiles of a joint's measured motion where an equilibrium position is tried: the
/// diagnosis's grid ([`super::output`]) and the starts of its refit ([`apply_finding`]).
pub const EQUILIBRIUM_QUANTILES: [f64; 5] = [0.1, 0.3, 0.5, 0.7, 0.9];

/// The refit of `fits` with the lowest cost; the first error when none succeeded.
fn lowest(fits: Vec<Result<Refit>>) -> Result<Refit> {
    let mut best: Option<Refit> = None;
    let mut first_error = None;
    for f in fits {
        match f {
            Ok(f)
                if best
                    .as_ref()
                    .is_none_or(|b| f.fit.cost_after < b.fit.cost_after) =>
            {
                best = Some(f)
            }
            Ok(_) => {}
            Err(e) => {
                first_error.get_or_insert(e);
            }
        }
    }
    best.ok_or_else(|| first_error.unwrap_or_else(|| anyhow!("no start to refit from")))
}

/// The profile of an equilibrium position for a joint refit after `finding`: when the
/// finding sets one (`qeq_i`), `changed` (the finding applied) with it at the finding's
/// value and at each of [`EQUILIBRIUM_QUANTILES`] of joint i's measured positions in
/// `records` (clamped into its bounds; values within 1e-3 of the span of one already taken
/// are skipped), and its name; otherwise `changed` alone and None.
fn equilibrium_starts(
    changed: &Plant,
    conf_name: &str,
    finding: &Finding,
    records: &[Record],
) -> Result<(Vec<Plant>, Option<String>)> {
    let mut starts = vec![changed.clone()];
    let conf = crate::util::configuration(changed.model, conf_name).map_err(|e| anyhow!("{e}"))?;
    let Some(a) = conf
        .free
        .iter()
        .position(|&j| changed.model.joints[j] == finding.joint)
    else {
        return Ok((starts, None));
    };
    let name = crate::names::parameter("qeq", changed.model.joints[conf.free[a]]);
    let Some(&given) = finding
        .values
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, v)| v)
    else {
        return Ok((starts, None));
    };
    let q: Vec<f64> = records
        .iter()
        .flat_map(|r| r.q[a].iter().copied())
        .collect();
    if q.is_empty() {
        return Ok((starts, None));
    }
    let span = (quantile(&q, 1.0) - quantile(&q, 0.0)).max(1e-9);
    let (lo, hi) = changed
        .bounds
        .get(&name)
        .copied()
        .unwrap_or((f64::NEG_INFINITY, f64::INFINITY));
    let mut taken = vec![given];
    for f in EQUILIBRIUM_QUANTILES {
        let g = quantile(&q, f).clamp(lo, hi);
        if taken.iter().all(|t| (t - g).abs() > 1e-3 * span) {
            taken.push(g);
            let mut p = changed.clone();
            p.parameters.insert(name.clone(), g);
            starts.push(p);
        }
    }
    Ok((starts, Some(name)))
}

/// Whether refit `r` lowered the summed squared RMS error of the free joints.
fn lowered(r: &Refit) -> bool {
    let energy = |v: &[(String, f64)]| v.iter().map(|x| x.1 * x.1).sum::<f64>();
    energy(&r.after) < energy(&r.before)
}

/// The fewest steps `diagnose --apply all-significant` may keep (the loop's preset): the
/// thesis's plants carry at most four effects per joint beyond the rigid body.
pub const MAX_APPLIED_STEPS: usize = 8;

/// The most steps `diagnose --apply all-significant` keeps on a configuration with `nf` free
/// joints: three per joint (a friction law's two terms and one more effect), at least
/// [`MAX_APPLIED_STEPS`] (a six-joint arm without friction needs twelve).
pub fn max_applied_steps(nf: usize) -> usize {
    MAX_APPLIED_STEPS.max(3 * nf)
}

/// What [`apply_all_significant`] reports as it goes.
#[derive(Debug, Clone, Copy)]
pub enum Turn<'a> {
    /// A diagnosis of the plant as it is (before each step, and the last).
    Diagnosed(&'a OutputDiagnosis),
    /// A step kept: the finding applied and its joint refit.
    Applied(&'a LoopStep),
}

/// One turn of [`apply_all_significant`]: the finding applied and its refit.
#[derive(Debug, Clone)]
pub struct LoopStep {
    /// The leading finding of the diagnosis of the plant as it was.
    pub finding: Finding,
    /// The joint refit after adding it (its plant carries the history entry).
    pub refit: Refit,
}

/// Why [`apply_all_significant`] stopped.
#[derive(Debug, Clone, PartialEq)]
pub enum LoopEnd {
    /// The leading finding is not significant: nothing significant is missing.
    NothingMissing,
    /// No finding is significant, yet what is left is not noise (listed: joints above
    /// their noise, joints whose residual is not white): what is missing is outside the
    /// catalogue and the library, or the plant's values are far off.
    Unexplained(Vec<String>),
    /// The leading finding is about the data's input, not the plant (its advice).
    InputAdvice(String),
    /// Applying the leading finding did not lower the summed squared RMS error of the free
    /// joints (the step is not kept).
    NoImprovement(String),
    /// The step limit (the number given) was reached with a significant finding left.
    StepLimit(usize),
    /// Torque space: the leading finding (named) is an effect not linear in its parameters,
    /// which the inverse model's least squares cannot refit.
    NotLinear(String),
}

impl std::fmt::Display for LoopEnd {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            LoopEnd::NothingMissing => write!(f, "nothing significant is missing"),
            LoopEnd::Unexplained(j) => write!(
                f,
                "stopped: what is left is not noise ({}) but no candidate explains it",
                j.join("; ")
            ),
            LoopEnd::InputAdvice(a) => write!(f, "stopped at a finding about the input: {a}"),
            LoopEnd::NoImprovement(w) => {
                write!(
                    f,
                    "stopped: applying {w} did not lower the error enough (not kept)"
                )
            }
            LoopEnd::StepLimit(k) => {
                write!(f, "stopped after {k} steps with a significant finding left")
            }
            LoopEnd::NotLinear(w) => write!(
                f,
                "stopped at {w}: not linear in its parameters, so torque space cannot refit it (apply it in output space)"
            ),
        }
    }
}

/// The result of [`apply_all_significant`].
#[derive(Debug, Clone)]
pub struct AppliedLoop {
    /// The plant after the last kept step (the starting plant when none was kept), less the
    /// effects the loop added that its joint refits took back to no effect (`removed`).
    pub plant: Plant,
    /// The diagnosis of the starting plant.
    pub first: OutputDiagnosis,
    /// The steps kept, in order.
    pub steps: Vec<LoopStep>,
    /// Effects the loop added and then removed, with why: a later joint refit put their
    /// size back at its no-effect value within two standard errors (a stand-in for an
    /// effect found later, e.g. a friction bias taken up while two couplings were missing).
    pub removed: Vec<String>,
    /// The diagnosis of the final plant.
    pub last: OutputDiagnosis,
    /// Why the loop stopped.
    pub end: LoopEnd,
}

/// `diagnose --apply all-significant`: diagnose `plant` on `records` of configuration
/// `conf_name`, apply the leading finding with a joint refit ([`apply_finding`]), and
/// repeat until nothing significant is missing, the leading finding is about the input,
/// a step does not lower the error, or `max_steps` steps were kept. `progress` sees each
/// diagnosis and each kept step as they end (a command prints them).
///
/// # Errors
/// As [`diagnose_output`] and [`apply_finding`] (a refit that fails ends with the error).
pub fn apply_all_significant(
    plant: &Plant,
    conf_name: &str,
    records: &[Record],
    options: &OutputOptions,
    max_steps: usize,
    progress: &dyn Fn(Turn),
) -> Result<AppliedLoop> {
    let mut current = plant.clone();
    let mut steps: Vec<LoopStep> = Vec::new();
    let mut first: Option<OutputDiagnosis> = None;
    let refit_options = options.joint_refit();
    loop {
        let d = diagnose_output(&current, conf_name, records, options)?;
        progress(Turn::Diagnosed(&d));
        let top = d.findings.first().cloned().ok_or_else(|| {
            anyhow!("configuration '{conf_name}': the diagnosis has no candidates")
        })?;
        let end = if !top.significant && !d.left().is_empty() {
            Some(LoopEnd::Unexplained(d.left()))
        } else if !top.significant {
            Some(LoopEnd::NothingMissing)
        } else if let (true, Some(a)) = (top.values.is_empty(), &top.advice) {
            Some(LoopEnd::InputAdvice(a.clone()))
        } else if steps.len() >= max_steps {
            Some(LoopEnd::StepLimit(max_steps))
        } else {
            None
        };
        if let Some(end) = end {
            // The diagnosis refitted the configuration's values first; where that lowered
            // the error, the plant ends with them (a history entry). A finding is applied
            // to the plant as it was instead: values refitted without the effect carry
            // its share, and the joint refit starts better from the plant's own.
            if let Some(vr) = d.values_refit.as_ref().filter(|r| lowered(r)) {
                current = vr.plant.clone();
                let entry = vr.history("refitted the configuration's values", records);
                current.history.push(entry);
            }
            return Ok(finish(current, steps, first, d, end));
        }
        if first.is_none() {
            first = Some(d.clone());
        }
        let r = apply_finding(&current, &top, conf_name, records, &refit_options)?;
        if !lowered(&r) {
            let end = LoopEnd::NoImprovement(format!("{} on {}", top.name, top.joint));
            return Ok(finish(current, steps, first, d, end));
        }
        current = r.plant.clone();
        let step = LoopStep {
            finding: top,
            refit: r,
        };
        progress(Turn::Applied(&step));
        steps.push(step);
    }
}

/// The loop's result when it stops with `end` after `steps`, the last diagnosis `last`
/// (also the first when no step was kept): the stand-ins pruned ([`prune`]).
fn finish(
    current: Plant,
    steps: Vec<LoopStep>,
    first: Option<OutputDiagnosis>,
    last: OutputDiagnosis,
    end: LoopEnd,
) -> AppliedLoop {
    let (plant, removed) = prune(current, &steps);
    AppliedLoop {
        plant,
        first: first.unwrap_or_else(|| last.clone()),
        steps,
        removed,
        last,
        end,
    }
}

/// The value at which an added effect of `kind` has no effect on the plant, for its size
/// parameter `symbol` (None: no single such value, e.g. a friction law).
fn no_effect_value(kind: EffectKind, symbol: &str) -> Option<f64> {
    use EffectKind as K;
    match (kind, symbol) {
        (K::FrictionBias, "FrictionBias") | (K::Gain, "Kp") => Some(1.0),
        (K::Spring, "Ks")
        | (K::InputCoupling, "G")
        | (K::Coulomb, "Fc")
        | (K::Viscous, "Fv")
        | (K::Offset, "offset")
        | (K::Armature, "Ia")
        | (K::Backlash, "backlash") => Some(0.0),
        _ => None,
    }
}

/// The parameter that sizes `effect` and the value at which it has no effect (None for a
/// friction law); the kind's symbols name its parameters in order
/// ([`crate::effects::Effect::parameter_names`]).
fn no_effect_size(effect: &crate::effects::Effect, joints: &[&str]) -> Option<(String, f64)> {
    effect
        .kind
        .symbols()
        .iter()
        .zip(effect.parameter_names(joints))
        .find_map(|(symbol, n)| no_effect_value(effect.kind, symbol).map(|v| (n, v)))
}

/// Remove from `plant` the effects the loop's `steps` added whose size the last joint
/// refit that fitted it put within two standard errors of its no-effect value; each
/// removal is recorded in the plant's history and returned as text.
fn prune(mut plant: Plant, steps: &[LoopStep]) -> (Plant, Vec<String>) {
    let mut removed = Vec::new();
    for step in steps {
        let Some(effect) = step.finding.effect else {
            continue;
        };
        if step.finding.replaces.is_some() {
            continue;
        }
        let joints = plant.model.joints;
        let names = effect.parameter_names(joints);
        let Some((name, neutral)) = no_effect_size(&effect, joints) else {
            continue;
        };
        // The last refit that fitted the size: its value and standard error.
        let Some((value, se)) = steps.iter().rev().find_map(|s| {
            let f = &s.refit.fit;
            let i = f.names.iter().position(|n| *n == name)?;
            Some((f.fitted[i], f.statistics.std_err[i]))
        }) else {
            continue;
        };
        if !(se.is_finite() && (value - neutral).abs() <= 2.0 * se) {
            continue;
        }
        plant.effects.retain(|e| *e != effect);
        let still_used: Vec<String> = plant
            .effects
            .iter()
            .flat_map(|e| e.parameter_names(joints))
            .collect();
        for n in &names {
            if !still_used.contains(n) {
                plant.parameters.remove(n);
                plant.bounds.remove(n);
            }
        }
        let why = format!(
            "removed {} on {} (a later joint refit took it back to no effect: {name} = {value:.6e} ± {se:.1e}, no effect at {neutral})",
            effect.kind, step.finding.joint
        );
        plant.history.push(crate::plant::HistoryEntry {
            change: why.clone(),
            configuration: step.refit.fit.configuration.clone(),
            files: Vec::new(),
            fitted: Default::default(),
            rms_before: Default::default(),
            rms_after: Default::default(),
            space: None,
        });
        removed.push(why);
    }
    (plant, removed)
}

#[cfg(test)]
mod tests {
    use super::no_effect_size;
    use crate::effects::{Effect, EffectKind};

    /// A replacement's history text names what it replaced.
    #[test]
    fn a_replacement_is_recorded_as_one() {
        use super::super::Finding;
        let finding = |kind: EffectKind, replaces: Option<EffectKind>| Finding {
            effect: Some(Effect::on(kind, 5)),
            replaces,
            ..Finding::new(
                "q5",
                kind.to_string(),
                Some(kind),
                None,
                vec![],
                (0.0, 1.0, 1.0, 1),
            )
        };
        let text = |f: &Finding| super::change_text(f);
        assert_eq!(
            text(&finding(EffectKind::Lugre, Some(EffectKind::Stribeck))),
            "replaced stribeck (and viscous friction, now σ2) by lugre on q5"
        );
        assert_eq!(
            text(&finding(EffectKind::Stribeck, Some(EffectKind::Coulomb))),
            "replaced coulomb by stribeck on q5"
        );
        assert_eq!(
            text(&finding(EffectKind::Spring, None)),
            "added spring on q5"
        );
    }

    /// The size an added effect is pruned on, and its no-effect value.
    #[test]
    fn added_effects_have_their_no_effect_size_and_friction_laws_none() {
        let joints = ["q0", "q1", "q2", "q3", "q4", "q5"];
        let size = |e: Effect| no_effect_size(&e, &joints);
        assert_eq!(
            size(Effect::coupling(5, 4)),
            Some(("G_q5_to_q4".into(), 0.0))
        );
        assert_eq!(
            size(Effect::on(EffectKind::FrictionBias, 4)),
            Some(("FrictionBias_q4".into(), 1.0))
        );
        assert_eq!(
            size(Effect::on(EffectKind::Spring, 3)),
            Some(("Ks_q3".into(), 0.0))
        );
        assert_eq!(size(Effect::on(EffectKind::Stribeck, 5)), None);
        assert_eq!(size(Effect::on(EffectKind::Lugre, 5)), None);
    }
}
