//! IDIM-LS: inverse dynamic identification model, least squares (Gautier; the EMPS
//! benchmark's reference method).
//!
//! 1. Low-pass the measured positions forward and backward (4th-order Butterworth, cut-off
//!    100 Hz by default: zero phase).
//! 2. Velocities and accelerations by central differences of the filtered positions; the
//!    two samples at each end, where they are not defined, are left out.
//! 3. Build the observation y (measured torque or force) and the regressor W: the rigid-body
//!    regressor Y_F(q, q̇, q̈) of the generated kernels, then one column per effect parameter.
//! 4. Parallel decimation: y and every column of W through MATLAB's `decimate` (×10 by
//!    default), which removes the high-frequency torque ripple without distorting the
//!    linear relation y = W θ.
//! 5. θ̂ = argmin ‖y − Wθ‖ (SVD), σ̂² = ‖y − Wθ̂‖²/(r − p), cov(θ̂) = σ̂² (WᵀW)⁻¹.

use crate::identify::identifiability::{base_parameters_at, BaseParameter, BaseParameters};
use crate::measurement::Measurement;
use crate::names;
use crate::plant::Plant;
use crate::signal::{butter_lowpass, decimate, decimation_indices, Differentiator};
use anyhow::{bail, Context, Result};
use nalgebra::{DMatrix, DVector};

/// Samples dropped at each end of a record: the double central difference (q̈) is defined
/// from the third sample to the third last.
const EDGE: usize = 2;

/// Data-preparation settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IdimOptions {
    /// Cut-off of the zero-phase Butterworth on positions (Hz); `f64::INFINITY`: the
    /// positions are not filtered (a motion that fills the band, [`super::preparation`]).
    pub cutoff_hz: f64,
    /// Order of that Butterworth.
    pub filter_order: usize,
    /// Parallel decimation factor (1 = none).
    pub decimation: usize,
    /// Only the rows whose time lies in `[from, to]` (s) enter the system: the records are
    /// filtered, differentiated and decimated whole, then cut (so the window's edges carry
    /// no filter transient). `None`: every row.
    pub window: Option<(f64, f64)>,
    /// Rows of a joint whose velocity is below this are left out (Gautier's practice with
    /// Coulomb friction: near q̇ = 0 the filtered velocity's sign and the presliding regime
    /// are not the model's sign(q̇)). `None`: every row.
    pub min_speed: Option<MinSpeed>,
    /// How q̇ and q̈ are taken from the filtered positions.
    pub differentiator: Differentiator,
    /// Leave out the rows at a record's ends that start or end in motion, where the
    /// filters' start-up spoils them (`moving_edges`); off in the EMPS benchmark's own
    /// processing (its records start and end moving, and its published figures keep every
    /// row).
    pub trim_moving_edges: bool,
}

/// The speed below which a joint's rows are left out of IDIM.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MinSpeed {
    /// An absolute speed (rad/s or m/s).
    Absolute(f64),
    /// A fraction of the joint's peak |q̇| over the rows (FIGAROH's `dq_lim_def` is 1 % of
    /// the joints' speed limits).
    FractionOfPeak(f64),
}

impl Default for IdimOptions {
    /// The EMPS benchmark's settings: 4th order, 100 Hz, decimation ×10.
    fn default() -> Self {
        IdimOptions {
            cutoff_hz: 100.0,
            filter_order: 4,
            decimation: 10,
            window: None,
            min_speed: None,
            differentiator: Differentiator::Central,
            trim_moving_edges: false,
        }
    }
}

/// The prepared linear system of one or more records, after decimation.
#[derive(Debug, Clone)]
pub struct Observation {
    /// Column (parameter) names.
    pub names: Vec<String>,
    /// Observation vector y (N·m or N), rows stacked record by record and joint by joint.
    pub y: DVector<f64>,
    /// Regressor W, rows × parameters.
    pub w: DMatrix<f64>,
    /// Per row: time (s), joint index, filtered q, q̇, q̈ at the decimated instants.
    pub rows: Vec<RowInfo>,
}

/// What one observation row is.
#[derive(Debug, Clone, Copy)]
pub struct RowInfo {
    /// Record index (order of the files given).
    pub record: usize,
    /// Time (s).
    pub t: f64,
    /// Joint index in the model.
    pub joint: usize,
    /// Filtered position (rad or m).
    pub q: f64,
    /// Velocity (rad/s or m/s).
    pub qd: f64,
    /// Acceleration (rad/s² or m/s²).
    pub qdd: f64,
}

/// Build the decimated observation of `plant` on `records`, configuration `config`
/// ([`Prepared::new`], then [`Prepared::at`] the plant's values).
///
/// # Errors
/// Unknown configuration; a record too short for the filters; a record with fewer joints
/// than the model; a cut-off at or above the Nyquist frequency; an effect the inverse model
/// does not take; a value not finite after filtering and differentiating.
pub fn observation(
    plant: &Plant,
    config: &str,
    records: &[Measurement],
    opts: &IdimOptions,
) -> Result<Observation> {
    Prepared::new(plant, config, records, opts)?.at(plant)
}

/// The part of an observation that does not depend on the values of the plant's effects:
/// the filtered positions and their derivatives, the torques, the rigid-body and
/// user-defined-effect columns (decimated), the rows and which of them the trims keep.
/// Built once; [`Prepared::at`] adds the effects' columns at a plant's values, which is all
/// a separable fit's trial of nonlinear values (a rest angle, a Stribeck speed, a friction
/// bias) changes: each effect column is non-zero on its own joint's rows only, so a trial
/// filters and decimates a few columns instead of every one (on the TX40 record 24 of 510).
pub struct Prepared<'a> {
    records: &'a [Measurement],
    conf: &'static generated::Configuration,
    opts: IdimOptions,
    /// Per record: filtered q of every joint, q̇ and q̈ of the free joints, the interior
    /// samples the rows come from and the decimated ones.
    signals: Vec<PreparedRecord>,
    /// Names of the rigid-body columns, then of the user-defined effects' columns.
    rigid_names: Vec<String>,
    expression_names: Vec<String>,
    /// The plant's effects and expressions the columns were built for (checked by `at`).
    effects: Vec<crate::effects::Effect>,
    expressions: Vec<String>,
    /// Stacked over every record and free joint (before the trims).
    y: Vec<f64>,
    rigid: Vec<Vec<f64>>,
    expression: Vec<Vec<f64>>,
    rows: Vec<RowInfo>,
    /// The rows the trims keep (moving ends, window, minimum speed); `None`: all.
    keep: Option<Vec<usize>>,
}

struct PreparedRecord {
    qf: Vec<Vec<f64>>,
    qd: Vec<Vec<f64>>,
    qdd: Vec<Vec<f64>>,
    interior: Vec<usize>,
    /// Decimated rows per free joint.
    nout: usize,
}

/// The effects on the free joints of `conf`, with the nonlinear values their columns are
/// built at and, per free joint, its friction position bias (factor, qeq).
struct EffectSetup<'p> {
    effects: Vec<&'p crate::effects::Effect>,
    names: Vec<String>,
    nonlinear: Vec<Vec<f64>>,
    bias: Vec<Option<(f64, f64)>>,
}

fn effect_setup<'p>(plant: &'p Plant, conf: &generated::Configuration) -> Result<EffectSetup<'p>> {
    let model = plant.model;
    let effects: Vec<_> = plant
        .effects
        .iter()
        .filter(|e| conf.free.contains(&e.joint))
        .collect();
    let mut names = Vec::new();
    for e in &effects {
        if e.kind == crate::effects::EffectKind::Backlash {
            bail!(
                "{}: backlash on joint '{}' changes the sensed position, not the torque, so the \
                 inverse-model least squares (IDIM), which reads the sensed positions as the \
                 drive's, cannot take it; use output-error identification or remove the effect",
                plant.name(),
                model.joints[e.joint]
            );
        }
        if !e.kind.in_torque_space() {
            bail!(
                "{}: effect '{}' on joint '{}' is not one the inverse model takes (it takes \
                 the linear effects, spring, stribeck, lugre's static curve and the friction \
                 bias), so IDIM cannot fit it; use output-error identification or remove the \
                 effect",
                plant.name(),
                e.kind,
                model.joints[e.joint]
            );
        }
        names.extend(
            e.kind
                .linear_symbols()
                .iter()
                .map(|s| e.parameter_name(s, model.joints)),
        );
    }
    // The nonlinear values each effect's columns are built at (the plant's).
    let nonlinear: Vec<Vec<f64>> = effects
        .iter()
        .map(|e| {
            e.kind
                .nonlinear_symbols()
                .iter()
                .map(|s| plant.value(&e.parameter_name(s, model.joints)))
                .collect::<Result<Vec<f64>>>()
        })
        .collect::<Result<_>>()?;
    for (e, nl) in effects.iter().zip(&nonlinear) {
        use crate::effects::EffectKind;
        let positive = match e.kind {
            EffectKind::Stribeck | EffectKind::Lugre => Some("vs"),
            EffectKind::FrictionBias => Some("FrictionBias"),
            _ => None,
        };
        if let Some(what) = positive {
            if !(nl[0] > 0.0 && nl[0].is_finite()) {
                bail!(
                    "{}: {} on joint '{}' needs {what} > 0, found {}",
                    plant.name(),
                    e.kind,
                    model.joints[e.joint],
                    nl[0]
                );
            }
        }
    }
    // Per free joint, its friction position bias (FrictionBias, qeq): the factor on its
    // friction columns below qeq (thesis 4.3.5, as the simulator applies it).
    let bias = conf
        .free
        .iter()
        .map(|&j| {
            effects
                .iter()
                .zip(&nonlinear)
                .find(|(e, _)| e.kind == crate::effects::EffectKind::FrictionBias && e.joint == j)
                .map(|(_, nl)| (nl[0], nl[1]))
        })
        .collect();
    Ok(EffectSetup {
        effects,
        names,
        nonlinear,
        bias,
    })
}

