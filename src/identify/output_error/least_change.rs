//! The least change along ties (after a step's fit): the rigid-body symbols moved back toward
//! the plant's initial values along the combinations the step cannot tell apart, and the
//! plant-gain scale move.

use super::*;

impl Problem {
    /// Least-change solution: from a minimum `p` of the cost, the point the data cannot tell
    /// from it that is nearest the plant's values p₀.
    ///
    /// The configuration sees the rigid body only through its base parameters β, so the
    /// fitted rigid-body symbols move from `p` toward p₀ along β = β(p)
    /// ([`least_change_along_ties`](crate::identify::identifiability::least_change_along_ties)):
    /// the same torques, the same simulated positions. The move is simulated and kept when
    /// the cost stays within one weighted noise variance σ̂² = S / (m − n) of the cost
    /// S = `cost_at_minimum` at `p` (as the fit computed it; the move changes it by
    /// rounding only); otherwise `p` is returned unchanged.
    ///
    /// Then the plant-gain scale: scaling the plant gains with every force of the
    /// configuration (the inertial symbols m·, I·, the friction levels, springs and
    /// offsets: [`scales_with_the_gain`]) by α moves nothing (Kp τ = D q̈ + … all × α), so
    /// position data cannot fix α; when every such parameter the configuration has is
    /// fitted, the fit ends anywhere on that line (k1 of the Freedom 6S from the Appendix
    /// D guess through the prediction-error homotopy: all −46 %, which k2 then inherits as
    /// "identifiable" values −46 % off). They are scaled by the α* that returns the fitted
    /// plant gains to their initial values (geometric mean of p₀ / p over them; the rest of
    /// the family follows, the held ties among it included: [`LeastChange::held`]), each
    /// clamped to its bounds, and the move is kept by the same rule; if the cost rises,
    /// α* clamped to keep every member inside its bounds is tried.
    /// (An earlier α* = Σρ/Σρ² over the whole family was set by its worst-determined
    /// member: k1's Fs_q5 at 50 × its initial value, with vs_q5 → 0, held the family at
    /// −50 %.) Where a held parameter breaks the symmetry the cost rises and the move is
    /// dropped.
    ///
    /// Directions the data determine only weakly (small but not zero singular values of
    /// the Jacobian) are left where the fit put them: a linearised move along them was
    /// tried and the simulated cost rose by orders of magnitude beyond the prediction (k1
    /// of the Freedom 6S: predicted 0.6068, simulated 516).
    ///
    /// # Errors
    /// The plant's barycentric parameters cannot be formed.
    pub fn least_change(&self, p: &[f64], cost_at_minimum: f64) -> Result<LeastChange> {
        let p0 = self.initial_values();
        let dof = self.m.saturating_sub(p.len()).max(1) as f64;
        let allowed_rise = cost_at_minimum / dof;
        let moved_to = crate::identify::identifiability::least_change_along_ties(
            &self.plant_at(p),
            self.conf,
            &self.names,
            &p0,
            &self.lower,
            &self.upper,
        )?;
        let cost = self.cost(&moved_to);
        let accepted = cost <= cost_at_minimum + allowed_rise;
        let (mut fitted, mut cost) = if accepted {
            (moved_to, cost)
        } else {
            (p.to_vec(), cost_at_minimum)
        };
        let mut gain_scale = None;
        let mut gain_scale_bound_by = None;
        let mut held = Vec::new();
        for m in self.gain_scale_toward(&fitted, &p0) {
            let c = self.with_plant_values(&m.held).cost(&m.fitted);
            if c <= cost_at_minimum + allowed_rise {
                (fitted, cost, held) = (m.fitted, c, m.held);
                gain_scale = Some(m.alpha);
                gain_scale_bound_by = m.bound_by;
                break;
            }
        }
        // Where the bounds stopped the scale short of α*, the gains do not return: say how far.
        let gains_after =
            gain_scale.map(|_| self.log_gain_ratio(&fitted, &p0).map_or(1.0, f64::exp));
        let moved = (0..p.len())
            .filter(|&i| (fitted[i] - p[i]).abs() > 1e-6 * (self.upper[i] - self.lower[i]))
            .map(|i| self.names[i].clone())
            .chain(held.iter().map(|(n, _)| n.clone()))
            .collect();
        Ok(LeastChange {
            fitted,
            held,
            cost_at_minimum,
            cost,
            allowed_rise,
            moved,
            accepted,
            gain_scale,
            gains_after,
            gain_scale_bound_by,
        })
    }

