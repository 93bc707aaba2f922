//! The torque-space data preparation chosen from the data: the band the inverse model is
//! fitted in, the parallel decimation that keeps it, the position filter above it, and the
//! differentiator accurate across it.
//!
//! IDIM-LS (Gautier's practice, [`super::idim`]) low-passes the positions with a zero-phase
//! Butterworth before differentiating them twice, then decimates the observation vector and
//! every regressor column through the same anti-aliasing filter (parallel filtering): the fit
//! sees the band that filter passes, where the torque and the regressor are filtered alike.
//! The settings depend on the record: the EMPS benchmark's 100 Hz and ×10 at 1 kHz leave a
//! 5 kHz arm's current-derived torques noisy, and on a 610 Hz record with a 60 Hz resonance
//! the ×10 decimation (anti-aliasing at 24 Hz) removes the band where the inertia shows.
//!
//! 1. **Noise limit** per joint, Winter's residual analysis (*Biomechanics and Motor Control
//!    of Human Movement*, 4th ed., 2009, §3.4.4.3) on a 1–1.5–2–3–5–7 grid of frequencies:
//!    the residual's power R²(fc) = mean (q − q̂_fc)² falls on a straight line where the
//!    filter removes only noise (white noise: σ² (1 − fc/f_N)); the line is fitted to the
//!    candidates above f_N/4, and the limit is the lowest cut-off whose residual is within
//!    1.1² of it. The line's intercept is the noise's power, so quantised or coloured encoder
//!    noise is measured as it is.
//! 2. **Motion band** f_v per joint: the band holding 99.9 % of the power of the velocity of
//!    the positions filtered at their noise limit (the lowest cut-off whose filter leaves at
//!    most 0.1 % of the velocity's variance; bisected between grid points).
//! 3. **Fit band**: chosen by cross-validation among 3, 6, 12, 24, 48 × the largest f_v
//!    ([`cross_validated`]) where the plant is known; 3 × f_v without it
//!    ([`Preparation::from_data`]).
//! 4. **Decimation** r = ⌊0.8 f_N / f_b⌋ (MATLAB's `decimate` passes 0.8 f_s / 2r); the
//!    **position filter** at twice the decimation's band, so that the regressor is not
//!    attenuated where the torque is not (4th-order zero-phase Butterworth: gain
//!    1/(1 + 2⁻⁸) = 0.996 at the band's edge, 1 − 1.5e-5 at f_v). Where the fit band reaches
//!    beyond 0.4 f_N no decimation is possible (r = 1) and the positions are not filtered:
//!    a filter would attenuate the regressor in the band where the torque keeps its content.
//! 5. **Differentiator**: central differences where their error across the fit band,
//!    (2π f_b / f_s)² / 3 for q̈, is at most 0.1 %; the band-limited differentiators
//!    ([`crate::signal::bandlimited_derivatives`]) beyond (at a fifth of the sampling rate
//!    central differences put q̈ 12 % low).
//!
//! What it chooses on the TX40, EMPS, a 610 Hz oscillator and a friction-dominated axis:
//! `docs/src/record/preparation.md`.

use crate::identify::idim::{IdimOptions, Observation};
use crate::measurement::{Measurement, SidePreparation};
use crate::plant::Plant;
use crate::signal::{butter_lowpass, Differentiator};
use anyhow::{bail, Result};

/// Order of the Butterworth whose residual is analysed (IDIM's default order).
const ORDER: usize = 4;

/// Tolerance of the residual criterion: the removed power may exceed the noise's share above
/// the cut-off by this factor squared (1.1: RMS within 10 %).
const TOLERANCE: f64 = 1.1;

/// Share of the Nyquist frequency the decimation's anti-aliasing filter passes (MATLAB's
/// `decimate`: 0.8).
const DECIMATE_PASSBAND: f64 = 0.8;

/// Samples at each end of a record left out of the residual (the filter's start-up), as a
/// share of its length.
const MARGIN: f64 = 0.02;

