//! Closed-loop PD verification (thesis 4.5): a position PD per joint at the control rate,
//! the second-order low-pass (4.7) on the error derivative, position commands from an
//! excitation table (Table 4.9), zero-order hold on the torque; the plant integrated by RK4
//! between samples.
//!
//! Per joint and sample k (period T): e(k) = q_cmd(k) − q(k), u(k) = (e(k) − e(k−1)) / T,
//! y(k) = (−a2 y(k−1) − a3 y(k−2) + b1 u(k−1) + b2 u(k−2)) / a1 (4.7),
//! τ(k) = P e(k) + D y(k), held over [kT, (k+1)T).

use crate::excitation::Excitations;
use crate::plant::{ConsistencyPolicy, Plant};
use crate::simulation::{PlantModel, State};
use anyhow::{bail, Context, Result};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The error-derivative filter (4.7), y(k) = (−a2 y(k−1) − a3 y(k−2) + b1 u(k−1) +
/// b2 u(k−2)) / a1. Thesis: a1 = 1, a2 = −0.8073, a3 = 0.2638, b1 = 0.2789, b2 = 0.1775
/// (15 Hz at 100 Hz).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DerivativeFilter {
    /// a1, a2, a3.
    pub a: [f64; 3],
    /// b1, b2 (on u(k−1), u(k−2)).
    pub b: [f64; 2],
}

impl DerivativeFilter {
    /// The thesis's 15 Hz filter at 100 Hz.
    pub const THESIS: DerivativeFilter = DerivativeFilter {
        a: [1.0, -0.8073, 0.2638],
        b: [0.2789, 0.1775],
    };

    /// Filter a whole sequence from rest.
    pub fn filter(&self, u: &[f64]) -> Vec<f64> {
        let mut st = FilterState::default();
        u.iter().map(|&x| st.step(self, x)).collect()
    }

    /// Frequency response H(e^{jωT}) at `f` Hz for sample period `period` s: (|H|, phase rad).
    pub fn response(&self, f: f64, period: f64) -> (f64, f64) {
        let w = std::f64::consts::TAU * f * period;
        // H(z) = (b1 z^-1 + b2 z^-2) / (a1 + a2 z^-1 + a3 z^-2)
        let c = |k: f64| ((-k * w).cos(), (-k * w).sin());
        let (c1, c2) = (c(1.0), c(2.0));
        let num = (
            self.b[0] * c1.0 + self.b[1] * c2.0,
            self.b[0] * c1.1 + self.b[1] * c2.1,
        );
        let den = (
            self.a[0] + self.a[1] * c1.0 + self.a[2] * c2.0,
            self.a[1] * c1.1 + self.a[2] * c2.1,
        );
        let mag = (num.0.hypot(num.1)) / den.0.hypot(den.1);
        let ph = num.1.atan2(num.0) - den.1.atan2(den.0);
        (mag, ph)
    }
}

/// The memory of one filter.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct FilterState {
    y1: f64,
    y2: f64,
    u1: f64,
    u2: f64,
}

impl FilterState {
    /// One sample: y(k) from u(k) (which enters the output from the next sample on).
    pub fn step(&mut self, f: &DerivativeFilter, u: f64) -> f64 {
        let y =
            (-f.a[1] * self.y1 - f.a[2] * self.y2 + f.b[0] * self.u1 + f.b[1] * self.u2) / f.a[0];
        self.y2 = self.y1;
        self.y1 = y;
        self.u2 = self.u1;
        self.u1 = u;
        y
    }
}

/// A closed-loop experiment file.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ClosedLoopSpec {
    /// Plant file, relative to this file (overridden by `--plant`).
    pub plant: PathBuf,
    /// Parameter values replacing the plant file's.
    #[serde(default)]
    pub plant_overrides: BTreeMap<String, f64>,
    /// Excitation file with the command table, relative to this file (default: bundled).
    #[serde(default)]
    pub excitation: Option<PathBuf>,
    /// Command table id (Table 4.9).
    pub commands: String,
    /// Configuration (free joints).
    pub configuration: String,
    /// Control rate (Hz).
    pub rate: f64,
    /// Duration (s).
    pub duration: f64,
    /// RK4 step (s).
    pub step: f64,
    /// Error-derivative filter (4.7).
    pub filter: DerivativeFilter,
    /// Gain sets (Table 4.8): name → joint → [P, D].
    pub gains: BTreeMap<String, BTreeMap<String, [f64; 2]>>,
}