/// The first non-finite value among `columns` (name, values) of free joint `a`'s rows of
/// record `m` (`interior` the samples they come from), as the error that names it.
fn refuse_non_finite(
    m: &Measurement,
    model: &generated::Model,
    joint: usize,
    interior: &[usize],
    columns: &[(&str, &[f64])],
) -> Result<()> {
    let bad = |v: &[f64]| v.iter().position(|x| !x.is_finite());
    let Some((r, what)) = columns
        .iter()
        .find_map(|(name, v)| bad(v).map(|r| (r, *name)))
    else {
        return Ok(());
    };
    let nj = model.joints.len();
    let n = m.len();
    let k = interior[r];
    // The sample that overflowed: the largest position of any joint.
    let (jmax, kmax) = (0..nj)
        .flat_map(|j| (0..n).map(move |k| (j, k)))
        .max_by(|x, y| m.q[x.0][x.1].abs().total_cmp(&m.q[y.0][y.1].abs()))
        .unwrap_or((0, 0));
    bail!(
        "{}: row {} (t = {} s), joint {}: {what} is not finite after filtering and differentiating the positions; the largest position in the file is {} = {:e} at row {} (a value near the float limit, or a spike)",
        m.file.display(),
        k + 2,
        m.t[k],
        model.joints[joint],
        names::column("q", model.joints[jmax]),
        m.q[jmax][kmax],
        kmax + 2
    );
}

/// `x` decimated ×`r` (`nout` samples); a column of zeros passes as zeros.
fn decimated(x: &[f64], r: usize, nout: usize) -> Option<Vec<f64>> {
    if x.iter().all(|v| *v == 0.0) {
        Some(vec![0.0; nout])
    } else {
        decimate(x, r)
    }
}