/// The preparation chosen for the records, with the figures behind it.
#[derive(Debug, Clone, PartialEq)]
pub struct Preparation {
    /// Cut-off of the position filter (Hz); `f64::INFINITY` when the positions are not
    /// filtered.
    pub cutoff_hz: f64,
    /// Parallel decimation factor (1 = none).
    pub decimation: usize,
    /// The largest of the joints' motion bands (Hz).
    pub motion_hz: f64,
    /// The fit band (Hz): [`BAND_FACTOR`] × the motion band, at most 0.8 f_N.
    pub band_hz: f64,
    /// How the positions are differentiated.
    pub differentiator: Differentiator,
    /// Sampling rate of the records (Hz; the lowest where they differ).
    pub sample_rate_hz: f64,
    /// Per joint analysed (model index): its residual analysis and motion band.
    pub joints: Vec<JointCutoff>,
}

/// One joint's residual analysis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointCutoff {
    /// Model joint index.
    pub joint: usize,
    /// The lowest candidate cut-off (Hz) that removes only noise from the positions.
    pub noise_limit_hz: f64,
    /// Noise standard deviation estimated from the positions (rad or m).
    pub noise_sigma: f64,
    /// The band (Hz) holding 99.9 % of the velocity's power; `None` for a joint that does
    /// not move.
    pub motion_band_hz: Option<f64>,
}

/// The fit band as a multiple of the motion band.
pub const BAND_FACTOR: f64 = 3.0;

/// The position filter's cut-off as a multiple of the decimation's band.
pub const FILTER_FACTOR: f64 = 2.0;

/// Largest relative error of central differences' q̈ across the fit band, (ω_b h)² / 3,
/// before the band-limited differentiators are used.
pub const CENTRAL_TOLERANCE: f64 = 1e-3;

/// Fewest samples a record needs for the preparation to be chosen from it.
pub const MIN_SAMPLES: usize = 100;

/// Share of the velocity's variance the motion band may leave out.
const BAND_SHARE: f64 = 1e-3;

impl Preparation {
    /// The residual analysis of the positions of joints `free` in `records`, and the
    /// decimation that keeps the chosen band.
    ///
    /// Returns `None` when no record has usable positions (fewer than [`MIN_SAMPLES`], or a
    /// non-positive sampling period) or no joint moves.
    pub fn from_data(records: &[Measurement], free: &[usize]) -> Option<Preparation> {
        let usable: Vec<&Measurement> = records.iter().filter(|r| r.len() >= MIN_SAMPLES).collect();
        let fs = sample_rate(usable.iter().copied())?;
        let nyquist = fs / 2.0;
        let grid = candidates(nyquist);
        let joints: Vec<JointCutoff> = free
            .iter()
            .map(|&j| {
                let columns: Vec<&[f64]> = usable
                    .iter()
                    .filter_map(|r| r.q.get(j).map(Vec::as_slice))
                    .collect();
                let (noise_limit_hz, noise_sigma) = residual_cutoff(&columns, &grid, nyquist);
                let motion_band_hz = motion_band(&columns, &grid, nyquist, noise_limit_hz);
                JointCutoff {
                    joint: j,
                    noise_limit_hz,
                    noise_sigma,
                    motion_band_hz,
                }
            })
            .collect();
        let motion_hz = joints
            .iter()
            .filter_map(|c| c.motion_band_hz)
            .reduce(f64::max)?;
        let band_hz = (BAND_FACTOR * motion_hz).min(DECIMATE_PASSBAND * nyquist);
        let decimation = decimation_for(band_hz, nyquist);
        Some(Preparation {
            cutoff_hz: cutoff_for(decimation, nyquist),
            decimation,
            motion_hz,
            band_hz,
            differentiator: differentiator_for(band_hz, fs),
            sample_rate_hz: fs,
            joints,
        })
    }

