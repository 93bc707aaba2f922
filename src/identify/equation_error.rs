//! Equation-error (inverse-dynamics) warm start of an output-error fit.
//!
//! Output error (thesis 4.2/4.3) compares simulated with measured positions: over a long
//! file the simulation of a far-off guess drifts, and the cost has local minima the
//! optimiser cannot leave (the isolated c4 step of the Freedom 6S from the Appendix D guess
//! stalls at 5e5 in the growing horizons). The equation error compares torques instead, at
//! every sample, from the measured motion: it needs no simulation, has no drift, and is
//! nearly quadratic in the parameters (linear in the barycentric parameters, the friction
//! levels and the springs; Gautier's IDIM, here with the nonlinear effects kept). Its
//! minimum is biased by the filtering and by the LuGre bristles being driven by estimated
//! velocities, so it only warm-starts the output-error stages.
//!
//! Per file, as [`super::idim`]: positions low-passed forward and backward (Butterworth,
//! zero phase), velocities and accelerations by central differences; the commanded torque,
//! held (ZOH) over each sample period, averaged over the two periods a central difference
//! spans and passed through the same filter. The LuGre deflections z are integrated along
//! the estimated velocities from z = 0 at each file's start (exactly for a velocity held
//! over a sample period: z relaxes to g(v) sign(v) / σ0 at rate σ0 |v| / g(v)). The residual
//! of free joint a at sample k, in commanded-torque units, is
//!
//! e_a,k = (Kp_a τ'_a,k − b F_a(q, q̇, z) − Ks_a (q_a − qeq_a) − offset_a − Y_F,a(q, q̇, q̈) p) / (Kp_a s_a)
//!
//! with τ' the command after the tendon couplings (4.5–4.6), p the barycentric parameters,
//! Y_F the generated regressor, and s_a the RMS of joint a's commanded torque over the files
//! (so that every joint's equation counts alike). Dividing by Kp keeps the exact scale
//! symmetry of the output-error cost (Kp with every force of its joint): the equation error
//! is the same all along it, as the positions are. The friction position bias's switch at
//! qeq is smoothed over `BIAS_WIDTH` (a jump would stall the finite-difference optimiser).

use super::output_error::Record;
use crate::plant::{ConsistencyPolicy, Plant};
use crate::signal::{butter_lowpass, central_difference};
use crate::simulation::{PlantModel, TorqueTerm};
use anyhow::{bail, Result};
use generated::Configuration;

/// Samples left out at each end of a file: the ends of a forward-backward filter and of
/// the double central difference are the least accurate.
const EDGE: usize = 10;

/// Cut-off of the position filter as a fraction of the Nyquist frequency (0.2: 10 Hz at
/// 100 Hz sampling, above the thesis's excitation frequencies).
pub const DEFAULT_CUTOFF: f64 = 0.2;

/// Candidate cut-offs (fractions of the Nyquist frequency) of [`Cutoff::Residual`].
pub const RESIDUAL_CUTOFFS: [f64; 9] = [0.1, 0.15, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8];

/// [`Cutoff::Residual`] takes the lowest candidate whose removed power is at most this
/// factor squared times the white noise's share above the cut-off (1.1: RMS within 10 %).
pub const RESIDUAL_TOLERANCE: f64 = 1.1;

/// Samples left out at each end of a file in [`residual_cutoff`] (0.5 s at 100 Hz).
const RESIDUAL_MARGIN: usize = 50;

/// The position filter's cut-off.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Cutoff {
    /// The same cut-off for every joint, a fraction of the Nyquist frequency in (0, 1).
    Fixed(f64),
    /// Per joint by residual analysis (Winter, *Biomechanics and Motor Control of Human
    /// Movement*, 4th ed., 2009, §3.4.4.3): the lowest of [`RESIDUAL_CUTOFFS`] whose
    /// filter removes from the measured positions no more power than the noise has above
    /// the cut-off, RMS(y − ŷ_fc)² ≤ [`RESIDUAL_TOLERANCE`]² σ̂² (1 − fc), σ̂ the joint's
    /// noise estimated from the data ([`crate::signal::noise_sigma`]), pooled over the
    /// files; the highest candidate if none qualifies. A light joint with fast content
    /// (the Freedom 6S wrist under Table 4.7) gets a high cut-off and a heavy, slow one a
    /// low cut-off, where one value for all hurts one or the other: at the truth of k2,
    /// joint 5's torque balance has RMS 0.69 of its command at 0.2 and 0.27 at 0.6, while
    /// in k4 joint 1's rises from 0.90 to 2.76.
    Residual,
}

