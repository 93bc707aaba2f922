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

use super::output::{diagnose_output, OutputDiagnosis, OutputOptions};
use super::Finding;
use crate::identify::output_error::Record;
use crate::identify::refit::{refit, Refit, RefitOptions};
use crate::plant::Plant;
use anyhow::{anyhow, Result};

/// The parameters a refit after adding `finding` to `plant` fits, for data of
/// configuration `conf_name`: the finding's own, then those fitted by earlier changes on
/// the same configuration (the plant's history, oldest first) that the plant still has,
/// each once.
pub fn joint_refit_names(plant: &Plant, conf_name: &str, finding: &Finding) -> Vec<String> {
    let mut names = finding.parameter_names();
    for entry in plant
        .history
        .iter()
        .filter(|e| e.configuration == conf_name)
    {
        for name in entry.fitted.keys() {
            if plant.parameters.contains_key(name)
                && plant.bounds.contains_key(name)
                && !names.contains(name)
            {
                names.push(name.clone());
            }
        }
    }
    names
}

/// The history text of applying `finding`, e.g. "added spring on q3", "added
/// input_coupling from q5 to q4", "refitted gain (Kp off) on q2".
pub fn change_text(finding: &Finding) -> String {
    match (&finding.effect, &finding.from) {
        (Some(e), Some(from)) => format!("added {} from {from} to {}", e.kind, finding.joint),
        (Some(_), None) => format!("added {} on {}", finding.name, finding.joint),
        (None, _) => format!("refitted {} on {}", finding.name, finding.joint),
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
    let names = joint_refit_names(&changed, conf_name, finding);
    let mut r = refit(plant, &changed, conf_name, records, &names, options)?;
    let files: Vec<String> = records
        .iter()
        .map(|x| x.file.display().to_string())
        .collect();
    let entry = r.history(&change_text(finding), &files);
    r.plant.history.push(entry);
    Ok(r)
}

/// The most steps `diagnose --apply all-significant` keeps (the loop's preset): the
/// thesis's plants carry at most four effects per joint beyond the rigid body.
pub const MAX_APPLIED_STEPS: usize = 8;

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
    /// The leading finding is about the data's input, not the plant (its advice).
    InputAdvice(String),
    /// Applying the leading finding did not lower the summed squared RMS error of the free
    /// joints (the step is not kept).
    NoImprovement(String),
    /// The step limit (the number given) was reached with a significant finding left.
    StepLimit(usize),
}

impl std::fmt::Display for LoopEnd {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            LoopEnd::NothingMissing => write!(f, "nothing significant is missing"),
            LoopEnd::InputAdvice(a) => write!(f, "stopped at a finding about the input: {a}"),
            LoopEnd::NoImprovement(w) => {
                write!(
                    f,
                    "stopped: applying {w} did not lower the error (not kept)"
                )
            }
            LoopEnd::StepLimit(k) => {
                write!(f, "stopped after {k} steps with a significant finding left")
            }
        }
    }
}

/// The result of [`apply_all_significant`].
#[derive(Debug, Clone)]
pub struct AppliedLoop {
    /// The plant after the last kept step (the starting plant when none was kept).
    pub plant: Plant,
    /// The steps kept, in order.
    pub steps: Vec<LoopStep>,
    /// The diagnosis of the final plant.
    pub last: OutputDiagnosis,
    /// Why the loop stopped.
    pub end: LoopEnd,
}

/// `diagnose --apply all-significant`: diagnose `plant` on `records` of configuration
/// `conf_name`, apply the leading finding with a joint refit ([`apply_finding`]), and
/// repeat until nothing significant is missing, the leading finding is about the input,
/// a step does not lower the error, or `max_steps` steps were kept. `progress` sees each
/// kept step as it ends (a command prints the error after each).
///
/// # Errors
/// As [`diagnose_output`] and [`apply_finding`] (a refit that fails ends with the error).
pub fn apply_all_significant(
    plant: &Plant,
    conf_name: &str,
    records: &[Record],
    options: &OutputOptions,
    max_steps: usize,
    progress: &dyn Fn(&LoopStep),
) -> Result<AppliedLoop> {
    let mut current = plant.clone();
    let mut steps: Vec<LoopStep> = Vec::new();
    let refit_options = RefitOptions {
        max_iter: RefitOptions::default().max_iter,
        ..options.fit.clone()
    };
    loop {
        let d = diagnose_output(&current, conf_name, records, options)?;
        let top = d.findings.first().cloned().ok_or_else(|| {
            anyhow!("configuration '{conf_name}': the diagnosis has no candidates")
        })?;
        let end = if !top.significant {
            Some(LoopEnd::NothingMissing)
        } else if let (true, Some(a)) = (top.values.is_empty(), &top.advice) {
            Some(LoopEnd::InputAdvice(a.clone()))
        } else if steps.len() >= max_steps {
            Some(LoopEnd::StepLimit(max_steps))
        } else {
            None
        };
        if let Some(end) = end {
            return Ok(AppliedLoop {
                plant: current,
                steps,
                last: d,
                end,
            });
        }
        let r = apply_finding(&current, &top, conf_name, records, &refit_options)?;
        let energy = |v: &[(String, f64)]| v.iter().map(|x| x.1 * x.1).sum::<f64>();
        if energy(&r.after) >= energy(&r.before) {
            return Ok(AppliedLoop {
                plant: current,
                steps,
                last: d,
                end: LoopEnd::NoImprovement(format!("{} on {}", top.name, top.joint)),
            });
        }
        current = r.plant.clone();
        let step = LoopStep {
            finding: top,
            refit: r,
        };
        progress(&step);
        steps.push(step);
    }
}
