//! Framework: traits, state shapes, the iteration driver, and the
//! convergence and execution controls. The slot taxonomy is:
//!
//! - [`problem`]: what the *user* implements about their objective:
//!   [`CostFunction`](problem::CostFunction),
//!   [`Gradient`](problem::Gradient),
//!   [`MiniBatchGradient`](problem::MiniBatchGradient) (finite-sum,
//!   for mini-batch SGD),
//!   [`Residual`](problem::Residual)/[`Jacobian`](problem::Jacobian)
//!   (least squares), and [`Hessian`](problem::Hessian) (second order).
//!   Future: operators (matrix-free).
//! - [`numdiff`]: finite-difference derivative synthesis and analytic checks.
//!   [`DerivativeChecker`](numdiff::DerivativeChecker) checks gradients and
//!   Jacobians with optional bounds and directional probes. The
//!   [`FiniteDiff`](numdiff::FiniteDiff) wrapper adds
//!   [`Gradient`](problem::Gradient)/[`Jacobian`](problem::Jacobian)/
//!   [`Hessian`](problem::Hessian) to a problem that only exposes
//!   function values.
//! - [`constraint`]: optional [`Constraints`](crate::Constraints) declarations
//!   for objective and residual problems. A typed
//!   [`ConstraintSet`](crate::ConstraintSet) determines compatibility with constrained solvers.
//!   Separate capabilities evaluate nonlinear values and Jacobians. COBYLA and
//!   SLSQP consume the complete set directly; absent blocks require no unused
//!   matrix type or callback.
//! - [`barrier`]: the [`LogBarrier`](barrier::LogBarrier) adapter that
//!   rewrites a linearly-constrained problem as the unconstrained
//!   log-barrier objective consumed by the
//!   [`BarrierMethod`](crate::solver::BarrierMethod).
//! - [`state`]: what a solver carries between iterations:
//!   [`State`](state::State) for the minimum,
//!   [`GradientState`](state::GradientState)/
//!   [`SimplexState`](state::SimplexState) when a solver carries
//!   richer info that convergence checks can read.
//! - [`solver`]: the [`Solver`](solver::Solver) trait every concrete
//!   solver implements. Lifecycle is `init` once, then repeated
//!   `next_iter`, with an optional `terminate` hook.
//! - [`convergence`]: shared fixed slots for solver-owned optional checks.
//!   Enabled checks require only their minimum state and backend capabilities.
//! - [`run_control`]: execution budgets, targets, stalls, and application hooks.
//! - [`termination`]: stopping reasons reported by solvers and execution controls.
//! - [`observer`]: read-only side-effect hooks fired around the loop
//!   ([`Observe`](observer::Observe) + [`ObserverMode`](observer::ObserverMode)).
//! - [`checkpoint`]: solver-aware snapshots for exact continuation. State-only
//!   warm-start files remain an observer concern.
//! - [`executor`]: the driver: [`Executor`](executor::Executor)/
//!   [`Stepper`](executor::Stepper)/[`run_loop_with_control`](executor::run_loop_with_control), plus the
//!   cooperative [`CancellationToken`](executor::CancellationToken). The
//!   canonical iteration ordering is documented on the [`executor`] module.
//! - [`inner`]: the composition adapter:
//!   [`InnerExecutor`](inner::InnerExecutor) wraps `run_loop_with_control` for outer
//!   solvers that drive an inner solver per outer iteration. See
//!   `CONTRIBUTING.md` "Solver composition" for the contracts.
//! - [`math`]: the small shared math layer
//!   ([`ScaledAdd`](math::ScaledAdd), [`NormSquared`](math::NormSquared),
//!   …) that backend-generic solvers depend on. Per tenet 5, this stays
//!   honest: only ops every backend can implement well live here. LA-heavy
//!   ops will live in a separate tier when the first solver wants them.

pub mod augmented_lagrangian;
pub mod barrier;
pub mod checkpoint;
pub mod constraint;
pub mod convergence;
pub mod executor;
pub mod inner;
pub mod least_squares;
pub mod math;
pub mod numdiff;
pub mod observer;
#[doc(hidden)]
pub mod parallel;
pub mod problem;
pub mod rng;
pub mod run_control;
pub mod solver;
pub mod state;
pub mod termination;