/// One series per free joint, `x[a][k]`.
pub type PerJoint = Vec<Vec<f64>>;

/// A closed-loop simulation.
#[derive(Debug, Clone)]
pub struct ClosedLoopRun {
    /// Gain set name.
    pub gains: String,
    /// Sample times (s).
    pub t: Vec<f64>,
    /// Free joints (model indices).
    pub joints: Vec<usize>,
    /// Commands per free joint (rad).
    pub q_cmd: Vec<Vec<f64>>,
    /// Simulated positions per free joint at the samples (rad).
    pub q: Vec<Vec<f64>>,
    /// Commanded torques per free joint (N·m).
    pub tau: Vec<Vec<f64>>,
}

impl ClosedLoopRun {
    /// RMS tracking error per free joint (rad).
    pub fn rms_error(&self) -> Vec<f64> {
        self.q_cmd
            .iter()
            .zip(&self.q)
            .map(|(c, q)| {
                (c.iter().zip(q).map(|(a, b)| (a - b).powi(2)).sum::<f64>() / c.len() as f64).sqrt()
            })
            .collect()
    }
}

/// A closed-loop file with its plant.
#[derive(Debug, Clone)]
pub struct ClosedLoop {
    /// The file.
    pub spec: ClosedLoopSpec,
    /// The plant (overrides applied).
    pub plant: Plant,
    /// Commands sampled at the rate, one column per model joint (rad).
    pub commands: (Vec<f64>, Vec<Vec<f64>>),
}

impl ClosedLoop {
    /// Load a closed-loop file; `plant` replaces the file's plant, `duration` (s) the file's.
    ///
    /// # Errors
    /// Unreadable or malformed file (line named), unknown joint in a gain set, unknown
    /// override, unknown command table or one that is not a position table, bad numbers.
    pub fn load(path: &Path, plant: Option<&Path>, duration: Option<f64>) -> Result<ClosedLoop> {
        let origin = path.display().to_string();
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("{origin}: cannot read the closed-loop file"))?;
        let mut spec: ClosedLoopSpec =
            toml::from_str(&text).map_err(|e| crate::util::toml_error(&origin, &text, &e))?;
        if let Some(d) = duration {
            spec.duration = d;
        }
        let dir = path.parent().unwrap_or(Path::new("."));
        // The overrides belong to the file's plant; a plant given instead is taken as is.
        let p = match plant {
            Some(given) => Plant::load(given)?,
            None => super::experiment_plant(path, &spec.plant, &spec.plant_overrides)?,
        };
        if !(spec.rate > 0.0 && spec.duration > 0.0 && spec.step > 0.0) {
            bail!("{origin}: rate, duration and step must be positive");
        }
        if spec.filter.a[0] == 0.0 {
            bail!("{origin}: filter: a1 must not be zero");
        }
        for (set, g) in &spec.gains {
            for j in g.keys() {
                if !p.model.joints.iter().any(|n| n == j) {
                    bail!("{origin}: gains.{set}: model has no joint '{j}'");
                }
            }
        }
        let ex = match &spec.excitation {
            Some(e) => Excitations::load(&dir.join(e), p.model)?,
            None => Excitations::bundled(p.model)?,
        };
        let table = ex.table(&spec.commands).with_context(|| origin.clone())?;
        if table.quantity != crate::excitation::Quantity::Position {
            bail!(
                "{origin}: commands: table {} holds torques, not position commands",
                table.id
            );
        }
        let test = table.test(None)?;
        let nj = p.model.joints.len();
        let all: Vec<usize> = (0..nj).collect();
        let (t, cols, _) = test.sample(nj, &all, spec.duration, spec.rate);
        Ok(ClosedLoop {
            spec,
            plant: p,
            commands: (t, cols),
        })
    }

    /// Simulate gain set `gains`.
    ///
    /// # Errors
    /// Unknown gain set, a free joint without gains, simulator errors, divergence (time named).
    pub fn run(&self, gains: &str) -> Result<ClosedLoopRun> {
        let g = self.spec.gains.get(gains).with_context(|| {
            format!(
                "no gain set '{gains}' (the file has {})",
                self.spec
                    .gains
                    .keys()
                    .cloned()
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        })?;
        let model = self.plant.model;
        let sim = self
            .plant
            .simulator(
                &self.spec.configuration,
                &vec![0.0; model.joints.len()],
                ConsistencyPolicy::Refuse,
            )?
            .model;
        let free = sim.conf.free.to_vec();
        let pd: Vec<[f64; 2]> = free
            .iter()
            .map(|&j| {
                g.get(model.joints[j]).copied().with_context(|| {
                    format!(
                        "gains.{gains}: no gains for free joint '{}'",
                        model.joints[j]
                    )
                })
            })
            .collect::<Result<_>>()?;
        let (t, cmd) = &self.commands;
        let q_cmd: Vec<Vec<f64>> = free.iter().map(|&j| cmd[j].clone()).collect();
        let names: Vec<String> = free.iter().map(|&j| model.joints[j].to_string()).collect();
        let (q, tau) = simulate_pd(
            &sim,
            &names,
            &pd,
            &self.spec.filter,
            &q_cmd,
            self.spec.rate,
            self.spec.step,
        )?;
        Ok(ClosedLoopRun {
            gains: gains.to_string(),
            t: t.clone(),
            joints: free,
            q_cmd,
            q,
            tau,
        })
    }
}

