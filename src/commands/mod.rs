//! The `lockstep` command line.

use anyhow::{bail, Result};
use clap::{Args, Parser, Subcommand};
use lockstep::identify::equation_error::Cutoff;
use lockstep::identify::identifiability::{base_parameters, markdown, occurrence};
use lockstep::identify::idim::{observation, IdimOptions};
use lockstep::identify::output_error::{OutputErrorOptions, StageOptimiser};
use lockstep::identify::sequence::{JointFitMode, RigidBodyFit, SequenceOptions};
use lockstep::measurement::Measurement;
use lockstep::plant::Plant;
use lockstep::report::diagnosis::{
    apply_all_command, apply_finding, compare_command, diagnose, effect_add, refit_command,
    refit_table, report_command, Inputs,
};
use lockstep::report::fit_table;
use lockstep::simulation::{Hold, Integrator};
use std::path::PathBuf;

/// lockstep: symbolic robot models to Rust kernels; identification, model-vs-measurement
/// diagnosis and haptic control.
#[derive(Debug, Parser)]
#[command(name = "lockstep", version, about)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// Subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Run the main job on the bundled EMPS measurements: fit, see where the model fails,
    /// add the missing effects, watch the error fall.
    Demo {
        /// Output directory.
        #[arg(long, default_value = "lockstep-out/demo")]
        out: PathBuf,
    },
    /// Fit a plant's parameters to torque-measured data by IDIM-LS.
    ///
    /// `--method idim` (default): IDIM-LS on torque-measured data. `--method isolated` or
    /// `coupled`: output-error fits along the model's locking sequence on the position
    /// measurements in `--data` (files or directories), writing `plant.toml`, `report.md`
    /// and `report.json` to `--out` (a directory) after every step.
    Identify {
        #[command(flatten)]
        common: Common,
        /// Method: idim, isolated (thesis 4.2-4.3) or coupled (4.4).
        #[arg(long, default_value = "idim")]
        method: String,
        /// IDIM: write the plant with the fitted values to this file. Output error: the
        /// output directory (default lockstep-out/identify).
        #[arg(long)]
        out: Option<PathBuf>,
        /// IDIM: write the fitted plant even when a link's mass or inertia is not physical
        /// or a value leaves its bounds (refused by default, with the reasons).
        #[arg(long)]
        allow_inconsistent: bool,
        #[command(flatten)]
        oe: Box<OutputErrorArgs>,
    },
    /// Compare a plant with measurements (MATLAB compare and resid): fit, errors and where
    /// they occur, residual CSVs, plots (residual vs time, position, velocity, torques;
    /// spectrum; autocorrelation and cross-correlation with 99 % bounds).
    Compare {
        #[command(flatten)]
        common: Common,
        #[command(flatten)]
        space: SpaceArgs,
        /// Output directory for residual CSVs and plots.
        #[arg(long, default_value = "lockstep-out/compare")]
        out: PathBuf,
    },
    /// Name the missing physical effect: rank a catalogue of candidate effects by how much
    /// of the residual each explains (ΔBIC), in torque space (inverse model) or output space
    /// (simulated positions). `--apply K --out P.toml` adds finding K, refits it and records
    /// the step in the plant's history.
    Diagnose {
        #[command(flatten)]
        common: Common,
        #[command(flatten)]
        space: SpaceArgs,
        /// Candidates to print.
        #[arg(long, default_value_t = 5)]
        top: usize,
        /// Add finding K (1 = the first) to the plant and refit its parameters jointly
        /// with the changes recorded earlier on the configuration (output space);
        /// `all-significant`: apply the leading finding and diagnose again until nothing
        /// significant is missing.
        #[arg(long, requires = "out")]
        apply: Option<Apply>,
        /// With --apply: where to write the changed plant.
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Refit chosen parameters by output error; print the error per joint before and after;
    /// append the step to the plant's history.
    Refit {
        #[command(flatten)]
        common: Common,
        #[command(flatten)]
        space: SpaceArgs,
        /// Parameters to fit (each needs bounds in the plant file), e.g. Ks_3,qeq_3.
        #[arg(long, value_delimiter = ',', required = true)]
        params: Vec<String>,
        /// What changed, for the history (default: "refitted <params>").
        #[arg(long)]
        change: Option<String>,
        /// Plant file to write (default: the plant file itself).
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Edit a plant's effects: `effect add KIND --joint q3 --plant P` (or `--from q5 --to
    /// q4` for input_coupling).
    Effect {
        #[command(subcommand)]
        action: EffectAction,
    },
    /// Compare, diagnose and the plant's history in one self-contained HTML report
    /// (`OUT/report.html`, figures inlined).
    Report {
        #[command(flatten)]
        common: Common,
        #[command(flatten)]
        space: SpaceArgs,
        /// Candidates listed.
        #[arg(long, default_value_t = 8)]
        top: usize,
        /// Output directory.
        #[arg(long, default_value = "lockstep-out/report")]
        out: PathBuf,
    },
    /// List the generated models, their joints, parameters and configurations.
    Models,
    /// Sample an excitation of the thesis (Tables 4.3, 4.4, 4.5, 4.7, 4.9) for a configuration
    /// and write a torque (or position-command) file with a side file naming the configuration.
    Excite {
        /// Model name.
        #[arg(long)]
        model: String,
        /// Table id (4.3, 4.4, 4.5, 4.7, 4.9).
        #[arg(long)]
        table: String,
        /// Test of the table (needed when it has several; the error lists them).
        #[arg(long)]
        test: Option<String>,
        /// Configuration: only its free joints are driven.
        #[arg(long)]
        config: String,
        /// Duration (s).
        #[arg(value_parser = parse_positive, long, default_value_t = 60.0)]
        duration: f64,
        /// Sampling rate (Hz).
        #[arg(value_parser = parse_positive, long, default_value_t = 100.0)]
        rate: f64,
        /// Excitation file (default: the tables bundled for the model).
        #[arg(long)]
        excitation: Option<PathBuf>,
        /// Output file (.csv or .mat).
        #[arg(long, short)]
        out: PathBuf,
    },
    /// Run a plant on a torque file (RK4 or ETDRK4) and write a measurement file, optionally with
    /// position noise and quantisation: synthetic data with any effect switched on.
    Simulate {
        /// Plant file.
        #[arg(long)]
        plant: PathBuf,
        /// Torque file (.csv or .mat): t and tau{j} of the free joints.
        #[arg(long)]
        input: PathBuf,
        /// Configuration (default: the input's side file's).
        #[arg(long)]
        config: Option<String>,
        /// Locked-joint positions, e.g. q0=0.1,q1=-0.2 (rad or m; default 0 or the side
        /// file's; repeatable).
        #[arg(long, value_parser = parse_positions)]
        locked: Vec<PositionList>,
        /// Initial positions of free joints, e.g. q4=0.3 (default 0; at rest, z = 0;
        /// repeatable).
        #[arg(long, value_parser = parse_positions)]
        initial: Vec<PositionList>,
        /// Integration step (s), a number or a fraction such as 1/6000.
        #[arg(long, default_value = "1/6000", value_parser = parse_number)]
        step: f64,
        /// Integrator: rk4 or etdrk4 (exponential RK4 taking the friction damping exactly).
        #[arg(long, default_value = "rk4")]
        integrator: Integrator,
        /// How the torques are applied between samples: zoh, linear, cubic or bandlimited
        /// (default: the input's side file's `hold`, else zoh). Recorded in the output's side
        /// file.
        #[arg(long)]
        hold: Option<Hold>,
        /// Gaussian position noise σ (rad or m).
        #[arg(value_parser = parse_non_negative, long, default_value_t = 0.0)]
        noise: f64,
        /// Position quantisation step (rad or m).
        #[arg(value_parser = parse_non_negative, long, default_value_t = 0.0)]
        quantisation: f64,
        /// Noise seed.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Report divergence when a speed exceeds this (rad/s or m/s).
        #[arg(value_parser = parse_positive, long, default_value_t = 100.0)]
        max_speed: f64,
        /// Simulate even with physically impossible rigid-body parameters.
        #[arg(long)]
        allow_inconsistent: bool,
        /// Output measurement file (.csv or .mat); a side file .toml is written beside it.
        #[arg(long, short)]
        out: PathBuf,
    },
    /// Check a plant: physical consistency of every link (mass, positive-definite inertia,
    /// triangle inequality) and, per configuration, what a simulation needs.
    Check {
        /// Plant file.
        #[arg(long)]
        plant: PathBuf,
        /// A plant file of values a fit from `--plant` should be able to reach (a published
        /// result, the truth of synthetic data): lists those outside `--plant`'s bounds.
        #[arg(long)]
        against: Option<PathBuf>,
    },
    /// Closed-loop PD verification (thesis 4.5): PD per joint with the filtered error
    /// derivative (4.7), position commands of Table 4.9, small and big gains of Table 4.8;
    /// simulated vs commanded (and measured, if given) positions, fit figures, plots.
    Closedloop {
        /// Closed-loop file (gains, filter, commands, plant).
        #[arg(long, default_value = "model/control/freedom6s_closedloop.toml")]
        spec: PathBuf,
        /// Plant file replacing the closed-loop file's.
        #[arg(long)]
        plant: Option<PathBuf>,
        /// Gain sets to run (default: all in the file).
        #[arg(long, num_args = 1..)]
        gains: Vec<String>,
        /// Measured closed-loop runs, one per gain set in the same order (CSV or .mat with
        /// t and q{j}).
        #[arg(long, num_args = 1..)]
        measured: Vec<PathBuf>,
        /// Duration (s), replacing the file's.
        #[arg(long, value_parser = parse_positive)]
        duration: Option<f64>,
        /// Output directory.
        #[arg(long, default_value = "lockstep-out/closedloop")]
        out: PathBuf,
    },
    /// Haptic virtual wall on joint 0 (thesis Chapter 5): PD vs fuzzy over the approach
    /// speeds and the hand sweep, chatter metrics, position plots (Figures 5.10-5.12),
    /// control surfaces (5.7-5.9), rule tables as FLL and FIS. `wall tune` tunes the rules.
    #[command(args_conflicts_with_subcommands = true)]
    Wall {
        /// `tune`: tune the fuzzy rules against the simulated user.
        #[command(subcommand)]
        action: Option<WallAction>,
        #[command(flatten)]
        args: WallArgs,
    },
    /// Parameter occurrence per configuration and along each locking sequence (thesis
    /// Figure 4.2), and the base (identifiable) parameters of every configuration; writes
    /// parameters.md and parameters.json.
    Params {
        /// Model name (see `lockstep models`).
        #[arg(long)]
        model: String,
        /// Output directory.
        #[arg(long, default_value = "lockstep-out/params")]
        out: PathBuf,
    },
}

/// Plant edits.
#[derive(Debug, Subcommand)]
pub enum EffectAction {
    /// Add an effect with neutral values (no effect: levels 0, gain and friction-bias
    /// factor 1); `--set` and `--bound` give values and bounds.
    Add {
        /// Kind: viscous, coulomb, asymmetric_friction, offset, gain, stribeck, lugre,
        /// spring, friction_bias, input_coupling (alias: coupling).
        kind: String,
        /// Plant file.
        #[arg(long)]
        plant: PathBuf,
        /// Joint the effect acts on.
        #[arg(long)]
        joint: Option<String>,
        /// input_coupling: the joint whose command is passed on.
        #[arg(long)]
        from: Option<String>,
        /// input_coupling: the joint that receives it.
        #[arg(long)]
        to: Option<String>,
        /// Values, e.g. Ks_3=0.01,qeq_3=0.2 (repeatable).
        #[arg(long, value_parser = parse_positions)]
        set: Vec<PositionList>,
        /// Bounds, e.g. Ks_3=0:0.1 (repeatable).
        #[arg(long, value_parser = parse_bound)]
        bound: Vec<(String, f64, f64)>,
        /// Plant file to write (default: the plant file itself).
        #[arg(long)]
        out: Option<PathBuf>,
    },
}

/// Where compare, diagnose and refit work, and the output-space settings.
#[derive(Debug, Clone, Args)]
pub struct SpaceArgs {
    /// auto (torque space for a plant whose effects are all linear in their parameters,
    /// output space otherwise), torque or output.
    #[arg(long, default_value = "auto")]
    pub space: String,
    /// Output space: integration step (s); fractions such as 1/6000 accepted.
    #[arg(long, default_value = "1/6000", value_parser = parse_number)]
    pub step: f64,
    /// Output space: integrator, rk4 or etdrk4 (exponential RK4 that takes the friction
    /// damping exactly: stable at steps where RK4 diverges on stiff friction).
    #[arg(long, default_value = "rk4")]
    pub integrator: Integrator,
    /// Output space: samples skipped at the start of each file.
    #[arg(long, default_value_t = 0)]
    pub skip: usize,
    /// Output space: largest motion (rad) allowed of a locked joint in a file.
    #[arg(value_parser = parse_positive, long, default_value_t = 0.01)]
    pub locked_tolerance: f64,
    /// Output space: initial positions `estimate`d from each file (as MATLAB compare) or
    /// the first `measured` sample.
    #[arg(long, default_value = "estimate", value_parser = ["estimate", "measured"])]
    pub initial: String,
    /// Output space: how the torques were applied between samples: zoh (a digital
    /// controller's hold), linear, cubic or bandlimited (a continuous signal sampled for
    /// the file). Default: each file's side file's `hold`, else zoh.
    #[arg(long)]
    pub hold: Option<Hold>,
}

fn parse_bound(s: &str) -> Result<(String, f64, f64), String> {
    let (n, r) = s
        .split_once('=')
        .ok_or_else(|| format!("'{s}': expected name=lower:upper, e.g. Ks_3=0:0.1"))?;
    let (lo, hi) = r
        .split_once(':')
        .ok_or_else(|| format!("'{s}': expected name=lower:upper, e.g. Ks_3=0:0.1"))?;
    Ok((
        n.trim().to_string(),
        parse_number(lo.trim()).map_err(|e| format!("'{s}': {e}"))?,
        parse_number(hi.trim()).map_err(|e| format!("'{s}': {e}"))?,
    ))
}

impl Common {
    fn inputs(&self, space: &SpaceArgs) -> Result<(Plant, Inputs)> {
        let (plant, idim) = self.load_plant()?;
        if !(space.step > 0.0 && space.step.is_finite()) {
            bail!(
                "--step: expected a positive step in seconds, got {}",
                space.step
            );
        }
        Ok((
            plant,
            Inputs {
                data: self.data.clone(),
                config: self.config.clone(),
                space: space.space.clone(),
                idim,
                h: space.step,
                integrator: space.integrator,
                skip: space.skip,
                locked_tolerance: space.locked_tolerance,
                estimate_initial: space.initial == "estimate",
                hold: space.hold,
            },
        ))
    }
}

/// What `lockstep wall` does besides the comparison.
#[derive(Debug, Subcommand)]
pub enum WallAction {
    /// Tune the fuzzy rules (one factor per position label for approaching and leaving
    /// velocities) to minimise chatter under the penetration bound; report the tuned table
    /// against the hand-made one.
    Tune {
        #[command(flatten)]
        args: WallArgs,
    },
}

/// Options of `lockstep wall`.
#[derive(Debug, Clone, Args)]
pub struct WallArgs {
    /// Wall file (plant, loop, PD gains, user, membership functions, rule modifications).
    #[arg(long, default_value = "model/control/freedom6s_wall.toml")]
    pub spec: PathBuf,
    /// Rule table replacing the file's modified one (.fll fuzzylite or .fis MATLAB).
    #[arg(long)]
    pub rules: Option<PathBuf>,
    /// Control rate for the hand sweep and tuning (Hz; default the file's first).
    #[arg(long, value_parser = parse_positive)]
    pub rate: Option<f64>,
    /// Output directory.
    #[arg(long, default_value = "lockstep-out/wall")]
    pub out: PathBuf,
}

/// Joint positions given on the command line.
#[derive(Debug, Clone, Default)]
pub struct PositionList(pub std::collections::BTreeMap<String, f64>);

fn parse_number(s: &str) -> Result<f64, String> {
    lockstep::excitation::Value::Expr(s.to_string())
        .eval()
        .map_err(|e| format!("{e:#}"))
}

/// A positive finite number (fractions accepted).
fn parse_positive(s: &str) -> Result<f64, String> {
    match parse_number(s)? {
        x if x > 0.0 => Ok(x),
        x => Err(format!("expected a positive number, got {x}")),
    }
}

/// A finite number ≥ 0 (fractions accepted).
fn parse_non_negative(s: &str) -> Result<f64, String> {
    match parse_number(s)? {
        x if x >= 0.0 => Ok(x),
        x => Err(format!("expected a number ≥ 0, got {x}")),
    }
}

fn parse_positions(s: &str) -> Result<PositionList, String> {
    let mut m = std::collections::BTreeMap::new();
    for item in s.split(',').map(str::trim).filter(|x| !x.is_empty()) {
        let (k, v) = item
            .split_once('=')
            .ok_or_else(|| format!("'{item}': expected joint=value, e.g. q0=0.1"))?;
        let v = parse_number(v.trim()).map_err(|e| format!("'{item}': {e}"))?;
        if m.insert(k.trim().to_string(), v).is_some() {
            return Err(format!("'{}' is given twice", k.trim()));
        }
    }
    Ok(PositionList(m))
}

/// The lists of a repeatable `flag` merged; a name given in two of them is refused.
fn merged(flag: &str, lists: Vec<PositionList>) -> Result<std::collections::BTreeMap<String, f64>> {
    let mut m = std::collections::BTreeMap::new();
    for l in lists {
        for (k, v) in l.0 {
            if m.insert(k.clone(), v).is_some() {
                bail!("{flag}: '{k}' is given twice");
            }
        }
    }
    Ok(m)
}

fn model_named(name: &str) -> Result<&'static generated::Model> {
    lockstep::util::model(name).map_err(|e| anyhow::anyhow!("--model: {e}"))
}

