//! Refit after a change: fit chosen parameters of a plant by output error on the files of
//! one configuration and report the position error per joint before and after (the loop
//! of diagnosis: add the missing effect, refit, watch the error fall). A [`HistoryEntry`]
//! records each step in the plant file's `[[history]]` list.

use crate::identify::output_error::{
    FitResult, JointFit, OutputErrorOptions, Problem, Record, TimeWeighting,
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
    /// Divergence bound on |q̇| (rad/s or m/s).
    pub max_speed: f64,
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
}

impl Default for RefitOptions {
    fn default() -> Self {
        RefitOptions {
            h: 1.0 / 6000.0,
            integrator: Integrator::Rk4,
            hold: None,
            max_speed: 100.0,
            skip: 0,
            max_iter: 50,
            starts: 1,
            estimate_initial: true,
            warm_ups: false,
        }
    }
}

impl RefitOptions {
    /// The output-error settings of these options: joints weighted 1, the first `skip`
    /// samples of each file left out, growing `horizons`.
    pub fn output_error(&self, horizons: Vec<f64>) -> OutputErrorOptions {
        let warm = if self.warm_ups {
            OutputErrorOptions::coupled()
        } else {
            OutputErrorOptions::thesis()
        };
        OutputErrorOptions {
            equation_error: warm.equation_error,
            predictor: warm.predictor,
            predictor_step: warm.predictor_step,
            predictor_optimiser: warm.predictor_optimiser,
            weighting: TimeWeighting::SkipTransient(self.skip),
            interest_weight: 1.0,
            h: self.h,
            integrator: self.integrator,
            hold: self.hold,
            max_speed: self.max_speed,
            max_iter: self.max_iter,
            starts: self.starts,
            horizons,
            ..OutputErrorOptions::thesis()
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
        HistoryEntry {
            change: change.to_string(),
            configuration: self.fit.configuration.clone(),
            files: records
                .iter()
                .map(|r| r.file.display().to_string())
                .collect(),
            fitted: self
                .fit
                .names
                .iter()
                .cloned()
                .zip(self.fit.fitted.iter().copied())
                .collect(),
            rms_before: self.before.iter().cloned().collect(),
            rms_after: self.after.iter().cloned().collect(),
        }
    }
}

/// Fit `names` of `plant` (each needs a value and bounds) on `records` of configuration
/// `conf_name` by output error, all joints weighted 1; the "before" figures are those of
/// `before` (the plant before the change; `plant` itself for a plain refit).
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
    // The step, checked against the data's noise on the plant before the change.
    let (problem, step) = crate::accuracy::with_checked_step(
        Problem::new(plant, conf, names.to_vec(), records.to_vec(), &[], oe)?,
        before,
        options.skip,
    )
    .map_err(|e| anyhow!("the plant before the change: {e:#}"))?;
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
