//! Model versus measurement (anchor: MATLAB's `compare` and `resid`), in two spaces:
//! - torque space ([`compare_torque`], inverse model): the measured torque y against the
//!   model's W θ on the same prepared (filtered, differentiated, decimated) data;
//! - output space ([`compare_output`]): the measured positions against the plant simulated
//!   on the measured torques.
//!
//! Each joint of each file gives a [`Comparison`]: RMSE, NRMSE fit %, relative error, the
//! largest error and where it occurs (time, position, velocity), and the residual tests of
//! [`residual_tests`]: autocorrelation (whiteness) and cross-correlation with the inputs
//! with 99 % bounds, the residual spectrum with the input frequencies. Plots show measured
//! vs model, the residual against time, position, velocity (by the sign of the velocity)
//! and the other joints' torques, the spectrum and both correlations.

use crate::files::write_atomic_with;
use crate::identify::idim::{observation, predict, IdimOptions, Observation};
use crate::identify::output_error::{Problem, Record};
use crate::identify::refit::RefitOptions;
use crate::measurement::Measurement;
use crate::plant::Plant;
use crate::report::plot::{figure, Panel, Series, Style};
use crate::simulation::Hold;
use anyhow::{anyhow, bail, Result};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Comparison of one joint of one record.
#[derive(Debug, Clone)]
pub struct Comparison {
    /// Record file.
    pub file: PathBuf,
    /// Joint name.
    pub joint: String,
    /// Time (s) of each decimated sample.
    pub t: Vec<f64>,
    /// Filtered position (rad or m).
    pub q: Vec<f64>,
    /// Velocity (rad/s or m/s).
    pub qd: Vec<f64>,
    /// Measured torque or force (N·m or N), after the parallel decimation.
    pub y: Vec<f64>,
    /// Model torque or force.
    pub yhat: Vec<f64>,
    /// Relative error 100·‖y − ŷ‖/‖y‖ (%).
    pub relative_error: f64,
    /// Root-mean-square residual (N·m or N).
    pub rmse: f64,
    /// Largest |residual| and the time (s) and velocity where it occurs.
    pub max_error: (f64, f64, f64),
    /// Least-squares fit of the residual to `a·sign(q̇) + b + c·q̇`, as (a, b): a step of 2a
    /// across q̇ = 0 is the signature of missing Coulomb friction, b of a missing offset.
    pub sign_step: (f64, f64),
    /// NRMSE fit % = 100 (1 − ‖y − ŷ‖/‖y − ȳ‖), as MATLAB's `compare`.
    pub nrmse_fit: f64,
    /// Position (rad or m) at the largest |residual|.
    pub max_error_q: f64,
    /// Sampling period of `t` (s).
    pub dt: f64,
    /// Signals the residual is tested against, by name: in output space every free joint's
    /// commanded torque (N·m), in torque space the velocity and the other joints' torques.
    pub inputs: Vec<(String, Vec<f64>)>,
    /// Unit of y.
    pub unit: &'static str,
    /// Residual tests.
    pub tests: ResidualTests,
}

/// Residual analysis as MATLAB's `resid`, for N samples of residual e and inputs u.
///
/// Autocorrelation ρ_ee(τ) = r_ee(τ)/r_ee(0), r_ee(τ) = (1/N) Σ_t e_t e_{t+τ}, τ = 0..M,
/// with the 99 % whiteness bound ±2.58/√N; cross-correlation ρ_eu(τ) = r_eu(τ)/√(r_ee(0)
/// r_uu(0)), r_eu(τ) = (1/N) Σ_t e_{t+τ} u_t, τ = −M..M, with the 99 % bound
/// 2.58 √(Σ_{k=−M}^{M} ρ_ee(k) ρ_uu(k) / N) (Ljung, System Identification, 16.6); the
/// residual amplitude spectrum (Hann-windowed periodogram) with the inputs' spectral peaks.
#[derive(Debug, Clone, Default)]
pub struct ResidualTests {
    /// Largest lag M.
    pub max_lag: usize,
    /// ρ_ee(τ), τ = 0..M.
    pub autocorrelation: Vec<f64>,
    /// Whiteness bound 2.58/√N.
    pub autocorrelation_bound: f64,
    /// Per input: name, ρ_eu(τ) for τ = −M..M, bound.
    pub cross_correlation: Vec<(String, Vec<f64>, f64)>,
    /// Frequencies (Hz) and residual amplitude spectrum.
    pub spectrum: (Vec<f64>, Vec<f64>),
    /// Frequencies (Hz) of the inputs' spectral peaks.
    pub input_frequencies: Vec<f64>,
    /// Lags τ ≥ 1 where |ρ_ee| exceeds the bound (a white residual has about 1 % of them).
    pub lags_outside: usize,
    /// Inputs whose cross-correlation leaves its bound at some lag.
    pub correlated_inputs: Vec<String>,
    /// The portmanteau test over lags 1..=M ([`whiteness`]): the residual is white when
    /// it passes.
    pub whiteness: Whiteness,
}

