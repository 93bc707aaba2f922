//! The earlier steps refitted on their own files after a later step
//! ([`SequenceOptions::earlier_information`]): the linear following
//! ([`EarlierInformation::following`]) is exact only to first order, and a later step that
//! moves a value an earlier step saw in a product or a square (c3 of the isolated method
//! moves z7, which c2 sees through m7·z7²) leaves that step's files off by the second-order
//! term. Where an earlier step's files then end above their own figure, the values only
//! they see are fitted once more on them ([`EarlierRefit`]); where the later step's files
//! see every value it fitted (c5 and c6 under c7), the steps are fitted again together
//! ([`joint_refit`]).

use super::*;
use crate::identify::output_error::{enters, Information};
use std::time::Instant;

/// An earlier step's files after a later step, and the refit of the values only they see
/// (after each step under [`SequenceOptions::earlier_information`]).
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct EarlierRefit {
    /// The earlier step's configuration.
    pub config: String,
    /// The values refitted (those of the earlier step's fitted values that the later
    /// step's files do not see).
    pub names: Vec<String>,
    /// The worst free joint's RMS / σ̂ on the earlier step's files (initial positions
    /// estimated): at that step's end, after the later step (with the linear following),
    /// and after this refit (None when it was not run or not kept).
    pub rms: (f64, f64, Option<f64>),
    /// Wall time (s).
    pub wall_s: f64,
    /// The earlier step's information at the refitted values (over the values its own
    /// information covers), which replaces its own in the later steps' priors; None where
    /// the refit was not kept or the information could not be formed.
    pub information: Option<Information>,
    /// Why the refit could not be fitted, when it could not.
    #[serde(default)]
    pub failure: Option<String>,
}

/// Step `st`'s information ([`Information`]) at `plant`'s values over the names of its own,
/// on its files (`problem`, the initial positions estimated; one central-difference
/// Jacobian); None where a value has no bounds or the statistics fail.
fn information_at(plant: &Plant, st: &StepReport, problem: &Problem) -> Option<Information> {
    let own = st.fit.statistics.information.as_ref()?;
    // Every value of its information as a fitted one: its columns are all simulated.
    let fitted = own.names.clone();
    let mut options = problem.options().clone();
    options.estimate_initial_positions = true;
    let at = Problem::new(
        plant,
        problem.configuration(),
        fitted,
        problem.records.clone(),
        &st.step.interest,
        options,
    )
    .ok()?
    .with_initial_positions_of(plant)
    .ok()?;
    let values: Vec<f64> = at.names.iter().map(|n| plant.parameters[n]).collect();
    let info = at.statistics(&values).ok()?.information?;
    // Only when it covers every value the step's own did.
    own.names
        .iter()
        .all(|n| info.names.contains(n))
        .then_some(info)
}

/// Whether the linear following `following` ((name, before, after) as [`run`] moved them
/// in `current`) leaves the earlier steps' files (`ran`, their reports in `reports`) no
/// further off than without it: the sum over the steps whose values it moved by more than
/// 1e-4 of themselves of the worst joint's RMS / σ̂ (a failed simulation counting as
/// infinite), with and without; and the checks of those steps with the plant kept (with
/// it where it helps), for [`refit_earlier_steps`] not to simulate them again. The following is exact to first order only, and over
/// directions an earlier step's files determine weakly (a short file, a weak excitation)
/// the pseudo-inverse can move values far: on 1 s of c1's J4 chirp, c2's moves took c1's
/// values where its file could not be simulated at all.
pub(super) fn following_helps(
    current: &Plant,
    following: &[(String, f64, f64)],
    ran: &[&(String, Problem)],
    reports: &[StepReport],
) -> (bool, Vec<FinalCheck>) {
    let large: Vec<&str> = following
        .iter()
        .filter(|(_, a, b)| (b - a).abs() > 1e-4 * a.abs().max(b.abs()))
        .map(|(n, ..)| n.as_str())
        .collect();
    if large.is_empty() {
        return (true, Vec::new());
    }
    let mut without = current.clone();
    for (n, old, _) in following {
        without.parameters.insert(n.clone(), *old);
    }
    let (mut with, mut with_out) = (Vec::new(), Vec::new());
    for (config, problem) in ran {
        let Some(st) = reports.iter().find(|d| d.step.config == *config) else {
            continue;
        };
        let sees = st
            .information()
            .is_some_and(|i| i.names.iter().any(|n| large.contains(&n.as_str())));
        if sees {
            with.extend(final_check(current, &[(st, problem)]));
            with_out.extend(final_check(&without, &[(st, problem)]));
        }
    }
    let sum = |checks: &[FinalCheck]| checks.iter().map(FinalCheck::worst).sum::<f64>();
    if sum(&with) <= sum(&with_out) {
        (true, with)
    } else {
        (false, with_out)
    }
}

