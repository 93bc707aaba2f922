//! The warm-up start ([`SequenceOptions::warm_up_start`]): where a step's fit through the growing
//! horizons ends above the noise floor, a second start from the same plant through the
//! coupled preset's warm-ups, the lower final cost kept.

use super::*;

/// The second start of a step through the warm-ups ([`StepRefit::warm_up_start`]).
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct WarmUpStart {
    /// The free joints above the floor after the first start ([`Statistics::above_floor`]).
    pub above_floor: Vec<String>,
    /// The cost (4.2)/(4.3) where the first start (the growing horizons) ended and where
    /// the warm-up start ended.
    pub cost: (f64, f64),
    /// Whether the warm-up start was kept (its cost lower).
    pub kept: bool,
    /// How the warm-up start ended and what it cost.
    #[serde(flatten)]
    pub work: RefitWork,
}

impl StepRefit<'_> {
    /// Where the step's `fit` ended above the noise floor and the step's options have no
    /// warm-up of their own (no equation-error start, predictor stage or segments), a
    /// second fit of the same parameters from the plant the step started from (`plant`)
    /// through the
    /// warm-ups of [`OutputErrorOptions::coupled`] — the equation-error start (the torque
    /// balance at every sample, no simulation), then the prediction-error homotopy (the
    /// simulation pulled toward the measured positions less and less, at
    /// ω = 100, 30, 10, 3, 1 rad/s, ETDRK4 at 1/2000 s) — and the whole files at the step's
    /// own step and cost; the lower final cost is kept, with the work of both.
    ///
    /// Why: the output error of a 40 s file has local minima the growing horizons end in
    /// where the start is far off. On the isolated sequence of the Freedom 6S from the
    /// Appendix D guess (data: the identification record), c5 ended at 331 σ̂ through the
    /// horizons and at 1.08 σ̂ through the warm-ups; c4 ended at 625 σ̂ by finite
    /// differences through the horizons before stop 82.
    ///
    /// # Errors
    /// The second fit's problem cannot be set up (a fitted value without bounds), or it
    /// fails where the first did not.
    pub fn warm_up_start(
        &self,
        plant: &Plant,
        fit: FitResult,
    ) -> Result<(FitResult, Option<WarmUpStart>)> {
        let options = self.problem.options();
        let own_warm_ups = options.equation_error.is_some()
            || !options.predictor.is_empty()
            || !options.segments.is_empty();
        if own_warm_ups || fit.statistics.above_floor.is_empty() {
            return Ok((fit, None));
        }
        let warm_options = OutputErrorOptions {
            // The warm-ups alone: the plant's values through the whole files would repeat
            // the first start's path (`--horizons none`).
            horizons: Vec::new(),
            segments: Vec::new(),
            ..options.clone()
        }
        .with_coupled_warm_ups();
        let second = self
            .refit_problem(plant, fit.names.clone(), warm_options)
            .context("the warm-up start")?
            .fit(self.progress)?;
        let kept = second.cost_after < fit.cost_after;
        let record = WarmUpStart {
            above_floor: fit.statistics.above_floor.clone(),
            cost: (fit.cost_after, second.cost_after),
            kept,
            work: RefitWork::of(&second),
        };
        let (mut best, other) = if kept { (second, fit) } else { (fit, second) };
        best.evaluations += other.evaluations;
        best.jacobians += other.jacobians;
        best.wall_s += other.wall_s;
        Ok((best, Some(record)))
    }
}
