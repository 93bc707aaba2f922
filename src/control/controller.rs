//! Closed-loop output error (issue 59): a device measured under its own position
//! controller is simulated in closed loop — the same controller at the same sample rate and
//! delay, fed by the measured reference — and the simulated command (force or torque) and
//! velocity are compared with the measured ones. This is the simulation of DIDIM (Gautier,
//! Janot, Vandanjon, *A New Closed-Loop Output Error Method for Parameter Identification of
//! Robot Dynamics*, IEEE TCST 21(2), 2013) and of the EMPS benchmark's reference results
//! (Janot, Gautier, Brunot 2019): a model error shows in position only through the
//! controller, and an open-loop simulation on the measured commands drifts.
//!
//! A controller file (`model/control/emps_controller.toml`):
//!
//! ```toml
//! configuration = "full"   # the model's configuration the measurements are of
//! period = 0.001           # s: the controller's sample period
//! delay = 1                # samples between a position sample and the command it gives
//! step = 1e-4              # s: the plant's RK4 step between samples (divides the period)
//!
//! [joints.q0]
//! law = "cascade"                # u = kv (kp (qref − q) − q̇̂)
//! kp = 160.18                    # 1/s
//! kv = 243.45                    # command per velocity, V/(m/s)
//! velocity = [0.5, 0.0, -0.5]    # q̇̂(k) = Σ c_i q(k − i) / period
//! saturation = [-10.0, 10.0]     # command limits (V)
//! drive_gain = 35.15065188       # N/V: the joint's force or torque = drive_gain · u
//! reference = "qref_q0"          # the measurement's reference column (default qref_J)
//! ```
//!
//! Laws of joint j, with e = qref − q and q̇̂ the velocity estimate:
//! - `cascade` (position loop → velocity loop → command): u = kv (kp e − q̇̂);
//! - `pd`: u = kp e − kd q̇̂ (derivative on the measurement);
//! - `pid`: u = kp e + ki T Σ e − kd q̇̂, the sum frozen while u is saturated and would
//!   grow further (conditional integration);
//!
//! and with `feedforward = "gravity"`, φ_j(q)/drive_gain added: the plant's gravity torque
//! at the positions the controller reads (a model-based feed-forward; the plant simulated
//! is the controller's model).
//!
//! Sample k (time t_k = t_0 + kT): the controller reads q(t_k), computes u(k) and
//! saturates it; over [t_k, t_k+1) the joint receives drive_gain · (u(k − delay) + d(k)),
//! d the recorded disturbance (zero-order hold; with `disturbance_hold = "linear"` (or
//! `cubic`, `bandlimited`) d(t) is instead reconstructed through the samples at every RK4
//! stage, as a simulation tool's interpolating input block feeds a continuous model; the
//! commands before the first sample are the record's first measured command less its
//! disturbance). That applied command is what
//! a record holds and what is compared. The plant starts at the first measured position,
//! at rest.

use crate::measurement::Table;
use crate::plant::{ConsistencyPolicy, Plant};
use crate::simulation::{Hold, InputSignal, PlantModel, State};
use anyhow::{anyhow, bail, Context, Result};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// One joint's controller as written in a controller file.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointLawSpec {
    /// `cascade`, `pd` or `pid`.
    pub law: String,
    /// Position gain (cascade: 1/s; pd, pid: command per rad or m).
    pub kp: f64,
    /// Velocity gain of the cascade (command per rad/s or m/s).
    #[serde(default)]
    pub kv: Option<f64>,
    /// Derivative gain of pd and pid (command per rad/s or m/s).
    #[serde(default)]
    pub kd: Option<f64>,
    /// Integral gain of pid (command per rad·s or m·s).
    #[serde(default)]
    pub ki: Option<f64>,
    /// Velocity estimate: q̇̂(k) = Σ_i c_i q(k − i) / period (c_0 first).
    pub velocity: Vec<f64>,
    /// Command limits [lower, upper] (none when absent).
    #[serde(default)]
    pub saturation: Option<[f64; 2]>,
    /// Force or torque per unit of command (N·m or N per command unit; 1 when absent).
    #[serde(default = "one")]
    pub drive_gain: f64,
    /// The measurement's reference column for this joint (standard name; `qref_J` for
    /// joint J when absent, the numbered `qref2` of earlier versions also read).
    #[serde(default)]
    pub reference: Option<String>,
    /// `"gravity"`: the controller adds the plant's gravity torque φ(q) at the positions it
    /// reads (over the drive gain), a model-based feed-forward.
    #[serde(default)]
    pub feedforward: Option<String>,
}