    /// The mean of ln(p / p₀) over the fitted plant gains `Kp_j` (the log of their
    /// geometric mean ratio: 0 where every gain is at its initial value; α* of
    /// [`Problem::gain_scale_toward`] is its exp(−·)). `None` without a fitted gain of
    /// the same sign as its initial value.
    fn log_gain_ratio(&self, p: &[f64], p0: &[f64]) -> Option<f64> {
        let log_rho: Vec<f64> = (0..p.len())
            .filter(|&i| self.names[i].starts_with("Kp_") && p0[i] != 0.0 && p[i] / p0[i] > 0.0)
            .map(|i| (p[i] / p0[i]).ln())
            .collect();
        (!log_rho.is_empty()).then(|| log_rho.iter().sum::<f64>() / log_rho.len() as f64)
    }

    /// The same problem with the plant's values of the (not fitted) parameters `values`
    /// replaced: the held ties the plant-gain scale move scales
    /// ([`Problem::least_change`]). Borrowed when `values` is empty.
    pub(super) fn with_plant_values(
        &self,
        values: &[(String, f64)],
    ) -> std::borrow::Cow<'_, Problem> {
        if values.is_empty() {
            return std::borrow::Cow::Borrowed(self);
        }
        let mut q = self.clone();
        for (n, v) in values {
            q.plant.parameters.insert(n.clone(), *v);
        }
        std::borrow::Cow::Owned(q)
    }

    /// The moves along the plant-gain scale of [`Problem::least_change`], best first: every
    /// fitted parameter that [`scales_with_the_gain`] times α*, where α* brings the fitted
    /// plant gains back to their initial values (the geometric mean of p₀ / p over the
    /// fitted `Kp_j`: a gain is amplifier × gearing, the force scale a user knows best; a
    /// member the data do not determine, such as a Stribeck level with vs → 0, must not set
    /// the scale). The held ties among the members ([`Problem::with_held_ties`]: inertias
    /// left at arbitrary values along exact ties, which the fitted symbols compensate)
    /// are scaled too, or the move would not be exact (k1 of the Freedom 6S: I7_13 held,
    /// the move from × 0.5 raised the RMS error from 2.0e-4 to 3.3e-4 rad). First each
    /// member is clamped to its own bounds (exact where a clamped member does not matter);
    /// then α* is clamped so that every member stays inside (exact always). Empty when no
    /// plant gain is fitted or α* is within 1e-9 of 1.
    pub(super) fn gain_scale_toward(&self, p: &[f64], p0: &[f64]) -> Vec<GainScaleMove> {
        let model = self.plant.model;
        let members: Vec<usize> = (0..p.len())
            .filter(|&i| scales_with_the_gain(model, &self.names[i]) && p[i] != 0.0 && p0[i] != 0.0)
            .collect();
        // Held ties that scale: (name, value, bounds (±∞ without)).
        let held: Vec<(&String, f64, f64, f64)> = self
            .held_ties
            .iter()
            .filter(|n| scales_with_the_gain(model, n))
            .filter_map(|n| {
                let v = *self.plant.parameters.get(n)?;
                let (lo, hi) = self
                    .plant
                    .bounds
                    .get(n)
                    .copied()
                    .unwrap_or((f64::NEG_INFINITY, f64::INFINITY));
                (v != 0.0).then_some((n, v, lo, hi))
            })
            .collect();
        let Some(log_rho) = self.log_gain_ratio(p, p0) else {
            return Vec::new();
        };
        let alpha = (-log_rho).exp();
        let mut within = alpha;
        // The member whose bounds clamp α last (the tightest: every interval holds 1).
        let mut binding: Option<&String> = None;
        let values = members
            .iter()
            .map(|&i| (&self.names[i], p[i], self.lower[i], self.upper[i]))
            .chain(held.iter().copied());
        for (name, v, lo, hi) in values {
            // α v within [lo, hi].
            let (a, b) = (lo / v, hi / v);
            let clamped = within.clamp(a.min(b), a.max(b));
            if clamped != within {
                binding = Some(name);
            }
            within = clamped;
        }
        let scaled = |alpha: f64, bound_by: Option<&String>| {
            let mut fitted = p.to_vec();
            for &i in &members {
                fitted[i] = (alpha * p[i]).clamp(self.lower[i], self.upper[i]);
            }
            let held = held
                .iter()
                .map(|&(n, v, lo, hi)| (n.clone(), (alpha * v).clamp(lo, hi)))
                .collect();
            GainScaleMove {
                alpha,
                fitted,
                held,
                bound_by: bound_by.cloned(),
            }
        };
        let mut out: Vec<GainScaleMove> = Vec::new();
        for (a, bound_by) in [(alpha, None), (within, binding)] {
            let new = out.iter().all(|m| (a - m.alpha).abs() > 1e-9);
            if a.is_finite() && a > 0.0 && (a - 1.0).abs() >= 1e-9 && new {
                out.push(scaled(a, bound_by));
            }
        }
        out
    }
}

