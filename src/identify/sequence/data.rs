//! The measurement files of a locking sequence: which configuration each file belongs to
//! (its side file, else its name's prefix), and each read as a [`Record`] of its
//! configuration, with the locked joints checked.

use super::*;

/// A measurement file found for a sequence, with the configuration it was taken in.
#[derive(Debug, Clone)]
pub struct DataFile {
    /// Path.
    pub path: PathBuf,
    /// Configuration (from the side file, else the file name's prefix before `_`).
    pub config: String,
}

/// Configuration `config` of `model` and the records of those `files` measured in it
/// ([`read_record`], locked joints within `locked_tolerance`); empty when none is; and what
/// reading did to their rows ([`read_record_with_notes`]).
///
/// # Errors
/// An unknown configuration; a file that cannot be read or does not match it.
pub(super) fn records_of(
    files: &[DataFile],
    model: &'static Model,
    config: &str,
    locked_tolerance: f64,
) -> Result<(&'static Configuration, Vec<Record>, Vec<String>)> {
    let conf = crate::util::configuration(model, config)?;
    let read = files
        .iter()
        .filter(|f| f.config == config)
        .map(|f| read_record_with_notes(&f.path, model, conf, locked_tolerance))
        .collect::<Result<Vec<_>>>()?;
    let (recs, notes): (Vec<Record>, Vec<Vec<String>>) = read.into_iter().unzip();
    Ok((conf, recs, notes.concat()))
}

/// Measurement files (`*.csv`, `*.mat`) given directly or found in directories, with
/// their configurations; files that cannot be used are returned with the reason.
///
/// # Errors
/// A path that does not exist, an unreadable directory or side file.
pub fn discover(paths: &[PathBuf], model: &Model) -> Result<(Vec<DataFile>, Vec<String>)> {
    let files = crate::measurement::expand_data_paths(paths)?;
    let mut out = Vec::new();
    let mut ignored = Vec::new();
    for f in files {
        let side = crate::measurement::read_side_file(&f)?;
        let stem = f
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let config = side.configuration.clone().or_else(|| {
            let prefix = stem.split(['_', '-', '.']).next().unwrap_or("");
            model
                .configurations
                .iter()
                .find(|c| c.name == prefix)
                .map(|c| c.name.to_string())
        });
        match config {
            Some(c) => out.push(DataFile { path: f, config: c }),
            None => ignored.push(format!(
                "{}: no configuration (name it in the side file {}, or start the file name with the configuration, e.g. k1_run1.csv)",
                f.display(),
                f.with_extension("toml").display()
            )),
        }
    }
    Ok((out, ignored))
}

/// Read file `path` as a record of configuration `conf`: `t`, `tau{j}` and `q{j}` of every
/// free joint; a locked joint's `q{j}`, where present, must stay within `tolerance` of its
/// mean (its position is the side file's `locked` value, else that mean, else 0).
///
/// # Errors
/// Unreadable file, a free joint without torque or position column, a locked joint that
/// moves, bad sampling (all naming the file and column).
pub fn read_record(
    path: &Path,
    model: &Model,
    conf: &Configuration,
    tolerance: f64,
) -> Result<Record> {
    Ok(read_record_with_notes(path, model, conf, tolerance)?.0)
}

/// [`read_record`], with what reading did to the file's rows (repeats dropped, stale rows,
/// uneven times resampled: [`crate::measurement::sampling`]), each note naming the file.
///
/// # Errors
/// As [`read_record`].
pub fn read_record_with_notes(
    path: &Path,
    model: &Model,
    conf: &Configuration,
    tolerance: f64,
) -> Result<(Record, Vec<String>)> {
    let table = Table::read(path)?;
    let notes = table.notes.clone();
    let t = table.need("t")?;
    let dt = check_sampling(path, &t)?;
    let nj = model.joints.len();
    let mut q_all = vec![0.0; nj];
    let mut tau = Vec::new();
    let mut q = Vec::new();
    for j in 0..nj {
        let name = model.joints[j];
        if conf.free.contains(&j) {
            let qj = table.joint_column(model.joints, "q", j)?.with_context(|| {
                format!(
                    "{}: joint '{name}' is free in configuration '{}' but the file has no position column 'q_{name}'",
                    path.display(),
                    conf.name
                )
            })?;
            let tj = table.joint_column(model.joints, "tau", j)?.with_context(|| {
                format!(
                    "{}: joint '{name}' is free in configuration '{}' but the file has no torque column 'tau_{name}'",
                    path.display(),
                    conf.name
                )
            })?;
            q_all[j] = qj[0];
            q.push(qj);
            tau.push(tj);
        } else {
            let measured = table.joint_column(model.joints, "q", j)?;
            if let Some(qj) = &measured {
                let (lo, hi) = qj
                    .iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
                        (a.min(x), b.max(x))
                    });
                if hi - lo > tolerance {
                    bail!(
                        "{}: joint '{name}' is locked in configuration '{}' but moves by {:.4} rad (tolerance {tolerance} rad): is the file from another configuration?",
                        path.display(),
                        conf.name,
                        hi - lo
                    );
                }
            }
            q_all[j] = match table.side.locked.get(name) {
                Some(&v) => v,
                None => measured
                    .as_ref()
                    .map(|v| v.iter().sum::<f64>() / v.len() as f64)
                    .unwrap_or(0.0),
            };
        }
    }
    let record = Record {
        file: path.to_path_buf(),
        t,
        dt,
        tau,
        q,
        q_all,
        qd0: None,
        hold: table.side.hold.unwrap_or_default(),
    };
    Ok((record, notes))
}