/// Options shared by identify and compare.
#[derive(Debug, Args)]
pub struct Common {
    /// Plant file (model + effects + parameter values).
    #[arg(long)]
    pub plant: PathBuf,
    /// Measurement files (CSV or .mat; a side file <name>.toml may map the columns).
    #[arg(long, required = true, num_args = 1..)]
    pub data: Vec<PathBuf>,
    /// Configuration (set of free joints) of the data (IDIM and compare: default `full`);
    /// with `--method isolated|coupled`, run this step of the sequence only.
    #[arg(long)]
    pub config: Option<String>,
    /// Cut-off of the zero-phase Butterworth on positions (Hz).
    #[arg(value_parser = parse_positive, long, default_value_t = 100.0)]
    pub cutoff: f64,
    /// Order of that Butterworth.
    #[arg(long, default_value_t = 4)]
    pub order: usize,
    /// Parallel decimation factor.
    #[arg(long, default_value_t = 10)]
    pub decimate: usize,
}

impl Common {
    /// The plant and the IDIM preparation options (checked).
    fn load_plant(&self) -> Result<(Plant, IdimOptions)> {
        let plant = Plant::load(&self.plant)?;
        if self.order == 0 || self.order > 12 {
            bail!("--order: expected 1 to 12, got {}", self.order);
        }
        if self.decimate == 0 {
            bail!("--decimate: expected 1 or more");
        }
        Ok((
            plant,
            IdimOptions {
                cutoff_hz: self.cutoff,
                filter_order: self.order,
                decimation: self.decimate,
            },
        ))
    }

