//! Measurement files (docs/src/design/digest.md §5): CSV with a header; `t` (s), then per joint `j`
//! `tau{j}` (commanded torque or force, N·m or N) and `q{j}` (position, rad or m); optional
//! `qd{j}` (rad/s or m/s) and `tauM{j}` (measured torque).
//!
//! Files with other column names (such as the EMPS benchmark's `t_s, force_N, q_m`) are read
//! through a side file `<name>.toml` beside the CSV whose `[columns]` table maps the standard
//! names to the file's own, e.g. `t = "t_s"`, `tau0 = "force_N"`, `q0 = "q_m"`.
//!
//! Every error names the file, and where it applies the row (1-based line number in the file,
//! the header being line 1) and the column.

use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

pub mod sampling;

/// A problem with a measurement file.
#[derive(Debug, thiserror::Error)]
pub enum DataError {
    /// The file cannot be opened or read.
    #[error("{file}: cannot read: {reason}")]
    Io {
        /// File.
        file: PathBuf,
        /// OS message.
        reason: String,
    },
    /// The side file is malformed.
    #[error("{file}: {reason}")]
    SideFile {
        /// Side file.
        file: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// A required column is absent.
    #[error("{file}: missing column '{column}' ({available})")]
    MissingColumn {
        /// File.
        file: PathBuf,
        /// Column name looked for.
        column: String,
        /// What the file has instead.
        available: String,
    },
    /// A cell is not a finite number.
    #[error("{file}: row {row}, column '{column}': {reason}")]
    BadCell {
        /// File.
        file: PathBuf,
        /// Line number in the file (header = 1).
        row: usize,
        /// Column name.
        column: String,
        /// What is wrong.
        reason: String,
    },
    /// A structural problem with the record (time, length).
    #[error("{file}: {reason}")]
    Record {
        /// File.
        file: PathBuf,
        /// What is wrong.
        reason: String,
    },
}

/// The side file of a measurement (`<stem>.toml` beside it): provenance, the column
/// mapping, and for data of a locked-joint configuration, which one and where the locked
/// joints stand.
#[derive(Debug, Default, Clone, Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct SideFile {
    /// Free text.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub description: String,
    /// Where the data come from.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub source: String,
    /// Configuration of the model the record was taken in (`k1`, `c6`, …).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub configuration: Option<String>,
    /// Positions of the locked joints (rad or m) by joint name.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub locked: BTreeMap<String, f64>,
    /// Standard name → column name in the file.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub columns: BTreeMap<String, String>,
    /// How the commanded torques were applied between their samples: `zoh` (a digital
    /// controller held each command), `linear`, `cubic` or `bandlimited` (a continuous
    /// signal sampled for the file). The simulating commands use it unless `--hold` is
    /// given; absent, `zoh`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hold: Option<crate::simulation::Hold>,
    /// The torque-space preparation the record was published with (a benchmark's own
    /// settings); the commands use it unless `--cutoff`/`--decimate` are given, and choose
    /// from the data where it is absent ([`crate::identify::preparation`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub preparation: Option<SidePreparation>,
    /// What the `tau` columns are: `measured` (joint torques from a sensor or the drives'
    /// currents: the inverse model compares them, torque space) or `commanded` (the inputs
    /// of an open-loop record whose measurement is the positions: output space). Absent:
    /// `commanded` when the side file declares a `hold` (how commands were applied between
    /// samples), else `measured`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub torque: Option<TorqueKind>,
}

/// What a record's torque columns are ([`SideFile::torque`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum TorqueKind {
    /// Joint torques measured (sensor, drive currents): torque space.
    Measured,
    /// Commands applied to the joints, positions measured: output space.
    Commanded,
}