    /// The preparation for fit band `band_hz` on these records: the decimation whose
    /// anti-aliasing filter passes it ([`decimation_for`]), the position filter at
    /// [`FILTER_FACTOR`] × the decimation's band (none where no decimation is possible), the
    /// differentiator accurate across it; the band actually fitted (the decimation's).
    pub fn for_band(&self, band_hz: f64, base: IdimOptions) -> (IdimOptions, f64) {
        let nyquist = self.sample_rate_hz / 2.0;
        let band_hz = band_hz.min(DECIMATE_PASSBAND * nyquist);
        let r = decimation_for(band_hz, nyquist);
        let mut opts = base;
        opts.trim_moving_edges = true;
        opts.decimation = r;
        opts.cutoff_hz = cutoff_for(r, nyquist);
        let band = if r > 1 {
            decimation_band(r, nyquist)
        } else {
            band_hz
        };
        opts.differentiator = differentiator_for(band, self.sample_rate_hz);
        (opts, band)
    }
}

/// The fit bands tried by [`cross_validated`], as multiples of the motion band.
pub const CANDIDATE_FACTORS: [f64; 5] = [3.0, 6.0, 12.0, 24.0, 48.0];

/// Blocks each record is cut into for [`cross_validated`]: the even ones train, the odd
/// ones test.
const BLOCKS: usize = 8;

/// Share of each record's span left out at either end of [`split`].
const SPLIT_MARGIN: f64 = 0.05;

/// A wider band is taken only where its held-out error is lower by more than this share
/// (narrower bands keep less noise and less unmodelled vibration in the fit).
const WIDER_GAIN: f64 = 0.01;

/// One band tried by [`cross_validated`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BandTrial {
    /// The fit band (Hz).
    pub band_hz: f64,
    /// Its preparation.
    pub options: IdimOptions,
    /// Relative torque error (%) of the fit on the training blocks, on the held-out blocks
    /// in the narrowest band; `None` when the fit failed.
    pub held_out_error: Option<f64>,
}

/// The fit band chosen by cross-validation (issue 57: the band depends on the record).
/// For each candidate band ([`CANDIDATE_FACTORS`] × the motion band, up to where no
/// decimation is possible) `held_out_error(band's options, narrowest band's options)` fits
/// the plant on the training rows and returns its relative torque error (%) on the held-out
/// rows in the narrowest band ([`split`]: the even and odd eighths of every record); the
/// candidates run in parallel. A wider band adds rows and the broadband content of
/// friction's sign changes, and lowers that error while its rows are as trustworthy as the
/// narrow band's; it raises it once the twice-differentiated position noise (errors in the
/// regressor) or vibration the model lacks dominate. The band whose error is lower than
/// every narrower one's by more than `WIDER_GAIN` is chosen, the widest such.
///
/// # Errors
/// None of the bands gives a fit (the first failure returned).
pub fn cross_validated(
    prep: &Preparation,
    base: IdimOptions,
    held_out_error: &(dyn Fn(&IdimOptions, &IdimOptions) -> Result<f64> + Sync),
) -> Result<(usize, Vec<BandTrial>)> {
    let mut trials: Vec<BandTrial> = Vec::new();
    for f in CANDIDATE_FACTORS {
        let (options, band_hz) = prep.for_band(f * prep.motion_hz, base);
        if trials
            .iter()
            .any(|t| t.options.decimation == options.decimation)
        {
            break;
        }
        trials.push(BandTrial {
            band_hz,
            options,
            held_out_error: None,
        });
        if options.decimation == 1 {
            break;
        }
    }
    let reference = trials[0].options;
    // The candidates are independent fits: in parallel.
    use rayon::prelude::*;
    let results: Vec<Result<f64>> = trials
        .par_iter()
        .map(|t| held_out_error(&t.options, &reference))
        .collect();
    let mut first_error: Option<anyhow::Error> = None;
    for (t, r) in trials.iter_mut().zip(results) {
        match r {
            Ok(e) if e.is_finite() => t.held_out_error = Some(e),
            Ok(_) => {}
            Err(e) => {
                first_error.get_or_insert(e);
            }
        }
    }
    let mut chosen: Option<(usize, f64)> = None;
    for (i, t) in trials.iter().enumerate() {
        let Some(e) = t.held_out_error else { continue };
        if chosen.is_none_or(|(_, best)| e < (1.0 - WIDER_GAIN) * best) {
            chosen = Some((i, e));
        }
    }
    match chosen {
        Some((i, _)) => Ok((i, trials)),
        None => Err(first_error.unwrap_or_else(|| anyhow::anyhow!("no band gave a fit"))),
    }
}

