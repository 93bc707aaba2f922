//! Whether a simulation is accurate enough for the data it is compared with: the part of
//! the verdict that belongs to the numerics, not to the model.
//!
//! A fixed-step simulation carries an integration error, and a sampled input carries the
//! error of its reconstruction between samples ([`Hold`]). Both look like missing dynamics
//! in a residual: on the Freedom 6S's wrist (k1) RK4 at the thesis's 1/6000 s leaves an
//! error of many σ of the sensor on the exact plant, which a diagnosis would otherwise
//! explain as friction. [`check_step`] estimates the integration error the usual way, by
//! step doubling: the difference of the simulations at h and h/2 bounds the error at h
//! (for RK4 the error at h/2 is about 1/15 of it). The step is halved until that
//! difference is at most [`STEP_TOLERANCE`] σ̂ on every free joint (σ̂ the joint's
//! measurement noise from the files alone, [`crate::signal::noise_sigma`]), at most
//! [`MAX_HALVINGS`] times; past that the check fails, naming the joint.
//!
//! What is left, the difference at the accepted step plus, for a [`Hold::Cubic`] input,
//! its difference from the band-limited reconstruction, is the numerical floor
//! ([`StepCheck::floor_energy`]): the diagnosis never calls an effect significant that
//! explains less of the residual than that.

use crate::identify::output_error::Problem;
use crate::plant::Plant;
use crate::simulation::{Hold, Trajectory};
use anyhow::{bail, Result};

/// A step is accurate when the simulations at h and h/2 differ by at most this fraction
/// of the noise σ̂ (RMS over the samples) on every free joint.
pub const STEP_TOLERANCE: f64 = 0.25;

/// Most halvings of the requested step before the check gives up.
pub const MAX_HALVINGS: usize = 3;

/// The step-doubling difference of one free joint at one step.
#[derive(Debug, Clone, serde::Serialize)]
pub struct StepJoint {
    /// Joint name.
    pub joint: String,
    /// RMS over every file's samples of q(h) − q(h/2) (rad or m).
    pub difference: f64,
    /// Measurement noise σ̂ of the joint (rad or m).
    pub noise: f64,
}

impl StepJoint {
    /// The difference in units of σ̂ (∞ without a noise estimate and a nonzero difference).
    pub fn in_sigma(&self) -> f64 {
        if self.noise > 0.0 {
            self.difference / self.noise
        } else if self.difference > 0.0 {
            f64::INFINITY
        } else {
            0.0
        }
    }
}

/// One step tried by [`check_step`].
#[derive(Debug, Clone, serde::Serialize)]
pub struct StepTrial {
    /// The step (s).
    pub h: f64,
    /// Each free joint's difference between the simulations at h and h/2 (empty when one
    /// of them diverged).
    pub joints: Vec<StepJoint>,
    /// The divergence of the simulation at h or h/2 (file, time, joint).
    pub diverged: Option<String>,
}

impl StepTrial {
    fn worst(&self) -> String {
        if let Some(d) = &self.diverged {
            return format!("nothing: the simulation diverged ({d})");
        }
        self.joints
            .iter()
            .max_by(|a, b| a.in_sigma().total_cmp(&b.in_sigma()))
            .map_or(String::from("no joint"), |j| {
                format!(
                    "{} {:.2e} (σ̂ {:.2e}, {:.2} σ̂)",
                    j.joint,
                    j.difference,
                    j.noise,
                    j.in_sigma()
                )
            })
    }
}

/// The outcome of [`check_step`].
#[derive(Debug, Clone, serde::Serialize)]
pub struct StepCheck {
    /// The step asked for (s).
    pub requested: f64,
    /// The step to simulate at (s): `requested` / 2^k.
    pub h: f64,
    /// Per step tried, coarsest first.
    pub tried: Vec<StepTrial>,
    /// Energy Σ (q(h) − q(h/2))² over the compared samples at the accepted step, plus the
    /// reconstruction difference of cubic-held records (rad²): the part of a residual the
    /// numerics can account for.
    pub floor_energy: f64,
}

impl StepCheck {
    /// Whether the step was refined.
    pub fn refined(&self) -> bool {
        self.h < self.requested
    }