/// A rise of an earlier step's worst RMS / σ̂ over its own end figure that is refitted:
/// 2 % (the noise floor's scatter between refits of the same files is below 1 %).
const RISE: f64 = 1.02;

/// After step `cname` (whose files see the values `enters` names), every step of `ran`
/// (the steps before it whose files are given; their reports in `reports`) whose files
/// the plant `current` no longer reproduces — the worst free joint's RMS / σ̂ above
/// [`RISE`] × its own end figure — has its fitted values that step `cname` does not see
/// fitted once more on its files, under the other steps' information (every other value
/// held); kept where the RMS falls (a refit whose files cannot be simulated is not). The
/// refits' values are set in `current`. `checked`: checks of some of those steps with
/// `current` already made ([`following_helps`]), not simulated again.
///
/// # Errors
/// A refit's problem cannot be set up, or its fit fails.
pub(super) fn refit_earlier_steps(
    current: &mut Plant,
    cname: &str,
    enters: &dyn Fn(&str) -> bool,
    ran: &[&(String, Problem)],
    reports: &[StepReport],
    checked: &[FinalCheck],
    progress: &(dyn Fn(&str, Progress) + Sync),
) -> Result<Vec<EarlierRefit>> {
    let mut out = Vec::new();
    for (config, problem) in ran {
        let Some(st) = reports.iter().find(|d| d.step.config == *config) else {
            continue;
        };
        let check = match checked.iter().find(|c| c.config == *config) {
            Some(c) => c.clone(),
            None => final_check(current, &[(st, problem)]).swap_remove(0),
        };
        let (own, now) = (check.worst_at_end(), check.worst());
        if now <= RISE * own {
            continue;
        }
        let names: Vec<String> = st
            .fit
            .names
            .iter()
            .filter(|n| !enters(n))
            .cloned()
            .collect();
        if names.is_empty() {
            out.push(EarlierRefit {
                config: config.clone(),
                names,
                rms: (own, now, None),
                wall_s: 0.0,
                information: None,
                failure: None,
            });
            continue;
        }
        let started = Instant::now();
        // The step's own stages (its growing horizons: from thousands of σ̂ the whole files
        // alone stall, as c2 after c3 of the isolated method did at 6.9e3), one start, the
        // initial positions estimated as the check above estimated them.
        let mut options = problem.options().clone();
        options.estimate_initial_positions = true;
        options.starts = 1;
        options.stribeck_reseed = false;
        options.least_change = false;
        let others = EarlierInformation::gather(
            reports
                .iter()
                .filter(|d| d.step.config != *config)
                .filter_map(StepReport::information),
            current,
        );
        let refit = Problem::new(
            current,
            problem.configuration(),
            names.clone(),
            problem.records.clone(),
            &st.step.interest,
            options,
        )
        .with_context(|| format!("step '{cname}': the refit of step '{config}'"))?;
        let refit = match others {
            Some(e) => refit.with_earlier_information(e)?,
            None => refit,
        };
        // A refit that cannot be fitted (its files cannot be simulated from this plant)
        // leaves the plant as it is: the final check reports the step.
        let fit = match refit.fit(&|p| progress(config, p)) {
            Ok(fit) => fit,
            Err(why) => {
                out.push(EarlierRefit {
                    config: config.clone(),
                    names,
                    rms: (own, now, None),
                    wall_s: started.elapsed().as_secs_f64(),
                    information: None,
                    failure: Some(format!("{why:#}")),
                });
                continue;
            }
        };
        let mut trial = current.clone();
        fit.apply(&mut trial);
        let after = final_check(&trial, &[(st, problem)])[0].worst();
        let kept = after < now;
        // The step's information where its values now are, over the values it had it for.
        let information = if kept {
            *current = trial;
            information_at(current, st, problem)
        } else {
            None
        };
        out.push(EarlierRefit {
            config: config.clone(),
            names,
            rms: (own, now, kept.then_some(after)),
            wall_s: started.elapsed().as_secs_f64(),
            information,
            failure: None,
        });
    }
    Ok(out)
}

