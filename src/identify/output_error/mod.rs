//! Output-error identification (thesis 4.1–4.4): simulate the plant on the measured
//! torques of every file of a configuration and fit parameters so that the simulated
//! positions match the measured ones.
//!
//! Cost (4.2) / (4.3): J(p) = Σ_files Σ_{a ∈ F} Σ_k w_k (λ_a (y_a,k − ŷ_a,k(p)))², with the
//! time weighting w_k of [`TimeWeighting`] and joint weights λ_a (λ = 50 for the joint of
//! interest, 1 for the joints already identified; docs/src/design/digest.md §3). Bounds on every fitted
//! parameter and Fs ≥ Fc (4.1) hold at every trial point: the optimiser works on
//! u ∈ [0, 1]ⁿ with p = lo + u (hi − lo), and a fitted Stribeck level as
//! Fs = max(Fc, lo_Fs) + u (hi_Fs − max(Fc, lo_Fs)).
//!
//! Stages ([`Stage`]): a start runs on growing horizons of the files, or — the extra start
//! of [`OutputErrorOptions::segments`] — on every file cut into short segments simulated
//! from the measured state ([`Problem::segmented`], multiple shooting), or — the extra
//! start of [`OutputErrorOptions::equation_error`] — on the torque balance at every sample
//! ([`super::equation_error`], no simulation); all end on the whole files, the cost itself.
//!
//! Optimisers ([`StageOptimiser`]): bounded Levenberg–Marquardt (MINPACK/CMPFIT, crate
//! `rmpfit`) or the trust-region-reflective method (Coleman & Li 1996, crate `basin`), the
//! Jacobian by forward finite differences, one simulation per column, run in parallel
//! (rayon), or Broyden's rank-one updates between finite-difference Jacobians
//! ([`OutputErrorOptions::jacobian_refresh`]). Standard errors from the Jacobian at the
//! solution, correlations above 0.95 flagged, NRMSE fit per joint as MATLAB's `compare`.
//! The defaults are the presets [`OutputErrorOptions::thesis`],
//! [`OutputErrorOptions::isolated`] and [`OutputErrorOptions::coupled`].
//!
//! Files: this one holds the options, the [`Problem`] of a configuration and its residuals,
//! the least change along ties; `fit.rs` the starts and their stages; `optimiser.rs` the
//! optimisers' adapters, Broyden's update and the stopping rules; `statistics.rs`
//! the standard errors, exact symmetries, structural ties and fit figures.

use super::equation_error::{Cutoff, EquationError};
use crate::plant::{ConsistencyPolicy, Plant};
use crate::simulation::{Hold, InputSignal, Integrator, State, Trajectory};
use anyhow::{bail, Result};
use generated::Configuration;
use nalgebra::DMatrix;
use rayon::prelude::*;
use rmpfit::{MPConfig, MPError, MPFitter, MPMaxFev, MPPar, MPResult, MPSide};
use serde::Serialize;
use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

mod fit;
mod optimiser;
mod statistics;

pub use fit::*;
pub(crate) use optimiser::*;
pub use statistics::*;

/// Relative cost decrease below which a warm-up stage (segments, a short horizon) ends.
const WARM_UP_FTOL: f64 = 1e-6;

/// Relative cost decrease below which a predictor stage followed by a lower bandwidth
/// ends: k3 of the Freedom 6S at ω = 30 rad/s was within 1e-3 of its final cost after 18
/// of its 79 iterations (134 of 598 s), the rest creeping by ~2e-5 per iteration.
const PREDICTOR_FTOL: f64 = 1e-4;

/// Largest root-mean-square difference on any free joint, in units of that joint's noise
/// σ̂, between the positions predicted at [`OutputErrorOptions::predictor_step`] and at
/// the user's step for which a predictor stage runs on the coarse step
/// ([`Problem::checked_predictor`]): a quarter of the noise, so the coarse stage's minimum
/// lies well within the scatter the data allow.
pub const COARSE_PREDICTOR_AGREEMENT: f64 = 0.25;

/// Scaled distance from a bound within which a parameter is put on the bound before a
/// stage ([`Problem::run_stage`]).
const BOUND_SNAP: f64 = 1e-9;

/// Stribeck velocities tried by the Stribeck re-seed, log-spaced over vs's bounds.
const STRIBECK_VS_GRID: usize = 9;

/// A predictor stage that ends above this factor times the larger of the noise floor and
/// the previous predictor stage's end is rerun through an intermediate bandwidth
/// ([`Problem::run_predictor_refined`]). Near the data the predictor's cost rises slowly
/// as ω falls, toward the whole files' floor: on the Freedom 6S paths that reached the
/// floor (k2..k5), every predictor stage ended below 1.4 × the step's final cost (k5's
/// ω = 1 rad/s: 0.419 against 0.310). Where a stage lost the path its cost jumped: k4
/// from the rerun's k3 plant, 0.386 at ω = 30 rad/s, 4.99 at 10; k5 of that path, 0.306
/// at ω = 10 rad/s, 0.728 at 3 and 4.50 at 1.
pub const PREDICTOR_REFINE_FACTOR: f64 = 2.0;

/// How many times [`Problem::run_predictor_refined`] may halve a predictor step (in
/// log ω): a factor 3 between stages becomes at most ≈ 1.32.
const PREDICTOR_REFINEMENTS: usize = 2;

/// A fitted Stribeck dip below this fraction of Fc counts as collapsed for the Stribeck
/// re-seed: a joint-4 dip of Fs = 2.1 Fc at vs = 0.05 rad/s fitted from its collapse ended
/// at Fs = 1.024 Fc, vs = 0.26 rad/s, cost 4 % above the truth's.
const STRIBECK_COLLAPSED: f64 = 0.1;

/// Stribeck levels tried by the Stribeck re-seed, as Fs = Fc (1 + r).
const STRIBECK_RATIOS: [f64; 3] = [0.25, 0.5, 1.0];

/// The Stribeck branch ([`WarmUp::StribeckBranch`]) runs the predictor's bandwidths up to
/// this one (rad/s): from the k3 re-seed, ω = 3 then 1 rad/s took the cost from 60.6 to
/// 0.30 in the predictor's terms, the lowest bandwidths pulling least on the dip.
const STRIBECK_BRANCH_OMEGA: f64 = 3.0;

/// Time weighting of the output-error cost.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, serde::Deserialize)]
pub enum TimeWeighting {
    /// Cost (4.2): samples in the first half of each file weighted ½, the rest 1.
    HalfFirst,
    /// Cost (4.3): the first `n` samples of each file skipped (transient), the rest 1.
    SkipTransient(usize),
}

impl TimeWeighting {
    /// Weight w_k of sample `k` of `n`.
    pub fn weight(self, k: usize, n: usize) -> f64 {
        match self {
            TimeWeighting::HalfFirst => {
                if 2 * k < n {
                    0.5
                } else {
                    1.0
                }
            }
            TimeWeighting::SkipTransient(s) => {
                if k < s {
                    0.0
                } else {
                    1.0
                }
            }
        }
    }
}

