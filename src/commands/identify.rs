//! `identify idim` and `identify sequence --preset isolated|coupled`: the methods'
//! subcommands, and the output-error options on the command line, built on the presets of
//! the library ([`OutputErrorOptions::isolated`], [`OutputErrorOptions::coupled`],
//! [`SequenceOptions::preset`]).

use super::*;

/// `lockstep identify`'s methods: each takes only its own options (one of the other is
/// refused naming the subcommand it belongs to, [`misplaced_option`]).
/// `identify idim --weighting`.
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
pub enum WeightingArg {
    /// IDIM-WLS.
    Wls,
    /// Ordinary least squares.
    Ols,
    /// WLS where the joints' torque scales differ by more than 10×.
    Auto,
}

impl From<WeightingArg> for lockstep::identify::idim::Weighting {
    fn from(w: WeightingArg) -> Self {
        use lockstep::identify::idim::Weighting;
        match w {
            WeightingArg::Wls => Weighting::Wls,
            WeightingArg::Ols => Weighting::Ols,
            WeightingArg::Auto => Weighting::Auto,
        }
    }
}

#[derive(Debug, Subcommand)]
pub enum IdentifyMethod {
    /// IDIM-LS: the inverse dynamic model, linear least squares on torque-measured data
    /// (positions filtered and differentiated), fitted on the base parameters where the
    /// regressor is rank-deficient.
    Idim {
        #[command(flatten)]
        common: Common,
        /// Write the plant with the fitted values to this file.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Write the fitted plant even when a link's mass or inertia is not physical or a
        /// value leaves its bounds (refused by default, with the reasons).
        #[arg(long)]
        allow_inconsistent: bool,
        /// Row weighting: `wls` (IDIM-WLS, each joint's rows divided by its residual σ),
        /// `ols` (every row alike), `auto` (WLS where the joints' torque RMS differ by more
        /// than 10×).
        #[arg(long, value_enum, default_value = "auto")]
        weighting: WeightingArg,
        /// After the least squares, the physically consistent standard set nearest to the
        /// data and to the plant's values (every link's pseudo-inertia positive definite,
        /// friction and rotor inertias non-negative; Wensing et al. 2018, log-Cholesky of
        /// Rucker & Wensing 2022): its torque error beside the unconstrained one, and the
        /// values that moved furthest from the plant's. `--out` then writes it.
        #[arg(long)]
        consistent: bool,
    },
    /// DIDIM (Gautier, Janot, Vandanjon 2013): closed-loop output error for a device
    /// measured under its own controller. The plant, from its values, is simulated under
    /// the controller of `--controller` on each file's reference; IDIM-LS on the simulated
    /// positions and the measured forces or torques gives the next values, until the
    /// closed-loop force error stops changing.
    Didim {
        #[command(flatten)]
        files: PlantAndData,
        /// The controller file (e.g. model/control/emps_controller.toml).
        #[arg(long)]
        controller: PathBuf,
        /// Write the plant with the fitted values to this file.
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Output error along the model's locking sequence (thesis 4.3) on the position
    /// measurements in `--data` (files or directories), writing `plant.toml`, `report.md`
    /// and `report.json` to `--out` after every step.
    #[command(disable_help_flag = true)]
    Sequence(Box<SequenceArgs>),
}

/// `lockstep identify sequence`.
#[derive(Debug, Args)]
pub struct SequenceArgs {
    /// The method, its locking sequence and its defaults: `isolated` (isolated joints,
    /// thesis 4.3.1) or `coupled` (coupling joints, 4.3.2).
    #[arg(long, value_enum)]
    pub preset: Preset,
    #[command(flatten)]
    pub files: PlantAndData,
    /// Run this step only (the plant must hold the earlier steps' values).
    #[arg(long)]
    pub config: Option<String>,
    /// Output directory.
    #[arg(long, default_value = "lockstep-out/identify")]
    pub out: PathBuf,
    #[command(flatten)]
    pub oe: OutputErrorArgs,
    /// Print help: every option and its default (--help-long: with details).
    #[arg(short = 'h', long, action = clap::ArgAction::HelpShort)]
    help: Option<bool>,
    /// Print help with each option's details.
    #[arg(long, action = clap::ArgAction::HelpLong)]
    help_long: Option<bool>,
}

/// Settings of output-error identification (`identify sequence`).
#[derive(Debug, Args)]
pub struct OutputErrorArgs {
    /// Resume an interrupted run in --out from its last completed step.
    ///
    /// Starts from --out's plant.toml, skips the steps its report lists and adds the rest to that report.
    #[arg(long)]
    #[arg(help_heading = "Output error: the sequence and its refinements")]
    pub resume: bool,
    /// Options from a file: a TOML table of option fields, or an earlier run's report.json (replays it).
    ///
    /// Applied to the preset after the flags' defaults; a flag given on the command line wins. Fields as in `report.json`'s `options`, e.g. `h = 8.333e-5`, `horizons = [0.1, 1.0]`, `max_speed = 300.0`.
    #[arg(long, value_name = "FILE")]
    #[arg(help_heading = "Output error: the sequence and its refinements")]
    pub profile: Option<PathBuf>,
    /// One option by its field name, e.g. `--set max_speed=300` (a TOML value; repeatable).
    ///
    /// Applied after --profile, e.g. `--set 'horizons=[0.5, 1.0]'`; a field a given flag also sets is refused.
    #[arg(long, value_name = "FIELD=VALUE")]
    #[arg(help_heading = "Output error: the sequence and its refinements")]
    pub set: Vec<String>,
    /// The identify options given on the command line (clap ids), set by the binary from
    /// its matches: the flags that win over `--profile`.
    #[arg(skip)]
    pub given: Vec<String>,
    /// Cost: 4.2 (first half of each file weighted ½) or 4.3 (first --skip samples skipped). Default: 4.3 for the coupled method, 4.2 for the isolated
    #[arg(long, value_enum)]
    #[arg(help_heading = "Output error: cost, integration and stopping")]
    pub cost: Option<CostArg>,
    /// Samples skipped at the start of each file under cost 4.3
    #[arg(long, default_value_t = 1000)]
    #[arg(help_heading = "Output error: cost, integration and stopping")]
    pub skip: usize,
    /// Weight of the joints of interest (the others 1; thesis 50)
    #[arg(value_parser = parse_positive, long, default_value_t = 50.0)]
    #[arg(help_heading = "Output error: cost, integration and stopping")]
    pub weight: f64,
    /// Integration step (s), e.g. 1/12000
    ///
    /// It must keep RK4 stable on the stiffest joint (a light link with strong friction damping); etdrk4 allows far larger steps there.
    #[arg(long, default_value = "1/12000", value_parser = parse_number)]
    #[arg(help_heading = "Output error: cost, integration and stopping")]
    pub step: f64,
    /// Integrator: rk4, or etdrk4 (exponential RK4, exact on the friction damping)
    #[arg(long, default_value = "rk4")]
    #[arg(help_heading = "Output error: cost, integration and stopping")]
    pub integrator: Integrator,
    /// Input between samples: zoh, linear, cubic or bandlimited (default: the side file's `hold`, else zoh)
    #[arg(long)]
    #[arg(help_heading = "Output error: cost, integration and stopping")]
    pub hold: Option<Hold>,
    /// Starts per step: the plant's values, then random points in the bounds (in parallel)
    #[arg(long, default_value_t = 1)]
    #[arg(help_heading = "Output error: cost, integration and stopping")]
    pub starts: usize,
    /// Seed of the random starts
    #[arg(long, default_value_t = 1)]
    #[arg(help_heading = "Output error: cost, integration and stopping")]
    pub seed: u64,
    /// Stop when the relative parameter step is below this (thesis 2e-6)
    #[arg(value_parser = parse_positive, long, default_value_t = 2e-6)]
    #[arg(help_heading = "Output error: cost, integration and stopping")]
    pub xtol: f64,
    /// Stop when the relative cost decrease is below this
    #[arg(value_parser = parse_positive, long, default_value_t = 1e-6)]
    #[arg(help_heading = "Output error: cost, integration and stopping")]
    pub ftol: f64,
    /// Most iterations per start and stage
    #[arg(long, default_value_t = 100)]
    #[arg(help_heading = "Output error: cost, integration and stopping")]
    pub max_iter: usize,
    /// Jacobian: sensitivities (one augmented simulation per file), differences (one simulation per file and parameter), or auto (sensitivities from 8 fitted values). Default: auto
    ///
    /// Where sensitivities are not available (the etdrk4 integrator, user-defined effects, backlash) differences are used.
    #[arg(long)]
    #[arg(help_heading = "Output error: cost, integration and stopping")]
    pub jacobian: Option<lockstep::identify::output_error::JacobianMethod>,
    /// Finite-difference Jacobian at most every N iterations, Broyden updates between. Default: 4 for the coupled method, 1 for the isolated
    ///
    /// A step that did not lower the cost, and the end of every stage, take a fresh one; both optimisers. 1: finite differences at every iteration.
    #[arg(long, value_name = "N")]
    #[arg(help_heading = "Output error: cost, integration and stopping")]
    pub jacobian_refresh: Option<usize>,
    /// Multiple-shooting warm-up: segment lengths (s) such as 1,4, or none
    ///
    /// One more start from the plant's values fits every file cut into segments of these lengths in turn (each from the measured state at its start), then the whole files; the lower cost wins.
    #[arg(long, default_value = "none")]
    #[arg(help_heading = "Output error: starts and warm-ups")]
    pub segments: String,
    /// Growing horizons: fractions of every file fitted in turn, ending with 1, or none. Default: none for the coupled method, 0.05,0.1,0.25,0.5,1 for the isolated
    ///
    /// Each horizon is simulated from the file's start and starts where the last ended. `none`: only the warm-ups (--equation-error, --predictor, --segments; one must be set).
    #[arg(long)]
    #[arg(help_heading = "Output error: starts and warm-ups")]
    pub horizons: Option<String>,
    /// After each step, move what it cannot tell apart (ties, gain scale) back toward the plant's values
    ///
    /// The rigid-body symbols along the ties with the base parameters held exactly, then the plant-gain scale to the point of that symmetry nearest the plant's values (gains and rigid-body symbols, held ties included, in units of their bounds' widths); each kept if the cost rises by less than one noise variance, so the next step starts from the prior, not from where the optimiser drifted.
    #[arg(long, value_enum, default_value = "on")]
    #[arg(help_heading = "Output error: the sequence and its refinements")]
    pub least_change: Switch,
    /// Gaussian prior about each step's start with relative spread TAU, such as 0.1, or none (maximum a posteriori)
    ///
    /// Weighed against each file's noise, it decides only where the data are silent (as MATLAB's regularisation toward the nominal model).
    #[arg(long, default_value = "none", value_name = "TAU")]
    #[arg(help_heading = "Output error: the sequence and its refinements")]
    pub prior: String,
    /// Hold the rigid-body symbols an earlier step left undetermined to that step's values and standard errors
    ///
    /// Each step records them in the plant it writes; overrides --prior for them.
    #[arg(long, value_enum, default_value = "off")]
    #[arg(help_heading = "Output error: the sequence and its refinements")]
    pub carried_prior: Switch,
    /// Where a step ends above the noise floor, refit the values earlier steps fixed that its data see better
    ///
    /// Under a Gaussian prior about their held values with their standard errors (the sequential estimate); kept when cost + prior term is lower.
    #[arg(long, value_enum, default_value = "on")]
    #[arg(help_heading = "Output error: the sequence and its refinements")]
    pub release_held: Switch,
    /// Where a step ends above the floor with a spanning symbol on a bound, widen that bound by what the held ties can carry
    ///
    /// The result is spread back over every symbol's own bounds and fitted there; kept when lower.
    #[arg(long, value_enum, default_value = "on")]
    #[arg(help_heading = "Output error: the sequence and its refinements")]
    pub tie_reach: Switch,
    /// Balanced refit: after a step with weighted joints of interest, the whole files once more with every joint weighted 1
    ///
    /// Kept when the worst free joint's RMS / σ̂ falls (the thesis's weight 50 lets a step leave a misfit on the other joints).
    #[arg(long, value_enum, default_value = "on")]
    #[arg(help_heading = "Output error: the sequence and its refinements")]
    pub balance: Switch,
    /// Where a step's horizons end above the noise floor, a second start through the warm-ups
    ///
    /// The coupled method's, from the same plant: the equation-error start, the prediction-error homotopy (ω = 100, 30, 10, 3, 1 rad/s at 1/2000 s), then the whole files at --step; the lower cost is kept. Steps whose options have warm-ups of their own do not run it.
    #[arg(long, value_enum, default_value = "on")]
    #[arg(help_heading = "Output error: the sequence and its refinements")]
    pub warm_up_start: Switch,
    /// Fit under the earlier steps' costs to second order. Default: off for the coupled method, on for the isolated
    ///
    /// A later step that refits a value an earlier one saw only in combination (a carried symbol) then keeps the combination: the earlier values its files do not see follow its moves, an earlier step whose files it still leaves off has those values refitted on them, and the gain families of joints earlier steps left apart are carried into a step that frees them together. The report lists what followed and what was refitted.
    #[arg(long, value_enum, value_name = "ON|OFF")]
    #[arg(help_heading = "Output error: the sequence and its refinements")]
    pub earlier_information: Option<Switch>,
    /// After the last step (each step under --earlier-information), refit the earlier steps whose files it left off
    ///
    /// An earlier step whose files end above 1.02 × its own figure has the values only its files see refitted on them; where the last step's files see every value it fitted, the two are fitted together on all their files (every free joint weighted 1). Kept where the worst joint falls; the report gives each step's figures before and after.
    #[arg(long, value_enum, default_value = "on", value_name = "ON|OFF")]
    #[arg(help_heading = "Output error: the sequence and its refinements")]
    pub earlier_refit: Switch,
    /// Equation-error warm start: on (filter cut-off per joint by residual analysis), off, or a cut-off fraction of Nyquist such as 0.2. Default: on for the coupled method, off for the isolated
    ///
    /// One more start fits the torque balance at every sample (positions low-passed and differentiated; no simulation, so no drift), then the whole files; the lower cost wins.
    #[arg(long, value_name = "on|off|CUTOFF")]
    #[arg(help_heading = "Output error: starts and warm-ups")]
    pub equation_error: Option<String>,
    /// Prediction-error homotopy: observer bandwidths ω (rad/s) fitted in turn, such as 3,1, or none. Default: 100,30,10,3,1 for the coupled method, none for the isolated
    ///
    /// Each stage simulates the files with a critically damped output injection of bandwidth ω (a Luenberger observer; ω → 0 is the output error). A stage that ends above twice the larger of the noise floor and the previous stage's end runs again at the geometric mean of the two bandwidths (twice at most).
    #[arg(long, value_name = "OMEGAS")]
    #[arg(help_heading = "Output error: starts and warm-ups")]
    pub predictor: Option<String>,
    /// Step (s) of the predictor's stages, simulated by ETDRK4, or none (--step). Default: 1/2000 for the coupled method, none for the isolated
    ///
    /// The Levenberg–Marquardt (--predictor-optimiser lm) can stall on the coarse step: pass none with it.
    #[arg(long, value_name = "STEP")]
    #[arg(help_heading = "Output error: starts and warm-ups")]
    pub predictor_step: Option<String>,
    /// Optimiser of the predictor's stages: lm (bounded Levenberg–Marquardt) or trf (trust-region-reflective)
    #[arg(long, value_enum, default_value = "trf")]
    #[arg(help_heading = "Output error: starts and warm-ups")]
    pub predictor_optimiser: OptimiserArg,
    /// Optimiser of the whole files' stage and of the release of held values: lm or trf. Default: trf for the coupled method, lm for the isolated
    ///
    /// The horizons', segments' and equation error's stages run lm.
    #[arg(long, value_enum)]
    #[arg(help_heading = "Output error: starts and warm-ups")]
    pub whole_files_optimiser: Option<OptimiserArg>,
    /// Initial positions of the free joints: estimate (as MATLAB's InitialCondition = 'estimate'), refit or the first measured sample. Default: estimate for the coupled method, refit for the isolated
    ///
    /// estimate: in every start's whole-files stage. refit: the starts compete on the measured samples, then the kept minimum, where at the noise floor, is fitted once more with them estimated (kept when the cost falls).
    #[arg(long, value_enum)]
    #[arg(help_heading = "Output error: starts and warm-ups")]
    pub initial_positions: Option<InitialPositionsArg>,
    /// Joint fit of every parameter the steps fit, on all their files at once: after the steps, only it, or off
    ///
    /// Each file in its configuration, every free joint weighted 1; its standard errors are those of all the data. It covers the steps up to --config's (all without it); their files must be in --data.
    #[arg(long, value_enum, default_value = "off")]
    #[arg(help_heading = "Output error: the sequence and its refinements")]
    pub joint_fit: JointFitArg,
    /// Position sensor noise σ (rad or m), such as 2e-4, or estimate (robust 5th differences of each file)
    ///
    /// Used for the noise-floor check, the prior's weight and the predictor step's check.
    #[arg(long, default_value = "estimate", value_name = "SIGMA|estimate")]
    #[arg(help_heading = "Output error: cost, integration and stopping")]
    pub noise_sigma: String,
    /// Largest motion (rad) allowed of a locked joint in a file
    #[arg(value_parser = parse_positive, long, default_value_t = 0.01)]
    #[arg(help_heading = "Output error: cost, integration and stopping")]
    pub locked_tolerance: f64,
    /// Rigid-body symbols each step fits: spanning (a set spanning its base parameters) or all
    ///
    /// `spanning` pivots on ∂β/∂s and holds the others for later steps; `all` fits every symbol the step identifies and leaves the ties to the least change.
    #[arg(long, value_enum, default_value = "spanning")]
    #[arg(help_heading = "Output error: the sequence and its refinements")]
    pub rigid_body: RigidBodyArg,
}

impl OutputErrorArgs {
    /// The output-error options of `preset` ([`OutputErrorOptions::isolated`],
    /// [`OutputErrorOptions::coupled`]) with the flags, then `--profile`'s fields but for
    /// those a given flag sets, then `--set`'s.
    ///
    /// # Errors
    /// A flag's value out of range; a profile or `--set` field that is not an option, or of
    /// the wrong type; a `--set` field a given flag also sets; nothing left to fit the
    /// plant's values.
    pub fn options(&self, preset: Preset) -> Result<OutputErrorOptions> {
        let mut o = self.options_from_flags(preset)?;
        let flag_of = |field: &str| {
            FIELD_FLAGS
                .iter()
                .filter(|(f, _)| *f == field)
                .flat_map(|(_, ids)| ids.iter())
                .find(|id| self.given.iter().any(|g| g == *id))
                .map(|id| format!("--{}", id.replace('_', "-")))
        };
        let mut origin = String::new();
        if let Some(path) = &self.profile {
            origin = path.display().to_string();
            let fields = profile_fields(path)?;
            o = with_fields(&o, &fields, &origin, &|f| flag_of(f).is_some())?;
        }
        for kv in &self.set {
            origin = format!("--set {kv}");
            let (k, v) = set_field(kv)?;
            if let Some(flag) = flag_of(&k) {
                bail!("--set {k}: {flag} sets it too; give one of them");
            }
            let fields = serde_json::Map::from_iter([(k, v)]);
            o = with_fields(&o, &fields, &origin, &|_| false)?;
        }
        if !origin.is_empty() && !o.fits_the_plant_values() {
            bail!(
                "{origin}: nothing would fit the plant's values (no horizons, equation error, predictor or segments)"
            );
        }
        Ok(o)
    }

