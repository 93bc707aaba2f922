//! The refinements after a step's fit ([`StepRefit`]), each kept only where it lowers the
//! cost or the worst joint's RMS / σ̂: the reach across held ties, the release of held
//! values the step sees better than the steps that fitted them, and the balanced refit with
//! every free joint weighted 1; and their records in the report.

use super::*;

/// Information ratio ρ ([`Statistics::held_information`]) above which a held value is
/// released: this step's data see it better than the step that fitted it.
pub const RELEASE_INFORMATION: f64 = 1.0;

/// The release of held values after a step that did not reach the noise floor
/// ([`SequenceOptions::release_held`]).
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct Release {
    /// Per released value: name, ρ ([`Statistics::held_information`]), the prior's
    /// standard deviation (SI; the standard error recorded by the step that fitted it), its
    /// value before and after.
    pub values: Vec<(String, f64, f64, f64, f64)>,
    /// Cost + prior term at the step's first fit (the prior's term there is 0 for the
    /// released values, at their centres).
    pub objective_before: f64,
    /// Cost + prior term after the release.
    pub objective_after: f64,
    /// Whether the release's fit was kept (its objective lower).
    pub kept: bool,
    /// How the release's fit ended and what it cost.
    #[serde(flatten)]
    pub work: RefitWork,
}

/// How a refit of a step ended and its work, included in the step's ([`Release`],
/// [`Balance`]).
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct RefitWork {
    /// How the refit's kept start ended.
    pub status: String,
    /// Cost evaluations.
    pub evaluations: usize,
    /// Jacobians.
    pub jacobians: usize,
    /// Wall time (s).
    pub wall_s: f64,
}

impl RefitWork {
    /// The work of `fit`.
    fn of(fit: &FitResult) -> RefitWork {
        RefitWork {
            status: fit
                .starts
                .get(fit.best_start)
                .map_or_else(String::new, |s| s.status.clone()),
            evaluations: fit.evaluations,
            jacobians: fit.jacobians,
            wall_s: fit.wall_s,
        }
    }
}

/// The balanced refit after a step's fit ([`StepRefit::balance`]).
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct Balance {
    /// Per free joint: name, RMS error over the fitted samples over its noise σ̂ before
    /// and after the balanced refit; None where the files give no σ̂
    /// ([`JointFit::floor_ratio`](super::output_error::JointFit::floor_ratio)).
    pub joints: Vec<(String, Option<f64>, Option<f64>)>,
    /// The cost (4.2)/(4.3) with the step's joint weights (the thesis's) at the step's fit
    /// and at the balanced refit's result.
    pub cost_weighted: (f64, f64),
    /// The cost with every free joint weighted 1 at the step's fit and at the result.
    pub cost_balanced: (f64, f64),
    /// Whether the refit was kept (its worst joint's RMS / σ̂ lower).
    pub kept: bool,
    /// How the refit ended and what it cost.
    #[serde(flatten)]
    pub work: RefitWork,
}

impl Balance {
    /// The worst free joint's RMS / σ̂ before and after, over the joints whose σ̂ the files
    /// give ([`JointFit::floor_ratio`](super::output_error::JointFit::floor_ratio)); 0 when
    /// none does.
    pub fn worst(&self) -> (f64, f64) {
        self.joints.iter().fold((0.0_f64, 0.0_f64), |(a, b), j| {
            (a.max(j.1.unwrap_or(0.0)), b.max(j.2.unwrap_or(0.0)))
        })
    }
}

/// The reach across held ties after a step that ended above the noise floor with a
/// fitted rigid-body symbol on a bound ([`StepRefit::reach_across_held_ties`]).
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct TieReach {
    /// Per fitted symbol on a bound: name, that bound, the bounds of the wide fit (SI),
    /// its value there (the β the held ties then carried).
    pub representatives: Vec<(String, f64, (f64, f64), f64)>,
    /// Held ties moved along the tie to carry it: name, value before, after (SI). Applied
    /// to the plant when [`TieReach::kept`].
    pub moved: Vec<(String, f64, f64)>,
    /// The step's cost before (its first fit), after the wide fit, and after the fit on
    /// the own bounds from the spread values.
    pub cost_before: f64,
    /// Cost of the wide fit.
    pub cost_wide: f64,
    /// Cost after.
    pub cost_after: f64,
    /// Whether the result was kept (its cost + prior term below the first fit's).
    pub kept: bool,
    /// Cost evaluations of both refits, included in the step's.
    pub evaluations: usize,
    /// Jacobians.
    pub jacobians: usize,
    /// Wall time (s).
    pub wall_s: f64,
}

