//! The options of an output-error fit ([`OutputErrorOptions`]) and its presets, the only
//! home of the defaults: [`OutputErrorOptions::thesis`], [`OutputErrorOptions::isolated`],
//! [`OutputErrorOptions::coupled`].

use crate::identify::equation_error::Cutoff;
use crate::simulation::{Hold, Integrator};
use serde::Serialize;

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

/// Fitted values from which [`JacobianMethod::Auto`] takes sensitivities. Measured (one
/// simulation of a 2 s file at 1/12000 s = 1; `cargo bench --bench sensitivities` and the
/// identification record): a sensitivity run costs a fixed 2.4 (c4), 2.7 (k1), 4.2 (k3),
/// 5.5 (k5) simulations — the generated state derivatives at every stage — plus 0.04–0.11
/// per value (k5: 6.2 at 8 values, 8.0 at 32, 12.6 at 64), where forward differences cost
/// one simulation per value, spread over the cores.
pub const SENSITIVITIES_FROM: usize = 8;

/// How the Jacobian of the simulated residuals is formed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum JacobianMethod {
    /// Sensitivities for a fit of at least [`SENSITIVITIES_FROM`] values, differences for
    /// fewer (where a sensitivity run's fixed cost exceeds a few simulations). Not the
    /// presets' default yet: on a k1 diagnosis whose plant bounds every effect value, the
    /// first refit of those values ended far off (q4 at 5080 σ̂) where differences found the
    /// missing coupling (docs/src/record/sensitivities.md).
    Auto,
    /// Forward sensitivities: every file simulated once with S = ∂x/∂θ stepped beside the
    /// state ([`crate::simulation::PlantModel::predict_at_with_sensitivities`]), the exact
    /// derivative of the discrete simulation; finite differences where they are not
    /// available (the ETDRK4 integrator, user-defined effects, backlash, the equation
    /// error's residuals).
    Sensitivities,
    /// Forward finite differences, one simulation of every file per fitted parameter
    /// ([`OutputErrorOptions::fd_step`]): the default but for the isolated preset's.
    #[default]
    Differences,
}

impl std::str::FromStr for JacobianMethod {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "auto" => Ok(JacobianMethod::Auto),
            "sensitivities" => Ok(JacobianMethod::Sensitivities),
            "differences" => Ok(JacobianMethod::Differences),
            _ => Err(format!(
                "expected `auto`, `sensitivities` or `differences`, got `{s}`"
            )),
        }
    }
}

impl std::fmt::Display for JacobianMethod {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            JacobianMethod::Auto => "auto",
            JacobianMethod::Sensitivities => "sensitivities",
            JacobianMethod::Differences => "differences",
        })
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
    /// record's own (`Record::hold`, from its side file). Recorded in a report's
    /// options, so a replay holds the torques as the run did.
    #[serde(default)]
    pub hold: Option<Hold>,
    /// Delay (s) between a torque's time stamp and its application to the joints (a
    /// transport delay; 0 for none).
    pub input_delay: f64,
    /// Divergence bound on |q̇| (rad/s or m/s); `None`: from each record, the larger of
    /// [`super::DEFAULT_MAX_SPEED`] and [`super::DIVERGENCE_FACTOR`] × its fastest measured
    /// speed.
    #[serde(default)]
    pub max_speed: Option<f64>,
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
    /// How the Jacobian is formed ([`JacobianMethod`]). A report written before this field
    /// existed was run with finite differences.
    #[serde(default = "differences")]
    pub jacobian: JacobianMethod,
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
    /// (simulated from the measured state at their starts, `Problem::segmented`) and
    /// then the whole files; it runs beside the start through the horizons and the lower
    /// final cost wins (neither warm-up reaches the noise floor on every step of the
    /// Freedom 6S sequence alone). Empty: no such start.
    pub segments: Vec<f64>,
    /// After the fit, move the rigid-body symbols back toward the plant's values along the
    /// exact ties of the configuration's base parameters (`Problem::least_change`): of
    /// all points the data cannot tell apart from the minimum that way, report the one
    /// closest to the initial values, so that the next
    /// step of a locking sequence starts from prior knowledge and not from where the
    /// optimiser drifted. Off by default (refits of a few named parameters); on in
    /// `lockstep identify sequence --preset isolated|coupled`.
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
    /// fits the equation error of the whole files (`Problem::equation_error_stage`: the
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
    /// (`Problem::predictor`: the simulation pulled toward the measured positions, a
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
    /// start, it predicts the positions within `COARSE_PREDICTOR_AGREEMENT` × the noise of
    /// the user's step; otherwise on the user's step (`Problem::predictor_step_disagreement`;
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
    /// `Problem::estimate_initial_positions`, and the stage again while an estimate
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
    /// branch too (`WarmUp::StribeckBranch`, `Problem::stribeck_reseed`). `false` for
    /// a refit from a fitted minimum that already had the branch (the release of held
    /// values, `crate::identify::sequence::release_held`).
    pub stribeck_reseed: bool,
    /// The optimiser of the predictor's stages ([`StageOptimiser`]).
    pub predictor_optimiser: StageOptimiser,
    /// The optimiser of the whole files' stage, the cost (4.2)/(4.3) itself
    /// (`Stage::is_final`), of the refits that release held values, and of a sequence's
    /// joint fit ([`crate::identify::joint`]). Every other stage (horizons, segments,
    /// equation error) runs rmpfit's Levenberg–Marquardt.
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
    /// (segments, equation error, predictor). `Problem::fit` refuses options without.
    pub fn fits_the_plant_values(&self) -> bool {
        !self.horizons.is_empty()
            || !self.segments.is_empty()
            || self.equation_error.is_some()
            || !self.predictor.is_empty()
    }
}

