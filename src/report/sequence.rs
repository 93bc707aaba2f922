//! The Markdown report of a locking sequence (`report.md` beside `plant.toml` and
//! `report.json`): per step its files, weights, costs, time and evaluations, the parameters
//! with standard errors and identifiability, the fit per joint, and the refinements.

use crate::identify::output_error::{
    FitResult, JacobianMethod, OutputErrorOptions, SENSITIVITIES_FROM,
};
use crate::identify::sequence::*;
use generated::Model;
use std::fmt::Write as _;

/// "name ± σ" for every (name, σ) of `values`, comma-separated.
fn plus_minus(values: &[(String, f64)]) -> String {
    values
        .iter()
        .map(|(n, se)| format!("{n} ± {}", fmt_g(*se)))
        .collect::<Vec<_>>()
        .join(", ")
}

/// An RMS / σ̂ ratio to two decimals, "—" where the files give no σ̂.
fn fmt_ratio(r: Option<f64>) -> String {
    r.map_or_else(|| "—".into(), |r| format!("{r:.2}"))
}

fn fmt_g(x: f64) -> String {
    if x == 0.0 {
        "0".into()
    } else if !x.is_finite() {
        format!("{x}")
    } else if (1e-3..1e4).contains(&x.abs()) {
        format!("{x:.5}")
    } else {
        format!("{x:.4e}")
    }
}

/// The report as Markdown: per step, files, weights, cost before and after, time and
/// evaluations, parameters with standard errors and identifiability, fit per joint.
pub fn markdown(report: &SequenceReport, model: &Model) -> String {
    let mut s = String::new();
    let o = &report.options;
    // The CLI's name of the scheme ("rk4", "etdrk4"), as the field writes it.
    let integrator = |i: crate::simulation::Integrator| i.to_string().to_uppercase();
    let mut simulation = format!("{} step {:.6e} s", integrator(o.integrator), o.h);
    if let (Some((h, i)), false) = (o.predictor_step, o.predictor.is_empty()) {
        let _ = write!(
            simulation,
            " (the predictor's stages: {} step {h:.6e} s)",
            integrator(i)
        );
    }
    if !o.predictor.is_empty() {
        let _ = write!(
            simulation,
            "; the predictor's stages by the {} method",
            o.predictor_optimiser
        );
    }
    let _ = write!(
        simulation,
        "; the whole files' stage by the {} method",
        o.whole_files_optimiser
    );
    let fresh = match o.jacobian {
        JacobianMethod::Differences => "by finite differences".to_string(),
        JacobianMethod::Sensitivities => {
            "by sensitivities (finite differences where they do not apply)".to_string()
        }
        JacobianMethod::Auto => format!(
            "by sensitivities from {SENSITIVITIES_FROM} fitted values (finite differences for fewer or where they do not apply)"
        ),
    };
    if o.jacobian_refresh > 1 {
        let _ = write!(
            simulation,
            "; a Jacobian {fresh} at most every {} iterations, Broyden's update between",
            o.jacobian_refresh
        );
    } else {
        let _ = write!(simulation, "; a Jacobian {fresh} at every iteration");
    }
    let _ = writeln!(
        s,
        "# Output-error identification: {} method\n\nPlant: `{}`. Cost: {}; joint of interest weighted {}; {}; stop at relative step < {:e} or relative cost decrease < {:e}; {} start(s).\n",
        report.sequence,
        report.plant,
        match o.weighting {
            crate::identify::output_error::TimeWeighting::HalfFirst =>
                "(4.2), first half of each file weighted ½".to_string(),
            crate::identify::output_error::TimeWeighting::SkipTransient(n) =>
                format!("(4.3), first {n} samples skipped"),
        },
        o.interest_weight,
        simulation,
        o.xtol,
        o.ftol,
        o.starts
    );
    for st in &report.steps {
        step_markdown(&mut s, st, o, model, false);
    }
    if let Some(st) = &report.joint {
        let _ = writeln!(
            s,
            "The joint fit refines every parameter of the steps above on all their files at once, from the values the steps left: its standard errors and identifiable calls are those of all the data, where each step's are conditional on the values earlier steps fixed. The plant written holds its values.\n"
        );
        step_markdown(&mut s, st, o, model, true);
    }
    if !report.final_check.is_empty() {
        final_check_markdown(&mut s, &report.final_check);
        moved_since_markdown(&mut s, &report.moved_since);
    }
    if !report.ignored.is_empty() {
        let _ = writeln!(s, "## Files not used\n");
        for i in &report.ignored {
            let _ = writeln!(s, "- {i}");
        }
    }
    if !report.data_notes.is_empty() {
        let _ = writeln!(s, "\n## How the files were read\n");
        for n in &report.data_notes {
            let _ = writeln!(s, "- {n}");
        }
    }
    s
}