    /// One line for the user: the step used and why.
    pub fn summary(&self) -> String {
        let last = self.tried.last().map(StepTrial::worst).unwrap_or_default();
        if self.refined() {
            format!(
                "step {} s refined to {} s: at {} s the simulations at h and h/2 differ by {} on the largest joint (tolerance {STEP_TOLERANCE} σ̂); at {} s by {last}",
                step_text(self.requested),
                step_text(self.h),
                step_text(self.requested),
                self.tried[0].worst(),
                step_text(self.h)
            )
        } else {
            format!(
                "step {} s: accurate for the data (h vs h/2 differ by at most {last})",
                step_text(self.h)
            )
        }
    }
}

/// A step as `1/N` where 1/h is a whole number, else in seconds.
pub fn step_text(h: f64) -> String {
    let n = 1.0 / h;
    if (n - n.round()).abs() < 1e-6 * n {
        format!("1/{}", n.round())
    } else {
        format!("{h:e}")
    }
}

/// Trajectories of `problem`'s records for `plant`.
fn trajectories(problem: &Problem, plant: &Plant) -> Result<Vec<Trajectory>> {
    problem
        .records
        .iter()
        .map(|r| problem.simulate(plant, r).map_err(anyhow::Error::from))
        .collect()
}

/// Per free joint, Σ (a − b)² and the count over the samples from `skip` on.
fn squared_differences(
    a: &[Trajectory],
    b: &[Trajectory],
    nf: usize,
    skip: usize,
) -> (Vec<f64>, Vec<usize>) {
    let mut sum = vec![0.0; nf];
    let mut count = vec![0usize; nf];
    for (ta, tb) in a.iter().zip(b) {
        for j in 0..nf {
            let from = skip.min(ta.q[j].len());
            for (x, y) in ta.q[j][from..].iter().zip(&tb.q[j][from..]) {
                sum[j] += (x - y).powi(2);
                count[j] += 1;
            }
        }
    }
    (sum, count)
}

/// The simulation problem of `plant` (nothing fitted, joints weighted 1) on `records` of
/// configuration `conf` under `options`, at the step [`check_step`] accepts, with the check.
///
/// # Errors
/// As [`Problem::new`] and [`check_step`].
pub fn checked_simulation(
    plant: &Plant,
    conf: &'static generated::Configuration,
    records: &[crate::identify::output_error::Record],
    options: &crate::identify::refit::RefitOptions,
) -> Result<(Problem, StepCheck)> {
    let problem = Problem::new(
        plant,
        conf,
        vec![],
        records.to_vec(),
        &[],
        options.output_error(vec![1.0]),
    )?;
    with_checked_step(problem, plant, options.skip)
}

/// `problem` at the step [`check_step`] accepts for `plant`, with the check.
///
/// # Errors
/// As [`check_step`].
pub fn with_checked_step(
    problem: Problem,
    plant: &Plant,
    skip: usize,
) -> Result<(Problem, StepCheck)> {
    let step = check_step(&problem, plant, skip)?;
    let checked = problem.with_step(step.h, problem.options().integrator);
    Ok((checked, step))
}

