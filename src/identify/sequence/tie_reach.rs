//! The reach across held ties ([`SequenceOptions::tie_reach`]): where a step ends above
//! the floor with a spanning rigid-body symbol on a bound, that bound is widened by what the
//! held ties can carry, the result spread back over every symbol's own bounds.

use super::*;

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

impl StepRefit<'_> {
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
        let mut options = self.refit_options(&fit);
        // The wide fit's values are only a β to spread back: no least change on them.
        options.least_change = false;
        // The first fit's Stribeck branch was fitted with the rigid body held short of its
        // β: the friction may have absorbed the missing inertia (c6 of the Freedom 6S: the
        // dip collapsed, Fs_q0 = Fc_q0, and the wide fit from there ended at 1.68 σ̂).
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
        let second = refit(&back, self.refit_options(&fit))?;
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
