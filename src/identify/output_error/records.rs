//! The records a fit returns: its result ([`FitResult`]), each start
//! ([`StartSummary`]) and each stage of a start ([`StageRecord`]); serde, rendered by
//! `report/`.

use super::*;

/// Result of [`Problem::fit`].
#[derive(Debug, Clone, Default, Serialize, serde::Deserialize)]
pub struct FitResult {
    /// Configuration.
    pub configuration: String,
    /// Fitted parameter names.
    pub names: Vec<String>,
    /// Values before.
    pub initial: Vec<f64>,
    /// Values after.
    pub fitted: Vec<f64>,
    /// Lower bounds used (after Fs ≥ Fc).
    pub lower: Vec<f64>,
    /// Upper bounds used.
    pub upper: Vec<f64>,
    /// Cost (4.2)/(4.3) at the plant's values.
    pub cost_before: f64,
    /// Cost at the result.
    pub cost_after: f64,
    /// The prior's term at the result ([`OutputErrorOptions::prior`]; 0 without one): the
    /// fit minimised `cost_after + prior_penalty`.
    pub prior_penalty: f64,
    /// The move from the minimum toward the initial values, when
    /// [`OutputErrorOptions::least_change`] is on.
    pub least_change: Option<LeastChange>,
    /// Uncertainty and fit figures.
    pub statistics: Statistics,
    /// All starts.
    pub starts: Vec<StartSummary>,
    /// The start that won.
    pub best_start: usize,
    /// Cost evaluations (each simulates every file), all starts.
    pub evaluations: usize,
    /// Jacobians (each n simulations of every file), all starts.
    pub jacobians: usize,
    /// Wall time (s).
    pub wall_s: f64,
    /// Number of residuals.
    pub residuals: usize,
    /// Files.
    pub files: Vec<PathBuf>,
    /// Per file, per free joint: the estimated initial position minus the first measured
    /// sample (rad), when [`OutputErrorOptions::estimate_initial_positions`] is on; the
    /// cost, RMS figures and standard errors are on these starts.
    pub initial_positions: Option<Vec<Vec<f64>>>,
}

impl FitResult {
    /// A result over `space`'s parameters moved from `initial` to `fitted` (n each), with
    /// `cost_before` and the fit's counters read now (`started`: the fit's clock); the
    /// other figures empty, for the fit to set.
    pub(crate) fn over(
        space: &ParameterSpace,
        (initial, fitted): (Vec<f64>, Vec<f64>),
        cost_before: f64,
        (evaluations, jacobians, started): (&AtomicUsize, &AtomicUsize, Instant),
    ) -> FitResult {
        FitResult {
            names: space.names.to_vec(),
            initial,
            fitted,
            lower: space.lower.to_vec(),
            upper: space.upper.to_vec(),
            cost_before,
            evaluations: evaluations.load(Ordering::Relaxed),
            jacobians: jacobians.load(Ordering::Relaxed),
            wall_s: started.elapsed().as_secs_f64(),
            ..FitResult::default()
        }
    }

    /// Write the fitted values into `plant`, and the held ties the least change scaled
    /// ([`LeastChange::held`]).
    pub fn apply(&self, plant: &mut Plant) {
        plant.set_values(&self.names, &self.fitted);
        for (n, v) in self.least_change.iter().flat_map(|lc| &lc.held) {
            plant.parameters.insert(n.clone(), *v);
        }
    }
}

/// One start of a multi-start fit.
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct StartSummary {
    /// Index (0 = the plant's values).
    pub start: usize,
    /// Cost at the start.
    pub start_cost: f64,
    /// Cost at its end.
    pub cost: f64,
    /// Levenberg–Marquardt iterations.
    pub iterations: usize,
    /// How each stage ended (warm-ups, then the whole files), e.g. "horizon 100 %:
    /// convergence in parameter value after 12 iteration(s)".
    pub status: String,
    /// Trial points rejected by the optimiser: their simulation diverged, or they left a
    /// guarded link physically impossible ([`Problem::guarded_links`]).
    pub diverged: usize,
    /// How the start was warmed up.
    pub warm_up: WarmUp,
    /// Each stage as run, in order: the record behind `status`.
    #[serde(default)]
    pub stages: Vec<StageRecord>,
}

/// One stage of a start as run ([`StartSummary::stages`]).
#[derive(Debug, Clone, PartialEq, Serialize, serde::Deserialize)]
pub struct StageRecord {
    /// The stage as the report names it, e.g. "predictor ω = 100 rad/s", "horizon 100 %".
    pub stage: String,
    /// The optimiser that ran it; `None`: the stage was skipped or could not start.
    pub optimiser: Option<StageOptimiser>,
    /// Iterations.
    pub iterations: usize,
    /// Trial points that could not be simulated.
    pub failures: usize,
    /// How it ended (the optimiser's stopping reason, or why it did not run).
    pub outcome: String,
    /// The whole files' cost (4.2)/(4.3) at its result; `None` after the final stage, or
    /// where the whole files cannot be simulated from it.
    pub whole_files_cost: Option<f64>,
    /// Cost evaluations the stage spent, each one simulation of its files (a Jacobian by
    /// finite differences counts one per column; by sensitivities, its simulation-cost
    /// equivalent). With parallel starts, the other starts' evaluations in the same
    /// interval are counted too. 0 in reports written before it was recorded.
    #[serde(default)]
    pub evaluations: usize,
    /// Jacobians the stage formed (fresh or by Broyden's update).
    #[serde(default)]
    pub jacobians: usize,
    /// Wall time of the stage (s), the whole files' cost at its result included.
    #[serde(default)]
    pub wall_s: f64,
}

impl StageRecord {
    /// A stage `stage` (its report name) that `optimiser` ran, ending as `outcome`, the
    /// whole files' cost at its result where known.
    pub(crate) fn ran(
        stage: String,
        optimiser: StageOptimiser,
        outcome: &StageOutcome,
        whole_files_cost: Option<f64>,
    ) -> Self {
        StageRecord {
            stage,
            optimiser: Some(optimiser),
            iterations: outcome.iterations,
            failures: outcome.failures,
            outcome: outcome.status.clone(),
            whole_files_cost,
            evaluations: 0,
            jacobians: 0,
            wall_s: 0.0,
        }
    }

    /// This record with what the stage spent since `since` on `context`'s counters.
    pub(crate) fn spent(mut self, since: &StageClock, context: &StageContext) -> Self {
        self.evaluations = context.evaluations.load(Ordering::Relaxed) - since.evaluations;
        self.jacobians = context.jacobians.load(Ordering::Relaxed) - since.jacobians;
        self.wall_s = since.started.elapsed().as_secs_f64();
        self
    }

    /// A stage that did not run, and why.
    pub(super) fn skipped(stage: Stage, why: String) -> Self {
        StageRecord {
            stage: stage.to_string(),
            optimiser: None,
            iterations: 0,
            failures: 0,
            outcome: why,
            whole_files_cost: None,
            evaluations: 0,
            jacobians: 0,
            wall_s: 0.0,
        }
    }
}

/// A stage's counters and clock at its start, for [`StageRecord::spent`].
pub(crate) struct StageClock {
    evaluations: usize,
    jacobians: usize,
    started: Instant,
}

impl StageClock {
    /// `context`'s counters now, the clock started.
    pub(crate) fn start(context: &StageContext) -> Self {
        StageClock {
            evaluations: context.evaluations.load(Ordering::Relaxed),
            jacobians: context.jacobians.load(Ordering::Relaxed),
            started: Instant::now(),
        }
    }
}