/// The section of [`markdown`] on the written plant with every step's files
/// ([`SequenceReport::final_check`]).
fn final_check_markdown(s: &mut String, checks: &[FinalCheck]) {
    let ratio = |r: Option<f64>| r.map_or_else(|| "–".to_string(), |r| format!("{r:.2}"));
    let _ = writeln!(
        s,
        "## The written plant on every step's files\n\nEach step's files simulated with the plant this run wrote, the initial positions estimated (as MATLAB `compare`); RMS / σ̂ over the samples the cost weighs.\n\n| step | joint | at the step's end | with the written plant |\n|---|---|---|---|"
    );
    for c in checks {
        for (joint, end, written) in &c.joints {
            let _ = writeln!(
                s,
                "| {} | {joint} | {} | {} |",
                c.config,
                ratio(*end),
                ratio(*written)
            );
        }
    }
    let _ = writeln!(s);
    for c in checks.iter().filter(|c| c.failure.is_some()) {
        let _ = writeln!(
            s,
            "{}: the written plant cannot simulate its files: {}.\n",
            c.config,
            c.failure.as_deref().unwrap_or_default()
        );
    }
    let above: Vec<&str> = checks
        .iter()
        .filter(|c| c.above_floor())
        .map(|c| c.config.as_str())
        .collect();
    if !above.is_empty() {
        let _ = writeln!(
            s,
            "**The written plant does not reproduce the files of {}** (a joint above {} σ̂): later steps moved values these files determine only in combination with others (symbols carried because a step did not call them identifiable, the held ties and plant-gain families a least change scales). Under `--earlier-information on` the values only these files see follow such moves and are refitted on them, and under `--earlier-refit on` (after the last step) they are refitted, jointly with the steps whose files see them where needed; what remains is what those refits could not bring back. The joint fit (`--joint-fit after`) fits every step's files at once; from a plant this far off it can stop in a local minimum.\n",
            above.join(", "),
            crate::identify::output_error::FLOOR_FACTOR
        );
    }
}

/// The values a step called identifiable that the plant written holds elsewhere
/// ([`SequenceReport::moved_since`]).
fn moved_since_markdown(s: &mut String, moved: &[crate::identify::sequence::MovedValue]) {
    if moved.is_empty() {
        return;
    }
    let _ = writeln!(
        s,
        "**Values a step called identifiable that the written plant holds elsewhere** (more than two of the step's standard errors; no later step fitted them): {}. The step determined them given its held values; later steps moved some of those, and these values followed to keep the step's files (the linear following under `--earlier-information on`, or the refit of the earlier steps under `--earlier-refit on`). Their standard errors in the plant are the step's, conditional on the held values it had.\n",
        moved
            .iter()
            .map(|m| format!(
                "{} ({}: {} ± {} → {})",
                m.name,
                m.config,
                fmt_g(m.at_step),
                fmt_g(m.std_err),
                fmt_g(m.written)
            ))
            .collect::<Vec<_>>()
            .join(", ")
    );
}