/// Result of [`Problem::least_change`].
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct LeastChange {
    /// The parameters after the move (physical units).
    #[serde(skip)]
    pub fitted: Vec<f64>,
    /// Held ties (not fitted; [`Problem::with_held_ties`]) the plant-gain scale move
    /// scaled with the rest, with their new values (physical units): the plant's values
    /// must change with the fitted ones ([`FitResult::apply`] writes both).
    pub held: Vec<(String, f64)>,
    /// Cost at the minimum the move started from.
    pub cost_at_minimum: f64,
    /// Cost after the move.
    pub cost: f64,
    /// The largest rise accepted: one weighted noise variance S / (m − n).
    pub allowed_rise: f64,
    /// The symbols the move changed.
    pub moved: Vec<String>,
    /// Whether the move along the ties was kept (the simulated cost within the allowed
    /// rise).
    pub accepted: bool,
    /// The plant-gain scale α applied after it (every parameter that scales with the gain
    /// times α), when that move was kept; `None` when there was none or it raised the
    /// cost.
    pub gain_scale: Option<f64>,
    /// After that move, the fitted plant gains over their initial values (geometric
    /// mean): 1 where the move returned them, another value where a member's bounds
    /// stopped it short. `None` without the move (and in reports written before it was
    /// recorded).
    #[serde(default)]
    pub gains_after: Option<f64>,
    /// The fitted value or held tie whose bounds stopped that move short of returning the
    /// gains (None where it returned them, or without the move).
    #[serde(default)]
    pub gain_scale_bound_by: Option<String>,
}

/// One candidate of the plant-gain scale move ([`Problem::least_change`]).
pub(super) struct GainScaleMove {
    /// The scale α.
    alpha: f64,
    /// The fitted parameters after it.
    fitted: Vec<f64>,
    /// The held ties it scales, with their new values.
    held: Vec<(String, f64)>,
    /// The member whose bounds stopped α short of α* (None for α* itself).
    bound_by: Option<String>,
}

/// Whether parameter `name` scales with the plant gain in the exact symmetry of position
/// data (Kp τ = D(q) q̈ + C q̇ + φ + friction + spring + offset, every term × α leaves q(t)
/// unchanged): the plant gains `Kp_j`; the inertial symbols of masses and inertias (`m…`,
/// `I…`: the barycentric parameters are products of them with the centroid coordinates,
/// which do not scale); the friction levels `Fv`, `Fc`, `Fs`, `Fv_pos`, `Fc_pos`, `Fv_neg`,
/// `Fc_neg`, the LuGre `sigma0`, `sigma1`, `sigma2` (z's dynamics depend on σ0 / g(v),
/// unchanged); springs `Ks`; offsets. Not: `vs`, `qeq`, `FrictionBias`, the tendon `G`.
pub fn scales_with_the_gain(model: &generated::Model, name: &str) -> bool {
    if model.inertial_symbols.contains(&name) {
        return name.starts_with('m') || name.starts_with('I');
    }
    let Some((symbol, _)) = crate::names::split_parameter(model.joints, name) else {
        return false;
    };
    matches!(
        symbol,
        "Kp" | "Fv"
            | "Fc"
            | "Fs"
            | "Fv_pos"
            | "Fc_pos"
            | "Fv_neg"
            | "Fc_neg"
            | "sigma0"
            | "sigma1"
            | "sigma2"
            | "Ks"
            | "offset"
    )
}
