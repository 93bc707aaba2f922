//! Refit after a change: fit chosen parameters of a plant by output error on the files of
//! one configuration and report the position error per joint before and after (the loop
//! of diagnosis: add the missing effect, refit, watch the error fall); on torque-measured
//! data, [`refit_torque`] refits by the inverse model (IDIM-LS on the base parameters) and
//! reports the torque residual. A [`HistoryEntry`] records each step in the plant file's
//! `[[history]]` list.

use crate::identify::output_error::{
    FitResult, JacobianMethod, JointFit, OutputErrorOptions, Problem, Record, TimeWeighting,
};
use crate::plant::{HistoryEntry, Plant};
use crate::simulation::{Hold, Integrator};
use anyhow::{anyhow, Result};

/// Settings of a refit.
#[derive(Debug, Clone)]
pub struct RefitOptions {
    /// Integration step (s).
    pub h: f64,
    /// Integration scheme.
    pub integrator: Integrator,
    /// Hold of the measured torques for every record; `None`: each record's own (its
    /// side file's, else zero-order).
    pub hold: Option<Hold>,
    /// Divergence bound on |q̇| (rad/s or m/s); `None`: from each record
    /// ([`crate::identify::output_error::OutputErrorOptions::max_speed`]).
    pub max_speed: Option<f64>,
    /// Samples skipped at the start of every file.
    pub skip: usize,
    /// Most Levenberg–Marquardt iterations.
    pub max_iter: usize,
    /// Starts (the plant's values, then random points in the bounds).
    pub starts: usize,
    /// Estimate the free joints' initial positions of each file
    /// ([`Problem::estimate_initial_positions`]): with the plant before the change for the
    /// "before" figures, with the changed plant for the fit.
    pub estimate_initial: bool,
    /// One more start from the plant's values, through the warm-ups of
    /// [`OutputErrorOptions::coupled`] (the torque balance at every sample, no simulation;
    /// then the prediction-error homotopy, the simulation pulled toward the measured
    /// positions less and less) before the whole files; it runs beside the growing horizons
    /// and the lower final cost wins. For a start far off: the output error of a long file
    /// has local minima the horizons end in.
    pub warm_ups: bool,
    /// How the fits' Jacobians are formed ([`OutputErrorOptions::jacobian`]; the default
    /// is the thesis preset's).
    pub jacobian: JacobianMethod,
}

impl Default for RefitOptions {
    fn default() -> Self {
        RefitOptions {
            h: 1.0 / 6000.0,
            integrator: Integrator::Rk4,
            hold: None,
            max_speed: None,
            skip: 0,
            max_iter: 50,
            starts: 1,
            estimate_initial: true,
            warm_ups: false,
            jacobian: OutputErrorOptions::thesis().jacobian,
        }
    }
}

impl RefitOptions {
    /// The output-error settings of these options: joints weighted 1, the first `skip`
    /// samples of each file left out, growing `horizons`.
    pub fn output_error(&self, horizons: Vec<f64>) -> OutputErrorOptions {
        let options = OutputErrorOptions {
            weighting: TimeWeighting::SkipTransient(self.skip),
            interest_weight: 1.0,
            h: self.h,
            integrator: self.integrator,
            hold: self.hold,
            max_speed: self.max_speed,
            max_iter: self.max_iter,
            starts: self.starts,
            horizons,
            jacobian: self.jacobian,
            ..OutputErrorOptions::thesis()
        };
        if self.warm_ups {
            options.with_coupled_warm_ups()
        } else {
            options
        }
    }
}

/// Result of [`refit`].
#[derive(Debug, Clone)]
pub struct Refit {
    /// The integration step's check against the data's noise (the step used).
    pub step: crate::accuracy::StepCheck,
    /// The plant with the fitted values.
    pub plant: Plant,
    /// RMS position error per free joint before (joint name, rad or m).
    pub before: Vec<(String, f64)>,
    /// … and after.
    pub after: Vec<(String, f64)>,
    /// Per-joint figures before (NRMSE fit %, max error).
    pub joints_before: Vec<JointFit>,
    /// The output-error fit (values, standard errors, correlations, per-joint figures after).
    pub fit: FitResult,
}

