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
mod options;
mod records;
mod residuals;
mod statistics;
pub use options::*;
mod held;
mod information;
pub use information::*;
mod least_change;
mod scaling;
mod sensitivities;
pub(crate) use sensitivities::{chain, physical_derivatives};
mod stages;
pub(crate) use held::*;
pub use least_change::*;
pub(crate) use scaling::*;

pub(crate) use optimiser::*;
pub use records::*;
pub use residuals::*;
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
/// (`Problem::checked_predictor`): a quarter of the noise, so the coarse stage's minimum
/// lies well within the scatter the data allow.
pub const COARSE_PREDICTOR_AGREEMENT: f64 = 0.25;

/// Scaled distance from a bound within which a parameter is put on the bound before a
/// Levenberg–Marquardt stage ([`optimiser::LevenbergMarquardt`]): 1e-6 of its range, well
/// inside any standard error, and wider than the distance at which the
/// trust-region-reflective method, whose iterates stay strictly inside the bounds, leaves
/// a value it pressed on a bound (I1_33 of the Freedom 6S's coupled k5 on seed 11: 5.2e-8).
/// A value further inside no longer stops the stage either: the vendored rmpfit clips a
/// step at the limits, or takes the Cauchy step on the box, where shortening it as a whole
/// would leave almost nothing of it (vendor/PATCHES.md).
const BOUND_SNAP: f64 = 1e-6;

/// Stribeck velocities tried by the Stribeck re-seed, log-spaced over vs's bounds.
const STRIBECK_VS_GRID: usize = 9;

/// A predictor stage that ends above this factor times the larger of the noise floor and
/// the previous predictor stage's end is rerun through an intermediate bandwidth
/// (`Problem::run_predictor_refined`). Near the data the predictor's cost rises slowly
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

/// Unless [`OutputErrorOptions::max_speed`] is given, a simulation diverges when a speed
/// exceeds this multiple of the fastest speed measured in its record (at least
/// [`DEFAULT_MAX_SPEED`]): a real record faster than any fixed bound is simulated, and a
/// divergence is still caught soon after leaving the measured motion.
pub const DIVERGENCE_FACTOR: f64 = 10.0;

/// The least divergence bound (rad/s or m/s) taken from the data.
pub const DEFAULT_MAX_SPEED: f64 = 100.0;

