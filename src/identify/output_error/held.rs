//! Held values in the statistics: the share of a step's standard errors that comes from the
//! values earlier steps fitted and this one holds (their recorded standard errors and
//! correlations), the plant-gain scale family, and the held ties made up by the rigid body.

use super::*;

/// The scale of a value a fit holds (its units): its bound width, else its magnitude, else
/// 1 (a zero or unknown value without bounds).
pub(crate) fn held_scale(plant: &Plant, name: &str) -> f64 {
    match plant.bounds.get(name) {
        Some(&(lo, hi)) if hi > lo => hi - lo,
        _ => plant
            .parameters
            .get(name)
            .map_or(1.0, |v| if *v == 0.0 { 1.0 } else { v.abs() }),
    }
}

/// The fitted parameters `names` (values `p`) of the plant-gain scale family
/// ([`scales_with_the_gain`], nonzero) when the family is an exact symmetry of the fit:
/// every joint of `free` has its plant gain `Kp_j` fitted, and every value that `plant`
/// holds although it enters the fit (`held`, from [`held_in`]) and scales with the gain is
/// one of `held_ties` ([`Problem::with_held_ties`], scaled along with the family by
/// [`Problem::least_change`]). With `scales_unknown`, the held members of scale families
/// no step determined (`held.scales`, their scale a nuisance of the fit,
/// [`project_out_held_scales`]) move with the family too, a held gain among them counting
/// as fitted; without, they fix the scale as any held value does. `None` otherwise: a held
/// gain or force (an earlier step's) then fixes the scale, and the standard errors are
/// conditional on it.
pub(crate) fn gain_scale_family(
    plant: &Plant,
    names: &[String],
    p: &[f64],
    free: &[usize],
    (held, scales_unknown): (&HeldColumns, bool),
    held_ties: &[String],
) -> Option<Vec<usize>> {
    let model = plant.model;
    let in_scale = |n: &String| held.scales.iter().any(|s| s.names.contains(n));
    let gains_fitted = free.iter().all(|&j| {
        let gain = crate::names::parameter("Kp", model.joints[j]);
        names.iter().zip(p).any(|(n, v)| *n == gain && *v != 0.0)
            || (scales_unknown && in_scale(&gain))
    });
    // A member with a recorded standard error (relative to its family's scale) is among
    // `held.names` as well: with the scale free it moves with the family all the same.
    let scale_held_elsewhere = held
        .names
        .iter()
        .chain(&held.exact)
        .chain(held.scales.iter().flat_map(|s| &s.names))
        .filter(|n| !(scales_unknown && in_scale(n)))
        .any(|n| {
            scales_with_the_gain(model, n)
                && !held_ties.contains(n)
                && plant.parameters.get(n).is_some_and(|v| *v != 0.0)
        });
    if free.is_empty() || !gains_fitted || scale_held_elsewhere {
        return None;
    }
    Some(
        (0..p.len())
            .filter(|&i| scales_with_the_gain(model, &names[i]) && p[i] != 0.0)
            .collect(),
    )
}

/// What removing the plant-gain scale from a fit's Jacobian needs to know of the fit
/// ([`GainScaleContext::project_out_of`]): a configuration's step, or the joint fit of
/// several.
pub(crate) struct GainScaleContext<'a> {
    /// The plant (held values, the model).
    pub plant: &'a Plant,
    /// The fitted parameters.
    pub names: &'a [String],
    /// Their bounds (physical units).
    pub bounds: (&'a [f64], &'a [f64]),
    /// Every free joint of the fit's configurations.
    pub free: &'a [usize],
    /// Rigid-body symbols held along exact ties ([`Problem::with_held_ties`]).
    pub held_ties: &'a [String],
}