/// Settings of an output-error fit.
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct OutputErrorOptions {
    /// Time weighting (cost 4.2 or 4.3).
    pub weighting: TimeWeighting,
    /// Joint weight λ of the joint(s) of interest (thesis: 50); others 1.
    pub interest_weight: f64,
    /// Integration step (s); the thesis uses RK4 at 1/6000 s for the coupled method.
    pub h: f64,
    /// Integration scheme ([`crate::simulation::Integrator`]).
    pub integrator: Integrator,
    /// Hold of the measured torques between samples for every record; `None`: each
    /// record's own ([`Record::hold`], from its side file).
    #[serde(skip)]
    pub hold: Option<Hold>,
    /// Delay (s) between a torque's time stamp and its application to the joints (a
    /// transport delay; 0 for none).
    pub input_delay: f64,
    /// Divergence bound on |q̇| (rad/s).
    pub max_speed: f64,
    /// Stop when the relative step in the scaled parameters is below this (thesis: 2e-6).
    pub xtol: f64,
    /// Stop when the relative cost decrease of a step is below this.
    pub ftol: f64,
    /// Most Levenberg–Marquardt iterations per start.
    pub max_iter: usize,
    /// Starts: the plant's current values, then `starts − 1` random points in the bounds
    /// (all through the horizons; plus one through the segments when `segments` is set).
    pub starts: usize,
    /// Seed of the random starts.
    pub seed: u64,
    /// Finite-difference step in the scaled parameters (fraction of the bound width).
    pub fd_step: f64,
    /// A finite-difference Jacobian (one simulation per parameter) at most every this many
    /// Levenberg–Marquardt iterations of a stage; between them Broyden's rank-one update
    /// from the step just taken (Dennis & Schnabel, *Numerical Methods for Unconstrained
    /// Optimization*, 8.1), no simulation. A fresh Jacobian is also taken after a step
    /// that did not lower the cost, and a stage that converged on an updated one is run
    /// on from a fresh one, so every stage ends on a finite-difference Jacobian. 1: a
    /// finite-difference Jacobian at every iteration (MINPACK's `lmdif`).
    pub jacobian_refresh: usize,
    /// Growing horizons: the fit runs on the first fraction of every file's weighted
    /// samples, then on longer ones, each stage starting where the last ended (a long
    /// output-error horizon has local minima that a short one does not; the last entry
    /// must be 1). Empty: no start from the plant's values through the horizons, only the
    /// warm-ups ([`Self::segments`], [`Self::equation_error`], [`Self::predictor`]; one of
    /// them must be set), and random starts fit the whole files at once.
    pub horizons: Vec<f64>,
    /// Multiple-shooting warm-up: segment lengths (s). When not empty, a second start from
    /// the plant's values fits every file cut into segments of each length in turn
    /// (simulated from the measured state at their starts, [`Problem::segmented`]) and
    /// then the whole files; it runs beside the start through the horizons and the lower
    /// final cost wins (neither warm-up reaches the noise floor on every step of the
    /// Freedom 6S sequence alone). Empty: no such start.
    pub segments: Vec<f64>,
    /// After the fit, move the rigid-body symbols back toward the plant's values along the
    /// exact ties of the configuration's base parameters ([`Problem::least_change`]): of
    /// all points the data cannot tell apart from the minimum that way, report the one
    /// closest to the initial values, so that the next
    /// step of a locking sequence starts from prior knowledge and not from where the
    /// optimiser drifted. Off by default (refits of a few named parameters); on in
    /// `lockstep identify --method isolated|coupled`.
    pub least_change: bool,
    /// Prior on the fitted parameters (maximum a posteriori, as MATLAB's
    /// `Regularization.Nominal = 'model'`): Gaussian about the plant's values p₀ with
    /// standard deviation τ |p₀| (τ × the bound width for p₀ within 1e-3 of the width of
    /// zero), τ = this value. The fit then minimises S + s̄² Σ ((p − p₀) / (τ |p₀|))², s̄² the expected
    /// cost per residual of the measurement noise alone (from the noise σ̂ of every file
    /// and joint, [`crate::signal::noise_sigma`]): the prior decides only where the data
    /// are silent or nearly so — an output-error valley along which the cost changes by
    /// less than the noise (the coupled k1 fit of the Freedom 6S drifts m7·z7 by 24 %
    /// there). `None`: the thesis cost alone.
    pub prior: Option<f64>,
    /// Sequential prior on carried symbols: a symbol an earlier step fitted at the noise
    /// floor without determining it, whose standard error there the plant records
    /// ([`crate::plant::Plant::standard_errors`]), gets a Gaussian prior about the plant's
    /// value with that standard error (weight s̄ / σ, so the penalty is what the earlier
    /// step's data would add to its cost, linearised and without the correlations). Without
    /// it, a later step weighted toward its joint of interest (λ = 50) may trade a carried
    /// wrist symbol for a slightly better fit of that joint: k4 of the Freedom 6S pushed y6
    /// from k3's −0.03 % to its bound (+30 %), a move of 3.8 standard errors of k3, and left
    /// the wrist above the noise floor. Overrides [`Self::prior`] for those symbols.
    pub carried_prior: bool,
    /// Equation-error warm start: when set, one more start from the plant's values first
    /// fits the equation error of the whole files ([`Problem::equation_error_stage`]: the
    /// torque balance at every sample from the filtered, differentiated positions, no
    /// simulation, so no drift), then the whole files (not the horizons: on the isolated
    /// c4 of the Freedom 6S from the Appendix D guess, a 10 % horizon fitted from the
    /// equation error's point reached 309 and the next, 25 %, started at 1.5e6, while the
    /// whole files started at 2.3e3); it runs beside the other starts and the lower final
    /// cost wins. The value sets the position filter's cut-off ([`Cutoff`]: one fraction
    /// of the Nyquist frequency for all joints, or per joint by residual analysis).
    /// `None`: no such start.
    pub equation_error: Option<Cutoff>,
    /// Prediction-error homotopy: output-injection bandwidths ω (rad/s), fitted in turn
    /// ([`Problem::predictor`]: the simulation pulled toward the measured positions, a
    /// low-passed equation error at large ω, the output error at ω → 0) before the whole
    /// files. With `equation_error` set, that start runs through them after the equation
    /// error; otherwise one more start from the plant's values does. On the isolated c4 of
    /// the Freedom 6S (joint 2: LuGre friction, a spring and a friction position bias) the
    /// equation error's point left the whole files in a local minimum at 2.3e3 (the noise
    /// floor is ≈ 0.3); through ω = 3, 1 rad/s they reached 0.42 in 128 s. Empty: none.
    pub predictor: Vec<f64>,
    /// Step (s) and integrator of the predictor's stages (ω > 0), when they differ from
    /// [`Self::h`] and [`Self::integrator`]. The output injection keeps an early error from
    /// growing along the file (it is damped at ω), so a step far too coarse for the whole
    /// files serves these warm-ups: on a 40 s k3 file of the Freedom 6S, ETDRK4 at 1/2000 s
    /// is within 5e-5 rad of a converged simulation at ω ≥ 10 rad/s and within 2.2e-4 rad
    /// (about the noise σ) at 1 rad/s, where the whole file needs RK4 at 1/12000 s (ETDRK4
    /// at 1/2000 s: 3.0e-3 rad, [`crate::simulation::Integrator::Etdrk4`]). The whole
    /// files, the segments, the horizons and the final report stay on [`Self::h`], so the
    /// fit ends on the accurate simulation. A stage runs on this step only where, at its
    /// start, it predicts the positions within [`COARSE_PREDICTOR_AGREEMENT`] × the noise of
    /// the user's step; otherwise on the user's step ([`Problem::predictor_step_disagreement`];
    /// the report names each stage's step and the figure). `None`: the predictor's stages
    /// on [`Self::h`].
    pub predictor_step: Option<(f64, Integrator)>,
    /// Estimate the free joints' initial positions of every file with the parameters
    /// (MATLAB `oe`/`pem` with `InitialCondition = 'estimate'`) instead of taking the first
    /// measured sample as exact. The first sample carries the sensor noise, and a
    /// trajectory that amplifies an early difference carries it to every later sample: on
    /// the Freedom 6S's k4 file (Table 4.7, 40 s, σ = 2e-4 rad) the *true* parameters
    /// leave q5 at 1.52 σ and q4 at 1.18 σ from the measured first sample, 1.01 σ each
    /// with the initial positions estimated — so the noise floor (every joint within
    /// 1.5 σ̂) cannot be reached without them, and a fit from the first sample moves
    /// parameters to make up for the start. Done at the whole files' stage, alternating
    /// (the stage from the first samples, then a Gauss–Newton step of q(0) per file,
    /// [`Problem::estimate_initial_positions`], and the stage again while an estimate
    /// moves an initial position by more than [`INITIAL_POSITION_SETTLED`] × its joint's
    /// σ̂, at most [`INITIAL_POSITION_ROUNDS`] stages); the warm-ups (predictor, segments, equation
    /// error) keep the measured samples, which their output injection or cuts absorb. The
    /// cost, the report and the standard errors (conditional on the estimated initial
    /// positions) are then those of the estimated starts. `false`: the first sample.
    pub estimate_initial_positions: bool,
    /// The position sensor's noise σ (rad or m), when known: used for every free joint
    /// instead of the σ̂ estimated from each file's positions (robust 5th differences,
    /// [`crate::signal::noise_sigma`]) — in the noise-floor check, the prior's weight and
    /// the coarse predictor step's check. The estimate is biased upward where a joint's
    /// motion has power at the highest frequencies (the Freedom 6S wrist's q4: 11–20 %
    /// above the sensor's 2.02e-4 rad), which makes the floor check lenient there.
    pub noise_sigma: Option<f64>,
    /// After the starts, re-seed a collapsed Stribeck dip of the best one and fit that
    /// branch too ([`WarmUp::StribeckBranch`], [`Problem::stribeck_reseed`]). `false` for
    /// a refit from a fitted minimum that already had the branch (the release of held
    /// values, [`crate::identify::sequence::release_held`]).
    pub stribeck_reseed: bool,
    /// The optimiser of the predictor's stages ([`StageOptimiser`]).
    pub predictor_optimiser: StageOptimiser,
    /// The optimiser of the whole files' stage, the cost (4.2)/(4.3) itself
    /// ([`Stage::is_final`]), and of the refits that release held values. Every other
    /// stage (horizons, segments, equation error, the joint fit) runs rmpfit's
    /// Levenberg–Marquardt.
    pub whole_files_optimiser: StageOptimiser,
}