/// The observation's rows split into the even and the odd of `BLOCKS` blocks of each
/// record's time span (the training and the held-out rows of [`cross_validated`]), the
/// rows within `SPLIT_MARGIN` of the span's ends in neither: there the filters' start-up
/// differs from band to band (a record that ends in motion put 900 N on its last row at
/// one cut-off and 100 N at another).
pub fn split(obs: &Observation) -> (Observation, Observation) {
    let mut spans: std::collections::BTreeMap<usize, (f64, f64)> = Default::default();
    for r in &obs.rows {
        let e = spans.entry(r.record).or_insert((r.t, r.t));
        e.0 = e.0.min(r.t);
        e.1 = e.1.max(r.t);
    }
    let (mut even, mut odd) = (Vec::new(), Vec::new());
    for (i, r) in obs.rows.iter().enumerate() {
        let (a, b) = spans[&r.record];
        let x = (r.t - a) / (b - a).max(f64::MIN_POSITIVE);
        if !(SPLIT_MARGIN..=1.0 - SPLIT_MARGIN).contains(&x) {
            continue;
        }
        let block = (x * BLOCKS as f64) as usize;
        if block.min(BLOCKS - 1).is_multiple_of(2) {
            even.push(i);
        } else {
            odd.push(i);
        }
    }
    (subset(obs, &even), subset(obs, &odd))
}

/// The rows `keep` of an observation.
fn subset(obs: &Observation, keep: &[usize]) -> Observation {
    Observation {
        names: obs.names.clone(),
        y: nalgebra::DVector::from_iterator(keep.len(), keep.iter().map(|&i| obs.y[i])),
        w: obs.w.select_rows(keep),
        rows: keep.iter().map(|&i| obs.rows[i]).collect(),
    }
}

/// Central differences where their q̈ is within [`CENTRAL_TOLERANCE`] across `band_hz` at
/// sampling rate `fs`, else the band-limited differentiators.
pub fn differentiator_for(band_hz: f64, fs: f64) -> Differentiator {
    let wh = 2.0 * std::f64::consts::PI * band_hz / fs;
    if wh * wh / 3.0 <= CENTRAL_TOLERANCE {
        Differentiator::Central
    } else {
        Differentiator::Bandlimited
    }
}