impl SideFile {
    /// What the record's torques are, and why: the declared `torque`, else `commanded` where
    /// a `hold` is declared, else `measured`.
    pub fn torque_kind(&self) -> (TorqueKind, &'static str) {
        match (self.torque, self.hold) {
            (Some(k), _) => (k, "declared in the side file"),
            (None, Some(_)) => (
                TorqueKind::Commanded,
                "the side file declares how the commands were held between samples",
            ),
            (None, None) => (
                TorqueKind::Measured,
                "the side file declares no hold of commands",
            ),
        }
    }
}

/// `[preparation]` of a side file: the position filter's cut-off and the decimation.
#[derive(Debug, Default, Clone, Copy, PartialEq, Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct SidePreparation {
    /// Cut-off of the zero-phase Butterworth on positions (Hz).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cutoff_hz: Option<f64>,
    /// Parallel decimation factor (1 = none).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub decimation: Option<usize>,
    /// How the positions are differentiated: `central` or `bandlimited`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub differentiator: Option<crate::signal::Differentiator>,
    /// Leave out the rows a record's moving ends spoil (default true; false keeps every row,
    /// as a benchmark's published processing may).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub trim_edges: Option<bool>,
}

/// Largest magnitude a measured value may have (any unit): beyond it a cell is corrupt, and
/// its square, in any sum of squares, would overflow the float format.
pub const MAX_MAGNITUDE: f64 = 1e100;

/// Why `x` cannot be a measured value (CSV cell or MAT element), or `None`.
fn implausible(x: f64) -> Option<String> {
    if !x.is_finite() {
        Some("is not a finite number".into())
    } else if x.abs() > MAX_MAGNITUDE {
        Some(format!(
            "is beyond any measured value (|x| > {MAX_MAGNITUDE:e}): a corrupt cell?"
        ))
    } else {
        None
    }
}

/// Named numeric columns of a CSV or MAT file, with the side file's mapping applied
/// (columns carry their standard names). A CSV cell that is not a finite number is reported
/// when its column is asked for.
#[derive(Debug, Clone)]
pub struct Table {
    /// The file.
    pub file: PathBuf,
    /// Its side file (empty when there is none).
    pub side: SideFile,
    names: Vec<String>,
    columns: Vec<Result<Vec<f64>, (usize, String)>>,
    /// "column" (CSV) or "variable" (MAT), for messages.
    what: &'static str,
    /// What reading did to the rows, each naming the file: repeats dropped, stale rows
    /// found, uneven times resampled ([`sampling`]); for the commands to print.
    pub notes: Vec<String>,
}