/// The bounded least-squares method of a fit's stages.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, serde::Deserialize)]
pub enum StageOptimiser {
    /// rmpfit's bounded Levenberg–Marquardt (MINPACK's `lmdif` with CMPFIT's limits), with
    /// [`OutputErrorOptions::jacobian_refresh`]'s Broyden updates between Jacobians.
    /// The CLI's `lm`.
    LevenbergMarquardt,
    /// basin's trust-region-reflective method (Coleman & Li, *SIAM J. Optim.* 6, 1996;
    /// SciPy's `least_squares(method='trf')`): bounds by an affine scaling that shrinks
    /// the steps toward a bound only along that bound's coordinate, a Jacobian at every
    /// accepted step (finite differences, or [`OutputErrorOptions::jacobian_refresh`]'s
    /// Broyden updates between them). It follows a descent on which the
    /// Levenberg–Marquardt stops with a collapsed trust region (the comparison on the
    /// Freedom 6S's k3 is in the identification record). The CLI's `trf`.
    TrustRegionReflective,
}

impl std::fmt::Display for StageOptimiser {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            StageOptimiser::LevenbergMarquardt => "Levenberg–Marquardt",
            StageOptimiser::TrustRegionReflective => "trust-region-reflective",
        })
    }
}

/// An estimated initial position has settled when a round moves it by less than this
/// fraction of its joint's noise σ̂ ([`OutputErrorOptions::estimate_initial_positions`]).
pub const INITIAL_POSITION_SETTLED: f64 = 0.1;

/// Most rounds of the whole files' stage with the initial positions re-estimated
/// ([`OutputErrorOptions::estimate_initial_positions`]).
pub const INITIAL_POSITION_ROUNDS: usize = 3;

impl OutputErrorOptions {
    /// Whether anything fits the plant's values: the horizons, or one of the warm-ups
    /// (segments, equation error, predictor). [`Problem::fit`] refuses options without.
    pub fn fits_the_plant_values(&self) -> bool {
        !self.horizons.is_empty()
            || !self.segments.is_empty()
            || self.equation_error.is_some()
            || !self.predictor.is_empty()
    }
}

/// The presets: the only home of the output-error defaults. The CLI (`identify --method
/// isolated|coupled`), the benches and the tests start from one of them and change fields.
impl OutputErrorOptions {
    /// The thesis's output-error fit (Chapter 4, cost (4.3)): RK4 at the thesis's 1/6000 s,
    /// the growing horizons 5 %, 10 %, 25 %, 50 %, 100 %, joints of interest weighted 50,
    /// rmpfit's Levenberg–Marquardt on every stage, each file started at its first measured
    /// sample, no warm-up, no prior.
    pub fn thesis() -> Self {
        OutputErrorOptions {
            weighting: TimeWeighting::SkipTransient(1000),
            interest_weight: 50.0,
            h: 1.0 / 6000.0,
            integrator: Integrator::Rk4,
            hold: None,
            input_delay: 0.0,
            max_speed: 100.0,
            xtol: 2e-6,
            ftol: 1e-6,
            max_iter: 100,
            starts: 1,
            seed: 1,
            fd_step: 1e-6,
            jacobian_refresh: 1,
            horizons: vec![0.05, 0.1, 0.25, 0.5, 1.0],
            segments: Vec::new(),
            least_change: false,
            prior: None,
            carried_prior: false,
            equation_error: None,
            predictor: Vec::new(),
            predictor_step: None,
            estimate_initial_positions: false,
            noise_sigma: None,
            stribeck_reseed: true,
            predictor_optimiser: StageOptimiser::LevenbergMarquardt,
            whole_files_optimiser: StageOptimiser::LevenbergMarquardt,
        }
    }
}

impl OutputErrorOptions {
    /// `identify --method isolated`: the method of isolated joints (thesis 4.3.1) with the
    /// thesis's cost (4.2) (first half of each file weighted ½) and growing horizons, RK4 at
    /// 1/12000 s (the thesis's 1/6000 s leaves RK4's stability region on the Freedom 6S
    /// wrist: the digest §2), the predictor's stages (if any are asked for) by the
    /// trust-region-reflective method, and the least change along ties after each step.
    pub fn isolated() -> Self {
        OutputErrorOptions {
            weighting: TimeWeighting::HalfFirst,
            h: 1.0 / 12000.0,
            least_change: true,
            predictor_optimiser: StageOptimiser::TrustRegionReflective,
            ..Self::thesis()
        }
    }

    /// `identify --method coupled`: the method of coupling joints (thesis 4.3.2) with cost
    /// (4.3) (the first 1000 samples skipped), RK4 at 1/12000 s, and the warm-ups in place
    /// of the horizons: the equation-error start (cut-off by residual analysis), then the
    /// prediction-error homotopy at ω = 100, 30, 10, 3, 1 rad/s on a coarse ETDRK4 step of
    /// 1/2000 s by the trust-region-reflective method, a Jacobian every 4 iterations with
    /// Broyden's updates between, the initial positions estimated, and the least change
    /// along ties after each step. The settings behind it are in the identification record.
    pub fn coupled() -> Self {
        OutputErrorOptions {
            weighting: TimeWeighting::SkipTransient(1000),
            h: 1.0 / 12000.0,
            jacobian_refresh: 4,
            horizons: Vec::new(),
            equation_error: Some(crate::identify::equation_error::Cutoff::Residual),
            predictor: vec![100.0, 30.0, 10.0, 3.0, 1.0],
            predictor_step: Some((1.0 / 2000.0, Integrator::Etdrk4)),
            estimate_initial_positions: true,
            least_change: true,
            predictor_optimiser: StageOptimiser::TrustRegionReflective,
            ..Self::thesis()
        }
    }
}

/// One measurement file prepared for a configuration.
#[derive(Debug, Clone)]
pub struct Record {
    /// The file.
    pub file: PathBuf,
    /// Sample times (s), evenly spaced.
    pub t: Vec<f64>,
    /// Sampling period (s).
    pub dt: f64,
    /// Commanded torque per free joint (NF × samples, N·m).
    pub tau: Vec<Vec<f64>>,
    /// Measured position per free joint (NF × samples, rad).
    pub q: Vec<Vec<f64>>,
    /// All joint positions (NJ): the locked joints' positions and the free joints' start
    /// (the first measured sample).
    pub q_all: Vec<f64>,
    /// Initial velocities of the free joints (NF, rad/s): `None` starts at rest with the
    /// LuGre deflections z = 0 (a file recorded from rest, as the thesis's); `Some` starts
    /// moving with the bristles in steady sliding (a segment cut from a file,
    /// [`Problem::segmented`]).
    pub qd0: Option<Vec<f64>>,
    /// How the torques were applied between samples (the side file's `hold`, else
    /// zero-order); [`OutputErrorOptions::hold`] overrides it.
    pub hold: Hold,
}

/// A stage of a fit: multiple-shooting segments, or a growing horizon of the files.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, serde::Deserialize)]
pub enum Stage {
    /// Every file cut into segments of this length (s), each simulated from the measured
    /// state at its start ([`Problem::segmented`]).
    Segments(f64),
    /// The first fraction of every file's weighted samples, simulated from the file's start;
    /// 1 is the cost (4.2)/(4.3) itself.
    Horizon(f64),
    /// The equation error of the whole files, no simulation
    /// ([`Problem::equation_error_stage`]).
    EquationError,
    /// The whole files simulated by the predictor of output-injection bandwidth ω (rad/s)
    /// ([`Problem::predictor`]).
    Predictor(f64),
    /// The whole files of every step of a locking sequence at once
    /// ([`super::joint::JointProblem`]).
    Joint,
}

/// How a start is warmed up before the fit of the whole files.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum WarmUp {
    /// Growing horizons ([`OutputErrorOptions::horizons`]).
    Horizons,
    /// Multiple-shooting segments ([`OutputErrorOptions::segments`]).
    Segments,
    /// The equation error, then the predictor's bandwidths if set, then the whole files
    /// ([`OutputErrorOptions::equation_error`]).
    EquationError,
    /// The predictor's bandwidths, then the whole files ([`OutputErrorOptions::predictor`];
    /// without the equation error).
    Predictor,
    /// The best start's Stribeck dip re-seeded where it collapsed, then the predictor's
    /// bandwidths up to [`STRIBECK_BRANCH_OMEGA`] and the whole files
    /// ([`Problem::stribeck_reseed`]).
    StribeckBranch,
    /// None: the joint fit of a locking sequence starts from the values its steps left
    /// ([`super::joint::JointProblem::fit`]).
    Sequence,
}

impl Stage {
    /// The stage whose result is the fit: the whole files.
    pub fn is_final(self) -> bool {
        self == Stage::Horizon(1.0)
    }
}