/// Check `problem`'s step (its options' `h` and integrator) for `plant` on its records
/// against the records' noise, halving it until accurate (module docs); `skip` samples at
/// the start of each file are left out.
///
/// # Errors
/// A simulation that fails (file, time, joint), or a step still inaccurate after
/// [`MAX_HALVINGS`] halvings (the joint, its difference and σ̂ named, with what to try).
pub fn check_step(problem: &Problem, plant: &Plant, skip: usize) -> Result<StepCheck> {
    let joints: Vec<&str> = problem
        .configuration()
        .free
        .iter()
        .map(|&j| plant.model.joints[j])
        .collect();
    let options = problem.options();
    let requested = options.h;
    let integrator = options.integrator;
    let nf = joints.len();
    // Noise-free data: the tolerance falls back to 1e-9 of the joint's motion.
    let scales: Vec<f64> = (0..nf)
        .map(|j| {
            problem
                .records
                .iter()
                .map(|r| rms_about_mean(&r.q[j]))
                .fold(0.0, f64::max)
        })
        .collect();
    let mut h = requested;
    let mut coarse = trajectories(problem, plant);
    let mut tried: Vec<StepTrial> = Vec::new();
    for halving in 0..=MAX_HALVINGS {
        let fine = trajectories(&problem.with_step(h / 2.0, integrator), plant);
        let trial = match (&coarse, &fine) {
            (Ok(c), Ok(f)) => {
                let (sum, count) = squared_differences(c, f, nf, skip);
                let joints: Vec<StepJoint> = (0..nf)
                    .map(|j| StepJoint {
                        joint: joints[j].to_string(),
                        difference: (sum[j] / count[j].max(1) as f64).sqrt(),
                        noise: problem.noise.get(j).copied().unwrap_or(0.0),
                    })
                    .collect();
                let accurate = joints
                    .iter()
                    .zip(&scales)
                    .all(|(j, scale)| j.difference <= (STEP_TOLERANCE * j.noise).max(1e-9 * scale));
                if accurate {
                    tried.push(StepTrial {
                        h,
                        joints,
                        diverged: None,
                    });
                    let floor_energy = sum.iter().sum::<f64>()
                        + cubic_reconstruction_energy(
                            &problem.with_step(h, integrator),
                            plant,
                            c,
                            nf,
                            skip,
                        )?;
                    return Ok(StepCheck {
                        requested,
                        h,
                        tried,
                        floor_energy,
                    });
                }
                StepTrial {
                    h,
                    joints,
                    diverged: None,
                }
            }
            (Err(e), _) | (_, Err(e)) => StepTrial {
                h,
                joints: Vec::new(),
                diverged: Some(format!("{e:#}")),
            },
        };
        tried.push(trial);
        if halving == MAX_HALVINGS {
            break;
        }
        h /= 2.0;
        coarse = fine;
    }
    let last = tried.last().expect("at least one step tried");
    // Diverging at every step tried is not a step problem: a smaller one will not help.
    if let (Some(first), true) = (
        tried[0].diverged.as_ref(),
        tried.iter().all(|t| t.diverged.is_some()),
    ) {
        bail!(
            "the simulation diverges at every step tried ({} s down to {} s), so the step is not the cause: the plant runs away on these inputs (a device measured under its controller cannot be simulated open loop: compare it in torque space, --space torque, where its torques are measured); at {} s: {first}",
            step_text(requested),
            step_text(last.h / 2.0),
            step_text(requested)
        );
    }
    bail!(
        "the simulation is not accurate enough for the data: at step {} s (the requested {} s halved {MAX_HALVINGS} times) the simulations at h and h/2 differ by {} (tolerance {STEP_TOLERANCE} σ̂ of each joint's noise): give a smaller --step, or --integrator etdrk4 for stiff friction",
        step_text(last.h),
        step_text(requested),
        last.worst()
    )
}

fn rms_about_mean(x: &[f64]) -> f64 {
    let n = x.len().max(1) as f64;
    let m = x.iter().sum::<f64>() / n;
    (x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / n).sqrt()
}

/// Σ (q(cubic) − q(band-limited))² over the records whose input is held by
/// [`Hold::Cubic`] (0 when none is): the cubic reconstruction's own error, estimated against
/// the band-limited one.
fn cubic_reconstruction_energy(
    problem: &Problem,
    plant: &Plant,
    at_h: &[Trajectory],
    nf: usize,
    skip: usize,
) -> Result<f64> {
    let cubic: Vec<usize> = problem
        .records
        .iter()
        .enumerate()
        .filter(|(_, r)| problem.options().hold.unwrap_or(r.hold) == Hold::Cubic)
        .map(|(i, _)| i)
        .collect();
    if cubic.is_empty() {
        return Ok(0.0);
    }
    let band = trajectories(&problem.with_hold(Some(Hold::Bandlimited)), plant)?;
    let pick =
        |t: &[Trajectory]| -> Vec<Trajectory> { cubic.iter().map(|&i| t[i].clone()).collect() };
    let (sum, _) = squared_differences(&pick(at_h), &pick(&band), nf, skip);
    Ok(sum.iter().sum())
}
