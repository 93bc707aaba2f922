//! DIDIM, the direct and inverse dynamic identification models (Gautier, Janot, Vandanjon,
//! *A New Closed-Loop Output Error Method for Parameter Identification of Robot Dynamics*,
//! IEEE TCST 21(2), 2013): the closed-loop output-error identification of a device measured
//! under its own controller, as IDIM-LS on simulated states.
//!
//! Iteration i: the plant with the values θ_{i−1} is simulated in closed loop under the
//! device's controller on each record's reference ([`crate::control::controller`]); the
//! inverse model's regressor W is built on the *simulated* positions (noise-free; filtered,
//! differentiated and decimated as IDIM-LS does, [`crate::identify::idim::observation`])
//! and the measured forces or torques y; θ_i = argmin ‖y − W θ‖² (on the base parameters
//! where W is rank-deficient). It is a Gauss–Newton iteration on the closed-loop force
//! error with W as the Jacobian's approximation; it stops when the relative force error of
//! the closed-loop simulation changes by less than [`DidimOptions::tolerance`] of itself.
//! The start θ_0 is the plant's values (IDIM-LS estimates or a CAD model).
//!
//! DIDIM's fixed point is not exactly the minimum of the closed-loop force error: the
//! regressor pairs each sample's held command with the states at the sample (a half-sample
//! offset of the zero-order hold) through the IDIM filter. Started at the truth on a Puma
//! arm under PD, it settles at 0.660 % where the truth gives 0.551 %
//! (docs/src/record/closed-loop.md). So once it converges, a closed-loop output-error
//! polish ([`polish`], Levenberg–Marquardt on the force error itself) takes the rest.

use crate::control::controller::{compare_closed_loop, ClosedLoopRecord, Controller};
use crate::identify::idim::{least_squares_base, observation, Fit, IdimOptions};
use crate::plant::Plant;
use anyhow::{bail, Result};

/// DIDIM's options; the defaults are the method's preset.
#[derive(Debug, Clone)]
pub struct DidimOptions {
    /// Largest number of iterations.
    pub max_iter: usize,
    /// Relative change of the force error (of itself) under which the iteration stops.
    pub tolerance: f64,
    /// How the regressor is prepared from the simulated positions.
    pub idim: IdimOptions,
    /// The parameters fitted (the regressor's columns by name); empty: all of them. The
    /// others are held at the plant's values, their columns' torque taken off the
    /// measured one.
    pub params: Vec<String>,
    /// Iterations of the closed-loop output-error polish after DIDIM converges
    /// ([`polish`]; 0: none).
    pub polish: usize,
}

impl Default for DidimOptions {
    /// Ten iterations (Gautier et al. report convergence in 2 to 5), a change of 1e-3 of
    /// the force error (on a Puma with noisy positions read by its controller the error
    /// wanders by 1e-3 of itself once converged), and IDIM-LS's preparation.
    fn default() -> Self {
        DidimOptions {
            max_iter: 10,
            tolerance: 1e-3,
            idim: IdimOptions::default(),
            params: Vec::new(),
            polish: 6,
        }
    }
}

/// One iteration's figures: the closed-loop errors (%) of the values it ends with.
#[derive(Debug, Clone, PartialEq)]
pub struct DidimIteration {
    /// The values (the regressor's columns).
    pub values: Vec<(String, f64)>,
    /// Relative force or torque error of the closed loop, all records and joints (%).
    pub force_error: f64,
    /// Relative velocity error likewise (%).
    pub velocity_error: f64,
}

/// What DIDIM returns.
#[derive(Debug, Clone)]
pub struct DidimResult {
    /// The plant with the last values.
    pub plant: Plant,
    /// The last least-squares fit (values, standard deviations, base parameters).
    pub fit: Fit,
    /// The start (index 0) and each iteration.
    pub iterations: Vec<DidimIteration>,
    /// Whether the force error's change fell under the tolerance.
    pub converged: bool,
}

/// The relative force and velocity errors (%) of `plant` in closed loop on every record:
/// 100 ‖y − ŷ‖ / ‖y‖ over all of them.
///
/// # Errors
/// As [`compare_closed_loop`].
pub fn closed_loop_errors(
    plant: &Plant,
    c: &Controller,
    records: &[ClosedLoopRecord],
) -> Result<(f64, f64)> {
    Ok(evaluate(plant, c, records)?.0)
}

