//! The optimiser behind every stage: bounded Levenberg–Marquardt (MINPACK/CMPFIT, crate
//! `rmpfit`) on the scaled coordinates, finite-difference Jacobian columns in parallel,
//! Broyden's rank-one update between refreshes, and each stage's stopping rules.

use super::*;
use std::sync::Mutex;

/// How many times a stage that stopped on a Broyden-updated Jacobian goes on from a
/// finite-difference one ([`LevenbergMarquardt`], [`TrustRegionReflective`]), so that it ends on stopping
/// rules that hold for the true Jacobian.
const BROYDEN_RERUNS: usize = 3;

/// The stopping rules of a fit's `stage` under `options` ([`Problem::run_stage`]).
/// Segment and short-horizon stages stop on looser rules: relative step 1e-4 (or the
/// user's xtol if looser) and the user's relative cost decrease (at least
/// [`WARM_UP_FTOL`]); a predictor stage followed by a lower bandwidth on the user's step
/// and a relative cost decrease of at least [`PREDICTOR_FTOL`]; the last predictor stage
/// and the whole files on the user's rules; the equation-error stage, whose evaluations
/// cost no simulation, only on a standstill (1e-10, at most 500 iterations).
pub(super) fn stage_rules(options: &OutputErrorOptions, stage: Stage) -> MPConfig {
    let warm_up = !stage.is_final();
    let (xtol, ftol, gtol, max_iter, max_fev) = match stage {
        // Cheap residuals (no simulation) on a problem with nearly flat directions (the
        // base parameters' ties): stop only on a standstill.
        Stage::EquationError => (1e-10, 1e-10, 1e-12, 500, 5000),
        // The predictor's stages move the parameters most of the way: the last (lowest
        // ω) runs on the whole files' rules (as measured on c4: 45 iterations at
        // ω = 3 rad/s); those before it stop once the cost only creeps.
        Stage::Predictor(omega) if options.predictor.iter().any(|&w| w < omega) => (
            options.xtol,
            options.ftol.max(PREDICTOR_FTOL),
            1e-10,
            options.max_iter,
            20 * options.max_iter.max(1),
        ),
        _ if warm_up && !matches!(stage, Stage::Predictor(_)) => (
            options.xtol.max(1e-4),
            options.ftol.max(WARM_UP_FTOL),
            1e-10,
            options.max_iter,
            20 * options.max_iter.max(1),
        ),
        _ => (
            options.xtol,
            options.ftol,
            1e-10,
            options.max_iter,
            20 * options.max_iter.max(1),
        ),
    };
    MPConfig {
        xtol,
        ftol,
        gtol,
        max_iter,
        max_fev: MPMaxFev::Limited(max_fev),
        ..MPConfig::new()
    }
}

/// One stage's bounded least-squares run, as a [`Solver`] is given it: `problem` from
/// scaled parameters u ∈ [0, 1]ⁿ (updated in place by the solver), the parameters where
/// `frozen` is true held, on the stopping rules `rules` ([`stage_rules`]); `stage` and
/// `context` feed the progress display and the counters, and give the Jacobian policy
/// ([`StageContext::jacobian`]); `start_cost` (the cost at u) scales the residuals a failed
/// simulation returns.
pub(crate) struct StageRun<'a> {
    pub(crate) problem: &'a dyn Residuals,
    pub(crate) stage: Stage,
    pub(crate) frozen: &'a [bool],
    pub(crate) rules: MPConfig,
    pub(crate) context: &'a StageContext<'a>,
    pub(crate) start_cost: f64,
}

/// A bounded least-squares method: the solver of a stage, separate from the residuals it
/// minimises ([`Residuals`]) and from the strategy that chains the stages
/// ([`OutputErrorOptions`]'s presets, [`Problem::fit`]). [`LevenbergMarquardt`] and
/// [`TrustRegionReflective`]; [`StageOptimiser::solver`] names them.
pub(crate) trait Solver: Sync {
    /// Minimise `run`'s problem from `u`, which it updates in place.
    fn minimise(&self, run: &StageRun, u: &mut [f64]) -> StageOutcome;
}

/// rmpfit's bounded Levenberg–Marquardt ([`StageOptimiser::LevenbergMarquardt`]) of a stage's problem from scaled parameters `u` ∈ [0, 1]ⁿ,
/// updated in place (a value within [`BOUND_SNAP`] of a bound put on it first), on the
/// stopping rules of its `rules`; parameters where `frozen` is true
/// stay. A run that stopped on a Broyden-updated Jacobian goes on from a finite-difference
/// one (at most [`BROYDEN_RERUNS`] times), so it ends on rules that hold for the true
/// Jacobian. `stage` and `context` feed the progress display; `start_cost` (the cost at
/// `u`) scales the residuals a failed simulation returns.
pub(crate) struct LevenbergMarquardt;

