/// Augmented-Lagrangian method for linear equality constraints `A x = b`
/// (penalty + multiplier updates over any unconstrained inner solver;
/// tolerates infeasible starts).
pub mod augmented_lagrangian_method;
/// Two-phase log-barrier method for linear inequality constraints `A x ≤ b`;
/// automatically finds a strictly feasible start when one exists.
pub mod barrier_method;
/// Basin-hopping (Wales & Doye 1997): Metropolis Monte-Carlo walk over the
/// `Ẽ(x) = min{f(x)}` transform, wrapping any [`WarmStart`](crate::core::inner::WarmStart)
/// local solver with a pluggable step taker and acceptance test.
pub mod basin_hopping;
/// Box-constrained CMA-ES with adaptive quadratic boundary penalty
/// (Hansen `BoundPenalty`, the default in pycma).
pub mod bounded_cma_es;
/// Memetic [`BoundedCmaEs`] with
/// Hansen-2011 injection: sibling of [`cma_inject`] over the bounded
/// outer. Inners: Nelder-Mead, Levenberg-Marquardt, L-BFGS-B.
pub mod bounded_cma_inject;
/// Levenberg-Marquardt with Coleman-Li box scaling.
pub mod bounded_levenberg_marquardt;
/// Brent's method (1D root or minimum bracketing).
pub mod brent;
/// Brent's method using first derivatives ("dbrent", 1D minimization).
pub mod brent_derivative;
/// Hansen 2016 (µ/µ_W, λ)-CMA-ES with negative weights.
pub mod cma_es;
/// Memetic CMA-ES with Hansen-2011 injection. Inners: Nelder-Mead,
/// Levenberg-Marquardt. For L-BFGS-B inner with consistent bound
/// handling, see [`bounded_cma_inject`].
pub mod cma_inject;
/// Configurable differential evolution: Storn-Price 1997 global
/// optimizer on a feasible box, fully backend-generic.
pub mod de;
/// Memetic [`De`] with per-generation top-k local refinement: the
/// DE-flavored sibling of [`cma_inject`]. Inners: Nelder-Mead,
/// Levenberg-Marquardt, L-BFGS-B.
pub mod de_inject;
/// Original DIRECT: deterministic global optimization over finite box bounds.
pub mod direct;
/// Pure Gauss-Newton solver for nonlinear least squares.
pub mod gauss_newton;
/// Globalized Bounded Nelder-Mead with probabilistic restarts.
pub mod gbnm;
/// Synchronous global-best particle swarm optimization.
pub mod global_best_pso;
/// Golden-section search (1D minimization on a bracketed interval).
pub mod golden_section;
/// Steepest-descent solver with a pluggable line search and optional
/// heavy-ball momentum.
pub mod gradient_descent;
/// L-BFGS family: unconstrained `Lbfgs<V, F, Unbounded>` (two-loop
/// recursion) and box-constrained `Lbfgs<V, F, Bounded>` (faithful port of
/// Nocedal's L-BFGS-B v3.0). `Lbfgsb` is a type alias for
/// `Lbfgs<V, F, Bounded>`.
pub mod lbfgs;
pub mod least_squares_diagnostics;
/// Levenberg-Marquardt solver for nonlinear least squares with
/// scaled trust-region damping by default and an optional Nielsen 1999 update.
pub mod levenberg_marquardt;
/// Generic MA-LSCh memetic framework: SSGA + local-search chains,
/// generic over the resumable LS operator.
pub mod ma_ls_ch;
/// MA-LSCh-CMA: memetic algorithm with LS chains (inner: CMA-ES).
pub mod ma_ls_ch_cma;
/// MA-SW-Chains: memetic algorithm with LS chains (inner: Solis-Wets).
pub mod ma_ls_ch_sw;
/// MADS (Audet & Dennis 2006): mesh adaptive direct search (deterministic
/// OrthoMADS instance) for nonsmooth or non-continuous objectives.
pub mod mads;
/// Nelder-Mead derivative-free simplex solver.
pub mod nelder_mead;
/// NEWUOA (Powell 2006): model-based derivative-free trust-region solver
/// (quadratic surrogate + least-Frobenius-norm update).
pub mod newuoa;
/// Nonlinear conjugate gradient with selectable updates and a pluggable line search.
pub mod nonlinear_cg;
mod population;
/// Shared core of the Powell-family DFO solvers (NEWUOA, BOBYQA, …): the
/// least-Frobenius-norm [`QuadraticModel`](powell::QuadraticModel), its `H`
/// update and origin shift, and the swappable
/// [`TrustRegionSubproblem`](powell::TrustRegionSubproblem) seam.
pub(crate) mod powell;
/// Projected gradient descent for box-constrained problems.
pub mod projected_gradient_descent;
/// Elitist (1+λ) random search over a feasible box.
pub mod random_search;
/// Mini-batch stochastic gradient descent with constant learning rate
/// and optional Polyak heavy-ball momentum.
pub mod sgd;
/// Generic simulated annealing with classical Metropolis acceptance and
/// explicit cooling schedules.
pub mod simulated_annealing;
/// Solis-Wets (1981) adaptive random local search: biased normal
/// mutations with success/failure step-size control.
pub mod solis_wets;
/// Steady-state real-coded GA with BLX-α + NAM + BGA + replace-worst.
pub mod ssga;

