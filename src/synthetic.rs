//! Synthetic data: sample a thesis excitation for a configuration (`lockstep excite`) and
//! run a plant on a torque file to make a measurement file (`lockstep simulate`), with any
//! effect of the plant file switched on, optional Gaussian sensor noise and quantisation.

use crate::excitation::{Excitations, Quantity};
use crate::measurement::{check_sampling, Measurement, SideFile, Table};
use crate::plant::{ConsistencyPolicy, Finding, Plant};
use crate::simulation::{Hold, InputSignal, State};
use crate::util::configuration;
use anyhow::{bail, Context, Result};
use generated::inertia::Xorshift;
use std::collections::BTreeMap;
use std::path::Path;

/// A sampled excitation.
#[derive(Debug, Clone)]
pub struct Excitation {
    /// Sample times (s).
    pub t: Vec<f64>,
    /// One column per joint (N·m or rad); zero on joints without a signal or locked.
    pub u: Vec<Vec<f64>>,
    /// Torques or position commands.
    pub quantity: Quantity,
    /// Side file recording the configuration and the source.
    pub side: SideFile,
    /// Joints whose signals the configuration does not apply (locked), by name.
    pub left_out: Vec<String>,
    /// The model's joint names, which name the columns ([`crate::names`]).
    pub joints: &'static [&'static str],
}

impl Excitation {
    /// Write `t` and one column per joint J (`tau_J` for torques, `qref_J` for position
    /// commands) as CSV or MAT (by extension), and the side file beside it, atomically.
    ///
    /// # Errors
    /// I/O errors, with the path.
    pub fn write(&self, path: &Path) -> Result<()> {
        let prefix = match self.quantity {
            Quantity::Torque => "tau",
            Quantity::Position => "qref",
        };
        let mut names = vec!["t".to_string()];
        let mut cols: Vec<&[f64]> = vec![&self.t];
        for (joint, c) in self.joints.iter().zip(&self.u) {
            names.push(crate::names::column(prefix, joint));
            cols.push(c);
        }
        crate::files::commit(vec![
            crate::measurement::stage_columns(path, &names, &cols)?,
            crate::measurement::stage_side_file(path, &self.side)?,
        ])
    }
}