/// A fitted rigid-body symbol's value within this fraction of its bound width from a
/// bound counts as on it ([`StepRefit::reach_across_held_ties`]).
pub(super) const ON_BOUND: f64 = 1e-6;

/// A step's refits from its first fit's minimum: the release of held values
/// ([`StepRefit::release_held`]) and the reach across held ties
/// ([`StepRefit::reach_across_held_ties`]), on the step's files.
pub struct StepRefit<'a> {
    /// The step's problem (configuration, files, options).
    pub problem: &'a Problem,
    /// Indices of the joints of interest (weighted [`OutputErrorOptions::interest_weight`]).
    pub interest: &'a [usize],
    /// Rigid-body symbols held along ties ([`spanning_symbols`]).
    pub held_ties: &'a [String],
    /// The progress display.
    pub progress: &'a (dyn Fn(Progress) + Sync),
}

impl StepRefit<'_> {
    /// The release of held values after a step's `fit` of `problem` (joints of interest
    /// `interest`, rigid-body symbols held along ties `held_ties`) ended above the noise floor;
    /// `plant` is the plant the step started from. The values earlier steps fitted
    /// whose recorded variance exceeds the variance this step's data alone would give them
    /// (ρ > [`RELEASE_INFORMATION`], [`Statistics::held_information`]) are fitted again with
    /// the step's parameters, from the fit's values and the whole files (no warm-ups), under
    /// a Gaussian prior about their held values with their recorded standard errors
    /// ([`Problem::with_released`]): the sequential estimate with each earlier step's data
    /// summarised by its values and standard errors. Why: a value fitted within its standard
    /// error on an earlier step's data can still be off by more than a later configuration
    /// tolerates — on the Freedom 6S, k2's qeq_3 (−1.9 %, 1.4 of its standard errors) alone
    /// leaves k4 at the truth of its own parameters 2.5–5.7 σ above the noise on q2..q5.
    /// The result is kept when its cost + prior term is lower than the fit's cost.
    ///
    /// # Errors
    /// The release's problem cannot be set up (a released value without bounds).
    pub fn release_held(
        &self,
        plant: &Plant,
        fit: FitResult,
    ) -> Result<(FitResult, Option<Release>)> {
        let progress = self.progress;
        let mut candidates: Vec<(String, f64)> = fit
            .statistics
            .held_information
            .iter()
            .filter(|(n, rho)| {
                *rho > RELEASE_INFORMATION
                    && plant.bounds.contains_key(n)
                    && plant.standard_errors.contains_key(n)
            })
            .cloned()
            .collect();
        candidates.sort_by(|a, b| b.1.total_cmp(&a.1));
        if candidates.is_empty() {
            return Ok((fit, None));
        }
        let mut from = plant.clone();
        fit.apply(&mut from);
        let options = self.refit_options();
        let released: Vec<String> = candidates.iter().map(|c| c.0.clone()).collect();
        let mut names = fit.names.clone();
        names.extend(released.iter().cloned());
        let release = self
            .refit_problem(&from, names, options)
            .and_then(|p| p.with_released(released))
            .context("releasing held values")?;
        let objective_before = fit.cost_after + fit.prior_penalty;
        let second = release.fit(progress)?;
        let objective_after = second.cost_after + second.prior_penalty;
        let kept = objective_after < objective_before;
        let values = candidates
            .iter()
            .map(|(n, rho)| {
                let i = second
                    .names
                    .iter()
                    .position(|x| x == n)
                    .expect("with_released checked that every released value is fitted");
                (
                    n.clone(),
                    *rho,
                    plant.standard_errors[n],
                    plant.parameters[n],
                    second.fitted[i],
                )
            })
            .collect();
        let summary = Release {
            values,
            objective_before,
            objective_after,
            kept,
            work: RefitWork::of(&second),
        };
        Ok((merge_refit(plant, fit, second, kept), Some(summary)))
    }

    /// The balanced refit after a step's `fit` (the last of its fits: after the reach
    /// across held ties and the release, whose `released` values keep their prior); `plant`
    /// is the plant the step started from. The thesis weights the joints of interest
    /// λ = [`OutputErrorOptions::interest_weight`] (50) against 1 for the others, so a
    /// misfit those others show costs the fit 1/λ² of what the same misfit of a joint of
    /// interest would: where the values earlier steps left are slightly off, the step's
    /// minimum trades it onto them (the Freedom 6S case is in the identification record).
    /// This refit fits the
    /// whole files once more from the fit's values with every free joint weighted 1 (no
    /// warm-ups, one start); it is kept when the worst free joint's RMS / σ̂ falls, the
    /// noise-floor criterion itself. None when every free joint already carries the same
    /// weight (every free joint of interest, or λ = 1).
    ///
    /// # Errors
    /// The refit's problem cannot be set up (a fitted value without bounds).
    pub fn balance(
        &self,
        plant: &Plant,
        fit: FitResult,
        released: &[String],
    ) -> Result<(FitResult, Option<Balance>)> {
        let options = self.problem.options();
        let free = self.problem.configuration().free.len();
        if options.interest_weight == 1.0 || self.interest.len() == free {
            return Ok((fit, None));
        }
        let mut from = plant.clone();
        fit.apply(&mut from);
        let mut balanced_options = self.refit_options();
        balanced_options.interest_weight = 1.0;
        let with_prior = |p: Problem| -> Result<Problem> {
            if released.is_empty() {
                Ok(p)
            } else {
                p.with_released(released.to_vec())
            }
        };
        let balanced = self
            .refit_problem(&from, fit.names.clone(), balanced_options)
            .and_then(with_prior)
            .context("the balanced refit")?;
        let second = balanced.fit(self.progress)?;
        let mut to = from.clone();
        second.apply(&mut to);
        // The thesis-weighted cost at the result, and the balanced one at the fit's values,
        // each on the initial positions that fit settled on (as the fits' own costs).
        let cost_at = |p: &Problem, of: &FitResult| -> f64 {
            match &of.initial_positions {
                Some(offsets) => p.with_initial_offsets(offsets).cost(&of.fitted),
                None => p.cost(&of.fitted),
            }
        };
        let weighted = self
            .refit_problem(&to, second.names.clone(), self.refit_options())
            .context("the balanced refit")?;
        let cost_weighted = (fit.cost_after, cost_at(&weighted, &second));
        let cost_balanced = (cost_at(&balanced, &fit), second.cost_after);
        let joints: Vec<(String, Option<f64>, Option<f64>)> = fit
            .statistics
            .joints
            .iter()
            .zip(&second.statistics.joints)
            .map(|(a, b)| (a.joint.clone(), a.floor_ratio(), b.floor_ratio()))
            .collect();
        let mut summary = Balance {
            joints,
            cost_weighted,
            cost_balanced,
            kept: false,
            work: RefitWork::of(&second),
        };
        let (before, after) = summary.worst();
        summary.kept = after < before;
        let mut merged = merge_refit(plant, fit, second, summary.kept);
        if summary.kept {
            // The step's cost stays the thesis's (4.2)/(4.3), now at the balanced values;
            // the statistics are the balanced fit's.
            merged.cost_after = summary.cost_weighted.1;
        }
        Ok((merged, Some(summary)))
    }

    /// A refit of the step on its files from plant `at`: `names` fitted under `options`,
    /// with the step's joints of interest and held ties.
    ///
    /// # Errors
    /// As [`Problem::new`] (a fitted value without bounds, or outside them).
    fn refit_problem(
        &self,
        at: &Plant,
        names: Vec<String>,
        options: OutputErrorOptions,
    ) -> Result<Problem> {
        Ok(Problem::new(
            at,
            self.problem.configuration(),
            names,
            self.problem.records.clone(),
            self.interest,
            options,
        )?
        .with_held_ties(self.held_ties.to_vec()))
    }

    /// The options of a refit from the step's fitted minimum: the step's, with the whole
    /// files only (no warm-ups), one start, and no Stribeck re-seed (the first fit's minimum
    /// already had that branch).
    fn refit_options(&self) -> OutputErrorOptions {
        let mut options = self.problem.options().clone();
        options.horizons = vec![1.0];
        options.segments.clear();
        options.equation_error = None;
        options.predictor.clear();
        options.starts = 1;
        options.stribeck_reseed = false;
        options
    }

    /// The reach across held ties after a step's `fit` of `problem` (joints of interest
    /// `interest`, rigid-body symbols held along ties `held_ties`) ended above the noise
    /// floor with a fitted rigid-body symbol on a bound; `plant` is the plant the step
    /// started from. Such a symbol stands for base parameters β that it shares with held
    /// ties ([`spanning_symbols`]), held at values an earlier step could not determine, so
    /// its bound is not β's: the held ties can carry β further within their own bounds
    /// ([`tie_reach`](crate::identify::identifiability::tie_reach)). The step is fitted again from
    /// the fit's values with each such symbol's bound moved out by that reach; the result's
    /// β is then spread back over the fitted and held symbols within their own bounds,
    /// nearest the step's initial values and the held values
    /// ([`least_change_along_ties_at`](crate::identify::identifiability::least_change_along_ties_at));
    /// and the step is fitted once more from there, on its own bounds. Kept when that
    /// last fit's cost + prior term is below the first fit's; the held ties that moved are
    /// then in [`TieReach::moved`], for the plant. On c6 of the Freedom 6S (joint 0 alone,
    /// its inertia β = I1_33 + the held links' terms) the first fit ended with I1_33 on its
    /// upper bound at 26 σ̂.
    ///
    /// # Errors
    /// A refit's problem cannot be set up; the barycentric parameters cannot be formed.
    pub fn reach_across_held_ties(
        &self,
        plant: &Plant,
        fit: FitResult,
    ) -> Result<(FitResult, Option<TieReach>)> {
        let (problem, held_ties) = (self.problem, self.held_ties);
        if held_ties.is_empty() || fit.statistics.above_floor.is_empty() {
            return Ok((fit, None));
        }
        let model = plant.model;
        let conf = problem.configuration();
        let locked_at = problem.locked_at();
        let mut from = plant.clone();
        fit.apply(&mut from);
        let mut wide = from.clone();
        let mut representatives = Vec::new();
        for (i, n) in fit.names.iter().enumerate() {
            if !model.inertial_symbols.contains(&n.as_str()) {
                continue;
            }
            let (lo, hi) = (fit.lower[i], fit.upper[i]);
            if hi <= lo {
                // Held by its bounds (lower = upper): the user's value, not a bound to reach past.
                continue;
            }
            let near = ON_BOUND * (hi - lo);
            let at_upper = fit.fitted[i] >= hi - near;
            if !(at_upper || fit.fitted[i] <= lo + near) {
                continue;
            }
            let reach =
                crate::identify::identifiability::tie_reach(&from, conf, &locked_at, n, held_ties)
                    .context("the reach across held ties")?;
            if reach <= near {
                continue;
            }
            let bound = if at_upper { hi } else { lo };
            let widened = if at_upper {
                (lo, hi + reach)
            } else {
                (lo - reach, hi)
            };
            wide.bounds.insert(n.clone(), widened);
            representatives.push((i, bound, widened));
        }
        if representatives.is_empty() {
            return Ok((fit, None));
        }
        let mut options = self.refit_options();
        // The wide fit's values are only a β to spread back: no least change on them.
        options.least_change = false;
        // The first fit's Stribeck branch was fitted with the rigid body held short of its
        // β: the friction may have absorbed the missing inertia (c6 of the Freedom 6S: the
        // dip collapsed, Fs_0 = Fc_0, and the wide fit from there ended at 1.68 σ̂).
        options.stribeck_reseed = problem.options().stribeck_reseed;
        let refit = |at: &Plant, options: OutputErrorOptions| -> Result<FitResult> {
            self.refit_problem(at, fit.names.clone(), options)
                .context("the reach across held ties")?
                .fit(self.progress)
        };
        let first = refit(&wide, options)?;
        // β of the wide fit spread back over the fitted and held symbols, on their own bounds.
        let mut reached = wide.clone();
        first.apply(&mut reached);
        let names: Vec<String> = fit.names.iter().chain(held_ties).cloned().collect();
        let initial: Vec<f64> = fit
            .initial
            .iter()
            .copied()
            .chain(held_ties.iter().map(|n| plant.parameters[n]))
            .collect();
        let own = |n: &String| -> Result<(f64, f64)> {
            plant
                .bounds
                .get(n)
                .copied()
                .with_context(|| format!("the reach across held ties: '{n}' has no bounds"))
        };
        let (lower, upper): (Vec<f64>, Vec<f64>) = names
            .iter()
            .map(own)
            .collect::<Result<Vec<_>>>()?
            .into_iter()
            .unzip();
        let spread = crate::identify::identifiability::least_change_along_ties_at(
            &reached, conf, &locked_at, &names, &initial, &lower, &upper,
        )?;
        let mut back = from.clone();
        back.set_values(&names, &spread);
        let second = refit(&back, self.refit_options())?;
        let objective_before = fit.cost_after + fit.prior_penalty;
        let objective_after = second.cost_after + second.prior_penalty;
        let kept = objective_after < objective_before;
        let k = fit.names.len();
        let moved = held_ties
            .iter()
            .enumerate()
            .filter(|&(h, n)| {
                (spread[k + h] - plant.parameters[n]).abs()
                    > ON_BOUND * (upper[k + h] - lower[k + h])
            })
            .map(|(h, n)| (n.clone(), plant.parameters[n], spread[k + h]))
            .collect();
        let summary = TieReach {
            // The wide fit has the step's names in the step's order.
            representatives: representatives
                .iter()
                .map(|&(i, bound, widened)| (fit.names[i].clone(), bound, widened, first.fitted[i]))
                .collect(),
            moved,
            cost_before: fit.cost_after,
            cost_wide: first.cost_after,
            cost_after: second.cost_after,
            kept,
            evaluations: first.evaluations + second.evaluations,
            jacobians: first.jacobians + second.jacobians,
            wall_s: first.wall_s + second.wall_s,
        };
        let mut second = second;
        second.evaluations = summary.evaluations;
        second.jacobians = summary.jacobians;
        second.wall_s = summary.wall_s;
        Ok((merge_refit(plant, fit, second, kept), Some(summary)))
    }
}