impl GainScaleContext<'_> {
    /// Where the plant-gain scale is an exact symmetry of the fit ([`gain_scale_family`];
    /// `held` the values held although they enter, their columns computed; `scales_unknown`
    /// whether the held scale families' scale is free, their columns already projected out
    /// of `cols`), removes its direction ([`gain_scale_direction`], [`project_out`]) from
    /// the Jacobian columns `cols` at physical parameters `p`; the held ties' ∂r/∂h are
    /// `held`'s, or, where `held` lacks one (a tie held as exact), `tie_columns` gives those
    /// of the named ties.
    pub(crate) fn project_out_of(
        &self,
        cols: &mut [Vec<f64>],
        p: &[f64],
        held: &HeldColumns,
        scales_unknown: bool,
        tie_columns: &dyn Fn(&[String]) -> Vec<Vec<f64>>,
    ) {
        let family = gain_scale_family(
            self.plant,
            self.names,
            p,
            self.free,
            (held, scales_unknown),
            self.held_ties,
        );
        let Some(members) = family else {
            return;
        };
        let widths = self.widths();
        let ties = scaled_ties(self.plant, self.held_ties);
        let names: Vec<String> = ties.iter().map(|(t, _)| t.clone()).collect();
        let known: Option<Vec<Vec<f64>>> = names
            .iter()
            .map(|name| {
                let k = held.names.iter().position(|n| n == name)?;
                held.cols.get(k).filter(|c| !c.is_empty()).cloned()
            })
            .collect();
        let ties: Vec<(f64, Vec<f64>)> = ties
            .into_iter()
            .map(|t| t.1)
            .zip(known.unwrap_or_else(|| tie_columns(&names)))
            .collect();
        let v = gain_scale_direction(cols, p, &widths, &members, (&ties, &self.rigid_body()));
        project_out(cols, &v, &widths);
    }

    /// For every held tie among `held` without a recorded standard error (`held.tie`,
    /// columns `held.cols` computed), the change of the fitted values that makes up for
    /// it ([`rigid_body_make_up`] on the Jacobian columns `cols` before any projection),
    /// into `held.make_up`.
    pub(crate) fn make_up_held_ties(&self, cols: &[Vec<f64>], held: &mut HeldColumns) {
        let (widths, rigid_body) = (self.widths(), self.rigid_body());
        held.make_up = held
            .cols
            .iter()
            .zip(&held.tie)
            .map(|(col, &tie)| {
                tie.then(|| {
                    let b: Vec<f64> = col.iter().map(|x| -x).collect();
                    rigid_body_make_up(cols, &widths, &rigid_body, &b)
                })
            })
            .collect();
    }

    /// The fitted parameters' bound widths (physical units).
    pub(crate) fn widths(&self) -> Vec<f64> {
        let (lower, upper) = self.bounds;
        lower.iter().zip(upper).map(|(lo, hi)| hi - lo).collect()
    }

    /// Per fitted parameter: a rigid-body symbol of the model.
    pub(crate) fn rigid_body(&self) -> Vec<bool> {
        self.names
            .iter()
            .map(|n| self.plant.model.inertial_symbols.contains(&n.as_str()))
            .collect()
    }
}

/// The held ties of the plant-gain scale family: the names among `held_ties` that scale
/// with the gain ([`scales_with_the_gain`]) and are nonzero in `plant`, with their values.
/// The family's symmetry scales them too ([`Problem::least_change`]), so its direction in
/// the fitted parameters includes what compensates their being held
/// ([`gain_scale_direction`]).
pub(crate) fn scaled_ties(plant: &Plant, held_ties: &[String]) -> Vec<(String, f64)> {
    held_ties
        .iter()
        .filter(|n| scales_with_the_gain(plant.model, n))
        .filter_map(|n| {
            let v = *plant.parameters.get(n)?;
            (v != 0.0).then(|| (n.clone(), v))
        })
        .collect()
}

/// The plant-gain scale's direction v in the fitted parameters (physical units) at `p`:
/// the family `members` times their values, plus the fitted change v_c that compensates
/// the family's held ties, each of value h_t and column ∂r/∂h_t in `ties`: the symmetry
/// moves them by h_t too, and held they leave J v = −Σ h_t ∂r/∂h_t, which the fitted
/// symbols they tie with make up exactly (v_c the least-squares solution of
/// J v_c = Σ h_t ∂r/∂h_t over the fitted rigid-body symbols, `rigid_body[i]` — a held tie
/// is spanned by them at the locked positions, nothing else makes it up exactly — in
/// columns scaled by `widths`, singular values below √1e-9 of the largest dropped, the
/// family's own direction among them; a column of zeros, which no data see, left out).
/// k1 of the Freedom 6S holds I7_13 and y7: at the truth the direction then moves I7_12
/// and I7_23 by 6 % and 3 % more than the other members, and z7 (the parallel-axis term
/// m7·x7·z7 makes up for I7_13); solved over every fitted column, the least squares also
/// leaked at least 1e-3 of the largest relative change (the threshold of
/// [`moved_by_null_directions`]) into vs_q4, which the statistics then called undetermined. Isolated c1 holds m7: x7 and y7 make up
/// for it (m7·x7, m7·y7 scale), and without this part the statistics gave them finite
/// standard errors, 220 % off the truth.
pub(crate) fn gain_scale_direction(
    cols: &[Vec<f64>],
    p: &[f64],
    widths: &[f64],
    members: &[usize],
    (ties, rigid_body): (&[(f64, Vec<f64>)], &[bool]),
) -> Vec<f64> {
    let n = p.len();
    let mut v = vec![0.0; n];
    for &i in members {
        v[i] = p[i];
    }
    if ties.is_empty() || n == 0 {
        return v;
    }
    let m = cols[0].len();
    let b: Vec<f64> = (0..m)
        .map(|k| ties.iter().map(|(h, col)| h * col[k]).sum())
        .collect();
    for (vj, dj) in v
        .iter_mut()
        .zip(rigid_body_make_up(cols, widths, rigid_body, &b))
    {
        *vj += dj;
    }
    v
}