/// BFGS quasi-Newton solver (dense inverse Hessian; `Vec`, nalgebra, ndarray,
/// and faer, with `f32` or `f64`).
pub mod bfgs;

/// BOBYQA (Powell 2009): bound-constrained model-based derivative-free
/// trust-region solver (shared Powell core + TRSBOX + ALTMOV + RESCUE).
pub mod bobyqa;

/// LINCOA (Powell 2015): linearly-constrained model-based derivative-free
/// trust-region solver (shared Powell core + TRSTEP projected-CG + GETACT).
pub mod lincoa;

/// COBYLA (Powell 1994): nonlinearly-constrained derivative-free solver
/// (simplex linear models + L-infinity merit + `trstlp`).
pub mod cobyla;

/// Trust-region Newton solver (Nocedal & Wright Algorithm 4.1) with
/// pluggable subproblem strategies (Steihaug-CG, dogleg, Moré–Sorensen,
/// Cauchy point).
pub mod trust_region;
/// Dense trust-region-reflective least squares with rank-aware subproblems.
pub mod trust_region_reflective;

pub use augmented_lagrangian_method::AugmentedLagrangianMethod;
pub use barrier_method::BarrierMethod;
pub use basin_hopping::{
    AcceptanceTest, BasinHopping, Metropolis, RandomDisplacement, StepTaker,
};
pub use bfgs::Bfgs;
pub use bobyqa::Bobyqa;
pub use bounded_cma_es::BoundedCmaEs;
pub use bounded_cma_inject::BoundedCmaInject;
pub use bounded_levenberg_marquardt::BoundedLevenbergMarquardt;
pub use brent::Brent;
pub use brent_derivative::BrentDerivative;
pub use cma_es::CmaEs;
pub use cma_inject::{ClosureInner, CmaInject, MemeticInner};
pub use cobyla::Cobyla;
pub use de::{De, DeCrossover, DeMutation};
pub use de_inject::DeInject;
pub use direct::Direct;
pub use gauss_newton::GaussNewton;
pub use gbnm::Gbnm;
pub use global_best_pso::{
    GlobalBestPso, PsoBoundaryHandling, PsoVelocityLimit,
};
pub use golden_section::GoldenSection;
pub use gradient_descent::GradientDescent;
pub use levenberg_marquardt::{
    LevenbergMarquardt, LevenbergMarquardtQr, LmDamping,
};
pub use lincoa::Lincoa;
pub use ma_ls_ch::MaLsCh;
pub use ma_ls_ch_cma::MaLsChCma;
pub use ma_ls_ch_sw::MaLsChSw;
pub use mads::{Bounded, Constrained, Mads};
pub use nelder_mead::{NelderMead, Projected, Unbounded};
pub use newuoa::Newuoa;
pub use nonlinear_cg::{CgUpdate, NonlinearCg};
pub use projected_gradient_descent::ProjectedGradientDescent;
pub use random_search::RandomSearch;
pub use sgd::Sgd;
pub use simulated_annealing::{
    Neighbor, Reannealing, SimulatedAnnealing, TemperatureSchedule,
};
pub use solis_wets::SolisWets;
pub use ssga::Ssga;
pub use trust_region::{
    CauchyPoint, Dogleg, ExactHessian, MatrixFree, MoreSorensen, Steihaug,
    TrustRegion,
};
pub use trust_region_reflective::TrustRegionReflective;

/// Sequential least-squares programming.
pub mod slsqp;
pub use slsqp::{Slsqp, SlsqpFailure};