impl<'a> Prepared<'a> {
    /// Prepare `records` for the observations of plants with `plant`'s effects and
    /// user-defined effects in configuration `config`.
    ///
    /// # Errors
    /// As [`observation`].
    pub fn new(
        plant: &Plant,
        config: &str,
        records: &'a [Measurement],
        opts: &IdimOptions,
    ) -> Result<Prepared<'a>> {
        let model = plant.model;
        let conf = crate::util::configuration(model, config)?;
        let nj = model.joints.len();
        let nf = conf.free.len();
        let np = model.params.len();
        // The effects are checked here too (an effect IDIM cannot take stops before the
        // records are filtered).
        effect_setup(plant, conf)?;
        let rigid_names: Vec<String> = conf
            .params_present
            .iter()
            .map(|&j| model.params[j].to_string())
            .collect();
        // User-defined effects: one column per parameter, ∂u/∂θ (the effect linear in θ).
        let columns = expression_columns(plant, conf.free)?;
        let expression_names: Vec<String> = columns.iter().map(|c| c.name.clone()).collect();
        let nrigid = rigid_names.len();
        // The columns as a finite-value error names them.
        let named: Vec<String> = rigid_names
            .iter()
            .chain(&expression_names)
            .map(|n| format!("regressor column '{n}'"))
            .collect();
        let ncol = nrigid + columns.len();
        let mut y_all: Vec<f64> = Vec::new();
        let mut w_cols: Vec<Vec<f64>> = vec![Vec::new(); ncol];
        let mut rows = Vec::new();
        let mut signals = Vec::new();
        // Per record, the spans at its ends the filters' start-up spoils: (from, to) in s.
        let mut spoiled: Vec<Vec<(f64, f64)>> = Vec::new();
        for (ri, m) in records.iter().enumerate() {
            if m.q.len() < nj {
                bail!(
                    "{}: has {} joints, model '{}' needs {nj}",
                    m.file.display(),
                    m.q.len(),
                    model.name
                );
            }
            let dt = m.dt();
            let fs = 1.0 / dt;
            if !(opts.cutoff_hz > 0.0
                && (opts.cutoff_hz < fs / 2.0 || opts.cutoff_hz == f64::INFINITY))
            {
                bail!(
                    "{}: filter cut-off {} Hz must lie between 0 and the Nyquist frequency {} Hz",
                    m.file.display(),
                    opts.cutoff_hz,
                    fs / 2.0
                );
            }
            // Below one cycle per record the filter removes the motion itself (and its
            // coefficients lose every significant digit): q̈ is then noise or overflow.
            let span = m.t[m.len() - 1] - m.t[0];
            if opts.cutoff_hz * span < 1.0 {
                bail!(
                    "{}: filter cut-off {} Hz is below one cycle per record (1/{span:.3} s = {:.4} Hz): it would remove the motion the fit needs",
                    m.file.display(),
                    opts.cutoff_hz,
                    1.0 / span
                );
            }
            let bw = opts
                .cutoff_hz
                .is_finite()
                .then(|| butter_lowpass(opts.filter_order, opts.cutoff_hz / (fs / 2.0)));
            let n = m.len();
            // Central differences drop EDGE samples at each end; filtfilt pads 3·order
            // samples; decimate's 8th-order Chebyshev pads 3·8 samples at the decimated rate.
            let min_len = 2 * EDGE + 3 * 8 * opts.decimation.max(1);
            let too_short = || {
                anyhow::anyhow!(
                    "{}: too few samples ({n}) for the filters and decimation ×{} (need more than {min_len})",
                    m.file.display(),
                    opts.decimation,
                )
            };
            if n <= min_len {
                return Err(too_short());
            }
            // Filtered q of every joint (locked ones too: their positions enter the kernels).
            let qf: Vec<Vec<f64>> = (0..nj)
                .map(|j| match &bw {
                    Some(bw) => bw.filtfilt(&m.q[j]).ok_or_else(too_short),
                    None => Ok(m.q[j].clone()),
                })
                .collect::<Result<_>>()?;
            let (qd, qdd): (Vec<Vec<f64>>, Vec<Vec<f64>>) = conf
                .free
                .iter()
                .map(|&j| opts.differentiator.derivatives(&qf[j], dt))
                .unzip();
            // Rows of this record: for each free joint a, interior sample k ∈ [2, n − 3]
            // (where both central differences are defined; the end values are one-sided).
            let interior: Vec<usize> = (EDGE..n - EDGE).collect();
            let ni = interior.len();
            let mut yr = vec![vec![0.0; ni]; nf];
            let mut wr = vec![vec![vec![0.0; ni]; ncol]; nf];
            let mut yk = vec![0.0; nf * np];
            let mut qk = vec![0.0; nj];
            let mut qdk = vec![0.0; nf];
            let mut qddk = vec![0.0; nf];
            for (r, &k) in interior.iter().enumerate() {
                for j in 0..nj {
                    qk[j] = qf[j][k];
                }
                for a in 0..nf {
                    qdk[a] = qd[a][k];
                    qddk[a] = qdd[a][k];
                }
                (conf.regressor)(&qk, &qdk, &qddk, &mut yk);
                for a in 0..nf {
                    yr[a][r] = m.tau[conf.free[a]][k];
                    for (c, &j) in conf.params_present.iter().enumerate() {
                        wr[a][c][r] = yk[a * np + j];
                    }
                    for (i, col) in columns.iter().enumerate() {
                        if col.joints.contains(&conf.free[a]) {
                            wr[a][nrigid + i][r] =
                                col.value(&qk, (&qd, &qdd), conf.free, (&m.t, &m.tau), k);
                        }
                    }
                }
            }
            // A value the float format cannot carry through the filter and the differences
            // (a 1e308 cell) would make the least squares meaningless: name the first one.
            for a in 0..nf {
                let mut cols: Vec<(&str, &[f64])> = vec![("the torque", &yr[a])];
                cols.extend(
                    named
                        .iter()
                        .map(String::as_str)
                        .zip(wr[a].iter().map(Vec::as_slice)),
                );
                refuse_non_finite(m, model, conf.free[a], &interior, &cols)?;
            }
            spoiled.push(if opts.trim_moving_edges {
                moving_edges(m, (&qd, dt), opts)
            } else {
                Vec::new()
            });
            // Parallel decimation.
            let idx: Vec<usize> = decimation_indices(ni, opts.decimation.max(1))
                .map(|i| interior[i])
                .collect();
            let nout = idx.len();
            // Every (joint, column) pair in parallel; a column that is zero on a joint's
            // rows (another joint's effect, a link beyond it) decimates to zeros.
            let decimated_cols: Vec<Option<Vec<f64>>> = {
                use rayon::prelude::*;
                (0..nf * (ncol + 1))
                    .into_par_iter()
                    .map(|i| {
                        let (a, c) = (i / (ncol + 1), i % (ncol + 1));
                        let x = if c == ncol { &yr[a] } else { &wr[a][c] };
                        decimated(x, opts.decimation, nout)
                    })
                    .collect()
            };
            let mut decimated_cols = decimated_cols.into_iter();
            for a in 0..nf {
                let mut of_joint: Vec<Vec<f64>> = (0..=ncol)
                    .map(|_| decimated_cols.next().flatten().ok_or_else(too_short))
                    .collect::<Result<_>>()?;
                let yd = of_joint.pop().ok_or_else(too_short)?;
                y_all.extend_from_slice(&yd);
                for (c, wd) in of_joint.into_iter().enumerate() {
                    w_cols[c].extend_from_slice(&wd);
                }
                for &k in &idx {
                    rows.push(RowInfo {
                        record: ri,
                        t: m.t[k],
                        joint: conf.free[a],
                        q: qf[conf.free[a]][k],
                        qd: qd[a][k],
                        qdd: qdd[a][k],
                    });
                }
            }
            signals.push(PreparedRecord {
                qf,
                qd,
                qdd,
                interior,
                nout,
            });
        }
        let keep = trimmed_rows(&rows, &spoiled, opts, model)?;
        let expression = w_cols.split_off(nrigid);
        Ok(Prepared {
            records,
            conf,
            opts: *opts,
            signals,
            rigid_names,
            expression_names,
            effects: plant.effects.clone(),
            expressions: plant.expressions.iter().map(|x| x.name.clone()).collect(),
            y: y_all,
            rigid: w_cols,
            expression,
            rows,
            keep,
        })
    }

    /// The observation of `plant` (the plant prepared for, or one that differs from it
    /// only in values): columns rigid body, effects, user-defined effects; the effects'
    /// columns built at `plant`'s values.
    ///
    /// # Errors
    /// `plant` has other effects or user-defined effects than the one prepared for; an
    /// effect's value missing or out of its range; a column not finite; a record too short
    /// for the decimation.
    pub fn at(&self, plant: &Plant) -> Result<Observation> {
        let model = plant.model;
        let conf = self.conf;
        let same_expressions = plant
            .expressions
            .iter()
            .map(|x| &x.name)
            .eq(self.expressions.iter());
        if plant.effects != self.effects || !same_expressions {
            bail!(
                "{}: the observation was prepared for other effects; prepare it again",
                plant.name()
            );
        }
        let setup = effect_setup(plant, conf)?;
        let nf = conf.free.len();
        let neff = setup.names.len();
        // Per effect column, stacked like the rows: zero except on its own joint's rows.
        let total = self.y.len();
        let mut effect_cols = vec![vec![0.0; total]; neff];
        let mut offset = 0;
        for (m, s) in self.records.iter().zip(&self.signals) {
            let ni = s.interior.len();
            let too_short = || {
                anyhow::anyhow!(
                    "{}: too few samples ({}) for the decimation ×{}",
                    m.file.display(),
                    m.len(),
                    self.opts.decimation
                )
            };
            // (effect column, free joint a, its values at the interior samples)
            let mut built: Vec<(usize, usize, Vec<f64>)> = Vec::new();
            let mut c0 = 0;
            for (e, nl) in setup.effects.iter().zip(&setup.nonlinear) {
                let width = e.kind.linear_symbols().len();
                let Some(a) = conf.free.iter().position(|&j| j == e.joint) else {
                    c0 += width;
                    continue;
                };
                let mut cols = vec![vec![0.0; ni]; width];
                for (r, &k) in s.interior.iter().enumerate() {
                    let below =
                        setup.bias[a]
                            .map_or(1.0, |(b, qeq)| if s.qf[e.joint][k] < qeq { b } else { 1.0 });
                    let factor = if e.kind.is_biased_friction() {
                        below
                    } else {
                        1.0
                    };
                    if let Some(v) =
                        e.kind
                            .regressor_at(s.qf[e.joint][k], s.qd[a][k], s.qdd[a][k], nl)
                    {
                        for (col, x) in cols.iter_mut().zip(v) {
                            col[r] = x * factor;
                        }
                    }
                }
                for (i, col) in cols.into_iter().enumerate() {
                    built.push((c0 + i, a, col));
                }
                c0 += width;
            }
            for (c, a, col) in &built {
                let name = format!("regressor column '{}'", setup.names[*c]);
                refuse_non_finite(m, model, conf.free[*a], &s.interior, &[(&name, col)])?;
            }
            let decimated_cols: Vec<Option<Vec<f64>>> = {
                use rayon::prelude::*;
                built
                    .par_iter()
                    .map(|(_, _, x)| decimated(x, self.opts.decimation, s.nout))
                    .collect()
            };
            for ((c, a, _), d) in built.iter().zip(decimated_cols) {
                let d = d.ok_or_else(too_short)?;
                let from = offset + a * s.nout;
                effect_cols[*c][from..from + s.nout].copy_from_slice(&d);
            }
            offset += nf * s.nout;
        }
        let names: Vec<String> = self
            .rigid_names
            .iter()
            .chain(&setup.names)
            .chain(&self.expression_names)
            .cloned()
            .collect();
        let columns: Vec<&Vec<f64>> = self
            .rigid
            .iter()
            .chain(&effect_cols)
            .chain(&self.expression)
            .collect();
        let (y, rows, w) = match &self.keep {
            None => (
                self.y.clone(),
                self.rows.clone(),
                DMatrix::from_fn(total, names.len(), |i, c| columns[c][i]),
            ),
            Some(keep) => (
                keep.iter().map(|&i| self.y[i]).collect(),
                keep.iter().map(|&i| self.rows[i]).collect(),
                DMatrix::from_fn(keep.len(), names.len(), |i, c| columns[c][keep[i]]),
            ),
        };
        Ok(Observation {
            names,
            y: DVector::from_vec(y),
            w,
            rows,
        })
    }
}

/// The rows (indices into `rows`) the trims keep: the spans a record's moving ends spoil
/// (`spoiled`, per record), the time window, the minimum speed; `None` when none applies.
///
/// # Errors
/// A window that holds no row; a joint with no row above the minimum speed.
fn trimmed_rows(
    rows: &[RowInfo],
    spoiled: &[Vec<(f64, f64)>],
    opts: &IdimOptions,
    model: &generated::Model,
) -> Result<Option<Vec<usize>>> {
    let mut keep: Option<Vec<usize>> = None;
    let all = || (0..rows.len()).collect::<Vec<usize>>();
    if spoiled.iter().any(|s| !s.is_empty()) {
        keep = Some(
            all()
                .into_iter()
                .filter(|&i| {
                    let r = &rows[i];
                    !spoiled[r.record].iter().any(|&(a, b)| r.t >= a && r.t <= b)
                })
                .collect(),
        );
    }
    if let Some((from, to)) = opts.window {
        let kept: Vec<usize> = keep
            .unwrap_or_else(all)
            .into_iter()
            .filter(|&i| rows[i].t >= from && rows[i].t <= to)
            .collect();
        if kept.is_empty() {
            bail!("the window {from} s to {to} s holds no sample of the records");
        }
        keep = Some(kept);
    }
    if let Some(min) = opts.min_speed {
        let current = keep.unwrap_or_else(all);
        let mut peak = vec![0.0f64; model.joints.len()];
        for &i in &current {
            let r = &rows[i];
            peak[r.joint] = peak[r.joint].max(r.qd.abs());
        }
        let threshold = |j: usize| match min {
            MinSpeed::Absolute(v) => v,
            MinSpeed::FractionOfPeak(f) => f * peak[j],
        };
        let kept: Vec<usize> = current
            .into_iter()
            .filter(|&i| rows[i].qd.abs() >= threshold(rows[i].joint))
            .collect();
        let mut joints: Vec<usize> = rows.iter().map(|r| r.joint).collect();
        joints.sort_unstable();
        joints.dedup();
        for j in joints {
            if !kept.iter().any(|&i| rows[i].joint == j) {
                bail!(
                    "no row of joint {} moves faster than the minimum speed {}: lower it",
                    model.joints[j],
                    threshold(j)
                );
            }
        }
        keep = Some(kept);
    }
    Ok(keep)
}