/// The change d of the fitted parameters (physical units) with J d = `b` in the least-squares
/// sense over the fitted rigid-body symbols (`rigid_body[j]`; zero for the rest): what
/// makes up for a change of held rigid-body symbols that these span at the locked
/// positions (a held tie, [`Problem::with_held_ties`]). Columns `cols` (∂r/∂p_j) scaled by
/// `widths`, singular values below √1e-9 of the largest dropped; a column of zeros, which
/// no data see, is its own null direction ([`moved_by_null_directions`]) and left out, so
/// rounding does not tie it to anything (k1: vs_q5 → 0).
pub(crate) fn rigid_body_make_up(
    cols: &[Vec<f64>],
    widths: &[f64],
    rigid_body: &[bool],
    b: &[f64],
) -> Vec<f64> {
    let n = cols.len();
    let mut d = vec![0.0; n];
    let partners: Vec<usize> = (0..n)
        .filter(|&j| rigid_body[j] && cols[j].iter().any(|c| *c != 0.0))
        .collect();
    if partners.is_empty() {
        return d;
    }
    let m = b.len();
    let c = DMatrix::from_fn(m, partners.len(), |k, a| {
        cols[partners[a]][k] * widths[partners[a]]
    });
    let Some(svd) = crate::util::svd(c) else {
        return d;
    };
    let eps = EXACT_SYMMETRY.sqrt() * svd.singular_values.max();
    if let Ok(y) = svd.solve(&nalgebra::DVector::from_column_slice(b), eps) {
        for (a, &j) in partners.iter().enumerate() {
            if y[a].is_finite() {
                d[j] = y[a] * widths[j];
            }
        }
    }
    d
}

/// Removes direction `v` (physical units; [`gain_scale_direction`]) from Jacobian columns
/// `cols` (∂r/∂p_i), orthogonally in coordinates scaled by `widths`: column i loses
/// (J v) w_i / (width_i ‖w‖²), w = v / width, so that J v = 0 exactly afterwards and
/// directions orthogonal to w keep their columns. Why: the plant-gain scale is an exact
/// symmetry of position data, but a finite-difference Jacobian sees it only to its own
/// accuracy, and a member the data barely see (k1 of the Freedom 6S: Fs_q5 at its bound
/// with vs_q5 → 0, a column of difference noise) can lift the family's direction above the
/// cut-off of [`covariance_statistics`], which then called the plant gains determined to
/// a few ppm by data that cannot see their scale. Projected out, the family is a null
/// direction of the statistics (its members undetermined), and every other parameter's
/// standard error is that of the problem with the scale fixed.
pub(crate) fn project_out(cols: &mut [Vec<f64>], v: &[f64], widths: &[f64]) {
    // A column of zeros (a value no sample sees: Fs_q5 with vs_q5 → 0, whose exact
    // sensitivity is 0 where a difference quotient holds noise) neither adds to J v nor
    // takes a share of the correction: ‖w‖² runs over the columns that do, so that J v = 0
    // afterwards.
    let w: Vec<f64> = v
        .iter()
        .zip(widths)
        .zip(cols.iter())
        .map(|((a, b), col)| {
            if col.iter().any(|c| *c != 0.0) {
                a / b
            } else {
                0.0
            }
        })
        .collect();
    let ww: f64 = w.iter().map(|x| x * x).sum();
    if ww == 0.0 || !ww.is_finite() || cols.is_empty() {
        return;
    }
    let m = cols[0].len();
    let mut jv = vec![0.0; m];
    for (col, vi) in cols.iter().zip(v) {
        if *vi != 0.0 {
            for (s, c) in jv.iter_mut().zip(col) {
                *s += vi * c;
            }
        }
    }
    for ((col, wi), width) in cols.iter_mut().zip(&w).zip(widths) {
        if *wi != 0.0 {
            let f = wi / (width * ww);
            for (c, s) in col.iter_mut().zip(&jv) {
                *c -= s * f;
            }
        }
    }
}

/// A held value's central-difference step: [`OutputErrorOptions::fd_step`] of its scale
/// (bound width, else magnitude, else 1).
pub(crate) fn held_step(plant: &Plant, name: &str, fd_step: f64) -> f64 {
    fd_step * held_scale(plant, name)
}