impl std::fmt::Display for Stage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Stage::Segments(s) => write!(f, "segments of {s} s"),
            Stage::Horizon(h) => write!(f, "horizon {:.0} %", 100.0 * h),
            Stage::EquationError => write!(f, "equation error"),
            // Four significant digits: a refined bandwidth is a geometric mean (17.32, not
            // 17.320508075688775).
            Stage::Predictor(omega) => {
                let digits = if *omega > 0.0 && omega.is_finite() {
                    (3 - omega.log10().floor() as i32).clamp(0, 12) as usize
                } else {
                    0
                };
                let text = format!("{omega:.digits$}");
                let text = if text.contains('.') {
                    text.trim_end_matches('0').trim_end_matches('.')
                } else {
                    &text
                };
                write!(f, "predictor ω = {text} rad/s")
            }
            Stage::Joint => write!(f, "joint fit"),
        }
    }
}

/// Progress of a running fit, for a display.
#[derive(Debug, Clone, Copy)]
pub struct Progress {
    /// Start index (0 = the plant's values).
    pub start: usize,
    /// Number of starts.
    pub starts: usize,
    /// Jacobians computed so far (≈ iterations).
    pub iteration: usize,
    /// Cost evaluations (simulations of all files) so far.
    pub evaluations: usize,
    /// The current stage (segments, then growing horizons).
    pub stage: Stage,
    /// Lowest cost seen in this stage of this start.
    pub cost: f64,
    /// Seconds since the fit started.
    pub elapsed: f64,
}

/// The fit problem of one configuration: which parameters, within which bounds, on which
/// files, with which weights.
#[derive(Clone)]
pub struct Problem {
    plant: Plant,
    conf: &'static Configuration,
    /// Fitted parameter names.
    pub names: Vec<String>,
    /// Lower bounds (physical units).
    pub lower: Vec<f64>,
    /// Upper bounds.
    pub upper: Vec<f64>,
    /// (Fc, Fs) index pairs within `names` under Fs ≥ Fc.
    pairs: Vec<(usize, usize)>,
    /// The files.
    pub records: Vec<Record>,
    /// Joint weights λ per free joint.
    pub lambda: Vec<f64>,
    /// √w_k per record and sample.
    sqrt_w: Vec<Vec<f64>>,
    /// Number of residuals.
    m: usize,
    /// Measurement noise σ̂ per free joint (rad), from the files ([`crate::signal::noise_sigma`],
    /// root mean square over files).
    pub noise: Vec<f64>,
    /// The prior's centre (scaled, the plant's values) and weight s̄ / spread per
    /// parameter, when [`OutputErrorOptions::prior`] is set.
    prior: Option<(Vec<f64>, Vec<f64>)>,
    /// Set on the equation-error stage: its residuals replace the simulated ones.
    equation_error: Option<std::sync::Arc<EquationError>>,
    /// Set on a prediction-error stage: the bandwidth ω (rad/s) of the output injection
    /// that pulls the simulation toward the measured positions ([`Problem::predictor`]).
    predictor: Option<f64>,
    /// Rigid-body symbols of the configuration held at the plant's values although they
    /// tie exactly with fitted ones ([`Problem::with_held_ties`]): the structural check
    /// counts them, so a fitted symbol determined only given a held one is not called
    /// identifiable.
    held_ties: Vec<String>,
    /// Values an earlier step fitted that this one fits again under a Gaussian prior of
    /// their recorded standard errors ([`Problem::with_released`]).
    released: Vec<String>,
    /// Links with a fitted symbol that are physically consistent at the plant's values
    /// (mass > 0, inertia about the centroid positive definite): a trial point that makes
    /// one of them impossible is rejected as a diverged simulation is
    /// ([`Problem::residuals`]). A link already impossible at the plant's values is free
    /// to move (the Appendix D initial guess of the Freedom 6S has L1–L5 indefinite, so
    /// its coupled steps k1..k4 guard only L6 and L7).
    guarded_links: Vec<String>,
    options: OutputErrorOptions,
}

/// A failed simulation at a trial point.
#[derive(Debug, Clone)]
pub struct TrialFailure(pub String);

/// The findings no body can have ([`crate::plant::Finding::is_blocking`]: mass ≤ 0,
/// inertia about the centroid not positive definite) of every link of `plant`; none
/// when its barycentric parameters cannot be formed (a missing value: the simulation
/// reports that).
fn blocking_findings(plant: &Plant) -> Vec<crate::plant::Finding> {
    match plant.barycentric(None) {
        Ok(b) => plant
            .consistency(&b, None)
            .into_iter()
            .filter(|f| f.is_blocking())
            .collect(),
        Err(_) => Vec::new(),
    }
}

impl Problem {
    /// Set up the fit of `names` of `plant` in configuration `conf` on `records`, with
    /// weight λ = `options.interest_weight` on the free joints listed in `interest`.
    ///
    /// # Errors
    /// No records; a fitted parameter without value or bounds, with lower ≥ upper, or with
    /// its value outside its bounds; Fs ≥ Fc infeasible within the bounds (all named).
    pub fn new(
        plant: &Plant,
        conf: &'static Configuration,
        names: Vec<String>,
        records: Vec<Record>,
        interest: &[usize],
        options: OutputErrorOptions,
    ) -> Result<Problem> {
        if records.is_empty() {
            bail!("configuration '{}': no measurement files", conf.name);
        }
        let (lower, upper, pairs) =
            feasible_bounds(plant, &names, &format!("configuration '{}'", conf.name))?;
        let nf = conf.free.len();
        let lambda: Vec<f64> = conf
            .free
            .iter()
            .map(|j| {
                if interest.contains(j) {
                    options.interest_weight
                } else {
                    1.0
                }
            })
            .collect();
        let sqrt_w: Vec<Vec<f64>> = records
            .iter()
            .map(|r| {
                let n = r.t.len();
                (0..n)
                    .map(|k| options.weighting.weight(k, n).sqrt())
                    .collect()
            })
            .collect();
        let m = residual_total(&sqrt_w, nf);
        if m <= names.len() {
            let lengths: Vec<String> = records
                .iter()
                .map(|r| format!("{} ({} samples)", r.file.display(), r.t.len()))
                .collect();
            let why = match options.weighting {
                TimeWeighting::SkipTransient(s) => {
                    format!("the cost skips the first {s} samples of each file (--skip)")
                }
                TimeWeighting::HalfFirst => "the files are too short".to_string(),
            };
            bail!(
                "configuration '{}': {m} weighted residuals for {} parameters: {why}; files: {}",
                conf.name,
                names.len(),
                lengths.join(", ")
            );
        }
        if let Some(sigma) = options.noise_sigma {
            if !(sigma > 0.0 && sigma.is_finite()) {
                bail!("noise σ: expected a positive sensor noise (rad or m), got {sigma}");
            }
        }
        let noise: Vec<f64> = (0..nf)
            .map(|a| {
                if let Some(sigma) = options.noise_sigma {
                    return sigma;
                }
                let v: f64 = records
                    .iter()
                    .map(|r| crate::signal::noise_sigma(&r.q[a]).powi(2))
                    .sum();
                (v / records.len() as f64).sqrt()
            })
            .collect();
        let mut problem = Problem {
            plant: plant.clone(),
            conf,
            names,
            lower,
            upper,
            pairs,
            records,
            lambda,
            sqrt_w,
            m,
            noise,
            prior: None,
            equation_error: None,
            predictor: None,
            held_ties: Vec::new(),
            released: Vec::new(),
            guarded_links: Vec::new(),
            options,
        };
        problem.guarded_links = {
            let impossible = blocking_findings(plant);
            let model = plant.model;
            model
                .links
                .iter()
                .enumerate()
                .filter(|(l, name)| {
                    plant
                        .link_symbols(*l)
                        .iter()
                        .any(|sym| problem.names.iter().any(|n| n == sym))
                        && !impossible.iter().any(|f| f.link == **name)
                })
                .map(|(_, name)| name.to_string())
                .collect()
        };
        problem.set_prior()?;
        Ok(problem)
    }

    /// The prior's centre and weights from the options ([`OutputErrorOptions::prior`],
    /// [`OutputErrorOptions::carried_prior`]) and the released values
    /// ([`Problem::with_released`]).
    ///
    /// # Errors
    /// A prior spread τ that is not positive and finite.
    fn set_prior(&mut self) -> Result<()> {
        if let Some(tau) = self.options.prior {
            if !(tau > 0.0 && tau.is_finite()) {
                bail!("prior: expected a positive relative spread τ (such as 0.1), got {tau}");
            }
        }
        // The carried symbols' and released values' standard errors from the step that last
        // fitted them.
        let carried: Vec<Option<f64>> = self
            .names
            .iter()
            .map(|n| self.prior_standard_error(n))
            .collect();
        if self.options.prior.is_some() || carried.iter().any(Option::is_some) {
            let s_bar = self.noise_residual_rms();
            let p0 = self.initial_values();
            // Spread in the scaled coordinates u (the parameter's units / bound width): the
            // carried standard error, else τ |p₀| (τ × the width for a value near zero),
            // else none (weight 0).
            let weight: Vec<f64> = (0..p0.len())
                .map(|i| {
                    let width = self.upper[i] - self.lower[i];
                    let spread = match (carried[i], self.options.prior) {
                        (Some(se), _) => se / width,
                        (None, Some(tau)) if p0[i].abs() > 1e-3 * width => {
                            tau * p0[i].abs() / width
                        }
                        (None, Some(tau)) => tau,
                        (None, None) => return 0.0,
                    };
                    s_bar / spread
                })
                .collect();
            self.prior = Some((self.to_scaled(&p0), weight));
        }
        Ok(())
    }

