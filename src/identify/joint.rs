//! The joint fit of a locking sequence: every parameter its steps fitted, on every step's
//! files at once, each file simulated in its own configuration.
//!
//! A locking sequence (thesis 4.2–4.4) fits each step with everything earlier held at its
//! fitted value. A held value that is off by more than its own standard error — the earlier
//! step determined it only given values fixed before it — is absorbed by the later step's
//! parameters, and that step's standard errors, conditional on the held values, do not
//! show it: on the Freedom 6S's k4 (the Freedom 6S status in the record) three values called identifiable were 5–93 %
//! off while k4's own data at the true held values called seven identifiable, all within
//! 0.83 %. The joint fit refines all of them together from where the sequence ended
//! (the whole files' optimiser of the preset on the stacked residuals; the sequence is its initialisation, as a
//! bundle adjustment follows incremental reconstruction), and its standard errors are those
//! of all the data, nothing held.
//!
//! Cost: Σ over steps of the cost (4.2)/(4.3) of that step's files with every free joint
//! weighted 1 (no joint of interest: every parameter is fitted here). The Jacobian column of
//! a parameter simulates only the configurations whose equations contain it (the
//! occurrence table, Figure 4.2; an effect where its joints are free).

use super::identifiability::Occurrence;
use super::output_error::{
    chain, difference_column, enters, feasible_bounds, fitted_companions, held_in,
    parameter_space_of, physical_derivatives, statistics_at, AtTheFit, FitResult, HeldColumns,
    JacobianPolicy, OutputErrorOptions, ParameterSpace, Problem, Progress, Record, Residuals,
    Stage, StageClock, StageContext, StageRecord, StageRun, StartSummary, Statistics, Stencil,
    TrialFailure, WarmUp, INITIAL_POSITION_ROUNDS, INITIAL_POSITION_SETTLED,
};
use crate::plant::Plant;
use crate::simulation::Trajectory;
use anyhow::{bail, Context, Result};
use generated::Configuration;
use rayon::prelude::*;
use rmpfit::{MPConfig, MPMaxFev};
use std::sync::atomic::AtomicUsize;
use std::time::Instant;

/// One configuration's files in the joint fit.
#[derive(Clone)]
struct Part {
    /// The configuration's problem: its parameters are those of the joint fit that enter
    /// its equations, its weights λ = 1 on every free joint.
    problem: Problem,
    /// Index in [`JointProblem::names`] of each of `problem.names`.
    index: Vec<usize>,
    /// Index of its first residual in the stacked vector.
    offset: usize,
}

impl Part {
    /// This part's parameters out of the joint fit's `p`.
    fn take(&self, p: &[f64]) -> Vec<f64> {
        self.index.iter().map(|&i| p[i]).collect()
    }

    fn len(&self) -> usize {
        self.problem.residual_count()
    }
}

/// The joint fit of several configurations' files ([module docs](self)).
#[derive(Clone)]
pub struct JointProblem {
    plant: Plant,
    /// Fitted parameter names.
    pub names: Vec<String>,
    /// Lower bounds (physical units, Fs ≥ Fc folded in).
    pub lower: Vec<f64>,
    /// Upper bounds.
    pub upper: Vec<f64>,
    pairs: Vec<(usize, usize)>,
    parts: Vec<Part>,
    m: usize,
    /// Rigid-body symbols held at the plant's values although they tie exactly with fitted
    /// ones (counted by the structural check, as [`Problem::with_held_ties`]).
    held_ties: Vec<String>,
    /// The model's occurrence table: which configurations a parameter enters.
    occ: Occurrence,
    options: OutputErrorOptions,
}

