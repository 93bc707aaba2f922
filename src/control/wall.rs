//! The haptic virtual wall of thesis Chapter 5 (docs/src/design/digest.md §4) with a simulated user.
//!
//! One joint of the plant is free (configuration c6: joint 0); the wall is at q = 0 and the
//! joint is inside when q < 0. A digital controller samples the encoder at `rate` Hz
//! (position quantised to 2π / counts), estimates q̇ by the backward difference of two
//! samples, computes the wall output u(q, q̇) in the thesis's sign (negative = push on the
//! user), and applies the command τ = −u to the joint through a zero-order hold, `delay`
//! samples late. A hand holds the end point at radius r through a grip spring–damper; an arm
//! drives the hand toward a target inside the wall along a ramp at the approach speed
//! ([`Hand`], [`User`]). Plant, hand and arm are integrated together by RK4 at a fixed step.
//!
//! Metrics ([`Metrics`], formulas in the guide's chapter "Control and the virtual wall", docs/src/guide/control.md): peak and steady penetration,
//! contact losses, restitution, oscillation amplitude and frequency, settling time, and the
//! energy the wall generates, from the hold-aware passivity observer
//! E(n) = E(n−1) − F(n−1)·(q(n) − q(n−1)) with F(n−1) the torque the wall applied over
//! [t(n−1), t(n)].

use super::fuzzy::Fam;
use crate::simulation::{PlantModel, State};
use anyhow::{bail, Result};
use serde::{Deserialize, Serialize};

/// The linear wall law of thesis 5.3, u = k1·q + k2·q̇ inside the wall (q ≤ 0), 0 outside.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PdWall {
    /// Stiffness k1 (N·m/rad of command torque).
    pub k1: f64,
    /// Damping k2 (N·m·s/rad of command torque).
    pub k2: f64,
}

impl PdWall {
    /// u(q, q̇) (N·m, thesis sign: negative pushes the user out).
    pub fn u(&self, q: f64, qd: f64) -> f64 {
        if q <= 0.0 {
            self.k1 * q + self.k2 * qd
        } else {
            0.0
        }
    }
}

/// A wall controller.
#[derive(Debug, Clone, PartialEq)]
pub enum WallLaw {
    /// PD inside the wall (5.3).
    Pd(PdWall),
    /// Fuzzy controller (5.4–5.5).
    Fuzzy(Fam),
}

impl WallLaw {
    /// u(q, q̇) (N·m, thesis sign).
    pub fn u(&self, q: f64, qd: f64) -> f64 {
        match self {
            WallLaw::Pd(p) => p.u(q, qd),
            WallLaw::Fuzzy(f) => f.output(q, qd),
        }
    }
}

/// The hand on the end point and the arm that drives it (one point of the sweep).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Hand {
    /// Distance r of the end point from the joint axis (m).
    pub radius: f64,
    /// Hand mass m_h (kg).
    pub mass: f64,
    /// Grip stiffness k_g between hand and end point (N/m).
    pub grip_stiffness: f64,
    /// Grip damping b_g (N·s/m).
    pub grip_damping: f64,
    /// Arm stiffness k_a pulling the hand to the intended position (N/m).
    pub arm_stiffness: f64,
    /// Arm damping b_a toward the intended velocity (N·s/m).
    pub arm_damping: f64,
}

/// What the user intends: start at rest at `start` (rad, outside the wall), move the intended
/// end point toward `target` (rad, inside) at `speed` (rad/s), then hold.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct User {
    /// Initial joint position (rad), > 0.
    pub start: f64,
    /// Final intended joint position (rad), < 0.
    pub target: f64,
    /// Approach speed of the intention (rad/s), > 0.
    pub speed: f64,
}

impl User {
    /// Intended joint position and velocity at t (rad, rad/s).
    pub fn intention(&self, t: f64) -> (f64, f64) {
        let q = self.start - self.speed * t;
        if q > self.target {
            (q, -self.speed)
        } else {
            (self.target, 0.0)
        }
    }
}