impl Table {
    /// Read a `.mat` (MATLAB v5/v7) or any other extension as CSV with a header, its times
    /// made even ([`sampling`]: exact repeats dropped, uneven times resampled onto the
    /// median period; what was done in [`Table::notes`]).
    ///
    /// # Errors
    /// [`DataError`]: unreadable file, malformed side file, CSV syntax, unreadable MAT file
    /// (v7.3/HDF5 is named as such), MAT variables of different lengths, a gap of missing
    /// samples ([`sampling::LARGEST_GAP`]).
    pub fn read(path: &Path) -> Result<Table, DataError> {
        let side = read_side_file(path)?;
        let is_mat = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("mat"));
        let mut t = if is_mat {
            read_mat(path)?
        } else {
            read_csv_table(path)?
        };
        for (std, own) in &side.columns {
            if let Some(i) = t.names.iter().position(|n| n == own) {
                t.names[i] = std.clone();
            }
        }
        t.side = side;
        t.regularise()?;
        Ok(t)
    }

    /// The column names (standard names where the side file maps them).
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// A column by name, `None` when absent.
    ///
    /// # Errors
    /// [`DataError::BadCell`] when it holds a cell that is not a finite number.
    pub fn get(&self, name: &str) -> Result<Option<Vec<f64>>, DataError> {
        let Some(i) = self.names.iter().position(|n| n == name) else {
            return Ok(None);
        };
        match &self.columns[i] {
            Ok(v) => Ok(Some(v.clone())),
            Err((row, reason)) => Err(DataError::BadCell {
                file: self.file.clone(),
                row: *row,
                column: self.own_name(name),
                reason: reason.clone(),
            }),
        }
    }

    /// A required column.
    ///
    /// # Errors
    /// [`DataError::MissingColumn`] naming the columns present, or as [`Table::get`].
    pub fn need(&self, name: &str) -> Result<Vec<f64>, DataError> {
        self.get(name)?.ok_or_else(|| self.missing(name, ""))
    }

    /// Column `name` is missing: the error naming the columns present, after `alternative`
    /// (another name that would have served, with its separator, or empty).
    fn missing(&self, name: &str, alternative: &str) -> DataError {
        DataError::MissingColumn {
            file: self.file.clone(),
            column: self.own_name(name),
            available: format!(
                "{alternative}{}: {}",
                if self.what == "column" {
                    "the header has"
                } else {
                    "the file's variables are"
                },
                self.names
                    .iter()
                    .map(|n| self.own_name(n))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        }
    }

    /// Column `signal` (`q`, `qd`, `tau`, `qref`, …) of joint `j` of a model whose joints
    /// are named `joints`: by the joint's name (`tau_q3`) or numbered from 0 as earlier
    /// versions wrote it (`tau2`; [`crate::names`]); `None` when neither is present.
    ///
    /// # Errors
    /// Both forms present ([`DataError::Record`], naming both columns); as [`Table::get`].
    pub fn joint_column(
        &self,
        joints: &[&str],
        signal: &str,
        j: usize,
    ) -> Result<Option<Vec<f64>>, DataError> {
        let named = crate::names::column(signal, joints[j]);
        let numbered = crate::names::numbered_column(signal, j);
        let has = |n: &str| self.names.iter().any(|x| x == n);
        match (has(&named), has(&numbered)) {
            (true, true) => Err(DataError::Record {
                file: self.file.clone(),
                reason: format!(
                    "columns '{}' and '{}' both give {signal} of joint '{}' ('{numbered}' numbers the joints from 0); keep one",
                    self.own_name(&named),
                    self.own_name(&numbered),
                    joints[j]
                ),
            }),
            (true, false) => self.get(&named),
            _ => self.get(&numbered),
        }
    }

    /// A required joint column ([`Table::joint_column`]).
    ///
    /// # Errors
    /// [`DataError::MissingColumn`] naming the column in the current form and the columns
    /// present; as [`Table::joint_column`].
    pub fn need_joint(
        &self,
        joints: &[&str],
        signal: &str,
        j: usize,
    ) -> Result<Vec<f64>, DataError> {
        self.joint_column(joints, signal, j)?.ok_or_else(|| {
            let numbered = crate::names::numbered_column(signal, j);
            self.missing(
                &crate::names::column(signal, joints[j]),
                &format!("or '{numbered}', numbered from 0 as earlier versions wrote; "),
            )
        })
    }

    fn own_name(&self, std: &str) -> String {
        self.side
            .columns
            .get(std)
            .cloned()
            .unwrap_or_else(|| std.to_string())
    }
}