impl Record {
    /// The fastest speed in the record (rad/s or m/s): the largest central difference of the
    /// measured positions of any free joint.
    pub fn peak_speed(&self) -> f64 {
        let two_dt = 2.0 * self.dt;
        self.q
            .iter()
            .flat_map(|q| q.windows(3).map(move |w| ((w[2] - w[0]) / two_dt).abs()))
            .filter(|v| v.is_finite())
            .fold(0.0, f64::max)
    }
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
    /// bandwidths up to `STRIBECK_BRANCH_OMEGA` and the whole files
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
    /// The earlier steps' information ([`Problem::with_earlier_information`]).
    earlier: Option<std::sync::Arc<EarlierInformation>>,
    /// Its prior on the fitted values, rows times s̄ ([`Problem::set_prior`]).
    information_prior: Option<InformationPrior>,
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

/// Why a trial point has no residuals: the optimisers reject it (its step is shortened),
/// and a start or stage that cannot be evaluated says which of these it met.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TrialFailure {
    /// The plant cannot be configured for a file at this point (file, reason).
    #[error("{0}: {1}")]
    NotConfigured(PathBuf, String),
    /// The simulation of a file diverged (file, which joint and when).
    #[error("{0}: {1}")]
    Diverged(PathBuf, String),
    /// The point leaves a guarded link physically impossible ([`Problem::guarded_links`]).
    #[error("physically impossible: {0}")]
    ImpossibleLink(String),
    /// The equation error cannot be evaluated at the point.
    #[error("equation error: {0}")]
    EquationError(String),
}

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
            earlier: None,
            information_prior: None,
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
    /// ([`Problem::with_released`]), and the earlier steps' information
    /// ([`Problem::with_earlier_information`]), which replaces the per-value priors on the
    /// values it knows.
    ///
    /// # Errors
    /// A prior spread τ that is not positive and finite.
    fn set_prior(&mut self) -> Result<()> {
        self.information_prior = None;
        if let Some(earlier) = &self.earlier {
            let occ = crate::identify::identifiability::occurrence(self.plant.model);
            let prior = earlier.prior_for(&self.names, |n| enters(&self.plant, &occ, self.conf, n));
            let s_bar = self.noise_residual_rms();
            self.information_prior = prior.map(|mut p| {
                for row in &mut p.rows {
                    row.iter_mut().for_each(|x| *x *= s_bar);
                }
                p
            });
        }
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
            .map(|n| {
                if self.earlier.as_ref().is_some_and(|e| e.knows(n)) {
                    None
                } else {
                    self.prior_standard_error(n)
                }
            })
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

    /// The same problem under the earlier steps' information `earlier` ([`EarlierInformation`]):
    /// its prior ([`EarlierInformation::prior_for`], weighted by s̄ as the per-value priors)
    /// on the fitted values, every other value the files see held, the rest at their
    /// conditional minimum; it replaces the per-value priors
    /// ([`OutputErrorOptions::carried_prior`], [`Problem::with_released`]) of the values it
    /// knows.
    ///
    /// # Errors
    /// As [`Problem::new`]'s prior (a spread τ that is not positive and finite).
    pub fn with_earlier_information(mut self, earlier: EarlierInformation) -> Result<Problem> {
        self.earlier = Some(std::sync::Arc::new(earlier));
        self.set_prior()?;
        Ok(self)
    }

    /// The earlier steps' information the problem was given, if any.
    pub fn earlier_information(&self) -> Option<&EarlierInformation> {
        self.earlier.as_deref()
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

    /// Simulate record `r` with physical parameters `p`.
    ///
    /// # Errors
    /// The plant cannot be configured or the simulation diverges (message with the file).
    pub fn simulate(&self, plant: &Plant, r: &Record) -> Result<Trajectory, TrialFailure> {
        let mut sim = plant
            .simulator(self.conf.name, &r.q_all, ConsistencyPolicy::Warn)
            .map_err(|e| TrialFailure::NotConfigured(r.file.clone(), format!("{e:#}")))?;
        sim.model.integrator = self.options.integrator;
        let (x0, input, max_speed) = self.start_of(&sim.model, r);
        sim.model
            .predict_at(
                x0,
                self.options.h,
                &input,
                self.predictor.map(|omega| (omega, r.q.as_slice())),
                &r.t,
                max_speed,
            )
            .map_err(|d| {
                let j = plant.model.joints[self.conf.free[d.joint]];
                TrialFailure::Diverged(r.file.clone(), d.message(&format!("'{j}'")))
            })
    }

    /// Where record `r` starts in simulator `sim`: the free joints at rest at the record's
    /// positions, or moving at its initial velocities with LuGre's deflections of steady
    /// sliding; its torques as the simulation holds them; the divergence bound on |q̇|.
    fn start_of<'r>(
        &self,
        sim: &crate::simulation::PlantModel,
        r: &'r Record,
    ) -> (State, InputSignal<'r>, f64) {
        let mut x0 = State::at_rest(self.conf.free.iter().map(|&j| r.q_all[j]).collect());
        if let Some(qd0) = &r.qd0 {
            for (a, &v) in qd0.iter().enumerate() {
                x0.qd[a] = v;
                if let Some(lugre) = sim.terms[a].lugre {
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
        let max_speed = self
            .options
            .max_speed
            .unwrap_or_else(|| DEFAULT_MAX_SPEED.max(DIVERGENCE_FACTOR * r.peak_speed()));
        (x0, input, max_speed)
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

    /// The whiteness of the residual at physical parameters `p` per free joint (its name),
    /// pooled over the files ([`crate::compare::whiteness`], 25 lags: the Ljung–Box test
    /// MATLAB `resid` runs): at the noise floor of a model that holds, the residual is the
    /// sensor's noise, white; a fit in a wrong minimum leaves the model's error, smooth at
    /// the sampling scale, even where its RMS is near the noise.
    ///
    /// # Errors
    /// The simulation at `p` fails.
    pub fn whiteness(&self, p: &[f64]) -> Result<Vec<(String, crate::compare::Whiteness)>> {
        let r = self
            .residuals(p)
            .map_err(|e| anyhow::anyhow!("the residual's whiteness: {e}"))?;
        let nf = self.lambda.len();
        // The residuals' order: per file, per free joint, its weighted samples.
        let mut segments: Vec<Vec<&[f64]>> = vec![Vec::new(); nf];
        let mut at = 0;
        for w in &self.sqrt_w {
            let k = w.iter().filter(|&&x| x > 0.0).count();
            for seg in segments.iter_mut() {
                seg.push(&r[at..at + k]);
                at += k;
            }
        }
        Ok(self
            .conf
            .free
            .iter()
            .zip(&segments)
            .map(|(&j, seg)| {
                (
                    self.plant.model.joints[j].to_string(),
                    crate::compare::whiteness(seg, 25),
                )
            })
            .collect())
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
}

impl Residuals for Problem {
    fn space(&self) -> ParameterSpace<'_> {
        parameter_space_of!(self)
    }

    fn residual_count(&self) -> usize {
        self.m
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
    fn residuals(&self, p: &[f64]) -> Result<Vec<f64>, TrialFailure> {
        if !self.guarded_links.is_empty() {
            let plant = self.plant_at(p);
            if let Some(f) = blocking_findings(&plant)
                .into_iter()
                .find(|f| self.guarded_links.contains(&f.link))
            {
                return Err(TrialFailure::ImpossibleLink(f.to_string()));
            }
        }
        if let Some(ee) = &self.equation_error {
            return ee
                .residuals(&self.plant_at(p))
                .map_err(|e| TrialFailure::EquationError(format!("{e:#}")));
        }
        Ok(self.residuals_of(&self.trajectories(p)?))
    }

    /// By sensitivities where the problem allows (`Problem::sensitivity_columns`), else
    /// by finite differences; by finite differences too where a sensitivity is not
    /// finite: far from the data a trajectory can leave the range the model is good for
    /// (c1 of the Freedom 6S from a ±25 % start after 3 iterations of the whole file:
    /// cost 7.6e7), where the residuals' divergence penalty keeps the differences finite
    /// and the statistics at that point would otherwise fail.
    fn jacobian_columns(&self, stencil: &Stencil) -> Vec<Vec<f64>> {
        self.sensitivity_columns(stencil)
            .filter(|cols| cols.iter().flatten().all(|x| x.is_finite()))
            .unwrap_or_else(|| finite_difference_columns(self, stencil))
    }

    fn jacobian_simulations(&self, n: usize) -> usize {
        if self.sensitivities_apply() {
            1
        } else {
            n
        }
    }

    fn prior_rows(&self) -> usize {
        self.prior.as_ref().map_or(0, |(_, w)| w.len())
            + self.information_prior.as_ref().map_or(0, |p| p.rows.len())
    }

    /// The prior's residuals at scaled parameters `u`: w_i (u_i − u₀_i), w_i = s̄ / the
    /// spread of parameter i in scaled units, then the earlier information's s̄ R (p(u) −
    /// c) (empty without a prior).
    fn prior_residuals(&self, u: &[f64]) -> Vec<f64> {
        let mut out: Vec<f64> = match &self.prior {
            Some((u0, weight)) => u
                .iter()
                .zip(u0)
                .zip(weight)
                .map(|((x, c), w)| w * (x - c))
                .collect(),
            None => Vec::new(),
        };
        if let Some(info) = &self.information_prior {
            let p = self.to_physical(u);
            for row in &info.rows {
                out.push(
                    row.iter()
                        .zip(&p)
                        .zip(&info.centre)
                        .filter(|((r, _), _)| **r != 0.0)
                        .map(|((r, x), c)| r * (x - c))
                        .sum(),
                );
            }
        }
        out
    }

    fn prior_jacobian(&self, u: &[f64]) -> Vec<Vec<f64>> {
        let n = u.len();
        let mut rows: Vec<Vec<f64>> = match &self.prior {
            Some((_, weight)) => (0..n)
                .map(|i| {
                    let mut row = vec![0.0; n];
                    row[i] = weight[i];
                    row
                })
                .collect(),
            None => Vec::new(),
        };
        if let Some(info) = &self.information_prior {
            // ∂p/∂u (exact where p is affine in u_i: everywhere except where Fs meets Fc).
            let steps: Vec<f64> = u
                .iter()
                .map(|&x| if x < 0.5 { 1e-7 } else { -1e-7 })
                .collect();
            let p_of = |x: &[f64]| self.to_physical(x);
            let p = self.to_physical(u);
            let dp_du = physical_derivatives(
                &Stencil {
                    x: u,
                    r0: &[],
                    steps: &steps,
                    p_of: &p_of,
                    central: false,
                },
                &p,
            );
            for row in &info.rows {
                rows.push(
                    (0..n)
                        .map(|i| row.iter().zip(&dp_du[i]).map(|(r, d)| r * d).sum())
                        .collect(),
                );
            }
        }
        rows
    }
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