/// A record's end is in motion when some free joint's speed there exceeds this share of its
/// peak speed in the record.
const MOVING_EDGE: f64 = 0.01;

/// The spans (s) at the ends of record `m` that the zero-phase filters' start-up spoils:
/// where the record starts or ends in motion, the first or last 3 periods of the lowest
/// frequency the preparation passes (the position filter's cut-off, the decimation's band;
/// the band-limited differentiators' reach without either). The filters pad a record by
/// reflecting it about its end, which continues a constant velocity but reverses the
/// acceleration: a record that ends at rest loses nothing; one cut mid-motion put 900 N
/// of error on its last row.
fn moving_edges(
    m: &Measurement,
    (qd, dt): (&[Vec<f64>], f64),
    opts: &IdimOptions,
) -> Vec<(f64, f64)> {
    let n = m.len();
    let moving = |k: usize| {
        qd.iter().any(|v| {
            let peak = v.iter().fold(0.0f64, |a, x| a.max(x.abs()));
            peak > 0.0 && v[k].abs() > MOVING_EDGE * peak
        })
    };
    let fs = 1.0 / dt;
    let mut lowest = f64::INFINITY;
    if opts.cutoff_hz.is_finite() {
        lowest = lowest.min(opts.cutoff_hz);
    }
    if opts.decimation > 1 {
        lowest = lowest.min(0.8 * fs / 2.0 / opts.decimation as f64);
    }
    let span = if lowest.is_finite() {
        3.0 / lowest
    } else {
        2.0 * crate::signal::DIFFERENTIATOR_TAPS as f64 * dt
    };
    let mut out = Vec::new();
    if n > 2 * EDGE + 1 {
        if moving(EDGE) {
            out.push((m.t[0], m.t[0] + span));
        }
        if moving(n - 1 - EDGE) {
            out.push((m.t[n - 1] - span, m.t[n - 1]));
        }
    }
    out
}

/// The regressor column of one parameter of a user-defined effect: ∂u/∂θ, which reads no
/// parameter (the effect is linear in its parameters).
struct ExpressionColumn {
    name: String,
    joints: Vec<usize>,
    program: crate::expression::Program,
}

impl ExpressionColumn {
    /// The column at sample `k`: positions `q` (NJ, filtered), velocities and accelerations
    /// `(qd, qdd)` of the free joints (NF × samples), the sample times `t` (s) and the
    /// measured torques `tau` (NJ × samples); a locked joint's velocity, acceleration and
    /// command are 0.
    fn value(
        &self,
        q: &[f64],
        (qd, qdd): (&[Vec<f64>], &[Vec<f64>]),
        free: &[usize],
        (t, tau): (&[f64], &[Vec<f64>]),
        k: usize,
    ) -> f64 {
        use crate::expression::Symbol;
        let at =
            |x: &[Vec<f64>], j: usize| free.iter().position(|&f| f == j).map_or(0.0, |a| x[a][k]);
        self.program.eval_at(|s| match s {
            Symbol::Q(j) => q[j],
            Symbol::Qd(j) => at(qd, j),
            Symbol::Qdd(j) => at(qdd, j),
            Symbol::Tau(j) => {
                if free.contains(&j) {
                    tau[j][k]
                } else {
                    0.0
                }
            }
            Symbol::T => t[k],
            Symbol::Z(_) | Symbol::Param(_) => 0.0,
        })
    }
}

/// The regressor columns of the user-defined effects of `plant` that act on the free
/// joints `free`.
///
/// # Errors
/// An effect that is not linear in its parameters, or that reads a LuGre deflection (a
/// simulator state the inverse model does not have).
fn expression_columns(plant: &Plant, free: &[usize]) -> Result<Vec<ExpressionColumn>> {
    use crate::expression::{Program, Symbol};
    let mut out = Vec::new();
    for x in plant.expressions.iter().filter(|x| x.acts_with(free)) {
        let e = &x.expression;
        if !e.is_linear_in_parameters() {
            bail!(
                "{}: expression '{}' is not linear in its parameters, so the inverse-model \
                 least squares (IDIM) cannot fit it; use output-error identification or \
                 remove the effect",
                plant.name(),
                x.name
            );
        }
        if e.symbols().iter().any(|s| matches!(s, Symbol::Z(_))) {
            bail!(
                "{}: expression '{}' reads a LuGre deflection (z), a simulator state the inverse model does not have",
                plant.name(),
                x.name
            );
        }
        for (i, p) in e.parameters.iter().enumerate() {
            let program = Program::compile(&e.derivative(Symbol::Param(i)), &|_| None)
                .map_err(|m| anyhow::anyhow!("{}: expression '{}': {m}", plant.name(), x.name))?;
            out.push(ExpressionColumn {
                name: p.clone(),
                joints: x.joints.clone(),
                program,
            });
        }
    }
    Ok(out)
}

/// Result of a least-squares fit.
#[derive(Debug, Clone)]
pub struct Fit {
    /// Parameter names.
    pub names: Vec<String>,
    /// Estimates θ̂ (SI).
    pub theta: Vec<f64>,
    /// Standard deviations σ_θ̂ (SI).
    pub std: Vec<f64>,
    /// Condition number of W (2-norm).
    pub condition: f64,
    /// Number of rows.
    pub rows: usize,
    /// Relative error 100·‖y − Wθ̂‖/‖y‖ (%).
    pub relative_error: f64,
    /// When the regressor is rank-deficient ([`least_squares_base`]): the base parameters
    /// the data determine, each a kept column with the dependent columns folded into it;
    /// empty for a full-rank fit.
    pub base: Vec<BaseEstimate>,
}

/// The estimate of one base parameter of a rank-deficient regressor
/// ([`least_squares_base`]).
#[derive(Debug, Clone)]
pub struct BaseEstimate {
    /// The base parameter: the kept parameter and the dependent ones folded into it,
    /// β = θ_kept + Σ k·θ_dependent ([`base_parameters_at`]).
    pub parameter: BaseParameter,
    /// Estimate β̂ (SI).
    pub value: f64,
    /// Standard deviation of β̂ (SI).
    pub std: f64,
}

impl Fit {
    /// Store the estimates as the plant's parameter values (links given in symbols whose
    /// barycentric parameters were fitted are converted to barycentric form,
    /// [`Plant::set_barycentric_values`]).
    ///
    /// # Errors
    /// As [`Plant::set_barycentric_values`].
    pub fn apply(&self, plant: &mut Plant) -> Result<()> {
        plant.set_barycentric_values(&self.names, &self.theta)
    }

    /// Relative standard deviation 100·σ/|θ| (%).
    pub fn relative_std(&self, i: usize) -> f64 {
        100.0 * self.std[i] / self.theta[i].abs()
    }

    /// Value by name.
    pub fn get(&self, name: &str) -> Option<f64> {
        self.names
            .iter()
            .position(|n| n == name)
            .map(|i| self.theta[i])
    }
}

/// The least squares' regressor is rank-deficient at the data: `columns` are the columns of
/// the dependency (the smallest singular value's right vector).
#[derive(Debug, Clone)]
pub struct RankDeficient {
    /// The dependent columns' names.
    pub columns: Vec<String>,
}

impl std::fmt::Display for RankDeficient {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "the regressor is rank-deficient: {} are not separately identifiable from these data",
            self.columns.join(", ")
        )
    }
}

impl std::error::Error for RankDeficient {}