    fn load(&self) -> Result<(Plant, Vec<Measurement>, IdimOptions)> {
        let (plant, opts) = self.load_plant()?;
        let nj = plant.model.joints.len();
        let records = lockstep::measurement::expand_data_paths(&self.data)?
            .iter()
            .map(|d| Measurement::read(d, nj))
            .collect::<Result<Vec<_>, _>>()?;
        Ok((plant, records, opts))
    }
}

/// Settings of output-error identification (`identify --method isolated|coupled`).
#[derive(Debug, Args)]
pub struct OutputErrorArgs {
    /// Continue an interrupted sequence in --out from its last completed step: start from
    /// --out's plant.toml, skip the steps its report lists, add the rest to that report.
    #[arg(long)]
    pub resume: bool,
    /// Cost: 4.2 (first half of each file weighted 1/2; isolated default) or 4.3 (skip the
    /// first --skip samples; coupled default).
    #[arg(long)]
    pub cost: Option<String>,
    /// Samples skipped at the start of each file under cost 4.3.
    #[arg(long, default_value_t = 1000)]
    pub skip: usize,
    /// Joint weight of the joint(s) of interest (others 1).
    #[arg(value_parser = parse_positive, long, default_value_t = 50.0)]
    pub weight: f64,
    /// Integration step (s); fractions such as 1/12000 accepted. The thesis's 1/6000 s leaves
    /// RK4's stability region on the Freedom 6S wrist (joint 4's friction damping over link
    /// 7's small inertia needs h < 1/9600 s), hence the default.
    #[arg(long, default_value = "1/12000", value_parser = parse_number)]
    pub step: f64,
    /// Integrator, rk4 or etdrk4 (exponential RK4 that takes the friction damping exactly:
    /// the Freedom 6S's wrist runs at 1/2000 s, where RK4 needs below 1/9600 s).
    #[arg(long, default_value = "rk4")]
    pub integrator: Integrator,
    /// How the torques were applied between samples: zoh, linear, cubic or bandlimited
    /// (default: each file's side file's `hold`, else zoh).
    #[arg(long)]
    pub hold: Option<Hold>,
    /// Starts per step: the plant's values, then random points inside the bounds (run in
    /// parallel).
    #[arg(long, default_value_t = 1)]
    pub starts: usize,
    /// Seed of the random starts.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Stop when the relative parameter step is below this (thesis 2e-6).
    #[arg(value_parser = parse_positive, long, default_value_t = 2e-6)]
    pub xtol: f64,
    /// Stop when the relative cost decrease is below this.
    #[arg(value_parser = parse_positive, long, default_value_t = 1e-6)]
    pub ftol: f64,
    /// Most iterations per start.
    #[arg(long, default_value_t = 100)]
    pub max_iter: usize,
    /// A finite-difference Jacobian (one simulation per fitted parameter) at most every N
    /// iterations of a stage, Broyden's rank-one update from the step taken between them;
    /// a step that did not lower the cost, and the end of every stage, take a fresh one.
    /// Both optimisers (--predictor-optimiser, --whole-files-optimiser). 1: finite
    /// differences at every iteration. Default: 4 for the coupled method (the Freedom 6S's
    /// k1 and k2 at 20 % and 50 % fewer simulations, the identification record), 1 for the
    /// isolated.
    #[arg(long, value_name = "N")]
    pub jacobian_refresh: Option<usize>,
    /// Multiple-shooting warm-up, e.g. `--segments 1,4`: one more start from the plant's
    /// values fits every file cut into segments of these lengths (s) in turn, each segment
    /// simulated from the measured state at its start (velocities from the positions), then
    /// the whole files; it runs beside the start through the horizons and the lower cost
    /// wins. `none`: only the horizons.
    #[arg(long, default_value = "none")]
    pub segments: String,
    /// Growing horizons: fit on these fractions of every file in turn (after the skipped
    /// transient), each simulated from the file's start and starting where the last stage
    /// ended; the last must be 1 (`--horizons 1`: the whole files at once). `none`: no
    /// start from the plant's values through the horizons, only the warm-ups
    /// (`--equation-error`, `--predictor`, `--segments`; one must be set). Default: none for
    /// the coupled method, 0.05,0.1,0.25,0.5,1 for the isolated.
    #[arg(long)]
    pub horizons: Option<String>,
    /// After each step's fit, move the rigid-body symbols back toward the plant's initial
    /// values along the combinations that step cannot tell apart (its base parameters held
    /// exactly; kept if the cost rises by less than one noise variance): the least-change
    /// solution, so the next step starts from the prior, not from where the optimiser
    /// drifted along an exact tie. `off`: keep the minimum as found.
    #[arg(long, default_value = "on", value_parser = ["on", "off"])]
    pub least_change: String,
    /// Prior on each step's fitted parameters (maximum a posteriori, as MATLAB's
    /// regularisation toward the nominal model): Gaussian about the values the step starts
    /// from, with spread TAU × each value (× the bound width for a value near zero; 0.1:
    /// the initial values are good to about 10 %), weighed against the noise
    /// each file shows (estimated from its positions). It decides only where the data are
    /// silent or nearly so, so a step does not hand an arbitrary point of a flat valley to
    /// the next. `none`: the thesis cost alone.
    #[arg(long, default_value = "none", value_name = "TAU")]
    pub prior: String,
    /// Sequential prior on carried symbols: each step records, in the plant it writes, the
    /// standard errors of the rigid-body symbols it fitted at the noise floor but could not
    /// determine; with `on`, the next step that fits them again holds them to those values
    /// with those standard errors (what the earlier step's data say about them), instead of
    /// letting its own joint of interest trade them away. Overrides `--prior` for them.
    #[arg(long, default_value = "off", value_parser = ["on", "off"])]
    pub carried_prior: String,
    /// Release held values where a step ends above the noise floor: the values earlier
    /// steps fitted (with a recorded standard error) that this step's data see better than
    /// those steps did are fitted again with the step's parameters, from its result, under a
    /// Gaussian prior about their held values with their standard errors (the sequential
    /// estimate); kept when cost + prior term is lower. A value fitted within its standard
    /// error on an earlier configuration can still be off by more than a later one
    /// tolerates. `off`: the thesis's sequence, every earlier value held as fitted.
    #[arg(long, default_value = "on", value_parser = ["on", "off"])]
    pub release_held: String,
    /// Reach across held ties where a step ends above the noise floor with a spanning
    /// rigid-body symbol on a bound: fitted again with that bound moved out by what the
    /// held ties (rigid-body symbols an earlier step left undetermined) can carry within
    /// their bounds, the result spread back over every symbol's own bounds, then fitted
    /// there; kept when lower, the held ties moved in the plant written. `off`: the held
    /// ties stay where they are (c6 of the Freedom 6S then ends at 26 σ̂).
    #[arg(long, default_value = "on", value_parser = ["on", "off"])]
    pub tie_reach: String,
    /// Balanced refit after each step whose joints of interest are weighted apart (--weight):
    /// the whole files once more with every free joint weighted 1, from the step's result;
    /// kept when the worst free joint's RMS / σ̂ falls. The thesis's weight 50 lets a step
    /// leave a misfit on the other joints that costs it 1/2500 of the same on a joint of
    /// interest (the Freedom 6S's seed-7 sequence: k3's q4 at 1.55 σ, k5's at 1.75 σ;
    /// balanced, every joint of every step within 1.01 σ, the record). `off`: the thesis's
    /// weights to the end
    #[arg(long, default_value = "on", value_parser = ["on", "off"])]
    pub balance: String,
    /// Equation-error warm start: one more start from the plant's values first fits the
    /// torque balance at every sample (positions low-passed and differentiated, LuGre
    /// bristles driven by the estimated velocities; no simulation, so no drift), then the
    /// whole files; it runs beside the other starts and the lower cost wins. `on`: the
    /// position filter's cut-off per joint by residual analysis (the lowest that removes
    /// no more than the noise: high for a light, fast wrist, low for a heavy base joint);
    /// a cut-off fraction of the Nyquist frequency for every joint, such as 0.2; or `off`.
    /// Default: on for the coupled method, off for the isolated.
    #[arg(long, value_name = "on|off|CUTOFF")]
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
    pub predictor: Option<String>,
    /// Step (s) of the predictor's stages, simulated by ETDRK4, e.g. 1/2000: the output
    /// injection keeps an early error from growing along the file, so the stages that move
    /// the parameters most of the way run far coarser than the whole files need. `none`:
    /// the predictor's stages on --step and --integrator. Default: 1/2000 for the coupled
    /// method, none for the isolated. With `--predictor-optimiser lm`, k1 of the Freedom 6S
    /// stalls on the coarse step (whole files 4.19, the identification record): pass none.
    #[arg(long, value_name = "STEP")]
    pub predictor_step: Option<String>,
    /// Optimiser of the predictor's stages: `lm`, rmpfit's bounded Levenberg–Marquardt
    /// (every other stage's), or `trf`, basin's trust-region-reflective method, which
    /// follows a descent that the Levenberg–Marquardt stops on with a collapsed trust
    /// region (k3 of the Freedom 6S at ω = 100 rad/s: 0.148 → 0.110 where it stopped at
    /// 0.147), at one Jacobian per accepted step (finite differences, or Broyden's update
    /// between them with --jacobian-refresh). Default: trf.
    #[arg(long, value_enum, default_value = "trf")]
    pub predictor_optimiser: OptimiserArg,
    /// Optimiser of the whole files' stage (the cost itself) and of the refit that
    /// releases held values: `lm` or `trf`, as --predictor-optimiser. The horizons',
    /// segments' and equation error's stages run `lm`.
    #[arg(long, value_enum, default_value = "lm")]
    pub whole_files_optimiser: OptimiserArg,
    /// Initial positions of the free joints in every file: `estimate`d with the parameters
    /// at the whole files' stage (as MATLAB `oe`/`pem` with `InitialCondition = 'estimate'`;
    /// the first sample carries the sensor noise, which a trajectory sensitive to its start
    /// carries to every later sample: the Freedom 6S's k4 at the true parameters has q5 at
    /// 1.52 σ from the first sample, 1.01 σ from the estimate) or the first `measured`
    /// sample, as the thesis. Default: estimate for the coupled method, measured for the
    /// isolated.
    #[arg(long, value_parser = ["estimate", "measured"])]
    pub initial_positions: Option<String>,
    /// Joint fit of the sequence's steps: `after` the step-by-step fits, every parameter the
    /// steps fit is refined on every step's files at once (each file in its configuration,
    /// every free joint weighted 1), from the values the steps left; its standard errors
    /// and identifiable calls are those of all the data, not conditional on values earlier
    /// steps fixed. `only`: the joint fit alone from the plant's values (a plant a sequence
    /// run wrote). It covers the steps up to --config's (all without it); their files must
    /// be in --data. `off`: the steps alone (the thesis).
    #[arg(long, default_value = "off", value_parser = ["off", "after", "only"])]
    pub joint_fit: String,
    /// The position sensor's noise σ (rad or m) when known, such as 2e-4: used instead of
    /// the σ̂ estimated from each file (robust 5th differences of the positions) for the
    /// noise-floor check, the prior's weight and the predictor step's check. `estimate`:
    /// from the data.
    #[arg(long, default_value = "estimate", value_name = "SIGMA|estimate")]
    pub noise_sigma: String,
    /// Largest motion (rad) allowed of a locked joint in a file.
    #[arg(value_parser = parse_positive, long, default_value_t = 0.01)]
    pub locked_tolerance: f64,
    /// Rigid-body symbols each step fits: `spanning` (a set of them that spans the
    /// configuration's base parameters where its files hold the locked joints, by column
    /// pivoting on ∂β/∂s; the others held at their values and left undetermined for later
    /// steps: the same reachable dynamics without the exact ties a finite-difference
    /// Jacobian fills with noise; on the isolated sequence of the Freedom 6S it takes c4
    /// and c5 to the noise floor where `all` stalls) or `all` (every symbol the step
    /// identifies or carries; the least change resolves their exact ties afterwards).
    #[arg(long, default_value = "spanning", value_parser = ["all", "spanning"])]
    pub rigid_body: String,
}