fn one() -> f64 {
    1.0
}

/// A controller file as written.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControllerSpec {
    /// What the controller is (for reports).
    #[serde(default)]
    pub description: String,
    /// The model's configuration the measurements are of.
    pub configuration: String,
    /// The controller's sample period (s).
    pub period: f64,
    /// Samples between a position sample and the command it gives.
    #[serde(default)]
    pub delay: usize,
    /// The plant's RK4 step between samples (s); `period / step` must be an integer.
    pub step: f64,
    /// Per joint (the model's joint names).
    pub joints: BTreeMap<String, JointLawSpec>,
    /// How the records' disturbance (`dist_J`) is applied between samples: `zoh` (held,
    /// as a digital controller adds it; the default), or `linear`, `cubic`, `bandlimited`
    /// (a continuous signal through the samples, as a simulation tool's interpolating
    /// input block feeds it).
    #[serde(default)]
    pub disturbance_hold: Option<String>,
    /// How the measured velocity is estimated for the comparison.
    #[serde(default)]
    pub compare: ComparePreset,
}

/// How a closed-loop run is compared with a record: the EMPS benchmark's way (its example
/// script): the measured velocity is the central difference of the position filtered by a
/// 4th-order zero-phase Butterworth low-pass (`filtfilt`), the simulated velocity the
/// plant's; the first `skip` samples (the filter's and the difference's edge) are left out
/// of every figure.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ComparePreset {
    /// Cut-off of the position filter (Hz).
    pub velocity_cutoff_hz: f64,
    /// Samples left out at the start.
    pub skip: usize,
}

impl Default for ComparePreset {
    /// The benchmark's: 100 Hz, the first 49 samples out (it compares from the 50th).
    fn default() -> Self {
        ComparePreset {
            velocity_cutoff_hz: 100.0,
            skip: 49,
        }
    }
}

/// A joint's control law.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Law {
    /// u = kv (kp e − q̇̂).
    Cascade {
        /// Position gain (1/s).
        kp: f64,
        /// Velocity gain.
        kv: f64,
    },
    /// u = kp e + ki T Σ e − kd q̇̂ (ki = 0: PD).
    Pid {
        /// Proportional gain.
        kp: f64,
        /// Integral gain.
        ki: f64,
        /// Derivative gain (on the measurement).
        kd: f64,
    },
}

/// One free joint's controller, checked.
#[derive(Debug, Clone, PartialEq)]
pub struct JointController {
    /// Its law.
    pub law: Law,
    /// Velocity estimate coefficients c_i (q̇̂(k) = Σ c_i q(k − i) / period).
    pub velocity: Vec<f64>,
    /// Command limits (lower < upper; ±∞ when none).
    pub saturation: (f64, f64),
    /// Force or torque per unit of command.
    pub drive_gain: f64,
    /// The measurement's reference column.
    pub reference: String,
    /// Whether the command adds the gravity torque at the read positions.
    pub gravity_feedforward: bool,
}