impl JointProblem {
    /// Set up the joint fit of `names` of `plant` on `files` (per configuration, its
    /// records), with the time weighting, integrator and stopping rules of `options` (its
    /// prior, carried prior and least change are not used); `held_ties` as
    /// [`Problem::with_held_ties`]; `occ` the model's occurrence table.
    ///
    /// # Errors
    /// A fitted parameter without value or bounds, or outside them; Fs ≥ Fc infeasible; a
    /// configuration without records; fewer residuals than parameters.
    pub fn new(
        plant: &Plant,
        names: Vec<String>,
        held_ties: Vec<String>,
        files: Vec<(&'static Configuration, Vec<Record>)>,
        options: &OutputErrorOptions,
        occ: &Occurrence,
    ) -> Result<JointProblem> {
        let (lower, upper, pairs) = feasible_bounds(plant, &names, "the joint fit")?;
        let options = OutputErrorOptions {
            prior: None,
            carried_prior: false,
            least_change: false,
            ..options.clone()
        };
        let mut parts = Vec::new();
        let mut m = 0;
        for (conf, records) in files {
            let index: Vec<usize> = (0..names.len())
                .filter(|&i| enters(plant, occ, conf, &names[i]))
                .collect();
            let sub: Vec<String> = index.iter().map(|&i| names[i].clone()).collect();
            let problem = Problem::new(plant, conf, sub, records, &[], options.clone())
                .with_context(|| format!("joint fit, configuration '{}'", conf.name))?
                .with_held_ties(
                    held_ties
                        .iter()
                        .filter(|n| occ.appears_in(n, conf.name))
                        .cloned()
                        .collect(),
                );
            let part = Part {
                problem,
                index,
                offset: m,
            };
            m += part.len();
            parts.push(part);
        }
        if m <= names.len() {
            bail!(
                "joint fit: {m} weighted residuals for {} parameters",
                names.len()
            );
        }
        Ok(JointProblem {
            plant: plant.clone(),
            names,
            lower,
            upper,
            pairs,
            parts,
            m,
            held_ties,
            occ: occ.clone(),
            options,
        })
    }

    /// The configurations, in order.
    pub fn configurations(&self) -> Vec<&'static str> {
        self.parts
            .iter()
            .map(|p| p.problem.configuration().name)
            .collect()
    }

    /// The fitted parameters that enter configuration `config` (its Jacobian columns are
    /// simulated there), in the order of [`JointProblem::names`]; empty for a
    /// configuration the fit does not have.
    pub fn entering(&self, config: &str) -> Vec<String> {
        self.parts
            .iter()
            .filter(|part| part.problem.configuration().name == config)
            .flat_map(|part| part.problem.names.clone())
            .collect()
    }

    /// Every configuration's trajectories at physical parameters `p` (configurations, and
    /// files within each, in parallel).
    ///
    /// # Errors
    /// The first failing file's simulation.
    fn trajectories(&self, p: &[f64]) -> Result<Vec<Vec<Trajectory>>, TrialFailure> {
        self.parts
            .par_iter()
            .map(|part| part.problem.trajectories(&part.take(p)))
            .collect()
    }

    /// The same fit with every file's initial positions estimated at `p`
    /// ([`Problem::estimate_initial_positions`]), and the largest move of an initial
    /// position in units of its joint's σ̂.
    ///
    /// # Errors
    /// A simulation fails (file named).
    fn with_initial_positions_at(&self, p: &[f64]) -> Result<(JointProblem, f64), TrialFailure> {
        let plant = self.plant_at(p);
        let moved: Vec<(Problem, f64)> = self
            .parts
            .par_iter()
            .map(|part| {
                let next = part.problem.with_initial_positions_of(&plant)?;
                let moved = part
                    .problem
                    .initial_position_move(&part.problem.records, &next.records);
                Ok((next, moved))
            })
            .collect::<Result<_, TrialFailure>>()?;
        let mut out = self.clone();
        let mut largest: f64 = 0.0;
        for (part, (next, d)) in out.parts.iter_mut().zip(moved) {
            part.problem = next;
            largest = largest.max(d);
        }
        Ok((out, largest))
    }

