//! The initial-positions refit ([`SequenceOptions::initial_positions_refit`]): after a
//! step's starts have competed on the measured first samples, the kept minimum is fitted
//! once more with every file's initial positions estimated.

use super::*;

/// The refit of a step's kept minimum with the initial positions estimated
/// ([`StepRefit::refit_initial_positions`]).
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct InitialPositionsRefit {
    /// The cost (4.2)/(4.3) plus any prior term at the kept minimum (on the measured first
    /// samples) and after the refit (on the estimated initial positions).
    pub cost: (f64, f64),
    /// The largest move of a free joint's initial position from its first measured sample,
    /// in units of that joint's noise σ̂.
    pub largest_move: f64,
    /// Whether the refit was kept (its cost lower).
    pub kept: bool,
    /// How the refit ended and what it cost.
    #[serde(flatten)]
    pub work: RefitWork,
}

impl StepRefit<'_> {
    /// The kept minimum of a step (`fit`, after the warm-up start; `plant` the plant the
    /// step started from) fitted once more through the whole files with the free joints'
    /// initial positions estimated with the parameters
    /// ([`OutputErrorOptions::estimate_initial_positions`]: the stage from the measured
    /// first samples, then rounds of a Gauss–Newton step of every file's q(0) and the stage
    /// again), no warm-ups, one start; kept where its cost (plus the prior term of any
    /// carried prior) is lower. None where the step's options estimate the initial
    /// positions already, or the fit ends above the noise floor
    /// ([`Statistics::above_floor`]): there the residual is the model's error, which
    /// estimated starts would absorb (k1 of the Freedom 6S, its starts estimated at the
    /// predictor's end: q5(0) moved by 3.2 σ̂ and the fit stalled at 4.19 against 0.607).
    ///
    /// Why after the starts and not in them: the first measured sample carries the sensor's
    /// noise, and where friction holds a joint at the start of a file the offset persists
    /// for the whole file — c3 of the Freedom 6S on seed-23 data ended at 1.12 σ̂ on its
    /// measured start and reaches 1.00 σ̂ with the start estimated. But estimating inside
    /// every start changes the starts' paths: c5 on seed-35 data then settled at 1.07 σ̂ in
    /// a wrong minimum (qeq_1 −5.5 %, called identifiable), low enough to hide from the
    /// floor test that runs the warm-up start, which finds the truth's minimum from the
    /// measured starts. Refitting only the kept minimum estimates the starts without
    /// choosing the minimum by them (the identification record, stop 83).
    ///
    /// # Errors
    /// The refit's problem cannot be set up (a fitted value without bounds or outside
    /// them), or its fit fails.
    pub fn refit_initial_positions(
        &self,
        plant: &Plant,
        fit: FitResult,
    ) -> Result<(FitResult, Option<InitialPositionsRefit>)> {
        if self.problem.options().estimate_initial_positions
            || !fit.statistics.above_floor.is_empty()
            || !fit.cost_after.is_finite()
        {
            return Ok((fit, None));
        }
        let mut from = plant.clone();
        fit.apply(&mut from);
        let mut options = self.refit_options(&fit);
        options.estimate_initial_positions = true;
        let second = self
            .refit_problem(&from, fit.names.clone(), options)
            .context("the initial-positions refit")?
            .fit(self.progress)?;
        let before = fit.cost_after + fit.prior_penalty;
        let after = second.cost_after + second.prior_penalty;
        let largest_move = second
            .initial_positions
            .iter()
            .flatten()
            .flat_map(|d| d.iter().zip(&second.statistics.joints))
            .map(|(d, j)| d.abs() / j.noise.max(f64::MIN_POSITIVE))
            .fold(0.0, f64::max);
        let record = InitialPositionsRefit {
            cost: (before, after),
            largest_move,
            kept: after < before,
            work: RefitWork::of(&second),
        };
        // The refit starts where the least change of the step's fit left the values; its
        // own least change moves them only where it moved something, and otherwise the
        // step's record (the plant-gain scale, the ties) stays the one reported.
        let own_move = second.least_change.as_ref().is_some_and(|l| {
            l.accepted && (!l.moved.is_empty() || !l.held.is_empty() || l.gain_scale.is_some())
        });
        let first_least_change = fit.least_change.clone();
        let mut merged = merge_refit(plant, fit, second, record.kept);
        if record.kept && !own_move {
            merged.least_change = first_least_change;
        }
        Ok((merged, Some(record)))
    }
}