/// A controller file, checked against a model: one [`JointController`] per free joint of
/// the configuration, in the configuration's order.
#[derive(Debug, Clone)]
pub struct Controller {
    /// The file it was read from.
    pub file: PathBuf,
    /// What it is.
    pub description: String,
    /// The configuration's name.
    pub configuration: String,
    /// Sample period T (s).
    pub period: f64,
    /// Delay (samples).
    pub delay: usize,
    /// RK4 steps per sample.
    pub substeps: usize,
    /// Per free joint.
    pub joints: Vec<JointController>,
    /// How a record's disturbance is applied between samples (zero-order hold unless the
    /// file says otherwise).
    pub disturbance_hold: Hold,
    /// How runs are compared with records.
    pub compare: ComparePreset,
}

impl Controller {
    /// Read and check a controller file for the model of `plant`.
    ///
    /// # Errors
    /// One line naming the file and the field: unreadable file, TOML syntax or unknown
    /// field, an unknown configuration or joint, a free joint without a law, a law missing
    /// its gain, a period or step that is not positive and finite, a step that does not
    /// divide the period, saturation limits not increasing, a drive gain of 0, an empty
    /// velocity estimate, a disturbance hold that is not one of [`Hold`]'s.
    pub fn load(path: &Path, plant: &Plant) -> Result<Controller> {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("cannot read controller file {}", path.display()))?;
        let spec: ControllerSpec =
            toml::from_str(&text).map_err(|e| anyhow!("{}: {}", path.display(), e.message()))?;
        Controller::from_spec(spec, path, plant)
    }

    /// Check a controller spec (read from `path`) against the model of `plant`.
    ///
    /// # Errors
    /// As [`Controller::load`].
    pub fn from_spec(spec: ControllerSpec, path: &Path, plant: &Plant) -> Result<Controller> {
        let file = path.display();
        let m = plant.model;
        let conf = m.configuration(&spec.configuration).ok_or_else(|| {
            anyhow!(
                "{file}: configuration '{}' is not one of model {}'s ({})",
                spec.configuration,
                m.name,
                m.configurations
                    .iter()
                    .map(|c| c.name)
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        })?;
        let positive = |name: &str, v: f64| -> Result<()> {
            if v > 0.0 && v.is_finite() {
                Ok(())
            } else {
                bail!("{file}: '{name}' must be a positive number of seconds, found {v}")
            }
        };
        positive("period", spec.period)?;
        let nyquist = 0.5 / spec.period;
        let fc = spec.compare.velocity_cutoff_hz;
        if !(fc > 0.0 && fc < nyquist) {
            bail!(
                "{file}: [compare] velocity_cutoff_hz = {fc}: it must lie between 0 and the Nyquist frequency {nyquist} Hz"
            );
        }
        positive("step", spec.step)?;
        let ratio = spec.period / spec.step;
        let substeps = ratio.round();
        if substeps < 1.0 || (ratio - substeps).abs() > 1e-6 * ratio {
            bail!(
                "{file}: the step {} s does not divide the period {} s ({ratio:.4} steps per sample): choose a step of period/n",
                spec.step,
                spec.period
            );
        }
        for name in spec.joints.keys() {
            if !m.joints.contains(&name.as_str()) {
                bail!(
                    "{file}: [joints.{name}]: the model {} has no joint '{name}' (joints: {})",
                    m.name,
                    m.joints.join(", ")
                );
            }
            if !conf.free.iter().any(|&j| m.joints[j] == name) {
                bail!(
                    "{file}: [joints.{name}]: '{name}' is locked in configuration '{}'",
                    conf.name
                );
            }
        }
        let disturbance_hold = match spec.disturbance_hold.as_deref() {
            None => Hold::Zoh,
            Some(s) => s
                .parse::<Hold>()
                .map_err(|e| anyhow!("{file}: disturbance_hold: {e}"))?,
        };
        let mut joints = Vec::new();
        for &j in conf.free {
            let name = m.joints[j];
            let s = spec.joints.get(name).ok_or_else(|| {
                anyhow!(
                    "{file}: no [joints.{name}]: every free joint of configuration '{}' needs its law",
                    conf.name
                )
            })?;
            let need = |g: Option<f64>, gain: &str| -> Result<f64> {
                match g {
                    Some(v) if v.is_finite() => Ok(v),
                    Some(v) => bail!("{file}: [joints.{name}] '{gain}' = {v} is not a number"),
                    None => bail!("{file}: [joints.{name}]: law '{}' needs '{gain}'", s.law),
                }
            };
            let law = match s.law.as_str() {
                "cascade" => Law::Cascade {
                    kp: need(Some(s.kp), "kp")?,
                    kv: need(s.kv, "kv")?,
                },
                "pd" => Law::Pid {
                    kp: need(Some(s.kp), "kp")?,
                    ki: 0.0,
                    kd: need(s.kd, "kd")?,
                },
                "pid" => Law::Pid {
                    kp: need(Some(s.kp), "kp")?,
                    ki: need(s.ki, "ki")?,
                    kd: need(s.kd, "kd")?,
                },
                other => bail!(
                    "{file}: [joints.{name}] law = '{other}': expected 'cascade', 'pd' or 'pid'"
                ),
            };
            let saturation = match s.saturation {
                Some([lo, hi]) if lo < hi => (lo, hi),
                Some([lo, hi]) => bail!(
                    "{file}: [joints.{name}] saturation = [{lo}, {hi}]: the lower limit must be below the upper"
                ),
                None => (f64::NEG_INFINITY, f64::INFINITY),
            };
            if s.velocity.is_empty() || s.velocity.iter().any(|c| !c.is_finite()) {
                bail!(
                    "{file}: [joints.{name}] velocity must list the estimate's coefficients c_0, c_1, … (q̇̂(k) = Σ c_i q(k − i) / period), e.g. [1.0, -1.0]"
                );
            }
            if !(s.drive_gain.is_finite() && s.drive_gain != 0.0) {
                bail!(
                    "{file}: [joints.{name}] drive_gain = {}: a force or torque per unit of command, not 0",
                    s.drive_gain
                );
            }
            let gravity_feedforward = match s.feedforward.as_deref() {
                None => false,
                Some("gravity") => true,
                Some(other) => bail!(
                    "{file}: [joints.{name}] feedforward = '{other}': expected 'gravity' (or none)"
                ),
            };
            joints.push(JointController {
                law,
                velocity: s.velocity.clone(),
                saturation,
                drive_gain: s.drive_gain,
                reference: s
                    .reference
                    .clone()
                    .unwrap_or_else(|| crate::names::column("qref", name)),
                gravity_feedforward,
            });
        }
        Ok(Controller {
            file: path.to_path_buf(),
            description: spec.description,
            configuration: conf.name.to_string(),
            period: spec.period,
            delay: spec.delay,
            substeps: substeps as usize,
            joints,
            disturbance_hold,
            compare: spec.compare,
        })
    }
}