    /// Fit from the plant's values — meant for the values a locking sequence's steps
    /// fitted: the options' [`OutputErrorOptions::whole_files_optimiser`] on the whole
    /// files of every configuration, on the stopping rules of the options (the coupled
    /// preset's trust-region-reflective method: rmpfit's Levenberg–Marquardt, from the
    /// seed-7 sequence's k5 plant of the Freedom 6S, ended after one step, its first trust
    /// radius set by a step a bound had cut; the sensitivities record, stop 92). With
    /// [`OutputErrorOptions::estimate_initial_positions`], the initial positions estimated
    /// at the start (where that lowers the cost), then per round estimated again at the
    /// fitted values and the fit rerun from them; a round is kept only where its refit
    /// lowers the cost, and the rounds end once the positions settle, after
    /// [`INITIAL_POSITION_ROUNDS`] of them, or at the first round that does not lower the
    /// cost. No warm-up (horizons, predictor): near the steps' values there is no need, and
    /// far from them the fit can end in a local minimum where the parameters have absorbed
    /// the initial positions' error — from the truth of the Freedom 6S with Fc_q4 and Fc_q3
    /// 2 % (or 0.5 %) off the joint fit of k1 and k2 ended at 4.28e-4 with q5 of k2 at
    /// 2.4 σ̂ (at the truth: 4.03e-4, every joint within 1.03 σ̂); with qeq_q4 and G_q5_to_q4
    /// 2 % off at 2.0e-3, 3.6–13.7 σ̂, and growing horizons or the predictor's stages
    /// before it did not reach the floor either (2.9e-3; 4.28e-4).
    /// The result's `statistics` are those of all the files.
    ///
    /// # Errors
    /// The start cannot be simulated; the statistics cannot be formed.
    pub fn fit(&self, progress: &(dyn Fn(Progress) + Sync)) -> Result<FitResult> {
        let started = Instant::now();
        let p0: Vec<f64> = self
            .names
            .iter()
            .map(|n| self.plant.parameters[n])
            .collect();
        let mut notes = Vec::new();
        let mut current = self.clone();
        if self.options.estimate_initial_positions {
            let (next, moved) = self
                .with_initial_positions_at(&p0)
                .map_err(|e| anyhow::anyhow!("joint fit: the start cannot be simulated: {}", e))?;
            if next.cost(&p0) < current.cost(&p0) {
                notes.push(format!(
                    "initial positions estimated at the start (moved up to {moved:.2} σ̂)"
                ));
                current = next;
            }
        }
        let cost_before = current.cost(&p0);
        if !cost_before.is_finite() {
            bail!("joint fit: the start cannot be simulated");
        }
        let evaluations = AtomicUsize::new(0);
        let jacobians = AtomicUsize::new(0);
        let context = StageContext {
            start: 0,
            starts: 1,
            evaluations: &evaluations,
            jacobians: &jacobians,
            started,
            progress,
            jacobian: JacobianPolicy::of(&self.options),
        };
        let frozen = vec![false; self.names.len()];
        let mut u = self.to_scaled(&p0);
        let (mut iterations, mut diverged) = (0, 0);
        let config = MPConfig {
            xtol: self.options.xtol,
            ftol: self.options.ftol,
            gtol: 1e-10,
            max_iter: self.options.max_iter,
            max_fev: MPMaxFev::Limited(20 * self.options.max_iter.max(1)),
            ..MPConfig::new()
        };
        let mut run = |problem: &JointProblem, u: &mut Vec<f64>, round: usize| {
            let clock = StageClock::start(&context);
            let start_cost = problem.cost(&self.to_physical(u));
            let run = StageRun {
                problem,
                stage: Stage::Joint,
                frozen: &frozen,
                rules: config.clone(),
                context: &context,
                start_cost,
            };
            let optimiser = self.options.whole_files_optimiser;
            let outcome = optimiser.solver().minimise(&run, u);
            iterations += outcome.iterations;
            diverged += outcome.failures;
            let record = StageRecord::ran(format!("joint fit {round}"), optimiser, &outcome, None)
                .spent(&clock, &context);
            (
                format!("fit {round}: {}", outcome.status),
                outcome.stop,
                record,
            )
        };
        // Each round's record, with the whole files' cost at its result.
        let mut stages = Vec::new();
        let (note, stop, mut record) = run(&current, &mut u, 1);
        notes.push(note);
        // The whole files' cost of `current` at `u`, kept with them.
        let mut cost = current.cost(&self.to_physical(&u));
        record.whole_files_cost = Some(cost).filter(|c| c.is_finite());
        stages.push(record);
        if self.options.estimate_initial_positions && !stop {
            for round in 2..=INITIAL_POSITION_ROUNDS {
                let (next, moved) = match current.with_initial_positions_at(&self.to_physical(&u)) {
                    Ok(estimated) => estimated,
                    Err(why) => {
                        notes.push(format!("initial positions not re-estimated: {}", why));
                        break;
                    }
                };
                if moved <= INITIAL_POSITION_SETTLED {
                    notes.push(format!(
                        "initial positions settled (last move {moved:.2} σ̂)"
                    ));
                    break;
                }
                let mut tried = u.clone();
                let (note, stop, mut record) = run(&next, &mut tried, round);
                let tried_cost = next.cost(&self.to_physical(&tried));
                record.whole_files_cost = Some(tried_cost).filter(|c| c.is_finite());
                stages.push(record);
                if tried_cost.is_nan() || tried_cost >= cost {
                    notes.push(format!(
                        "initial positions moved up to {moved:.2} σ̂ and refitted: cost \
                         {tried_cost:.4e}, not below {cost:.4e}; kept the last"
                    ));
                    break;
                }
                notes.push(format!(
                    "initial positions moved up to {moved:.2} σ̂; {note}"
                ));
                (current, u, cost) = (next, tried, tried_cost);
                if stop {
                    break;
                }
                if round == INITIAL_POSITION_ROUNDS {
                    notes.push(format!(
                        "initial positions not settled after {round} fits (last move \
                         {moved:.2} σ̂)"
                    ));
                }
            }
        }
        let p = self.to_physical(&u);
        let statistics = current.statistics(&p)?;
        let status = notes.join("; ");
        Ok(FitResult {
            configuration: format!("joint ({})", self.configurations().join(", ")),
            cost_after: cost,
            statistics,
            starts: vec![StartSummary {
                start: 0,
                start_cost: cost_before,
                cost,
                iterations,
                status,
                diverged,
                warm_up: WarmUp::Sequence,
                stages,
            }],
            residuals: self.m,
            files: current
                .parts
                .iter()
                .flat_map(|part| part.problem.records.iter().map(|r| r.file.clone()))
                .collect(),
            ..FitResult::over(
                &self.space(),
                (p0, p),
                cost_before,
                (&evaluations, &jacobians, started),
            )
        })
    }