/// The record `r` with the free joints' positions of the closed-loop `run` in place of
/// the measured ones (the measured forces or torques kept).
fn with_simulated_positions(
    r: &ClosedLoopRecord,
    run: &crate::control::controller::ClosedLoopRun,
    free: &[usize],
) -> crate::measurement::Measurement {
    let mut m = r.measurement.clone();
    for (a, &j) in free.iter().enumerate() {
        m.q[j] = run.q[a].clone();
    }
    m
}

/// One closed-loop simulation of `plant` per record, for both of its uses: the relative
/// force and velocity errors ([`closed_loop_errors`]) and the records with the simulated
/// positions ([`with_simulated_positions`]).
fn evaluate(
    plant: &Plant,
    c: &Controller,
    records: &[ClosedLoopRecord],
) -> Result<((f64, f64), Vec<crate::measurement::Measurement>)> {
    let conf = crate::util::configuration(plant.model, &c.configuration)?;
    let mut sums = [(0.0, 0.0); 2];
    let mut simulated = Vec::with_capacity(records.len());
    for r in records {
        let (cmp, run) = compare_closed_loop(plant, c, r)?;
        simulated.push(with_simulated_positions(r, &run, conf.free));
        for pair in &cmp {
            for (k, x) in pair.iter().enumerate() {
                sums[k].0 +=
                    x.y.iter()
                        .zip(&x.yhat)
                        .map(|(a, b)| (a - b).powi(2))
                        .sum::<f64>();
                sums[k].1 += x.y.iter().map(|a| a * a).sum::<f64>();
            }
        }
    }
    let rel = |(e, n): (f64, f64)| 100.0 * (e / n).sqrt();
    Ok(((rel(sums[0]), rel(sums[1])), simulated))
}

/// The inverse model's observation on the closed loop of `plant` under `c`: each record
/// with the simulated positions of the free joints in place of the measured ones, the
/// measured forces or torques kept ([`observation`]); and those records.
///
/// # Errors
/// As [`crate::control::controller::simulate_closed_loop`] and [`observation`].
pub fn closed_loop_observation(
    plant: &Plant,
    c: &Controller,
    records: &[ClosedLoopRecord],
    idim: &IdimOptions,
) -> Result<(
    crate::identify::idim::Observation,
    Vec<crate::measurement::Measurement>,
)> {
    let conf = crate::util::configuration(plant.model, &c.configuration)?;
    let simulated = records
        .iter()
        .map(|r| {
            let run = crate::control::controller::simulate_closed_loop(plant, c, r)?;
            Ok(with_simulated_positions(r, &run, conf.free))
        })
        .collect::<Result<Vec<_>>>()?;
    let obs = observation(plant, &c.configuration, &simulated, idim)?;
    Ok((obs, simulated))
}

/// The diagnosis in closed-loop space: the torque-space catalogue, built-ins and structure
/// search ([`crate::diagnose::torque::diagnosis_with`]) on the regressor of the simulated
/// closed loop and the measured forces or torques ([`closed_loop_observation`]): what the
/// plant, run as the device ran, leaves of the measured command; the user's `candidates`
/// ranked beside them (those not linear in their parameters left out, each with its
/// reason in the second value).
///
/// # Errors
/// As [`closed_loop_observation`] and the torque-space diagnosis.
pub fn diagnose_closed_loop(
    plant: &Plant,
    c: &Controller,
    records: &[ClosedLoopRecord],
    idim: &IdimOptions,
    candidates: &[crate::diagnose::candidates::UserCandidate],
) -> Result<(crate::diagnose::torque::TorqueDiagnosis, Vec<String>)> {
    let (obs, simulated) = closed_loop_observation(plant, c, records, idim)?;
    let (user, left_out) = crate::diagnose::candidates::columns(
        candidates,
        plant,
        &c.configuration,
        &simulated,
        idim,
    )?;
    Ok((
        crate::diagnose::torque::diagnosis_with(plant, &obs, &user)?,
        left_out,
    ))
}

/// The observation restricted to the columns `params`: the others' torque at their values
/// `value(name)` taken off y.
///
/// # Errors
/// A name that is not a column (the columns listed), a held column without a value.
fn held_out(
    obs: crate::identify::idim::Observation,
    params: &[String],
    value: &dyn Fn(&str) -> Option<f64>,
) -> Result<crate::identify::idim::Observation> {
    if let Some(p) = params.iter().find(|p| !obs.names.contains(p)) {
        bail!(
            "'{p}' is not a parameter of the inverse model (its parameters: {})",
            obs.names.join(", ")
        );
    }
    let mut y = obs.y.clone();
    let mut kept = Vec::new();
    for (c, name) in obs.names.iter().enumerate() {
        if params.contains(name) {
            kept.push(c);
            continue;
        }
        let v = value(name).ok_or_else(|| anyhow::anyhow!("'{name}' is held but has no value"))?;
        y -= obs.w.column(c) * v;
    }
    Ok(crate::identify::idim::Observation {
        names: kept.iter().map(|&c| obs.names[c].clone()).collect(),
        y,
        w: nalgebra::DMatrix::from_fn(obs.w.nrows(), kept.len(), |i, a| obs.w[(i, kept[a])]),
        rows: obs.rows,
    })
}