/// Per free joint, per sample.
pub type PerJoint = Vec<Vec<f64>>;

/// What the controller and the plant did at each sample of a closed-loop run.
#[derive(Debug, Clone, PartialEq)]
pub struct ClosedLoopRun {
    /// Sample times (s).
    pub t: Vec<f64>,
    /// Positions read by the controller (rad or m).
    pub q: PerJoint,
    /// The plant's velocities at the samples (rad/s or m/s).
    pub qd: PerJoint,
    /// The controller's velocity estimates.
    pub qd_hat: PerJoint,
    /// The commands applied over each sample period, u(k − delay) + d(k) (command units).
    pub u: PerJoint,
    /// Those commands as forces or torques, drive_gain · u (N·m or N).
    pub tau: PerJoint,
}

/// The measured signals a closed-loop run is compared with, per free joint. A record may
/// hold a disturbance the experiment added to joint J's command, `dist_J` (command units,
/// added after the saturation: EMPS's force pulses, 5 V for 0.5 s each second, are inside
/// its recorded command); the controller then adds it too.
#[derive(Debug, Clone)]
pub struct ClosedLoopRecord {
    /// The file.
    pub file: PathBuf,
    /// Sample times (s), the controller's period apart.
    pub t: Vec<f64>,
    /// References (rad or m).
    pub qref: PerJoint,
    /// Measured positions.
    pub q: PerJoint,
    /// Measured forces or torques (the drive's command times its gain, N·m or N).
    pub tau: PerJoint,
    /// Disturbances added to the command (command units; zeros where none).
    pub disturbance: PerJoint,
    /// The whole record (every joint), for the inverse model on simulated positions.
    pub measurement: crate::measurement::Measurement,
}

