//! `identify --method isolated|coupled`: the output-error options on the command line, built
//! on the presets of the library ([`OutputErrorOptions::isolated`],
//! [`OutputErrorOptions::coupled`], [`SequenceOptions::preset`]).

use super::*;
/// Settings of output-error identification (`identify --method isolated|coupled`).
#[derive(Debug, Args)]
pub struct OutputErrorArgs {
    /// Continue an interrupted sequence in --out from its last completed step: start from
    /// --out's plant.toml, skip the steps its report lists, add the rest to that report.
    #[arg(long)]
    #[arg(help_heading = "Output error: the sequence and its refinements")]
    pub resume: bool,
    /// Output-error options from a file, applied to the method's preset before the flags
    /// (a flag given on the command line wins): a TOML table of the options' fields
    /// (e.g. `h = 8.333e-5`, `horizons = [0.1, 1.0]`, `max_speed = 300.0`), or the
    /// `report.json` of an earlier run, whose recorded options replay it.
    #[arg(long, value_name = "FILE")]
    #[arg(help_heading = "Output error: the sequence and its refinements")]
    pub profile: Option<PathBuf>,
    /// The identify options given on the command line (clap ids), set by the binary from
    /// its matches: the flags that win over `--profile`.
    #[arg(skip)]
    pub given: Vec<String>,
    /// Cost: 4.2 (first half of each file weighted 1/2; isolated default) or 4.3 (skip the
    /// first --skip samples; coupled default).
    #[arg(long, value_enum)]
    #[arg(help_heading = "Output error: cost, integration and stopping")]
    pub cost: Option<CostArg>,
    /// Samples skipped at the start of each file under cost 4.3.
    #[arg(long, default_value_t = 1000)]
    #[arg(help_heading = "Output error: cost, integration and stopping")]
    pub skip: usize,
    /// Joint weight of the joint(s) of interest (others 1).
    #[arg(value_parser = parse_positive, long, default_value_t = 50.0)]
    #[arg(help_heading = "Output error: cost, integration and stopping")]
    pub weight: f64,
    /// Integration step (s); fractions such as 1/12000 accepted. The step must keep RK4
    /// stable on the stiffest joint (a light link with strong friction damping).
    #[arg(long, default_value = "1/12000", value_parser = parse_number)]
    #[arg(help_heading = "Output error: cost, integration and stopping")]
    pub step: f64,
    /// Integrator, rk4 or etdrk4 (exponential RK4 that takes the friction damping exactly,
    /// stable at far larger steps on a stiff joint).
    #[arg(long, default_value = "rk4")]
    #[arg(help_heading = "Output error: cost, integration and stopping")]
    pub integrator: Integrator,
    /// How the torques were applied between samples: zoh, linear, cubic or bandlimited
    /// (default: each file's side file's `hold`, else zoh).
    #[arg(long)]
    #[arg(help_heading = "Output error: cost, integration and stopping")]
    pub hold: Option<Hold>,
    /// Starts per step: the plant's values, then random points inside the bounds (run in
    /// parallel).
    #[arg(long, default_value_t = 1)]
    #[arg(help_heading = "Output error: cost, integration and stopping")]
    pub starts: usize,
    /// Seed of the random starts.
    #[arg(long, default_value_t = 1)]
    #[arg(help_heading = "Output error: cost, integration and stopping")]
    pub seed: u64,
    /// Stop when the relative parameter step is below this (thesis 2e-6).
    #[arg(value_parser = parse_positive, long, default_value_t = 2e-6)]
    #[arg(help_heading = "Output error: cost, integration and stopping")]
    pub xtol: f64,
    /// Stop when the relative cost decrease is below this.
    #[arg(value_parser = parse_positive, long, default_value_t = 1e-6)]
    #[arg(help_heading = "Output error: cost, integration and stopping")]
    pub ftol: f64,
    /// Most iterations per start.
    #[arg(long, default_value_t = 100)]
    #[arg(help_heading = "Output error: cost, integration and stopping")]
    pub max_iter: usize,
    /// A finite-difference Jacobian (one simulation per fitted parameter) at most every N
    /// iterations of a stage, Broyden's rank-one update from the step taken between them;
    /// a step that did not lower the cost, and the end of every stage, take a fresh one.
    /// Both optimisers (--predictor-optimiser, --whole-files-optimiser). 1: finite
    /// differences at every iteration. Default: 4 for the coupled method, 1 for the
    /// isolated.
    #[arg(long, value_name = "N")]
    #[arg(help_heading = "Output error: cost, integration and stopping")]
    pub jacobian_refresh: Option<usize>,
    /// Multiple-shooting warm-up, e.g. `--segments 1,4`: one more start from the plant's
    /// values fits every file cut into segments of these lengths (s) in turn, each segment
    /// simulated from the measured state at its start (velocities from the positions), then
    /// the whole files; it runs beside the start through the horizons and the lower cost
    /// wins. `none`: only the horizons.
    #[arg(long, default_value = "none")]
    #[arg(help_heading = "Output error: starts and warm-ups")]
    pub segments: String,
    /// Growing horizons: fit on these fractions of every file in turn (after the skipped
    /// transient), each simulated from the file's start and starting where the last stage
    /// ended; the last must be 1 (`--horizons 1`: the whole files at once). `none`: no
    /// start from the plant's values through the horizons, only the warm-ups
    /// (`--equation-error`, `--predictor`, `--segments`; one must be set). Default: none for
    /// the coupled method, 0.05,0.1,0.25,0.5,1 for the isolated.
    #[arg(long)]
    #[arg(help_heading = "Output error: starts and warm-ups")]
    pub horizons: Option<String>,
    /// After each step's fit, move the rigid-body symbols back toward the plant's initial
    /// values along the combinations that step cannot tell apart (its base parameters held
    /// exactly; kept if the cost rises by less than one noise variance): the least-change
    /// solution, so the next step starts from the prior, not from where the optimiser
    /// drifted along an exact tie. `off`: keep the minimum as found.
    #[arg(long, value_enum, default_value = "on")]
    #[arg(help_heading = "Output error: the sequence and its refinements")]
    pub least_change: Switch,
    /// Prior on each step's fitted parameters (maximum a posteriori, as MATLAB's
    /// regularisation toward the nominal model): Gaussian about the values the step starts
    /// from, with spread TAU × each value (× the bound width for a value near zero; 0.1:
    /// the initial values are good to about 10 %), weighed against the noise
    /// each file shows (estimated from its positions). It decides only where the data are
    /// silent or nearly so, so a step does not hand an arbitrary point of a flat valley to
    /// the next. `none`: the thesis cost alone.
    #[arg(long, default_value = "none", value_name = "TAU")]
    #[arg(help_heading = "Output error: the sequence and its refinements")]
    pub prior: String,
    /// Sequential prior on carried symbols: each step records, in the plant it writes, the
    /// standard errors of the rigid-body symbols it fitted at the noise floor but could not
    /// determine; with `on`, the next step that fits them again holds them to those values
    /// with those standard errors (what the earlier step's data say about them), instead of
    /// letting its own joint of interest trade them away. Overrides `--prior` for them.
    #[arg(long, value_enum, default_value = "off")]
    #[arg(help_heading = "Output error: the sequence and its refinements")]
    pub carried_prior: Switch,
    /// Release held values where a step ends above the noise floor: the values earlier
    /// steps fitted (with a recorded standard error) that this step's data see better than
    /// those steps did are fitted again with the step's parameters, from its result, under a
    /// Gaussian prior about their held values with their standard errors (the sequential
    /// estimate); kept when cost + prior term is lower. A value fitted within its standard
    /// error on an earlier configuration can still be off by more than a later one
    /// tolerates. `off`: the thesis's sequence, every earlier value held as fitted.
    #[arg(long, value_enum, default_value = "on")]
    #[arg(help_heading = "Output error: the sequence and its refinements")]
    pub release_held: Switch,
    /// Reach across held ties where a step ends above the noise floor with a spanning
    /// rigid-body symbol on a bound: fitted again with that bound moved out by what the
    /// held ties (rigid-body symbols an earlier step left undetermined) can carry within
    /// their bounds, the result spread back over every symbol's own bounds, then fitted
    /// there; kept when lower, the held ties moved in the plant written. `off`: the held
    /// ties stay where they are.
    #[arg(long, value_enum, default_value = "on")]
    #[arg(help_heading = "Output error: the sequence and its refinements")]
    pub tie_reach: Switch,
    /// Balanced refit after each step whose joints of interest are weighted apart (--weight):
    /// the whole files once more with every free joint weighted 1, from the step's result;
    /// kept when the worst free joint's RMS / σ̂ falls. The thesis's weight 50 lets a step
    /// leave a misfit on the other joints that costs it 1/2500 of the same on a joint of
    /// interest. `off`: the thesis's weights to the end.
    #[arg(long, value_enum, default_value = "on")]
    #[arg(help_heading = "Output error: the sequence and its refinements")]
    pub balance: Switch,
    /// Equation-error warm start: one more start from the plant's values first fits the
    /// torque balance at every sample (positions low-passed and differentiated, LuGre
    /// bristles driven by the estimated velocities; no simulation, so no drift), then the
    /// whole files; it runs beside the other starts and the lower cost wins. `on`: the
    /// position filter's cut-off per joint by residual analysis (the lowest that removes
    /// no more than the noise: high for a light, fast wrist, low for a heavy base joint);
    /// a cut-off fraction of the Nyquist frequency for every joint, such as 0.2; or `off`.
    /// Default: on for the coupled method, off for the isolated.
    #[arg(long, value_name = "on|off|CUTOFF")]
    #[arg(help_heading = "Output error: starts and warm-ups")]
    pub equation_error: Option<String>,
    /// Prediction-error homotopy, e.g. `--predictor 3,1`: before the whole files, fit the
    /// files simulated with the state pulled toward the measured positions by a critically
    /// damped output injection of each bandwidth ω (rad/s) in turn (a Luenberger observer:
    /// at large ω a low-passed equation error, smooth in the parameters; ω → 0 is the
    /// output error). It follows the equation error when `--equation-error` is on, or is one
    /// more start from the plant's values. A stage that ends above twice the larger of the
    /// noise floor and the previous stage's end is run again through the geometric mean of
    /// the two bandwidths (twice at most; the report says so). `none`: no such stages.
    /// Default: 100,30,10,3,1 for the coupled method, none for the isolated.
    #[arg(long, value_name = "OMEGAS")]
    #[arg(help_heading = "Output error: starts and warm-ups")]
    pub predictor: Option<String>,
    /// Step (s) of the predictor's stages, simulated by ETDRK4, e.g. 1/2000: the output
    /// injection keeps an early error from growing along the file, so the stages that move
    /// the parameters most of the way run far coarser than the whole files need. `none`:
    /// the predictor's stages on --step and --integrator. Default: 1/2000 for the coupled
    /// method, none for the isolated. The Levenberg–Marquardt (`--predictor-optimiser lm`)
    /// can stall on the coarse step: pass none with it.
    #[arg(long, value_name = "STEP")]
    #[arg(help_heading = "Output error: starts and warm-ups")]
    pub predictor_step: Option<String>,
    /// Optimiser of the predictor's stages: `lm`, rmpfit's bounded Levenberg–Marquardt
    /// (every other stage's), or `trf`, basin's trust-region-reflective method, which
    /// follows a descent that the Levenberg–Marquardt stops on with a collapsed trust
    /// region, at one Jacobian per accepted step (finite differences, or Broyden's update
    /// between them with --jacobian-refresh).
    #[arg(long, value_enum, default_value = "trf")]
    #[arg(help_heading = "Output error: starts and warm-ups")]
    pub predictor_optimiser: OptimiserArg,
    /// Optimiser of the whole files' stage (the cost itself) and of the refit that
    /// releases held values: `lm` or `trf`, as --predictor-optimiser. The horizons',
    /// segments' and equation error's stages run `lm`.
    #[arg(long, value_enum, default_value = "lm")]
    #[arg(help_heading = "Output error: starts and warm-ups")]
    pub whole_files_optimiser: OptimiserArg,
    /// Initial positions of the free joints in every file: `estimate`d with the parameters
    /// at the whole files' stage (as MATLAB `oe`/`pem` with `InitialCondition = 'estimate'`;
    /// the first sample carries the sensor noise, which a trajectory sensitive to its start
    /// carries to every later sample) or the first `measured`
    /// sample, as the thesis. Default: estimate for the coupled method, measured for the
    /// isolated.
    #[arg(long, value_enum)]
    #[arg(help_heading = "Output error: starts and warm-ups")]
    pub initial_positions: Option<InitialPositionsArg>,
    /// Joint fit of the sequence's steps: `after` the step-by-step fits, every parameter the
    /// steps fit is refined on every step's files at once (each file in its configuration,
    /// every free joint weighted 1), from the values the steps left; its standard errors
    /// and identifiable calls are those of all the data, not conditional on values earlier
    /// steps fixed. `only`: the joint fit alone from the plant's values (a plant a sequence
    /// run wrote). It covers the steps up to --config's (all without it); their files must
    /// be in --data. `off`: the steps alone (the thesis).
    #[arg(long, value_enum, default_value = "off")]
    #[arg(help_heading = "Output error: the sequence and its refinements")]
    pub joint_fit: JointFitArg,
    /// The position sensor's noise σ (rad or m) when known, such as 2e-4: used instead of
    /// the σ̂ estimated from each file (robust 5th differences of the positions) for the
    /// noise-floor check, the prior's weight and the predictor step's check. `estimate`:
    /// from the data.
    #[arg(long, default_value = "estimate", value_name = "SIGMA|estimate")]
    #[arg(help_heading = "Output error: cost, integration and stopping")]
    pub noise_sigma: String,
    /// Largest motion (rad) allowed of a locked joint in a file.
    #[arg(value_parser = parse_positive, long, default_value_t = 0.01)]
    #[arg(help_heading = "Output error: cost, integration and stopping")]
    pub locked_tolerance: f64,
    /// Rigid-body symbols each step fits: `spanning` (a set of them that spans the
    /// configuration's base parameters where its files hold the locked joints, by column
    /// pivoting on ∂β/∂s; the others held at their values and left undetermined for later
    /// steps: the same reachable dynamics without the exact ties a finite-difference
    /// Jacobian fills with noise) or `all` (every symbol the step
    /// identifies or carries; the least change resolves their exact ties afterwards).
    #[arg(long, value_enum, default_value = "spanning")]
    #[arg(help_heading = "Output error: the sequence and its refinements")]
    pub rigid_body: RigidBodyArg,
}