/// Ordinary least squares on an observation.
///
/// # Errors
/// Fewer rows than parameters, or W rank-deficient (names the columns that are not
/// separately identifiable).
pub fn least_squares(obs: &Observation) -> Result<Fit> {
    let (r, p) = obs.w.shape();
    if r <= p {
        bail!(
            "{r} observation rows (after filtering, decimation, the window and the speed \
             threshold) for {p} parameters to estimate: more data needed (a longer record or \
             window, or less decimation)"
        );
    }
    // Scale columns to unit norm for a meaningful rank test.
    let scale: Vec<f64> = (0..p)
        .map(|c| obs.w.column(c).norm().max(f64::MIN_POSITIVE))
        .collect();
    let ws = DMatrix::from_fn(r, p, |i, c| obs.w[(i, c)] / scale[c]);
    let svd = crate::util::svd(ws.clone()).context(
        "the regressor's singular value decomposition did not converge (non-finite entries)",
    )?;
    let smax = svd.singular_values.max();
    let smin = svd.singular_values.min();
    if smin <= 1e-10 * smax {
        // The right singular vector of the smallest singular value names the dependency.
        let k = svd.singular_values.imin();
        let v_t = svd.v_t.as_ref().expect("computed");
        let dep: Vec<String> = (0..p)
            .filter(|&c| v_t[(k, c)].abs() > 0.1)
            .map(|c| obs.names[c].clone())
            .collect();
        return Err(RankDeficient { columns: dep }.into());
    }
    let sol = svd
        .solve(&obs.y, 0.0)
        .map_err(|e| anyhow::anyhow!("least squares: {e}"))?;
    let theta: Vec<f64> = (0..p).map(|c| sol[c] / scale[c]).collect();
    let std_of =
        |cov: &DMatrix<f64>| -> Vec<f64> { (0..p).map(|i| cov[(i, i)].max(0.0).sqrt()).collect() };
    let th = DVector::from_vec(theta.clone());
    let resid = &obs.y - &obs.w * &th;
    let sigma2 = resid.norm_squared() / (r - p) as f64;
    let wtw = obs.w.transpose() * &obs.w;
    let cov = wtw.try_inverse().context("WᵀW is singular")? * sigma2;
    let std = std_of(&cov);
    let condition =
        crate::util::singular_values(&obs.w).map_or(f64::INFINITY, |s| s.max() / s.min());
    let relative_error = 100.0 * resid.norm() / obs.y.norm();
    if !(condition.is_finite() && relative_error.is_finite())
        || theta.iter().chain(&std).any(|x| !x.is_finite())
    {
        bail!(
            "the least squares gave no usable estimate (condition number {condition:.3e}, relative error {relative_error} %): the data do not determine {}",
            obs.names.join(", ")
        );
    }
    Ok(Fit {
        names: obs.names.clone(),
        theta,
        std,
        condition,
        rows: r,
        relative_error,
        base: Vec::new(),
    })
}

/// Least squares on the base parameters (Gautier & Khalil 1990), for a regressor with
/// dependent columns (every serial arm's). The grouping is the configuration's own
/// ([`base_parameters_at`] at the records' locked positions `locked_at`, as `lockstep
/// params` prints it): each dependent rigid-body column is a combination of kept ones
/// (W₂ = W₁K), so the base parameters β = θ₁ + Kθ₂ are fitted on W₁ (the kept rigid-body
/// columns and every effect column). The dependent parameters θ₂ keep the values `prior`
/// gives (the plant's), the kept ones get θ₁ = β̂ − Kθ₂, so the fitted dynamics Wθ equal
/// W₁β̂ whatever θ₂. Standard deviations are those of β̂; a dependent parameter's is NaN
/// (not determined). Without dependent columns the result is [`least_squares`]'s, `base`
/// empty.
///
/// `prior(name)` gives a dependent parameter's value (`None`: 0).
///
/// `structural`, when given, is the same plant's observation on a record of random motion
/// ([`random_motion_observation`]): columns that depend on the others there as well as in
/// the data (a rotor inertia Ia_j beside the link inertia about joint j's axis, which
/// multiply the same q̈_j) are grouped the same way, effect columns kept and rigid-body
/// columns folded into them ([`effect_grouping`]).
///
/// # Errors
/// As [`least_squares`] on the kept columns (fewer rows than base parameters, a kept
/// column the data do not determine, non-finite estimates); a dependency that holds at the
/// data only is named with the joints' excitation (`explain_deficiency`).
pub fn least_squares_base(
    obs: &Observation,
    model: &generated::Model,
    conf: &generated::Configuration,
    locked_at: &[Vec<f64>],
    prior: &dyn Fn(&str) -> Option<f64>,
    structural: Option<&Observation>,
) -> Result<Fit> {
    let mut grouping = base_parameters_at(model, conf, locked_at);
    if let Some(random) = structural {
        effect_grouping(obs, random, &mut grouping);
    }
    let p = obs.names.len();
    let is_dependent = |c: usize| grouping.dependent.contains(&obs.names[c]);
    if !(0..p).any(is_dependent) {
        return least_squares(obs).map_err(|e| explain_deficiency(e, obs, model));
    }
    let kept: Vec<usize> = (0..p).filter(|&c| !is_dependent(c)).collect();
    let reduced = Observation {
        names: kept.iter().map(|&c| obs.names[c].clone()).collect(),
        y: obs.y.clone(),
        w: DMatrix::from_fn(obs.w.nrows(), kept.len(), |i, a| obs.w[(i, kept[a])]),
        rows: obs.rows.clone(),
    };
    let beta = least_squares(&reduced).map_err(|e| explain_deficiency(e, &reduced, model))?;
    let mut theta = vec![0.0; p];
    let mut std = vec![f64::NAN; p];
    let mut base = Vec::new();
    for c in (0..p).filter(|&c| is_dependent(c)) {
        theta[c] = prior(&obs.names[c]).unwrap_or(0.0);
    }
    for (a, &c) in kept.iter().enumerate() {
        // θ₁ = β̂ − Σ k·θ₂ over the dependent parameters folded into this one.
        let folded = grouping.base.iter().find(|b| b.name == obs.names[c]);
        let made_up: f64 = folded.map_or(0.0, |b| {
            b.terms
                .iter()
                .map(|(k, n)| k * prior(n).unwrap_or(0.0))
                .sum()
        });
        theta[c] = beta.theta[a] - made_up;
        std[c] = beta.std[a];
        if let Some(b) = folded.filter(|b| !b.terms.is_empty()) {
            base.push(BaseEstimate {
                parameter: b.clone(),
                value: beta.theta[a],
                std: beta.std[a],
            });
        }
    }
    Ok(Fit {
        names: obs.names.clone(),
        theta,
        std,
        base,
        ..beta
    })
}

/// Each record's first joint vector: the locked joints' positions the base-parameter
/// grouping is found at ([`base_parameters_at`]).
pub fn locked_positions(records: &[Measurement]) -> Vec<Vec<f64>> {
    records
        .iter()
        .map(|r| {
            r.q.iter()
                .map(|q| q.first().copied().unwrap_or(0.0))
                .collect()
        })
        .collect()
}

/// IDIM on the base parameters of `plant`'s observation `obs`, as `identify idim`, `refit`
/// and `diagnose --apply` fit it: the rigid body grouped at the locked positions
/// `locked_at` ([`locked_positions`]), the effect columns grouped against a random motion
/// ([`random_motion_observation`]), the dependent parameters at the plant's values, the
/// rows weighted by `weighting` ([`weighted_least_squares_base`]). Returns the fit and each
/// weighted joint's σ. The linear step of [`separable_fit`].
///
/// # Errors
/// A free joint that does not move in the records ([`refuse_still_joints`]); as
/// [`random_motion_observation`] and [`weighted_least_squares_base`].
pub fn base_fit(
    plant: &Plant,
    obs: &Observation,
    config: &str,
    locked_at: &[Vec<f64>],
    opts: &IdimOptions,
    weighting: Weighting,
) -> Result<(Fit, Vec<(usize, f64)>)> {
    let random = random_motion_observation(plant, config, locked_at, opts)?;
    base_fit_with(plant, obs, config, locked_at, weighting, &random)
}

/// [`base_fit`] with the random motion's observation `random` given
/// ([`random_motion_observation`] of a plant with the same effects): the structural
/// grouping does not change with the effects' nonlinear values, so a separable fit builds
/// it once for all its trials.
///
/// # Errors
/// As [`base_fit`].
pub fn base_fit_with(
    plant: &Plant,
    obs: &Observation,
    config: &str,
    locked_at: &[Vec<f64>],
    weighting: Weighting,
    random: &Observation,
) -> Result<(Fit, Vec<(usize, f64)>)> {
    let conf = crate::util::configuration(plant.model, config)?;
    refuse_still_joints(obs, plant.model)?;
    let values = plant.values_with_barycentric()?;
    weighted_least_squares_base(
        obs,
        plant.model,
        conf,
        locked_at,
        &|n| values.get(n).copied(),
        weighting,
        Some(random),
    )
}

/// A free joint whose filtered position spans less than this share of the widest joint's
/// span over the observation's rows does not move for IDIM.
pub const STILL_SHARE: f64 = 1e-4;

/// Refuse an observation in which a free joint does not move: its velocity and acceleration
/// columns are then zero or noise (sign(q̇) of a still joint is the sign of rounding), so
/// the least squares would return numbers for what the data cannot separate. Structurally
/// the columns are separable (a random motion separates them); the records give them no
/// excitation.
///
/// # Errors
/// The first still joint, its span against the widest one's, and the parameters of its
/// own effects.
pub fn refuse_still_joints(obs: &Observation, model: &generated::Model) -> Result<()> {
    let spans: Vec<(usize, f64)> = rows_by_joint(obs)
        .into_iter()
        .map(|(j, idx)| {
            let (lo, hi) = idx
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &i| {
                    (lo.min(obs.rows[i].q), hi.max(obs.rows[i].q))
                });
            (j, hi - lo)
        })
        .collect();
    let Some(&(widest, max)) = spans.iter().max_by(|a, b| a.1.total_cmp(&b.1)) else {
        return Ok(());
    };
    if spans.len() < 2 || max.is_nan() || max <= 0.0 {
        return Ok(());
    }
    if let Some(&(j, span)) = spans.iter().find(|(_, s)| *s <= STILL_SHARE * max) {
        let own: Vec<&str> = obs
            .names
            .iter()
            .filter(|n| names::split_parameter(model.joints, n).is_some_and(|(_, k)| k == j))
            .filter(|n| !model.params.contains(&n.as_str()) && !n.starts_with("offset_"))
            .map(String::as_str)
            .collect();
        bail!(
            "joint '{}' does not move in these records (its filtered position spans {span:.3e} \
             against {max:.3e} on '{}'): too little excitation on it to separate its \
             velocity and acceleration terms ({}, and the inertia it moves); lock it (a \
             configuration without it) or record motion of the joint",
            model.joints[j],
            model.joints[widest],
            if own.is_empty() {
                "the link inertias".to_string()
            } else {
                own.join(", ")
            }
        );
    }
    Ok(())
}