/// The closed-loop force or torque residuals of `plant` on `records` (measured less
/// simulated, every free joint, from the comparison's skip on), stacked.
fn force_residuals(
    plant: &Plant,
    c: &Controller,
    records: &[ClosedLoopRecord],
) -> Result<Vec<f64>> {
    let skip = c.compare.skip;
    let mut out = Vec::new();
    for r in records {
        let run = crate::control::controller::simulate_closed_loop(plant, c, r)?;
        for (y, yhat) in r.tau.iter().zip(&run.tau) {
            out.extend(y.iter().zip(yhat).skip(skip).map(|(a, b)| a - b));
        }
    }
    Ok(out)
}

/// The closed-loop output-error polish: Levenberg–Marquardt on the closed-loop force or
/// torque error itself over the parameters `names`, from `plant` (DIDIM's values), with a
/// forward-difference Jacobian (one closed-loop simulation per parameter, in parallel),
/// at most `max_iter` iterations; stops when a step lowers the cost by less than 1e-4 of
/// it. DIDIM's fixed point pairs each held command with the states at its sample through
/// the IDIM filter and sits above the minimum (on a Puma arm under PD, 0.660 % where the
/// truth gives 0.551 %); this step takes the rest. None when no step lowered the cost.
///
/// # Errors
/// A closed loop that diverges at the start.
pub fn polish(
    plant: &Plant,
    c: &Controller,
    records: &[ClosedLoopRecord],
    names: &[String],
    max_iter: usize,
) -> Result<Option<Plant>> {
    use rayon::prelude::*;
    let with = |p: &Plant, theta: &[f64]| -> Result<Plant> {
        let mut q = p.clone();
        q.set_barycentric_values(names, theta)?;
        Ok(q)
    };
    let mut theta: Vec<f64> = names
        .iter()
        .map(|n| plant.value(n))
        .collect::<Result<_>>()?;
    let mut current = plant.clone();
    let mut r = force_residuals(&current, c, records)?;
    let cost = |r: &[f64]| r.iter().map(|x| x * x).sum::<f64>();
    let mut f = cost(&r);
    let mut lambda = 1e-3;
    let mut improved = false;
    for _ in 0..max_iter {
        // J = ∂ŷ/∂θ = −∂r/∂θ, by forward differences.
        let columns: Vec<Option<Vec<f64>>> = (0..names.len())
            .into_par_iter()
            .map(|k| {
                let h = 1e-6 * theta[k].abs().max(1e-3);
                let mut t = theta.clone();
                t[k] += h;
                let rk = force_residuals(&with(&current, &t).ok()?, c, records).ok()?;
                Some(r.iter().zip(&rk).map(|(a, b)| (a - b) / h).collect())
            })
            .collect();
        let Some(columns) = columns.into_iter().collect::<Option<Vec<_>>>() else {
            break;
        };
        let p = names.len();
        let j = nalgebra::DMatrix::from_fn(r.len(), p, |i, k| columns[k][i]);
        let jtj = j.transpose() * &j;
        let jtr = j.transpose() * nalgebra::DVector::from_column_slice(&r);
        let mut stepped = false;
        for _ in 0..6 {
            let mut a = jtj.clone();
            for k in 0..p {
                a[(k, k)] += lambda * jtj[(k, k)].max(1e-12 * jtj.diagonal().max());
            }
            let Some(delta) = a.lu().solve(&jtr) else {
                lambda *= 4.0;
                continue;
            };
            let t: Vec<f64> = theta.iter().zip(delta.iter()).map(|(x, d)| x + d).collect();
            let Ok(candidate) = with(&current, &t) else {
                lambda *= 4.0;
                continue;
            };
            match force_residuals(&candidate, c, records) {
                Ok(rt) if cost(&rt) < f => {
                    let gain = (f - cost(&rt)) / f;
                    theta = t;
                    current = candidate;
                    f = cost(&rt);
                    r = rt;
                    lambda = (lambda / 3.0).max(1e-9);
                    stepped = true;
                    improved = true;
                    if gain < 1e-4 {
                        return Ok(Some(current));
                    }
                    break;
                }
                _ => lambda *= 4.0,
            }
        }
        if !stepped {
            break;
        }
    }
    Ok(improved.then_some(current))
}