impl std::fmt::Display for Cutoff {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Cutoff::Fixed(c) => write!(f, "{c}"),
            Cutoff::Residual => write!(f, "by residual analysis"),
        }
    }
}

/// Per free joint (NF values), the cut-off [`Cutoff::Residual`] chooses on the measured
/// positions of `records` (see there). A joint whose positions show no noise gets the
/// highest candidate.
pub fn residual_cutoffs(records: &[Record], nf: usize) -> Vec<f64> {
    (0..nf)
        .map(|a| {
            let columns: Vec<&[f64]> = records
                .iter()
                .filter_map(|r| r.q.get(a).map(Vec::as_slice))
                .collect();
            residual_cutoff(&columns)
        })
        .collect()
}

/// The cut-off [`Cutoff::Residual`] chooses for one joint measured in the files `columns`
/// (positions at their sampling rate).
pub fn residual_cutoff(columns: &[&[f64]]) -> f64 {
    let last = RESIDUAL_CUTOFFS[RESIDUAL_CUTOFFS.len() - 1];
    // The filter's start-up at either end of a file is no measure of the motion.
    let inner = |c: &[f64]| {
        if c.len() > 8 * RESIDUAL_MARGIN {
            RESIDUAL_MARGIN..c.len() - RESIDUAL_MARGIN
        } else {
            0..c.len()
        }
    };
    let n: usize = columns.iter().map(|c| inner(c).len()).sum();
    let noise: f64 = columns
        .iter()
        .map(|c| crate::signal::noise_sigma(c).powi(2) * inner(c).len() as f64)
        .sum::<f64>()
        / n.max(1) as f64;
    if noise.is_nan() || noise <= 0.0 {
        return last;
    }
    RESIDUAL_CUTOFFS
        .iter()
        .copied()
        .find(|&fc| {
            let filter = butter_lowpass(ORDER, fc);
            let removed: f64 = columns
                .iter()
                .map(|c| match filter.filtfilt(c) {
                    Some(f) => inner(c).map(|k| (c[k] - f[k]).powi(2)).sum(),
                    None => f64::INFINITY,
                })
                .sum::<f64>()
                / n as f64;
            removed <= RESIDUAL_TOLERANCE.powi(2) * noise * (1.0 - fc)
        })
        .unwrap_or(last)
}

/// Width (rad) of the logistic step that stands for the friction position bias's switch
/// at q = qeq (thesis 4.3.5: all friction × FrictionBias where q < qeq). A sharp switch
/// makes the equation error jump wherever a sample crosses qeq, and a finite-difference
/// Jacobian then sees a derivative of about the jump / the step: the optimiser stalls.
const BIAS_WIDTH: f64 = 2e-3;

/// Order of the Butterworth position filter.
const ORDER: usize = 4;

/// A torque u(q, q̇, τ) of the free joints' positions, velocities and commands (NF each),
/// N·m or N ([`EquationError::torque_columns`]).
pub type TorqueFn<'a> = &'a (dyn Fn(&[f64], &[f64], &[f64]) -> f64 + Sync);

/// One file prepared for the equation error.
#[derive(Debug, Clone)]
struct Prepared {
    /// Positions of every joint (NJ): the locked joints' values.
    q_all: Vec<f64>,
    /// Sampling period (s).
    dt: f64,
    /// Sample times (s).
    t: Vec<f64>,
    /// Filtered positions per free joint (NF × n).
    q: Vec<Vec<f64>>,
    /// Velocities per free joint (NF × n).
    qd: Vec<Vec<f64>>,
    /// Accelerations per free joint (NF × n), for the armatures.
    qdd: Vec<Vec<f64>>,
    /// Filtered held commands per free joint (NF × n).
    tau: Vec<Vec<f64>>,
    /// Regressor rows at the used samples: per used sample, NF × (present parameters).
    y: Vec<f64>,
}

/// The equation error of one configuration on a set of files, ready to evaluate at any
/// parameter values (see the module documentation).
#[derive(Debug, Clone)]
pub struct EquationError {
    conf: &'static Configuration,
    files: Vec<Prepared>,
    /// 1 / s_a per free joint.
    scale: Vec<f64>,
    /// The position filter's cut-off per free joint (fraction of the Nyquist frequency).
    cutoffs: Vec<f64>,
    /// Number of residuals.
    len: usize,
}