/// The band (Hz) holding all but [`BAND_SHARE`] of the velocity's power, the velocity the
/// central difference of the positions filtered at `limit_hz`; `None` when the joint does
/// not move.
fn motion_band(columns: &[&[f64]], grid: &[f64], nyquist: f64, limit_hz: f64) -> Option<f64> {
    let smooth = butter_lowpass(ORDER, limit_hz / nyquist);
    let velocities: Vec<Vec<f64>> = columns
        .iter()
        .filter_map(|c| smooth.filtfilt(c))
        .map(|f| f.windows(3).map(|w| w[2] - w[0]).collect())
        .collect();
    let n: usize = velocities.iter().map(|v| inner(v).len()).sum();
    if n == 0 {
        return None;
    }
    let variance = velocities
        .iter()
        .map(|v| {
            let r = inner(v);
            let mean = v[r.clone()].iter().sum::<f64>() / r.len().max(1) as f64;
            v[r].iter().map(|x| (x - mean).powi(2)).sum::<f64>()
        })
        .sum::<f64>()
        / n as f64;
    if !(variance.is_finite() && variance > 0.0) {
        return None;
    }
    let left = |fc: f64| -> bool {
        let filter = butter_lowpass(ORDER, fc / nyquist);
        let removed = velocities
            .iter()
            .map(|v| match filter.filtfilt(v) {
                Some(f) => inner(v).map(|k| (v[k] - f[k]).powi(2)).sum(),
                None => f64::INFINITY,
            })
            .sum::<f64>()
            / n as f64;
        removed <= BAND_SHARE * variance
    };
    let i = grid.iter().position(|&fc| left(fc))?;
    if i == 0 {
        return Some(grid[0]);
    }
    // Bisection between the grid's neighbours, on a log scale.
    let (mut lo, mut hi) = (grid[i - 1].ln(), grid[i].ln());
    for _ in 0..8 {
        let mid = 0.5 * (lo + hi);
        if left(mid.exp()) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    Some(hi.exp())
}

/// What the user fixed of the preparation (`--cutoff`, `--decimate`, `--differentiator`);
/// the rest comes from the records' side files (`[preparation]`, all alike) or else from
/// the data ([`Preparation::from_data`]).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Requested {
    /// Cut-off of the position filter (Hz).
    pub cutoff_hz: Option<f64>,
    /// Parallel decimation factor.
    pub decimation: Option<usize>,
    /// How the positions are differentiated.
    pub differentiator: Option<Differentiator>,
}

impl Requested {
    /// `base` with the cut-off, decimation and differentiator resolved for `records`
    /// (joints `free`), and a line saying what was chosen and why.
    ///
    /// A cut-off given without a decimation gets the decimation whose band is half of it
    /// ([`FILTER_FACTOR`]); a decimation given without a cut-off gets the cut-off twice its
    /// band. The differentiator, unless given, follows the fit band
    /// ([`differentiator_for`]).
    ///
    /// # Errors
    /// Side files that declare different preparations; a side file whose declared cut-off is
    /// at or above the records' Nyquist frequency or whose decimation is 0; records whose
    /// positions do not move when something is left to choose from them.
    pub fn resolve(
        &self,
        base: IdimOptions,
        records: &[Measurement],
        free: &[usize],
        plant: Option<(&Plant, &str)>,
    ) -> Result<(IdimOptions, String)> {
        const SIDE: &str = "the side file's [preparation]";
        let side = side_preparation(records)?.unwrap_or_default();
        let fs = sample_rate(records).unwrap_or(f64::INFINITY);
        let nyquist = fs / 2.0;
        if side.decimation == Some(0) {
            bail!(
                "{}: [preparation] decimation: expected 1 or more",
                side_name(records)
            );
        }
        if let Some(c) = side.cutoff_hz {
            if !(c > 0.0 && c < nyquist) {
                bail!(
                    "{}: [preparation] cutoff_hz = {c}: expected a positive frequency below the \
                     record's Nyquist frequency {nyquist} Hz",
                    side_name(records)
                );
            }
        }
        fn pick<T>(given: Option<T>, declared: Option<T>) -> Option<(T, &'static str)> {
            given
                .map(|v| (v, "given"))
                .or_else(|| declared.map(|v| (v, SIDE)))
        }
        let cutoff = pick(self.cutoff_hz, side.cutoff_hz);
        let decimation = pick(self.decimation, side.decimation);
        let mut data_said = String::new();
        let (cutoff_hz, why_c, r, why_r) = match (cutoff, decimation) {
            (Some((c, wc)), Some((r, wr))) => (c, wc.to_string(), r, wr.to_string()),
            (Some((c, wc)), None) => {
                let r = decimation_for(c / FILTER_FACTOR, nyquist);
                (
                    c,
                    wc.to_string(),
                    r,
                    "its band half the cut-off".to_string(),
                )
            }
            (cutoff, decimation) => {
                if let Some(r) = records.iter().find(|r| r.len() < MIN_SAMPLES) {
                    bail!(
                        "{}: too few samples ({}) to choose the preparation from the data (at \
                         least {MIN_SAMPLES}): give --cutoff (Hz) and --decimate",
                        r.file.display(),
                        r.len()
                    );
                }
                let Some(p) = Preparation::from_data(records, free) else {
                    bail!(
                        "the records' positions do not move, so no preparation can be chosen \
                         from them: give --cutoff (Hz) and --decimate"
                    );
                };
                let motion = p.motion_hz;
                data_said = format!(
                    "; the motion's band {motion:.4} Hz (99.9 % of the fastest joint's velocity \
                     power), fitted up to {:.4} Hz",
                    p.band_hz
                );
                match (cutoff, decimation) {
                    (_, Some((r, wr))) => (
                        cutoff_for(r, nyquist),
                        "twice the decimation's band".into(),
                        r,
                        wr.to_string(),
                    ),
                    _ => match plant {
                        Some((plant, config)) => {
                            let (opts, said) =
                                band_by_cross_validation(plant, config, records, base, &p)?;
                            data_said = format!("; the motion's band {motion:.4} Hz{said}");
                            (
                                opts.cutoff_hz,
                                "cross-validated".into(),
                                opts.decimation,
                                "cross-validated".into(),
                            )
                        }
                        None => (
                            p.cutoff_hz,
                            "from the data".into(),
                            p.decimation,
                            "from the data".into(),
                        ),
                    },
                }
            }
        };
        let band = if r > 1 {
            decimation_band(r, nyquist).min(cutoff_hz)
        } else {
            cutoff_hz.min(DECIMATE_PASSBAND * nyquist)
        };
        let (differentiator, why_d) = match (self.differentiator, side.differentiator) {
            (Some(d), _) => (d, "given".to_string()),
            (None, Some(d)) => (d, SIDE.to_string()),
            (None, None) => (differentiator_for(band, fs), format!("across {band:.4} Hz")),
        };
        let mut opts = base;
        opts.cutoff_hz = cutoff_hz;
        opts.decimation = r;
        opts.differentiator = differentiator;
        opts.trim_moving_edges = side.trim_edges.unwrap_or(true);
        let filtered = if cutoff_hz.is_finite() {
            format!("positions filtered at {cutoff_hz:.4} Hz ({why_c})")
        } else {
            format!("positions not filtered ({why_c}: the motion fills the band)")
        };
        let decimated = if r > 1 {
            format!(
                "decimated ×{r} ({why_r}; anti-aliasing at {:.4} Hz)",
                decimation_band(r, nyquist)
            )
        } else {
            format!("not decimated ({why_r})")
        };
        Ok((
            opts,
            format!("{filtered}, {decimated}, {differentiator} ({why_d}){data_said}"),
        ))
    }
}