impl OutputErrorArgs {
    fn options<'a>(&'a self, method: &str) -> Result<OutputErrorOptions> {
        use lockstep::identify::output_error::TimeWeighting;
        // The coupled method's defaults are the settings that took k1..k4 of the Freedom
        // 6S sequence to the noise floor (README); the isolated method keeps the thesis's
        // growing horizons.
        let coupled = method == "coupled";
        let pick = |given: &'a Option<String>, coupled_default: &'a str, isolated: &'a str| {
            given
                .as_deref()
                .unwrap_or(if coupled { coupled_default } else { isolated })
        };
        let horizons_arg = pick(&self.horizons, "none", "0.05,0.1,0.25,0.5,1");
        let predictor_arg = pick(&self.predictor, "100,30,10,3,1", "none");
        let equation_error_arg = pick(&self.equation_error, "on", "off");
        let initial_positions_arg = pick(&self.initial_positions, "estimate", "measured");
        let predictor_step_arg = pick(&self.predictor_step, "1/2000", "none");
        let jacobian_refresh = self.jacobian_refresh.unwrap_or(if coupled { 4 } else { 1 });
        let weighting =
            match self
                .cost
                .as_deref()
                .unwrap_or(if method == "isolated" { "4.2" } else { "4.3" })
            {
                "4.2" => TimeWeighting::HalfFirst,
                "4.3" => TimeWeighting::SkipTransient(self.skip),
                other => bail!("--cost: expected 4.2 or 4.3, got '{other}'"),
            };
        if !(self.step > 0.0 && self.step.is_finite()) {
            bail!(
                "--step: expected a positive step in seconds, got {}",
                self.step
            );
        }
        if !(self.weight > 0.0 && self.weight.is_finite()) {
            bail!("--weight: expected a positive weight, got {}", self.weight);
        }
        if self.starts == 0 || self.max_iter == 0 || jacobian_refresh == 0 {
            bail!("--starts, --max-iter and --jacobian-refresh must be at least 1");
        }
        if !(self.xtol > 0.0 && self.ftol > 0.0) {
            bail!("--xtol and --ftol must be positive");
        }
        let horizons = positive_list(
            "--horizons",
            horizons_arg,
            "increasing fractions in (0, 1] ending with 1 such as 0.1,0.5,1",
        )?;
        if !horizons.is_empty()
            && (horizons.last() != Some(&1.0)
                || horizons.iter().any(|&h| h > 1.0)
                || horizons.windows(2).any(|w| w[0] >= w[1]))
        {
            bail!(
                "--horizons: expected 'none' or increasing fractions in (0, 1] ending with 1, got '{}'",
                horizons_arg
            );
        }
        let segments = positive_list(
            "--segments",
            &self.segments,
            "lengths in seconds such as 1,4",
        )?;
        let predictor = positive_list(
            "--predictor",
            predictor_arg,
            "bandwidths in rad/s such as 3,1",
        )?;
        let hold = self.hold;
        let options = OutputErrorOptions {
            weighting,
            interest_weight: self.weight,
            h: self.step,
            integrator: self.integrator,
            hold,
            xtol: self.xtol,
            ftol: self.ftol,
            max_iter: self.max_iter,
            jacobian_refresh,
            starts: self.starts,
            seed: self.seed,
            horizons,
            segments,
            predictor,
            least_change: self.least_change == "on",
            prior: match self.prior.trim() {
                "none" => None,
                x => match x.parse::<f64>() {
                    Ok(t) if t > 0.0 && t.is_finite() => Some(t),
                    _ => bail!("--prior: expected 'none' or a positive relative spread such as 0.1, got '{x}'"),
                },
            },
            carried_prior: self.carried_prior == "on",
            equation_error: match equation_error_arg.trim() {
                "off" | "none" => None,
                "on" => Some(Cutoff::Residual),
                x => match x.parse::<f64>() {
                    Ok(c) if c > 0.0 && c < 1.0 => Some(Cutoff::Fixed(c)),
                    _ => bail!("--equation-error: expected on, off or a filter cut-off in (0, 1) of the Nyquist frequency such as 0.2, got '{x}'"),
                },
            },
            predictor_step: match predictor_step_arg.trim() {
                "none" => None,
                x => match parse_number(x) {
                    Ok(h) if h > 0.0 && h.is_finite() => Some((h, Integrator::Etdrk4)),
                    _ => bail!("--predictor-step: expected 'none' or a positive step in seconds such as 1/2000, got '{x}'"),
                },
            },
            predictor_optimiser: self.predictor_optimiser.into(),
            whole_files_optimiser: self.whole_files_optimiser.into(),
            estimate_initial_positions: initial_positions_arg == "estimate",
            noise_sigma: match self.noise_sigma.trim() {
                "estimate" => None,
                x => match parse_number(x) {
                    Ok(s) if s > 0.0 && s.is_finite() => Some(s),
                    _ => bail!("--noise-sigma: expected 'estimate' or the sensor's positive noise σ such as 2e-4, got '{x}'"),
                },
            },
            ..OutputErrorOptions::default()
        };
        if !options.fits_the_plant_values() {
            bail!(
                "--horizons none{}: nothing would fit the plant's values; set --equation-error, --predictor or --segments, or give horizons such as 1",
                if coupled && self.horizons.is_none() { " (the coupled method's default)" } else { "" }
            );
        }
        Ok(options)
    }
}