/// basin's trust-region-reflective method ([`StageOptimiser::TrustRegionReflective`])
/// instead of rmpfit's Levenberg–Marquardt ([`LevenbergMarquardt`]): a stage's problem from scaled parameters `u` ∈ [0, 1]ⁿ, updated in place; parameters where
/// `frozen` is true stay. A Jacobian at every accepted step: finite differences (columns in
/// parallel, step [`OutputErrorOptions::fd_step`] of the bound width), or Broyden's update
/// between them as [`OutputErrorOptions::jacobian_refresh`] allows (a run that stopped on an
/// updated one goes on from finite differences, at most [`BROYDEN_RERUNS`] times, as
/// [`LevenbergMarquardt`]); it stops on its `rules`' relative cost change (ftol), relative step (xtol)
/// or iteration limit, as [`stage_rules`] set them for the stage; the prior's rows as in
/// [`LevenbergMarquardt`]. A trial point whose simulation fails returns residuals 1e3 × the start's
/// root mean square, so the step is rejected and the trust region shrinks; `start_cost`
/// (the cost at `u`) sets that level.
pub(crate) struct TrustRegionReflective;

impl StageOptimiser {
    /// The solver of this choice.
    pub(crate) fn solver(self) -> &'static dyn Solver {
        match self {
            StageOptimiser::LevenbergMarquardt => &LevenbergMarquardt,
            StageOptimiser::TrustRegionReflective => &TrustRegionReflective,
        }
    }
}

impl Solver for LevenbergMarquardt {
    fn minimise(&self, run: &StageRun, u: &mut [f64]) -> StageOutcome {
        let config = run.rules.clone();
        // A parameter within rounding of a bound (a value read back from a plant file, or
        // the Fs of a collapsed Stribeck pair, u ≈ 1e-16) must sit exactly on it: rmpfit
        // freezes a parameter only when it equals its limit, and otherwise shortens the
        // whole step to reach the limit, a step of ~1e-16 that it then reports as
        // convergence after one iteration (k3 of the Freedom 6S from the fitted plant,
        // I6_13 = −2.1999999999999996e-7 against a bound of −2.2e-7: no stage moved). The
        // same from a trust-region-reflective stage's end, strictly inside its bounds: the
        // joint refit after seed 11's coupled k5 started with I1_33 at 5.2e-8 of its range
        // from its upper bound and stopped after 2 iterations, its cost unchanged.
        for x in u.iter_mut() {
            if *x < BOUND_SNAP {
                *x = 0.0;
            } else if *x > 1.0 - BOUND_SNAP {
                *x = 1.0;
            }
        }
        let mut fitter = Fitter {
            evaluator: Evaluator::new(run.problem, run.context, run.stage, run.start_cost),
            jacobian: None,
            config,
            pars: run
                .frozen
                .iter()
                .map(|&fixed| MPPar {
                    fixed,
                    limited_low: true,
                    limited_up: true,
                    limit_low: 0.0,
                    limit_up: 1.0,
                    side: MPSide::User,
                    ..MPPar::new()
                })
                .collect(),
        };
        let mut result = fitter.mpfit(u);
        let mut iterations = result.as_ref().map_or(0, |st| st.n_iter);
        // A stage that stopped on a Broyden-updated Jacobian goes on from a
        // finite-difference one (its stopping rules then hold for the true Jacobian).
        let mut reruns = 0;
        while result.is_ok()
            && fitter.jacobian.as_ref().is_some_and(|j| j.updates > 0)
            && reruns < BROYDEN_RERUNS
        {
            fitter.jacobian = None;
            result = fitter.mpfit(u);
            iterations += result.as_ref().map_or(0, |st| st.n_iter);
            reruns += 1;
        }
        let failures = fitter.evaluator.failures();
        match result {
            Ok(st) => StageOutcome {
                status: format!("{:?} after {iterations} iteration(s)", st.success),
                iterations,
                failures,
                stop: false,
            },
            Err(MPError::Eval) => {
                StageOutcome::stopped("stopped, a simulation failed".into(), failures)
            }
            Err(e) => StageOutcome::stopped(format!("optimiser error {e:?}"), failures),
        }
    }
}

/// What every stage of one start shares: its place among the starts, the fit's counters
/// and clock, and the progress display.
pub(crate) struct StageContext<'a> {
    pub(crate) start: usize,
    pub(crate) starts: usize,
    pub(crate) evaluations: &'a AtomicUsize,
    pub(crate) jacobians: &'a AtomicUsize,
    pub(crate) started: Instant,
    pub(crate) progress: &'a (dyn Fn(Progress) + Sync),
    /// How the solvers form the Jacobian.
    pub(crate) jacobian: JacobianPolicy,
}

impl<'a> StageContext<'a> {
    /// The context of a lone start (1 of 1) on `evaluations` and `jacobians`, its clock
    /// started now, no progress display, the Jacobian by `jacobian`.
    pub(crate) fn alone(
        evaluations: &'a AtomicUsize,
        jacobians: &'a AtomicUsize,
        jacobian: JacobianPolicy,
    ) -> Self {
        StageContext {
            start: 0,
            starts: 1,
            evaluations,
            jacobians,
            started: Instant::now(),
            progress: &|_| {},
            jacobian,
        }
    }
}

/// How a solver forms the Jacobian of a stage: forward differences with step `fd_step`
/// (scaled units, toward the interior at an upper bound), taken afresh at most every
/// `refresh` iterations, Broyden's rank-one updates between (1: finite differences at
/// every iteration). A value the solver is given, not read back from the problem.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct JacobianPolicy {
    pub(crate) fd_step: f64,
    pub(crate) refresh: usize,
}

impl JacobianPolicy {
    /// The policy of `options` ([`OutputErrorOptions::fd_step`],
    /// [`OutputErrorOptions::jacobian_refresh`]).
    pub(crate) fn of(options: &OutputErrorOptions) -> Self {
        JacobianPolicy {
            fd_step: options.fd_step,
            refresh: options.jacobian_refresh,
        }
    }
}