impl ResidualTests {
    /// One line for a reader: is the residual white ([`Whiteness::white`]), does it
    /// depend on an input.
    pub fn verdict(&self) -> String {
        let white = if self.whiteness.white() {
            format!(
                "the residual is white ({}; the model explains the dynamics)",
                self.whiteness.text()
            )
        } else {
            format!(
                "the residual is not white ({}; {} of {} lags outside ±{:.3}): dynamics the model lacks",
                self.whiteness.text(),
                self.lags_outside,
                self.max_lag,
                self.autocorrelation_bound
            )
        };
        if self.correlated_inputs.is_empty() {
            format!("{white}; no correlation with the inputs")
        } else {
            format!(
                "{white}; it correlates with {} (an input path is missing or wrong: gain, coupling, friction)",
                self.correlated_inputs.join(", ")
            )
        }
    }
}

/// Significance level of the whiteness test: a white residual fails it with this
/// probability.
pub const WHITENESS_LEVEL: f64 = 0.01;

/// The Ljung–Box portmanteau test of a residual's whiteness (Ljung & Box, Biometrika
/// 65, 1978): with ρ_k the autocorrelation at lag k pooled over the residual's segments
/// (each demeaned; lags taken within a segment, so files are not joined) and N samples in
/// all, Q = N (N + 2) Σ_{k=1}^{M} ρ_k² / (N − k), which is χ²(M) for a white residual;
/// the residual is white when Q ≤ the χ²(M) quantile at 1 − [`WHITENESS_LEVEL`]
/// (Wilson–Hilferty: M (1 − 2/(9M) + z √(2/(9M)))³, z = 2.326; within 0.5 % of the
/// exact quantile for M ≥ 10).
#[derive(Debug, Clone, Default)]
pub struct Whiteness {
    /// Q.
    pub statistic: f64,
    /// The χ²(M) quantile Q is compared with.
    pub critical: f64,
    /// Lags M.
    pub max_lag: usize,
    /// The largest |ρ_k|, 1 ≤ k ≤ M: about the share of the residual's energy in its
    /// coloured part (a white residual has ρ_k ≈ 0; a component smooth or periodic at the
    /// sampling scale carrying a share s of the energy gives |ρ_k| ≈ s at some lag).
    pub largest: f64,
    /// Samples N.
    pub samples: usize,
}

impl Whiteness {
    /// The coloured share of the residual's energy, estimated as the largest |ρ_k| less
    /// what white noise reaches by chance over M lags (each ρ_k of N white samples has
    /// standard deviation 1/√N; their largest |ρ_k| over 25 lags stays below 3/√N in 99 %
    /// of records), at least 0.
    pub fn coloured_share(&self) -> f64 {
        (self.largest - 3.0 / (self.samples.max(1) as f64).sqrt()).max(0.0)
    }

    /// Q ≤ the critical value (also true of a residual too short or without energy).
    pub fn white(&self) -> bool {
        self.statistic <= self.critical
    }

    /// "Ljung–Box Q = 31.2 ≤ 44.3 over 25 lags".
    pub fn text(&self) -> String {
        format!(
            "Ljung–Box Q = {:.1} {} {:.1} over {} lags",
            self.statistic,
            if self.white() { "≤" } else { ">" },
            self.critical,
            self.max_lag
        )
    }
}

/// The standard normal quantile at 1 − [`WHITENESS_LEVEL`], for the Wilson–Hilferty
/// critical value of [`Whiteness`].
const WHITENESS_Z: f64 = 2.326_347_874;

/// The Ljung–Box test ([`Whiteness`]) of the autocorrelations `rho` (ρ_1 … ρ_M) of `n`
/// samples.
fn ljung_box(rho: &[f64], n: usize) -> Whiteness {
    let nf = n as f64;
    let statistic = nf
        * (nf + 2.0)
        * rho
            .iter()
            .enumerate()
            .map(|(i, r)| r * r / (nf - (i + 1) as f64))
            .sum::<f64>();
    let m = rho.len();
    let critical = if m > 0 {
        let mf = m as f64;
        let a = 2.0 / (9.0 * mf);
        mf * (1.0 - a + WHITENESS_Z * a.sqrt()).powi(3)
    } else {
        f64::INFINITY
    };
    Whiteness {
        statistic,
        critical,
        max_lag: m,
        largest: rho.iter().fold(0.0f64, |a, r| a.max(r.abs())),
        samples: n,
    }
}