/// A comma-separated list of positive numbers for `flag`, or `none` (empty list).
fn positive_list(flag: &str, value: &str, what: &str) -> Result<Vec<f64>> {
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
fn identify_sequence(
    common: &Common,
    method: &str,
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
    let opts = SequenceOptions {
        sequence: method.to_string(),
        only: common.config.clone(),
        fit: oe.options(method)?,
        locked_tolerance: oe.locked_tolerance,
        out,
        resume: oe.resume,
        rigid_body: if oe.rigid_body == "spanning" {
            RigidBodyFit::Spanning
        } else {
            RigidBodyFit::All
        },
        joint: match oe.joint_fit.as_str() {
            "after" => JointFitMode::After,
            "only" => JointFitMode::Only,
            _ => JointFitMode::Off,
        },
        release_held: oe.release_held == "on",
        tie_reach: oe.tie_reach == "on",
        balance: oe.balance == "on",
    };
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

/// Run a parsed command line.
///
/// # Errors
/// Any failure, with a message naming the file or option.
pub fn run(cli: Cli) -> Result<()> {
    // A command's outputs are written together at its end, or not at all
    // ([`lockstep::files::all_or_nothing`]); the identification sequences instead keep each
    // completed step's files, so that an interrupted run can be resumed.
    let keeps_each_step =
        matches!(&cli.command, Command::Identify { method, .. } if method != "idim");
    if keeps_each_step {
        run_command(cli)
    } else {
        lockstep::files::all_or_nothing(|| run_command(cli))
    }
}

fn run_command(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Demo { out } => {
            lockstep::files::check_output_dir(&out)?;
            let r = lockstep::demo::run(&lockstep::demo::bundled_data_dir(), &out)?;
            lockstep::out!("{}", r.text);
            lockstep::outln!("\nOutputs (plant files, residual CSVs, plots as PNG and SVG, summary.txt) are in {}", r.out.display());
        }
        Command::Identify {
            common,
            method,
            out,
            allow_inconsistent,
            oe,
        } => {
            match method.as_str() {
                "idim" => {}
                "isolated" | "coupled" => return identify_sequence(&common, &method, out, &oe),
                other => bail!("--method: expected idim, isolated or coupled, got '{other}'"),
            }
            let config = common.config.as_deref().unwrap_or("full");
            if let Some(out) = &out {
                lockstep::files::check_writable(&[out])?;
            }
            let (mut plant, records, opts) = common.load()?;
            let obs = observation(&plant, config, &records, &opts)?;
            // A rank-deficient regressor (every serial arm's) is fitted on its base
            // parameters, grouped at the records' locked positions; the dependent ones keep
            // the plant's values.
            let conf = lockstep::util::configuration(plant.model, config)?;
            let values = plant.values_with_barycentric()?;
            let locked_at: Vec<Vec<f64>> = records
                .iter()
                .map(|r| r.q.iter().map(|q| q[0]).collect())
                .collect();
            let fit = lockstep::identify::idim::least_squares_base(
                &obs,
                plant.model,
                conf,
                &locked_at,
                &|n| values.get(n).copied(),
            )?;
            lockstep::outln!(
                "IDIM-LS, plant {}, configuration {}, {} record(s)",
                common.plant.display(),
                config,
                records.len()
            );
            lockstep::out!("{}", fit_table(&fit));
            if let Some(out) = out {
                fit.apply(&mut plant)?;
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
        }
        Command::Compare { common, space, out } => {
            lockstep::files::check_output_dir(&out)?;
            let (plant, inputs) = common.inputs(&space)?;
            compare_command(&plant, &inputs, &inputs.load(&plant)?, &out)?;
        }
        Command::Diagnose {
            common,
            space,
            top,
            apply,
            out,
        } => {
            if let Some(out) = &out {
                lockstep::files::check_writable(&[out])?;
            }
            let (plant, inputs) = common.inputs(&space)?;
            let data = inputs.load(&plant)?;
            if let (Some(Apply::AllSignificant), Some(out)) = (apply, &out) {
                // The loop diagnoses (and prints) the plant itself, before each step.
                let done = apply_all_command(&plant, &inputs, &data, out, top)?;
                lockstep::outln!(
                    "{}; wrote {} ({} steps applied, history: {} steps)",
                    done.end,
                    out.display(),
                    done.steps.len(),
                    done.plant.history.len()
                );
                return Ok(());
            }
            let results = diagnose(&plant, &inputs, &data)?;
            for (title, findings, above_noise) in &results {
                lockstep::outln!("plant {}, {title}:", plant.name());
                lockstep::out!(
                    "{}",
                    lockstep::diagnose::table_with(findings, top, above_noise)
                );
            }
            if let (Some(Apply::Finding(k)), Some(out)) = (apply, out) {
                let r = apply_finding(&plant, &inputs, &data, &results[0].1, k, &out)?;
                lockstep::outln!("applied finding {k} and refitted jointly:");
                lockstep::out!("{}", refit_table(&r));
                lockstep::outln!(
                    "wrote {} (history: {} steps)",
                    out.display(),
                    r.plant.history.len()
                );
            }
        }
        Command::Refit {
            common,
            space,
            params,
            change,
            out,
        } => {
            let out = out.unwrap_or_else(|| common.plant.clone());
            lockstep::files::check_writable(&[&out])?;
            let (plant, inputs) = common.inputs(&space)?;
            let change = change.unwrap_or_else(|| format!("refitted {}", params.join(", ")));
            let r = refit_command(&plant, &inputs, &params, &change, &out)?;
            lockstep::out!("{}", refit_table(&r));
            lockstep::outln!("wrote {}", out.display());
        }
        Command::Effect {
            action:
                EffectAction::Add {
                    kind,
                    plant,
                    joint,
                    from,
                    to,
                    set,
                    bound,
                    out,
                },
        } => {
            let p = Plant::load(&plant)?;
            let out = out.unwrap_or_else(|| plant.clone());
            lockstep::files::check_writable(&[&out])?;
            let kind = if kind == "coupling" {
                "input_coupling".to_string()
            } else {
                kind
            };
            let set: Vec<(String, f64)> = merged("--set", set)?.into_iter().collect();
            let (new, effect) = effect_add(
                &p,
                &kind,
                joint.as_deref(),
                (from.as_deref(), to.as_deref()),
                &set,
                &bound,
                &out,
            )?;
            let added = effect.parameter_names();
            lockstep::outln!(
                "added {kind} to {}: {}",
                out.display(),
                added
                    .iter()
                    .map(|n| format!("{n} = {}", new.parameters[n]))
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
        Command::Report {
            common,
            space,
            top,
            out,
        } => {
            lockstep::files::check_output_dir(&out)?;
            let (plant, inputs) = common.inputs(&space)?;
            let path = report_command(&plant, &inputs, &out, top)?;
            lockstep::outln!("wrote {}", path.display());
        }
        Command::Excite {
            model,
            table,
            test,
            config,
            duration,
            rate,
            excitation,
            out,
        } => {
            let m = model_named(&model)?;
            let inputs: Vec<&std::path::Path> = excitation.iter().map(|p| p.as_path()).collect();
            lockstep::measurement::check_side_file_target(&out, &inputs)?;
            let ex = match &excitation {
                Some(p) => lockstep::excitation::Excitations::load(p, m)?,
                None => lockstep::excitation::Excitations::bundled(m)?,
            };
            let e = lockstep::synthetic::excite(
                m,
                &ex,
                &table,
                test.as_deref(),
                &config,
                duration,
                rate,
            )?;
            e.write(&out)?;
            if !e.left_out.is_empty() {
                lockstep::errln!(
                    "note: {} locked in configuration {config}: their signals of table {table} are not applied",
                    e.left_out.join(", ")
                );
            }
            lockstep::outln!(
                "wrote {} ({} samples, {}) and its side file {}",
                out.display(),
                e.t.len(),
                e.side.description,
                out.with_extension("toml").display()
            );
        }
        Command::Simulate {
            plant,
            input,
            config,
            locked,
            initial,
            step,
            integrator,
            hold,
            noise,
            quantisation,
            seed,
            max_speed,
            allow_inconsistent,
            out,
        } => {
            lockstep::measurement::check_side_file_target(&out, &[&plant, &input])?;
            let p = Plant::load(&plant)?;
            let opts = lockstep::synthetic::SimulateOptions {
                config,
                locked: merged("--locked", locked)?,
                initial: merged("--initial", initial)?,
                h: step,
                integrator,
                hold,
                noise,
                quantisation,
                seed,
                max_speed,
                policy: if allow_inconsistent {
                    lockstep::plant::ConsistencyPolicy::Warn
                } else {
                    lockstep::plant::ConsistencyPolicy::Refuse
                },
            };
            let started = std::time::Instant::now();
            let sim = lockstep::synthetic::simulate_file(&p, &input, &opts)?;
            let elapsed = started.elapsed().as_secs_f64();
            for f in &sim.findings {
                lockstep::errln!("warning: {}: {f}", plant.display());
            }
            for n in &sim.notes {
                lockstep::errln!("note: {n}");
            }
            sim.write(&out)?;
            let m = &sim.measurement;
            let span = m.t[m.len() - 1] - m.t[0];
            lockstep::outln!(
                "simulated {span:.3} s of configuration {} in {elapsed:.3} s ({:.0} RK4 steps/s); wrote {} and {}",
                sim.side.configuration.as_deref().unwrap_or("?"),
                span / step / elapsed.max(1e-9),
                out.display(),
                out.with_extension("toml").display()
            );
        }
        Command::Check { plant, against } => {
            let p = Plant::load(&plant)?;
            let m = p.model;
            let reference = match &against {
                Some(other) => {
                    let o = Plant::load(other)?;
                    if o.model.name != m.name {
                        bail!(
                            "{}: model '{}', but {} is of model '{}'",
                            other.display(),
                            o.model.name,
                            plant.display(),
                            m.name
                        );
                    }
                    Some((other, o))
                }
                None => None,
            };
            lockstep::outln!(
                "plant {} (model {}): {}",
                plant.display(),
                m.name,
                p.description
            );
            let all = p.consistency(&p.barycentric(None)?, None);
            if all.is_empty() {
                lockstep::outln!("every link is physically consistent");
            }
            for f in &all {
                lockstep::outln!(
                    "  {} {f}",
                    if f.is_blocking() {
                        "IMPOSSIBLE "
                    } else {
                        "implausible"
                    }
                );
            }
            for c in m.configurations {
                let q = vec![0.0; m.joints.len()];
                match p.simulator(c.name, &q, lockstep::plant::ConsistencyPolicy::Warn) {
                    Ok(s) => {
                        let blocking = s.findings.iter().filter(|f| f.is_blocking()).count();
                        lockstep::outln!(
                            "  configuration {:<6} simulates{}",
                            c.name,
                            if blocking > 0 {
                                format!(" only with --allow-inconsistent ({blocking} impossible link(s) in its equations)")
                            } else {
                                String::new()
                            }
                        );
                    }
                    Err(e) => {
                        lockstep::outln!("  configuration {:<6} cannot simulate: {e:#}", c.name)
                    }
                }
            }
            if let Some((other, o)) = reference {
                let outside = p.outside_bounds(&o.parameters);
                if outside.is_empty() {
                    lockstep::outln!("every value of {} lies within the bounds", other.display());
                } else {
                    lockstep::outln!(
                        "{} value(s) of {} outside the bounds (a fit from this plant cannot reach them):",
                        outside.len(),
                        other.display()
                    );
                }
                for (n, v, (lo, hi)) in &outside {
                    lockstep::outln!("  {n} = {v:.5e} outside [{lo:.5e}, {hi:.5e}]");
                }
            }
        }
        Command::Params { model, out } => {
            let m = model_named(&model)?;
            let occ = occurrence(m);
            let bases: Vec<_> = m
                .configurations
                .iter()
                .map(|c| base_parameters(m, c))
                .collect();
            // The files first: a reader that closes the pipe early loses nothing.
            let md = markdown(&occ, &bases);
            let json = serde_json::to_string_pretty(&serde_json::json!({
                "occurrence": occ,
                "base_parameters": bases,
            }))?;
            lockstep::files::check_output_dir(&out)?;
            lockstep::files::write_all_atomic(&[
                (out.join("parameters.md"), md.into_bytes()),
                (out.join("parameters.json"), json.into_bytes()),
            ])?;
            for seq in &occ.sequences {
                lockstep::outln!(
                    "sequence {}: {} first identified per step",
                    seq.name,
                    occ.quantity
                );
                for (c, first) in &seq.steps {
                    lockstep::outln!("  {c:<6} {:>3}  {}", first.len(), first.join(", "));
                }
                lockstep::outln!(
                    "  nowhere {:>2}  {}",
                    seq.nowhere.len(),
                    seq.nowhere.join(", ")
                );
            }
            for b in &bases {
                lockstep::outln!(
                    "configuration {}: {} barycentric parameters appear, {} base parameters",
                    b.configuration,
                    b.appearing,
                    b.rank
                );
            }
            lockstep::outln!(
                "wrote {0}/parameters.md and {0}/parameters.json",
                out.display()
            );
        }
        Command::Closedloop {
            spec,
            plant,
            gains,
            measured,
            duration,
            out,
        } => lockstep::report::control::closedloop_command(
            &bundled_path(&spec),
            plant.as_deref(),
            &gains,
            &measured,
            duration,
            &out,
        )?,
        Command::Wall { action, args } => match action {
            None => lockstep::report::control::wall_command(&bundled_wall_args(args))?,
            Some(WallAction::Tune { args }) => {
                lockstep::report::control::tune_command(&bundled_wall_args(args))?
            }
        },
        Command::Models => {
            for m in generated::MODELS {
                lockstep::outln!(
                    "{}: joints {}; {} barycentric parameters ({})",
                    m.name,
                    m.joints.join(", "),
                    m.params.len(),
                    m.params.join(", ")
                );
                for c in m.configurations {
                    let free: Vec<&str> = c.free.iter().map(|&j| m.joints[j]).collect();
                    lockstep::outln!(
                        "  configuration {}: free {}; parameters present {}",
                        c.name,
                        free.join(", "),
                        c.params_present.len()
                    );
                }
            }
        }
    }
    Ok(())
}

/// A default data path of the repository: as given when it exists, else under the crate's
/// own directory (so the defaults work from any working directory of a source checkout).
fn bundled_path(p: &std::path::Path) -> PathBuf {
    if p.exists() || p.is_absolute() {
        return p.to_path_buf();
    }
    let alt = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(p);
    if alt.exists() {
        alt
    } else {
        p.to_path_buf()
    }
}

fn bundled_wall_args(a: WallArgs) -> lockstep::report::control::WallRun {
    lockstep::report::control::WallRun {
        spec: bundled_path(&a.spec),
        rules: a.rules,
        rate: a.rate,
        out: a.out,
    }
}

/// What `diagnose --apply` applies: one finding by rank, or the loop.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Apply {
    /// Finding K (1-based).
    Finding(usize),
    /// Apply the leading finding until nothing significant is missing.
    AllSignificant,
}

impl std::str::FromStr for Apply {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "all-significant" => Ok(Apply::AllSignificant),
            _ => match s.parse::<usize>() {
                Ok(k) if k >= 1 => Ok(Apply::Finding(k)),
                _ => Err(format!(
                    "expected a finding's rank (1, 2, …) or 'all-significant', got '{s}'"
                )),
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Apply;

    #[test]
    fn apply_takes_a_rank_or_all_significant_and_refuses_the_rest() {
        assert_eq!("2".parse::<Apply>(), Ok(Apply::Finding(2)));
        assert_eq!(
            "all-significant".parse::<Apply>(),
            Ok(Apply::AllSignificant)
        );
        for bad in ["0", "-1", "all", ""] {
            let e = bad.parse::<Apply>().unwrap_err();
            assert!(e.contains("all-significant") && e.contains(bad), "{e}");
        }
    }
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