impl ClosedLoopRecord {
    /// The controller's signals of `table` (a measurement of the model of `plant`, columns
    /// by standard names): the time, each free joint's reference, position and force or
    /// torque.
    ///
    /// # Errors
    /// A missing column (the file and the columns present named), a sample period or a side
    /// file's configuration that is not the controller's (both named).
    pub fn from_table(table: &Table, plant: &Plant, c: &Controller) -> Result<ClosedLoopRecord> {
        let m = plant.model;
        let conf = m
            .configuration(&c.configuration)
            .ok_or_else(|| anyhow!("configuration '{}'", c.configuration))?;
        if let Some(own) = table
            .side
            .configuration
            .as_deref()
            .filter(|own| *own != c.configuration)
        {
            bail!(
                "{}: its side file says configuration '{own}', the controller {} is for '{}'",
                table.file.display(),
                c.file.display(),
                c.configuration
            );
        }
        let t = table.need("t")?;
        if t.len() < 2 {
            bail!("{}: fewer than two samples", table.file.display());
        }
        let dt = (t[t.len() - 1] - t[0]) / (t.len() - 1) as f64;
        if (dt - c.period).abs() > 1e-6 * c.period {
            bail!(
                "{}: sampled every {dt:.6e} s, the controller {} runs every {} s",
                table.file.display(),
                c.file.display(),
                c.period
            );
        }
        let mut qref = Vec::new();
        let mut q = Vec::new();
        let mut tau = Vec::new();
        let mut disturbance = Vec::new();
        for (a, &j) in conf.free.iter().enumerate() {
            let jc = &c.joints[a];
            // The joint's own reference column may be in either form (`qref_q0`, `qref0`).
            let own = crate::names::column_joint(m.joints, "qref", &jc.reference) == Some(j);
            let reference = if own {
                table.need_joint(m.joints, "qref", j)
            } else {
                table.need(&jc.reference)
            };
            qref.push(reference.with_context(|| {
                format!(
                    "the reference of joint {} in {}",
                    m.joints[j],
                    c.file.display()
                )
            })?);
            q.push(table.need_joint(m.joints, "q", j)?);
            tau.push(table.need_joint(m.joints, "tau", j)?);
            let mapped = [
                crate::names::column("dist", m.joints[j]),
                crate::names::numbered_column("dist", j),
            ]
            .into_iter()
            .find(|n| table.side.columns.contains_key(n));
            disturbance.push(match table.joint_column(m.joints, "dist", j)? {
                Some(d) => d,
                None if mapped.is_some() => {
                    let dist = mapped.unwrap_or_default();
                    bail!(
                        "{}: its side file maps '{dist}' to '{}', which is not a column of the file",
                        table.file.display(),
                        table.side.columns[&dist]
                    )
                }
                None => vec![0.0; t.len()],
            });
        }
        Ok(ClosedLoopRecord {
            file: table.file.clone(),
            t,
            qref,
            q,
            tau,
            disturbance,
            measurement: crate::measurement::Measurement::from_table(table, m.joints)?,
        })
    }
}

/// The velocity estimate of `c` on the position history `history` (most recent first).
fn estimate(c: &[f64], history: &[f64], period: f64) -> f64 {
    c.iter().zip(history).map(|(c, q)| c * q).sum::<f64>() / period
}