impl EquationError {
    /// Prepare the files `records` of configuration `conf` of `plant`'s model (their
    /// locked joints' positions, measured positions and commanded torques); `cutoff` sets
    /// the filter's cut-off as a fraction of each file's Nyquist frequency, one for every
    /// joint or per joint ([`Cutoff`]); joint a's positions and command go through joint
    /// a's filter.
    ///
    /// # Errors
    /// A file with fewer than 4·EDGE + 12 samples, or a cut-off outside (0, 1).
    pub fn new(
        plant: &Plant,
        conf: &'static Configuration,
        records: &[Record],
        cutoff: Cutoff,
    ) -> Result<EquationError> {
        let nf = conf.free.len();
        let cutoffs = match cutoff {
            Cutoff::Fixed(c) => {
                if !(c > 0.0 && c < 1.0) {
                    bail!("equation error: the filter cut-off must lie in (0, 1) of the Nyquist frequency, got {c}");
                }
                vec![c; nf]
            }
            Cutoff::Residual => residual_cutoffs(records, nf),
        };
        let np = conf.params_present.len();
        let np_all = plant.model.params.len();
        let filters: Vec<_> = cutoffs.iter().map(|&c| butter_lowpass(ORDER, c)).collect();
        let mut prepared = Vec::with_capacity(records.len());
        let mut sum_sq = vec![0.0; nf];
        let mut count = 0usize;
        for Record {
            file,
            q_all,
            dt,
            t,
            q,
            tau,
            ..
        } in records
        {
            let n = q.first().map_or(0, Vec::len);
            if n < 4 * EDGE + 12 {
                bail!(
                    "{}: {n} samples, the equation error needs at least {}",
                    file.display(),
                    4 * EDGE + 12
                );
            }
            let filt = |a: usize, x: &[f64]| filters[a].filtfilt(x).unwrap_or_else(|| x.to_vec());
            let qf: Vec<Vec<f64>> = q.iter().enumerate().map(|(a, c)| filt(a, c)).collect();
            let qd: Vec<Vec<f64>> = qf.iter().map(|c| central_difference(c, *dt)).collect();
            let qdd: Vec<Vec<f64>> = qd.iter().map(|c| central_difference(c, *dt)).collect();
            // The command held over [t_k, t_k+1): a central difference at k spans the
            // periods of τ_k−1 and τ_k.
            let tauf: Vec<Vec<f64>> = tau
                .iter()
                .enumerate()
                .map(|(a, c)| {
                    let held: Vec<f64> = (0..n)
                        .map(|k| 0.5 * (c[k.saturating_sub(1)] + c[k]))
                        .collect();
                    filt(a, &held)
                })
                .collect();
            let mut y = Vec::with_capacity((n - 2 * EDGE) * nf * np);
            let mut q_full = q_all.clone();
            let mut qdk = vec![0.0; nf];
            let mut qddk = vec![0.0; nf];
            let mut yk = vec![0.0; nf * np_all];
            for k in EDGE..n - EDGE {
                for (a, &j) in conf.free.iter().enumerate() {
                    q_full[j] = qf[a][k];
                    qdk[a] = qd[a][k];
                    qddk[a] = qdd[a][k];
                    sum_sq[a] += tau[a][k] * tau[a][k];
                }
                count += 1;
                (conf.regressor)(&q_full, &qdk, &qddk, &mut yk);
                for a in 0..nf {
                    y.extend(conf.params_present.iter().map(|&j| yk[a * np_all + j]));
                }
            }
            prepared.push(Prepared {
                q_all: q_all.clone(),
                dt: *dt,
                t: t.clone(),
                q: qf,
                qd,
                qdd,
                tau: tauf,
                y,
            });
        }
        let rms: Vec<f64> = sum_sq
            .iter()
            .map(|s| (s / count.max(1) as f64).sqrt())
            .collect();
        let largest = rms.iter().copied().fold(0.0, f64::max);
        let scale = rms
            .iter()
            .map(|&s| {
                // A joint without command of its own (moved by a coupling or the others)
                // weighs as the most driven one.
                let s = if s > 1e-9 * largest { s } else { largest };
                if s > 0.0 {
                    1.0 / s
                } else {
                    1.0
                }
            })
            .collect();
        Ok(EquationError {
            conf,
            len: count * nf,
            files: prepared,
            scale,
            cutoffs,
        })
    }

    /// Number of residuals (used samples × free joints).
    pub fn len(&self) -> usize {
        self.len
    }

    /// The position filter's cut-off per free joint (NF fractions of the Nyquist
    /// frequency), as given or as [`Cutoff::Residual`] chose them.
    pub fn cutoffs(&self) -> &[f64] {
        &self.cutoffs
    }