    /// The method's preset with the flags (every flag: a default is the preset's value).
    fn options_from_flags(&self, preset: Preset) -> Result<OutputErrorOptions> {
        use lockstep::identify::output_error::TimeWeighting;
        let coupled = preset == Preset::Coupled;
        let mut o = preset.options();
        o.weighting = match (self.cost, o.weighting) {
            (Some(CostArg::HalfFirst), _) => TimeWeighting::HalfFirst,
            (Some(CostArg::SkipTransient), _) | (None, TimeWeighting::SkipTransient(_)) => {
                TimeWeighting::SkipTransient(self.skip)
            }
            (None, w) => w,
        };
        if self.starts == 0 || self.max_iter == 0 || self.jacobian_refresh == Some(0) {
            bail!("--starts, --max-iter and --jacobian-refresh must be at least 1");
        }
        o.interest_weight = self.weight;
        o.h = self.step;
        o.integrator = self.integrator;
        o.hold = self.hold;
        o.xtol = self.xtol;
        o.ftol = self.ftol;
        o.max_iter = self.max_iter;
        o.starts = self.starts;
        o.seed = self.seed;
        if let Some(n) = self.jacobian_refresh {
            o.jacobian_refresh = n;
        }
        if let Some(j) = self.jacobian {
            o.jacobian = j;
        }
        if let Some(h) = &self.horizons {
            let horizons = positive_list(
                "--horizons",
                h,
                "increasing fractions in (0, 1] ending with 1 such as 0.1,0.5,1",
            )?;
            if !horizons.is_empty()
                && (horizons.last() != Some(&1.0)
                    || horizons.iter().any(|&h| h > 1.0)
                    || horizons.windows(2).any(|w| w[0] >= w[1]))
            {
                bail!(
                    "--horizons: expected 'none' or increasing fractions in (0, 1] ending with 1, got '{h}'"
                );
            }
            o.horizons = horizons;
        }
        o.segments = positive_list(
            "--segments",
            &self.segments,
            "lengths in seconds such as 1,4",
        )?;
        if let Some(p) = &self.predictor {
            o.predictor = positive_list("--predictor", p, "bandwidths in rad/s such as 3,1")?;
        }
        o.least_change = self.least_change.on();
        o.prior = match self.prior.trim() {
            "none" => None,
            x => match x.parse::<f64>() {
                Ok(t) if t > 0.0 && t.is_finite() => Some(t),
                _ => bail!(
                    "--prior: expected 'none' or a positive relative spread such as 0.1, got '{x}'"
                ),
            },
        };
        o.carried_prior = self.carried_prior.on();
        if let Some(e) = &self.equation_error {
            o.equation_error = match e.trim() {
                "off" | "none" => None,
                "on" => Some(Cutoff::Residual),
                x => match x.parse::<f64>() {
                    Ok(c) if c > 0.0 && c < 1.0 => Some(Cutoff::Fixed(c)),
                    _ => bail!("--equation-error: expected on, off or a filter cut-off in (0, 1) of the Nyquist frequency such as 0.2, got '{x}'"),
                },
            };
        }
        if let Some(p) = &self.predictor_step {
            o.predictor_step = match p.trim() {
                "none" => None,
                x => match parse_number(x) {
                    Ok(h) if h > 0.0 && h.is_finite() => Some((h, Integrator::Etdrk4)),
                    _ => bail!("--predictor-step: expected 'none' or a positive step in seconds such as 1/2000, got '{x}'"),
                },
            };
        }
        o.predictor_optimiser = self.predictor_optimiser.into();
        if let Some(w) = self.whole_files_optimiser {
            o.whole_files_optimiser = w.into();
        }
        if let Some(i) = self.initial_positions {
            o.estimate_initial_positions = i == InitialPositionsArg::Estimate;
        }
        o.noise_sigma = match self.noise_sigma.trim() {
            "estimate" => None,
            x => match parse_number(x) {
                Ok(s) if s > 0.0 && s.is_finite() => Some(s),
                _ => bail!("--noise-sigma: expected 'estimate' or the sensor's positive noise σ such as 2e-4, got '{x}'"),
            },
        };
        if !o.fits_the_plant_values() {
            bail!(
                "--horizons none{}: nothing would fit the plant's values; set --equation-error, --predictor or --segments, or give horizons such as 1",
                if coupled && self.horizons.is_none() { " (the coupled method's default)" } else { "" }
            );
        }
        Ok(o)
    }