/// Simulate `plant` under controller `c` on the reference of `record`: the closed loop of
/// the module documentation.
///
/// # Errors
/// A plant that cannot be simulated in the configuration (a parameter without value); a
/// divergence (the time and joint named).
pub fn simulate_closed_loop(
    plant: &Plant,
    c: &Controller,
    record: &ClosedLoopRecord,
) -> Result<ClosedLoopRun> {
    let m = plant.model;
    let conf = m
        .configuration(&c.configuration)
        .ok_or_else(|| anyhow!("configuration '{}'", c.configuration))?;
    let nf = conf.free.len();
    let mut q_locked = vec![0.0; m.joints.len()];
    for (a, &j) in conf.free.iter().enumerate() {
        q_locked[j] = record.q[a][0];
    }
    let model: PlantModel = plant
        .simulator(&c.configuration, &q_locked, ConsistencyPolicy::Warn)?
        .model;
    let n = record.t.len();
    let h = c.period / c.substeps as f64;
    let mut x = State::at_rest((0..nf).map(|a| record.q[a][0]).collect());
    // Position histories (most recent first) and the commands waiting out the delay.
    let depth = c.joints.iter().map(|j| j.velocity.len()).max().unwrap_or(1);
    let mut history: Vec<Vec<f64>> = (0..nf).map(|a| vec![record.q[a][0]; depth]).collect();
    let first: Vec<f64> = (0..nf)
        .map(|a| record.tau[a][0] / c.joints[a].drive_gain - record.disturbance[a][0])
        .collect();
    let mut queue: std::collections::VecDeque<Vec<f64>> =
        std::iter::repeat_n(first, c.delay).collect();
    let mut integral = vec![0.0; nf];
    let mut run = ClosedLoopRun {
        t: record.t.clone(),
        q: vec![Vec::with_capacity(n); nf],
        qd: vec![Vec::with_capacity(n); nf],
        qd_hat: vec![Vec::with_capacity(n); nf],
        u: vec![Vec::with_capacity(n); nf],
        tau: vec![Vec::with_capacity(n); nf],
    };
    let names: Vec<&str> = conf.free.iter().map(|&j| m.joints[j]).collect();
    let feedforward = c.joints.iter().any(|j| j.gravity_feedforward);
    let mut q_full = model.q_locked.clone();
    let mut gravity = vec![0.0; nf];
    let continuous = c.disturbance_hold.is_continuous();
    let mut stepper = model.stepper();
    // The disturbance at a stage time, under a continuous hold.
    let mut d = vec![0.0; nf];
    let disturbance = InputSignal {
        t0: record.t[0],
        dt: c.period,
        tau: &record.disturbance,
        hold: c.disturbance_hold,
    };
    for k in 0..n {
        if feedforward {
            for (a, &j) in conf.free.iter().enumerate() {
                q_full[j] = x.q[a];
            }
            (conf.gravity)(&q_full, &model.p, &mut gravity);
        }
        let mut u = vec![0.0; nf];
        for (a, jc) in c.joints.iter().enumerate() {
            let h_a = &mut history[a];
            h_a.rotate_right(1);
            h_a[0] = x.q[a];
            let qd_hat = estimate(&jc.velocity, h_a, c.period);
            let e = record.qref[a][k] - x.q[a];
            let ff = if jc.gravity_feedforward {
                gravity[a] / jc.drive_gain
            } else {
                0.0
            };
            let raw = ff
                + match jc.law {
                    Law::Cascade { kp, kv } => kv * (kp * e - qd_hat),
                    Law::Pid { kp, ki, kd } => kp * e + ki * integral[a] - kd * qd_hat,
                };
            let (lo, hi) = jc.saturation;
            let sat = raw.clamp(lo, hi);
            if let Law::Pid { ki, .. } = jc.law {
                // Conditional integration: frozen while saturated and pushing outward.
                let outward = (sat >= hi && e > 0.0) || (sat <= lo && e < 0.0);
                if ki != 0.0 && !outward {
                    integral[a] += e * c.period;
                }
            }
            u[a] = sat;
            run.q[a].push(x.q[a]);
            run.qd[a].push(x.qd[a]);
            run.qd_hat[a].push(qd_hat);
        }
        queue.push_back(u);
        let applied = queue.pop_front().unwrap_or_default();
        let tau: Vec<f64> = (0..nf)
            .map(|a| {
                let u = applied[a] + record.disturbance[a][k];
                run.u[a].push(u);
                run.tau[a].push(c.joints[a].drive_gain * u);
                c.joints[a].drive_gain * u
            })
            .collect();
        if k + 1 == n {
            break;
        }
        // Under a continuous disturbance hold, the command between samples is the held
        // controller output plus the disturbance's reconstruction at each RK4 stage.
        let input = |t: f64, out: &mut [f64]| {
            if continuous {
                disturbance.at(t, &mut d);
                for (a, o) in out.iter_mut().enumerate() {
                    *o = c.joints[a].drive_gain * (applied[a] + d[a]);
                }
            } else {
                out.copy_from_slice(&tau);
            }
        };
        stepper
            .advance(record.t[k], &mut x, h, c.substeps, 1e6, input, |_, _| {})
            .map_err(|d| {
                let name = names.get(d.joint).copied().unwrap_or("?");
                anyhow!(
                    "closed loop on {}, sample {k} (t = {:.4} s): {}",
                    record.file.display(),
                    record.t[k],
                    d.message(name)
                )
            })?;
    }
    Ok(run)
}