fn read_csv_table(path: &Path) -> Result<Table, DataError> {
    let file = path.to_path_buf();
    let mut rdr = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .from_path(path)
        .map_err(|e| DataError::Io {
            file: file.clone(),
            reason: io_reason(&e),
        })?;
    let headers = rdr
        .headers()
        .map_err(|e| DataError::Io {
            file: file.clone(),
            reason: e.to_string(),
        })?
        .clone();
    let names: Vec<String> = headers.iter().map(str::to_string).collect();
    if names.iter().all(|n| n.is_empty()) {
        return Err(DataError::Record {
            file,
            reason: "the file is empty: expected a header row (such as t,tau0,q0) and data rows"
                .into(),
        });
    }
    for (i, n) in names.iter().enumerate() {
        if let Some(first) = names[..i].iter().position(|m| m == n) {
            return Err(DataError::Record {
                file,
                reason: format!(
                    "the header names '{n}' twice (columns {} and {}): which one is meant?",
                    first + 1,
                    i + 1
                ),
            });
        }
    }
    let mut columns: Vec<Result<Vec<f64>, (usize, String)>> = vec![Ok(Vec::new()); names.len()];
    for (r, rec) in rdr.records().enumerate() {
        let row = r + 2;
        let rec = rec.map_err(|e| DataError::Record {
            file: file.clone(),
            reason: format!("row {row}: {e}"),
        })?;
        for (i, col) in columns.iter_mut().enumerate() {
            let Ok(v) = col else { continue };
            let text = rec.get(i).unwrap_or("");
            match text.parse::<f64>().map(|x| (x, implausible(x))) {
                Ok((x, None)) => v.push(x),
                Ok((_, Some(why))) => *col = Err((row, format!("'{text}' {why}"))),
                Err(_) => *col = Err((row, format!("'{text}' is not a number"))),
            }
        }
    }
    Ok(Table {
        file,
        side: SideFile::default(),
        names,
        columns,
        what: "column",
        notes: Vec::new(),
    })
}

/// MATLAB's descriptive header must begin "MATLAB 5.0 MAT-file, " for the reader; files
/// written by other tools (SciPy: "MATLAB 5.0 MAT-file Platform: …") are accepted by
/// rewriting the descriptive text, which carries no data.
fn normalise_mat_header(bytes: &mut [u8]) {
    const PREFIX: &[u8] = b"MATLAB 5.0 MAT-file";
    if bytes.len() >= 128 && bytes.starts_with(PREFIX) && &bytes[19..21] != b", " {
        let text = b"MATLAB 5.0 MAT-file, read by lockstep";
        bytes[..116].fill(b' ');
        bytes[..text.len()].copy_from_slice(text);
    }
}

thread_local! {
    static QUIET_PANIC: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Parse MAT bytes with `matrw`, turning its panics on corrupt or truncated files into
/// errors (the panic message is not printed) and removing terminal colour codes from its
/// messages.
fn parse_mat(bytes: &[u8]) -> Result<matrw::MatFile, String> {
    static HOOK: std::sync::Once = std::sync::Once::new();
    HOOK.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if !QUIET_PANIC.with(|q| q.get()) {
                previous(info);
            }
        }));
    });
    QUIET_PANIC.with(|q| q.set(true));
    let result = std::panic::catch_unwind(|| matrw::load_matfile_from_u8(bytes));
    QUIET_PANIC.with(|q| q.set(false));
    let strip = |m: String| -> String {
        let mut out = String::with_capacity(m.len());
        let mut chars = m.chars().peekable();
        while let Some(c) = chars.next() {
            if c == '\u{1b}' {
                // CSI sequence: ESC [ parameters final-byte.
                if chars.peek() == Some(&'[') {
                    chars.next();
                    for c in chars.by_ref() {
                        if ('@'..='~').contains(&c) {
                            break;
                        }
                    }
                }
                continue;
            }
            out.push(c);
        }
        out.trim().to_string()
    };
    match result {
        Ok(Ok(m)) => Ok(m),
        Ok(Err(e)) => Err(strip(e.to_string())),
        Err(_) => Err("the file is truncated or corrupt".into()),
    }
}

/// Read back a MAT file lockstep wrote (see [`parse_mat`]).
fn load_mat_caught(path: &Path) -> Result<matrw::MatFile, String> {
    let bytes = std::fs::read(path).map_err(|e| e.to_string())?;
    parse_mat(&bytes)
}

