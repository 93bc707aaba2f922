//! The balanced refit ([`SequenceOptions::balance`]): after a step whose joints of
//! interest are weighted apart, the whole files once more with every free joint weighted 1,
//! kept when the worst free joint's RMS / σ̂ falls.

use super::*;

/// The balanced refit after a step's fit ([`StepRefit::balance`]).
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct Balance {
    /// Per free joint: name, RMS error over the fitted samples over its noise σ̂ before
    /// and after the balanced refit; None where the files give no σ̂
    /// ([`JointFit::floor_ratio`](crate::identify::output_error::JointFit::floor_ratio)).
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
    /// give ([`JointFit::floor_ratio`](crate::identify::output_error::JointFit::floor_ratio)); 0 when
    /// none does.
    pub fn worst(&self) -> (f64, f64) {
        self.joints.iter().fold((0.0_f64, 0.0_f64), |(a, b), j| {
            (a.max(j.1.unwrap_or(0.0)), b.max(j.2.unwrap_or(0.0)))
        })
    }
}

impl StepRefit<'_> {
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
        let mut balanced_options = self.refit_options(&fit);
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
            .refit_problem(&to, second.names.clone(), self.refit_options(&fit))
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
}
