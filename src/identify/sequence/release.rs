//! The release of held values ([`SequenceOptions::release_held`]): where a step ends
//! above the noise floor, the values earlier steps fitted that its data see better are
//! fitted again under a Gaussian prior about their held values (the sequential estimate).

use super::*;

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
    /// tolerates — on the Freedom 6S, k2's qeq_q3 (−1.9 %, 1.4 of its standard errors) alone
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
        let options = self.refit_options(&fit);
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
}