    /// The fitted symbols [`OutputErrorOptions::carried_prior`] holds, with the standard
    /// deviation of their prior (SI: the standard error the plant records from the step that
    /// last fitted them, [`Plant::standard_errors`]), in the order of [`Problem::names`];
    /// empty without the option.
    pub fn carried_prior(&self) -> Vec<(String, f64)> {
        self.names
            .iter()
            .filter(|n| !self.released.contains(n))
            .filter_map(|n| Some((n.clone(), self.prior_standard_error(n)?)))
            .collect()
    }

    /// The standard deviation (SI) of the prior on `name` from the standard error the plant
    /// records for it: a carried symbol under [`OutputErrorOptions::carried_prior`], or a
    /// released value ([`Problem::with_released`]).
    fn prior_standard_error(&self, name: &str) -> Option<f64> {
        let undetermined = self.plant.undetermined.iter().any(|n| n == name);
        let released = self.released.iter().any(|n| n == name);
        (self.options.carried_prior && undetermined || released)
            .then(|| self.plant.standard_errors.get(name).copied())
            .flatten()
    }

    /// The same problem with `released` — values an earlier step fitted, which the plant
    /// holds with their standard errors ([`Plant::standard_errors`]) and which are among
    /// [`Problem::names`] — under a Gaussian prior about the plant's values with those
    /// standard errors (weight s̄ / σ, as [`OutputErrorOptions::carried_prior`]): the
    /// sequential estimate of a value this step's data see better than the step that
    /// fitted it did ([`Statistics::held_information`]), the earlier data's verdict kept as
    /// the prior, linearised and without their correlations.
    ///
    /// # Errors
    /// A released value that is not fitted here, or has no recorded standard error.
    pub fn with_released(mut self, released: Vec<String>) -> Result<Problem> {
        for n in &released {
            if !self.names.contains(n) {
                bail!("released value '{n}' is not among the fitted parameters");
            }
            if !self.plant.standard_errors.contains_key(n) {
                bail!("released value '{n}' has no standard error in the plant");
            }
        }
        self.released = released;
        self.set_prior()?;
        Ok(self)
    }

    /// s̄: the root mean square of a residual from the measurement noise alone, √(mean of
    /// w λ² σ̂²) over the weighted samples and the free joints (the residuals' units: rad
    /// times √w λ). The scale of the prior's weights.
    pub fn noise_residual_rms(&self) -> f64 {
        let mut expected = 0.0;
        for w in &self.sqrt_w {
            for &sw in w.iter().filter(|&&x| x > 0.0) {
                for (l, s) in self.lambda.iter().zip(&self.noise) {
                    expected += (sw * l * s).powi(2);
                }
            }
        }
        (expected / self.m.max(1) as f64).sqrt()
    }

    /// The fitted parameters' values in the plant the problem was set up with (the start
    /// of the fit and the centre of its prior), physical units.
    fn initial_values(&self) -> Vec<f64> {
        self.names
            .iter()
            .map(|k| self.plant.parameters[k])
            .collect()
    }

    /// The prior's residuals w_i (u_i − u₀_i) at scaled parameters `u`, w_i = s̄ / the
    /// spread of parameter i in scaled units (empty without a prior).
    fn prior_residuals(&self, u: &[f64]) -> Vec<f64> {
        match &self.prior {
            Some((u0, weight)) => u
                .iter()
                .zip(u0)
                .zip(weight)
                .map(|((x, c), w)| w * (x - c))
                .collect(),
            None => Vec::new(),
        }
    }

    /// The prior's term of the objective at scaled parameters `u` (0 without a prior).
    pub fn prior_penalty(&self, u: &[f64]) -> f64 {
        self.prior_residuals(u).iter().map(|x| x * x).sum()
    }

    /// The same problem on the first samples of every file: the skipped transient plus
    /// `fraction` of the weighted samples.
    fn truncated(&self, fraction: f64) -> Problem {
        let mut records = Vec::with_capacity(self.records.len());
        let mut sqrt_w = Vec::with_capacity(self.records.len());
        for (r, w) in self.records.iter().zip(&self.sqrt_w) {
            let first = w.iter().position(|&x| x > 0.0).unwrap_or(0);
            let n = r.t.len();
            let keep =
                (first + ((n - first) as f64 * fraction).ceil() as usize).clamp(first + 2, n);
            let mut rr = r.clone();
            rr.t.truncate(keep);
            for c in rr.tau.iter_mut().chain(rr.q.iter_mut()) {
                c.truncate(keep);
            }
            records.push(rr);
            sqrt_w.push(w[..keep].to_vec());
        }
        self.with_records(records, sqrt_w)
    }

    /// The same problem (parameters, bounds, weights λ, options) on other `records` with
    /// sample weights `sqrt_w` (√w per record and sample); this problem's records are not
    /// copied.
    fn with_records(&self, records: Vec<Record>, sqrt_w: Vec<Vec<f64>>) -> Problem {
        Problem {
            plant: self.plant.clone(),
            conf: self.conf,
            names: self.names.clone(),
            lower: self.lower.clone(),
            upper: self.upper.clone(),
            pairs: self.pairs.clone(),
            m: residual_total(&sqrt_w, self.lambda.len()),
            records,
            lambda: self.lambda.clone(),
            sqrt_w,
            noise: self.noise.clone(),
            prior: self.prior.clone(),
            equation_error: None,
            predictor: self.predictor,
            held_ties: self.held_ties.clone(),
            released: self.released.clone(),
            guarded_links: self.guarded_links.clone(),
            options: self.options.clone(),
        }
    }

    /// The same problem with the rigid-body symbols `names` (not fitted, held at the
    /// plant's values) counted by the structural check of [`Problem::statistics`]: a
    /// fitted symbol that trades exactly with one of them is determined only given the
    /// held value, so it is not called identifiable and its `only_with` names the held
    /// symbol. Set by `--rigid-body spanning` ([`super::sequence::RigidBodyFit`]).
    pub fn with_held_ties(mut self, names: Vec<String>) -> Problem {
        self.held_ties = names;
        self
    }

    /// The same parameters, bounds and Fs ≥ Fc on the equation error of the whole files
    /// ([`EquationError`], position filter cut-off `cutoff`):
    /// its residuals are torque balances, not position errors, so it has no prior (the
    /// prior's weight is set by the position noise) and serves only as a warm start. The
    /// carried symbols — those an earlier step of the plant's sequence left undetermined
    /// ([`Plant::undetermined`]), with or without the carried prior
    /// ([`OutputErrorOptions::carried_prior`]) — stay at their values there: the torque
    /// balance moved them hundreds of the earlier step's standard errors (k4 of the
    /// Freedom 6S), a start the first predictor stage then began 100 times above its end;
    /// k3 with link 7's m7 and z7 carried from k2 went from 6.36e5 to 5.55e5 there, its
    /// predictor stages ended where RK4 diverged, and the step stopped at 2.48e4 with
    /// link 3 impossible.
    ///
    /// # Errors
    /// A file too short for the filter, or a cut-off outside (0, 1).
    pub fn equation_error_stage(&self, cutoff: Cutoff) -> Result<Problem> {
        let ee = EquationError::new(&self.plant, self.conf, &self.records, cutoff)?;
        let mut problem = self.with_records(self.records.clone(), self.sqrt_w.clone());
        problem.m = ee.len();
        problem.prior = None;
        problem.equation_error = Some(std::sync::Arc::new(ee));
        Ok(problem)
    }

    /// The parameters this stage holds at their start (the optimiser does not vary them):
    /// in the equation-error stage, the carried symbols ([`Problem::equation_error_stage`]);
    /// none elsewhere.
    pub fn frozen(&self) -> Vec<String> {
        self.names
            .iter()
            .filter(|n| self.is_frozen(n))
            .cloned()
            .collect()
    }

    /// Whether this stage holds parameter `name` at its start ([`Problem::frozen`]).
    fn is_frozen(&self, name: &str) -> bool {
        self.equation_error.is_some() && self.plant.undetermined.iter().any(|n| n == name)
    }

    /// For the equation-error stage, the position filter's cut-off per free joint
    /// (" (filter cut-offs q3 0.7, q5 0.6 of the Nyquist frequency)"); empty otherwise.
    fn equation_error_note(&self) -> String {
        let Some(ee) = &self.equation_error else {
            return String::new();
        };
        let each: Vec<String> = self
            .conf
            .free
            .iter()
            .zip(ee.cutoffs())
            .map(|(j, c)| format!("q{j} {c}"))
            .collect();
        format!(
            " (filter cut-offs {} of the Nyquist frequency)",
            each.join(", ")
        )
    }