    /// The sequence options of `preset` ([`SequenceOptions::preset`]) with the options
    /// given on the command line.
    pub fn sequence_options(
        &self,
        preset: Preset,
        only: Option<String>,
        out: PathBuf,
    ) -> Result<SequenceOptions> {
        let mut opts = SequenceOptions::preset(preset.name(), out);
        opts.only = only;
        opts.fit = self.options(preset)?;
        opts.locked_tolerance = self.locked_tolerance;
        opts.resume = self.resume;
        opts.rigid_body = match self.rigid_body {
            RigidBodyArg::Spanning => RigidBodyFit::Spanning,
            RigidBodyArg::All => RigidBodyFit::All,
        };
        opts.joint = match self.joint_fit {
            JointFitArg::Off => JointFitMode::Off,
            JointFitArg::After => JointFitMode::After,
            JointFitArg::Only => JointFitMode::Only,
        };
        opts.release_held = self.release_held.on();
        opts.tie_reach = self.tie_reach.on();
        opts.balance = self.balance.on();
        opts.warm_up_start = self.warm_up_start.on();
        if let Some(e) = self.earlier_information {
            opts.earlier_information = e.on();
        }
        opts.earlier_refit = self.earlier_refit.on();
        if let Some(i) = self.initial_positions {
            opts.initial_positions_refit = i == InitialPositionsArg::Refit;
        }
        Ok(opts)
    }
}

/// On or off.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Switch {
    /// On.
    On,
    /// Off.
    Off,
}