/// The whiteness test ([`Whiteness`]) of a residual given as `segments` (each one file's
/// samples in time order), lags 1..=`max_lag` (fewer when the segments are short).
pub fn whiteness(segments: &[&[f64]], max_lag: usize) -> Whiteness {
    let n: usize = segments.iter().map(|s| s.len()).sum();
    let longest = segments.iter().map(|s| s.len()).max().unwrap_or(0);
    let m = max_lag.min(longest.saturating_sub(2));
    let centred: Vec<Vec<f64>> = segments.iter().map(|s| demean(s)).collect();
    let lagged = |k: usize| -> f64 {
        centred
            .iter()
            .map(|e| {
                e.iter()
                    .zip(e.iter().skip(k))
                    .map(|(a, b)| a * b)
                    .sum::<f64>()
            })
            .sum()
    };
    let r0 = lagged(0);
    let rho: Vec<f64> = (1..=m)
        .map(|k| if r0 > 0.0 { lagged(k) / r0 } else { 0.0 })
        .collect();
    ljung_box(&rho, n)
}

fn correlation(a: &[f64], b: &[f64], lag: isize) -> f64 {
    let n = a.len().min(b.len());
    let mut s = 0.0;
    for t in 0..n {
        let k = t as isize + lag;
        if k >= 0 && (k as usize) < n {
            s += a[k as usize] * b[t];
        }
    }
    s / n as f64
}

fn demean(v: &[f64]) -> Vec<f64> {
    let m = v.iter().sum::<f64>() / v.len().max(1) as f64;
    v.iter().map(|x| x - m).collect()
}

/// Amplitude spectrum of `x` sampled at `dt` (Hann window, at most 4096 samples by
/// decimation in time; frequencies up to the Nyquist frequency): (f in Hz, amplitude).
pub fn amplitude_spectrum(x: &[f64], dt: f64) -> (Vec<f64>, Vec<f64>) {
    let step = x.len().div_ceil(4096).max(1);
    let v: Vec<f64> = demean(&x.iter().step_by(step).copied().collect::<Vec<_>>());
    let n = v.len();
    if n < 4 {
        return (vec![], vec![]);
    }
    let dtn = dt * step as f64;
    let w: Vec<f64> = (0..n)
        .map(|k| 0.5 - 0.5 * (2.0 * std::f64::consts::PI * k as f64 / (n - 1) as f64).cos())
        .collect();
    let gain: f64 = w.iter().sum();
    let mut f = Vec::with_capacity(n / 2);
    let mut a = Vec::with_capacity(n / 2);
    for m in 0..=n / 2 {
        let (mut re, mut im) = (0.0, 0.0);
        let dphi = -2.0 * std::f64::consts::PI * m as f64 / n as f64;
        let (sd, cd) = dphi.sin_cos();
        let (mut s, mut c) = (0.0f64, 1.0f64);
        for k in 0..n {
            re += w[k] * v[k] * c;
            im += w[k] * v[k] * s;
            let c2 = c * cd - s * sd;
            s = s * cd + c * sd;
            c = c2;
        }
        f.push(m as f64 / (n as f64 * dtn));
        a.push(2.0 * (re * re + im * im).sqrt() / gain);
    }
    (f, a)
}

/// Frequencies of the largest local maxima of an amplitude spectrum (at most `k`, each at
/// least a tenth of the largest).
fn peaks(f: &[f64], a: &[f64], k: usize) -> Vec<f64> {
    let top = a.iter().skip(1).fold(0.0f64, |m, &x| m.max(x));
    let mut p: Vec<(f64, f64)> = (1..a.len().saturating_sub(1))
        .filter(|&i| a[i] >= a[i - 1] && a[i] > a[i + 1] && a[i] >= 0.1 * top && top > 0.0)
        .map(|i| (f[i], a[i]))
        .collect();
    p.sort_by(|x, y| y.1.total_cmp(&x.1));
    p.truncate(k);
    p.into_iter().map(|x| x.0).collect()
}

/// The part of a comparison's residual that a diagnosis finding describes, drawn over the
/// residual figures ([`plot`]): the model's output with the finding applied less the
/// model's, at the comparison's samples (same unit as the residual).
#[derive(Debug, Clone, PartialEq)]
pub struct Described {
    /// The legend, e.g. "finding 1: cubic stiffness on q3".
    pub name: String,
    /// ŷ(plant with the finding) − ŷ(plant), one per sample of the comparison.
    pub e: Vec<f64>,
}

/// A `described` residual of the comparison's length, or the error that names both.
fn check_described(c: &Comparison, described: Option<&Described>) -> Result<()> {
    match described.filter(|d| d.e.len() != c.t.len()) {
        Some(d) => bail!(
            "the residual described by '{}' has {} samples, the comparison of {} {} has {}",
            d.name,
            d.e.len(),
            c.file.display(),
            c.joint,
            c.t.len()
        ),
        None => Ok(()),
    }
}

/// Bins of the trend line drawn over the residual against position and velocity.
pub const TREND_BINS: usize = 40;