/// DIDIM on `records` under controller `c` from the values of `plant` (module
/// documentation); `progress` gets each iteration as it ends.
///
/// # Errors
/// A plant whose effects are not linear in their parameters (the inverse model's), a
/// parameter without a starting value, a divergence of the closed loop, a least-squares
/// failure (named).
pub fn didim(
    plant: &Plant,
    c: &Controller,
    records: &[ClosedLoopRecord],
    options: &DidimOptions,
    progress: &dyn Fn(usize, &DidimIteration),
) -> Result<DidimResult> {
    if records.is_empty() {
        bail!("DIDIM: no records");
    }
    let m = plant.model;
    let conf = crate::util::configuration(m, &c.configuration)?;
    // DIDIM's Gauss–Newton is IDIM-LS on the simulated states: the effects linear in their
    // parameters. A rest angle or a Stribeck speed would be held where the plant puts it.
    if let Some(e) = plant
        .effects
        .iter()
        .find(|e| conf.free.contains(&e.joint) && !e.kind.is_linear())
    {
        bail!(
            "{}: effect '{}' on joint '{}' is not linear in its parameters, and DIDIM fits \
             only effects that are; fit it by `identify idim` (variable projection) or in \
             output space, or remove it",
            plant.name(),
            e.kind,
            m.joints[e.joint]
        );
    }
    let mut current = plant.clone();
    let columns = |p: &Plant| -> Result<Vec<String>> {
        let first = observation(
            p,
            &c.configuration,
            std::slice::from_ref(&records[0].measurement),
            &options.idim,
        )?;
        Ok(first.names)
    };
    let names = columns(&current)?;
    let values = |p: &Plant| -> Vec<(String, f64)> {
        names
            .iter()
            .map(|n| (n.clone(), p.value(n).unwrap_or(f64::NAN)))
            .collect()
    };
    // Each evaluation's simulation serves the next iteration's regressor too.
    let ((f0, v0), mut simulated) = evaluate(&current, c, records)?;
    let start = DidimIteration {
        values: values(&current),
        force_error: f0,
        velocity_error: v0,
    };
    progress(0, &start);
    let mut iterations = vec![start];
    let mut fit = None;
    let mut converged = false;
    for i in 1..=options.max_iter {
        let obs = observation(&current, &c.configuration, &simulated, &options.idim)?;
        let prior = current.values_with_barycentric()?;
        let obs = if options.params.is_empty() {
            obs
        } else {
            held_out(obs, &options.params, &|n| prior.get(n).copied())?
        };
        let locked_at = crate::identify::idim::locked_positions(&simulated);
        let f = least_squares_base(&obs, m, conf, &locked_at, &|n| prior.get(n).copied(), None)?;
        f.apply(&mut current)?;
        let ((force, velocity), next) = evaluate(&current, c, records)?;
        simulated = next;
        let it = DidimIteration {
            values: values(&current),
            force_error: force,
            velocity_error: velocity,
        };
        progress(i, &it);
        let before = iterations.last().map_or(f64::INFINITY, |x| x.force_error);
        iterations.push(it);
        fit = Some(f);
        if (before - force).abs() <= options.tolerance * force {
            converged = true;
            break;
        }
    }
    let Some(fit) = fit else {
        bail!("DIDIM: no iteration ran (max_iter = 0)");
    };
    if converged && options.polish > 0 {
        // The identifiable columns DIDIM fitted (a dependent one has no standard deviation).
        let names: Vec<String> = fit
            .names
            .iter()
            .zip(&fit.std)
            .filter(|(n, s)| {
                s.is_finite() && (options.params.is_empty() || options.params.contains(n))
            })
            .map(|(n, _)| n.clone())
            .collect();
        let polished = polish(&current, c, records, &names, options.polish)?;
        if let Some(p) = polished {
            let (force, velocity) = closed_loop_errors(&p, c, records)?;
            let last = iterations.last().map_or(f64::INFINITY, |x| x.force_error);
            if force < last {
                current = p;
                let it = DidimIteration {
                    values: values(&current),
                    force_error: force,
                    velocity_error: velocity,
                };
                progress(iterations.len(), &it);
                iterations.push(it);
            }
        }
    }
    Ok(DidimResult {
        plant: current,
        fit,
        iterations,
        converged,
    })
}