impl OutputErrorArgs {
    /// The output-error options of `method`: its preset ([`OutputErrorOptions::isolated`],
    /// [`OutputErrorOptions::coupled`]) with the options given on the command line.
    pub fn options(&self, method: Method) -> Result<OutputErrorOptions> {
        let flags = self.options_from_flags(method)?;
        let Some(path) = &self.profile else {
            return Ok(flags);
        };
        // The profile's fields on the flags' options, but for those a given flag sets.
        let set_by_a_flag = |field: &str| {
            FIELD_FLAGS.iter().any(|(f, ids)| {
                *f == field && ids.iter().any(|id| self.given.iter().any(|g| g == id))
            })
        };
        let o = with_profile(&flags, path, &set_by_a_flag)?;
        if !o.fits_the_plant_values() {
            bail!(
                "{}: nothing would fit the plant's values (no horizons, equation error, predictor or segments)",
                path.display()
            );
        }
        Ok(o)
    }

    /// The method's preset with the flags (every flag: a default is the preset's value).
    fn options_from_flags(&self, method: Method) -> Result<OutputErrorOptions> {
        use lockstep::identify::output_error::TimeWeighting;
        let coupled = method == Method::Coupled;
        let mut o = method.preset();
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
        o.whole_files_optimiser = self.whole_files_optimiser.into();
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

    /// The sequence options of `method`: its preset ([`SequenceOptions::preset`]) with the
    /// options given on the command line.
    pub fn sequence_options(
        &self,
        method: Method,
        only: Option<String>,
        out: PathBuf,
    ) -> Result<SequenceOptions> {
        let mut opts = SequenceOptions::preset(method.name(), out);
        opts.only = only;
        opts.fit = self.options(method)?;
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
        Ok(opts)
    }
}

/// The fields of [`OutputErrorOptions`] each command-line flag sets (clap ids): a given flag
/// wins over `--profile` for its fields.
const FIELD_FLAGS: &[(&str, &[&str])] = &[
    ("weighting", &["cost", "skip"]),
    ("interest_weight", &["weight"]),
    ("h", &["step"]),
    ("integrator", &["integrator"]),
    ("xtol", &["xtol"]),
    ("ftol", &["ftol"]),
    ("max_iter", &["max_iter"]),
    ("starts", &["starts"]),
    ("seed", &["seed"]),
    ("jacobian_refresh", &["jacobian_refresh"]),
    ("horizons", &["horizons"]),
    ("segments", &["segments"]),
    ("least_change", &["least_change"]),
    ("prior", &["prior"]),
    ("carried_prior", &["carried_prior"]),
    ("equation_error", &["equation_error"]),
    ("predictor", &["predictor"]),
    ("predictor_step", &["predictor_step"]),
    ("predictor_optimiser", &["predictor_optimiser"]),
    ("whole_files_optimiser", &["whole_files_optimiser"]),
    ("estimate_initial_positions", &["initial_positions"]),
    ("noise_sigma", &["noise_sigma"]),
];

/// `base` with the fields a profile file sets, but for those `kept` names: a TOML table of
/// [`OutputErrorOptions`] fields, or a `report.json` whose `options` it takes (any other
/// JSON: the object itself).
///
/// # Errors
/// The file cannot be read or parsed; a field that is not an option, or a value of the
/// wrong type (both named with the file).
pub fn with_profile(
    base: &OutputErrorOptions,
    path: &std::path::Path,
    kept: &dyn Fn(&str) -> bool,
) -> Result<OutputErrorOptions> {
    use anyhow::Context as _;
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read the profile", path.display()))?;
    let is_json = path.extension().is_some_and(|e| e == "json");
    let fields: serde_json::Value = if is_json {
        let v: serde_json::Value = serde_json::from_str(&text)
            .with_context(|| format!("{}: not a JSON file", path.display()))?;
        v.get("options").cloned().unwrap_or(v)
    } else {
        let t: toml::Table =
            toml::from_str(&text).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
        serde_json::to_value(t)?
    };
    let Some(fields) = fields.as_object() else {
        bail!("{}: expected a table of option fields", path.display());
    };
    let mut merged = serde_json::to_value(base)?;
    let known: Vec<String> = merged
        .as_object()
        .map(|m| m.keys().cloned().collect())
        .unwrap_or_default();
    for (k, v) in fields {
        if !known.contains(k) {
            bail!(
                "{}: '{k}' is not an output-error option (expected one of: {})",
                path.display(),
                known.join(", ")
            );
        }
        if !kept(k) {
            merged[k] = v.clone();
        }
    }
    let mut o: OutputErrorOptions =
        serde_json::from_value(merged).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    o.hold = base.hold;
    Ok(o)
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

/// `identify --method`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Method {
    /// IDIM-LS: inverse-dynamic model, linear least squares on torque-measured data.
    Idim,
    /// Output error along the method of isolated joints' locking sequence (thesis 4.3.1).
    Isolated,
    /// Output error along the method of coupling joints' locking sequence (thesis 4.3.2).
    Coupled,
}

impl Method {
    /// The output-error preset of the method's sequence ([`OutputErrorOptions::for_sequence`]).
    pub fn preset(self) -> OutputErrorOptions {
        OutputErrorOptions::for_sequence(self.name())
    }