/// [`cross_validated`] with the commands' least squares on the base parameters of `plant`
/// (IDIM-LS, [`crate::identify::idim::base_fit`]), and what it found, for the printed line.
fn band_by_cross_validation(
    plant: &Plant,
    config: &str,
    records: &[Measurement],
    base: IdimOptions,
    prep: &Preparation,
) -> Result<(IdimOptions, String)> {
    use crate::identify::idim;
    let locked_at = idim::locked_positions(records);
    // Fitted on the even blocks (the nonlinear values by variable projection on those rows
    // too), compared on the odd blocks in the reference band, its columns built at the
    // fitted nonlinear values.
    let held_out_error = |o: &IdimOptions, reference: &IdimOptions| -> Result<f64> {
        let random = idim::random_motion_observation(plant, config, &locked_at, o)?;
        let linear = |p: &Plant, obs: &Observation| {
            Ok(idim::base_fit_with(p, obs, config, &locked_at, idim::Weighting::Ols, &random)?.0)
        };
        let training = |obs: Observation| split(&obs).0;
        let fitted = idim::separable_fit_rows(plant, config, records, o, &linear, &training)?;
        let mut p = fitted.plant.clone();
        fitted.fit.apply(&mut p)?;
        let (_, test) = split(&idim::observation(&p, config, records, reference)?);
        Ok(idim::relative_error(&test.y, &idim::predict(&p, &test)?))
    };
    let (i, trials) = cross_validated(prep, base, &held_out_error)?;
    let table: Vec<String> = trials
        .iter()
        .map(|t| match t.held_out_error {
            Some(e) => format!("{:.4} Hz {e:.3} %", t.band_hz),
            None => format!("{:.4} Hz (no fit)", t.band_hz),
        })
        .collect();
    Ok((
        trials[i].options,
        format!(
            "; fit band {:.4} Hz chosen by cross-validation (held-out torque error in the \
             {:.4} Hz band, trained on alternate blocks: {})",
            trials[i].band_hz,
            trials[0].band_hz,
            table.join(", ")
        ),
    ))
}