/// The earlier steps `left_off` and every other step of `ran` ((configuration name, its
/// configuration, the values it fitted), in the plan's order) whose files see a value one
/// of them fitted, repeated until none is added, in `ran`'s order: the group whose files
/// the joint refit of `left_off` must hold ([`joint_refit`] keeps every value the files
/// outside its group see where it is).
///
/// Under the earlier information the steps outside are held by their information, and
/// `left_off` is the group. Without it ([`SequenceOptions::earlier_refit`] alone) nothing
/// else keeps what their files determined, and a step that still reproduces its files can
/// see every value the left-off one needs moved: after seed 11's coupled k5, k3's files at
/// 1.51 σ̂ and k4's at its own figure, k4's files see every value of k1..k3, so a group
/// without k4 could move only joint 0's values, which k3's files do not see, and did not
/// lower them (the sensitivities record, stop 89).
pub fn closed_over_seen_values(
    left_off: &[String],
    ran: &[(&str, &Configuration, &[String])],
    current: &Plant,
    occ: &Occurrence,
) -> Vec<String> {
    let mut group: Vec<&str> = ran
        .iter()
        .map(|(c, ..)| *c)
        .filter(|c| left_off.iter().any(|l| l == c))
        .collect();
    loop {
        let fitted: Vec<&String> = ran
            .iter()
            .filter(|(c, ..)| group.contains(c))
            .flat_map(|(.., names)| names.iter())
            .collect();
        let more: Vec<&str> = ran
            .iter()
            .filter(|(c, conf, _)| {
                !group.contains(c) && fitted.iter().any(|n| enters(current, occ, conf, n))
            })
            .map(|(c, ..)| *c)
            .collect();
        if more.is_empty() {
            break;
        }
        group.extend(more);
    }
    ran.iter()
        .map(|(c, ..)| *c)
        .filter(|c| group.contains(c))
        .map(str::to_string)
        .collect()
}

/// A later step fitted once more jointly with the earlier steps whose files it left off
/// although it fitted or saw every value they fitted ([`joint_refit`]).
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct JointRefit {
    /// The configurations fitted together, in the plan's order (the later step's last).
    pub configs: Vec<String>,
    /// The values fitted: every value those steps fitted, without those that the files of
    /// the plan's other steps see (they stay where those steps left them).
    pub names: Vec<String>,
    /// Per configuration: the worst free joint's RMS / σ̂ at the step's own end, before
    /// this refit, and after it (None when it was not run to the end or not kept).
    pub rms: Vec<(String, f64, f64, Option<f64>)>,
    /// Cost (sum over the configurations, every free joint weighted 1) before → after;
    /// None where the refit could not be fitted.
    pub cost: Option<(f64, f64)>,
    /// Cost evaluations.
    pub evaluations: usize,
    /// Jacobians.
    pub jacobians: usize,
    /// Wall time (s).
    pub wall_s: f64,
    /// Each step's information where the kept refit left its values (over the values its
    /// own information covers), which replaces its own in later steps' priors; empty
    /// where the refit was not kept.
    #[serde(default)]
    pub information: Vec<(String, Information)>,
    /// Why the refit could not be fitted, when it could not.
    #[serde(default)]
    pub failure: Option<String>,
    /// How the fit ended: its start's optimiser account of each round and the initial
    /// positions' rounds (`StartSummary::status`); empty where it could not be fitted.
    #[serde(default)]
    pub status: String,
}

impl JointRefit {
    /// Whether the refit's values were kept.
    pub fn kept(&self) -> bool {
        self.rms.iter().all(|r| r.3.is_some())
    }
}