/// The trend of `y` against `x`: the samples sorted by x and cut into `bins` groups of
/// equal count, each group's mean x and mean y (a binned-mean smoother: a missing cubic
/// stiffness or a position ripple shows as a curve through the scatter, issue 54 item 4).
/// Non-finite pairs are left out; fewer samples than bins give one point per sample.
pub fn trend(x: &[f64], y: &[f64], bins: usize) -> (Vec<f64>, Vec<f64>) {
    let mut pairs: Vec<(f64, f64)> = x
        .iter()
        .zip(y)
        .filter(|(a, b)| a.is_finite() && b.is_finite())
        .map(|(a, b)| (*a, *b))
        .collect();
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
    let n = pairs.len();
    let bins = bins.clamp(1, n.max(1));
    (0..bins)
        .filter_map(|b| {
            let group = &pairs[b * n / bins..(b + 1) * n / bins];
            (!group.is_empty()).then(|| {
                let k = group.len() as f64;
                (
                    group.iter().map(|p| p.0).sum::<f64>() / k,
                    group.iter().map(|p| p.1).sum::<f64>() / k,
                )
            })
        })
        .unzip()
}

/// The residual tests of residual `e` (sampling period `dt`) against `inputs`, lags up to
/// `max_lag` (MATLAB's default 25).
pub fn residual_tests(
    e: &[f64],
    inputs: &[(String, Vec<f64>)],
    dt: f64,
    max_lag: usize,
) -> ResidualTests {
    let n = e.len();
    let e0 = demean(e);
    let ree0 = correlation(&e0, &e0, 0);
    let m = max_lag.min(n.saturating_sub(2));
    let acf: Vec<f64> = (0..=m)
        .map(|k| {
            if ree0 > 0.0 {
                correlation(&e0, &e0, k as isize) / ree0
            } else {
                0.0
            }
        })
        .collect();
    let whiteness = ljung_box(&acf[1..], n);
    let bound = 2.58 / (n.max(1) as f64).sqrt();
    let lags_outside = acf.iter().skip(1).filter(|x| x.abs() > bound).count();
    let mut ccf = Vec::new();
    let mut correlated = Vec::new();
    for (name, u) in inputs {
        if u.len() != n {
            continue;
        }
        let u0 = demean(u);
        let ruu0 = correlation(&u0, &u0, 0);
        if ruu0 <= 0.0 || ree0 <= 0.0 {
            continue;
        }
        let norm = (ree0 * ruu0).sqrt();
        let c: Vec<f64> = (-(m as isize)..=m as isize)
            .map(|k| correlation(&e0, &u0, k) / norm)
            .collect();
        let p: f64 = (-(m as isize)..=m as isize)
            .map(|k| {
                let k = k.unsigned_abs();
                acf[k] * correlation(&u0, &u0, k as isize) / ruu0
            })
            .sum();
        let b = 2.58 * (p.abs() / n as f64).sqrt();
        if c.iter().any(|x| x.abs() > b) {
            correlated.push(name.clone());
        }
        ccf.push((name.clone(), c, b));
    }
    let spectrum = amplitude_spectrum(e, dt);
    let mut input_frequencies: Vec<f64> = Vec::new();
    for (_, u) in inputs.iter().filter(|(n, _)| n.starts_with("tau")) {
        let (f, a) = amplitude_spectrum(u, dt);
        for x in peaks(&f, &a, 3) {
            if !input_frequencies.iter().any(|y| (y - x).abs() < 1e-9) {
                input_frequencies.push(x);
            }
        }
    }
    ResidualTests {
        max_lag: m,
        autocorrelation: acf,
        autocorrelation_bound: bound,
        cross_correlation: ccf,
        spectrum,
        input_frequencies,
        lags_outside,
        correlated_inputs: correlated,
        whiteness,
    }
}

impl Comparison {
    /// Residuals y − ŷ.
    pub fn residual(&self) -> Vec<f64> {
        self.y.iter().zip(&self.yhat).map(|(a, b)| a - b).collect()
    }
}

/// Compare the plant with each record (inverse model, torque space).
///
/// # Errors
/// As [`observation`] and [`predict`]: unknown configuration, a record too short, a
/// parameter without value.
pub fn compare_torque(
    plant: &Plant,
    config: &str,
    records: &[Measurement],
    opts: &IdimOptions,
) -> Result<Vec<Comparison>> {
    let mut out = Vec::new();
    for m in records {
        let obs = observation(plant, config, std::slice::from_ref(m), opts)?;
        out.extend(compare_observation(plant, &obs, &m.file)?);
    }
    Ok(out)
}