/// What a report without [`OutputErrorOptions::jacobian`] was run with.
fn differences() -> JacobianMethod {
    JacobianMethod::Differences
}

/// The presets: the only home of the output-error defaults. The CLI (`identify sequence
/// --preset isolated|coupled`), the benches and the tests start from one of them and change fields.
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
            max_speed: None,
            xtol: 2e-6,
            ftol: 1e-6,
            max_iter: 100,
            starts: 1,
            seed: 1,
            fd_step: 1e-6,
            jacobian: JacobianMethod::Differences,
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
    /// The preset of the locking sequence named `sequence` in a model file: `isolated`
    /// ([`OutputErrorOptions::isolated`]), any other ([`OutputErrorOptions::coupled`]).
    pub fn for_sequence(sequence: &str) -> Self {
        if sequence == "isolated" {
            Self::isolated()
        } else {
            Self::coupled()
        }
    }

    /// `identify sequence --preset isolated`: the method of isolated joints (thesis 4.3.1) with the
    /// thesis's cost (4.2) (first half of each file weighted ½) and growing horizons, RK4 at
    /// 1/12000 s (the thesis's 1/6000 s leaves RK4's stability region on the Freedom 6S
    /// wrist: the digest §2), the predictor's stages (if any are asked for) by the
    /// trust-region-reflective method, the least change along ties after each step, and
    /// the Jacobian by sensitivities from [`SENSITIVITIES_FROM`] fitted values
    /// ([`JacobianMethod::Auto`]: the same minima as finite differences on the Freedom 6S
    /// steps c1..c4, for 3–8 × less CPU; the sensitivities record). The starts run from the
    /// measured first samples: estimated in every start, the initial positions took c3 of
    /// the Freedom 6S on seed-23 data from 1.12 to 1.00 σ̂, but let c5 on seed-35 data
    /// settle at 1.07 σ̂ in a wrong minimum (qeq_1 −5.5 %, 360 standard errors off, called
    /// identifiable) where the measured starts end above the floor and the warm-up start
    /// finds the truth's. A sequence estimates them after the starts instead
    /// ([`SequenceOptions::initial_positions_refit`](crate::identify::sequence::SequenceOptions::initial_positions_refit)).
    pub fn isolated() -> Self {
        OutputErrorOptions {
            weighting: TimeWeighting::HalfFirst,
            h: 1.0 / 12000.0,
            jacobian: JacobianMethod::Auto,
            least_change: true,
            predictor_optimiser: StageOptimiser::TrustRegionReflective,
            ..Self::thesis()
        }
    }

    /// `identify sequence --preset coupled`: the method of coupling joints (thesis 4.3.2) with cost
    /// (4.3) (the first 1000 samples skipped), RK4 at 1/12000 s, and the warm-ups in place
    /// of the horizons: the equation-error start (cut-off by residual analysis), then the
    /// prediction-error homotopy at ω = 100, 30, 10, 3, 1 rad/s on a coarse ETDRK4 step of
    /// 1/2000 s by the trust-region-reflective method, a Jacobian every 4 iterations with
    /// Broyden's updates between, the initial positions estimated, and the least change
    /// along ties after each step. The whole files' stage runs the trust-region-reflective
    /// method too, on the Jacobian by sensitivities from [`SENSITIVITIES_FROM`] fitted
    /// values ([`JacobianMethod::Auto`]; the predictor's ETDRK4 stages take differences):
    /// the same minima as finite differences on the Freedom 6S steps k1..k5, for 2,283
    /// CPU-s instead of 8,061 on seed-7 data, where the Levenberg–Marquardt with the same
    /// Jacobian crawled along k5's valley (the sensitivities record). The settings behind
    /// it are in the identification record.
    pub fn coupled() -> Self {
        OutputErrorOptions {
            weighting: TimeWeighting::SkipTransient(1000),
            h: 1.0 / 12000.0,
            jacobian: JacobianMethod::Auto,
            whole_files_optimiser: StageOptimiser::TrustRegionReflective,
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

    /// These options with the warm-ups of [`OutputErrorOptions::coupled`] — the
    /// equation-error start, the prediction-error homotopy and its step and optimiser —
    /// in place of their own; every other setting kept. A refit's extra start
    /// ([`RefitOptions::warm_ups`](crate::identify::refit::RefitOptions::warm_ups)) and a
    /// sequence step's warm-up start
    /// ([`StepRefit::warm_up_start`](crate::identify::sequence::StepRefit::warm_up_start)).
    pub fn with_coupled_warm_ups(self) -> Self {
        let warm = Self::coupled();
        OutputErrorOptions {
            equation_error: warm.equation_error,
            predictor: warm.predictor,
            predictor_step: warm.predictor_step,
            predictor_optimiser: warm.predictor_optimiser,
            ..self
        }
    }
}