/// The `[preparation]` the records' side files declare: `None` when none does.
///
/// # Errors
/// Two records that declare different preparations, or one that declares and one that
/// does not.
fn side_preparation(records: &[Measurement]) -> Result<Option<SidePreparation>> {
    let mut found: Option<(SidePreparation, &std::path::Path)> = None;
    let mut without: Option<&std::path::Path> = None;
    for r in records {
        let side = crate::measurement::read_side_file(&r.file)?;
        match (side.preparation, &found) {
            (Some(p), None) => found = Some((p, &r.file)),
            (Some(p), Some((q, f))) if p != *q => bail!(
                "{} and {} declare different [preparation]s in their side files: give \
                 --cutoff and --decimate for all of them",
                f.display(),
                r.file.display()
            ),
            (None, _) => without = Some(&r.file),
            _ => {}
        }
    }
    if let (Some((_, f)), Some(w)) = (found, without) {
        bail!(
            "{} declares a [preparation] in its side file and {} does not: give --cutoff and \
             --decimate for all of them",
            f.display(),
            w.display()
        );
    }
    Ok(found.map(|(p, _)| p))
}

/// The side file of the first record, for messages.
fn side_name(records: &[Measurement]) -> String {
    records.first().map_or_else(String::new, |r| {
        r.file.with_extension("toml").display().to_string()
    })
}

/// The largest decimation factor whose anti-aliasing filter passes `cutoff_hz` at Nyquist
/// frequency `nyquist` (Hz): ⌊0.8 f_N / fc⌋, at least 1.
pub fn decimation_for(cutoff_hz: f64, nyquist: f64) -> usize {
    (decimation_band(1, nyquist) / cutoff_hz).floor().max(1.0) as usize
}

/// The samples of a record's column that enter the residual analysis: all but [`MARGIN`] of
/// them at each end (the filter's start-up).
fn inner(c: &[f64]) -> std::ops::Range<usize> {
    let m = (MARGIN * c.len() as f64) as usize;
    m..c.len() - m
}

/// The records' sampling rate (Hz; the lowest where they differ), `None` without a positive
/// finite one.
fn sample_rate<'a>(records: impl IntoIterator<Item = &'a Measurement>) -> Option<f64> {
    let fs = records
        .into_iter()
        .map(|r| 1.0 / r.dt())
        .filter(|f| f.is_finite() && *f > 0.0)
        .fold(f64::INFINITY, f64::min);
    fs.is_finite().then_some(fs)
}

/// The band (Hz) the anti-aliasing filter of decimation ×`r` passes at Nyquist frequency
/// `nyquist`: 0.8 f_N / r.
fn decimation_band(r: usize, nyquist: f64) -> f64 {
    DECIMATE_PASSBAND * nyquist / r as f64
}

/// The position filter's cut-off (Hz) for decimation ×`r`: [`FILTER_FACTOR`] × its band;
/// `f64::INFINITY` (no filter) without decimation.
fn cutoff_for(r: usize, nyquist: f64) -> f64 {
    if r > 1 {
        FILTER_FACTOR * decimation_band(r, nyquist)
    } else {
        f64::INFINITY
    }
}