    /// True when there are no residuals.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The columns, aligned with [`EquationError::residuals`], of torques taken from free
    /// joints: for each `(a, u)`, u(q, q̇, τ) of the free joints' filtered positions,
    /// velocities and held commands (NF each) at the rows of joint a, divided by that
    /// joint's Kp_a s_a (0 at the other joints' rows). A torque u missing from `plant`
    /// leaves the residual e ≈ Σ θ u / (Kp s): the least squares of e on such columns
    /// estimates θ in torque units (N·m or N). Also the residuals' segment lengths (one per
    /// file and free joint, for [`crate::diagnose::effective_samples`] after
    /// [`EquationError::by_joint`]).
    ///
    /// # Errors
    /// The plant cannot be configured (a parameter without value, …).
    pub fn torque_columns(
        &self,
        plant: &Plant,
        terms: &[(usize, TorqueFn)],
    ) -> Result<Vec<Vec<f64>>> {
        let nf = self.conf.free.len();
        let Some(first) = self.files.first() else {
            return Ok(vec![Vec::new(); terms.len()]);
        };
        let model = plant
            .simulator(self.conf.name, &first.q_all, ConsistencyPolicy::Warn)?
            .model;
        let mut out = vec![Vec::with_capacity(self.len); terms.len()];
        let (mut q, mut qd, mut tau) = (vec![0.0; nf], vec![0.0; nf], vec![0.0; nf]);
        for f in &self.files {
            let n = f.q[0].len();
            for k in EDGE..n - EDGE {
                for a in 0..nf {
                    q[a] = f.q[a][k];
                    qd[a] = f.qd[a][k];
                    tau[a] = f.tau[a][k];
                }
                for a in 0..nf {
                    let gain = model.terms[a].gain;
                    let gain = if gain.abs() > f64::MIN_POSITIVE {
                        gain
                    } else {
                        1.0
                    };
                    for (c, (b, u)) in out.iter_mut().zip(terms) {
                        c.push(if *b == a {
                            u(&q, &qd, &tau) * self.scale[a] / gain
                        } else {
                            0.0
                        });
                    }
                }
            }
        }
        Ok(out)
    }

    /// `v` (aligned with [`EquationError::residuals`]) split by free joint: NF vectors,
    /// each joint's rows in order (files one after the other), and the lengths of the
    /// files' segments in each.
    pub fn by_joint(&self, v: &[f64]) -> (Vec<Vec<f64>>, Vec<usize>) {
        let nf = self.conf.free.len();
        let mut out = vec![Vec::with_capacity(v.len() / nf.max(1)); nf];
        for (i, x) in v.iter().enumerate() {
            out[i % nf].push(*x);
        }
        let segments = self
            .files
            .iter()
            .map(|f| f.q[0].len().saturating_sub(2 * EDGE))
            .collect();
        (out, segments)
    }

    /// The residuals e_a,k of `plant`, file by file, sample by sample, joint by joint.
    ///
    /// # Errors
    /// The plant cannot be configured (a parameter without value, LuGre with vs ≤ 0, …).
    pub fn residuals(&self, plant: &Plant) -> Result<Vec<f64>> {
        let mut out = Vec::with_capacity(self.len);
        let Some(first) = self.files.first() else {
            return Ok(out);
        };
        let mut model = plant
            .simulator(self.conf.name, &first.q_all, ConsistencyPolicy::Warn)?
            .model;
        // The friction position bias switches at q = qeq: smoothed here (see
        // [`BIAS_WIDTH`]), so it is taken out of the model's friction.
        let bias: Vec<Option<(f64, f64)>> = model.terms.iter_mut().map(|t| t.bias.take()).collect();
        let p: Vec<f64> = self
            .conf
            .params_present
            .iter()
            .map(|&j| model.p[j])
            .collect();
        for f in &self.files {
            self.file_residuals(&model, &bias, &p, f, &mut out);
        }
        Ok(out)
    }

