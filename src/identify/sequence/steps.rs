//! The steps of a sequence run: which it fits, the report it starts from, the rigid-body
//! symbols each holds, and what a fitted step leaves in the plant for the next.

use super::*;

/// The steps a run fits, in the plan's order.
pub(super) struct Selection {
    /// The steps fitted one by one.
    pub(super) steps: Vec<Step>,
    /// The steps the joint fit covers (empty without one).
    pub(super) joint_steps: Vec<Step>,
    /// Every step of the sequence's plan, for the report's order.
    pub(super) plan_order: Vec<String>,
}

/// The steps of `opts.sequence` a run fits: up to `opts.only` (that one alone, or none
/// under the joint fit alone), without those `previous` completed under `--resume`.
///
/// # Errors
/// An unknown `--config` step; `--resume` without a report, or with nothing left.
pub(super) fn select_steps(
    plant: &Plant,
    opts: &SequenceOptions,
    occ: &Occurrence,
    previous: Option<&SequenceReport>,
) -> Result<Selection> {
    let mut steps = plan_with(plant, &opts.sequence, occ)?;
    let plan_order: Vec<String> = steps.iter().map(|s| s.config.clone()).collect();
    if let Some(only) = &opts.only {
        let Some(i) = steps.iter().position(|s| &s.config == only) else {
            bail!(
                "--config: sequence '{}' has no step '{only}' (its steps: {})",
                opts.sequence,
                config_list(&steps)
            );
        };
        steps.truncate(i + 1);
    }
    // The joint fit covers every step up to the last one run; the per-step fits, that one
    // alone under --config, none under --joint-fit only.
    let joint_steps: Vec<Step> = if opts.joint == JointFitMode::Off {
        Vec::new()
    } else {
        steps.clone()
    };
    match (&opts.only, opts.joint) {
        (_, JointFitMode::Only) => steps.clear(),
        (Some(_), _) => {
            steps.drain(..steps.len() - 1);
        }
        (None, _) => {}
    }
    if opts.resume {
        let Some(prev) = previous else {
            bail!(
                "--resume: {} holds no report of the '{}' sequence",
                opts.out.display(),
                opts.sequence
            );
        };
        steps.retain(|s| !prev.steps.iter().any(|d| d.step.config == s.config));
        if steps.is_empty() && (opts.joint == JointFitMode::Off || prev.joint.is_some()) {
            bail!(
                "--resume: every step of {} is already completed (steps {}); nothing to resume",
                opts.out.display(),
                prev.step_list()
            );
        }
    }
    Ok(Selection {
        steps,
        joint_steps,
        plan_order,
    })
}

/// The steps' configurations, e.g. "k1, k2".
pub(super) fn config_list(steps: &[Step]) -> String {
    steps
        .iter()
        .map(|s| s.config.as_str())
        .collect::<Vec<_>>()
        .join(", ")
}

/// The report a run starts from: `previous`'s completed steps but for those it runs again
/// (`steps`), and its joint fit unless this run makes one (`joint_steps`); with the files
/// not used and what reading did to the others (`ignored`, `data_notes`).
pub(super) fn starting_report(
    plant: &Plant,
    opts: &SequenceOptions,
    previous: Option<SequenceReport>,
    (steps, joint_steps): (&[Step], &[Step]),
    (ignored, data_notes): (Vec<String>, Vec<String>),
) -> SequenceReport {
    let rerun: Vec<&str> = steps.iter().map(|s| s.config.as_str()).collect();
    let (plant_name, kept, joint) = match previous {
        Some(p) => (
            p.plant,
            p.steps
                .into_iter()
                .filter(|d| !rerun.contains(&d.step.config.as_str()))
                .collect(),
            p.joint,
        ),
        None => (plant.name(), Vec::new(), None),
    };
    SequenceReport {
        sequence: opts.sequence.clone(),
        plant: plant_name,
        options: opts.fit.clone(),
        steps: kept,
        joint: if joint_steps.is_empty() { joint } else { None },
        ignored,
        data_notes,
        final_check: Vec::new(),
        moved_since: Vec::new(),
    }
}

/// Under [`RigidBodyFit::Spanning`]: step `s` fits only a set of its rigid-body symbols
/// that spans the configuration's base parameters where `first`'s files hold the locked
/// joints ([`spanning_symbols`]); the others are held at `current`'s values
/// (`s.tied_held`).
///
/// # Errors
/// The barycentric parameters of `current` cannot be formed (step named).
pub(super) fn hold_tied_symbols(current: &Plant, first: &Problem, s: &mut Step) -> Result<()> {
    let keep = spanning_symbols(
        current,
        first.configuration(),
        &s.fitted,
        &bound_width(current, &s.fitted),
        &first.locked_at(),
    )
    .with_context(|| format!("step '{}'", s.config))?;
    let inertial = current.model.inertial_symbols;
    let tied_held: Vec<String> = s
        .fitted
        .iter()
        .enumerate()
        .filter(|&(i, n)| inertial.contains(&n.as_str()) && !keep.contains(&i))
        .map(|(_, n)| n.clone())
        .collect();
    s.fitted.retain(|n| !tied_held.contains(n));
    s.carried.retain(|n| !tied_held.contains(n));
    s.tied_held = tied_held;
    Ok(())
}

/// Write a refined step (configuration `config`) into `current`: its fitted values, the
/// standard errors of what it fitted (a released value it could not determine keeps the one
/// it had), the plant-gain scale families ([`record_scale_families`]), and the
/// rigid-body symbols left undetermined for later steps (`tied_held`, and those it fitted
/// but did not call identifiable, but for released values).
pub(super) fn keep_step(
    current: &mut Plant,
    config: &str,
    undetermined: &mut Vec<String>,
    refined: &Refined,
    tied_held: &[String],
) {
    let (fit, released) = (&refined.fit, &refined.released);
    let prior_se: Vec<(String, f64)> = released
        .iter()
        .filter_map(|n| Some((n.clone(), current.standard_errors.get(n).copied()?)))
        .collect();
    fit.apply(current);
    undetermined.retain(|n| !fit.names.contains(n));
    for n in tied_held {
        if !undetermined.contains(n) {
            undetermined.push(n.clone());
        }
    }
    let inertial = current.model.inertial_symbols;
    for (i, n) in fit.names.iter().enumerate() {
        if inertial.contains(&n.as_str())
            && !fit.statistics.identifiable_given_scale(i)
            && !released.contains(n)
        {
            undetermined.push(n.clone());
        }
    }
    current.undetermined = undetermined.clone();
    record_standard_errors(current, &fit.names, &fit.statistics);
    record_scale_families(current, config, &fit.names, &fit.statistics);
    // A released value the step could not determine keeps the standard error it had: it
    // moved under that prior.
    for (n, se) in prior_se {
        current.standard_errors.entry(n).or_insert(se);
    }
}
