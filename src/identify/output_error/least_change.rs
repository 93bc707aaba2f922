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
    /// "identifiable" values −46 % off). They are moved to the point of that line nearest
    /// the plant's values: α and the rigid-body symbols (the step's held ties among them,
    /// [`LeastChange::held`]) chosen together so that the plant gains and the rigid-body
    /// symbols change least in units of their bounds' widths, the friction levels, springs
    /// and offsets following α
    /// ([`least_change_along_scale`](crate::identify::identifiability::least_change_along_scale));
    /// the move is kept by the
    /// same rule; if the cost rises, the same with α limited to keep every member inside
    /// its bounds is tried. Where a held parameter breaks the symmetry the cost rises and
    /// the move is dropped.
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
        // Under the earlier steps' information (Problem::with_earlier_information) a move
        // along this configuration's ties may cross what earlier files determined: its
        // prior counts.
        let prior_at = |x: &[f64]| self.prior_penalty(&self.to_scaled(x));
        let prior_before = prior_at(p);
        let cost = self.cost(&moved_to);
        let accepted = cost + prior_at(&moved_to) <= cost_at_minimum + prior_before + allowed_rise;
        let (mut fitted, mut cost) = if accepted {
            (moved_to, cost)
        } else {
            (p.to_vec(), cost_at_minimum)
        };
        let mut gain_scale = None;
        let mut gain_scale_bound_by = None;
        let mut held = Vec::new();
        for m in self.gain_scale_toward(&fitted, &p0) {
            // Held values the earlier steps' files determined are not this step's to scale.
            if m.held
                .iter()
                .any(|(n, _)| self.earlier_information().is_some_and(|e| e.knows(n)))
            {
                continue;
            }
            let c = self.with_plant_values(&m.held).cost(&m.fitted);
            if c + prior_at(&m.fitted) <= cost_at_minimum + prior_before + allowed_rise {
                (fitted, cost, held) = (m.fitted, c, m.held);
                gain_scale = Some(m.alpha);
                gain_scale_bound_by = m.bound_by;
                break;
            }
        }
        // Where the gains end after the move (the nearest point need not return them).
        let gains_after =
            gain_scale.map(|_| self.log_gain_ratio(&fitted, &p0).map_or(1.0, f64::exp));
        let moved = self
            .moved_between(p, &fitted)
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

    /// The indices of the fitted values that differ between `a` and `b` by more than
    /// 1e-6 of their bounds' width (less is a solve's rounding, no move).
    fn moved_between<'a>(&'a self, a: &'a [f64], b: &'a [f64]) -> impl Iterator<Item = usize> + 'a {
        (0..a.len()).filter(move |&i| (b[i] - a[i]).abs() > 1e-6 * (self.upper[i] - self.lower[i]))
    }

    /// The mean of ln(p / p₀) over the fitted plant gains `Kp_j` (the log of their
    /// geometric mean ratio: 0 where every gain is at its initial value; the report's
    /// [`LeastChange::gains_after`] is its exp). `None` without a fitted gain of the same
    /// sign as its initial value.
    fn log_gain_ratio(&self, p: &[f64], p0: &[f64]) -> Option<f64> {
        let log_rho: Vec<f64> = (0..p.len())
            .filter(|&i| self.names[i].starts_with("Kp_") && p0[i] != 0.0 && p[i] / p0[i] > 0.0)
            .map(|i| (p[i] / p0[i]).ln())
            .collect();
        (!log_rho.is_empty()).then(|| log_rho.iter().sum::<f64>() / log_rho.len() as f64)
    }

    /// The same problem with the plant's values of the (not fitted) parameters `values`
    /// replaced: the held ties the plant-gain scale move moves
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

    /// The moves along the plant-gain scale of [`Problem::least_change`], best first: the
    /// point of the exact symmetry nearest the plant's values
    /// ([`least_change_along_scale`](crate::identify::identifiability::least_change_along_scale)):
    /// every fitted parameter that [`scales_with_the_gain`] times α, the rigid-body symbols
    /// — fitted, and the step's held ties ([`Problem::with_held_ties`]: inertias left at
    /// arbitrary values along exact ties) — moved along the ties so that the base
    /// parameters are α × the minimum's, with α and those symbols chosen together to change
    /// the plant gains and the rigid-body symbols least, each in units of its bounds'
    /// width (the spread the user gave it). The other members (friction levels, springs,
    /// offsets) follow α and do not count: a member the data do not determine, such as a
    /// Stribeck level with vs → 0, must not set the scale (k1 of the Freedom 6S: Fs_q5 at
    /// 50 × its initial value held the family at −50 %).
    ///
    /// Neither the gains nor the held ties alone may set it. Returning the gains to their
    /// initial values with the held ties scaled along (as before stop 82) halved link 7's
    /// mass in c2 of the Freedom 6S (a held tie, 0.060 → 0.030 kg, its bound), which c3
    /// then saw; and in c4, where the Appendix D guess has Kp_q2 = 1 against the truth's
    /// 4.6, it scaled every held link mass by 0.67 and c5 ended at 2 σ̂. Keeping the held
    /// ties while returning the gains is impossible there (I7_22, c4's one fitted inertia,
    /// would have to leave its bounds).
    ///
    /// First α within the range that keeps the gains inside their bounds, the other members
    /// clamped to theirs (exact where a clamped member does not matter); then α within the
    /// range that keeps every member inside (exact always). Empty when no plant gain is
    /// fitted or the nearest point is the minimum itself (α within 1e-6 of 1, every value
    /// within 1e-6 of its bounds' width).
    pub(super) fn gain_scale_toward(&self, p: &[f64], p0: &[f64]) -> Vec<GainScaleMove> {
        let model = self.plant.model;
        // The members that follow α (the rigid-body ones move in the solve).
        let followers: Vec<usize> = (0..p.len())
            .filter(|&i| {
                let name = self.names[i].as_str();
                scales_with_the_gain(model, name)
                    && !model.inertial_symbols.contains(&name)
                    && p[i] != 0.0
                    && p0[i] != 0.0
            })
            .collect();
        let gains: Vec<usize> = followers
            .iter()
            .copied()
            .filter(|&i| self.names[i].starts_with("Kp_"))
            .collect();
        if gains.is_empty() {
            return Vec::new();
        }
        // The held ties with bounds join the fitted symbols as unknowns of the tie move; the
        // rest stay where they are.
        let held: Vec<(String, f64, f64, f64)> = self
            .held_ties
            .iter()
            .filter(|n| !self.names.contains(n))
            .filter_map(|n| {
                let v = *self.plant.parameters.get(n)?;
                let (lo, hi) = *self.plant.bounds.get(n)?;
                // One pinned by its bounds (lower = upper) stays, as one without bounds.
                (hi > lo).then(|| (n.clone(), v, lo, hi))
            })
            .collect();
        let mut names = self.names.clone();
        let (mut initial, mut lower, mut upper) =
            (p0.to_vec(), self.lower.clone(), self.upper.clone());
        for (n, v, lo, hi) in &held {
            names.push(n.clone());
            initial.push(*v);
            lower.push(*lo);
            upper.push(*hi);
        }
        // α p within [lo, hi] for each of `over`: the range, and whose bound ends each side.
        let range = |over: &[usize]| {
            let (mut a, mut b) = ((1e-3f64, None), (1e3f64, None));
            for &i in over {
                let (x, y) = (self.lower[i] / p[i], self.upper[i] / p[i]);
                let (x, y) = (x.min(y), x.max(y));
                if x > a.0 {
                    a = (x, Some(self.names[i].clone()));
                }
                if y < b.0 {
                    b = (y, Some(self.names[i].clone()));
                }
            }
            (a, b)
        };
        let mut out: Vec<GainScaleMove> = Vec::new();
        for over in [&gains, &followers] {
            let (a, b) = range(over);
            if out.iter().any(|m| m.range == (a.0, b.0)) || a.0 > b.0 {
                continue;
            }
            let Some(mut m) =
                self.nearest_on_scale(p, &names, &gains, &initial, (&lower, &upper), (a.0, b.0))
            else {
                continue;
            };
            m.bound_by = if (m.alpha / a.0 - 1.0).abs() < 1e-9 {
                a.1.clone()
            } else if (m.alpha / b.0 - 1.0).abs() < 1e-9 {
                b.1.clone()
            } else {
                None
            };
            for &i in &followers {
                m.fitted[i] = (m.alpha * p[i]).clamp(self.lower[i], self.upper[i]);
            }
            // The solve's rounding is no move: α within 1e-6 of 1, no value moved.
            let moved = (m.alpha - 1.0).abs() >= 1e-6
                || self.moved_between(p, &m.fitted).next().is_some()
                || !m.held.is_empty();
            if moved {
                out.push(m);
            }
        }
        out
    }

    /// One solve of [`Problem::gain_scale_toward`]: the nearest point with α within
    /// `alpha_range`, over `names` (the fitted parameters, then the held ties) with
    /// `initial` values and `bounds`. The fitted members that follow α are left at `p`
    /// (the caller scales them); a held tie moved by less than 1e-6 of its bounds' width
    /// stays where it was. `None` where the rigid-body symbols cannot keep α β
    /// within their bounds (a base parameter missed by more than 1e-6 of it) or β cannot
    /// be formed.
    fn nearest_on_scale(
        &self,
        p: &[f64],
        names: &[String],
        gains: &[usize],
        initial: &[f64],
        (lower, upper): (&[f64], &[f64]),
        alpha_range: (f64, f64),
    ) -> Option<GainScaleMove> {
        use crate::identify::identifiability::{
            base_parameter_values_at, least_change_along_scale,
        };
        let locked_at = self.locked_at();
        let at_p = self.plant_at(p);
        let (alpha, values) = least_change_along_scale(
            &at_p,
            self.conf,
            &locked_at,
            names,
            gains,
            initial,
            lower,
            upper,
            alpha_range,
        )
        .ok()?;
        let n = p.len();
        // A held tie the solve moved by less than 1e-6 of its bounds' width stays: its share
        // is rounding, and the plant keeps the value an earlier step or the user gave.
        let held: Vec<(String, f64)> = (n..names.len())
            .filter(|&i| (values[i] - initial[i]).abs() > 1e-6 * (upper[i] - lower[i]))
            .map(|i| (names[i].clone(), values[i]))
            .collect();
        let mut moved_plant = at_p.clone();
        for (name, v) in names[..n]
            .iter()
            .zip(&values)
            .chain(held.iter().map(|(a, b)| (a, b)))
        {
            moved_plant.parameters.insert(name.clone(), *v);
        }
        let beta = |plant: &Plant| -> Option<Vec<f64>> {
            let named = base_parameter_values_at(plant, self.conf, &locked_at).ok()?;
            Some(named.into_iter().map(|(_, b)| b).collect())
        };
        let target: Vec<f64> = beta(&at_p)?.iter().map(|b| alpha * b).collect();
        let reached = beta(&moved_plant)?;
        let largest = target.iter().fold(0.0f64, |a, b| a.max(b.abs()));
        let exact = reached
            .iter()
            .zip(&target)
            .all(|(r, t)| (r - t).abs() <= 1e-6 * t.abs().max(1e-9 * largest));
        if !exact {
            return None;
        }
        Some(GainScaleMove {
            alpha,
            fitted: values[..n].to_vec(),
            held,
            bound_by: None,
            range: alpha_range,
        })
    }
}

/// Result of [`Problem::least_change`].
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct LeastChange {
    /// The parameters after the move (physical units).
    #[serde(skip)]
    pub fitted: Vec<f64>,
    /// Held ties (not fitted; [`Problem::with_held_ties`]) the plant-gain scale move
    /// moved along the ties with the rest, with their new values (physical units): the
    /// plant's values must change with the fitted ones ([`FitResult::apply`] writes both).
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
    /// mean): 1 where the nearest point of the symmetry returns them, another value where
    /// the rigid-body symbols or a member's bounds hold them elsewhere. `None` without the
    /// move (and in reports written before it was recorded).
    #[serde(default)]
    pub gains_after: Option<f64>,
    /// The fitted value whose bounds stopped α (None where α is inside its range, or
    /// without the move).
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
    /// The member whose bound stopped α (None where α is inside its range).
    bound_by: Option<String>,
    /// The range of α searched.
    range: (f64, f64),
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
