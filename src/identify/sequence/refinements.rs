//! The refinements after a step's fit ([`StepRefit`]), each kept only where it lowers the
//! cost or the worst joint's RMS / σ̂, each in a file of its own with its record for the
//! report: the reach across held ties (`tie_reach.rs`), the release of held values the step
//! sees better than the steps that fitted them (`release.rs`) and the balanced refit with
//! every free joint weighted 1 (`balance.rs`). Here: what they share, and their order
//! ([`StepRefit::refine`]).

use super::*;

/// Information ratio ρ ([`Statistics::held_information`]) above which a held value is
/// released: this step's data see it better than the step that fitted it.
pub const RELEASE_INFORMATION: f64 = 1.0;

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
    /// "61 cost evaluations, 23 Jacobians, 13.1 s; " then the status, as the report gives it.
    pub fn text(&self) -> String {
        format!(
            "{} cost evaluations, {} Jacobians, {:.1} s; {}",
            self.evaluations, self.jacobians, self.wall_s, self.status
        )
    }

    /// The work of `fit`.
    pub(super) fn of(fit: &FitResult) -> RefitWork {
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
    /// A refit of the step on its files from plant `at`: `names` fitted under `options`,
    /// with the step's joints of interest and held ties.
    ///
    /// # Errors
    /// As [`Problem::new`] (a fitted value without bounds, or outside them).
    pub(super) fn refit_problem(
        &self,
        at: &Plant,
        names: Vec<String>,
        options: OutputErrorOptions,
    ) -> Result<Problem> {
        let problem = Problem::new(
            at,
            self.problem.configuration(),
            names,
            self.problem.records.clone(),
            self.interest,
            options,
        )?
        .with_held_ties(self.held_ties.to_vec());
        match self.problem.earlier_information() {
            Some(earlier) => problem.with_earlier_information(earlier.clone()),
            None => Ok(problem),
        }
    }

    /// The options of a refit from the step's fitted minimum `fit`: the step's, with the
    /// whole files only (no warm-ups), one start, and no Stribeck re-seed (the first fit's
    /// minimum already had that branch); the initial positions estimated where `fit`'s were
    /// ([`StepRefit::refit_initial_positions`]), so that the refit's cost compares with
    /// `fit`'s.
    pub(super) fn refit_options(&self, fit: &FitResult) -> OutputErrorOptions {
        let mut options = self.problem.options().clone();
        options.estimate_initial_positions |= fit.initial_positions.is_some();
        options.horizons = vec![1.0];
        options.segments.clear();
        options.equation_error = None;
        options.predictor.clear();
        options.starts = 1;
        options.stribeck_reseed = false;
        options
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
