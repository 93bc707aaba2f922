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
        if self.own_warm_ups() || fit.statistics.above_floor.is_empty() {
            return Ok((fit, None));
        }
        let second = self.through_the_warm_ups(plant, &fit)?;
        let kept = second.cost_after < fit.cost_after;
        let record = WarmUpStart {
            above_floor: fit.statistics.above_floor.clone(),
            cost: (fit.cost_after, second.cost_after),
            kept,
            work: RefitWork::of(&second),
        };
        Ok((lower_with_work_of_both(fit, second, kept), Some(record)))
    }

    /// Whether the step's options have warm-ups of their own (an equation-error start, a
    /// predictor stage or segments).
    fn own_warm_ups(&self) -> bool {
        let options = self.problem.options();
        options.equation_error.is_some()
            || !options.predictor.is_empty()
            || !options.segments.is_empty()
    }

    /// The second fit of `fit`'s parameters from `plant` through the coupled preset's
    /// warm-ups alone (the plant's values through the whole files would repeat the first
    /// start's path: `--horizons none`).
    fn through_the_warm_ups(&self, plant: &Plant, fit: &FitResult) -> Result<FitResult> {
        let warm_options = OutputErrorOptions {
            horizons: Vec::new(),
            segments: Vec::new(),
            ..self.problem.options().clone()
        }
        .with_coupled_warm_ups();
        self.refit_problem(plant, fit.names.clone(), warm_options)
            .context("the warm-up start")?
            .fit(self.progress)
    }
}

/// The kept one of `fit` and `second` (`second` where `kept`), with the work of both.
fn lower_with_work_of_both(fit: FitResult, second: FitResult, kept: bool) -> FitResult {
    let (mut best, other) = if kept { (second, fit) } else { (fit, second) };
    best.evaluations += other.evaluations;
    best.jacobians += other.jacobians;
    best.wall_s += other.wall_s;
    best
}

/// The warm-up start run because the step's residual at the floor is not white
/// ([`StepRefit::whiteness_start`]).
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct WhitenessStart {
    /// The free joints whose residual is not white at the kept minimum, with the test
    /// ("q1: Ljung–Box Q = 1556.0 > 44.3 over 25 lags").
    pub not_white: Vec<String>,
    /// The cost (4.2)/(4.3), initial positions estimated where the step's were, at the kept
    /// minimum and where the warm-up start ended (after its own initial-positions refit).
    pub cost: (f64, f64),
    /// Whether the warm-up start was kept (its cost lower).
    pub kept: bool,
    /// How the warm-up start ended and what it cost.
    #[serde(flatten)]
    pub work: RefitWork,
}

impl StepRefit<'_> {
    /// Where the step's kept minimum `fit` is at the noise floor but its residual is not
    /// white on some free joint ([`Problem::whiteness`], initial positions as `fit`
    /// estimated them), the warm-up start ([`StepRefit::warm_up_start`]'s second fit, from
    /// `plant`) and its initial-positions refit; the lower cost is kept. None where every
    /// residual is white, the fit is above the floor (the warm-up start's own case), or the
    /// step's options have warm-ups of their own.
    ///
    /// Why: the floor test reads the RMS, and a wrong minimum can sit near it. c5 of the
    /// isolated Freedom 6S on seed 31–37 data ended at 1.07 σ̂ with qeq_q1 5.5 % and vs_q1
    /// 32 % off, called identifiable; its residual's Ljung–Box Q was 1556 against 44.3,
    /// while at the truth it is 35.4 (the sensitivities record, stops 83 and 84).
    ///
    /// # Errors
    /// As [`StepRefit::warm_up_start`].
    pub fn whiteness_start(
        &self,
        plant: &Plant,
        fit: FitResult,
    ) -> Result<(FitResult, Option<WhitenessStart>)> {
        if self.own_warm_ups() || !fit.statistics.above_floor.is_empty() {
            return Ok((fit, None));
        }
        let at = match &fit.initial_positions {
            Some(offsets) => self.problem.with_initial_offsets(offsets),
            None => self.problem.clone(),
        };
        let not_white: Vec<String> = at
            .whiteness(&fit.fitted)?
            .into_iter()
            .filter(|(_, w)| !w.white())
            .map(|(j, w)| format!("{j}: {}", w.text()))
            .collect();
        if not_white.is_empty() {
            return Ok((fit, None));
        }
        let second = self.through_the_warm_ups(plant, &fit)?;
        // On estimated starts too, so that the costs compare.
        let (second, _) = self.refit_initial_positions(plant, second)?;
        let kept = second.cost_after < fit.cost_after;
        let record = WhitenessStart {
            not_white,
            cost: (fit.cost_after, second.cost_after),
            kept,
            work: RefitWork::of(&second),
        };
        Ok((lower_with_work_of_both(fit, second, kept), Some(record)))
    }
}