/// The nonlinear parameters of the plant's torque-space effects on the free joints of
/// `config` (spring and friction-bias rest angles `qeq_j`, once per joint; Stribeck and
/// LuGre speeds `vs_j`; friction bias factors `FrictionBias_j`), by name.
///
/// # Errors
/// Unknown configuration.
pub fn nonlinear_parameters(plant: &Plant, config: &str) -> Result<Vec<String>> {
    let conf = crate::util::configuration(plant.model, config)?;
    Ok(plant
        .effects
        .iter()
        .filter(|e| conf.free.contains(&e.joint))
        .flat_map(|e| {
            e.kind
                .nonlinear_symbols()
                .iter()
                .map(move |s| e.parameter_name(s, plant.model.joints))
        })
        .fold(Vec::new(), |mut names: Vec<String>, n| {
            // A spring and a friction bias on one joint share its qeq.
            if !names.contains(&n) {
                names.push(n);
            }
            names
        }))
}

/// What [`separable_fit`] returns: the plant with its nonlinear values set, the
/// observation built at them, the linear fit on it, and the nonlinear values found.
pub struct SeparableFit {
    /// The plant with the nonlinear values found (the linear ones not yet applied).
    pub plant: Plant,
    /// The observation at those values.
    pub observation: Observation,
    /// The linear least squares on it.
    pub fit: Fit,
    /// The nonlinear parameters and their values (empty when the plant has none).
    pub nonlinear: Vec<(String, f64)>,
}

/// Variable projection (Golub & Pereyra, SIAM J. Numer. Anal. 10(2), 1973) for a plant whose
/// torque-space effects are linear in all but a few parameters (a spring's rest angle, a
/// Stribeck speed: [`nonlinear_parameters`]): for given nonlinear values ν the inverse model
/// is linear, and `linear` (IDIM-LS on the base parameters, weighted or not) gives the best
/// linear values α̂(ν); ν is then fitted by Levenberg–Marquardt on the projected residual
/// y − W(ν) α̂(ν) (Stribeck speeds through their logarithm, so they stay positive), the
/// Jacobian by differences. Without nonlinear parameters it is the linear fit alone.
///
/// # Errors
/// As [`observation`] and `linear` at the plant's values; a trial point whose observation or
/// fit fails is rejected (the step shrinks).
pub fn separable_fit(
    plant: &Plant,
    config: &str,
    records: &[Measurement],
    opts: &IdimOptions,
    linear: &dyn Fn(&Plant, &Observation) -> Result<Fit>,
) -> Result<SeparableFit> {
    separable_fit_rows(plant, config, records, opts, linear, &|obs| obs)
}

/// [`separable_fit`] on the rows `rows` keeps of each observation built (the training rows
/// of a cross-validation, [`crate::identify::preparation::split`]).
///
/// # Errors
/// As [`separable_fit`].
pub fn separable_fit_rows(
    plant: &Plant,
    config: &str,
    records: &[Measurement],
    opts: &IdimOptions,
    linear: &dyn Fn(&Plant, &Observation) -> Result<Fit>,
    rows: &dyn Fn(Observation) -> Observation,
) -> Result<SeparableFit> {
    let names = nonlinear_parameters(plant, config)?;
    let log = |n: &str| n.starts_with("vs_") || n.starts_with("FrictionBias_");
    // A rest angle far outside the motion turns the spring into a constant torque: keep it
    // within two spans of the joint's range in the records (found once, for every trial).
    let bounds: Vec<Option<(f64, f64)>> = names
        .iter()
        .map(|n| {
            let j = names::parameter_joint(plant.model.joints, "qeq", n)?;
            let (lo, hi) = records
                .iter()
                .flat_map(|r| r.q.get(j).into_iter().flatten())
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
                    (a.min(x), b.max(x))
                });
            let span = (hi - lo).max(1e-3);
            (lo.is_finite() && hi.is_finite()).then_some((lo - 2.0 * span, hi + 2.0 * span))
        })
        .collect();
    let clamp = |u: &mut [f64]| {
        for (b, x) in bounds.iter().zip(u.iter_mut()) {
            if let Some((lo, hi)) = b {
                *x = x.clamp(*lo, *hi);
            }
        }
    };
    // The records filtered, differentiated and the rigid body's columns built once: a
    // trial rebuilds only the effects' columns.
    let prepared = Prepared::new(plant, config, records, opts)?;
    let at = |u: &[f64]| -> Result<(Plant, Observation, Fit, DVector<f64>)> {
        let mut p = plant.clone();
        for (n, &x) in names.iter().zip(u) {
            p.parameters
                .insert(n.clone(), if log(n) { x.exp() } else { x });
        }
        let obs = rows(prepared.at(&p)?);
        let fit = linear(&p, &obs)?;
        let th = DVector::from_column_slice(&fit.theta);
        let r = &obs.y - &obs.w * th;
        Ok((p, obs, fit, r))
    };
    let mut u: Vec<f64> = names
        .iter()
        .map(|n| {
            let v = plant.value(n)?;
            Ok(if log(n) { v.max(1e-12).ln() } else { v })
        })
        .collect::<Result<_>>()?;
    let mut best = at(&u)?;
    if names.is_empty() {
        let (plant, observation, fit, _) = best;
        return Ok(SeparableFit {
            plant,
            observation,
            fit,
            nonlinear: Vec::new(),
        });
    }
    // The rest angle of a friction bias on a joint without a spring is a switch: the
    // projected residual is flat between samples and jumps across them, so it is profiled
    // on a grid of the joint's measured positions (19 quantiles, then 7 points between the
    // best one's neighbours) and held in the Levenberg–Marquardt steps. Each point rebuilds
    // the effects' columns of the prepared observation.
    let switch: Vec<Option<Vec<f64>>> = names
        .iter()
        .map(|n| {
            let j = names::parameter_joint(plant.model.joints, "qeq", n)?;
            let has = |k: crate::effects::EffectKind| {
                plant.effects.iter().any(|e| e.kind == k && e.joint == j)
            };
            if !has(crate::effects::EffectKind::FrictionBias)
                || has(crate::effects::EffectKind::Spring)
            {
                return None;
            }
            let mut q: Vec<f64> = records
                .iter()
                .flat_map(|r| r.q.get(j).into_iter().flatten().copied())
                .filter(|x| x.is_finite())
                .collect();
            q.sort_by(f64::total_cmp);
            (!q.is_empty()).then(|| {
                (1..20)
                    .map(|i| q[((q.len() - 1) as f64 * i as f64 / 20.0) as usize])
                    .collect()
            })
        })
        .collect();
    let mut cost = best.3.norm_squared();
    let profile =
        |u: &mut Vec<f64>, best: &mut (Plant, Observation, Fit, DVector<f64>), cost: &mut f64| {
            for (k, grid) in switch.iter().enumerate() {
                let Some(grid) = grid else { continue };
                let mut try_at = |x: f64, u: &mut Vec<f64>| {
                    let mut un = u.clone();
                    un[k] = x;
                    if let Ok(trial) = at(&un) {
                        let c = trial.3.norm_squared();
                        if c.is_finite() && c < *cost {
                            *cost = c;
                            *best = trial;
                            *u = un;
                        }
                    }
                };
                for &x in grid {
                    try_at(x, u);
                }
                let i = grid
                    .iter()
                    .position(|&g| g >= u[k])
                    .unwrap_or(grid.len() - 1);
                let (lo, hi) = (grid[i.saturating_sub(1)], grid[(i + 1).min(grid.len() - 1)]);
                for f in 1..8 {
                    try_at(lo + (hi - lo) * f as f64 / 8.0, u);
                }
            }
        };
    let lm =
        |u: &mut Vec<f64>, best: &mut (Plant, Observation, Fit, DVector<f64>), cost: &mut f64| {
            let mut lambda = 1e-2;
            for _ in 0..30 {
                let n = u.len();
                let rows = best.3.len();
                let mut jac = DMatrix::zeros(rows, n);
                for k in (0..n).filter(|&k| switch[k].is_none()) {
                    let h = 1e-4 * u[k].abs().max(1.0);
                    let mut up = u.clone();
                    up[k] += h;
                    let Ok((_, _, _, rp)) = at(&up) else {
                        continue;
                    };
                    jac.set_column(k, &((rp - &best.3) / h));
                }
                let jtj = jac.transpose() * &jac;
                let g = jac.transpose() * &best.3;
                let mut improved = false;
                for _ in 0..12 {
                    let mut a = jtj.clone();
                    for k in 0..n {
                        a[(k, k)] += lambda * jtj[(k, k)].max(1e-300) + 1e-300;
                    }
                    let Some(step) = a.cholesky().map(|c| c.solve(&(-&g))) else {
                        lambda *= 10.0;
                        continue;
                    };
                    let mut un: Vec<f64> = u
                        .iter()
                        .zip(step.iter())
                        .zip(&switch)
                        .map(|((a, b), s)| if s.is_some() { *a } else { a + b })
                        .collect();
                    clamp(&mut un);
                    if let Ok(trial) = at(&un) {
                        let cn = trial.3.norm_squared();
                        if cn.is_finite() && cn < *cost {
                            improved = (*cost - cn) / cost.max(1e-300) > 1e-10;
                            *u = un;
                            *best = trial;
                            *cost = cn;
                            lambda = (lambda / 3.0).max(1e-9);
                            break;
                        }
                    }
                    lambda *= 4.0;
                }
                if !improved {
                    break;
                }
            }
        };
    // A neutral bias (1) makes its rest angle invisible to the profile: the bias moves first.
    let neutral = names
        .iter()
        .zip(&u)
        .any(|(n, &x)| n.starts_with("FrictionBias_") && x.abs() < 1e-12);
    if neutral {
        lm(&mut u, &mut best, &mut cost);
    }
    profile(&mut u, &mut best, &mut cost);
    lm(&mut u, &mut best, &mut cost);
    let nonlinear = names
        .iter()
        .zip(&u)
        .map(|(n, &x)| (n.clone(), if log(n) { x.exp() } else { x }))
        .collect();
    let (plant, observation, fit, _) = best;
    Ok(SeparableFit {
        plant,
        observation,
        fit,
        nonlinear,
    })
}