/// The step's result after a refit `second` of its `fit` from `plant` (the plant the step
/// started from): the refit's values and statistics with the step's history (initial
/// values, cost before, starts) when `kept`, else the fit; the work of both either way
/// ([`StepRefit`]).
pub(super) fn merge_refit(
    plant: &Plant,
    fit: FitResult,
    second: FitResult,
    kept: bool,
) -> FitResult {
    if !kept {
        let mut fit = fit;
        fit.evaluations += second.evaluations;
        fit.jacobians += second.jacobians;
        fit.wall_s += second.wall_s;
        return fit;
    }
    let mut merged = second;
    for (i, n) in merged.names.iter().enumerate() {
        merged.initial[i] = match fit.names.iter().position(|x| x == n) {
            Some(j) => fit.initial[j],
            None => plant.parameters[n],
        };
    }
    merged.cost_before = fit.cost_before;
    merged.evaluations += fit.evaluations;
    merged.jacobians += fit.jacobians;
    merged.wall_s += fit.wall_s;
    merged.starts = fit.starts;
    merged.best_start = fit.best_start;
    merged
}

/// A step's fit after its refinements ([`StepRefit::refine`]).
pub(super) struct Refined {
    /// The fit kept.
    pub(super) fit: FitResult,
    /// The reach across held ties, if tried.
    pub(super) tie_reach: Option<TieReach>,
    /// The release of held values, if tried.
    pub(super) release: Option<Release>,
    /// The balanced refit, if tried.
    pub(super) balance: Option<Balance>,
    /// The held values the kept release fitted again.
    pub(super) released: Vec<String>,
}