/// How a stage ended.
pub(crate) struct StageOutcome {
    /// For the report, e.g. "Convergence in parameter value after 6 iteration(s)".
    pub(crate) status: String,
    pub(crate) iterations: usize,
    /// Trial points that could not be simulated.
    pub(crate) failures: usize,
    /// The start cannot go on to the next stage.
    pub(crate) stop: bool,
}

impl StageOutcome {
    /// A stage the optimiser could not run: `status` says why, after `failures` trial
    /// points that could not be simulated; the start cannot go on.
    fn stopped(status: String, failures: usize) -> StageOutcome {
        StageOutcome {
            status,
            iterations: 0,
            failures,
            stop: true,
        }
    }
}

/// The rmpfit adapter: scaled parameters, cached residuals, user (parallel) Jacobian.
struct Fitter<'a> {
    evaluator: Evaluator<'a>,
    /// The last Jacobian handed to the optimiser ([`OutputErrorOptions::jacobian_refresh`]).
    jacobian: Option<LastJacobian>,

    config: MPConfig,
    pars: Vec<MPPar>,
}

/// A Jacobian of the simulated residuals and where it was taken.
pub(super) struct LastJacobian {
    /// Scaled parameters.
    u: Vec<f64>,
    /// Residuals there (the simulated ones, without the prior's rows).
    r: Vec<f64>,
    /// ∂r/∂u_i per parameter.
    columns: Vec<Vec<f64>>,
    /// Broyden updates since the last finite-difference Jacobian (0: it is one).
    updates: usize,
}

impl LastJacobian {
    /// The Jacobian at scaled parameters `u` with simulated residuals `r`: Broyden's update
    /// of `last` where it exists, the step to `u` lowered the simulated cost and fewer than
    /// `refresh` − 1 updates were made since its finite differences
    /// ([`OutputErrorOptions::jacobian_refresh`]); otherwise `fresh()`'s finite-difference
    /// columns.
    fn next(
        last: Option<LastJacobian>,
        refresh: usize,
        u: &[f64],
        r: &[f64],
        fresh: impl FnOnce() -> Vec<Vec<f64>>,
    ) -> LastJacobian {
        let sum_sq = |r: &[f64]| r.iter().map(|x| x * x).sum::<f64>();
        last.filter(|last| last.updates + 1 < refresh && sum_sq(r) < sum_sq(&last.r))
            .and_then(|mut last| last.broyden(u, r).then_some(last))
            .unwrap_or_else(|| LastJacobian {
                u: u.to_vec(),
                r: r.to_vec(),
                columns: fresh(),
                updates: 0,
            })
    }

    /// Broyden's rank-one update to the point `u` with residuals `r`:
    /// J ← J + (Δr − J Δu) Δuᵀ / (Δuᵀ Δu), the least change of J that maps the step taken
    /// to the residual change seen. False (J unchanged) for a zero step.
    fn broyden(&mut self, u: &[f64], r: &[f64]) -> bool {
        let du: Vec<f64> = u.iter().zip(&self.u).map(|(a, b)| a - b).collect();
        let du2: f64 = du.iter().map(|d| d * d).sum();
        if du2.is_nan() || du2 <= 0.0 {
            return false;
        }
        let mut defect: Vec<f64> = r.iter().zip(&self.r).map(|(a, b)| a - b).collect();
        for (col, d) in self.columns.iter().zip(&du) {
            for (e, c) in defect.iter_mut().zip(col) {
                *e -= c * d;
            }
        }
        for (col, d) in self.columns.iter_mut().zip(&du) {
            let f = d / du2;
            for (c, e) in col.iter_mut().zip(&defect) {
                *c += e * f;
            }
        }
        self.u = u.to_vec();
        self.r = r.to_vec();
        self.updates += 1;
        true
    }
}

/// A stage's residual evaluations, shared by both optimisers' adapters: the simulated
/// residuals at scaled parameters then the prior's rows, the last point's cached (an
/// optimiser asks again for the point whose Jacobian it takes), every simulation counted in
/// the fit's evaluations, and the progress display fed the lowest cost seen. A trial point
/// where the plant diverges gets residuals of 1e3 × the start's root mean square, a cost
/// far above the start's, so that the step is rejected and the trust region shrinks.
struct Evaluator<'a> {
    problem: &'a dyn Residuals,
    context: &'a StageContext<'a>,
    stage: Stage,
    /// The residual of a trial point that cannot be simulated.
    level: f64,
    cache: Mutex<Option<(Vec<f64>, Vec<f64>)>>,
    best: Mutex<f64>,
    failures: AtomicUsize,
}

impl<'a> Evaluator<'a> {
    /// For `stage` of `problem` from a start of cost `start_cost`.
    fn new(
        problem: &'a dyn Residuals,
        context: &'a StageContext<'a>,
        stage: Stage,
        start_cost: f64,
    ) -> Self {
        let m = problem.residual_count();
        Evaluator {
            problem,
            context,
            stage,
            level: (start_cost.max(1e-12) / m as f64).sqrt() * 1e3,
            cache: Mutex::new(None),
            best: Mutex::new(f64::INFINITY),
            failures: AtomicUsize::new(0),
        }
    }