impl Switch {
    pub fn on(self) -> bool {
        self == Switch::On
    }
}

/// `identify sequence --preset`: the method whose locking sequence and defaults a run
/// takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Preset {
    /// The method of isolated joints (thesis 4.3.1).
    Isolated,
    /// The method of coupling joints (thesis 4.3.2).
    Coupled,
}

impl Preset {
    /// The output-error options of the preset's sequence
    /// ([`OutputErrorOptions::for_sequence`]).
    pub fn options(self) -> OutputErrorOptions {
        OutputErrorOptions::for_sequence(self.name())
    }

    /// The name of the preset, and of its sequence in the model file.
    pub fn name(self) -> &'static str {
        match self {
            Preset::Isolated => "isolated",
            Preset::Coupled => "coupled",
        }
    }
}

/// `--cost`: the thesis's output-error costs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum CostArg {
    /// (4.2): the first half of each file weighted ½.
    #[value(name = "4.2")]
    HalfFirst,
    /// (4.3): the first --skip samples of each file left out.
    #[value(name = "4.3")]
    SkipTransient,
}

/// `--initial-positions`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum InitialPositionsArg {
    /// Estimated with the parameters at every start's whole files' stage.
    Estimate,
    /// The first measured sample while the starts compete, then estimated in a refit of
    /// the kept minimum.
    Refit,
    /// The first measured sample of each file.
    Measured,
}