    /// The same problem as multiple shooting: every file cut into segments of `seconds`
    /// (at least 4 samples; a shorter rest joins the last segment), each simulated from the
    /// measured state at its start: positions as measured, velocities by the 7-point cubic
    /// Savitzky–Golay derivative of the measured positions, LuGre bristles in steady
    /// sliding; the first segment keeps the file's own start. Every sample has weight 1
    /// except each segment's first (its initial condition); joint weights λ are kept.
    ///
    /// A long output-error horizon of a sensitive trajectory (a light wrist joint swinging
    /// through several turns) has local minima far from the truth; short segments have
    /// fewer, and together they still use every sample for the cost of one simulation per
    /// file. The start states are estimates — the velocity's noise is ≈ 0.5 σ/Δt, but a
    /// joint with fast content between samples is worse (joint 4 of the Freedom 6S under
    /// Table 4.7: errors up to 4 rad/s), and the bristle deflection is not measured — so at
    /// the true parameters the segments do not reach the noise floor (joint 3 alone,
    /// Table 4.3: 1.1e-2 rad RMS with 1 s segments, 6.9e-3 rad with 4 s): the segment fit is
    /// a warm start for the fit of the whole files, never the result.
    pub fn segmented(&self, seconds: f64) -> Problem {
        let mut records = Vec::new();
        let mut sqrt_w = Vec::new();
        for r in &self.records {
            let n = r.t.len();
            let len = ((seconds / r.dt).round() as usize).max(4);
            let mut starts: Vec<usize> = (0..n).step_by(len).collect();
            if starts.len() > 1 && n - starts[starts.len() - 1] < 4 {
                starts.pop();
            }
            for (i, &k0) in starts.iter().enumerate() {
                let k1 = starts.get(i + 1).copied().unwrap_or(n);
                let mut seg = Record {
                    file: r.file.clone(),
                    t: r.t[k0..k1].to_vec(),
                    dt: r.dt,
                    tau: r.tau.iter().map(|c| c[k0..k1].to_vec()).collect(),
                    q: r.q.iter().map(|c| c[k0..k1].to_vec()).collect(),
                    q_all: r.q_all.clone(),
                    qd0: r.qd0.clone(),
                    hold: r.hold,
                };
                if k0 > 0 {
                    for (a, &j) in self.conf.free.iter().enumerate() {
                        seg.q_all[j] = r.q[a][k0];
                    }
                    seg.qd0 = Some(
                        r.q.iter()
                            .map(|c| savitzky_golay_velocity(c, k0, r.dt))
                            .collect(),
                    );
                }
                let mut w = vec![1.0; k1 - k0];
                w[0] = 0.0;
                records.push(seg);
                sqrt_w.push(w);
            }
        }
        self.with_records(records, sqrt_w)
    }

    /// The same problem on the predictor's errors: every file simulated with the state pulled
    /// toward its measured positions by a critically damped output injection of bandwidth
    /// `omega` (rad/s, [`crate::simulation::PlantModel::predict_at`]). Below ω the residual is a
    /// low-passed equation error, so drift and the long memory of friction (where a joint
    /// sticks decides every later position) no longer make the cost rugged; `omega` → 0 is
    /// the output error. A sequence of decreasing ω is a homotopy from the one to the other.
    /// For ω > 0 the step and integrator are [`OutputErrorOptions::predictor_step`]'s when
    /// set.
    pub fn predictor(&self, omega: f64) -> Problem {
        let mut p = self.clone();
        p.predictor = (omega > 0.0).then_some(omega);
        if let (true, Some((h, integrator))) = (omega > 0.0, self.options.predictor_step) {
            p.options.h = h;
            p.options.integrator = integrator;
        }
        p
    }

    /// The predictor's stage at `omega` (rad/s) for a start at scaled parameters `u`, with a
    /// note for the report. With [`OutputErrorOptions::predictor_step`] set, the coarse step
    /// serves the stage only where it is checked to: at `u` the coarse and the user's step
    /// must predict the same positions within [`COARSE_PREDICTOR_AGREEMENT`] × σ̂ on every
    /// free joint (root mean square over the weighted samples, σ̂ the joint's noise). The output
    /// injection's damping of an early error weakens as ω falls: on the 40 s k3 file of the
    /// Freedom 6S, ETDRK4 at 1/2000 s is within 0.09 σ̂ at every ω down to 1 rad/s, at
    /// 1/1000 s 0.32 σ̂ at 3 and 1.5 σ̂ at 1 rad/s, at 1/500 s 0.15 σ̂ at 100 rad/s but
    /// 0.79 at 30 and 84 at 1 rad/s, where a fit would hand the whole files a point the
    /// accurate simulation does not share. A stage that fails the check runs on the user's
    /// step.
    fn checked_predictor(&self, omega: f64, u: &[f64]) -> (Problem, String) {
        let Some((h, integrator)) = self.options.predictor_step.filter(|_| omega > 0.0) else {
            return (self.predictor(omega), String::new());
        };
        let coarse = format!("{} at {h:.4e} s", integrator.to_string().to_uppercase());
        match self.coarse_step_disagreement(omega, &self.to_physical(u)) {
            Ok(d) if d <= COARSE_PREDICTOR_AGREEMENT => (
                self.predictor(omega),
                format!(" ({coarse}: within {d:.1e} σ̂ of the user's step)"),
            ),
            Ok(d) => (
                self.predictor_on_user_step(omega),
                format!(" (on the user's step: {coarse} off by {d:.1e} σ̂)"),
            ),
            Err(why) => (
                self.predictor_on_user_step(omega),
                format!(" (on the user's step: {coarse} not checked: {})", why.0),
            ),
        }
    }

    /// [`Problem::predictor`] on the user's step whatever
    /// [`OutputErrorOptions::predictor_step`] says.
    fn predictor_on_user_step(&self, omega: f64) -> Problem {
        let mut p = self.clone();
        p.options.predictor_step = None;
        p.predictor(omega)
    }

    /// How far the positions predicted at bandwidth `omega` (rad/s) on
    /// [`OutputErrorOptions::predictor_step`] lie from those on the user's step
    /// ([`OutputErrorOptions::h`], [`OutputErrorOptions::integrator`]) at physical parameters
    /// `p`: per free joint the root mean square of the difference over the weighted samples
    /// of every file, over that joint's noise σ̂; the largest over the joints (dimensionless;
    /// 1 = as far as the noise). Per joint, as the noise floor is judged, so a wrist joint's
    /// difference is not discounted by the joint of interest's weight. `Ok(None)` without a
    /// predictor step or at `omega` = 0. Errors: either simulation fails.
    pub fn predictor_step_disagreement(
        &self,
        omega: f64,
        p: &[f64],
    ) -> Result<Option<f64>, TrialFailure> {
        if self.options.predictor_step.is_none() || omega <= 0.0 {
            return Ok(None);
        }
        self.coarse_step_disagreement(omega, p).map(Some)
    }

    /// [`Problem::predictor_step_disagreement`] where a predictor step is set and ω > 0.
    fn coarse_step_disagreement(&self, omega: f64, p: &[f64]) -> Result<f64, TrialFailure> {
        let coarse = self.predictor(omega).trajectories(p)?;
        let fine = self.predictor_on_user_step(omega).trajectories(p)?;
        let mut worst: f64 = 0.0;
        for (a, sigma) in self.noise.iter().enumerate() {
            let (mut squares, mut n) = (0.0, 0usize);
            for ((c, f), w) in coarse.iter().zip(&fine).zip(&self.sqrt_w) {
                for (k, _) in w.iter().enumerate().filter(|(_, &x)| x > 0.0) {
                    squares += (c.q[a][k] - f.q[a][k]).powi(2);
                    n += 1;
                }
            }
            worst = worst.max((squares / n.max(1) as f64).sqrt() / sigma);
        }
        Ok(worst)
    }

    /// Number of residuals.
    pub fn residual_count(&self) -> usize {
        self.m
    }

    /// The options.
    pub fn options(&self) -> &OutputErrorOptions {
        &self.options
    }

    /// The same problem with every record's input held by `hold` (`None`: each record's
    /// own, [`Record::hold`]).
    pub fn with_hold(&self, hold: Option<Hold>) -> Problem {
        let mut p = self.clone();
        p.options.hold = hold;
        p
    }

    /// The same problem with every record's input applied `delay` seconds after its time
    /// stamps ([`OutputErrorOptions::input_delay`]).
    pub fn with_input_delay(&self, delay: f64) -> Problem {
        let mut p = self.clone();
        p.options.input_delay = delay;
        p
    }

    /// The same problem simulated at step `h` (s) by `integrator`.
    pub fn with_step(&self, h: f64, integrator: Integrator) -> Problem {
        let mut p = self.clone();
        p.options.h = h;
        p.options.integrator = integrator;
        p
    }