/// The digital loop.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Loop {
    /// Control rate (Hz).
    pub rate: f64,
    /// Samples between measurement and applied torque (thesis hardware: 1).
    pub delay: usize,
    /// Encoder counts per revolution after quadrature (2000 × 4 = 8000); 0 = exact.
    pub encoder_counts: f64,
    /// RK4 step (s); rounded down to divide the control period.
    pub step: f64,
    /// Simulated time (s).
    pub duration: f64,
    /// Command torque limit (N·m, symmetric); 0 = none.
    pub torque_limit: f64,
}

/// Chatter metrics of one run (positions in rad, q < 0 inside).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Default)]
pub struct Metrics {
    /// The joint entered the wall.
    pub contact: bool,
    /// Time of first contact (s).
    pub t_contact: f64,
    /// |q̇| at first contact (rad/s).
    pub approach_speed: f64,
    /// max(−q) after first contact (rad).
    pub peak_penetration: f64,
    /// mean(−q) over the last 20 % of the run (rad).
    pub steady_penetration: f64,
    /// Exits from the wall (q < 0 → q ≥ 0) after first contact.
    pub contact_losses: usize,
    /// |q̇ at first exit| / |q̇ at first contact|; 0 without exit.
    pub restitution: f64,
    /// Half peak-to-peak of q over the second half of the time after contact (rad).
    pub oscillation_amplitude: f64,
    /// Crossings of that window's mean / 2 / window length (Hz).
    pub oscillation_frequency: f64,
    /// Time after first contact from which |q − q_steady| stays within
    /// max(5 % of the peak penetration, 2 encoder counts) (s); None when it never does.
    pub settling_time: Option<f64>,
    /// Energy generated by the wall, max_n(−E(n)) ≥ 0 (J).
    pub energy_generated: f64,
    /// E at the end of the run (J).
    pub energy_final: f64,
}

/// One simulated run.
#[derive(Debug, Clone)]
pub struct Run {
    /// Times of the RK4 steps (s).
    pub t: Vec<f64>,
    /// Joint position at those times (rad).
    pub q: Vec<f64>,
    /// Joint velocity (rad/s).
    pub qd: Vec<f64>,
    /// Control sample times (s).
    pub t_control: Vec<f64>,
    /// Command torque computed at each sample (N·m, before the delay).
    pub tau: Vec<f64>,
    /// Passivity observer E(n) at each sample (J).
    pub energy: Vec<f64>,
    /// Metrics.
    pub metrics: Metrics,
}

fn quantise(q: f64, counts: f64) -> f64 {
    if counts > 0.0 {
        let d = std::f64::consts::TAU / counts;
        (q / d).round() * d
    } else {
        q
    }
}