impl Refit {
    /// A history entry for this refit on `records`, described by `change`.
    pub fn history(&self, change: &str, records: &[Record]) -> HistoryEntry {
        entry(
            change,
            &self.fit.configuration,
            records.iter().map(|r| r.file.as_path()),
            self.fit
                .names
                .iter()
                .cloned()
                .zip(self.fit.fitted.iter().copied())
                .collect(),
            (&self.before, &self.after),
            None,
        )
    }
}

/// Fit `names` of `plant` (each needs a value and bounds) on `records` of configuration
/// `conf_name` by output error, all joints weighted 1; the "before" figures are those of
/// `before` (the plant before the change; `plant` itself for a plain refit). The step is
/// checked against the data's noise ([`crate::accuracy::check_step`]) on `before`, then
/// from that step on `plant`, and the finer is used ([`Refit::step`] lists both checks'
/// trials).
///
/// # Errors
/// Unknown configuration, no parameters, a parameter without value or bounds (named),
/// either plant cannot be simulated on a record.
pub fn refit(
    before: &Plant,
    plant: &Plant,
    conf_name: &str,
    records: &[Record],
    names: &[String],
    options: &RefitOptions,
) -> Result<Refit> {
    let conf = crate::util::configuration(plant.model, conf_name).map_err(|e| anyhow!("{e}"))?;
    if names.is_empty() {
        anyhow::bail!("configuration '{conf_name}': no parameters to refit");
    }
    let oe = options.output_error(vec![0.25, 1.0]);
    // The step, checked against the data's noise on the plant before the change, then from
    // there on the changed plant: an added effect can need a finer one (a friction that
    // switches over a narrow band of speed), and a fit at too coarse a step ends above the
    // noise with its values biased, and the next diagnosis finds the integration error.
    let (problem, step) = crate::accuracy::with_checked_step(
        Problem::new(plant, conf, names.to_vec(), records.to_vec(), &[], oe)?,
        before,
        options.skip,
    )
    .map_err(|e| anyhow!("the plant before the change: {e:#}"))?;
    let changed = if std::ptr::eq(before, plant) {
        // A plain refit: the plant was just checked.
        None
    } else {
        // Where the changed plant cannot be checked the fit reports what fails.
        crate::accuracy::with_checked_step(problem.clone(), plant, options.skip).ok()
    };
    let (problem, step) = match changed {
        Some((changed, check)) if check.h < step.h => {
            let mut tried = step.tried;
            tried.extend(check.tried);
            let merged = crate::accuracy::StepCheck {
                requested: step.requested,
                tried,
                ..check
            };
            (changed, merged)
        }
        _ => (problem, step),
    };
    // The initial positions are a nuisance of each model: estimated for the plant before
    // the change (its figures) and for the changed plant (the fit).
    let (before_problem, problem) = if options.estimate_initial {
        (
            problem
                .with_initial_positions_of(before)
                .map_err(|e| anyhow!("the plant before the change: {}", e))?,
            problem
                .with_initial_positions_of(plant)
                .map_err(|e| anyhow!("the changed plant: {}", e))?,
        )
    } else {
        (problem.clone(), problem)
    };
    let trajectories = before_problem
        .records
        .iter()
        .map(|r| before_problem.simulate(before, r))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| anyhow!("the plant before the change: {}", e))?;
    let joints_before = before_problem.joint_fits(&trajectories);
    let fit = problem.fit(&|_| {})?;
    let mut fitted = plant.clone();
    fit.apply(&mut fitted);
    let rms = |j: &[JointFit]| j.iter().map(|x| (x.joint.clone(), x.rms)).collect();
    Ok(Refit {
        step,
        plant: fitted,
        before: rms(&joints_before),
        after: rms(&fit.statistics.joints),
        joints_before,
        fit,
    })
}

/// A figure per joint: (joint name, value).
type JointFigures = [(String, f64)];

/// A history entry: `change` on configuration `configuration`, fitted on `files`, with the
/// fitted values and the RMS per joint before and after (`space`: None for position errors).
fn entry<'a>(
    change: &str,
    configuration: &str,
    files: impl Iterator<Item = &'a std::path::Path>,
    fitted: std::collections::BTreeMap<String, f64>,
    (before, after): (&JointFigures, &JointFigures),
    space: Option<&str>,
) -> HistoryEntry {
    HistoryEntry {
        change: change.to_string(),
        configuration: configuration.to_string(),
        files: files.map(|f| f.display().to_string()).collect(),
        fitted,
        rms_before: before.iter().cloned().collect(),
        rms_after: after.iter().cloned().collect(),
        space: space.map(str::to_string),
    }
}

