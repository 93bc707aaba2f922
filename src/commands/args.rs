//! Options shared by several commands, and their parsers.

use super::*;
/// Plant edits.
#[derive(Debug, Subcommand)]
pub enum EffectAction {
    /// Add an effect with neutral values (no effect: levels 0, gain and friction-bias
    /// factor 1; a user-defined effect's parameters 0); `--set` and `--bound` give values
    /// and bounds.
    Add {
        /// Kind: viscous, coulomb, asymmetric_friction, offset, gain, stribeck, lugre,
        /// spring, friction_bias, input_coupling (alias: coupling), armature, backlash, or
        /// expression (a user-defined effect: --name, --torque, --params).
        kind: String,
        /// Plant file.
        #[arg(long)]
        plant: PathBuf,
        /// Joint the effect acts on (expression: one or more, e.g. q4,q5).
        #[arg(long)]
        joint: Option<String>,
        /// expression: the effect's name, unique in the plant.
        #[arg(long)]
        name: Option<String>,
        /// expression: the torque it takes from each joint, e.g. "K3*(q_q3 - qeq3)^3"
        /// (symbols q_J, qd_J, qdd_J, tau_J, z_J of joint J, t the time; functions sin cos
        /// tan exp ln sqrt abs sign tanh atan sinh cosh min max; ^ power).
        #[arg(long)]
        torque: Option<String>,
        /// expression: its parameters, e.g. K3,qeq3.
        #[arg(long, value_delimiter = ',')]
        params: Vec<String>,
        /// input_coupling: the joint whose command is passed on.
        #[arg(long)]
        from: Option<String>,
        /// input_coupling: the joint that receives it.
        #[arg(long)]
        to: Option<String>,
        /// Values, e.g. Ks_q3=0.01,qeq_q3=0.2 (repeatable).
        #[arg(long, value_parser = parse_positions)]
        set: Vec<PositionList>,
        /// Bounds, e.g. Ks_q3=0:0.1 (repeatable).
        #[arg(long, value_parser = parse_bound)]
        bound: Vec<(String, f64, f64)>,
        /// Plant file to write (default: the plant file itself).
        #[arg(long)]
        out: Option<PathBuf>,
    },
}

/// `lockstep plant …`.
#[derive(Debug, Subcommand)]
pub enum PlantAction {
    /// Write a complete starting plant for a model: every inertial symbol at the model
    /// file's value (its `[defaults]`, a URDF's `<inertial>` numbers), and the effects asked
    /// for on the joints asked for, at neutral values (no effect: levels 0).
    New {
        /// Model name (see `lockstep models`).
        #[arg(long)]
        model: String,
        /// Effects on each joint, e.g. viscous,coulomb,offset,armature (default: none).
        #[arg(long, value_delimiter = ',')]
        effects: Vec<String>,
        /// The joints they act on (default: every joint).
        #[arg(long, value_delimiter = ',')]
        joints: Vec<String>,
        /// Plant file to write.
        #[arg(long, short)]
        out: PathBuf,
    },
}

/// Where compare, diagnose and refit work, and the output-space settings.
#[derive(Debug, Clone, Args)]
pub struct SpaceArgs {
    /// auto (by the data: torque space where the records' torques are measured, output
    /// space where they are commands — the side file's `torque`, else `commanded` where it
    /// declares a `hold`), torque or output. Printed.
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

/// The output-space fits of diagnose, refit and report (not compare: it fits nothing but
/// the initial positions).
#[derive(Debug, Clone, Args)]
pub struct FitArgs {
    /// Output space: the fits' Jacobian of the simulated positions: sensitivities
    /// (integrated beside the state: one augmented simulation per file), differences (one
    /// simulation per file and parameter), or auto (sensitivities from 8 fitted values).
    /// Default: differences. Where sensitivities are not available (the etdrk4 integrator,
    /// user-defined effects, backlash) differences are used.
    #[arg(long)]
    pub jacobian: Option<lockstep::identify::output_error::JacobianMethod>,
}

impl FitArgs {
    /// `inputs` with these settings (the preset's where a flag is not given).
    pub fn apply(&self, inputs: &mut Inputs) {
        inputs.jacobian = self.jacobian;
    }