/// Simulate the wall `law` on free joint `joint` (free index) of `plant` with `hand`
/// driven by `user`, under the digital `lp`.
///
/// # Errors
/// Invalid loop or hand parameters (named), or the simulation diverging (non-finite state,
/// with the time).
pub fn simulate(
    plant: &PlantModel,
    joint: usize,
    law: &WallLaw,
    hand: &Hand,
    user: &User,
    lp: &Loop,
) -> Result<Run> {
    if !(lp.rate > 0.0 && lp.step > 0.0 && lp.duration > 0.0) {
        bail!("loop: rate, step and duration must be positive");
    }
    if !(hand.radius > 0.0 && hand.mass > 0.0) {
        bail!("hand: radius and mass must be positive");
    }
    if !(user.start > 0.0 && user.target < 0.0 && user.speed > 0.0) {
        bail!(
            "user: start must be outside the wall (> 0), target inside (< 0), speed > 0; found start {}, target {}, speed {}",
            user.start,
            user.target,
            user.speed
        );
    }
    if joint >= plant.nf() {
        bail!("wall joint index {joint} is not a free joint of the configuration");
    }
    let nf = plant.nf();
    let period = 1.0 / lp.rate;
    let sub = (period / lp.step).ceil().max(1.0) as usize;
    let h = period / sub as f64;
    let samples = (lp.duration * lp.rate).round() as usize;
    let r = hand.radius;
    let gain = plant.terms[joint].gain;

    let mut q0 = vec![0.0; nf];
    q0[joint] = user.start;
    let mut x = State::at_rest(q0);
    // Hand position (m) and velocity (m/s) along the end point's path.
    let (mut xh, mut vh) = (r * user.start, 0.0);

    // The plant's derivative beside the hand's (position, velocity), with one work space.
    let mut stepper = plant.stepper();
    let mut ext = vec![0.0; nf];
    let mut deriv =
        |x: &State, xh: f64, vh: f64, t: f64, tau: &[f64], dx: &mut State| -> (f64, f64) {
            let (q, qd) = (x.q[joint], x.qd[joint]);
            let f_grip = hand.grip_stiffness * (xh - r * q) + hand.grip_damping * (vh - r * qd);
            let (qi, qdi) = user.intention(t);
            let f_arm = hand.arm_stiffness * (r * qi - xh) + hand.arm_damping * (r * qdi - vh);
            ext[joint] = r * f_grip;
            stepper.derivative_into(t, x, tau, &ext, dx);
            (vh, (f_arm - f_grip) / hand.mass)
        };
    let zero = || State::at_rest(vec![0.0; nf]);
    let [mut k1, mut k2, mut k3, mut k4] = [zero(), zero(), zero(), zero()];
    let mut stage = zero();

    let mut run = Run {
        t: Vec::with_capacity(samples * sub + 1),
        q: Vec::with_capacity(samples * sub + 1),
        qd: Vec::with_capacity(samples * sub + 1),
        t_control: Vec::with_capacity(samples),
        tau: Vec::with_capacity(samples),
        energy: Vec::with_capacity(samples),
        metrics: Metrics::default(),
    };
    run.t.push(0.0);
    run.q.push(x.q[joint]);
    run.qd.push(x.qd[joint]);
    let mut pending = std::collections::VecDeque::from(vec![0.0; lp.delay]);
    let mut q_meas_prev = quantise(user.start, lp.encoder_counts);
    let (mut energy, mut q_prev_true, mut f_prev) = (0.0, x.q[joint], 0.0);
    let mut tau = vec![0.0; nf];
    for n in 0..samples {
        let t = n as f64 * period;
        // Passivity observer with the torque held over the last period.
        energy -= f_prev * (x.q[joint] - q_prev_true);
        q_prev_true = x.q[joint];
        let q_meas = quantise(x.q[joint], lp.encoder_counts);
        let qd_est = if n == 0 {
            0.0
        } else {
            (q_meas - q_meas_prev) / period
        };
        q_meas_prev = q_meas;
        let mut cmd = -law.u(q_meas, qd_est);
        if lp.torque_limit > 0.0 {
            cmd = cmd.clamp(-lp.torque_limit, lp.torque_limit);
        }
        pending.push_back(cmd);
        let applied = pending.pop_front().unwrap_or(cmd);
        tau[joint] = applied;
        f_prev = gain * applied;
        run.t_control.push(t);
        run.tau.push(cmd);
        run.energy.push(energy);
        for s in 0..sub {
            let ts = t + s as f64 * h;
            let (a1, b1) = deriv(&x, xh, vh, ts, &tau, &mut k1);
            x.axpy_into(h / 2.0, &k1, &mut stage);
            let (a2, b2) = deriv(
                &stage,
                xh + h / 2.0 * a1,
                vh + h / 2.0 * b1,
                ts + h / 2.0,
                &tau,
                &mut k2,
            );
            x.axpy_into(h / 2.0, &k2, &mut stage);
            let (a3, b3) = deriv(
                &stage,
                xh + h / 2.0 * a2,
                vh + h / 2.0 * b2,
                ts + h / 2.0,
                &tau,
                &mut k3,
            );
            x.axpy_into(h, &k3, &mut stage);
            let (a4, b4) = deriv(&stage, xh + h * a3, vh + h * b3, ts + h, &tau, &mut k4);
            let c = h / 6.0;
            for i in 0..nf {
                x.q[i] += c * (k1.q[i] + 2.0 * k2.q[i] + 2.0 * k3.q[i] + k4.q[i]);
                x.qd[i] += c * (k1.qd[i] + 2.0 * k2.qd[i] + 2.0 * k3.qd[i] + k4.qd[i]);
                x.z[i] += c * (k1.z[i] + 2.0 * k2.z[i] + 2.0 * k3.z[i] + k4.z[i]);
            }
            xh += c * (a1 + 2.0 * a2 + 2.0 * a3 + a4);
            vh += c * (b1 + 2.0 * b2 + 2.0 * b3 + b4);
            if !(x.q[joint].is_finite() && x.qd[joint].is_finite() && vh.is_finite()) {
                bail!(
                    "wall simulation diverged at t = {:.4} s (step {h} s)",
                    ts + h
                );
            }
            run.t.push(ts + h);
            run.q.push(x.q[joint]);
            run.qd.push(x.qd[joint]);
        }
    }
    energy -= f_prev * (x.q[joint] - q_prev_true);
    run.metrics = metrics(&run, energy, lp.encoder_counts);
    Ok(run)
}