/// `--rigid-body`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum RigidBodyArg {
    /// A set of symbols that spans the configuration's base parameters.
    Spanning,
    /// Every symbol the step identifies or carries.
    All,
}

/// `--joint-fit`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum JointFitArg {
    /// No joint fit.
    Off,
    /// A joint fit after the step-by-step fits.
    After,
    /// The joint fit instead of the step-by-step fits.
    Only,
}

/// A comma-separated list of positive numbers for `flag`, or `none` (empty list).
pub fn positive_list(flag: &str, value: &str, what: &str) -> Result<Vec<f64>> {
    match value.trim() {
        "" | "none" => Ok(Vec::new()),
        list => list
            .split(',')
            .map(|x| match x.trim().parse::<f64>() {
                Ok(v) if v > 0.0 && v.is_finite() => Ok(v),
                _ => Err(anyhow::anyhow!(
                    "{flag}: expected 'none' or positive {what}, got '{x}'"
                )),
            })
            .collect(),
    }
}

/// `identify idim`: IDIM-LS on the base parameters; the fitted plant written to `out` if
/// given.
pub fn identify_idim(
    common: &Common,
    out: Option<PathBuf>,
    allow_inconsistent: bool,
    weighting: WeightingArg,
    consistent: bool,
) -> Result<()> {
    let config = common.config.as_deref().unwrap_or("full");
    if let Some(out) = &out {
        lockstep::files::check_writable(&[out])?;
    }
    let (plant, records, opts) = common.load()?;
    // A rank-deficient regressor (every serial arm's) is fitted on its base parameters,
    // grouped at the records' locked positions; the dependent ones keep the plant's values.
    // A spring's rest angle or a Stribeck speed is fitted around that by variable projection.
    let conf = lockstep::util::configuration(plant.model, config)?;
    let locked_at = lockstep::identify::idim::locked_positions(&records);
    let sigma_of = std::sync::Mutex::new(Vec::new());
    let random =
        lockstep::identify::idim::random_motion_observation(&plant, config, &locked_at, &opts)?;
    let linear = |p: &Plant, obs: &lockstep::identify::idim::Observation| {
        let (fit, sigma) = lockstep::identify::idim::base_fit_with(
            p,
            obs,
            config,
            &locked_at,
            weighting.into(),
            &random,
        )?;
        *sigma_of.lock().unwrap_or_else(|e| e.into_inner()) = sigma;
        Ok(fit)
    };
    let separable =
        lockstep::identify::idim::separable_fit(&plant, config, &records, &opts, &linear)?;
    let (obs, fit, mut plant) = (separable.observation, separable.fit, separable.plant);
    let sigma = sigma_of.into_inner().unwrap_or_default();
    lockstep::outln!(
        "{}, plant {}, configuration {}, {} record(s)",
        if sigma.is_empty() {
            "IDIM-LS"
        } else {
            "IDIM-WLS"
        },
        common.files.plant.display(),
        config,
        records.len()
    );
    for (j, s) in &sigma {
        lockstep::outln!(
            "  rows of {} weighted by 1/σ, σ = {s:.4e} (the residual of the ordinary fit)",
            plant.model.joints[*j]
        );
    }
    lockstep::out!("{}", fit_table(&fit));
    for (n, v) in &separable.nonlinear {
        lockstep::outln!(
            "{n:<16} {v:>11.6}   (nonlinear: variable projection around the least squares)"
        );
    }
    for e in plant
        .effects
        .iter()
        .filter(|e| conf.free.contains(&e.joint))
    {
        for sym in e.kind.undetermined_in_torque_space() {
            let n = e.parameter_name(sym, plant.model.joints);
            if let Ok(v) = plant.value(&n) {
                lockstep::outln!(
                    "{n:<16} {v:>11.6}   (kept: not determined in torque space; the presliding \
                     transients do not show in the steady-state curve)"
                );
            }
        }
    }
    let consistent_set = if consistent {
        let c = lockstep::identify::consistent::consistent_parameters(
            &obs,
            &plant,
            &fit,
            &Default::default(),
        )?;
        lockstep::out!("{}", consistent_table(&c));
        Some(c)
    } else {
        None
    };
    if let Some(out) = out {
        match &consistent_set {
            Some(c) => c.apply(&mut plant)?,
            None => fit.apply(&mut plant)?,
        }
        let reasons = lockstep::identify::idim::implausible(&plant, conf)?;
        if !reasons.is_empty() {
            if !allow_inconsistent {
                bail!(
                    "{} not written: the fitted values are not a physical body: {} (check the data for spikes and the filter cut-off; --allow-inconsistent writes them anyway)",
                    out.display(),
                    reasons.join("; ")
                );
            }
            for r in &reasons {
                lockstep::errln!("warning: {r}");
            }
        }
        plant.save(&out)?;
        lockstep::outln!("wrote {}", out.display());
    }
    Ok(())
}