    /// Standard errors, correlations and fit figures at physical parameters `p` from all
    /// the configurations' files: the stacked Jacobian (central differences, step
    /// [`OutputErrorOptions::fd_step`] of the bound width; a column only where the
    /// parameter enters), each residual's variance from its configuration and joint
    /// (`Problem::residual_variances`), the structural ties that no configuration breaks
    /// (`fitted_companions`); fit figures per configuration and joint, named
    /// "k3 q2".
    ///
    /// # Errors
    /// A simulation at `p` fails; the barycentric parameters cannot be formed.
    pub fn statistics(&self, p: &[f64]) -> Result<Statistics> {
        let trajectories = self
            .trajectories(p)
            .map_err(|e| anyhow::anyhow!("at the fitted values: {}", e))?;
        let mut r = Vec::with_capacity(self.m);
        let mut variances = Vec::with_capacity(self.m);
        let mut joints = Vec::new();
        for (part, traj) in self.parts.iter().zip(&trajectories) {
            let rk = part.problem.residuals_of(traj);
            variances.extend(part.problem.residual_variances(&rk));
            r.extend(rk);
            let conf = part.problem.configuration().name;
            joints.extend(part.problem.joint_fits(traj).into_iter().map(|mut j| {
                j.joint = format!("{conf} {}", j.joint);
                j
            }));
        }
        // The plant-gain scale across every configuration's free joints (an exact symmetry
        // of all the files where every gain is fitted and nothing else of the family held).
        let mut free: Vec<usize> = self
            .parts
            .iter()
            .flat_map(|part| part.problem.configuration().free.iter().copied())
            .collect();
        free.sort_unstable();
        free.dedup();
        let at = AtTheFit {
            variances,
            r: &r,
            held: self.held_columns(p, &r),
            free: &free,
            only_with: self.structural_companions(p)?,
            joints,
        };
        statistics_at(self, p, at, |ties| self.stacked_columns(p, ties, &r))
    }

    /// The held values entering any configuration (those with a recorded standard error,
    /// with their stacked columns ∂r/∂h, zero where a configuration does not contain
    /// them; the others listed as exact) at physical parameters `p`; `r` the stacked
    /// residuals there.
    fn held_columns(&self, p: &[f64], r: &[f64]) -> HeldColumns {
        let confs: Vec<&Configuration> = self
            .parts
            .iter()
            .map(|part| part.problem.configuration())
            .collect();
        let mut held = held_in(&self.plant, &self.names, &self.held_ties, &self.occ, &confs);
        held.set_columns(self.stacked_columns(p, &held.column_names(), r));
        held
    }

    /// ∂r/∂h of the stacked residuals `r` (at physical parameters `p`) for every held value
    /// named in `names`, each configuration's block by [`Problem::held_columns`], zero where
    /// the value does not enter the configuration.
    fn stacked_columns(&self, p: &[f64], names: &[String], r: &[f64]) -> Vec<Vec<f64>> {
        let mut cols = vec![vec![0.0; self.m]; names.len()];
        for part in &self.parts {
            let conf = part.problem.configuration();
            let (here, these): (Vec<usize>, Vec<String>) = names
                .iter()
                .enumerate()
                .filter(|(_, n)| enters(&self.plant, &self.occ, conf, n))
                .map(|(k, n)| (k, n.clone()))
                .unzip();
            let range = part.offset..part.offset + part.len();
            let blocks = part
                .problem
                .held_columns(&part.take(p), &these, &r[range.clone()]);
            for (&k, block) in here.iter().zip(blocks) {
                cols[k][range.clone()].copy_from_slice(&block);
            }
        }
        cols
    }