/// The parameters of `plant` that a fit of `names` holds although they enter one of the
/// configurations `confs` ([`enters`]): those with a recorded standard error with it; the
/// `held_ties` ([`Problem::with_held_ties`]) without one with the spread of a value
/// uniform within their bounds, (upper − lower)/√12 — a tie is held at an arbitrary
/// point of its bounds, not at an estimate; the others as exact. Besides, the nonzero
/// members of a plant-gain scale family no step determined ([`Plant::scale_families`];
/// not held ties) per family, their common scale unknown ([`HeldScale`]): with a recorded
/// standard error (relative to that scale) also among the former, without one not exact.
/// The columns are left for the fit to simulate (empty; [`HeldColumns::column_names`]).
pub(crate) fn held_in(
    plant: &Plant,
    names: &[String],
    held_ties: &[String],
    occ: &crate::identify::identifiability::Occurrence,
    confs: &[&Configuration],
) -> HeldColumns {
    let mut held = HeldColumns::default();
    for n in plant.parameters.keys() {
        if names.contains(n) || !confs.iter().any(|c| enters(plant, occ, c, n)) {
            continue;
        }
        let tie_spread = || match plant.bounds.get(n) {
            Some(&(lo, hi)) if held_ties.contains(n) && hi > lo => Some((hi - lo) / 12f64.sqrt()),
            _ => None,
        };
        let value = plant.parameters[n];
        let family = plant.scale_family_of(n).filter(|_| value != 0.0);
        // (σ, whether a tie's spread), where the value has a share.
        let share = match plant.standard_errors.get(n) {
            Some(&se) => Some((se, false)),
            None => tie_spread().map(|se| (se, true)),
        };
        if share.is_none() && family.is_none() {
            held.exact.push(n.clone());
        }
        // A held tie's make-up scales with the fit's own family ([`gain_scale_direction`]),
        // never with a held one.
        let tie = share.is_some_and(|(_, tie)| tie);
        if let Some(family) = family.filter(|_| !tie) {
            let at = match held.scales.iter().position(|s| s.family == family) {
                Some(at) => at,
                None => {
                    held.scales.push(HeldScale {
                        family: family.to_string(),
                        ..HeldScale::default()
                    });
                    held.scales.len() - 1
                }
            };
            held.scales[at].names.push(n.clone());
            held.scales[at].values.push(value);
        }
        let Some((se, tie)) = share else {
            continue;
        };
        held.names.push(n.clone());
        held.std_err.push(se);
        held.tie.push(tie);
    }
    // A held tie's spread is its bounds', independent of every other value.
    let recorded: Vec<usize> = (0..held.names.len()).filter(|&k| !held.tie[k]).collect();
    for (a, &k) in recorded.iter().enumerate() {
        for &l in &recorded[a + 1..] {
            let r = plant.correlation(&held.names[k], &held.names[l]);
            if r != 0.0 {
                held.correlation.push((k, l, r));
            }
        }
    }
    held
}

/// Whether parameter `name` of `plant` enters configuration `conf`'s simulation: a
/// rigid-body symbol that the occurrence table `occ` lists there, a parameter of an effect
/// that acts with its free joints ([`crate::effects::Effect::acts_with`]), or anything else
/// the plant holds (a barycentric parameter: kept, to be safe).
pub(crate) fn enters(
    plant: &Plant,
    occ: &crate::identify::identifiability::Occurrence,
    conf: &Configuration,
    name: &str,
) -> bool {
    if plant.model.inertial_symbols.contains(&name) {
        return occ.appears_in(name, conf.name);
    }
    let mut owners = plant
        .effects
        .iter()
        .filter(|e| {
            e.parameter_names(plant.model.joints)
                .iter()
                .any(|n| n == name)
        })
        .peekable();
    let mut expressions = plant
        .expressions
        .iter()
        .filter(|x| x.expression.parameters.iter().any(|n| n == name))
        .peekable();
    if expressions.peek().is_some() {
        return expressions.any(|x| x.acts_with(conf.free));
    }
    owners.peek().is_none() || owners.any(|e| e.acts_with(conf.free))
}

/// The (name, σ) of the `held` values whose σ was recorded (`ties` false) or is a held
/// tie's bounds' spread (`ties` true).
pub(crate) fn held_share(held: &HeldColumns, ties: bool) -> Vec<(String, f64)> {
    (0..held.names.len())
        .filter(|&k| held.tie[k] == ties)
        .map(|k| (held.names[k].clone(), held.std_err[k]))
        .collect()
}