/// Compare the plant with an already prepared observation of one record (`file` names it),
/// one [`Comparison`] per joint.
///
/// # Errors
/// As [`predict`]: a parameter without value.
pub fn compare_observation(
    plant: &Plant,
    obs: &Observation,
    file: &Path,
) -> Result<Vec<Comparison>> {
    let yhat = predict(plant, obs)?;
    let mut joints: Vec<usize> = obs.rows.iter().map(|r| r.joint).collect();
    joints.dedup();
    let column = |j: usize, f: &dyn Fn(usize) -> f64| -> Vec<f64> {
        (0..obs.rows.len())
            .filter(|&i| obs.rows[i].joint == j)
            .map(f)
            .collect()
    };
    let mut out = Vec::new();
    for &j in &joints {
        let t = column(j, &|i| obs.rows[i].t);
        let qd = column(j, &|i| obs.rows[i].qd);
        let mut inputs = vec![("qd".to_string(), qd.clone())];
        for &k in joints.iter().filter(|&&k| k != j) {
            let name = crate::names::column("tau", plant.model.joints[k]);
            inputs.push((name, column(k, &|i| obs.y[i])));
        }
        let dt = if t.len() > 1 { t[1] - t[0] } else { 1.0 };
        out.push(comparison(
            file,
            plant.model.joints[j],
            Signals {
                q: column(j, &|i| obs.rows[i].q),
                y: column(j, &|i| obs.y[i]),
                yhat: column(j, &|i| yhat[i]),
                t,
                qd,
                dt,
                inputs,
            },
            "N·m or N",
        ));
    }
    Ok(out)
}

/// The signals of one joint of one record.
pub(crate) struct Signals {
    pub t: Vec<f64>,
    pub q: Vec<f64>,
    pub qd: Vec<f64>,
    pub y: Vec<f64>,
    pub yhat: Vec<f64>,
    pub dt: f64,
    pub inputs: Vec<(String, Vec<f64>)>,
}

/// The [`Comparison`] of measured `s.y` with modelled `s.yhat` of joint `joint` in `file`,
/// in `unit`: errors, where the largest is, the residual tests.
pub(crate) fn comparison(file: &Path, joint: &str, s: Signals, unit: &'static str) -> Comparison {
    let e: Vec<f64> = s.y.iter().zip(&s.yhat).map(|(a, b)| a - b).collect();
    let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    let imax = (0..e.len())
        .max_by(|&a, &b| e[a].abs().total_cmp(&e[b].abs()))
        .unwrap_or(0);
    let tests = residual_tests(&e, &s.inputs, s.dt, 25);
    Comparison {
        file: file.to_path_buf(),
        joint: joint.to_string(),
        relative_error: 100.0 * norm(&e) / norm(&s.y),
        rmse: norm(&e) / (e.len().max(1) as f64).sqrt(),
        max_error: (e[imax], s.t[imax], s.qd[imax]),
        max_error_q: s.q[imax],
        sign_step: sign_fit(&e, &s.qd),
        nrmse_fit: crate::util::nrmse_fit(&s.y, &s.yhat),
        dt: s.dt,
        inputs: s.inputs,
        unit,
        tests,
        t: s.t,
        q: s.q,
        qd: s.qd,
        y: s.y,
        yhat: s.yhat,
    }
}

/// Output-space comparison of a plant with position records ([`compare_output`]).
#[derive(Debug, Clone)]
pub struct OutputComparison {
    /// One per free joint and record.
    pub comparisons: Vec<Comparison>,
    /// The integration step's check against the data's noise, and the step used.
    pub step: crate::accuracy::StepCheck,
    /// The hold each record was simulated with (the option's or the side file's).
    pub holds: Vec<crate::simulation::Hold>,
    /// The RMS position error over every free joint and record (rad or m) with the holds
    /// used, and with each other hold applied to every record, best first: `(hold, RMS)`.
    pub hold_errors: Vec<(Option<crate::simulation::Hold>, f64)>,
}

/// A markedly better fit: another hold whose RMS error is below this fraction of the RMS
/// error with the holds used.
pub const MARKEDLY_BETTER: f64 = 0.8;

impl OutputComparison {
    /// The hold that fits markedly better than the ones used, with its RMS error and the
    /// RMS error with the holds used.
    pub fn better_hold(&self) -> Option<(crate::simulation::Hold, f64, f64)> {
        let used = self.hold_errors.iter().find(|h| h.0.is_none())?.1;
        self.hold_errors
            .iter()
            .filter_map(|&(h, e)| h.map(|h| (h, e)))
            .filter(|&(_, e)| e < MARKEDLY_BETTER * used)
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(h, e)| (h, e, used))
    }
}

