//! Measurement files (DESIGN.md §5): CSV with a header; `t` (s), then per joint `j`
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
    #[error("{file}: missing column '{column}' (the header has: {available})")]
    MissingColumn {
        /// File.
        file: PathBuf,
        /// Column name looked for.
        column: String,
        /// Header names present.
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

/// Column mapping from the side file.
#[derive(Debug, Default, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SideFile {
    /// Free text.
    #[serde(default)]
    pub description: String,
    /// Where the data come from.
    #[serde(default)]
    pub source: String,
    /// Standard name → column name in the CSV.
    #[serde(default)]
    pub columns: BTreeMap<String, String>,
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
}

/// The minimum number of samples a record must have.
pub const MIN_SAMPLES: usize = 10;

impl Measurement {
    /// Sampling period (s).
    pub fn dt(&self) -> f64 {
        (self.t[self.t.len() - 1] - self.t[0]) / (self.t.len() - 1) as f64
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// True when there are no samples (never for a loaded record).
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// Read a CSV record with `joints` joints.
    ///
    /// # Errors
    /// [`DataError`]: missing or unreadable file, malformed side file, missing column,
    /// non-numeric or non-finite cell, fewer than [`MIN_SAMPLES`] rows, time not strictly
    /// increasing or not evenly spaced (relative deviation of a step above 1e-3).
    pub fn read_csv(path: &Path, joints: usize) -> Result<Measurement, DataError> {
        let side = read_side_file(path)?;
        let col = |std: &str| -> String {
            side.columns
                .get(std)
                .cloned()
                .unwrap_or_else(|| std.to_string())
        };
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
        let find = |name: &str| headers.iter().position(|h| h == name);
        let need = |name: String| -> Result<usize, DataError> {
            find(&name).ok_or_else(|| DataError::MissingColumn {
                file: file.clone(),
                column: name,
                available: headers.iter().collect::<Vec<_>>().join(", "),
            })
        };
        let ti = need(col("t"))?;
        let mut tau_i = Vec::new();
        let mut q_i = Vec::new();
        let mut qd_i = Vec::new();
        let mut tm_i = Vec::new();
        for j in 0..joints {
            tau_i.push(need(col(&format!("tau{j}")))?);
            q_i.push(need(col(&format!("q{j}")))?);
            qd_i.push(find(&col(&format!("qd{j}"))));
            tm_i.push(find(&col(&format!("tauM{j}"))));
        }
        let mut t = Vec::new();
        let mut tau = vec![Vec::new(); joints];
        let mut q = vec![Vec::new(); joints];
        let mut qd: Vec<Option<Vec<f64>>> = qd_i.iter().map(|i| i.map(|_| Vec::new())).collect();
        let mut tau_m: Vec<Option<Vec<f64>>> = tm_i.iter().map(|i| i.map(|_| Vec::new())).collect();
        for (r, rec) in rdr.records().enumerate() {
            let row = r + 2;
            let rec = rec.map_err(|e| DataError::Record {
                file: file.clone(),
                reason: format!("row {row}: {e}"),
            })?;
            let cell = |i: usize| -> Result<f64, DataError> {
                let text = rec.get(i).unwrap_or("");
                let bad = |reason: String| DataError::BadCell {
                    file: file.clone(),
                    row,
                    column: headers.get(i).unwrap_or("?").to_string(),
                    reason,
                };
                let v: f64 = text
                    .parse()
                    .map_err(|_| bad(format!("'{text}' is not a number")))?;
                if !v.is_finite() {
                    return Err(bad(format!("'{text}' is not a finite number")));
                }
                Ok(v)
            };
            t.push(cell(ti)?);
            for j in 0..joints {
                tau[j].push(cell(tau_i[j])?);
                q[j].push(cell(q_i[j])?);
                if let (Some(i), Some(v)) = (qd_i[j], qd[j].as_mut()) {
                    v.push(cell(i)?);
                }
                if let (Some(i), Some(v)) = (tm_i[j], tau_m[j].as_mut()) {
                    v.push(cell(i)?);
                }
            }
        }
        let m = Measurement {
            file,
            t,
            tau,
            q,
            qd,
            tau_m,
        };
        m.check_time()?;
        Ok(m)
    }

    fn check_time(&self) -> Result<(), DataError> {
        let err = |reason: String| DataError::Record {
            file: self.file.clone(),
            reason,
        };
        if self.t.len() < MIN_SAMPLES {
            return Err(err(format!(
                "too few samples: {} rows, at least {MIN_SAMPLES} needed",
                self.t.len()
            )));
        }
        let dt = self.dt();
        if dt <= 0.0 {
            return Err(err("time does not increase".into()));
        }
        for k in 1..self.t.len() {
            let step = self.t[k] - self.t[k - 1];
            if step <= 0.0 {
                return Err(err(format!(
                    "row {}: time {} s is not after the previous {} s (time must increase)",
                    k + 2,
                    self.t[k],
                    self.t[k - 1]
                )));
            }
            if (step - dt).abs() > 1e-3 * dt {
                return Err(err(format!(
                    "row {}: uneven sampling, step {step:.6e} s where the mean step is {dt:.6e} s",
                    k + 2
                )));
            }
        }
        Ok(())
    }
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
    let side = path.with_extension("toml");
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
