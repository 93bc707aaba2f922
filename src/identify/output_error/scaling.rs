//! The scaled coordinates of every fit: bounds and Fs ≥ Fc (thesis (4.1)) kept at every trial
//! point by fitting u ∈ [0, 1]ⁿ.

use super::*;

/// Lower bounds, upper bounds (physical units) and the (Fc, Fs) index pairs kept feasible by
/// the scaled coordinates ([`feasible_bounds`]).
pub(crate) type FeasibleBounds = (Vec<f64>, Vec<f64>, Vec<(usize, usize)>);

/// Bounds of the fitted parameters `names` of `plant` (physical units) with the constraint
/// Fs ≥ Fc (4.1) folded in: both of a joint fitted → an (Fc, Fs) index pair that the
/// scaled coordinates keep feasible ([`scaled_to_physical`]); one fitted → a bound from the
/// other's value. `fitted_in` names the fit for the messages (e.g. "configuration 'k3'").
///
/// # Errors
/// A fitted parameter without value or bounds, with lower ≥ upper, or with its value
/// outside its bounds; Fs ≥ Fc infeasible within the bounds (all named).
pub(crate) fn feasible_bounds(
    plant: &Plant,
    names: &[String],
    fitted_in: &str,
) -> Result<FeasibleBounds> {
    let pname = plant.name();
    let mut lower = Vec::new();
    let mut upper = Vec::new();
    for n in names {
        let v = plant.value(n)?;
        let Some(&(lo, hi)) = plant.bounds.get(n) else {
            bail!("{pname}: parameter '{n}' is fitted in {fitted_in} but has no bounds (add `{n} = [lower, upper]` under [bounds])");
        };
        if lo >= hi {
            bail!("{pname}: bounds of '{n}' are [{lo}, {hi}]: lower must be below upper for a fitted parameter");
        }
        if !(lo..=hi).contains(&v) {
            bail!("{pname}: '{n}' = {v} is outside its bounds [{lo}, {hi}]");
        }
        lower.push(lo);
        upper.push(hi);
    }
    // Fs ≥ Fc per joint (4.1): both fitted → mapped pair; one fitted → a bound.
    let mut pairs = Vec::new();
    for (i, n) in names.iter().enumerate() {
        let Some(j) = n.strip_prefix("Fc_") else {
            continue;
        };
        let fs = format!("Fs_{j}");
        match names.iter().position(|x| *x == fs) {
            Some(k) => {
                upper[i] = upper[i].min(upper[k]);
                if upper[i] < lower[i] {
                    bail!(
                        "{pname}: Fs_{j} ≥ Fc_{j} cannot hold: Fs_{j} ≤ {} but Fc_{j} ≥ {}",
                        upper[k],
                        lower[i]
                    );
                }
                pairs.push((i, k));
            }
            None => {
                if let Ok(fs_v) = plant.value(&fs) {
                    upper[i] = upper[i].min(fs_v);
                    if upper[i] < lower[i] {
                        bail!("{pname}: Fs_{j} = {fs_v} (fixed) is below the lower bound {} of Fc_{j}", lower[i]);
                    }
                }
            }
        }
    }
    for (k, n) in names.iter().enumerate() {
        let Some(j) = n.strip_prefix("Fs_") else {
            continue;
        };
        let fc = format!("Fc_{j}");
        if !names.contains(&fc) {
            if let Ok(fc_v) = plant.value(&fc) {
                lower[k] = lower[k].max(fc_v);
                if upper[k] < lower[k] {
                    bail!(
                        "{pname}: Fc_{j} = {fc_v} (fixed) is above the upper bound {} of Fs_{j}",
                        upper[k]
                    );
                }
            }
        }
    }
    Ok((lower, upper, pairs))
}

/// Physical parameters from scaled ones u ∈ [0, 1]ⁿ within `lower`, `upper`, and each
/// (Fc, Fs) pair of `pairs` as Fs = max(Fc, lo_Fs) + u (hi_Fs − max(Fc, lo_Fs))
/// ([`feasible_bounds`]).
pub(crate) fn scaled_to_physical(
    lower: &[f64],
    upper: &[f64],
    pairs: &[(usize, usize)],
    u: &[f64],
) -> Vec<f64> {
    let mut p: Vec<f64> = (0..u.len())
        .map(|i| {
            // lower + 1 × (upper − lower) can round past upper; the plant file written
            // from these values must read back within its bounds.
            (lower[i] + u[i].clamp(0.0, 1.0) * (upper[i] - lower[i])).clamp(lower[i], upper[i])
        })
        .collect();
    for &(c, s) in pairs {
        let lo = p[c].max(lower[s]);
        p[s] = (lo + u[s].clamp(0.0, 1.0) * (upper[s] - lo).max(0.0)).clamp(lo, upper[s].max(lo));
    }
    p
}

/// Scaled parameters of physical ones `p` (clamped into the feasible set), the inverse of
/// [`scaled_to_physical`].
pub(crate) fn physical_to_scaled(
    lower: &[f64],
    upper: &[f64],
    pairs: &[(usize, usize)],
    p: &[f64],
) -> Vec<f64> {
    let mut u: Vec<f64> = (0..p.len())
        .map(|i| ((p[i] - lower[i]) / (upper[i] - lower[i])).clamp(0.0, 1.0))
        .collect();
    for &(c, s) in pairs {
        let pc = lower[c] + u[c] * (upper[c] - lower[c]);
        let lo = pc.max(lower[s]);
        let w = upper[s] - lo;
        u[s] = if w > 0.0 {
            ((p[s] - lo) / w).clamp(0.0, 1.0)
        } else {
            0.0
        };
    }
    u
}