    pub fn name(self) -> &'static str {
        match self {
            Method::Idim => "idim",
            Method::Isolated => "isolated",
            Method::Coupled => "coupled",
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
    /// Estimated with the parameters at the whole files' stage.
    Estimate,
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

/// Output-error identification along a locking sequence, with a progress line.
pub fn identify_sequence(
    common: &Common,
    method: Method,
    out: Option<PathBuf>,
    oe: &OutputErrorArgs,
) -> Result<()> {
    let out = out.unwrap_or_else(|| PathBuf::from("lockstep-out/identify"));
    let mut plant = Plant::load(&common.plant)?;
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
    let opts = oe.sequence_options(method, common.config.clone(), out)?;
    let bar = indicatif::ProgressBar::new_spinner();
    bar.enable_steady_tick(std::time::Duration::from_millis(250));
    // Without a terminal (logs, CI) one line per iteration instead of a spinner.
    let plain = bar.is_hidden();
    let last = std::sync::Mutex::new((String::new(), usize::MAX));
    let report = lockstep::identify::sequence::run(&plant, &common.data, &opts, &|step, p| {
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

/// Refuses an `identify` option of another method than `method` among those `given` on the
/// command line ([`given_identify_options`]), naming the method it
/// belongs to (a flag that would be ignored is an error, not a silent no-op).
///
/// # Errors
/// An output-error option with `--method idim`, or an IDIM option with an output-error method.
pub fn refuse_options_of_other_methods(method: Method, given: &[String]) -> Result<()> {
    let is_given = |id: &str| given.iter().any(|g| g == id);
    let flag = |id: &str| format!("--{}", id.replace('_', "-"));
    if method == Method::Idim {
        let output_error = OutputErrorArgs::augment_args(clap::Command::new("identify"));
        let first = output_error
            .get_arguments()
            .map(|a| a.get_id().to_string())
            .find(|id| is_given(id));
        if let Some(id) = first {
            bail!(
                "{}: an option of `identify --method isolated|coupled` (output error); IDIM-LS (`--method idim`, the default) does not use it",
                flag(&id)
            );
        }
    } else if let Some(id) = ["cutoff", "order", "decimate", "allow_inconsistent"]
        .into_iter()
        .find(|id| is_given(id))
    {
        bail!(
            "{}: an option of `identify --method idim` (IDIM-LS); output error (`--method {}`) does not use it",
            flag(id),
            method.name()
        );
    }
    Ok(())
}

/// The `identify` options given on the command line (clap ids); empty for other commands.
pub fn given_identify_options(matches: &ArgMatches) -> Vec<String> {
    let Some(("identify", sub)) = matches.subcommand() else {
        return Vec::new();
    };
    sub.ids()
        .filter(|id| sub.value_source(id.as_str()) == Some(clap::parser::ValueSource::CommandLine))
        .map(|id| id.to_string())
        .collect()
}

#[cfg(test)]
mod method_tests {
    use super::*;
    use clap::{CommandFactory, FromArgMatches};

    /// The matches of `lockstep identify --plant p --data d ARGS`.
    fn identify_matches(args: &[&str]) -> ArgMatches {
        Cli::command()
            .try_get_matches_from(
                [
                    &["lockstep", "identify", "--plant", "p", "--data", "d"][..],
                    args,
                ]
                .concat(),
            )
            .unwrap()
    }

    fn identify(args: &[&str]) -> (Method, OutputErrorArgs) {
        let cli = Cli::try_parse_from(
            [
                &[
                    "lockstep", "identify", "--plant", "p.toml", "--data", "d.csv",
                ][..],
                args,
            ]
            .concat(),
        )
        .unwrap();
        match cli.command {
            Command::Identify { method, oe, .. } => (method, *oe),
            _ => unreachable!(),
        }
    }

    #[test]
    fn the_cli_builds_its_options_from_the_presets() {
        for name in ["coupled", "isolated"] {
            let (method, oe) = identify(&["--method", name]);
            let built = oe
                .sequence_options(method, None, PathBuf::from("out"))
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
        let (method, oe) = identify(&["--method", "coupled", "--horizons", "1"]);
        let o = oe.options(method).unwrap();
        assert_eq!(o.horizons, vec![1.0]);
        assert_eq!(format!("{:?}", o.predictor), format!("{:?}", c.predictor));
    }

    /// The per-method defaults the help states are the presets' values.
    #[test]
    fn the_help_states_the_presets_defaults() {
        let mut cmd = Cli::command();
        let help = cmd
            .find_subcommand_mut("identify")
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
        let initial = |e: bool| if e { "estimate" } else { "measured" };
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
            format!(
                "Default: {} for the coupled method, {} for the isolated",
                initial(c.estimate_initial_positions),
                initial(i.estimate_initial_positions)
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
            let m = identify_matches(args);
            let cli = Cli::from_arg_matches(&m).unwrap();
            let Command::Identify { method, mut oe, .. } = cli.command else {
                unreachable!()
            };
            oe.given = given_identify_options(&m);
            oe.options(method)
        };
        let o = parse(&["--method", "coupled", "--profile", p]).unwrap();
        assert_eq!((o.h, o.max_speed), (1e-4, 300.0));
        assert_eq!(o.horizons, vec![0.5, 1.0]);
        assert_eq!(o.predictor, OutputErrorOptions::coupled().predictor);
        let o = parse(&["--method", "coupled", "--profile", p, "--horizons", "1"]).unwrap();
        assert_eq!((o.h, o.horizons.clone()), (1e-4, vec![1.0]));
        // A report's recorded options replay the run.
        let report = d.path().join("report.json");
        let mut recorded = OutputErrorOptions::isolated();
        recorded.seed = 42;
        recorded.prior = Some(0.2);
        std::fs::write(
            &report,
            serde_json::json!({ "sequence": "isolated", "options": recorded }).to_string(),
        )
        .unwrap();
        let o = parse(&[
            "--method",
            "isolated",
            "--profile",
            report.to_str().unwrap(),
        ])
        .unwrap();
        assert_eq!(format!("{o:?}"), format!("{recorded:?}"));
        std::fs::write(&profile, "step = 1e-4\n").unwrap();
        let e = parse(&["--method", "coupled", "--profile", p])
            .unwrap_err()
            .to_string();
        assert!(e.contains("identify.toml") && e.contains("'step'"), "{e}");
    }

    #[test]
    fn an_option_of_another_method_is_refused_naming_its_method() {
        let refused = |args: &[&str]| {
            let m = identify_matches(args);
            let method = m
                .subcommand_matches("identify")
                .and_then(|sub| sub.get_one::<Method>("method").copied())
                .unwrap();
            refuse_options_of_other_methods(method, &given_identify_options(&m))
                .map_err(|e| e.to_string())
        };
        let e = refused(&["--horizons", "1"]).unwrap_err();
        assert!(
            e.contains("--horizons") && e.contains("--method isolated|coupled"),
            "{e}"
        );
        let e = refused(&["--method", "coupled", "--cutoff", "5"]).unwrap_err();
        assert!(e.contains("--cutoff") && e.contains("--method idim"), "{e}");
        assert!(refused(&["--cutoff", "5"]).is_ok());
        assert!(refused(&["--method", "coupled", "--horizons", "1"]).is_ok());
    }
}