/// The observation of `plant` on a record of random smooth motion (each joint a sum of three
/// sines of random amplitude, frequency 0.2–3 Hz and phase, 4 s at 1 kHz; locked joints at
/// `locked_at[0]`, or 0), with the same columns as the data's: what holds for every motion
/// (a structural dependency) holds here too, what holds only at the data does not.
///
/// # Errors
/// As [`observation`].
pub fn random_motion_observation(
    plant: &Plant,
    config: &str,
    locked_at: &[Vec<f64>],
    window_free: &IdimOptions,
) -> Result<Observation> {
    let model = plant.model;
    let conf = crate::util::configuration(model, config)?;
    let nj = model.joints.len();
    let n = 4000;
    let dt = 1e-3;
    let mut rng = generated::inertia::Xorshift(0x5eed_0057);
    let t: Vec<f64> = (0..n).map(|k| k as f64 * dt).collect();
    let q: Vec<Vec<f64>> = (0..nj)
        .map(|j| {
            if !conf.free.contains(&j) {
                let at = locked_at.first().map_or(0.0, |v| v[j]);
                return vec![at; n];
            }
            let waves: Vec<(f64, f64, f64)> = (0..3)
                .map(|_| {
                    (
                        rng.uniform(0.2, 0.8),
                        rng.uniform(0.2, 3.0),
                        rng.uniform(0.0, std::f64::consts::TAU),
                    )
                })
                .collect();
            t.iter()
                .map(|&tk| {
                    waves
                        .iter()
                        .map(|(a, f, ph)| a * (std::f64::consts::TAU * f * tk + ph).sin())
                        .sum()
                })
                .collect()
        })
        .collect();
    let record = Measurement {
        file: "random motion".into(),
        t,
        tau: vec![vec![0.0; n]; nj],
        q,
        qd: vec![None; nj],
        tau_m: vec![None; nj],
        notes: Vec::new(),
    };
    let opts = IdimOptions {
        cutoff_hz: 40.0,
        filter_order: window_free.filter_order,
        decimation: 5,
        window: None,
        min_speed: None,
        differentiator: Differentiator::Central,
        trim_moving_edges: false,
    };
    observation(plant, config, std::slice::from_ref(&record), &opts)
}

/// The structural dependencies left after the rigid-body grouping: the columns of the data
/// `obs` and of a random motion `random` (the same columns) are scaled, stacked and taken
/// effect columns first (in the plant's order), then the kept rigid-body columns; a column
/// that depends on those before it in both is folded into them, β = θ_kept + Σ k θ_dep, as
/// [`base_parameters_at`] does for the rigid body (Gautier & Khalil 1990). Added to
/// `grouping`.
pub fn effect_grouping(obs: &Observation, random: &Observation, grouping: &mut BaseParameters) {
    let p = obs.names.len();
    if random.names != obs.names {
        return;
    }
    let rigid_dependent = |c: usize| grouping.dependent.contains(&obs.names[c]);
    let is_rigid = |c: usize| grouping.base.iter().any(|b| b.name == obs.names[c]);
    let mut order: Vec<usize> = (0..p)
        .filter(|&c| !rigid_dependent(c) && !is_rigid(c))
        .collect();
    order.extend((0..p).filter(|&c| !rigid_dependent(c) && is_rigid(c)));
    let (ra, rb) = (obs.w.nrows(), random.w.nrows());
    let stacked = |c: usize| -> DVector<f64> {
        let a = obs.w.column(c);
        let b = random.w.column(c);
        let (na, nb) = (a.norm().max(1e-300), b.norm().max(1e-300));
        DVector::from_iterator(
            ra + rb,
            a.iter().map(|x| x / na).chain(b.iter().map(|x| x / nb)),
        )
    };
    let mut basis: Vec<DVector<f64>> = Vec::new();
    let mut kept: Vec<usize> = Vec::new();
    let mut dependent: Vec<usize> = Vec::new();
    for c in order {
        let col = stacked(c);
        let norm = col.norm();
        if norm < 1e-12 {
            continue;
        }
        let mut r = col.clone();
        for _ in 0..2 {
            for b in &basis {
                let d = b.dot(&r);
                r -= b * d;
            }
        }
        if r.norm() > 1e-8 * norm {
            basis.push(r.normalize());
            kept.push(c);
        } else {
            dependent.push(c);
        }
    }
    if dependent.is_empty() {
        return;
    }
    // Coefficients in the parameters' own units, from the data and the random motion
    // together (unscaled): W_dep = W_kept K.
    let unscaled = |c: usize| -> DVector<f64> {
        DVector::from_iterator(
            ra + rb,
            obs.w
                .column(c)
                .iter()
                .chain(random.w.column(c).iter())
                .copied(),
        )
    };
    let w1 = DMatrix::from_columns(&kept.iter().map(|&c| unscaled(c)).collect::<Vec<_>>());
    let Some(svd) = crate::util::svd(w1) else {
        return;
    };
    for &d in &dependent {
        let Ok(k) = svd.solve(&unscaled(d), 1e-12) else {
            continue;
        };
        grouping.dependent.push(obs.names[d].clone());
        // A rigid-body base parameter that folds here brings its own dependent terms along.
        let carried: Vec<(f64, String)> =
            match grouping.base.iter().position(|b| b.name == obs.names[d]) {
                Some(at) => grouping.base.remove(at).terms,
                None => Vec::new(),
            };
        for (i, &ki) in k.iter().enumerate() {
            if ki.abs() <= 1e-9 {
                continue;
            }
            let name = &obs.names[kept[i]];
            let mut terms = vec![(ki, obs.names[d].clone())];
            terms.extend(carried.iter().map(|(c, n)| (ki * c, n.clone())));
            match grouping.base.iter_mut().find(|b| b.name == *name) {
                Some(b) => b.terms.extend(terms),
                None => grouping.base.push(BaseParameter {
                    name: name.clone(),
                    terms,
                }),
            }
        }
    }
}