fn read_mat(path: &Path) -> Result<Table, DataError> {
    let file = path.to_path_buf();
    let mut bytes = std::fs::read(path).map_err(|e| DataError::Io {
        file: file.clone(),
        reason: e.to_string(),
    })?;
    if bytes.starts_with(b"MATLAB 7.3 MAT-file") {
        return Err(DataError::Record {
            file,
            reason: "MATLAB v7.3 (HDF5) files are not read; save with save(..., '-v7')".into(),
        });
    }
    normalise_mat_header(&mut bytes);
    let mat = parse_mat(&bytes).map_err(|e| DataError::Record {
        file: file.clone(),
        reason: format!("not a readable MATLAB v5/v7 MAT file ({e})"),
    })?;
    let mut names = Vec::new();
    let mut columns: Vec<Result<Vec<f64>, (usize, String)>> = Vec::new();
    for (name, var) in mat.iter() {
        let dim = var.dim();
        let Some(data) = var.to_vec::<f64>() else {
            continue; // structs, cells, text, integer arrays: not signals
        };
        if dim.len() != 2 || data.len() <= 1 {
            continue; // scalars and higher-dimensional arrays
        }
        let (rows, cols) = (dim[0], dim[1]);
        let check = |v: Vec<f64>| -> Result<Vec<f64>, (usize, String)> {
            match v
                .iter()
                .enumerate()
                .find_map(|(k, &x)| Some((k, implausible(x)?)))
            {
                Some((k, why)) => Err((k + 1, format!("element {} ({:e}) {why}", k + 1, v[k]))),
                None => Ok(v),
            }
        };
        if rows == 1 || cols == 1 {
            names.push(name.clone());
            columns.push(check(data));
        } else {
            // A matrix `q` (samples × joints) gives columns q0, q1, …; column-major data.
            for c in 0..cols {
                names.push(format!("{name}{c}"));
                columns.push(check(data[c * rows..(c + 1) * rows].to_vec()));
            }
        }
    }
    let len = |c: &Result<Vec<f64>, (usize, String)>| c.as_ref().map_or(0, Vec::len);
    if let Some(first) = columns.first() {
        let n = len(first);
        for (nm, c) in names.iter().zip(&columns) {
            if c.is_ok() && len(c) != n {
                return Err(DataError::Record {
                    file,
                    reason: format!(
                        "variable '{nm}' has {} samples where '{}' has {n}",
                        len(c),
                        names[0]
                    ),
                });
            }
        }
    }
    Ok(Table {
        file,
        side: SideFile::default(),
        names,
        columns,
        what: "variable",
        notes: Vec::new(),
    })
}

/// One record: evenly sampled time series of one or more joints.
#[derive(Debug, Clone)]
pub struct Measurement {
    /// The file it was read from.
    pub file: PathBuf,
    /// Sample times (s), strictly increasing, evenly spaced.
    pub t: Vec<f64>,
    /// Commanded torque per joint: `tau[j][k]` (N·m, or N for a prismatic joint).
    pub tau: Vec<Vec<f64>>,
    /// Measured position per joint: `q[j][k]` (rad or m).
    pub q: Vec<Vec<f64>>,
    /// Measured velocity per joint when the file has it.
    pub qd: Vec<Option<Vec<f64>>>,
    /// Measured torque per joint when the file has it.
    pub tau_m: Vec<Option<Vec<f64>>>,
    /// What reading did to the rows ([`Table::notes`]).
    pub notes: Vec<String>,
}

/// The minimum number of samples a record must have.
pub const MIN_SAMPLES: usize = 10;