/// The comparison of a closed-loop run of `plant` under `c` with `record`, per free joint:
/// the force or torque (the applied command times the drive gain against the recorded one)
/// and the velocity (the plant's against the measured position's filtered central
/// difference, [`ComparePreset`]), each a [`crate::compare::Comparison`] with its residual
/// tests against the reference; the run itself.
///
/// # Errors
/// As [`simulate_closed_loop`]; a record not longer than the preset's skip plus the
/// filter's edge.
pub fn compare_closed_loop(
    plant: &Plant,
    c: &Controller,
    record: &ClosedLoopRecord,
) -> Result<(Vec<[crate::compare::Comparison; 2]>, ClosedLoopRun)> {
    use crate::compare::{comparison, Signals};
    let run = simulate_closed_loop(plant, c, record)?;
    let m = plant.model;
    let conf = m
        .configuration(&c.configuration)
        .ok_or_else(|| anyhow!("configuration '{}'", c.configuration))?;
    let n = record.t.len();
    let skip = c.compare.skip;
    let filter = crate::signal::butter_lowpass(4, c.compare.velocity_cutoff_hz * 2.0 * c.period);
    let mut out = Vec::new();
    for (a, &j) in conf.free.iter().enumerate() {
        let filtered = filter
            .filtfilt(&record.q[a])
            .filter(|_| n > skip + 2)
            .ok_or_else(|| {
                anyhow!(
                "{}: {n} samples, too few for the velocity filter and the {skip} samples left out",
                record.file.display()
            )
            })?;
        let v = crate::signal::central_difference(&filtered, c.period);
        let cut = |x: &[f64]| x[skip..].to_vec();
        let name = m.joints[j];
        let inputs = vec![(crate::names::column("qref", name), cut(&record.qref[a]))];
        let signals = |y: &[f64], yhat: &[f64]| Signals {
            t: cut(&record.t),
            q: cut(&record.q[a]),
            qd: cut(&v),
            y: cut(y),
            yhat: cut(yhat),
            dt: c.period,
            inputs: inputs.clone(),
        };
        out.push([
            comparison(
                &record.file,
                name,
                signals(&record.tau[a], &run.tau[a]),
                "N·m or N",
            ),
            comparison(&record.file, name, signals(&v, &run.qd[a]), "rad/s or m/s"),
        ]);
    }
    Ok((out, run))
}