/// Sample test `test` of table `table` of `ex` for configuration `config` of `model`, for
/// `duration` s at `rate` Hz.
///
/// # Errors
/// Unknown table, test or configuration; duration or rate not positive; no signal on any
/// free joint.
pub fn excite(
    model: &'static generated::Model,
    ex: &Excitations,
    table: &str,
    test: Option<&str>,
    config: &str,
    duration: f64,
    rate: f64,
) -> Result<Excitation> {
    if !(duration > 0.0 && duration.is_finite()) {
        bail!("--duration: expected a positive number of seconds, got {duration}");
    }
    if !(rate > 0.0 && rate.is_finite()) {
        bail!("--rate: expected a positive sampling rate in Hz, got {rate}");
    }
    // Samples × (time and one column per joint) × 8 bytes, about four copies while written.
    crate::util::check_memory(
        (duration * rate + 1.0) * (model.joints.len() + 1) as f64 * 8.0 * 4.0,
        &format!("--duration {duration} s at --rate {rate} Hz"),
    )?;
    let conf = configuration(model, config)?;
    let tab = ex.table(table)?;
    let test = tab.test(test)?;
    let (t, u, left_out) = test.sample(model.joints.len(), conf.free, duration, rate);
    if test.signals.iter().all(|s| !conf.free.contains(&s.joint)) {
        bail!(
            "table {} test '{}' drives {}, none of them free in configuration '{}' (free: {})",
            tab.id,
            test.name,
            test.signals
                .iter()
                .map(|s| model.joints[s.joint])
                .collect::<Vec<_>>()
                .join(", "),
            conf.name,
            conf.free
                .iter()
                .map(|&j| model.joints[j])
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    let side = SideFile {
        description: format!(
            "{} (thesis Table {}, test '{}')",
            tab.title, tab.id, test.name
        ),
        source: format!(
            "lockstep excite: model {}, {duration} s at {rate} Hz",
            model.name
        ),
        configuration: Some(conf.name.to_string()),
        ..SideFile::default()
    };
    Ok(Excitation {
        t,
        u,
        quantity: tab.quantity,
        side,
        left_out: left_out
            .iter()
            .map(|&j| model.joints[j].to_string())
            .collect(),
        joints: model.joints,
    })
}

/// Options of [`simulate_file`].
#[derive(Debug, Clone)]
pub struct SimulateOptions {
    /// Configuration; `None` takes the input's side file's.
    pub config: Option<String>,
    /// Locked-joint positions by joint name (override the input's side file; default 0).
    pub locked: BTreeMap<String, f64>,
    /// Initial positions of free joints by name (default 0), at rest, z = 0.
    pub initial: BTreeMap<String, f64>,
    /// Integration step (s).
    pub h: f64,
    /// Integration scheme.
    pub integrator: crate::simulation::Integrator,
    /// How the input torques are applied between samples; `None`: the input's side
    /// file's `hold`, else zero-order. Recorded in the output's side file.
    pub hold: Option<Hold>,
    /// Standard deviation of Gaussian position noise (rad or m), 0 for none.
    pub noise: f64,
    /// Position quantisation step (rad or m), 0 for none.
    pub quantisation: f64,
    /// Seed of the noise.
    pub seed: u64,
    /// Divergence bound on |q̇| (rad/s or m/s).
    pub max_speed: f64,
    /// Physical-consistency policy.
    pub policy: ConsistencyPolicy,
}

impl Default for SimulateOptions {
    fn default() -> Self {
        SimulateOptions {
            config: None,
            locked: BTreeMap::new(),
            initial: BTreeMap::new(),
            h: 1.0 / 6000.0,
            integrator: crate::simulation::Integrator::Rk4,
            hold: None,
            noise: 0.0,
            quantisation: 0.0,
            seed: 1,
            max_speed: 100.0,
            policy: ConsistencyPolicy::Refuse,
        }
    }
}

/// What [`simulate_file`] made.
#[derive(Debug, Clone)]
pub struct Simulated {
    /// The measurement: `t`, per joint J `tau_J` (as commanded), `q_J` (with noise and
    /// quantisation; locked joints at their positions) and `qd_J` (noise-free).
    pub measurement: Measurement,
    /// The model's joint names, which name the columns ([`crate::names`]).
    pub joints: &'static [&'static str],
    /// Its side file (configuration, locked positions, provenance).
    pub side: SideFile,
    /// Consistency findings the simulation went ahead with.
    pub findings: Vec<Finding>,
    /// Things the user should know (ignored torque columns of locked joints).
    pub notes: Vec<String>,
}

impl Simulated {
    /// Write the measurement (CSV or MAT by extension) and its side file, atomically.
    ///
    /// # Errors
    /// I/O errors, with the path.
    pub fn write(&self, path: &Path) -> Result<()> {
        crate::files::commit(vec![
            self.measurement.stage(path, self.joints)?,
            crate::measurement::stage_side_file(path, &self.side)?,
        ])
    }
}

/// Standard normal deviate (Box–Muller).
pub(crate) fn gaussian(rng: &mut Xorshift) -> f64 {
    let u1 = rng.uniform(f64::MIN_POSITIVE, 1.0);
    let u2 = rng.uniform(0.0, 1.0);
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

fn joint_map(
    model: &generated::Model,
    map: &BTreeMap<String, f64>,
    what: &str,
) -> Result<BTreeMap<usize, f64>> {
    map.iter()
        .map(|(k, v)| {
            let j = model.joints.iter().position(|x| x == k).with_context(|| {
                format!(
                    "{what}: unknown joint '{k}' (model '{}' has {})",
                    model.name,
                    model.joints.join(", ")
                )
            })?;
            if !v.is_finite() {
                bail!("{what}: '{k}' must be a finite position");
            }
            Ok((j, *v))
        })
        .collect()
}

/// Run `plant` on the torque file `input` (CSV or MAT: `t` and `tau{j}` of the free joints)
/// and return the simulated measurement at the input's sample times.
///
/// # Errors
/// Unreadable input or missing torque column of a free joint, no configuration, a position
/// for a joint of the wrong kind (locked given as initial or free as locked), bad step,
/// plant errors ([`Plant::simulator`]), divergence (time and joint).
pub fn simulate_file(plant: &Plant, input: &Path, opts: &SimulateOptions) -> Result<Simulated> {
    let model = plant.model;
    let nj = model.joints.len();
    if !(opts.h > 0.0 && opts.h.is_finite()) {
        bail!(
            "--step: expected a positive step in seconds, got {}",
            opts.h
        );
    }
    if !(opts.noise >= 0.0 && opts.noise.is_finite()) {
        bail!(
            "--noise: expected a finite σ ≥ 0 (rad or m), got {}",
            opts.noise
        );
    }
    if !(opts.quantisation >= 0.0 && opts.quantisation.is_finite()) {
        bail!(
            "--quantisation: expected a finite step ≥ 0 (rad or m), got {}",
            opts.quantisation
        );
    }
    let table = Table::read(input)?;
    let config = opts
        .config
        .clone()
        .or_else(|| table.side.configuration.clone())
        .with_context(|| {
            format!(
                "{}: no configuration: give --config (or 'configuration' in the side file)",
                input.display()
            )
        })?;
    let conf = configuration(model, &config)?;
    let mut locked = joint_map(model, &table.side.locked, "side file 'locked'")?;
    locked.extend(joint_map(model, &opts.locked, "--locked")?);
    let initial = joint_map(model, &opts.initial, "--initial")?;
    for j in locked.keys() {
        if conf.free.contains(j) && opts.locked.contains_key(model.joints[*j]) {
            bail!(
                "--locked: joint '{}' is free in configuration '{}'; give its start with --initial",
                model.joints[*j],
                conf.name
            );
        }
    }
    for j in initial.keys() {
        if !conf.free.contains(j) {
            bail!(
                "--initial: joint '{}' is locked in configuration '{}'; give its position with --locked",
                model.joints[*j],
                conf.name
            );
        }
    }
    let mut q_all = vec![0.0; nj];
    for (&j, &v) in locked.iter().chain(initial.iter()) {
        q_all[j] = v;
    }
    let configured = plant.simulator(conf.name, &q_all, opts.policy)?;
    let t = table.need("t")?;
    let mut notes = table.notes.clone();
    let mut tau_all = vec![vec![0.0; t.len()]; nj];
    for j in 0..nj {
        let name = crate::names::column("tau", model.joints[j]);
        let col = if conf.free.contains(&j) {
            Some(table.need_joint(model.joints, "tau", j)?)
        } else {
            table.joint_column(model.joints, "tau", j)?
        };
        if let Some(c) = col {
            if !conf.free.contains(&j) && c.iter().any(|&x| x != 0.0) {
                notes.push(format!(
                    "{name}: joint '{}' is locked in configuration '{}': its torque is recorded but not applied",
                    model.joints[j], conf.name
                ));
            }
            tau_all[j] = c;
        }
    }
    let dt = check_sampling(input, &t)?;
    if opts.h > dt * (1.0 + 1e-9) {
        bail!(
            "--step {} s is longer than the input's sample period {dt} s: each step would skip input samples; give a step of at most {dt} s (a fraction of it, such as 1/6000)",
            opts.h
        );
    }
    let tau_free: Vec<Vec<f64>> = conf.free.iter().map(|&j| tau_all[j].clone()).collect();
    let hold = opts.hold.or(table.side.hold).unwrap_or_default();
    let signal = InputSignal {
        t0: t[0],
        dt,
        tau: &tau_free,
        hold,
    };
    let x0 = State::at_rest(conf.free.iter().map(|&j| q_all[j]).collect());
    let mut sim = configured.model;
    sim.integrator = opts.integrator;
    let traj = sim
        .simulate_at(x0.clone(), opts.h, &signal, &t, opts.max_speed)
        .map_err(|d| {
            let joint = format!("'{}'", model.joints[conf.free[d.joint]]);
            // Advice on the step only where a smaller one was tried: a quarter of it.
            let quarter = opts.h / 4.0;
            let advice = if d.inertia_min_eigenvalue.is_some() {
                String::new()
            } else if sim
                .simulate_at(x0.clone(), quarter, &signal, &t, opts.max_speed)
                .is_ok()
            {
                format!("; it runs at a quarter of the step: give --step {quarter:e} or smaller")
            } else {
                format!("; it diverges at a quarter of the step ({quarter:e} s) too, so the step is not the cause: the plant runs away on these inputs, or such speeds are real and --max-speed is too low")
            };
            anyhow::anyhow!("{}: {}{advice}", input.display(), d.message(&joint))
        })?;
    let mut rng = Xorshift(opts.seed.max(1));
    let mut measure = |x: f64| {
        let y = if opts.noise > 0.0 {
            x + opts.noise * gaussian(&mut rng)
        } else {
            x
        };
        if opts.quantisation > 0.0 {
            (y / opts.quantisation).round() * opts.quantisation
        } else {
            y
        }
    };
    let mut q: Vec<Vec<f64>> = Vec::with_capacity(nj);
    let mut qd = Vec::with_capacity(nj);
    for j in 0..nj {
        match conf.free.iter().position(|&k| k == j) {
            Some(a) => {
                q.push(traj.q[a].iter().map(|&x| measure(x)).collect());
                qd.push(Some(traj.qd[a].clone()));
            }
            None => {
                q.push(t.iter().map(|_| measure(q_all[j])).collect());
                qd.push(Some(vec![0.0; t.len()]));
            }
        }
    }
    // Noise or quantisation the float format cannot carry (a σ near 1e308, a step near
    // 1e-320) would write non-finite positions that no reader accepts.
    for (j, col) in q.iter().enumerate() {
        if let Some(k) = col.iter().position(|x: &f64| !x.is_finite()) {
            bail!(
                "joint '{}', t = {} s: the measured position is {} after noise σ = {:e} and quantisation {:e}: these settings overflow the float format",
                model.joints[j],
                t[k],
                col[k],
                opts.noise,
                opts.quantisation
            );
        }
    }
    let side = SideFile {
        description: format!(
            "simulated: plant '{}' ({}), configuration {}",
            plant
                .file
                .as_ref()
                .map(|p| p.display().to_string())
                .unwrap_or_default(),
            plant.description,
            conf.name
        ),
        source: format!(
            "lockstep simulate on {}: {} step {} s, {} hold, position noise σ = {}, quantisation {}, seed {}; qd columns are noise-free",
            input.display(),
            opts.integrator,
            opts.h,
            hold,
            opts.noise,
            opts.quantisation,
            opts.seed
        ),
        configuration: Some(conf.name.to_string()),
        locked: (0..nj)
            .filter(|j| !conf.free.contains(j))
            .map(|j| (model.joints[j].to_string(), q_all[j]))
            .collect(),
        columns: BTreeMap::new(),
        hold: Some(hold),
        preparation: None,
        torque: Some(crate::measurement::TorqueKind::Commanded),
    };
    Ok(Simulated {
        measurement: Measurement {
            file: input.to_path_buf(),
            t,
            tau: tau_all,
            q,
            qd,
            tau_m: vec![None; nj],
            notes: Vec::new(),
        },
        joints: model.joints,
        side,
        findings: configured.findings,
        notes,
    })
}