impl Measurement {
    /// Sampling period (s).
    pub fn dt(&self) -> f64 {
        mean_period(&self.t)
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// True when there are no samples (never for a loaded record).
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// Read a record with `joints` joints from a CSV file or, for a `.mat` extension, a
    /// MATLAB v5/v7 MAT file (one variable per column name, or a matrix `q`/`tau`/… with a
    /// column per joint).
    ///
    /// # Errors
    /// [`DataError`]: missing or unreadable file, malformed side file, missing column,
    /// non-numeric or non-finite cell, fewer than [`MIN_SAMPLES`] rows, time not strictly
    /// increasing or not evenly spaced (relative deviation of a step above 1e-3).
    pub fn read(path: &Path, joints: &[&str]) -> Result<Measurement, DataError> {
        let table = Table::read(path)?;
        Measurement::from_table(&table, joints)
    }

    /// A record from a table, for a model whose joints are named `joints`: `t`, and per
    /// joint J `tau_J` and `q_J` required, `qd_J`, `tauM_J` optional (each also read in the
    /// numbered form of earlier versions, `tau2`: [`Table::joint_column`]).
    ///
    /// # Errors
    /// As [`Measurement::read`].
    pub fn from_table(table: &Table, joints: &[&str]) -> Result<Measurement, DataError> {
        let t = table.need("t")?;
        let mut tau = Vec::new();
        let mut q = Vec::new();
        let mut qd = Vec::new();
        let mut tau_m = Vec::new();
        for j in 0..joints.len() {
            tau.push(table.need_joint(joints, "tau", j)?);
            q.push(table.need_joint(joints, "q", j)?);
            qd.push(table.joint_column(joints, "qd", j)?);
            tau_m.push(table.joint_column(joints, "tauM", j)?);
        }
        let m = Measurement {
            file: table.file.clone(),
            t,
            tau,
            q,
            qd,
            tau_m,
            notes: table.notes.clone(),
        };
        check_sampling(&m.file, &m.t)?;
        Ok(m)
    }

    /// Write the record as CSV, or as a MATLAB v7 MAT file for a `.mat` extension (one
    /// N×1 double variable per column), atomically: a temporary file renamed into place.
    /// Columns: `t`, then per joint J (of `joints`, the model's joint names) `tau_J`, `q_J`,
    /// and `qd_J`, `tauM_J` where present.
    ///
    /// # Errors
    /// I/O errors, with the path; fewer joint names than joints.
    pub fn write(&self, path: &Path, joints: &[&str]) -> anyhow::Result<()> {
        crate::files::commit(vec![self.stage(path, joints)?])
    }

    /// The record staged for [`crate::files::commit`] (see [`Measurement::write`]).
    ///
    /// # Errors
    /// As [`Measurement::write`].
    pub fn stage(&self, path: &Path, joints: &[&str]) -> anyhow::Result<crate::files::Staged> {
        if joints.len() < self.q.len() {
            anyhow::bail!(
                "{}: {} joint names for a record of {} joints",
                path.display(),
                joints.len(),
                self.q.len()
            );
        }
        let col = crate::names::column;
        let mut names = vec!["t".to_string()];
        let mut cols: Vec<&[f64]> = vec![&self.t];
        for (j, joint) in joints.iter().enumerate().take(self.q.len()) {
            names.push(col("tau", joint));
            cols.push(&self.tau[j]);
            names.push(col("q", joint));
            cols.push(&self.q[j]);
            if let Some(v) = &self.qd[j] {
                names.push(col("qd", joint));
                cols.push(v);
            }
            if let Some(v) = &self.tau_m[j] {
                names.push(col("tauM", joint));
                cols.push(v);
            }
        }
        stage_columns(path, &names, &cols)
    }
}

/// Mean sampling period of sample times `t` (two or more), (t_last − t_first)/(n − 1).
fn mean_period(t: &[f64]) -> f64 {
    (t[t.len() - 1] - t[0]) / (t.len() - 1) as f64
}

/// Check sample times `t` of `file`: at least [`MIN_SAMPLES`], strictly increasing, evenly
/// spaced (relative deviation of a step at most 1e-3). Returns the mean sampling period (s).
///
/// # Errors
/// [`DataError::Record`] naming the row (header = line 1).
pub(crate) fn check_sampling(file: &Path, t: &[f64]) -> Result<f64, DataError> {
    let err = |reason: String| DataError::Record {
        file: file.to_path_buf(),
        reason,
    };
    if t.len() < MIN_SAMPLES {
        return Err(err(format!(
            "too few samples: {} rows, at least {MIN_SAMPLES} needed",
            t.len()
        )));
    }
    let dt = mean_period(t);
    if dt <= 0.0 {
        return Err(err("time does not increase".into()));
    }
    for k in 1..t.len() {
        let step = t[k] - t[k - 1];
        if step <= 0.0 {
            return Err(err(format!(
                "row {}: time {} s is not after the previous {} s (time must increase)",
                k + 2,
                t[k],
                t[k - 1]
            )));
        }
        if (step - dt).abs() > 1e-3 * dt {
            return Err(err(format!(
                "row {}: uneven sampling, step {step:.6e} s where the mean step is {dt:.6e} s",
                k + 2
            )));
        }
    }
    Ok(dt)
}

fn io_reason(e: &csv::Error) -> String {
    match e.kind() {
        csv::ErrorKind::Io(io) => io.to_string(),
        _ => e.to_string(),
    }
}

/// The side file of a measurement: `<stem>.toml` beside it, or an empty mapping.
///
/// # Errors
/// [`DataError::SideFile`] when it exists but is not valid.
pub fn read_side_file(path: &Path) -> Result<SideFile, DataError> {
    let side = side_file_path(path);
    if !side.exists() {
        return Ok(SideFile::default());
    }
    let text = std::fs::read_to_string(&side).map_err(|e| DataError::Io {
        file: side.clone(),
        reason: e.to_string(),
    })?;
    toml::from_str(&text).map_err(|e| DataError::SideFile {
        file: side.clone(),
        reason: e.message().replace('`', "'"),
    })
}

/// Write named columns of equal length as CSV (17 significant digits, exact round trip) or,
/// for a `.mat` extension, as a MATLAB v7 MAT file, atomically ([`crate::files`]).
///
/// # Errors
/// I/O errors, with the path; columns of different lengths; a target that is not a regular
/// file.
pub fn write_columns(path: &Path, names: &[String], cols: &[&[f64]]) -> anyhow::Result<()> {
    crate::files::commit(vec![stage_columns(path, names, cols)?])
}

/// The columns of [`write_columns`] written to a staged temporary file, for
/// [`crate::files::commit`] together with other outputs.
///
/// # Errors
/// As [`write_columns`].
pub fn stage_columns(
    path: &Path,
    names: &[String],
    cols: &[&[f64]],
) -> anyhow::Result<crate::files::Staged> {
    let n = cols.first().map_or(0, |c| c.len());
    if let Some((name, c)) = names.iter().zip(cols).find(|(_, c)| c.len() != n) {
        anyhow::bail!(
            "{}: column '{name}' has {} samples, expected {n}",
            path.display(),
            c.len()
        );
    }
    let staged = crate::files::Staged::new(path)?;
    let is_mat = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("mat"));
    if is_mat {
        let mut mat = matrw::MatFile::new();
        for (name, c) in names.iter().zip(cols) {
            let arr =
                matrw::NumericArray::new(vec![n, 1], matrw::MatlabType::from(c.to_vec()), None)
                    .map_err(|e| anyhow::anyhow!("{}: variable '{name}': {e}", path.display()))?;
            mat.insert(name, matrw::MatVariable::NumericArray(arr));
        }
        // matrw writes to a path: write the staged file, check that it reads back.
        let tmp_str = staged
            .tmp_path()
            .to_str()
            .ok_or_else(|| anyhow::anyhow!("{}: path is not valid UTF-8", path.display()))?;
        matrw::save_matfile_v7(tmp_str, mat, true)
            .map_err(|e| anyhow::anyhow!("{}: cannot write: {e}", path.display()))?;
        let back = load_mat_caught(staged.tmp_path())
            .map_err(|e| anyhow::anyhow!("{}: cannot write: {e}", path.display()))?;
        if back.iter().count() != names.len() {
            anyhow::bail!(
                "{}: cannot write: the written file does not read back",
                path.display()
            );
        }
        return Ok(staged);
    }
    staged.fill(|w| {
        use std::io::Write;
        writeln!(w, "{}", names.join(","))?;
        for k in 0..n {
            let row: Vec<String> = cols.iter().map(|c| format!("{:e}", c[k])).collect();
            writeln!(w, "{}", row.join(","))?;
        }
        Ok(())
    })?;
    Ok(staged)
}