/// Candidate cut-offs (Hz): 1, 1.5, 2, 3, 5, 7 per decade from 0.5 Hz to 0.8 f_N (and
/// 0.8 f_N itself).
fn candidates(nyquist: f64) -> Vec<f64> {
    let top = DECIMATE_PASSBAND * nyquist;
    let mut grid = vec![0.5];
    let mut decade = 1.0;
    while decade <= top {
        for m in [1.0, 1.5, 2.0, 3.0, 5.0, 7.0] {
            let f = m * decade;
            if f < top {
                grid.push(f);
            }
        }
        decade *= 10.0;
    }
    grid.retain(|&f| f < top);
    grid.push(top);
    grid
}

/// The lowest of `grid` (Hz) that removes only noise from the positions `columns` (one per
/// record), and the noise σ̂ (the residual line's intercept); the highest candidate where
/// none does or the positions show no noise.
fn residual_cutoff(columns: &[&[f64]], grid: &[f64], nyquist: f64) -> (f64, f64) {
    let last = grid[grid.len() - 1];
    let n: usize = columns.iter().map(|c| inner(c).len()).sum();
    if n == 0 {
        return (last, 0.0);
    }
    let removed: Vec<f64> = grid
        .iter()
        .map(|&fc| {
            let filter = butter_lowpass(ORDER, fc / nyquist);
            columns
                .iter()
                .map(|c| match filter.filtfilt(c) {
                    Some(f) => inner(c).map(|k| (c[k] - f[k]).powi(2)).sum(),
                    None => f64::INFINITY,
                })
                .sum::<f64>()
                / n as f64
        })
        .collect();
    // The noise line R² = α + β fc through the candidates above f_N / 4 (least squares);
    // with fewer than two there, white noise of the differences' σ̂.
    let upper: Vec<(f64, f64)> = grid
        .iter()
        .zip(&removed)
        .filter(|(&f, r)| f >= 0.25 * nyquist && r.is_finite())
        .map(|(&f, &r)| (f, r))
        .collect();
    let line: Box<dyn Fn(f64) -> f64> = if upper.len() >= 2 {
        let m = upper.len() as f64;
        let (sx, sy) = upper
            .iter()
            .fold((0.0, 0.0), |(a, b), (f, r)| (a + f, b + r));
        let (sxx, sxy) = upper
            .iter()
            .fold((0.0, 0.0), |(a, b), (f, r)| (a + f * f, b + f * r));
        let beta = (m * sxy - sx * sy) / (m * sxx - sx * sx);
        let alpha = (sy - beta * sx) / m;
        Box::new(move |fc| alpha + beta * fc)
    } else {
        let sigma2 = columns
            .iter()
            .map(|c| crate::signal::noise_sigma(c).powi(2) * inner(c).len() as f64)
            .sum::<f64>()
            / n as f64;
        Box::new(move |fc| sigma2 * (1.0 - fc / nyquist))
    };
    let noise = line(0.0);
    if !(noise.is_finite() && noise > 0.0) {
        return (last, 0.0);
    }
    let fc = grid
        .iter()
        .zip(&removed)
        .find(|(&fc, &r)| r <= TOLERANCE.powi(2) * line(fc).max(0.0))
        .map_or(last, |(&fc, _)| fc);
    (fc, noise.sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_grid_stays_below_the_decimation_passband() {
        let g = candidates(500.0);
        assert_eq!(g[0], 0.5);
        assert!(g.contains(&20.0) && g.contains(&300.0));
        assert_eq!(*g.last().unwrap(), 400.0);
        assert!(g.windows(2).all(|w| w[0] < w[1]));
    }

    #[test]
    fn decimation_keeps_the_band() {
        // The TX40 at 5 kHz with a 20 Hz cut-off: ×100 (anti-aliasing at 20 Hz).
        assert_eq!(decimation_for(20.0, 2500.0), 100);
        // EMPS at 1 kHz with 100 Hz: ×4 (the benchmark's ×10 cuts at 40 Hz).
        assert_eq!(decimation_for(100.0, 500.0), 4);
        assert_eq!(decimation_for(400.0, 500.0), 1);
    }
}