    /// The residuals at scaled parameters `u` (simulated, then the prior's rows).
    fn residuals(&self, u: &[f64]) -> Vec<f64> {
        if let Some((cu, cr)) = self
            .cache
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .as_ref()
        {
            if cu.as_slice() == u {
                return cr.clone();
            }
        }
        self.context.evaluations.fetch_add(1, Ordering::Relaxed);
        let p = self.problem;
        let mut r = p.residuals(&p.to_physical(u)).unwrap_or_else(|_| {
            self.failures.fetch_add(1, Ordering::Relaxed);
            vec![self.level; p.residual_count()]
        });
        r.extend(p.prior_residuals(u));
        let c: f64 = r.iter().map(|x| x * x).sum();
        let best = {
            let mut best = self.best.lock().unwrap_or_else(|e| e.into_inner());
            *best = best.min(c);
            *best
        };
        (self.context.progress)(Progress {
            start: self.context.start,
            starts: self.context.starts,
            stage: self.stage,
            iteration: self.context.jacobians.load(Ordering::Relaxed),
            evaluations: self.context.evaluations.load(Ordering::Relaxed),
            cost: best,
            elapsed: self.context.started.elapsed().as_secs_f64(),
        });
        *self.cache.lock().unwrap_or_else(|e| e.into_inner()) = Some((u.to_vec(), r.clone()));
        r
    }

    /// Forward-difference columns ∂r/∂x of the simulated residuals at scaled values `x`
    /// (`p_of(x)` the physical parameters; `r0` the residuals there, prior's rows allowed),
    /// step [`OutputErrorOptions::fd_step`], toward the interior where a step would pass
    /// the upper bound 1; the simulations counted in the fit's evaluations.
    fn difference_columns(
        &self,
        x: &[f64],
        r0: &[f64],
        p_of: &(dyn Fn(&[f64]) -> Vec<f64> + Sync),
    ) -> Vec<Vec<f64>> {
        let p = self.problem;
        let h = self.context.jacobian.fd_step;
        let steps: Vec<f64> = x
            .iter()
            .map(|&u| if u + h > 1.0 { -h } else { h })
            .collect();
        let columns = p.jacobian_columns(&Stencil {
            x,
            r0: &r0[..p.residual_count()],
            steps: &steps,
            p_of,
            central: false,
        });
        self.context
            .evaluations
            .fetch_add(p.jacobian_simulations(x.len()), Ordering::Relaxed);
        columns
    }

    /// Trial points that could not be simulated so far.
    fn failures(&self) -> usize {
        self.failures.load(Ordering::Relaxed)
    }
}

/// Whether the Jacobian column `col` (∂r/∂u_j in scaled units, prior's rows included) of
/// a parameter is numerically absent from the Gauss–Newton model at residuals `r` of
/// cost `cost` = ‖r‖²: a move of u_j across its whole range [0, 1] changes the linear
/// model's cost ‖r + J_j δ‖² by at most 2 |J_jᵀ r| + ‖J_j‖², and that is below the stage's
/// relative cost tolerance `ftol` × `cost`.
///
/// rmpfit treats a column as singular only when it is exactly zero (MINPACK's `lmpar`).
/// A column that is tiny but not zero — the sensitivity to a collapsed Stribeck velocity
/// vs, ∂/∂vs of e^{−(v/vs)²}, which underflows toward 1e-60 where a finite difference is
/// exactly zero — gets a Gauss–Newton component of ~1e60 of its range; rmpfit's bounds
/// then shorten the whole step to reach that parameter's limit, a step of ~1e-60 that its
/// first iteration takes as the trust region and reports as convergence in chi-square and
/// parameter values, far from the minimum (the sensitivities record, stop 88). The column
/// is taken as zero for that step; the next Jacobian looks at it again.
fn absent_from_the_linear_model(col: &[f64], r: &[f64], cost: f64, ftol: f64) -> bool {
    let g: f64 = col.iter().zip(r).map(|(j, r)| j * r).sum();
    let n2: f64 = col.iter().map(|j| j * j).sum();
    2.0 * g.abs() + n2 <= ftol * cost
}

impl MPFitter for Fitter<'_> {
    fn eval(&mut self, params: &[f64], deviates: &mut [f64]) -> MPResult<()> {
        let r = self.evaluator.residuals(params);
        deviates.copy_from_slice(&r);
        Ok(())
    }

    fn number_of_points(&self) -> usize {
        let p = self.evaluator.problem;
        p.residual_count() + p.prior_rows()
    }

    fn config(&self) -> &MPConfig {
        &self.config
    }

    fn parameters(&self) -> &[MPPar] {
        &self.pars
    }

    fn jacobian(
        &mut self,
        params: &[f64],
        deviates: &mut [f64],
        derivs: &mut [Option<Vec<f64>>],
    ) -> MPResult<()> {
        let r0 = self.evaluator.residuals(params);
        deviates.copy_from_slice(&r0);
        self.evaluator
            .context
            .jacobians
            .fetch_add(1, Ordering::Relaxed);
        let p = self.evaluator.problem;
        let m = p.residual_count();
        let last = LastJacobian::next(
            self.jacobian.take(),
            self.evaluator.context.jacobian.refresh,
            params,
            &r0[..m],
            || {
                self.evaluator
                    .difference_columns(params, &r0, &|x: &[f64]| p.to_physical(x))
            },
        );
        let cols = &self.jacobian.insert(last).columns;
        // rmpfit's deviates are (y − f): the derivative of the residual as defined here;
        // then the prior's rows.
        let prior = p.prior_jacobian(params);
        let cost: f64 = r0.iter().map(|x| x * x).sum();
        for (i, d) in derivs.iter_mut().enumerate() {
            if let Some(col) = d {
                col[..m].copy_from_slice(&cols[i]);
                for (k, row) in prior.iter().enumerate() {
                    col[m + k] = row[i];
                }
                if absent_from_the_linear_model(col, &r0, cost, self.config.ftol) {
                    col.fill(0.0);
                }
            }
        }
        Ok(())
    }
}

