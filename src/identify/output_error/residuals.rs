//! The residuals of a fit: the one interface every solver ([`Solver`]:
//! [`LevenbergMarquardt`], [`TrustRegionReflective`]) and the statistics work on. A configuration's output error ([`Problem`]: whole files,
//! the predictor, the equation error, segments — the mode is the problem's) and the joint
//! fit of several configurations ([`crate::identify::joint::JointProblem`]) implement it;
//! the prior's rows are part of it, the solver's Jacobian policy is not
//! ([`JacobianPolicy`]).

use super::*;

/// A fit's parameters and their feasible set: the scaled coordinates, the plant at a point
/// and the statistics read them.
#[derive(Clone, Copy)]
pub struct ParameterSpace<'a> {
    /// The plant the fitted values are set in (every other value as it holds them).
    pub plant: &'a Plant,
    /// Fitted parameter names (n).
    pub names: &'a [String],
    /// Lower bounds (n; physical units, Fs ≥ Fc folded in).
    pub lower: &'a [f64],
    /// Upper bounds (n).
    pub upper: &'a [f64],
    /// (Fc, Fs) index pairs within `names` under Fs ≥ Fc (`feasible_bounds`).
    pub pairs: &'a [(usize, usize)],
    /// Rigid-body symbols held at the plant's values although they tie exactly with
    /// fitted ones ([`Problem::with_held_ties`]).
    pub held_ties: &'a [String],
    /// Finite-difference step, a fraction of each bound's width
    /// ([`OutputErrorOptions::fd_step`]).
    pub fd_step: f64,
}

/// The [`ParameterSpace`] of a fit type that holds `plant`, `names`, `lower`, `upper`,
/// `pairs`, `held_ties` and `options` ([`Problem`] and
/// [`crate::identify::joint::JointProblem`]).
macro_rules! parameter_space_of {
    ($fit:expr) => {
        ParameterSpace {
            plant: &$fit.plant,
            names: &$fit.names,
            lower: &$fit.lower,
            upper: &$fit.upper,
            pairs: &$fit.pairs,
            held_ties: &$fit.held_ties,
            fd_step: $fit.options.fd_step,
        }
    };
}
pub(crate) use parameter_space_of;

impl ParameterSpace<'_> {
    /// Forward-difference steps at physical parameters `p` (n): `fd_step` × the bound
    /// width, negative where the step would leave the upper bound.
    pub fn difference_steps(&self, p: &[f64]) -> Vec<f64> {
        (0..self.names.len())
            .map(|i| {
                let s = self.fd_step * (self.upper[i] - self.lower[i]);
                if p[i] + s > self.upper[i] {
                    -s
                } else {
                    s
                }
            })
            .collect()
    }
}

/// Where a finite-difference Jacobian is taken: at `x` (n; scaled or physical coordinates)
/// where `p_of(x)` gives the physical parameters and the residuals are `r0` (m), column i
/// stepped by `steps[i]` (the sign chosen by the caller to stay in the feasible set);
/// forward differences, or central where `central` and both sides simulate.
#[derive(Clone, Copy)]
pub struct Stencil<'a> {
    /// The point (n).
    pub x: &'a [f64],
    /// The residuals there (m).
    pub r0: &'a [f64],
    /// Each column's step (n).
    pub steps: &'a [f64],
    /// Physical parameters of a point.
    pub p_of: &'a (dyn Fn(&[f64]) -> Vec<f64> + Sync),
    /// Central differences.
    pub central: bool,
}

/// [`Residuals::jacobian_columns`] by finite differences: n columns of length m, all
/// simulated in parallel; a column whose simulation fails is retried with the opposite
/// step, then left zero.
pub fn finite_difference_columns<R: Residuals + ?Sized>(r: &R, stencil: &Stencil) -> Vec<Vec<f64>> {
    (0..stencil.x.len())
        .into_par_iter()
        .map(|i| {
            let at = |step: f64| {
                let mut xi = stencil.x.to_vec();
                xi[i] += step;
                r.residuals(&(stencil.p_of)(&xi))
            };
            difference_column(&at, stencil.r0, stencil.steps[i], stencil.central)
        })
        .collect()
}

/// The residuals of a fit at physical parameters, its scaled coordinates u ∈ [0, 1]ⁿ,
/// finite-difference Jacobian columns and the prior's rows.
pub trait Residuals: Sync {
    /// The fitted parameters and their feasible set.
    fn space(&self) -> ParameterSpace<'_>;
    /// Number of residuals m (the simulated ones, without the prior's rows).
    fn residual_count(&self) -> usize;
    /// The residuals (m) at physical parameters `p` (n).
    ///
    /// # Errors
    /// A trial point that cannot be simulated ([`TrialFailure`]).
    fn residuals(&self, p: &[f64]) -> Result<Vec<f64>, TrialFailure>;

    /// Σ r² at physical parameters `p`, or +∞ where a simulation fails.
    fn cost(&self, p: &[f64]) -> f64 {
        self.residuals(p)
            .map(|r| r.iter().map(|x| x * x).sum())
            .unwrap_or(f64::INFINITY)
    }
    /// Physical parameters from scaled ones u ∈ [0, 1]ⁿ (`scaled_to_physical`).
    fn to_physical(&self, u: &[f64]) -> Vec<f64> {
        let s = self.space();
        scaled_to_physical(s.lower, s.upper, s.pairs, u)
    }
    /// Scaled parameters of physical ones, clamped into the feasible set
    /// (`physical_to_scaled`).
    fn to_scaled(&self, p: &[f64]) -> Vec<f64> {
        let s = self.space();
        physical_to_scaled(s.lower, s.upper, s.pairs, p)
    }
    /// The plant with the fitted parameters set to physical `p`.
    fn plant_at(&self, p: &[f64]) -> Plant {
        let s = self.space();
        let mut plant = s.plant.clone();
        plant.set_values(s.names, p);
        plant
    }
    /// Jacobian ∂r/∂x at `stencil`'s point ([`Stencil`]): n columns of length m; by default
    /// [`finite_difference_columns`].
    fn jacobian_columns(&self, stencil: &Stencil) -> Vec<Vec<f64>> {
        finite_difference_columns(self, stencil)
    }
    /// Simulations one Jacobian of `n` columns cost, counted in a fit's evaluations (n by
    /// finite differences).
    fn jacobian_simulations(&self, n: usize) -> usize {
        n
    }
    /// Number of the prior's rows (0 without a prior).
    fn prior_rows(&self) -> usize {
        0
    }
    /// The prior's Jacobian ∂(prior residuals)/∂u at scaled parameters `u`:
    /// [`Residuals::prior_rows`] rows of n.
    fn prior_jacobian(&self, _u: &[f64]) -> Vec<Vec<f64>> {
        Vec::new()
    }
    /// The prior's residuals at scaled parameters `u` (empty without a prior).
    fn prior_residuals(&self, _u: &[f64]) -> Vec<f64> {
        Vec::new()
    }
    /// The prior's term of the objective at scaled parameters `u` (0 without a prior).
    fn prior_penalty(&self, u: &[f64]) -> f64 {
        self.prior_residuals(u).iter().map(|x| x * x).sum()
    }
}