/// Result of [`refit_torque`].
#[derive(Debug, Clone)]
pub struct TorqueRefit {
    /// The plant with the fitted values.
    pub plant: Plant,
    /// The least-squares fit (values, standard deviations, base parameters).
    pub fit: crate::identify::idim::Fit,
    /// RMS torque residual y − ŷ per free joint before (joint name, N·m or N).
    pub before: Vec<(String, f64)>,
    /// … and after.
    pub after: Vec<(String, f64)>,
    /// Relative error 100‖y − ŷ‖/‖y‖ (%) over all rows, before and after.
    pub relative: (f64, f64),
}

impl TorqueRefit {
    /// A history entry for this refit of configuration `conf_name` on `records`, described
    /// by `change` (space `torque`; the fitted values with a finite standard deviation: the
    /// base parameters' kept columns and the effects).
    pub fn history(
        &self,
        change: &str,
        conf_name: &str,
        records: &[crate::measurement::Measurement],
    ) -> HistoryEntry {
        entry(
            change,
            conf_name,
            records.iter().map(|r| r.file.as_path()),
            self.fit
                .names
                .iter()
                .zip(self.fit.theta.iter().zip(&self.fit.std))
                .filter(|(_, (_, s))| s.is_finite())
                .map(|(n, (v, _))| (n.clone(), *v))
                .collect(),
            (&self.before, &self.after),
            Some("torque"),
        )
    }
}

/// RMS of y − ŷ over each free joint's rows of `obs`, in the configuration's order.
fn rms_per_joint(
    plant: &Plant,
    obs: &crate::identify::idim::Observation,
    yhat: &nalgebra::DVector<f64>,
) -> Vec<(String, f64)> {
    crate::identify::idim::rows_by_joint(obs)
        .into_iter()
        .map(|(j, idx)| {
            let sum: f64 = idx.iter().map(|&i| (obs.y[i] - yhat[i]).powi(2)).sum();
            (
                plant.model.joints[j].to_string(),
                (sum / idx.len().max(1) as f64).sqrt(),
            )
        })
        .collect()
}

/// Refit `plant` in torque space: IDIM-LS ([`crate::identify::idim`]) of its rigid-body
/// parameters and its effects linear in their parameters on the torque-measured `records`
/// of configuration `conf_name`, on the base parameters where the regressor has dependent
/// columns ([`crate::identify::idim::least_squares_base`], grouped at the records' locked
/// positions; the dependent ones keep the plant's values). Every parameter of the
/// observation is refitted: in the inverse model that is one linear least squares, the
/// joint refit of the output space at the cost of one solve. The "before" figures are those
/// of `before` (the plant before the change) on the same records.
///
/// # Errors
/// Unknown configuration; an effect of `plant` on a free joint that is not linear in its
/// parameters (named: a spring's rest angle, Stribeck's vs, LuGre, a friction bias, a
/// coupling; these are refitted in output space); a parameter of `before` without value;
/// as [`crate::identify::idim::observation`] and
/// [`crate::identify::idim::least_squares_base`].
pub fn refit_torque(
    before: &Plant,
    plant: &Plant,
    conf_name: &str,
    records: &[crate::measurement::Measurement],
    options: &crate::identify::idim::IdimOptions,
) -> Result<TorqueRefit> {
    refit_torque_of(before, plant, conf_name, records, options, None)
}

/// [`refit_torque`] of the parameters `names` only, the others held at the plant's values
/// (their share of the torque is taken off the measured torque first): `lockstep refit` on
/// torque-measured data.
///
/// # Errors
/// A name that is not a parameter of the inverse model of this configuration (the ones it
/// has are listed); the named columns rank-deficient on these data (named); as
/// [`refit_torque`].
pub fn refit_torque_names(
    plant: &Plant,
    conf_name: &str,
    records: &[crate::measurement::Measurement],
    options: &crate::identify::idim::IdimOptions,
    names: &[String],
) -> Result<TorqueRefit> {
    refit_torque_of(plant, plant, conf_name, records, options, Some(names))
}

