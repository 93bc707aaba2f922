//! Model versus measurement in torque space (inverse model): the measured torque y against
//! the model's W θ on the same prepared (filtered, differentiated, decimated) data, with the
//! residual e = y − Wθ, error figures, a residual CSV and plots.

use crate::identify::idim::{observation, predict, IdimOptions, Observation};
use crate::measurement::Measurement;
use crate::plant::Plant;
use crate::report::plot::{figure, Panel, Series, Style};
use crate::util::write_atomic_with;
use anyhow::Result;
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
    let mut out = Vec::new();
    for j in joints {
        let idx: Vec<usize> = (0..obs.rows.len())
            .filter(|&i| obs.rows[i].joint == j)
            .collect();
        let y: Vec<f64> = idx.iter().map(|&i| obs.y[i]).collect();
        let yh: Vec<f64> = idx.iter().map(|&i| yhat[i]).collect();
        let t: Vec<f64> = idx.iter().map(|&i| obs.rows[i].t).collect();
        let qd: Vec<f64> = idx.iter().map(|&i| obs.rows[i].qd).collect();
        let q: Vec<f64> = idx.iter().map(|&i| obs.rows[i].q).collect();
        let e: Vec<f64> = y.iter().zip(&yh).map(|(a, b)| a - b).collect();
        let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
        let imax = (0..e.len())
            .max_by(|&a, &b| e[a].abs().total_cmp(&e[b].abs()))
            .unwrap_or(0);
        out.push(Comparison {
            file: file.to_path_buf(),
            joint: plant.model.joints[j].to_string(),
            relative_error: 100.0 * norm(&e) / norm(&y),
            rmse: norm(&e) / (e.len() as f64).sqrt(),
            max_error: (e[imax], t[imax], qd[imax]),
            sign_step: sign_fit(&e, &qd),
            t,
            q,
            qd,
            y,
            yhat: yh,
        });
    }
    Ok(out)
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
    match a.svd(true, true).solve(&y, 1e-12) {
        Ok(x) => (x[0], x[1]),
        Err(_) => (0.0, 0.0),
    }
}

/// Write the residual time series: `t, q, qd, y, yhat, residual`.
///
/// # Errors
/// I/O failure (path named); nothing is left half-written.
pub fn write_residual_csv(path: &Path, c: &Comparison) -> Result<()> {
    write_atomic_with(path, |w| {
        writeln!(w, "t,q,qd,y,yhat,residual")?;
        for i in 0..c.t.len() {
            writeln!(
                w,
                "{},{},{},{},{},{}",
                c.t[i],
                c.q[i],
                c.qd[i],
                c.y[i],
                c.yhat[i],
                c.y[i] - c.yhat[i]
            )?;
        }
        Ok(())
    })
}

/// Plot measured vs model, residual vs time, residual vs velocity (`<stem>.svg`, `.png`).
///
/// # Errors
/// As [`figure`].
pub fn plot(stem: &Path, c: &Comparison, title: &str) -> Result<[PathBuf; 2]> {
    let e = c.residual();
    let unit = "N·m or N";
    figure(
        stem,
        &[
            Panel {
                title: format!(
                    "{title}: measured vs model ({}, error {:.2} %)",
                    c.joint, c.relative_error
                ),
                x_label: "t (s)".into(),
                y_label: format!("torque ({unit})"),
                series: vec![
                    Series {
                        name: "measured".into(),
                        x: c.t.clone(),
                        y: c.y.clone(),
                        style: Style::Line,
                    },
                    Series {
                        name: "model".into(),
                        x: c.t.clone(),
                        y: c.yhat.clone(),
                        style: Style::Line,
                    },
                ],
            },
            Panel {
                title: "residual vs time".into(),
                x_label: "t (s)".into(),
                y_label: format!("residual ({unit})"),
                series: vec![Series {
                    name: "y − ŷ".into(),
                    x: c.t.clone(),
                    y: e.clone(),
                    style: Style::Line,
                }],
            },
            Panel {
                title: "residual vs velocity".into(),
                x_label: "velocity (rad/s or m/s)".into(),
                y_label: format!("residual ({unit})"),
                series: vec![Series {
                    name: "y − ŷ".into(),
                    x: c.qd.clone(),
                    y: e,
                    style: Style::Points,
                }],
            },
        ],
        1000,
    )
}