/// `identify sequence`: output-error identification along a locking sequence, with a
/// progress line.
pub fn identify_sequence(args: &SequenceArgs) -> Result<()> {
    let (out, oe) = (args.out.clone(), &args.oe);
    let mut plant = Plant::load(&args.files.plant)?;
    if oe.resume {
        let current = lockstep::identify::sequence::resume_plant(&out)?;
        if current.model.name != plant.model.name {
            bail!(
                "--resume: {} is a plant of model '{}', --plant of '{}'",
                out.join("plant.toml").display(),
                current.model.name,
                plant.model.name
            );
        }
        lockstep::errln!(
            "resuming from {} (the plant of the last completed step)",
            out.join("plant.toml").display()
        );
        plant = current;
    }
    let opts = oe.sequence_options(args.preset, args.config.clone(), out)?;
    let bar = indicatif::ProgressBar::new_spinner();
    bar.enable_steady_tick(std::time::Duration::from_millis(250));
    // Without a terminal (logs, CI) one line per iteration instead of a spinner.
    let plain = bar.is_hidden();
    let last = std::sync::Mutex::new((String::new(), usize::MAX));
    let report = lockstep::identify::sequence::run(&plant, &args.files.data, &opts, &|step, p| {
        let msg = format!(
            "{step} · start {}/{} · {} · iteration {} · {} evaluations · cost {:.4e} · {:.0} s",
            p.start + 1,
            p.starts,
            p.stage,
            p.iteration,
            p.evaluations,
            p.cost,
            p.elapsed
        );
        if plain {
            let mut l = last.lock().unwrap_or_else(|e| e.into_inner());
            if l.0 != step || l.1 != p.iteration {
                *l = (step.to_string(), p.iteration);
                lockstep::errln!("{msg}");
            }
        } else {
            bar.set_message(msg);
        }
    });
    bar.finish_and_clear();
    let report = report?;
    for i in &report.ignored {
        lockstep::errln!("note: not used: {i}");
    }
    for n in &report.data_notes {
        lockstep::errln!("note: {n}");
    }
    lockstep::outln!(
        "{:<6} {:>6} {:>12} {:>12} {:>9} {:>8} {:>6}  fit % per joint",
        "step",
        "params",
        "cost before",
        "cost after",
        "wall s",
        "evals",
        "ident."
    );
    for s in report.steps.iter().chain(&report.joint) {
        let f = &s.fit;
        lockstep::outln!(
            "{:<6} {:>6} {:>12.4e} {:>12.4e} {:>9.1} {:>8} {:>6}  {}",
            s.step.config,
            f.names.len(),
            f.cost_before,
            f.cost_after,
            f.wall_s,
            f.evaluations,
            f.statistics.identifiable.iter().filter(|&&x| x).count(),
            f.statistics
                .joints
                .iter()
                .map(|j| format!("{} {:.2}", j.joint, j.nrmse_fit))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    for s in report.steps.iter().chain(&report.joint) {
        if s.fit.evaluations == 0 {
            lockstep::errln!(
                "warning: step {}: no fit was made (the plant's values are kept); {} says why",
                s.step.config,
                opts.out.join("report.md").display()
            );
        }
        for line in &s.impossible {
            lockstep::errln!(
                "warning: step {}: physically impossible: {line}",
                s.step.config
            );
        }
    }
    lockstep::outln!(
        "wrote {}, {} and {}",
        opts.out.join("plant.toml").display(),
        opts.out.join("report.md").display(),
        opts.out.join("report.json").display()
    );
    Ok(())
}

/// A stage optimiser on the command line ([`StageOptimiser`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum OptimiserArg {
    /// Bounded Levenberg–Marquardt (rmpfit).
    Lm,
    /// Trust-region-reflective (basin).
    Trf,
}

impl From<OptimiserArg> for StageOptimiser {
    fn from(a: OptimiserArg) -> Self {
        match a {
            OptimiserArg::Lm => StageOptimiser::LevenbergMarquardt,
            OptimiserArg::Trf => StageOptimiser::TrustRegionReflective,
        }
    }
}

/// Where clap refused an unknown option `--x` in `lockstep identify M` that another
/// method's subcommand takes: the message naming the subcommand it belongs to (a flag that
/// would be ignored is an error, and the user learns where it goes). `args` is the command
/// line; None for any other error.
pub fn misplaced_option(error: &clap::Error, args: &[String]) -> Option<String> {
    use clap::error::{ContextKind, ContextValue, ErrorKind};
    if error.kind() != ErrorKind::UnknownArgument {
        return None;
    }
    let Some(ContextValue::String(given)) = error.get(ContextKind::InvalidArg) else {
        return None;
    };
    let flag = given.split('=').next()?.trim_start_matches('-');
    let at = args.iter().position(|a| a == "identify")?;
    let used = args.get(at + 1)?;
    let cli = <Cli as clap::CommandFactory>::command();
    let identify = cli.find_subcommand("identify")?;
    // Only after a method's subcommand; without one clap's message lists them.
    identify.find_subcommand(used)?;
    let owner = identify.get_subcommands().find(|sub| {
        sub.get_name() != used && sub.get_arguments().any(|a| a.get_long() == Some(flag))
    })?;
    let what = match owner.get_name() {
        "idim" => "IDIM-LS, on torque measurements",
        _ => "output error, on position measurements",
    };
    Some(format!(
        "--{flag} is an option of `lockstep identify {}` ({what}); `lockstep identify {used}` does not take it",
        owner.get_name()
    ))
}

/// The `identify sequence` options given on the command line (clap ids); empty for other
/// commands.
pub fn given_identify_options(matches: &ArgMatches) -> Vec<String> {
    let Some(("identify", identify)) = matches.subcommand() else {
        return Vec::new();
    };
    let Some(("sequence", sub)) = identify.subcommand() else {
        return Vec::new();
    };
    sub.ids()
        .filter(|id| sub.value_source(id.as_str()) == Some(clap::parser::ValueSource::CommandLine))
        .map(|id| id.to_string())
        .collect()
}

/// The consistent set's report: torque errors, the links made consistent, the values that
/// moved furthest from the plant's (relative to their size).
fn consistent_table(c: &lockstep::identify::consistent::ConsistentFit) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    writeln!(
        s,
        "physically consistent set ({} iterations): torque error {:.3} % (least squares {:.3} %); links {}",
        c.iterations,
        c.consistent_error,
        c.unconstrained_error,
        c.links.join(", ")
    )
    .ok();
    for k in &c.skipped {
        writeln!(s, "  {k}").ok();
    }
    // The rigid body's values (effects start from the plant's, often none).
    let rigid = |n: &str| {
        c.links
            .iter()
            .any(|l| n.ends_with(&format!("_{l}")) || n == format!("m_{l}"))
    };
    let mut moved: Vec<(usize, f64)> = (0..c.names.len())
        .filter(|&i| rigid(&c.names[i]))
        .map(|i| {
            let d = (c.theta[i] - c.prior[i]).abs() / c.prior[i].abs().max(1e-9);
            (i, d)
        })
        .collect();
    moved.sort_by(|a, b| b.1.total_cmp(&a.1));
    writeln!(
        s,
        "  rigid-body values furthest from the plant's (relative):"
    )
    .ok();
    writeln!(
        s,
        "  {:<16} {:>12} {:>12}",
        "parameter", "plant", "consistent"
    )
    .ok();
    for &(i, _) in moved.iter().take(10) {
        writeln!(
            s,
            "  {:<16} {:>12.6} {:>12.6}",
            c.names[i], c.prior[i], c.theta[i]
        )
        .ok();
    }
    s
}