fn refit_torque_of(
    before: &Plant,
    plant: &Plant,
    conf_name: &str,
    records: &[crate::measurement::Measurement],
    options: &crate::identify::idim::IdimOptions,
    names: Option<&[String]>,
) -> Result<TorqueRefit> {
    use crate::identify::idim::{observation, predict, relative_error};
    // An unknown configuration is named before anything is read.
    crate::util::configuration(plant.model, conf_name).map_err(|e| anyhow!("{e}"))?;
    let obs_before = observation(before, conf_name, records, options)
        .map_err(|e| anyhow!("the plant before the change: {e:#}"))?;
    let yhat_before =
        predict(before, &obs_before).map_err(|e| anyhow!("the plant before the change: {e:#}"))?;
    let values = plant.values_with_barycentric()?;
    let locked_at = crate::identify::idim::locked_positions(records);
    let (obs, mut fit, mut fitted) = match names {
        None => {
            // Every parameter: the linear ones by least squares on the base parameters, a
            // spring's rest angle or a Stribeck speed by variable projection around them.
            let random = crate::identify::idim::random_motion_observation(
                plant, conf_name, &locked_at, options,
            )
            .map_err(|e| anyhow!("refitting in torque space: {e:#}"))?;
            let linear = |p: &Plant, obs: &crate::identify::idim::Observation| {
                crate::identify::idim::base_fit_with(
                    p,
                    obs,
                    conf_name,
                    &locked_at,
                    crate::identify::idim::Weighting::Ols,
                    &random,
                )
                .map(|(fit, _)| fit)
            };
            let s =
                crate::identify::idim::separable_fit(plant, conf_name, records, options, &linear)
                    .map_err(|e| anyhow!("refitting in torque space: {e:#}"))?;
            (s.observation, s.fit, s.plant)
        }
        Some(names) => {
            let obs = observation(plant, conf_name, records, options)
                .map_err(|e| anyhow!("refitting in torque space: {e:#}"))?;
            let fit = held_least_squares(&obs, &values, names, conf_name)
                .map_err(|e| anyhow!("refitting in torque space: {e:#}"))?;
            (obs, fit, plant.clone())
        }
    };
    fit.apply(&mut fitted)?;
    let yhat = predict(&fitted, &obs)?;
    // The fit's own figure is of the torque left to the fitted columns; report the whole.
    fit.relative_error = relative_error(&obs.y, &yhat);
    Ok(TorqueRefit {
        before: rms_per_joint(before, &obs_before, &yhat_before),
        after: rms_per_joint(&fitted, &obs, &yhat),
        relative: (
            relative_error(&obs_before.y, &yhat_before),
            relative_error(&obs.y, &yhat),
        ),
        plant: fitted,
        fit,
    })
}

/// Least squares of the columns `names` of `obs`, every other column held at its value in
/// `values` (y − W_held θ_held = W_names θ_names).
fn held_least_squares(
    obs: &crate::identify::idim::Observation,
    values: &std::collections::BTreeMap<String, f64>,
    names: &[String],
    conf_name: &str,
) -> Result<crate::identify::idim::Fit> {
    use nalgebra::{DMatrix, DVector};
    let mut fitted: Vec<usize> = Vec::new();
    for n in names {
        let c = obs.names.iter().position(|x| x == n).ok_or_else(|| {
            anyhow!(
                "--params: '{n}' is not a parameter of the inverse model of configuration '{conf_name}' (it has {})",
                obs.names.join(", ")
            )
        })?;
        if !fitted.contains(&c) {
            fitted.push(c);
        }
    }
    let mut y = obs.y.clone();
    for (c, n) in obs.names.iter().enumerate() {
        if !fitted.contains(&c) {
            let v = values
                .get(n)
                .copied()
                .ok_or_else(|| anyhow!("parameter '{n}' has no value to hold"))?;
            y -= obs.w.column(c) * v;
        }
    }
    let reduced = crate::identify::idim::Observation {
        names: fitted.iter().map(|&c| obs.names[c].clone()).collect(),
        y: DVector::from_iterator(y.len(), y.iter().copied()),
        w: DMatrix::from_fn(obs.w.nrows(), fitted.len(), |i, a| obs.w[(i, fitted[a])]),
        rows: obs.rows.clone(),
    };
    crate::identify::idim::least_squares(&reduced)
}