impl StepRefit<'_> {
    /// The refinements after a step's `fit`, in order, each as `opts` switches it on: the
    /// reach across held ties (the held ties it moves are set in `current`), the release
    /// of held values where the step ends above the noise floor, and the balanced refit.
    ///
    /// # Errors
    /// A refinement's problem cannot be set up.
    pub(super) fn refine(
        &self,
        current: &mut Plant,
        fit: FitResult,
        opts: &SequenceOptions,
    ) -> Result<Refined> {
        let (fit, tie_reach) = if opts.tie_reach {
            self.reach_across_held_ties(current, fit)?
        } else {
            (fit, None)
        };
        if let Some(t) = tie_reach.as_ref().filter(|t| t.kept) {
            for (n, _, v) in &t.moved {
                current.parameters.insert(n.clone(), *v);
            }
        }
        let (fit, release) = if opts.release_held && !fit.statistics.above_floor.is_empty() {
            self.release_held(current, fit)?
        } else {
            (fit, None)
        };
        let released: Vec<String> = release
            .iter()
            .filter(|r| r.kept)
            .flat_map(|r| r.values.iter().map(|v| v.0.clone()))
            .collect();
        let (fit, balance) = if opts.balance {
            self.balance(current, fit, &released)?
        } else {
            (fit, None)
        };
        Ok(Refined {
            fit,
            tie_reach,
            release,
            balance,
            released,
        })
    }
}