/// After step `later` (its report and problem), the earlier steps `left_off` (their
/// configurations) whose files the plant `current` no longer reproduces although every
/// value they fitted enters `later`'s files, so that the refit of an earlier step's own
/// values has nothing of theirs to refit alone: `later`'s files and theirs fitted at once
/// ([`JointProblem`], every free joint weighted 1), on the values any of them fitted that
/// the files of the other steps of `ran` do not see. Kept where the worst of those steps'
/// worst free joints falls; then each step's information is formed again where its values
/// now are ([`StepReport::information_now`]). None where there is nothing to refit (no
/// step of `left_off` in `ran`, or every value is seen by another step's files).
///
/// Why: the earlier information carries an earlier step's cost to second order only. c7 of
/// the isolated method refits every value c5 and c6 fitted (joints 1 and 0 and the base's
/// links), and without this the written plant left their files above their own figures
/// (the sensitivities record, stops 84 and 85).
///
/// A refit that cannot be set up or fitted is reported ([`JointRefit::failure`]) and the
/// plant left as it was.
pub fn joint_refit(
    current: &mut Plant,
    later: (&StepReport, &Problem),
    left_off: &[String],
    ran: &[&(String, Problem)],
    reports: &[StepReport],
    occ: &Occurrence,
    progress: &(dyn Fn(&str, Progress) + Sync),
) -> Option<JointRefit> {
    let started = Instant::now();
    let mut group: Vec<(&StepReport, &Problem)> = ran
        .iter()
        .filter(|(c, _)| left_off.contains(c))
        .filter_map(|(c, p)| Some((reports.iter().find(|d| d.step.config == *c)?, p)))
        .collect();
    if group.is_empty() {
        return None;
    }
    group.push(later);
    let outside: Vec<&'static Configuration> = ran
        .iter()
        .filter(|(c, _)| !left_off.contains(c))
        .map(|(_, p)| p.configuration())
        .collect();
    let mut names: Vec<String> = Vec::new();
    let mut tied_held: Vec<String> = Vec::new();
    for (st, _) in &group {
        for n in &st.fit.names {
            if !names.contains(n) && !outside.iter().any(|c| enters(current, occ, c, n)) {
                names.push(n.clone());
            }
        }
        for n in &st.step.tied_held {
            if !tied_held.contains(n) {
                tied_held.push(n.clone());
            }
        }
    }
    names.retain(|n| !tied_held.contains(n));
    if names.is_empty() {
        return None;
    }
    // Checked again rather than taken from the earlier-step refits' checks: a refit of
    // another earlier step after those checks may have moved values these files see.
    let before = final_check(current, &group);
    let rms_before: Vec<(String, f64, f64)> = before
        .iter()
        .map(|c| (c.config.clone(), c.worst_at_end(), c.worst()))
        .collect();
    let worst = |checks: &[FinalCheck]| checks.iter().map(FinalCheck::worst).fold(0.0, f64::max);
    let mut options = later.1.options().clone();
    options.estimate_initial_positions = true;
    let files: Vec<(&'static Configuration, Vec<Record>)> = group
        .iter()
        .map(|(_, p)| (p.configuration(), p.records.clone()))
        .collect();
    let configs: Vec<String> = group.iter().map(|(st, _)| st.step.config.clone()).collect();
    let problem = JointProblem::new(current, names.clone(), tied_held, files, &options, occ);
    let label = format!("joint refit {}", configs.join("+"));
    let mut out = JointRefit {
        configs,
        names,
        rms: rms_before
            .iter()
            .map(|(c, e, n)| (c.clone(), *e, *n, None))
            .collect(),
        cost: None,
        evaluations: 0,
        jacobians: 0,
        wall_s: 0.0,
        information: Vec::new(),
        failure: None,
        status: String::new(),
    };
    // A refit that cannot be set up or fitted leaves the plant as it is: the final check
    // reports the steps.
    let fit = match problem.and_then(|p| p.fit(&|p| progress(&label, p))) {
        Ok(fit) => fit,
        Err(why) => {
            out.failure = Some(format!("{why:#}"));
            out.wall_s = started.elapsed().as_secs_f64();
            return Some(out);
        }
    };
    out.cost = Some((fit.cost_before, fit.cost_after));
    out.evaluations = fit.evaluations;
    out.jacobians = fit.jacobians;
    out.status = fit
        .starts
        .get(fit.best_start)
        .map(|st| st.status.clone())
        .unwrap_or_default();
    let mut trial = current.clone();
    fit.apply(&mut trial);
    let after = final_check(&trial, &group);
    if worst(&after) < worst(&before) {
        *current = trial;
        for (r, c) in out.rms.iter_mut().zip(&after) {
            r.3 = Some(c.worst());
        }
        out.information = group
            .iter()
            .filter_map(|(st, p)| Some((st.step.config.clone(), information_at(current, st, p)?)))
            .collect();
    }
    out.wall_s = started.elapsed().as_secs_f64();
    Some(out)
}