/// Compare the plant simulated on each record's measured torques with its measured
/// positions (output space), one [`Comparison`] per free joint and record; the simulation
/// starts at rest (z = 0) at the first measured position, or, with
/// `options.estimate_initial`, at the initial position that fits the file best
/// ([`Problem::estimate_initial_positions`], as MATLAB `compare`). The step `options.h` is
/// first checked against the data's noise and refined where it is not accurate
/// ([`crate::accuracy::check_step`]); each record's input is held by `options.hold`, else
/// by its side file's hold, and each other hold is tried too so that a markedly better one
/// is reported ([`OutputComparison::better_hold`]). The first `options.skip` samples of
/// each file are simulated but left out of every figure of merit (0: the whole file, as
/// MATLAB `compare`); the initial-position fit uses every sample (the start is seen best
/// before the trajectory amplifies it).
///
/// # Errors
/// Unknown configuration, a parameter without value, a file with no more than `skip`
/// samples (named), a simulation that diverges (file, time and joint named), a step that
/// stays inaccurate after refinement (joint named).
pub fn compare_output(
    plant: &Plant,
    conf_name: &str,
    records: &[Record],
    options: &RefitOptions,
) -> Result<OutputComparison> {
    let conf = crate::util::configuration(plant.model, conf_name).map_err(|e| anyhow!("{e}"))?;
    let skip = options.skip;
    if let Some(r) = records.iter().find(|r| r.t.len() <= skip) {
        bail!(
            "{}: --skip {skip} leaves no samples to compare (the file has {})",
            r.file.display(),
            r.t.len()
        );
    }
    let (problem, step) = crate::accuracy::checked_simulation(plant, conf, records, options)?;
    let problem = if options.estimate_initial {
        problem.with_initial_positions_of(plant)?
    } else {
        problem
    };
    let holds: Vec<Hold> = problem
        .records
        .iter()
        .map(|r| options.hold.unwrap_or(r.hold))
        .collect();
    let rms_of = |p: &Problem| -> Result<f64> {
        let mut sum = 0.0;
        let mut n = 0usize;
        for r in &p.records {
            let traj = p.simulate(plant, r)?;
            for (y, yhat) in r.q.iter().zip(&traj.q) {
                for (a, b) in y[skip..].iter().zip(&yhat[skip..]) {
                    sum += (a - b).powi(2);
                    n += 1;
                }
            }
        }
        Ok((sum / n.max(1) as f64).sqrt())
    };
    let mut out = Vec::new();
    let mut used = (0.0, 0usize);
    for r in &problem.records {
        let traj = problem.simulate(plant, r)?;
        let inputs: Vec<(String, Vec<f64>)> = conf
            .free
            .iter()
            .zip(&r.tau)
            .map(|(&k, u)| {
                (
                    crate::names::column("tau", plant.model.joints[k]),
                    u.clone(),
                )
            })
            .collect();
        for (a, &j) in conf.free.iter().enumerate() {
            for (x, y) in r.q[a][skip..].iter().zip(&traj.q[a][skip..]) {
                used.0 += (x - y).powi(2);
                used.1 += 1;
            }
            out.push(comparison(
                &r.file,
                plant.model.joints[j],
                Signals {
                    t: r.t[skip..].to_vec(),
                    q: r.q[a][skip..].to_vec(),
                    qd: traj.qd[a][skip..].to_vec(),
                    y: r.q[a][skip..].to_vec(),
                    yhat: traj.q[a][skip..].to_vec(),
                    dt: r.dt,
                    inputs: inputs
                        .iter()
                        .map(|(n, u)| (n.clone(), u[skip..].to_vec()))
                        .collect(),
                },
                "rad or m",
            ));
        }
    }
    let mut hold_errors = vec![(None, (used.0 / used.1.max(1) as f64).sqrt())];
    for hold in Hold::ALL {
        if holds.iter().all(|&h| h == hold) {
            continue;
        }
        // A hold that cannot simulate the data (a diverging reconstruction) is no candidate.
        if let Ok(e) = rms_of(&problem.with_hold(Some(hold))) {
            hold_errors.push((Some(hold), e));
        }
    }
    hold_errors.sort_by(|a, b| a.1.total_cmp(&b.1));
    Ok(OutputComparison {
        comparisons: out,
        step,
        holds,
        hold_errors,
    })
}

/// Least squares e ≈ a·sign(q̇) + b + c·q̇, returning (a, b). The velocity term lets a step
/// at zero velocity show even when a fitted viscous coefficient has absorbed part of it.
fn sign_fit(e: &[f64], qd: &[f64]) -> (f64, f64) {
    let n = e.len();
    let sign = crate::effects::sign;
    let a = nalgebra::DMatrix::from_fn(n, 3, |i, c| match c {
        0 => sign(qd[i]),
        1 => 1.0,
        _ => qd[i],
    });
    let y = nalgebra::DVector::from_column_slice(e);
    match crate::util::svd(a).map(|s| s.solve(&y, 1e-12)) {
        Some(Ok(x)) => (x[0], x[1]),
        _ => (0.0, 0.0),
    }
}

/// Write the residual time series: `t, q, qd, y, yhat, residual`, and `described` (what a
/// diagnosis finding describes of the residual, [`Described`]) when given.
///
/// # Errors
/// A `described` of another length; I/O failure (path named); nothing is left half-written.
pub fn write_residual_csv(
    path: &Path,
    c: &Comparison,
    described: Option<&Described>,
) -> Result<()> {
    check_described(c, described)?;
    write_atomic_with(path, |w| {
        write!(w, "t,q,qd,y,yhat,residual")?;
        if described.is_some() {
            write!(w, ",described")?;
        }
        writeln!(w)?;
        for i in 0..c.t.len() {
            write!(
                w,
                "{},{},{},{},{},{}",
                c.t[i],
                c.q[i],
                c.qd[i],
                c.y[i],
                c.yhat[i],
                c.y[i] - c.yhat[i]
            )?;
            if let Some(d) = described {
                write!(w, ",{}", d.e[i])?;
            }
            writeln!(w)?;
        }
        Ok(())
    })
}