    /// # Errors
    /// `--jacobian` given with `--controller`: DIDIM's iterations are least squares on the
    /// closed loop's simulated states, with no Jacobian of simulated positions.
    pub fn closed_loop(&self) -> Result<()> {
        if let Some(j) = self.jacobian {
            bail!("--jacobian {j}: the closed-loop fits (DIDIM, --controller) are least squares on the simulated states and take no Jacobian of simulated positions; drop --jacobian");
        }
        Ok(())
    }
}

pub fn parse_bound(s: &str) -> Result<(String, f64, f64), String> {
    let (n, r) = s
        .split_once('=')
        .ok_or_else(|| format!("'{s}': expected name=lower:upper, e.g. Ks_q3=0:0.1"))?;
    let (lo, hi) = r
        .split_once(':')
        .ok_or_else(|| format!("'{s}': expected name=lower:upper, e.g. Ks_q3=0:0.1"))?;
    Ok((
        n.trim().to_string(),
        parse_number(lo.trim()).map_err(|e| format!("'{s}': {e}"))?,
        parse_number(hi.trim()).map_err(|e| format!("'{s}': {e}"))?,
    ))
}

impl Common {
    pub fn inputs(&self, space: &SpaceArgs) -> Result<(Plant, Inputs)> {
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
                data: self.files.data.clone(),
                config: self.config.clone(),
                space: space.space.clone(),
                idim,
                preparation: self.preparation(),
                h: space.step,
                integrator: space.integrator,
                skip: space.skip,
                locked_tolerance: space.locked_tolerance,
                estimate_initial: space.initial == "estimate",
                hold: space.hold,
                refit_values: lockstep::diagnose::OutputOptions::default().refit_values,
                candidates: Vec::new(),
                jacobian: None,
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

pub fn parse_number(s: &str) -> Result<f64, String> {
    lockstep::excitation::Value::Expr(s.to_string())
        .eval()
        .map_err(|e| format!("{e:#}"))
}

/// A positive finite number (fractions accepted).
pub fn parse_positive(s: &str) -> Result<f64, String> {
    match parse_number(s)? {
        x if x > 0.0 => Ok(x),
        x => Err(format!("expected a positive number, got {x}")),
    }
}

/// A finite number ≥ 0 (fractions accepted).
pub fn parse_non_negative(s: &str) -> Result<f64, String> {
    match parse_number(s)? {
        x if x >= 0.0 => Ok(x),
        x => Err(format!("expected a number ≥ 0, got {x}")),
    }
}

pub fn parse_positions(s: &str) -> Result<PositionList, String> {
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
pub fn merged(
    flag: &str,
    lists: Vec<PositionList>,
) -> Result<std::collections::BTreeMap<String, f64>> {
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

pub fn model_named(name: &str) -> Result<&'static generated::Model> {
    lockstep::util::model(name).map_err(|e| anyhow::anyhow!("--model: {e}"))
}

/// The plant and the measurements a command works on.
#[derive(Debug, Clone, Args)]
pub struct PlantAndData {
    /// Plant file (model + effects + parameter values).
    #[arg(long)]
    pub plant: PathBuf,
    /// Measurement files (CSV or .mat; a side file <name>.toml may map the columns and name
    /// the configuration), or directories of them.
    #[arg(long, required = true, num_args = 1..)]
    pub data: Vec<PathBuf>,
}

/// Options shared by identify idim, compare, diagnose and refit.
#[derive(Debug, Args)]
pub struct Common {
    #[command(flatten)]
    pub files: PlantAndData,
    /// Configuration (set of free joints) of the data (default `full`).
    #[arg(long)]
    pub config: Option<String>,
    /// Cut-off of the zero-phase Butterworth on positions (Hz). Default: the side file's
    /// [preparation], else twice the decimation's band, which is chosen from the data (3 ×
    /// the band holding 99.9 % of the velocity's power); printed.
    #[arg(value_parser = parse_positive, long)]
    #[arg(help_heading = "Torque space (IDIM-LS, and compare/diagnose in torque space)")]
    pub cutoff: Option<f64>,
    /// Order of that Butterworth.
    #[arg(long, default_value_t = 4)]
    #[arg(help_heading = "Torque space (IDIM-LS, and compare/diagnose in torque space)")]
    pub order: usize,
    /// Parallel decimation factor. Default: the side file's [preparation], else the
    /// largest whose anti-aliasing filter passes the band (half the cut-off, or the one
    /// chosen from the data).
    #[arg(long)]
    #[arg(help_heading = "Torque space (IDIM-LS, and compare/diagnose in torque space)")]
    pub decimate: Option<usize>,
    /// How q̇ and q̈ are taken from the positions: central (differences) or bandlimited
    /// (exact up to 0.4 of the sampling rate). Default: the side file's [preparation], else
    /// central where it is within 0.1 % across the band.
    #[arg(long)]
    #[arg(help_heading = "Torque space (IDIM-LS, and compare/diagnose in torque space)")]
    pub differentiator: Option<lockstep::signal::Differentiator>,
    /// Only the samples from FROM to TO seconds (`0.1:5.5`) enter the fit or the
    /// comparison; the records are filtered whole first. Train on one window, validate on
    /// another.
    #[arg(long, value_parser = parse_window)]
    #[arg(help_heading = "Torque space (IDIM-LS, and compare/diagnose in torque space)")]
    pub window: Option<(f64, f64)>,
    /// Leave out each joint's rows slower than this: a speed (`0.05`, rad/s or m/s) or a
    /// share of the joint's peak speed (`1%`). Coulomb friction's sign(q̇) is not the
    /// presliding regime near rest.
    #[arg(long, value_parser = parse_min_speed)]
    #[arg(help_heading = "Torque space (IDIM-LS, and compare/diagnose in torque space)")]
    pub min_speed: Option<lockstep::identify::idim::MinSpeed>,
}

/// `0.05` (a speed) or `1%` (of each joint's peak speed).
fn parse_min_speed(s: &str) -> Result<lockstep::identify::idim::MinSpeed, String> {
    use lockstep::identify::idim::MinSpeed;
    let bad = || format!("'{s}': expected a speed (0.05) or a percentage of the peak speed (1%)");
    if let Some(p) = s.strip_suffix('%') {
        let v: f64 = p.trim().parse().map_err(|_| bad())?;
        if !(v.is_finite() && (0.0..100.0).contains(&v)) {
            return Err(bad());
        }
        return Ok(MinSpeed::FractionOfPeak(v / 100.0));
    }
    let v: f64 = s.trim().parse().map_err(|_| bad())?;
    if !(v.is_finite() && v >= 0.0) {
        return Err(bad());
    }
    Ok(MinSpeed::Absolute(v))
}

/// `FROM:TO` in seconds, FROM < TO.
fn parse_window(s: &str) -> Result<(f64, f64), String> {
    let (a, b) = s
        .split_once(':')
        .ok_or_else(|| format!("'{s}': expected FROM:TO in seconds, e.g. 0.1:5.5"))?;
    let parse = |x: &str| {
        x.trim()
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| format!("'{x}': expected a number of seconds"))
    };
    let (from, to) = (parse(a)?, parse(b)?);
    if from >= to {
        return Err(format!("'{s}': FROM must be before TO"));
    }
    Ok((from, to))
}

impl Common {
    /// The plant and the IDIM preparation options (checked).
    pub fn load_plant(&self) -> Result<(Plant, IdimOptions)> {
        let plant = Plant::load(&self.files.plant)?;
        if self.order == 0 || self.order > 12 {
            bail!("--order: expected 1 to 12, got {}", self.order);
        }
        if self.decimate == Some(0) {
            bail!("--decimate: expected 1 or more");
        }
        let defaults = IdimOptions::default();
        Ok((
            plant,
            IdimOptions {
                cutoff_hz: self.cutoff.unwrap_or(defaults.cutoff_hz),
                filter_order: self.order,
                decimation: self.decimate.unwrap_or(defaults.decimation),
                window: self.window,
                min_speed: self.min_speed,
                differentiator: defaults.differentiator,
                trim_moving_edges: false,
            },
        ))
    }

    /// The cut-off and decimation given on the command line.
    pub fn preparation(&self) -> lockstep::identify::preparation::Requested {
        lockstep::identify::preparation::Requested {
            cutoff_hz: self.cutoff,
            decimation: self.decimate,
            differentiator: self.differentiator,
        }
    }

    /// The plant, the torque-measured records and their preparation (the cut-off and
    /// decimation resolved for the records and printed).
    pub fn load(&self) -> Result<(Plant, Vec<Measurement>, IdimOptions)> {
        let (plant, opts) = self.load_plant()?;
        let (records, opts, said) = lockstep::report::diagnosis::torque_records(
            &plant,
            &self.files.data,
            self.config.as_deref().unwrap_or("full"),
            opts,
            &self.preparation(),
        )?;
        lockstep::outln!("preparation: {said}");
        Ok((plant, records, opts))
    }
}

/// A default data path of the repository: as given when it exists, else under the crate's
/// own directory (so the defaults work from any working directory of a source checkout).
pub fn bundled_path(p: &std::path::Path) -> PathBuf {
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

pub fn bundled_wall_args(a: WallArgs) -> lockstep::report::control::WallRun {
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

/// Options of `lockstep simulate`.
#[derive(Debug, Args)]
pub struct SimulateArgs {
    /// Plant file.
    #[arg(long)]
    pub plant: PathBuf,
    /// Torque file (.csv or .mat): t and tau_J of the free joints J.
    #[arg(long)]
    pub input: PathBuf,
    /// Configuration (default: the input's side file's).
    #[arg(long)]
    pub config: Option<String>,
    /// Locked-joint positions, e.g. q0=0.1,q1=-0.2 (rad or m; default 0 or the side
    /// file's; repeatable).
    #[arg(long, value_parser = parse_positions)]
    pub locked: Vec<PositionList>,
    /// Initial positions of free joints, e.g. q4=0.3 (default 0; at rest, z = 0;
    /// repeatable).
    #[arg(long, value_parser = parse_positions)]
    pub initial: Vec<PositionList>,
    /// Integration step (s), a number or a fraction such as 1/6000.
    #[arg(long, default_value = "1/6000", value_parser = parse_number)]
    pub step: f64,
    /// Integrator: rk4 or etdrk4 (exponential RK4 taking the friction damping exactly).
    #[arg(long, default_value = "rk4")]
    pub integrator: Integrator,
    /// How the torques are applied between samples: zoh, linear, cubic or bandlimited
    /// (default: the input's side file's `hold`, else zoh). Recorded in the output's side
    /// file.
    #[arg(long)]
    pub hold: Option<Hold>,
    /// Gaussian position noise σ (rad or m).
    #[arg(value_parser = parse_non_negative, long, default_value_t = 0.0)]
    pub noise: f64,
    /// Position quantisation step (rad or m).
    #[arg(value_parser = parse_non_negative, long, default_value_t = 0.0)]
    pub quantisation: f64,
    /// Noise seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Report divergence when a speed exceeds this (rad/s or m/s).
    #[arg(value_parser = parse_positive, long, default_value_t = 100.0)]
    pub max_speed: f64,
    /// Simulate even with physically impossible rigid-body parameters.
    #[arg(long)]
    pub allow_inconsistent: bool,
    /// Output measurement file (.csv or .mat); a side file .toml is written beside it.
    #[arg(long, short)]
    pub out: PathBuf,
}

impl SimulateArgs {
    /// The simulation options of the flags.
    ///
    /// # Errors
    /// A joint given twice in `--locked` or `--initial`.
    pub fn options(&self) -> Result<lockstep::synthetic::SimulateOptions> {
        Ok(lockstep::synthetic::SimulateOptions {
            config: self.config.clone(),
            locked: merged("--locked", self.locked.clone())?,
            initial: merged("--initial", self.initial.clone())?,
            h: self.step,
            integrator: self.integrator,
            hold: self.hold,
            noise: self.noise,
            quantisation: self.quantisation,
            seed: self.seed,
            max_speed: self.max_speed,
            policy: if self.allow_inconsistent {
                lockstep::plant::ConsistencyPolicy::Warn
            } else {
                lockstep::plant::ConsistencyPolicy::Refuse
            },
        })
    }
}