/// One step's section of [`markdown`] (the joint fit's when `joint`), with the run's
/// options `o`.
fn step_markdown(
    s: &mut String,
    st: &StepReport,
    o: &OutputErrorOptions,
    model: &Model,
    joint: bool,
) {
    let f = &st.fit;
    let joints = |v: &[usize]| {
        v.iter()
            .map(|&j| model.joints[j])
            .collect::<Vec<_>>()
            .join(", ")
    };
    let title = if joint {
        format!(
            "Joint fit of every step's files: free {}, all weighted 1",
            joints(&st.step.free)
        )
    } else {
        format!(
            "Step {}: free {}, of interest {}",
            st.step.config,
            joints(&st.step.free),
            if st.step.interest.is_empty() {
                "none (all weighted 1)".into()
            } else {
                joints(&st.step.interest)
            }
        )
    };
    // The cost before and by how much the fit lowered it; a start the whole files cannot
    // be simulated from has no cost to compare with.
    let (cost_before, lower) = if f.cost_before.is_finite() {
        (
            fmt_g(f.cost_before),
            format!(
                " ({:.1} % lower)",
                100.0 * (1.0 - f.cost_after / f.cost_before)
            ),
        )
    } else {
        (
            "∞ (the whole files cannot be simulated from the plant's values)".into(),
            String::new(),
        )
    };
    let _ = writeln!(
        s,
        "## {title}\n\n{} file(s): {}. {} residuals, {} parameters. Cost {} → {}{}. {:.1} s wall, {} cost evaluations and {} Jacobians; best of {} start(s): start {} ({}).\n",
        f.files.len(),
        f.files.iter().map(|p| format!("`{}`", p.display())).collect::<Vec<_>>().join(", "),
        f.residuals,
        f.names.len(),
        cost_before,
        fmt_g(f.cost_after),
        lower,
        f.wall_s,
        f.evaluations,
        f.jacobians,
        f.starts.len(),
        f.best_start,
        f.starts.get(f.best_start).map(|x| x.status.as_str()).unwrap_or("")
    );
    for other in f.starts.iter().filter(|x| x.start != f.best_start) {
        let _ = writeln!(
            s,
            "Start {} (not kept): cost {} → {}: {}.\n",
            other.start,
            fmt_g(other.start_cost),
            fmt_g(other.cost),
            other.status
        );
    }
    if let Some(line) = stage_costs(f) {
        let _ = writeln!(s, "{line}\n");
    }
    let rejected: usize = f.starts.iter().map(|x| x.diverged).sum();
    if rejected > 0 {
        let _ = writeln!(
            s,
            "{rejected} trial point(s) rejected by the optimiser: the simulation diverged, or a link with a fitted symbol, consistent at the start, became physically impossible.\n"
        );
    }
    if !st.step.carried.is_empty() {
        let _ = writeln!(
            s,
            "Carried from earlier steps, which did not determine them: {}.\n",
            st.step.carried.join(", ")
        );
    }
    if !st.step.tied_held.is_empty() {
        let _ = writeln!(
            s,
            "Held along exact ties (the fitted symbols span this configuration's base parameters without them; left undetermined): {}.\n",
            st.step.tied_held.join(", ")
        );
    }
    if !st.step.held.is_empty() {
        let _ = writeln!(
            s,
            "Held at their values (bounds lower = upper): {}.\n",
            st.step.held.join(", ")
        );
    }
    if let Some(tau) = o.prior {
        let _ = writeln!(
            s,
            "Prior: Gaussian about the initial values, spread {tau} × each value; its term at the result {} (the fit minimised cost + prior term).\n",
            fmt_g(f.prior_penalty)
        );
    }
    if o.carried_prior && st.carried_prior.is_empty() && !st.step.carried.is_empty() {
        let _ = writeln!(
            s,
            "Carried prior (`--carried-prior on`): none of the carried symbols has a standard error in the plant (recorded only by a step at the noise floor that fitted them with a finite one, off their bounds), so none is held.\n"
        );
    }
    if !st.carried_prior.is_empty() {
        let _ = writeln!(
            s,
            "Carried prior (`--carried-prior on`): Gaussian about the values the earlier steps left, standard deviation their standard errors there: {}; the prior's term at the result {} (the fit minimised cost + prior term).\n",
            plus_minus(&st.carried_prior),
            fmt_g(f.prior_penalty)
        );
    }
    if st.earlier_information {
        let _ = writeln!(
            s,
            "Earlier information (`--earlier-information on`): fitted under the earlier steps' files' costs to second order (their information and gradient at their solutions), every other value these files see held; the term at the result {} (the fit minimised cost + that term).{}\n",
            fmt_g(f.prior_penalty),
            {
                // Moves below 1e-4 of the value are listed by count only.
                let (large, small): (Vec<_>, Vec<_>) = st
                    .following
                    .iter()
                    .partition(|(_, a, b)| (b - a).abs() > 1e-4 * a.abs().max(b.abs()));
                match (large.is_empty(), small.len()) {
                    _ if st.following_reverted => format!(
                        " The values these files do not see were moved to the earlier costs' conditional minimum and moved back: the earlier steps' files were further off with the moves ({} values).",
                        st.following.len()
                    ),
                    (true, 0) => String::new(),
                    (true, k) => format!(
                        " {k} value(s) these files do not see moved by less than 1e-4 of themselves after the step, to the earlier costs' conditional minimum."
                    ),
                    (false, k) => format!(
                        " Moved after the step to the earlier costs' conditional minimum (values these files do not see): {}{}.",
                        large
                            .iter()
                            .map(|(n, a, b)| format!("{n} {} → {}", fmt_g(*a), fmt_g(*b)))
                            .collect::<Vec<_>>()
                            .join(", "),
                        if k > 0 {
                            format!("; {k} more by less than 1e-4 of themselves")
                        } else {
                            String::new()
                        }
                    ),
                }
            }
        );
    }
    for r in &st.earlier_refits {
        let _ = writeln!(
            s,
            "Step {}'s files after this step: worst joint {:.2} σ̂ (its own end {:.2} σ̂){}.\n",
            r.config,
            r.rms.1,
            r.rms.0,
            match (r.names.is_empty(), r.rms.2) {
                (false, None) if r.failure.is_some() => format!(
                    "; the refit of {} on them could not be fitted: {}",
                    r.names.join(", "),
                    r.failure.as_deref().unwrap_or_default()
                ),
                (true, _) => " — every value it fitted enters this step's files too, so none is refitted on them alone (the joint refit below)".to_string(),
                (false, Some(after)) => format!(
                    "; {} refitted on them (the values of that step these files do not see, under the other steps' information): {after:.2} σ̂ ({:.1} s)",
                    r.names.join(", "),
                    r.wall_s
                ),
                (false, None) => format!(
                    "; the refit of {} on them did not lower it ({:.1} s), not kept",
                    r.names.join(", "),
                    r.wall_s
                ),
            }
        );
    }
    if let Some(j) = &st.joint_refit {
        let figures: Vec<String> = j
            .rms
            .iter()
            .map(|(c, _, before, after)| match after {
                Some(a) => format!("{c} {before:.2} → {a:.2} σ̂"),
                None => format!("{c} {before:.2} σ̂"),
            })
            .collect();
        let _ = writeln!(
            s,
            "Joint refit of {} (every value the earlier ones fitted enters this step's files; {} values, those the other steps' files do not see, on all their files at once): {}; {} ({} cost evaluations, {} Jacobians, {:.1} s{}).\n",
            j.configs.join(", "),
            j.names.len(),
            figures.join(", "),
            match j.cost {
                None => format!(
                    "could not be fitted: {}",
                    j.failure.as_deref().unwrap_or_default()
                ),
                Some((a, b)) => format!(
                    "cost {} → {}, {}",
                    fmt_g(a),
                    fmt_g(b),
                    if j.kept() {
                        "kept"
                    } else {
                        "not kept: the worst step's files did not fall"
                    }
                ),
            },
            j.evaluations,
            j.jacobians,
            j.wall_s,
            if j.status.is_empty() {
                String::new()
            } else {
                format!("; {}", j.status)
            }
        );
    }
    if let Some(w) = &st.warm_up_start {
        let _ = writeln!(
            s,
            "Warm-up start (`--warm-up-start on`; the fit through the growing horizons ended above the noise floor: {}): a second start from the same plant through the equation-error start and the prediction-error homotopy, then the whole files; cost {} (horizons) against {} (warm-ups): {} ({}).\n",
            w.above_floor.join(", "),
            fmt_g(w.cost.0),
            fmt_g(w.cost.1),
            if w.kept { "the warm-ups' kept" } else { "the horizons' kept" },
            w.work.text()
        );
    }
    if let Some(w) = &st.whiteness_start {
        let _ = writeln!(
            s,
            "Warm-up start for a residual that is not white (`--warm-up-start on`; at the noise floor, but {}): a second start from the same plant through the equation-error start and the prediction-error homotopy, then its initial positions refitted; cost {} (kept minimum) against {} (warm-ups): {} ({}).\n",
            w.not_white.join("; "),
            fmt_g(w.cost.0),
            fmt_g(w.cost.1),
            if w.kept { "the warm-ups' kept" } else { "the first kept" },
            w.work.text()
        );
    }
    if let Some(r) = &st.initial_positions_refit {
        let _ = writeln!(
            s,
            "Initial-positions refit (`--initial-positions refit`): the kept minimum fitted once more with every file's initial positions estimated; cost {} (first measured samples) against {} (estimated, largest move {:.2} σ̂): {} ({}).\n",
            fmt_g(r.cost.0),
            fmt_g(r.cost.1),
            r.largest_move,
            if r.kept { "the estimated kept" } else { "the measured kept" },
            r.work.text()
        );
    }
    if let Some(t) = &st.tie_reach {
        let _ = writeln!(
            s,
            "Reach across held ties (the step's first fit ended above the noise floor with {} on a bound that the held ties could carry further): fitted again with {}; cost {} → {} there, spread back over the symbols' own bounds ({}), then fitted on them: {} ({}; {} cost evaluations, {} Jacobians, {:.1} s).\n",
            t.representatives
                .iter()
                .map(|(n, bound, ..)| format!("{n} at {}", fmt_g(*bound)))
                .collect::<Vec<_>>()
                .join(", "),
            t.representatives
                .iter()
                .map(|(n, _, (lo, hi), v)| format!("{n} in [{}, {}] (to {})", fmt_g(*lo), fmt_g(*hi), fmt_g(*v)))
                .collect::<Vec<_>>()
                .join(", "),
            fmt_g(t.cost_before),
            fmt_g(t.cost_wide),
            if t.moved.is_empty() {
                "no held tie moved".to_string()
            } else {
                format!(
                    "held ties moved: {}",
                    t.moved
                        .iter()
                        .map(|(n, a, b)| format!("{n} {} → {}", fmt_g(*a), fmt_g(*b)))
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            },
            fmt_g(t.cost_after),
            if t.kept { "kept: the values and statistics below are these, and the plant has the moved held ties" } else { "not lower: not kept" },
            t.evaluations,
            t.jacobians,
            t.wall_s
        );
    }
    if let Some(r) = &st.release {
        let _ = writeln!(
            s,
            "Release of held values (`--release-held on`; the step's first fit ended above the noise floor): {} fitted again with this step's parameters from its first fit, under a Gaussian prior about their held values with their recorded standard errors (ρ: the recorded variance over the variance this step's data alone give the value): {}. Cost + prior term {} → {} ({}; {}).\n",
            r.values.len(),
            r.values
                .iter()
                .map(|(n, rho, se, before, after)| format!(
                    "{n} (ρ = {rho:.3}) {} → {}, {:+.2} σ",
                    fmt_g(*before),
                    fmt_g(*after),
                    (after - before) / se
                ))
                .collect::<Vec<_>>()
                .join(", "),
            fmt_g(r.objective_before),
            fmt_g(r.objective_after),
            if r.kept { "kept: the values and statistics below are the release's" } else { "not lower: not kept" },
            r.work.text()
        );
    }
    if let Some(b) = &st.balance {
        let (worst_before, worst_after) = b.worst();
        let _ = writeln!(
            s,
            "Balanced refit (`--balance on`): the whole files once more with every free joint weighted 1, from the step's fit: RMS / σ̂ {}; worst {worst_before:.2} → {worst_after:.2} ({}). Cost with every joint weighted 1 {} → {}; the cost with the step's weights {} → {} ({}).\n",
            b.joints
                .iter()
                .map(|(j, a, c)| format!("{j} {} → {}", fmt_ratio(*a), fmt_ratio(*c)))
                .collect::<Vec<_>>()
                .join(", "),
            if b.kept {
                "kept: the values and statistics below are the balanced fit's, the step's cost the one with its weights"
            } else {
                "not lower: not kept"
            },
            fmt_g(b.cost_balanced.0),
            fmt_g(b.cost_balanced.1),
            fmt_g(b.cost_weighted.0),
            fmt_g(b.cost_weighted.1),
            b.work.text()
        );
    }
    if let Some(lc) = f.least_change.as_ref().filter(|lc| !lc.moved.is_empty()) {
        let _ = writeln!(
            s,
            "Least change: {} moved from the minimum toward the initial values with this configuration's base parameters unchanged (values these data cannot tell apart); cost {} → {} ({}; one noise variance: {}).\n",
            lc.moved.join(", "),
            fmt_g(lc.cost_at_minimum),
            fmt_g(lc.cost),
            if lc.accepted { "kept" } else { "rose more than one noise variance: not kept" },
            fmt_g(lc.allowed_rise),
        );
        if let Some(alpha) = lc.gain_scale {
            let gains = match lc.gains_after {
                Some(r) if (r - 1.0).abs() > 1e-6 => format!(
                    "the fitted gains end at {} × their initial values (geometric mean)",
                    fmt_g(r)
                ),
                Some(_) => {
                    "the fitted gains end at their initial values (geometric mean)".to_string()
                }
                None => String::new(),
            };
            let stopped = lc.gain_scale_bound_by.as_ref().map_or(String::new(), |n| {
                format!(", α stopped by the bounds of {n}")
            });
            let held = if lc.held.is_empty() {
                String::new()
            } else {
                format!(
                    "; held ties moved with it: {}",
                    lc.held
                        .iter()
                        .map(|(n, v)| format!("{n} to {}", fmt_g(*v)))
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            };
            let _ = writeln!(
                s,
                "Plant-gain scale: position data fix the plant gains only together with every force of the configuration (an exact symmetry). All of them were scaled by α = {}, the point of the symmetry nearest the plant's values (the gains and the rigid-body symbols, held ties included, changed least in units of their bounds' widths){stopped}: {gains}{held}; the cost unchanged within one noise variance. The scale is set by the plant's values, not by these data: hold one gain at a known value (bounds lower = upper) to set it.\n",
                fmt_g(alpha)
            );
        }
    }
    if !st.impossible.is_empty() {
        let _ = writeln!(
            s,
            "**Physically impossible links after this step** (the data of this configuration are fitted, but no body has these values; the plant-gain scale of an isolated step can drive a link's inertia there):\n"
        );
        for line in &st.impossible {
            let _ = writeln!(s, "- {line}");
        }
        let _ = writeln!(s);
    }
    let stats = &f.statistics;
    if let Some(offsets) = &f.initial_positions {
        let each: Vec<String> = f
            .files
            .iter()
            .zip(offsets)
            .map(|(file, d)| {
                let joints: Vec<String> = stats
                    .joints
                    .iter()
                    .zip(d)
                    .map(|(j, &d)| format!("{} {:+.2} σ̂", j.joint, d / j.noise))
                    .collect();
                format!("{}: {}", file.display(), joints.join(", "))
            })
            .collect();
        let _ = writeln!(
            s,
            "Initial positions estimated with the parameters (`--initial-positions estimate` or `refit`; the figures below are on these starts), estimate − first sample: {}.\n",
            each.join("; ")
        );
    }
    if !stats.above_floor.is_empty() {
        let _ = writeln!(
            s,
            "**Not at the noise floor** ({}, over the samples the cost weighs; the floor is {} σ̂, σ̂ {}): the residuals are not noise, the standard errors do not bound the error of the values, and no parameter is called identifiable.\n",
            stats.above_floor.join(", "),
            crate::identify::output_error::FLOOR_FACTOR,
            match o.noise_sigma {
                Some(sigma) => format!("the sensor's noise given by --noise-sigma, {sigma:e}"),
                None => "the noise each joint's data show".to_string(),
            }
        );
        let at_bound: Vec<&str> = f
            .names
            .iter()
            .zip(&stats.at_bound)
            .filter(|(_, &b)| b)
            .map(|(n, _)| n.as_str())
            .collect();
        if !at_bound.is_empty() {
            let _ = writeln!(
                s,
                "{} of {} fitted value(s) ended at a bound: {}. A fit away from the floor with values at their bounds may have its minimum outside them, or be making up for a value held wrong: check that the bounds hold the values expected (widen them and fit again) before reading the misfit as a missing effect.\n",
                at_bound.len(),
                f.names.len(),
                at_bound.join(", ")
            );
        }
    }
    if !stats.held.is_empty() {
        let _ = writeln!(
            s,
            "Standard errors include the uncertainty of {} held value(s), as recorded by the step that fitted each (taken as independent): {}. The column \"given held\" takes them as exact.\n",
            stats.held.len(),
            plus_minus(&stats.held)
        );
    }
    if !stats.held_ties.is_empty() {
        let _ = writeln!(
            s,
            "Standard errors include the uncertainty of {} held tie(s), held at the plant's values although the fitted symbols make up for them (not separately identifiable here): each as a value uniform within its bounds, σ = width/√12: {}. A value that makes up for a held tie is determined only given the tie's value.\n",
            stats.held_ties.len(),
            plus_minus(&stats.held_ties)
        );
    }
    for (family, members) in &stats.held_scales {
        let _ = writeln!(
            s,
            "Held without a known scale: {} value(s) of plant-gain scale family {family} ({}), whose scale no step determined (its step set it by its least change, near the plant's values). That scale counts as unknown here: a value that moves with it is known only relative to it (an infinite standard error; the figure relative to the family's scale is given beside it).\n",
            members.len(),
            members.join(", ")
        );
    }
    if !stats.held_exact.is_empty() {
        let _ = writeln!(
            s,
            "Held as exact (no standard error recorded: not fitted, or not determined where fitted): {}.\n",
            stats.held_exact.join(", ")
        );
    }
    for o in &stats.other_minima {
        let _ = writeln!(
            s,
            "Start {} ends as low as the kept one within the noise (objective {} higher, Δχ² {:.2} ≤ {}): {}; the standard errors describe only the kept minimum's neighbourhood, so {}.\n",
            o.start,
            fmt_g(o.objective_difference),
            o.chi2_difference,
            crate::identify::output_error::EQUAL_MINIMUM_CHI2,
            if o.moved.is_empty() {
                format!(
                    "no parameter there is more than {} standard errors away",
                    crate::identify::output_error::EQUAL_MINIMUM_STD_ERRORS
                )
            } else {
                o.moved
                    .iter()
                    .map(|(n, v, d)| format!("{n} = {} ({d:.1} σ away)", fmt_g(*v)))
                    .collect::<Vec<_>>()
                    .join(", ")
            },
            if o.moved.is_empty() {
                "nothing changes"
            } else {
                "those are not called identifiable, and the standard error the plant records for them is at least that distance"
            }
        );
    }
    let _ = writeln!(
        s,
        "| parameter | initial | fitted | std error | given held | rel. % | bounds | identifiable |\n|---|---|---|---|---|---|---|---|"
    );
    for i in 0..f.names.len() {
        let mut why = Vec::new();
        if !stats.above_floor.is_empty() {
            why.push("not at the noise floor".to_string());
        }
        if stats.at_bound[i] {
            why.push("at a bound".to_string());
        }
        let given_scale = stats.std_err_given_scale(i);
        if stats.std_err[i].is_infinite() && given_scale.is_finite() {
            why.push(format!(
                "known only relative to the held scale families' scale ({}; ± {} ({:.2} %) relative to it)",
                stats
                    .held_scales
                    .iter()
                    .map(|(f, _)| f.as_str())
                    .collect::<Vec<_>>()
                    .join(", "),
                fmt_g(given_scale),
                100.0 * given_scale / f.fitted[i].abs().max(1e-300)
            ));
        } else if stats.std_err[i].is_infinite() {
            why.push(
                "not determined by the data (moves along an exact symmetry, such as the plant-gain scale)"
                    .to_string(),
            );
        } else if stats.relative_std_err[i] > crate::identify::output_error::RELATIVE_STD_LIMIT {
            let given = stats.std_err_given_held[i] / f.fitted[i].abs();
            let limit = 100.0 * crate::identify::output_error::RELATIVE_STD_LIMIT;
            why.push(
                if given <= crate::identify::output_error::RELATIVE_STD_LIMIT {
                    format!(
                    "σ/|p| > {limit} % from the held values' uncertainty ({:.2} % with them exact)",
                    100.0 * given
                )
                } else {
                    format!("σ/|p| > {limit} %")
                },
            );
        }
        if !stats.only_with[i].is_empty() {
            why.push(format!(
                "only in combination with {} (base parameters)",
                stats.only_with[i].join(", ")
            ));
        }
        for o in &stats.other_minima {
            for (_, v, d) in o.moved.iter().filter(|m| m.0 == f.names[i]) {
                why.push(format!(
                    "start {} ends as low (Δχ² {:.2}) at {} ({d:.1} σ away)",
                    o.start,
                    o.chi2_difference,
                    fmt_g(*v)
                ));
            }
        }
        for (a, b, c) in &stats.correlated {
            if *a == f.names[i] || *b == f.names[i] {
                let other = if *a == f.names[i] { b } else { a };
                why.push(format!("corr {c:+.3} with {other}"));
            }
        }
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {:.2} | [{}, {}] | {} |",
            f.names[i],
            fmt_g(f.initial[i]),
            fmt_g(f.fitted[i]),
            fmt_g(stats.std_err[i]),
            fmt_g(stats.std_err_given_held[i]),
            100.0 * stats.relative_std_err[i],
            fmt_g(f.lower[i]),
            fmt_g(f.upper[i]),
            if stats.identifiable[i] {
                "yes".to_string()
            } else {
                format!("no: {}", why.join("; "))
            }
        );
    }
    let _ = writeln!(
        s,
        "\nCondition number of the scaled JᵀJ: {:.3e}.\n\nPer joint: the RMS error over the samples the cost weighs (the noise floor is judged there: cost (4.3) skips the first samples, whose initial state is not known) and over all samples (as MATLAB `compare`).\n\n| joint | λ | RMS error, fitted samples (rad) | noise σ̂ (rad) | RMS / σ̂ | RMS / σ̂, all samples | max error (rad) | NRMSE fit % |\n|---|---|---|---|---|---|---|---|",
        stats.condition
    );
    for j in &stats.joints {
        let _ = writeln!(
            s,
            "| {} | {} | {:.4e} | {:.4e} | {} | {} | {:.4e} | {:.2} |",
            j.joint,
            j.weight,
            j.rms_fitted,
            j.noise,
            fmt_ratio(j.floor_ratio()),
            fmt_ratio(j.rms_ratio()),
            j.max_abs,
            j.nrmse_fit
        );
    }
    let _ = writeln!(s);
}

/// Where a fit's wall time went, one line: each start's stages with their wall time and
/// cost evaluations (as recorded, [`StageRecord`](crate::identify::output_error::StageRecord)),
/// then what the stages leave of the fit's wall time (the least change, the statistics,
/// and the refinements merged into the fit: the balanced refit and the like);
/// `None` for a report written before the stages' costs were recorded.
fn stage_costs(f: &FitResult) -> Option<String> {
    let stages: Vec<_> = f.starts.iter().flat_map(|x| &x.stages).collect();
    if stages.iter().all(|g| g.wall_s == 0.0) {
        return None;
    }
    let per_start: Vec<String> = f
        .starts
        .iter()
        .filter(|x| x.stages.iter().any(|g| g.wall_s > 0.0))
        .map(|x| {
            let parts: Vec<String> = x
                .stages
                .iter()
                .filter(|g| g.wall_s > 0.0)
                .map(|g| {
                    let name = g.stage.split(" (").next().unwrap_or(&g.stage);
                    format!("{name} {:.1} s ({} evaluations)", g.wall_s, g.evaluations)
                })
                .collect();
            format!("start {}: {}", x.start, parts.join(", "))
        })
        .collect();
    let in_stages: f64 = stages.iter().map(|g| g.wall_s).sum();
    Some(format!(
        "Where the fit's wall time went: {}; outside the stages (least change, statistics, the refinements below) {:.1} s.",
        per_start.join("; "),
        (f.wall_s - in_stages).max(0.0)
    ))
}