#[cfg(test)]
mod method_tests {
    use super::*;
    use clap::{CommandFactory, FromArgMatches};

    /// `lockstep identify sequence --preset PRESET --plant p --data d ARGS`.
    fn sequence_line(preset: &str, args: &[&str]) -> Vec<String> {
        [
            &[
                "lockstep", "identify", "sequence", "--preset", preset, "--plant", "p", "--data",
                "d",
            ][..],
            args,
        ]
        .concat()
        .into_iter()
        .map(String::from)
        .collect()
    }

    /// The sequence arguments of `sequence_line(preset, args)`, with the given flags set as
    /// the binary sets them.
    fn sequence(preset: &str, args: &[&str]) -> SequenceArgs {
        let m = Cli::command()
            .try_get_matches_from(sequence_line(preset, args))
            .unwrap();
        let cli = Cli::from_arg_matches(&m).unwrap();
        let Command::Identify {
            method: IdentifyMethod::Sequence(mut a),
        } = cli.command
        else {
            unreachable!()
        };
        a.oe.given = given_identify_options(&m);
        *a
    }

    #[test]
    fn the_cli_builds_its_options_from_the_presets() {
        for name in ["coupled", "isolated"] {
            let a = sequence(name, &[]);
            let built =
                a.oe.sequence_options(a.preset, None, PathBuf::from("out"))
                    .unwrap();
            let preset = SequenceOptions::preset(name, PathBuf::from("out"));
            assert_eq!(format!("{built:?}"), format!("{preset:?}"), "{name}");
        }
        // The presets differ where the methods do.
        let (c, i) = (
            OutputErrorOptions::coupled(),
            OutputErrorOptions::isolated(),
        );
        assert!(c.horizons.is_empty() && !i.horizons.is_empty());
        assert!(c.equation_error.is_some() && i.equation_error.is_none());
        // A flag changes only its field.
        let a = sequence("coupled", &["--horizons", "1"]);
        let o = a.oe.options(a.preset).unwrap();
        assert_eq!(o.horizons, vec![1.0]);
        assert_eq!(format!("{:?}", o.predictor), format!("{:?}", c.predictor));
    }

    /// `identify sequence --help` fits on two screens (100 lines of 100 columns).
    #[test]
    fn the_sequence_help_fits_on_two_screens() {
        let mut cmd = Cli::command();
        let help = cmd
            .find_subcommand_mut("identify")
            .and_then(|c| c.find_subcommand_mut("sequence"))
            .unwrap()
            .render_help()
            .to_string();
        let rows: usize = help
            .lines()
            .map(|l| l.chars().count().div_ceil(100).max(1))
            .sum();
        assert!(rows <= 110, "{rows} rows:\n{help}");
        assert!(help.contains("--help-long"));
    }

    /// The per-method defaults the help states are the presets' values.
    #[test]
    fn the_help_states_the_presets_defaults() {
        let mut cmd = Cli::command();
        let help = cmd
            .find_subcommand_mut("identify")
            .and_then(|c| c.find_subcommand_mut("sequence"))
            .unwrap()
            .render_long_help()
            .to_string();
        let help = help.split_whitespace().collect::<Vec<_>>().join(" ");
        let (c, i) = (
            OutputErrorOptions::coupled(),
            OutputErrorOptions::isolated(),
        );
        let list = |v: &[f64]| {
            if v.is_empty() {
                "none".to_string()
            } else {
                v.iter()
                    .map(|x| x.to_string())
                    .collect::<Vec<_>>()
                    .join(",")
            }
        };
        let on = |b: bool| if b { "on" } else { "off" };
        let step = |s: Option<(f64, Integrator)>| match s {
            Some((h, _)) => format!("1/{}", (1.0 / h).round()),
            None => "none".into(),
        };
        let optimiser = |o: StageOptimiser| match o {
            StageOptimiser::LevenbergMarquardt => "lm",
            StageOptimiser::TrustRegionReflective => "trf",
        };
        let refit = SequenceOptions::preset("isolated", PathBuf::new()).initial_positions_refit;
        let initial = |e: bool| match (e, refit) {
            (true, _) => "estimate",
            (false, true) => "refit",
            (false, false) => "measured",
        };
        for stated in [
            format!(
                "Default: {} for the coupled method, {} for the isolated",
                c.jacobian_refresh, i.jacobian_refresh
            ),
            format!(
                "Default: {} for the coupled method, {} for the isolated",
                list(&c.horizons),
                list(&i.horizons)
            ),
            format!(
                "Default: {} for the coupled method, {} for the isolated",
                on(c.equation_error.is_some()),
                on(i.equation_error.is_some())
            ),
            format!(
                "Default: {} for the coupled method, {} for the isolated",
                list(&c.predictor),
                list(&i.predictor)
            ),
            format!(
                "Default: {} for the coupled method, {} for the isolated",
                step(c.predictor_step),
                step(i.predictor_step)
            ),
            if c.estimate_initial_positions == i.estimate_initial_positions {
                format!(
                    "the first measured sample. Default: {}",
                    initial(c.estimate_initial_positions)
                )
            } else {
                format!(
                    "Default: {} for the coupled method, {} for the isolated",
                    initial(c.estimate_initial_positions),
                    initial(i.estimate_initial_positions)
                )
            },
            format!(
                "Default: {} for the coupled method, {} for the isolated",
                on(SequenceOptions::preset("coupled", PathBuf::new()).earlier_information),
                on(SequenceOptions::preset("isolated", PathBuf::new()).earlier_information)
            ),
            if c.jacobian == i.jacobian {
                format!(
                    "or auto (sensitivities from {} fitted values). Default: {}",
                    lockstep::identify::output_error::SENSITIVITIES_FROM,
                    c.jacobian
                )
            } else {
                format!(
                    "or auto (sensitivities from {} fitted values). Default: {} for the coupled method, {} for the isolated",
                    lockstep::identify::output_error::SENSITIVITIES_FROM,
                    c.jacobian,
                    i.jacobian
                )
            },
            format!(
                "lm or trf. Default: {} for the coupled method, {} for the isolated",
                optimiser(c.whole_files_optimiser),
                optimiser(i.whole_files_optimiser)
            ),
        ] {
            assert!(help.contains(&stated), "not in identify --help: {stated}");
        }
    }