/// Plot a comparison (`<stem>.svg`, `.png`): measured vs model (and vs `start`, the same
/// record and joint compared with a starting plant, when given: where the loop of
/// diagnosis began), the residual against time, position, velocity (by its sign) and the
/// other joints' torques, the residual spectrum with the input frequencies marked, the
/// autocorrelation and the cross-correlations with their 99 % bounds. `described`, when
/// given, is drawn over the residual against time, and its binned mean over the residual
/// against position and velocity: what the diagnosis's finding would take out, where.
///
/// # Errors
/// As [`figure`]; a `start` of another record, joint or length; a `described` of another
/// length.
pub fn plot(
    stem: &Path,
    c: &Comparison,
    title: &str,
    start: Option<&Comparison>,
    described: Option<&Described>,
) -> Result<[PathBuf; 2]> {
    let e = c.residual();
    check_described(c, described)?;
    let unit = c.unit;
    let line = |name: &str, x: Vec<f64>, y: Vec<f64>| Series {
        name: name.into(),
        x,
        y,
        style: Style::Line,
    };
    let points = |name: &str, x: Vec<f64>, y: Vec<f64>| Series {
        name: name.into(),
        x,
        y,
        style: Style::Points,
    };
    let panel = |title: String, x: &str, y: &str, series: Vec<Series>| Panel {
        title,
        x_label: x.into(),
        y_label: y.into(),
        series,
    };
    let ylab = format!("residual ({unit})");
    let with_described = |mut series: Vec<Series>, draw: &dyn Fn(&Described) -> Series| {
        series.extend(described.map(draw));
        series
    };
    let by_sign = |positive: bool| -> (Vec<f64>, Vec<f64>) {
        (0..e.len())
            .filter(|&i| (c.qd[i] > 0.0) == positive && c.qd[i] != 0.0)
            .map(|i| (c.qd[i], e[i]))
            .unzip()
    };
    let (vp, ep) = by_sign(true);
    let (vn, en) = by_sign(false);
    let mut measured_vs_model = vec![
        line("measured", c.t.clone(), c.y.clone()),
        line("model", c.t.clone(), c.yhat.clone()),
    ];
    let mut heading = format!(
        "{title}: measured vs model ({}, NRMSE fit {:.1} %, RMSE {:.3e})",
        c.joint, c.nrmse_fit, c.rmse
    );
    if let Some(s) = start {
        if s.file != c.file || s.joint != c.joint || s.t.len() != c.t.len() {
            bail!(
                "the starting plant's comparison is of {} {} ({} samples), not of {} {} ({} samples)",
                s.file.display(),
                s.joint,
                s.t.len(),
                c.file.display(),
                c.joint,
                c.t.len()
            );
        }
        measured_vs_model.push(line("starting plant", s.t.clone(), s.yhat.clone()));
        heading += &format!("; starting plant {:.1} %, RMSE {:.3e}", s.nrmse_fit, s.rmse);
    }
    let mut panels = vec![
        panel(heading, "t (s)", unit, measured_vs_model),
        panel(
            format!(
                "residual vs time (largest {:.3e} at t = {:.2} s)",
                c.max_error.0, c.max_error.1
            ),
            "t (s)",
            &ylab,
            with_described(
                vec![line("y − ŷ", c.t.clone(), e.clone())],
                &|d: &Described| line(&d.name, c.t.clone(), d.e.clone()),
            ),
        ),
        panel(
            "residual vs position (trend: a cubic or a ripple shows as a curve)".into(),
            "position (rad or m)",
            &ylab,
            with_described(
                vec![points("y − ŷ", c.q.clone(), e.clone()), {
                    let (x, y) = trend(&c.q, &e, TREND_BINS);
                    line("trend (binned mean)", x, y)
                }],
                &|d: &Described| {
                    let (x, y) = trend(&c.q, &d.e, TREND_BINS);
                    line(&format!("{} (binned mean)", d.name), x, y)
                },
            ),
        ),
        panel(
            "residual vs velocity (a step at 0: Coulomb friction; a hump: Stribeck)".into(),
            "velocity (rad/s or m/s)",
            &ylab,
            with_described(
                vec![points("q̇ > 0", vp, ep), points("q̇ < 0", vn, en), {
                    let (x, y) = trend(&c.qd, &e, TREND_BINS);
                    line("trend (binned mean)", x, y)
                }],
                &|d: &Described| {
                    let (x, y) = trend(&c.qd, &d.e, TREND_BINS);
                    line(&format!("{} (binned mean)", d.name), x, y)
                },
            ),
        ),
    ];
    for (name, u) in c.inputs.iter().filter(|(n, _)| n.starts_with("tau")) {
        panels.push(panel(
            format!("residual vs {name} (a slope: gain or input coupling)"),
            &format!("{name} (N·m or N)"),
            &ylab,
            vec![points("y − ŷ", u.clone(), e.clone())],
        ));
    }
    let (f, a) = &c.tests.spectrum;
    let top = a.iter().fold(0.0f64, |m, &x| m.max(x));
    let mut spec = vec![line("|E(f)|", f.clone(), a.clone())];
    for (i, &fi) in c.tests.input_frequencies.iter().enumerate() {
        spec.push(line(
            if i == 0 { "input frequencies" } else { "" },
            vec![fi, fi],
            vec![0.0, top],
        ));
    }
    panels.push(panel(
        "residual amplitude spectrum".into(),
        "frequency (Hz)",
        unit,
        spec,
    ));
    let m = c.tests.max_lag;
    let lags: Vec<f64> = (0..=m).map(|k| k as f64).collect();
    let b = c.tests.autocorrelation_bound;
    panels.push(panel(
        format!(
            "residual autocorrelation ({} of {} lags outside the 99 % bound)",
            c.tests.lags_outside, c.tests.max_lag
        ),
        "lag (samples)",
        "ρ_ee",
        vec![
            line("ρ_ee", lags.clone(), c.tests.autocorrelation.clone()),
            line("99 % bound", vec![0.0, m as f64], vec![b, b]),
            line("", vec![0.0, m as f64], vec![-b, -b]),
        ],
    ));
    let both: Vec<f64> = (-(m as isize)..=m as isize).map(|k| k as f64).collect();
    for (name, r, b) in &c.tests.cross_correlation {
        panels.push(panel(
            format!("cross-correlation of the residual with {name}"),
            "lag (samples)",
            "ρ_eu",
            vec![
                line("ρ_eu", both.clone(), r.clone()),
                line("99 % bound", vec![-(m as f64), m as f64], vec![*b, *b]),
                line("", vec![-(m as f64), m as f64], vec![-*b, -*b]),
            ],
        ));
    }
    figure(stem, &panels, 1000)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The critical values against the χ² table (Abramowitz & Stegun 26.8, upper 1 %
    /// points: M = 10: 23.209, 25: 44.314, 50: 76.154), and Q of a segmented residual:
    /// an alternating sequence (ρ_k = (−1)^k) fails, its segments joined or not; two
    /// segments of uniform pseudo-random numbers (SplitMix64) pass.
    #[test]
    fn ljung_box_critical_values_and_segments() {
        for (m, table) in [(10, 23.209), (25, 44.314), (50, 76.154)] {
            let e: Vec<f64> = (0..1000).map(|k| ((k * 7919) % 1000) as f64).collect();
            let w = whiteness(&[&e], m);
            assert!(
                (w.critical / table - 1.0).abs() < 5e-3,
                "{m}: {}",
                w.critical
            );
        }
        let alternating: Vec<f64> = (0..400)
            .map(|k| if k % 2 == 0 { 1.0 } else { -1.0 })
            .collect();
        let w = whiteness(&[&alternating[..200], &alternating[200..]], 25);
        assert!(!w.white() && w.statistic > 1000.0, "{w:?}");
        let mut state = 7u64;
        let uniform: Vec<f64> = (0..4000)
            .map(|_| {
                state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
                let mut z = state;
                z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
                z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
                ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64 - 0.5
            })
            .collect();
        let w = whiteness(&[&uniform[..2000], &uniform[2000..]], 25);
        assert!(w.white(), "{w:?}");
        assert_eq!(w.max_lag, 25);
        assert_eq!(whiteness(&[&[1.0, 2.0]], 25).max_lag, 0);
        assert!(whiteness(&[&[1.0, 2.0]], 25).white());
    }

    /// A cubic under noise: the binned means follow x³ (each bin's mean of x³ against the
    /// cube of its mean x differs by the bin's spread, under 1e-3 here), in order.
    #[test]
    fn the_trend_follows_a_cubic_through_noise() {
        let n = 8000;
        let x: Vec<f64> = (0..n)
            .map(|k| -1.0 + 2.0 * (k as f64 * 0.618_034).fract())
            .collect();
        let y: Vec<f64> = x
            .iter()
            .enumerate()
            .map(|(k, v)| v.powi(3) + 0.05 * ((k as f64 * 12.9898).sin() * 43758.5453).fract())
            .collect();
        let (tx, ty) = trend(&x, &y, 40);
        assert_eq!(tx.len(), 40);
        assert!(tx.windows(2).all(|w| w[0] < w[1]));
        for (a, b) in tx.iter().zip(&ty) {
            assert!((b - a.powi(3)).abs() < 0.01, "{a}: {b} vs {}", a.powi(3));
        }
        assert_eq!(
            trend(&[1.0, 2.0], &[3.0, 4.0], 40),
            (vec![1.0, 2.0], vec![3.0, 4.0])
        );
    }
}