    fn file_residuals(
        &self,
        model: &PlantModel,
        bias: &[Option<(f64, f64)>],
        p: &[f64],
        f: &Prepared,
        out: &mut Vec<f64>,
    ) {
        let nf = self.conf.free.len();
        let np = p.len();
        let n = f.q[0].len();
        let mut z = vec![0.0; nf];
        let mut tau = vec![0.0; nf];
        let mut tc = vec![0.0; nf];
        let (mut qk, mut qdk) = (vec![0.0; nf], vec![0.0; nf]);
        let mut row = 0;
        for k in 1..n - EDGE {
            // Bristles: the velocity of sample k held over the period before it.
            for (a, za) in z.iter_mut().enumerate() {
                if let Some(l) = &model.terms[a].lugre {
                    let v = f.qd[a][k];
                    let g = l.g(v);
                    let rate = l.sigma0 * v.abs() / g;
                    if rate > 0.0 && rate.is_finite() {
                        let z_ss = v / rate;
                        *za = z_ss + (*za - z_ss) * (-rate * f.dt).exp();
                    }
                }
            }
            if k < EDGE {
                continue;
            }
            for a in 0..nf {
                tau[a] = f.tau[a][k];
                qk[a] = f.q[a][k];
                qdk[a] = f.qd[a][k];
            }
            model.coupled_command(&tau, &mut tc);
            for (a, t) in model.terms.iter().enumerate() {
                let q = f.q[a][k];
                let (mut friction, _) = model.friction(a, q, f.qd[a][k], z[a]);
                if let Some((factor, qeq)) = bias[a] {
                    let below = 1.0 / (1.0 + ((q - qeq) / BIAS_WIDTH).exp());
                    friction *= 1.0 + (factor - 1.0) * below;
                }
                let spring = t.spring.map_or(0.0, |(ks, qeq)| ks * (q - qeq));
                let extra: f64 = t
                    .extra
                    .iter()
                    .map(|e| {
                        e.torque(f.t[k], &qk, &qdk, &z, &tau)
                            + e.inertia
                                .iter()
                                .map(|(b, program, inputs)| {
                                    TorqueTerm::coefficient(
                                        program,
                                        inputs,
                                        f.t[k],
                                        (&qk, &qdk, &z, &tau),
                                    ) * f.qdd[*b][k]
                                })
                                .sum::<f64>()
                    })
                    .sum();
                let yk = &f.y[(row * nf + a) * np..(row * nf + a + 1) * np];
                let rigid: f64 =
                    yk.iter().zip(p).map(|(y, p)| y * p).sum::<f64>() + t.armature * f.qdd[a][k];
                let gain = if t.gain.abs() > f64::MIN_POSITIVE {
                    t.gain
                } else {
                    1.0
                };
                out.push(
                    (t.gain * tc[a] - friction - spring - extra - t.offset - rigid) / gain
                        * self.scale[a],
                );
            }
            row += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// White noise of σ = 2e-4 on a sine of `amplitude` (rad) at `hz` (100 Hz sampling,
    /// 40 s): Gaussian by Box–Muller from a fixed linear congruential sequence.
    fn measured(amplitude: f64, hz: f64) -> Vec<f64> {
        let mut state = 12345u64;
        let mut uniform = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        (0..4000)
            .map(|k| {
                let t = k as f64 * 0.01;
                let g =
                    (-2.0 * uniform().ln()).sqrt() * (2.0 * std::f64::consts::PI * uniform()).cos();
                amplitude * (2.0 * std::f64::consts::PI * hz * t).sin() + 2e-4 * g
            })
            .collect()
    }

    /// Residual analysis against the filter's analytic response. The forward-backward
    /// 4th-order Butterworth (bilinear, prewarped) passes a sine at f with gain
    /// 1 / (1 + (tan(π f/fs) / tan(π fc/2))⁸) for a cut-off fc of the Nyquist frequency.
    /// A 3 Hz sine of 0.05 rad: at fc = 0.1 (5 Hz) the ratio is 0.598, the gain 0.984,
    /// the removed power ½ (0.016 · 0.05)² = 3.2e-7 — far above the allowed
    /// 1.1² σ² (1 − fc) = 4.4e-8 — while at 0.15 the ratio is 0.394, the removed power
    /// 4e-10: 0.15 is chosen. A 0.5 Hz sine loses nothing at 0.1, nor does noise alone:
    /// the lowest candidate.
    #[test]
    fn residual_analysis_keeps_the_motion_and_removes_only_noise() {
        assert_eq!(residual_cutoff(&[&measured(0.5, 0.5)]), 0.1);
        assert_eq!(residual_cutoff(&[&measured(0.05, 3.0)]), 0.15);
        assert_eq!(residual_cutoff(&[&measured(0.0, 0.0)]), 0.1);
        // Two files pooled: the 3 Hz one decides.
        let (a, b) = (measured(0.5, 0.5), measured(0.05, 3.0));
        assert_eq!(residual_cutoff(&[&a, &b]), 0.15);
        // A constant column has no noise to compare with: the highest candidate.
        assert_eq!(residual_cutoff(&[&[1.0; 100]]), 0.8);
    }
}