    /// A profile sets fields on the preset, a flag given on the command line wins over it,
    /// a report.json replays its recorded options, and a field that is not an option is
    /// refused naming the file and the field.
    #[test]
    fn a_profile_sets_the_presets_fields_and_a_given_flag_wins() {
        let d = tempfile::tempdir().unwrap();
        let profile = d.path().join("identify.toml");
        std::fs::write(
            &profile,
            "h = 1e-4\nhorizons = [0.5, 1.0]\nmax_speed = 300.0\n",
        )
        .unwrap();
        let p = profile.to_str().unwrap();
        let parse = |args: &[&str]| {
            let (preset, rest) = args.split_first().unwrap();
            let a = sequence(preset, rest);
            a.oe.options(a.preset)
        };
        let o = parse(&["coupled", "--profile", p]).unwrap();
        assert_eq!((o.h, o.max_speed), (1e-4, Some(300.0)));
        assert_eq!(o.horizons, vec![0.5, 1.0]);
        assert_eq!(o.predictor, OutputErrorOptions::coupled().predictor);
        let o = parse(&["coupled", "--profile", p, "--horizons", "1"]).unwrap();
        assert_eq!((o.h, o.horizons.clone()), (1e-4, vec![1.0]));
        // A report's recorded options replay the run.
        let report = d.path().join("report.json");
        let mut recorded = OutputErrorOptions::isolated();
        recorded.seed = 42;
        recorded.prior = Some(0.2);
        recorded.hold = Some(lockstep::simulation::Hold::Linear);
        std::fs::write(
            &report,
            serde_json::json!({ "sequence": "isolated", "options": recorded }).to_string(),
        )
        .unwrap();
        let o = parse(&["isolated", "--profile", report.to_str().unwrap()]).unwrap();
        assert_eq!(format!("{o:?}"), format!("{recorded:?}"));
        std::fs::write(&profile, "step = 1e-4\n").unwrap();
        let e = parse(&["coupled", "--profile", p]).unwrap_err().to_string();
        assert!(e.contains("identify.toml") && e.contains("'step'"), "{e}");
        // --set: after the profile; TOML values; a field a given flag sets is refused.
        std::fs::write(&profile, "h = 1e-4\nmax_speed = 300.0\n").unwrap();
        let o = parse(&[
            "coupled",
            "--profile",
            p,
            "--set",
            "max_speed=250",
            "--set",
            "horizons=[0.5, 1]",
            "--set",
            "integrator=etdrk4",
        ])
        .unwrap();
        assert_eq!((o.h, o.max_speed), (1e-4, Some(250.0)));
        assert_eq!(o.horizons, vec![0.5, 1.0]);
        assert_eq!(o.integrator, Integrator::Etdrk4);
        let e = parse(&["coupled", "--step", "1e-4", "--set", "h=2e-4"])
            .unwrap_err()
            .to_string();
        assert!(e.contains("--set h") && e.contains("--step"), "{e}");
        let e = parse(&["coupled", "--set", "speed=3"])
            .unwrap_err()
            .to_string();
        assert!(e.contains("--set") && e.contains("'speed'"), "{e}");
        let e = parse(&["coupled", "--set", "max_speed"])
            .unwrap_err()
            .to_string();
        assert!(e.contains("FIELD=VALUE"), "{e}");
        let e = parse(&["coupled", "--set", "integrator=Euler"])
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("--set integrator=Euler") && e.contains("rk4"),
            "{e}"
        );
    }

    #[test]
    fn an_option_of_another_method_is_refused_naming_its_subcommand() {
        let refused = |args: &[&str]| {
            let args: Vec<String> = args.iter().map(|a| a.to_string()).collect();
            match Cli::command().try_get_matches_from(&args) {
                Ok(_) => None,
                Err(e) => Some(misplaced_option(&e, &args).unwrap_or_else(|| e.to_string())),
            }
        };
        let idim = [
            "lockstep", "identify", "idim", "--plant", "p", "--data", "d",
        ];
        let e = refused(&[&idim[..], &["--horizons", "1"]].concat()).unwrap();
        assert!(
            e.contains("--horizons") && e.contains("`lockstep identify sequence`"),
            "{e}"
        );
        let line = sequence_line("coupled", &["--cutoff", "5"]);
        let line: Vec<&str> = line.iter().map(String::as_str).collect();
        let e = refused(&line).unwrap();
        assert!(
            e.contains("--cutoff") && e.contains("`lockstep identify idim`"),
            "{e}"
        );
        assert!(refused(&[&idim[..], &["--cutoff", "5"]].concat()).is_none());
        let line = sequence_line("coupled", &["--horizons", "1"]);
        let line: Vec<&str> = line.iter().map(String::as_str).collect();
        assert!(refused(&line).is_none());
        // An option no method takes: clap's own message.
        let e = refused(&[&idim[..], &["--speed", "1"]].concat()).unwrap();
        assert!(e.contains("unexpected argument '--speed'"), "{e}");
        // No method given (the old `identify --plant …`): clap's own message, which lists
        // the subcommands, not one naming `--plant` as a method.
        let e = refused(&["lockstep", "identify", "--plant", "p", "--data", "d"]).unwrap();
        assert!(!e.contains("lockstep identify --plant"), "{e}");
    }
}