/// Simulate the PD loop on `sim` (free joints, called `names` in messages): `pd[a] = [P, D]`, commands `q_cmd[a][k]` at
/// `rate` Hz, RK4 step ≤ `step`. Returns positions at the samples and the torques applied
/// from each sample on.
///
/// # Errors
/// Divergence of the plant (time and joint named).
pub fn simulate_pd(
    sim: &PlantModel,
    names: &[String],
    pd: &[[f64; 2]],
    filter: &DerivativeFilter,
    q_cmd: &[Vec<f64>],
    rate: f64,
    step: f64,
) -> Result<(PerJoint, PerJoint)> {
    let nf = sim.nf();
    let n = q_cmd.first().map_or(0, Vec::len);
    let period = 1.0 / rate;
    let sub = (period / step).ceil().max(1.0) as usize;
    let h = period / sub as f64;
    let mut x = State::at_rest(vec![0.0; nf]);
    let mut fs = vec![FilterState::default(); nf];
    let mut e_prev = vec![0.0; nf];
    let mut q = vec![Vec::with_capacity(n); nf];
    let mut tau = vec![Vec::with_capacity(n); nf];
    let mut u = vec![0.0; nf];
    let mut stepper = sim.stepper();
    for k in 0..n {
        for a in 0..nf {
            let e = q_cmd[a][k] - x.q[a];
            let de = if k == 0 {
                0.0
            } else {
                (e - e_prev[a]) / period
            };
            e_prev[a] = e;
            let y = fs[a].step(filter, de);
            u[a] = pd[a][0] * e + pd[a][1] * y;
            q[a].push(x.q[a]);
            tau[a].push(u[a]);
        }
        if k + 1 == n {
            break;
        }
        let t0 = k as f64 * period;
        stepper
            .advance(
                t0,
                &mut x,
                h,
                sub,
                1e3,
                |_, out| out.copy_from_slice(&u),
                |_, _| {},
            )
            .map_err(|d| {
                let name = names.get(d.joint).map_or("?", String::as_str);
                anyhow::anyhow!(
                    "closed loop, sample {k} (t = {t0:.2} s): {}",
                    d.message(name)
                )
            })?;
    }
    Ok((q, tau))
}