    /// For every fitted parameter, the other rigid-body symbols (fitted, or held along
    /// ties) it trades with exactly in every configuration at once, each with its locked
    /// joints where its files hold them ([`fitted_companions`]).
    ///
    /// # Errors
    /// The plant's barycentric parameters cannot be formed.
    fn structural_companions(&self, p: &[f64]) -> Result<Vec<Vec<String>>> {
        let locked_at: Vec<Vec<Vec<f64>>> = self
            .parts
            .iter()
            .map(|part| part.problem.locked_at())
            .collect();
        let places: Vec<(&Configuration, &[Vec<f64>])> = self
            .parts
            .iter()
            .zip(&locked_at)
            .map(|(part, at)| (part.problem.configuration(), at.as_slice()))
            .collect();
        fitted_companions(
            &self.plant_at(p),
            &self.names,
            (&self.lower, &self.upper),
            &self.held_ties,
            &places,
        )
    }
}

impl Residuals for JointProblem {
    fn space(&self) -> ParameterSpace<'_> {
        parameter_space_of!(self)
    }

    fn residual_count(&self) -> usize {
        self.m
    }

    /// The stacked residuals (configurations in order) at physical parameters `p`.
    ///
    /// # Errors
    /// The first failing file's simulation.
    fn residuals(&self, p: &[f64]) -> Result<Vec<f64>, TrialFailure> {
        let blocks: Vec<Vec<f64>> = self
            .parts
            .par_iter()
            .map(|part| part.problem.residuals(&part.take(p)))
            .collect::<Result<_, _>>()?;
        Ok(blocks.concat())
    }

    /// A configuration whose fit takes sensitivities (`Problem::sensitivities_apply`)
    /// gives its rows of every column from one augmented simulation per file; otherwise
    /// column i simulates only the configurations that parameter i enters, by finite
    /// differences. The other rows are zero. The configurations, and the (parameter,
    /// configuration) pairs of the differences, run in parallel.
    fn jacobian_columns(&self, stencil: &Stencil) -> Vec<Vec<f64>> {
        let Stencil {
            x,
            r0,
            steps,
            p_of,
            central,
        } = *stencil;
        let p = p_of(x);
        let by_sensitivities: Vec<Option<Vec<Vec<f64>>>> = self
            .parts
            .par_iter()
            .map(|part| {
                let pr = &part.problem;
                pr.sensitivities_apply()
                    .then(|| pr.value_sensitivities(&pr.plant_at(&part.take(&p)), &pr.names))
                    .flatten()
            })
            .collect();
        let mut cols = vec![vec![0.0; self.m]; x.len()];
        if by_sensitivities.iter().any(Option::is_some) {
            let dp_dx = physical_derivatives(stencil, &p);
            for (part, dr_dp) in self.parts.iter().zip(&by_sensitivities) {
                let Some(dr_dp) = dr_dp else { continue };
                let column_of = |k: usize| part.index.iter().position(|&i| i == k);
                let block = chain(&dp_dx, dr_dp, column_of, part.len());
                for (col, b) in cols.iter_mut().zip(block) {
                    col[part.offset..part.offset + part.len()].copy_from_slice(&b);
                }
            }
        }
        let by_differences: Vec<bool> = by_sensitivities.iter().map(Option::is_none).collect();
        let by_differences = &by_differences;
        let tasks: Vec<(usize, usize)> = (0..x.len())
            .flat_map(|i| {
                self.parts
                    .iter()
                    .enumerate()
                    .filter(move |(k, part)| by_differences[*k] && part.index.contains(&i))
                    .map(move |(k, _)| (i, k))
            })
            .collect();
        let blocks: Vec<Vec<f64>> = tasks
            .par_iter()
            .map(|&(i, k)| {
                let part = &self.parts[k];
                let at = |s: f64| {
                    let mut xi = x.to_vec();
                    xi[i] += s;
                    part.problem.residuals(&part.take(&p_of(&xi)))
                };
                let r0k = &r0[part.offset..part.offset + part.len()];
                difference_column(&at, r0k, steps[i], central)
            })
            .collect();
        for (&(i, k), block) in tasks.iter().zip(blocks) {
            let part = &self.parts[k];
            cols[i][part.offset..part.offset + part.len()].copy_from_slice(&block);
        }
        cols
    }

    /// 1 where every configuration's rows are taken by sensitivities (one augmented
    /// simulation of every file), else `n` (finite differences for some).
    fn jacobian_simulations(&self, n: usize) -> usize {
        if self
            .parts
            .iter()
            .all(|part| part.problem.sensitivities_apply())
        {
            1
        } else {
            n
        }
    }
}