/// A rank-deficiency error of the least squares made specific: the combination the data
/// cannot separate (structurally separable, or it would have been grouped) and, for each
/// joint whose rows those columns act on, its excitation (RMS q̇ and q̈ over its rows).
fn explain_deficiency(
    e: anyhow::Error,
    obs: &Observation,
    model: &generated::Model,
) -> anyhow::Error {
    let Some(deficient) = e.downcast_ref::<RankDeficient>() else {
        return e;
    };
    let msg = deficient.to_string();
    let names: Vec<&str> = deficient.columns.iter().map(|s| s.as_str()).collect();
    let mut joints: Vec<usize> = Vec::new();
    for n in &names {
        let c = obs.names.iter().position(|x| x == n).unwrap_or(0);
        let before = joints.len();
        for (i, r) in obs.rows.iter().enumerate() {
            if obs.w[(i, c)] != 0.0 && !joints.contains(&r.joint) {
                joints.push(r.joint);
            }
        }
        // A column that is zero in these data: an effect parameter names its joint (`Fc_q5`).
        if joints.len() == before {
            if let Some((_, j)) = names::split_parameter(model.joints, n) {
                if !joints.contains(&j) {
                    joints.push(j);
                }
            }
        }
    }
    joints.sort_unstable();
    let excitation: Vec<String> = joints
        .iter()
        .map(|&j| {
            let rows: Vec<&RowInfo> = obs.rows.iter().filter(|r| r.joint == j).collect();
            let rms = |f: &dyn Fn(&RowInfo) -> f64| {
                (rows.iter().map(|r| f(r).powi(2)).sum::<f64>() / rows.len().max(1) as f64).sqrt()
            };
            format!(
                "joint {}: RMS velocity {:.3e}, RMS acceleration {:.3e}",
                model.joints[j],
                rms(&|r| r.qd),
                rms(&|r| r.qdd)
            )
        })
        .collect();
    anyhow::anyhow!(
        "{msg}; these columns are separable for other motions, so the records do not excite them enough (too little motion of the joints they act on: {}); add motion of those joints, or fix one of the parameters",
        excitation.join("; ")
    )
}

/// How IDIM weights the rows of its joints.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Weighting {
    /// Ordinary least squares: every row alike.
    Ols,
    /// IDIM-WLS ([`weighted_least_squares_base`]).
    Wls,
    /// WLS where the joints' torque scales (RMS of y per joint) differ by more than
    /// [`WLS_SCALE_RATIO`], else OLS (the default).
    #[default]
    Auto,
}

/// The ratio of the largest to the smallest joint torque RMS above which `Auto` weights.
pub const WLS_SCALE_RATIO: f64 = 10.0;

/// The joints of an observation's rows and each joint's row indices, in joint order.
pub fn rows_by_joint(obs: &Observation) -> Vec<(usize, Vec<usize>)> {
    let mut joints: Vec<usize> = obs.rows.iter().map(|r| r.joint).collect();
    joints.sort_unstable();
    joints.dedup();
    joints
        .into_iter()
        .map(|j| {
            let idx = (0..obs.rows.len())
                .filter(|&i| obs.rows[i].joint == j)
                .collect();
            (j, idx)
        })
        .collect()
}

/// IDIM-WLS (Gautier, *Dynamic identification of robots with power model*, ICRA 1997; the
/// weighting FIGAROH uses): each joint j's subsystem alone (its rows on the columns that act
/// on them) fitted by least squares gives its residual σ_j² = ‖ρ_j‖² / (r_j − b_j) (r_j its
/// rows, b_j the rank of its columns: not the whole fit's residual, into which the other
/// joints' noise leaks through the shared parameters); the rows of joint j are divided by
/// σ_j and the whole fitted again ([`least_squares_base`]). Joints whose torques differ by orders of magnitude (a wrist beside a
/// shoulder) then count by their own noise, not by their size. With `weighting` `Ols`, or
/// `Auto` where the joints' torque RMS differ by at most [`WLS_SCALE_RATIO`], the ordinary
/// fit is returned and the σ list is empty. The returned fit's relative error is the
/// unweighted 100‖y − Wθ̂‖/‖y‖; its standard deviations are the weighted fit's.
///
/// # Errors
/// As [`least_squares_base`]; a joint whose residual is 0 or not finite (no weight).
pub fn weighted_least_squares_base(
    obs: &Observation,
    model: &generated::Model,
    conf: &generated::Configuration,
    locked_at: &[Vec<f64>],
    prior: &dyn Fn(&str) -> Option<f64>,
    weighting: Weighting,
    structural: Option<&Observation>,
) -> Result<(Fit, Vec<(usize, f64)>)> {
    let joints = rows_by_joint(obs);
    let scale = |idx: &[usize]| {
        (idx.iter().map(|&i| obs.y[i] * obs.y[i]).sum::<f64>() / idx.len().max(1) as f64).sqrt()
    };
    let scales: Vec<f64> = joints.iter().map(|(_, idx)| scale(idx)).collect();
    let ratio = scales.iter().fold(0.0f64, |a, &s| a.max(s))
        / scales
            .iter()
            .fold(f64::INFINITY, |a, &s| a.min(s))
            .max(f64::MIN_POSITIVE);
    let weigh = match weighting {
        Weighting::Ols => false,
        Weighting::Wls => true,
        Weighting::Auto => ratio > WLS_SCALE_RATIO,
    };
    if !weigh || joints.len() < 2 {
        return Ok((
            least_squares_base(obs, model, conf, locked_at, prior, structural)?,
            Vec::new(),
        ));
    }
    let mut sigma = Vec::new();
    for (j, idx) in &joints {
        // The joint's own subsystem: its rows on the columns that act on them, by least
        // squares (minimum norm where they are dependent).
        let active: Vec<usize> = (0..obs.w.ncols())
            .filter(|&c| idx.iter().any(|&i| obs.w[(i, c)] != 0.0))
            .collect();
        let wj = DMatrix::from_fn(idx.len(), active.len(), |r, c| obs.w[(idx[r], active[c])]);
        let yj = DVector::from_iterator(idx.len(), idx.iter().map(|&i| obs.y[i]));
        let svd = crate::util::svd(wj.clone()).with_context(|| {
            format!(
                "IDIM-WLS: joint {}'s regressor is not finite",
                model.joints[*j]
            )
        })?;
        let tol = 1e-10 * svd.singular_values.max();
        let rank = svd.singular_values.iter().filter(|&&v| v > tol).count();
        let xj = svd
            .solve(&yj, tol)
            .map_err(|e| anyhow::anyhow!("IDIM-WLS: joint {}: {e}", model.joints[*j]))?;
        let rho = &yj - &wj * xj;
        let dof = idx.len().saturating_sub(rank).max(1) as f64;
        let s = (rho.norm_squared() / dof).sqrt();
        if !(s.is_finite() && s > 0.0) {
            bail!(
                "IDIM-WLS: joint {}'s residual is {s}: it gives no weight (use the ordinary least squares)",
                model.joints[*j]
            );
        }
        sigma.push((*j, s));
    }
    let mut weighted = obs.clone();
    for ((_, idx), (_, s)) in joints.iter().zip(&sigma) {
        for &i in idx {
            weighted.y[i] /= s;
            for c in 0..weighted.w.ncols() {
                weighted.w[(i, c)] /= s;
            }
        }
    }
    let mut fit = least_squares_base(&weighted, model, conf, locked_at, prior, structural)?;
    let th = DVector::from_column_slice(&fit.theta);
    fit.relative_error = 100.0 * (&obs.y - &obs.w * th).norm() / obs.y.norm();
    Ok((fit, sigma))
}

/// Why the values of `plant` (after a fit) are not a physical body, for configuration
/// `conf`: links with mass ≤ 0 or an inertia that is not positive definite
/// ([`Plant::consistency`], blocking findings only), and values outside the plant's
/// `[bounds]`. Empty when plausible.
///
/// # Errors
/// A parameter the configuration needs has no value.
pub fn implausible(plant: &Plant, conf: &generated::Configuration) -> Result<Vec<String>> {
    let p = plant.barycentric(Some(conf))?;
    let mut out: Vec<String> = plant
        .consistency(&p, Some(conf))
        .into_iter()
        .filter(|f| f.is_blocking())
        .map(|f| f.to_string())
        .collect();
    for (n, v, (lo, hi)) in plant.outside_bounds(&plant.parameters) {
        out.push(format!(
            "{n} = {v:.6e} is outside its bounds [{lo:.6e}, {hi:.6e}]"
        ));
    }
    Ok(out)
}

/// The model's prediction Wθ for the observation with the plant's parameter values.
///
/// # Errors
/// A parameter of the observation has no value in the plant.
pub fn predict(plant: &Plant, obs: &Observation) -> Result<DVector<f64>> {
    // Links given in the model file's symbols enter through their barycentric values.
    let values = plant.values_with_barycentric()?;
    let theta: Vec<f64> = obs
        .names
        .iter()
        .map(|n| {
            values.get(n).copied().with_context(|| {
                format!(
                    "{}: parameter '{n}' has no value (identify first, or add it under [parameters])",
                    plant.name()
                )
            })
        })
        .collect::<Result<_>>()?;
    Ok(&obs.w * DVector::from_vec(theta))
}

/// Relative error 100·‖y − ŷ‖/‖y‖ (%).
pub fn relative_error(y: &DVector<f64>, yhat: &DVector<f64>) -> f64 {
    100.0 * (y - yhat).norm() / y.norm()
}