/// The measurement files named by `paths`: each file as given, each directory as its `.csv`
/// and `.mat` files in name order (side files, `.toml`, are not measurements).
///
/// # Errors
/// A path that does not exist; a directory that cannot be read or holds no measurement.
pub fn expand_data_paths(paths: &[PathBuf]) -> anyhow::Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    for p in paths {
        if p.is_dir() {
            let mut found: Vec<PathBuf> = std::fs::read_dir(p)
                .map_err(|e| anyhow::anyhow!("{}: cannot read the directory: {e}", p.display()))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|f| {
                    f.is_file()
                        && f.extension().is_some_and(|e| {
                            e.eq_ignore_ascii_case("csv") || e.eq_ignore_ascii_case("mat")
                        })
                })
                .collect();
            if found.is_empty() {
                anyhow::bail!("{}: the directory holds no .csv or .mat file", p.display());
            }
            found.sort();
            files.extend(found);
        } else if p.exists() {
            files.push(p.clone());
        } else {
            anyhow::bail!("{}: no such file or directory", p.display());
        }
    }
    Ok(files)
}

/// The side file of the measurement file `data`: `<stem>.toml` beside it.
pub fn side_file_path(data: &Path) -> PathBuf {
    data.with_extension("toml")
}

/// Refuse a measurement output whose side file would destroy something: the output itself
/// (a `.toml` measurement), one of the command's `inputs` (a plant `run1.toml` beside
/// `-o run1.csv`), or an existing file that is not a side file. Call before computing.
///
/// # Errors
/// Each collision, naming both paths and what to do.
pub fn check_side_file_target(data: &Path, inputs: &[&Path]) -> anyhow::Result<()> {
    let side = side_file_path(data);
    if data
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("toml"))
    {
        anyhow::bail!(
            "{}: a measurement cannot be written as .toml (its side file would be the same file); use .csv or .mat",
            data.display()
        );
    }
    if let Some(input) = inputs.iter().find(|i| crate::files::same_file(&side, i)) {
        anyhow::bail!(
            "{}: the side file of {} would overwrite the input {}; choose another output name",
            side.display(),
            data.display(),
            input.display()
        );
    }
    if side.exists() {
        let is_side_file = std::fs::read_to_string(&side)
            .ok()
            .is_some_and(|t| toml::from_str::<SideFile>(&t).is_ok());
        if !is_side_file {
            anyhow::bail!(
                "{} exists and is not a measurement's side file; writing {} would replace it: choose another output name or move that file",
                side.display(),
                data.display()
            );
        }
    }
    crate::files::check_writable(&[data, &side])
}

/// Write a measurement's side file (`<stem>.toml` beside `data`), atomically.
///
/// # Errors
/// I/O errors, with the path.
pub fn write_side_file(data: &Path, side: &SideFile) -> anyhow::Result<()> {
    crate::files::commit(vec![stage_side_file(data, side)?])
}

/// The side file of `data` staged for [`crate::files::commit`].
///
/// # Errors
/// As [`write_side_file`].
pub fn stage_side_file(data: &Path, side: &SideFile) -> anyhow::Result<crate::files::Staged> {
    let text = toml::to_string_pretty(side)?;
    crate::files::Staged::with_bytes(&side_file_path(data), text.as_bytes())
}