    /// The configuration.
    pub fn configuration(&self) -> &'static Configuration {
        self.conf
    }

    /// Every joint's position (rad, `n_joints` each) at the start of each file, in file
    /// order: where the files hold the locked joints, for the structural checks that
    /// evaluate the model there.
    pub fn locked_at(&self) -> Vec<Vec<f64>> {
        self.records.iter().map(|r| r.q_all.clone()).collect()
    }

    /// Physical parameters from scaled ones (u ∈ [0, 1]ⁿ).
    pub fn to_physical(&self, u: &[f64]) -> Vec<f64> {
        scaled_to_physical(&self.lower, &self.upper, &self.pairs, u)
    }

    /// Scaled parameters of physical ones (clamped into the feasible set).
    pub fn to_scaled(&self, p: &[f64]) -> Vec<f64> {
        physical_to_scaled(&self.lower, &self.upper, &self.pairs, p)
    }

    /// The plant with the fitted parameters set to `p`.
    pub fn plant_at(&self, p: &[f64]) -> Plant {
        let mut plant = self.plant.clone();
        plant.set_values(&self.names, p);
        plant
    }

    /// Simulate record `r` with physical parameters `p`.
    ///
    /// # Errors
    /// The plant cannot be configured or the simulation diverges (message with the file).
    pub fn simulate(&self, plant: &Plant, r: &Record) -> Result<Trajectory, TrialFailure> {
        let fail = |e: String| TrialFailure(format!("{}: {e}", r.file.display()));
        let mut sim = plant
            .simulator(self.conf.name, &r.q_all, ConsistencyPolicy::Warn)
            .map_err(|e| fail(format!("{e:#}")))?;
        sim.model.integrator = self.options.integrator;
        let mut x0 = State::at_rest(self.conf.free.iter().map(|&j| r.q_all[j]).collect());
        if let Some(qd0) = &r.qd0 {
            for (a, &v) in qd0.iter().enumerate() {
                x0.qd[a] = v;
                if let Some(lugre) = sim.model.terms[a].lugre {
                    x0.z[a] = lugre.sliding_deflection(v);
                }
            }
        }
        let input = InputSignal {
            t0: r.t[0] + self.options.input_delay,
            dt: r.dt,
            tau: &r.tau,
            hold: self.options.hold.unwrap_or(r.hold),
        };
        sim.model
            .predict_at(
                x0,
                self.options.h,
                &input,
                self.predictor.map(|omega| (omega, r.q.as_slice())),
                &r.t,
                self.options.max_speed,
            )
            .map_err(|d| {
                let j = plant.model.joints[self.conf.free[d.joint]];
                fail(d.message(&format!("'{j}'")))
            })
    }

    /// Weighted residuals √w_k λ_a (y − ŷ) of one record into `out`.
    fn record_residuals(&self, ri: usize, traj: &Trajectory, out: &mut [f64]) {
        let r = &self.records[ri];
        let mut i = 0;
        for (a, lam) in self.lambda.iter().enumerate() {
            for (k, &sw) in self.sqrt_w[ri].iter().enumerate() {
                if sw > 0.0 {
                    out[i] = sw * lam * (r.q[a][k] - traj.q[a][k]);
                    i += 1;
                }
            }
        }
    }

    /// The simulated trajectory of every file at physical parameters `p`, files in
    /// parallel.
    ///
    /// # Errors
    /// The first failing file's simulation.
    pub fn trajectories(&self, p: &[f64]) -> Result<Vec<Trajectory>, TrialFailure> {
        let plant = self.plant_at(p);
        self.records
            .par_iter()
            .map(|r| self.simulate(&plant, r))
            .collect()
    }

    /// The records with the free joints' initial positions estimated (MATLAB `compare`'s
    /// `InitialCondition = 'e'`): the first measured sample carries the position noise, and
    /// with friction holding the joint an initial error persists for seconds. One
    /// Gauss–Newton step of the free joints' q(0), from the records' current ones, on the
    /// whole file's unweighted position residual of `plant` (central differences,
    /// ±1e-3 rad), run per file. All samples, including those the cost (4.3) skips: the
    /// start is seen best before the trajectory amplifies it — on the Freedom 6S's k4 the
    /// same step on the cost's weighted samples after 10 s left the true parameters at
    /// 17–126 σ̂ (the linearisation does not hold that far), on the whole file at 1.0 σ̂.
    ///
    /// # Errors
    /// A simulation fails (file named).
    pub fn estimate_initial_positions(&self, plant: &Plant) -> Result<Vec<Record>, TrialFailure> {
        let nf = self.conf.free.len();
        let delta = 1e-3;
        self.records
            .par_iter()
            .map(|r| {
                let stack =
                    |t: &Trajectory| -> Vec<f64> { t.q.iter().flatten().copied().collect() };
                let y: Vec<f64> = r.q.iter().flatten().copied().collect();
                let base = stack(&self.simulate(plant, r)?);
                let mut cols = Vec::with_capacity(nf);
                for a in 0..nf {
                    let at = |d: f64| {
                        let mut rr = r.clone();
                        rr.q_all[self.conf.free[a]] += d;
                        self.simulate(plant, &rr).map(|t| stack(&t))
                    };
                    let (p, m) = (at(delta)?, at(-delta)?);
                    cols.push(
                        p.iter()
                            .zip(&m)
                            .map(|(x, z)| (x - z) / (2.0 * delta))
                            .collect::<Vec<f64>>(),
                    );
                }
                let a = DMatrix::from_fn(y.len(), nf, |i, c| cols[c][i]);
                let e = nalgebra::DVector::from_iterator(
                    y.len(),
                    y.iter().zip(&base).map(|(u, v)| u - v),
                );
                let mut out = r.clone();
                if let Some(Ok(d)) = crate::util::svd(a).map(|s| s.solve(&e, 1e-12)) {
                    for (k, &j) in self.conf.free.iter().enumerate() {
                        // A step beyond ±10 δ is not a noise correction: keep the sample.
                        if d[k].abs() <= 10.0 * delta {
                            out.q_all[j] += d[k];
                        }
                    }
                }
                Ok(out)
            })
            .collect()
    }

    /// The same problem on the records with the initial positions `plant` fits best
    /// ([`Problem::estimate_initial_positions`]).
    ///
    /// # Errors
    /// A simulation fails (file named).
    pub fn with_initial_positions_of(&self, plant: &Plant) -> Result<Problem, TrialFailure> {
        Ok(self.with_records(self.estimate_initial_positions(plant)?, self.sqrt_w.clone()))
    }

    /// The same problem with every file's free-joint initial positions moved by `offsets`
    /// (per file, per free joint, rad; [`FitResult::initial_positions`]: the starts a fit
    /// settled on, so that [`Problem::cost`] there repeats that fit's cost). Files without
    /// an offset keep their measured first samples.
    pub fn with_initial_offsets(&self, offsets: &[Vec<f64>]) -> Problem {
        let records = self
            .records
            .iter()
            .enumerate()
            .map(|(i, r)| {
                let mut r = r.clone();
                if let Some(d) = offsets.get(i) {
                    for (&j, dj) in self.conf.free.iter().zip(d) {
                        r.q_all[j] += dj;
                    }
                }
                r
            })
            .collect();
        self.with_records(records, self.sqrt_w.clone())
    }

    /// Residual vector (length [`Problem::residual_count`]) of the files' trajectories.
    pub(crate) fn residuals_of(&self, trajectories: &[Trajectory]) -> Vec<f64> {
        let mut r = vec![0.0; self.m];
        let mut at = 0;
        for (ri, traj) in trajectories.iter().enumerate() {
            let len = residual_total(&self.sqrt_w[ri..=ri], self.lambda.len());
            self.record_residuals(ri, traj, &mut r[at..at + len]);
            at += len;
        }
        r
    }

    /// The links this fit keeps physically consistent ([`Problem::residuals`]): those with
    /// a fitted symbol that are consistent at the plant's values, by name.
    pub fn guarded_links(&self) -> &[String] {
        &self.guarded_links
    }

    /// Residual vector (length [`Problem::residual_count`]) at physical parameters `p`,
    /// files simulated in parallel.
    ///
    /// # Errors
    /// The first failing file's simulation.
    ///
    /// A trial point that leaves a [guarded](Problem::guarded_links) link physically
    /// impossible fails too (named): the torque balance of the equation error and a
    /// strongly pulled predictor can be evaluated at a point no body has, and a fit that
    /// starts consistent must not end there (a constraint, as the bounds are).
    pub fn residuals(&self, p: &[f64]) -> Result<Vec<f64>, TrialFailure> {
        if !self.guarded_links.is_empty() {
            let plant = self.plant_at(p);
            if let Some(f) = blocking_findings(&plant)
                .into_iter()
                .find(|f| self.guarded_links.contains(&f.link))
            {
                return Err(TrialFailure(format!("physically impossible: {f}")));
            }
        }
        if let Some(ee) = &self.equation_error {
            return ee
                .residuals(&self.plant_at(p))
                .map_err(|e| TrialFailure(format!("equation error: {e:#}")));
        }
        Ok(self.residuals_of(&self.trajectories(p)?))
    }

    /// Σ r² at `p`, or +∞ where the simulation fails.
    pub fn cost(&self, p: &[f64]) -> f64 {
        self.residuals(p)
            .map(|r| r.iter().map(|x| x * x).sum())
            .unwrap_or(f64::INFINITY)
    }

    /// Least-change solution: from a minimum `p` of the cost, the point the data cannot tell
    /// from it that is nearest the plant's values p₀.
    ///
    /// The configuration sees the rigid body only through its base parameters β, so the
    /// fitted rigid-body symbols move from `p` toward p₀ along β = β(p)
    /// ([`least_change_along_ties`](super::identifiability::least_change_along_ties)):
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
    /// member: k1's Fs_5 at 50 × its initial value, with vs_5 → 0, held the family at
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
        let moved_to = super::identifiability::least_change_along_ties(
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
        let mut held = Vec::new();
        for m in self.gain_scale_toward(&fitted, &p0) {
            let c = self.with_plant_values(&m.held).cost(&m.fitted);
            if c <= cost_at_minimum + allowed_rise {
                (fitted, cost, held) = (m.fitted, c, m.held);
                gain_scale = Some(m.alpha);
                break;
            }
        }
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
        })
    }

    /// The same problem with the plant's values of the (not fitted) parameters `values`
    /// replaced: the held ties the plant-gain scale move scales
    /// ([`Problem::least_change`]). Borrowed when `values` is empty.
    fn with_plant_values(&self, values: &[(String, f64)]) -> std::borrow::Cow<'_, Problem> {
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
    fn gain_scale_toward(&self, p: &[f64], p0: &[f64]) -> Vec<GainScaleMove> {
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
        let log_rho: Vec<f64> = members
            .iter()
            .filter(|&&i| self.names[i].starts_with("Kp_") && p[i] / p0[i] > 0.0)
            .map(|&i| (p[i] / p0[i]).ln())
            .collect();
        if log_rho.is_empty() {
            return Vec::new();
        }
        let alpha = (-log_rho.iter().sum::<f64>() / log_rho.len() as f64).exp();
        let mut within = alpha;
        let values = members
            .iter()
            .map(|&i| (p[i], self.lower[i], self.upper[i]))
            .chain(held.iter().map(|&(_, v, lo, hi)| (v, lo, hi)));
        for (v, lo, hi) in values {
            // α v within [lo, hi].
            let (a, b) = (lo / v, hi / v);
            within = within.clamp(a.min(b), a.max(b));
        }
        let scaled = |alpha: f64| {
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
            }
        };
        let mut out: Vec<GainScaleMove> = Vec::new();
        for a in [alpha, within] {
            let new = out.iter().all(|m| (a - m.alpha).abs() > 1e-9);
            if a.is_finite() && a > 0.0 && (a - 1.0).abs() >= 1e-9 && new {
                out.push(scaled(a));
            }
        }
        out
    }
}

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