/// The chatter metrics of a run (definitions on [`Metrics`]).
pub fn metrics(run: &Run, energy_final: f64, encoder_counts: f64) -> Metrics {
    let (t, q, qd) = (&run.t, &run.q, &run.qd);
    let mut m = Metrics {
        energy_final,
        energy_generated: run
            .energy
            .iter()
            .chain([&energy_final])
            .fold(0.0f64, |a, &e| a.max(-e)),
        ..Metrics::default()
    };
    let Some(c) = q.iter().position(|&x| x < 0.0) else {
        return m;
    };
    let n = q.len();
    let t_end = t[n - 1];
    m.contact = true;
    m.t_contact = t[c];
    m.approach_speed = qd[c].abs();
    m.peak_penetration = q[c..].iter().fold(0.0f64, |a, &x| a.max(-x));
    let tail = t.partition_point(|&x| x < t_end - 0.2 * t_end);
    let tail = tail.min(n - 1);
    let q_ss = q[tail..].iter().sum::<f64>() / (n - tail) as f64;
    m.steady_penetration = -q_ss;
    let mut first_exit = None;
    for k in c + 1..n {
        if q[k - 1] < 0.0 && q[k] >= 0.0 {
            m.contact_losses += 1;
            if first_exit.is_none() {
                first_exit = Some(k);
            }
        }
    }
    m.restitution = first_exit.map_or(0.0, |k| qd[k].abs() / m.approach_speed.max(1e-300));
    let w0 = t.partition_point(|&x| x < m.t_contact + 0.5 * (t_end - m.t_contact));
    let w0 = w0.min(n - 1);
    let win = &q[w0..];
    let (lo, hi) = win
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
            (a.min(x), b.max(x))
        });
    m.oscillation_amplitude = 0.5 * (hi - lo);
    let mean = win.iter().sum::<f64>() / win.len() as f64;
    let crossings = win
        .windows(2)
        .filter(|p| (p[0] - mean) * (p[1] - mean) < 0.0)
        .count();
    let dur = t_end - t[w0];
    m.oscillation_frequency = if dur > 0.0 {
        crossings as f64 / 2.0 / dur
    } else {
        0.0
    };
    let count = if encoder_counts > 0.0 {
        std::f64::consts::TAU / encoder_counts
    } else {
        1e-5
    };
    let band = (0.05 * m.peak_penetration).max(2.0 * count);
    let last_out = (c..n).rev().find(|&k| (q[k] - q_ss).abs() > band);
    m.settling_time = match last_out {
        None => Some(0.0),
        Some(k) if k + 1 < n && t_end - t[k + 1] > 0.1 * (t_end - m.t_contact) => {
            Some(t[k + 1] - m.t_contact)
        }
        Some(_) => None,
    };
    m
}