impl Solver for TrustRegionReflective {
    fn minimise(&self, run: &StageRun, u: &mut [f64]) -> StageOutcome {
        let StageRun {
            problem,
            stage,
            frozen,
            context,
            start_cost,
            ..
        } = *run;
        let config = &run.rules;
        use basin::{
            BoxBounds, ConstraintSet, CostFunction, DenseMatrix, Executor, Jacobian, Residual,
            TrustRegionReflective as BasinTrf,
        };
        use std::convert::Infallible;

        /// The stage's free parameters as basin sees them: the scaled values of the free
        /// ones, the frozen ones fixed at `base`.
        struct Free<'a> {
            evaluator: &'a Evaluator<'a>,
            base: Vec<f64>,
            free: Vec<usize>,
            lower: Vec<f64>,
            upper: Vec<f64>,
            /// The last Jacobian (free columns only) for Broyden's updates
            /// ([`OutputErrorOptions::jacobian_refresh`]).
            jacobian: &'a Mutex<Option<LastJacobian>>,
            /// Jacobians taken by finite differences.
            differenced: &'a AtomicUsize,
        }

        impl Free<'_> {
            /// All scaled parameters with the free ones at `x` (clamped into [0, 1]: the
            /// method's iterates stay strictly inside, this guards rounding).
            fn full(&self, x: &[f64]) -> Vec<f64> {
                let mut u = self.base.clone();
                for (&i, &v) in self.free.iter().zip(x) {
                    u[i] = v.clamp(0.0, 1.0);
                }
                u
            }
        }

        impl basin::Constraints for Free<'_> {
            type Set = ConstraintSet<BoxBounds<Vec<f64>>>;
            fn constraints(&self) -> <Self::Set as basin::ConstraintDescription>::Borrowed<'_> {
                ConstraintSet::new()
                    .with_bounds(BoxBounds::new(Some(&self.lower), Some(&self.upper)))
            }
        }

        impl CostFunction for Free<'_> {
            type Param = Vec<f64>;
            type Output = f64;
            type Error = Infallible;
            fn cost(&self, x: &Vec<f64>) -> Result<f64, Infallible> {
                Ok(0.5
                    * self
                        .evaluator
                        .residuals(&self.full(x))
                        .iter()
                        .map(|r| r * r)
                        .sum::<f64>())
            }
        }

        impl Residual for Free<'_> {
            type Param = Vec<f64>;
            type Output = Vec<f64>;
            type Error = Infallible;
            fn residual(&self, x: &Vec<f64>) -> Result<Vec<f64>, Infallible> {
                Ok(self.evaluator.residuals(&self.full(x)))
            }
        }

        impl Jacobian for Free<'_> {
            type Jacobian = DenseMatrix;
            fn jacobian(&self, x: &Vec<f64>) -> Result<DenseMatrix, Infallible> {
                let p = self.evaluator.problem;
                let u = self.full(x);
                let r0 = self.evaluator.residuals(&u);
                let m = p.residual_count();
                // Columns only for the free parameters.
                let free = &self.free;
                let y: Vec<f64> = free.iter().map(|&i| u[i]).collect();
                let mut slot = self.jacobian.lock().unwrap_or_else(|e| e.into_inner());
                let last = LastJacobian::next(
                    slot.take(),
                    self.evaluator.context.jacobian.refresh,
                    &y,
                    &r0[..m],
                    || {
                        self.differenced.fetch_add(1, Ordering::Relaxed);
                        self.evaluator
                            .difference_columns(&y, &r0, &|y: &[f64]| p.to_physical(&self.full(y)))
                    },
                );
                let columns = &slot.insert(last).columns;
                self.evaluator
                    .context
                    .jacobians
                    .fetch_add(1, Ordering::Relaxed);
                let n = free.len();
                let rows = r0.len();
                let mut j = vec![0.0; rows * n];
                for (c, column) in columns.iter().enumerate() {
                    for (k, &d) in column.iter().enumerate() {
                        j[k * n + c] = d;
                    }
                }
                // The prior's rows.
                for (k, row) in p.prior_jacobian(&u).iter().enumerate() {
                    for (c, &i) in free.iter().enumerate() {
                        j[(m + k) * n + c] = row[i];
                    }
                }
                Ok(DenseMatrix::from_row_slice(rows, n, &j))
            }
        }

        let free: Vec<usize> = (0..u.len()).filter(|&i| !frozen[i]).collect();
        let x0: Vec<f64> = free.iter().map(|&i| u[i].clamp(0.0, 1.0)).collect();
        let evaluator = Evaluator::new(problem, context, stage, start_cost);
        let (jacobian, differenced) = (Mutex::new(None), AtomicUsize::new(0));
        let jacobians_before = context.jacobians.load(Ordering::Relaxed);
        let run = |x0: Vec<f64>| {
            let fitter = Free {
                evaluator: &evaluator,
                base: u.to_vec(),
                lower: vec![0.0; free.len()],
                upper: vec![1.0; free.len()],
                free: free.clone(),
                jacobian: &jacobian,
                differenced: &differenced,
            };
            let solver = BasinTrf::new()
                .with_relative_cost_change_tolerance(config.ftol)
                .with_relative_step_tolerance::<Vec<f64>, f64>(config.xtol);
            Executor::from_start(fitter, solver, x0)
                .max_iter(config.max_iter as u64)
                .run()
                .map(|result| {
                    // The best point basin saw (the method is monotone: its last accepted one).
                    let x = result.best_param().to_vec();
                    (x, result.iter() as usize, result.report.termination.code())
                })
        };
        let mut outcome = run(x0);
        // A stage that stopped on a Broyden-updated Jacobian goes on from a finite-difference
        // one (its stopping rules then hold for the true Jacobian).
        let mut iterations = 0;
        for _ in 0..BROYDEN_RERUNS {
            let updated = || {
                jacobian
                    .lock()
                    .unwrap_or_else(|e| e.into_inner())
                    .take()
                    .is_some_and(|j| j.updates > 0)
            };
            match &outcome {
                Ok((x, done, _)) if updated() => {
                    iterations += done;
                    outcome = run(x.clone());
                }
                _ => break,
            }
        }
        let failures = evaluator.failures();
        match outcome {
            Ok((x, done, code)) => {
                iterations += done;
                for (&i, &v) in free.iter().zip(&x) {
                    u[i] = v.clamp(0.0, 1.0);
                }
                StageOutcome {
                    status: format!(
                        "trust-region-reflective: {code:?} after {iterations} iteration(s) \
                     ({} Jacobians, {} of them fresh, the rest Broyden's updates)",
                        context.jacobians.load(Ordering::Relaxed) - jacobians_before,
                        differenced.load(Ordering::Relaxed)
                    ),
                    iterations,
                    failures,
                    stop: false,
                }
            }
            Err(e) => StageOutcome::stopped(
                format!("trust-region-reflective: optimiser error {e:?}"),
                failures,
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// y = a e^{−b t} sampled at t = 0, 0.1, …, 2.9 s, with a ∈ [0, 4] and b ∈ [0, b_max]
    /// mapped to the unit square: a least-squares problem whose minimum is known.
    struct Decay {
        y: Vec<f64>,
        options: OutputErrorOptions,
        /// Unused by the residuals: the space's plant.
        plant: Plant,
        names: Vec<String>,
        lower: Vec<f64>,
        upper: Vec<f64>,
        pairs: Vec<(usize, usize)>,
        held_ties: Vec<String>,
        /// A third parameter c ∈ [0, 1] whose residual term is −ε c, and the Jacobian in
        /// closed form (as sensitivities give it) instead of by differences.
        absent: Option<f64>,
    }

    impl Decay {
        /// Data of a = 2, b = 0.7 without noise.
        fn new(b_max: f64) -> Decay {
            let emps = concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/model/plants/emps_symmetric.toml"
            );
            Decay {
                y: (0..30)
                    .map(|k| 2.0 * (-0.7 * 0.1 * k as f64).exp())
                    .collect(),
                options: OutputErrorOptions::thesis(),
                plant: Plant::load(std::path::Path::new(emps)).unwrap(),
                names: vec!["a".into(), "b".into()],
                lower: vec![0.0, 0.0],
                upper: vec![4.0, b_max],
                pairs: Vec::new(),
                held_ties: Vec::new(),
                absent: None,
            }
        }

        /// [`Decay::new`] with b ∈ [0, 2] and the third parameter c of effect `epsilon`.
        fn with_absent(epsilon: f64) -> Decay {
            let mut d = Decay::new(2.0);
            d.names.push("c".into());
            d.lower.push(0.0);
            d.upper.push(1.0);
            d.absent = Some(epsilon);
            d
        }

        /// The sum of squared residuals at scaled parameters `u`.
        fn cost(&self, u: &[f64]) -> f64 {
            let r = self.residuals(&self.to_physical(u)).unwrap();
            r.iter().map(|x| x * x).sum()
        }
    }

    impl Residuals for Decay {
        fn space(&self) -> ParameterSpace<'_> {
            parameter_space_of!(self)
        }
        fn residual_count(&self) -> usize {
            self.y.len()
        }
        fn residuals(&self, p: &[f64]) -> Result<Vec<f64>, TrialFailure> {
            Ok(self
                .y
                .iter()
                .enumerate()
                .map(|(k, y)| {
                    y - p[0] * (-p[1] * 0.1 * k as f64).exp()
                        - self.absent.map_or(0.0, |e| e * p[2])
                })
                .collect())
        }
        fn jacobian_columns(&self, stencil: &Stencil) -> Vec<Vec<f64>> {
            let Some(epsilon) = self.absent else {
                return finite_difference_columns(self, stencil);
            };
            // ∂r/∂u = ∂r/∂p (upper − lower): the scaling is linear without pairs.
            let p = (stencil.p_of)(stencil.x);
            let t = |k: usize| 0.1 * k as f64;
            let e = |k: usize| (-p[1] * t(k)).exp();
            vec![
                (0..30).map(|k| -e(k) * self.upper[0]).collect(),
                (0..30)
                    .map(|k| p[0] * t(k) * e(k) * self.upper[1])
                    .collect(),
                vec![-epsilon; 30],
            ]
        }
    }

    fn trf(problem: &Decay, frozen: &[bool], u: &mut [f64]) -> StageOutcome {
        let (evaluations, jacobians) = (AtomicUsize::new(0), AtomicUsize::new(0));
        let context = StageContext::alone(
            &evaluations,
            &jacobians,
            JacobianPolicy::of(&problem.options),
        );
        let start_cost = problem.cost(u);
        // The last predictor stage's rules: the user's (default) tolerances.
        let config = stage_rules(&OutputErrorOptions::thesis(), Stage::Predictor(1.0));
        let run = StageRun {
            problem,
            stage: Stage::Predictor(1.0),
            frozen,
            rules: config,
            context: &context,
            start_cost,
        };
        let outcome = TrustRegionReflective.minimise(&run, u);
        assert!(jacobians.load(Ordering::Relaxed) >= 1);
        assert!(problem.cost(u) < start_cost);
        outcome
    }

    /// The trust-region-reflective stage finds the known minimum inside the bounds, ends
    /// on an upper bound that excludes the truth where the conditional minimum of the other
    /// parameter is the closed form's, and leaves a frozen parameter where it was.
    #[test]
    fn the_trust_region_reflective_stage_finds_the_minimum_within_the_bounds() {
        // Inside: a = 2, b = 0.7 ↔ u = (0.5, 0.35) with b ∈ [0, 2].
        let inside = Decay::new(2.0);
        let mut u = vec![0.1, 0.9];
        let outcome = trf(&inside, &[false, false], &mut u);
        assert!(!outcome.stop, "{}", outcome.status);
        let p = inside.to_physical(&u);
        assert!(
            (p[0] - 2.0).abs() < 1e-6 && (p[1] - 0.7).abs() < 1e-6,
            "{p:?}"
        );
        // b ≤ 0.5 excludes the truth: b ends on its bound, and a at the least-squares
        // amplitude for that decay, Σ y e^{−b t} / Σ e^{−2 b t}.
        let bounded = Decay::new(0.5);
        let mut u = vec![0.2, 0.3];
        trf(&bounded, &[false, false], &mut u);
        let p = bounded.to_physical(&u);
        assert!((p[1] - 0.5).abs() < 1e-9, "{p:?}");
        let e: Vec<f64> = (0..30).map(|k| (-0.5 * 0.1 * k as f64).exp()).collect();
        let a = bounded.y.iter().zip(&e).map(|(y, e)| y * e).sum::<f64>()
            / e.iter().map(|e| e * e).sum::<f64>();
        assert!((p[0] - a).abs() < 1e-6 * a, "{} vs {a}", p[0]);
        // b frozen at 0.4: a alone is fitted, b stays.
        let mut u = vec![0.2, 0.2];
        trf(&inside, &[false, true], &mut u);
        assert_eq!(u[1], 0.2);
        let e: Vec<f64> = (0..30).map(|k| (-0.4 * 0.1 * k as f64).exp()).collect();
        let a = inside.y.iter().zip(&e).map(|(y, e)| y * e).sum::<f64>()
            / e.iter().map(|e| e * e).sum::<f64>();
        assert!((inside.to_physical(&u)[0] - a).abs() < 1e-6 * a);
    }

    /// With `jacobian_refresh` 4 the trust-region-reflective stage takes Broyden-updated
    /// Jacobians between finite-difference ones and still ends on the known minimum (a run
    /// that stopped on an updated Jacobian goes on from a fresh one).
    #[test]
    fn the_trust_region_reflective_stage_with_broyden_updates_finds_the_minimum() {
        let mut broyden = Decay::new(2.0);
        broyden.options.jacobian_refresh = 4;
        let mut u = vec![0.1, 0.9];
        let outcome = trf(&broyden, &[false, false], &mut u);
        let p = broyden.to_physical(&u);
        assert!(
            (p[0] - 2.0).abs() < 1e-6 && (p[1] - 0.7).abs() < 1e-6,
            "{p:?}, {}",
            outcome.status
        );
        // "(J Jacobians, F of them fresh, …)": some were updates.
        let counts: Vec<usize> = outcome
            .status
            .split(['(', ' ', ','])
            .filter_map(|w| w.parse().ok())
            .collect();
        let [.., jacobians, differenced] = counts[..] else {
            panic!("{}", outcome.status)
        };
        assert!(
            differenced >= 1 && differenced < jacobians,
            "{}",
            outcome.status
        );
    }

    /// One Levenberg–Marquardt stage of `problem` (the whole files' rules, nothing frozen)
    /// from scaled parameters `u`, updated in place.
    fn levenberg_marquardt_stage(problem: &Decay, u: &mut [f64]) -> StageOutcome {
        let (evaluations, jacobians) = (AtomicUsize::new(0), AtomicUsize::new(0));
        let context = StageContext::alone(
            &evaluations,
            &jacobians,
            JacobianPolicy::of(&problem.options),
        );
        let run = StageRun {
            problem,
            stage: Stage::Horizon(1.0),
            frozen: &vec![false; u.len()],
            rules: stage_rules(&problem.options, Stage::Horizon(1.0)),
            context: &context,
            start_cost: problem.cost(u),
        };
        LevenbergMarquardt.minimise(&run, u)
    }

    /// The Levenberg–Marquardt stage reaches the known minimum past a parameter whose
    /// closed-form Jacobian column is ~1e-60 (a collapsed Stribeck velocity's
    /// sensitivity): rmpfit alone gives it a Gauss–Newton step of ~1e60 of its range,
    /// shortens the whole step to that parameter's bound and stops after one iteration.
    #[test]
    fn the_levenberg_marquardt_stage_steps_past_a_numerically_absent_parameter() {
        let problem = Decay::with_absent(1e-60);
        let mut u = vec![0.1, 0.9, 0.3];
        let start_cost = problem.cost(&u);
        let outcome = levenberg_marquardt_stage(&problem, &mut u);
        let p = problem.to_physical(&u);
        assert!(
            (p[0] - 2.0).abs() < 1e-6 && (p[1] - 0.7).abs() < 1e-6,
            "{p:?} from cost {start_cost}: {}",
            outcome.status
        );
        assert!(outcome.iterations > 1, "{}", outcome.status);
        // The threshold: a 1e-60 column is absent, a 1e-3 one (cost change 6e-3 ≫ 3e-7) is not.
        assert!(absent_from_the_linear_model(
            &[1e-60; 30],
            &[0.1; 30],
            0.3,
            1e-6
        ));
        assert!(!absent_from_the_linear_model(
            &[1e-3; 30],
            &[0.1; 30],
            0.3,
            1e-6
        ));
    }

    /// A Levenberg–Marquardt stage that starts 5e-8 of a range inside a bound the minimum
    /// presses on (b ≤ 0.6 against the data's 0.7), as a trust-region-reflective stage
    /// leaves such a value, with a far from its best (0.4): on the bound, rmpfit freezes b
    /// and fits a; 5e-8 inside, it shortened the whole step to b's bound, ~3e-7 of it, and
    /// stopped on the relative step.
    #[test]
    fn the_levenberg_marquardt_stage_is_not_held_by_a_value_just_inside_its_bound() {
        let problem = Decay::new(0.6);
        let mut u = vec![0.1, 1.0 - 5e-8];
        let outcome = levenberg_marquardt_stage(&problem, &mut u);
        let p = problem.to_physical(&u);
        // The best a with b = 0.6: Σ 2 e^{−1.3 t} / Σ e^{−1.2 t} over t = 0.1 k.
        let t = (0..30).map(|k| 0.1 * k as f64);
        let a_best = t.clone().map(|t| 2.0 * (-1.3 * t).exp()).sum::<f64>()
            / t.map(|t| (-1.2 * t).exp()).sum::<f64>();
        assert!(
            (p[0] - a_best).abs() < 1e-6 && p[1] == 0.6,
            "{p:?}, a best {a_best}: {}",
            outcome.status
        );
    }

    /// Broyden's update meets the secant condition J⁺ Δu = Δr, changes J only along Δu
    /// (J⁺ v = J v for v ⟂ Δu), leaves an exact Jacobian of a linear map as it is, and
    /// refuses a zero step.
    #[test]
    fn broyden_update_meets_the_secant_condition_and_nothing_more() {
        // r(u) = A u + b + 0.3 u0² e0: nonlinear in u0 only.
        let a = [[1.0, 2.0], [-0.5, 3.0], [4.0, 0.25]];
        let r = |u: &[f64]| -> Vec<f64> {
            (0..3)
                .map(|i| {
                    a[i][0] * u[0] + a[i][1] * u[1] + if i == 0 { 0.3 * u[0] * u[0] } else { 0.0 }
                })
                .collect()
        };
        let columns = |u0: f64| vec![vec![1.0 + 0.6 * u0, -0.5, 4.0], vec![2.0, 3.0, 0.25]];
        let u0 = [0.2, -0.1];
        let mut j = LastJacobian {
            u: u0.to_vec(),
            r: r(&u0),
            columns: columns(u0[0]),
            updates: 0,
        };
        let u1 = [0.5, 0.3];
        let before = j.columns.clone();
        assert!(j.broyden(&u1, &r(&u1)));
        assert_eq!(j.updates, 1);
        let du = [u1[0] - u0[0], u1[1] - u0[1]];
        let dr: Vec<f64> = r(&u1).iter().zip(r(&u0)).map(|(x, y)| x - y).collect();
        let apply = |c: &[Vec<f64>], v: [f64; 2]| -> Vec<f64> {
            (0..3).map(|i| c[0][i] * v[0] + c[1][i] * v[1]).collect()
        };
        for (x, y) in apply(&j.columns, du).iter().zip(&dr) {
            assert!((x - y).abs() < 1e-14, "secant: {x} vs {y}");
        }
        let perp = [-du[1], du[0]];
        for (x, y) in apply(&j.columns, perp).iter().zip(apply(&before, perp)) {
            assert!(
                (x - y).abs() < 1e-14,
                "orthogonal direction moved: {x} vs {y}"
            );
        }
        // Only row 0 is nonlinear: the others were exact and stay so.
        for c in 0..2 {
            for i in 1..3 {
                assert!((j.columns[c][i] - before[c][i]).abs() < 1e-14);
            }
        }
        assert!(!j.broyden(&u1, &r(&u1)), "a zero step is no update");
        assert_eq!(j.updates, 1);
    }
}