/// q̇ at sample `k` of `q` (3 ≤ k < len − 3, else the nearest such sample) by the 7-point
/// cubic Savitzky–Golay derivative (22, −67, −58, 0, 58, 67, −22)/(252 Δt): exact for
/// quartics, noise gain ≈ 0.51 σ/Δt.
fn savitzky_golay_velocity(q: &[f64], k: usize, dt: f64) -> f64 {
    const C: [f64; 7] = [22.0, -67.0, -58.0, 0.0, 58.0, 67.0, -22.0];
    if q.len() < 7 {
        return 0.0;
    }
    let k = k.clamp(3, q.len() - 4);
    C.iter()
        .enumerate()
        .map(|(i, c)| c * q[k + i - 3])
        .sum::<f64>()
        / (252.0 * dt)
}

/// Number of weighted residuals of files with sample weights √w `sqrt_w` and `nf` free
/// joints (samples of weight 0 are left out).
fn residual_total(sqrt_w: &[Vec<f64>], nf: usize) -> usize {
    sqrt_w
        .iter()
        .map(|w| w.iter().filter(|&&x| x > 0.0).count() * nf)
        .sum()
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
}

/// One candidate of the plant-gain scale move ([`Problem::least_change`]).
struct GainScaleMove {
    /// The scale α.
    alpha: f64,
    /// The fitted parameters after it.
    fitted: Vec<f64>,
    /// The held ties it scales, with their new values.
    held: Vec<(String, f64)>,
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
    let Some((symbol, joint)) = name.rsplit_once('_') else {
        return false;
    };
    joint.parse::<usize>().is_ok()
        && matches!(
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

/// Result of [`Problem::fit`].
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct FitResult {
    /// Configuration.
    pub configuration: String,
    /// Fitted parameter names.
    pub names: Vec<String>,
    /// Values before.
    pub initial: Vec<f64>,
    /// Values after.
    pub fitted: Vec<f64>,
    /// Lower bounds used (after Fs ≥ Fc).
    pub lower: Vec<f64>,
    /// Upper bounds used.
    pub upper: Vec<f64>,
    /// Cost (4.2)/(4.3) at the plant's values.
    pub cost_before: f64,
    /// Cost at the result.
    pub cost_after: f64,
    /// The prior's term at the result ([`OutputErrorOptions::prior`]; 0 without one): the
    /// fit minimised `cost_after + prior_penalty`.
    pub prior_penalty: f64,
    /// The move from the minimum toward the initial values, when
    /// [`OutputErrorOptions::least_change`] is on.
    pub least_change: Option<LeastChange>,
    /// Uncertainty and fit figures.
    pub statistics: Statistics,
    /// All starts.
    pub starts: Vec<StartSummary>,
    /// The start that won.
    pub best_start: usize,
    /// Cost evaluations (each simulates every file), all starts.
    pub evaluations: usize,
    /// Jacobians (each n simulations of every file), all starts.
    pub jacobians: usize,
    /// Wall time (s).
    pub wall_s: f64,
    /// Number of residuals.
    pub residuals: usize,
    /// Files.
    pub files: Vec<PathBuf>,
    /// Per file, per free joint: the estimated initial position minus the first measured
    /// sample (rad), when [`OutputErrorOptions::estimate_initial_positions`] is on; the
    /// cost, RMS figures and standard errors are on these starts.
    pub initial_positions: Option<Vec<Vec<f64>>>,
}

impl FitResult {
    /// Write the fitted values into `plant`, and the held ties the least change scaled
    /// ([`LeastChange::held`]).
    pub fn apply(&self, plant: &mut Plant) {
        plant.set_values(&self.names, &self.fitted);
        for (n, v) in self.least_change.iter().flat_map(|lc| &lc.held) {
            plant.parameters.insert(n.clone(), *v);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_predictor_stage_is_named_by_its_bandwidth_to_four_significant_digits() {
        let name = |omega: f64| Stage::Predictor(omega).to_string();
        assert_eq!(name(100.0), "predictor ω = 100 rad/s");
        assert_eq!(
            name(30.0f64.sqrt() * 10.0f64.sqrt()),
            "predictor ω = 17.32 rad/s"
        );
        assert_eq!(name(3.0f64.sqrt()), "predictor ω = 1.732 rad/s");
        assert_eq!(name(5.5), "predictor ω = 5.5 rad/s");
        assert_eq!(name(0.25), "predictor ω = 0.25 rad/s");
        assert_eq!(name(0.0), "predictor ω = 0 rad/s");
    }

    /// The 7-point cubic Savitzky–Golay derivative is exact for quartics (its error term is
    /// the fifth derivative) and its noise gain is √Σc² / 252 ≈ 0.51 per Δt.
    #[test]
    fn savitzky_golay_velocity_is_exact_for_quartics() {
        let dt = 0.01;
        let q: Vec<f64> = (0..20)
            .map(|k| {
                let t = k as f64 * dt;
                0.3 - 2.0 * t + 5.0 * t * t - 7.0 * t.powi(3) + 11.0 * t.powi(4)
            })
            .collect();
        for k in [3, 9, 16] {
            let t = k as f64 * dt;
            let exact = -2.0 + 10.0 * t - 21.0 * t * t + 44.0 * t.powi(3);
            assert!((savitzky_golay_velocity(&q, k, dt) - exact).abs() < 1e-9);
        }
        // Near the ends the nearest centred window is used: sample 3 for sample 0.
        assert_eq!(
            savitzky_golay_velocity(&q, 0, dt),
            savitzky_golay_velocity(&q, 3, dt)
        );
        let gain = [22.0f64, 67.0, 58.0, 0.0, 58.0, 67.0, 22.0]
            .iter()
            .map(|c| c * c)
            .sum::<f64>()
            .sqrt()
            / 252.0;
        assert!((gain - 0.5124).abs() < 1e-3, "{gain}");
    }
}
