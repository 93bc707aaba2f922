//! Fitting one configuration: the starts (the plant's values, random points, the
//! Stribeck re-seed), each through its warm-up stages to the whole files, and the final
//! stage's fallback (thesis 4.4; the stages of [`super::Stage`]).

use super::*;

/// Where the final stage starts: the lowest-cost entry of `simulable` (name, whole files'
/// cost (4.2)/(4.3), scaled parameters: the start first where the whole files can be
/// simulated from it, then each warm-up result they can be simulated from, in order; `u`
/// is left as it is when there is none), into `u`, the warm-ups' end
/// whose whole files' cost is `cost_u` (infinite where they cannot be simulated from it).
/// The final stage minimises exactly that cost, so the warm-ups only choose where it
/// starts. Two ways the warm-ups' end is not the best start:
/// - a predictor's output injection holds a simulation on the data that runs away without
///   it, so its stages can end where the whole files cannot be simulated, and the final
///   stage would have no start;
/// - a predictor stage can raise the whole files' cost, and a final stage started there
///   can stop in a worse minimum than one started from an earlier stage.
///
/// (Both were met on the Freedom 6S; the identification record has the runs.)
///
/// Returns the report's note when the start is not the warm-ups' end.
pub(super) fn start_final_stage(
    u: &mut [f64],
    simulable: &[(String, f64, Vec<f64>)],
    cost_u: f64,
) -> Option<String> {
    let (name, cost, best) = simulable.iter().min_by(|a, b| a.1.total_cmp(&b.1))?;
    if *cost >= cost_u {
        return None;
    }
    u.copy_from_slice(best);
    Some(if cost_u.is_finite() {
        format!(
            "the final stage starts from {name}'s result (whole files' cost {cost:.5e}), lower than the warm-ups' end ({cost_u:.5e})"
        )
    } else {
        format!(
            "the warm-ups ended where the whole files cannot be simulated: the final stage starts from the lowest-cost result they could be simulated from, {name}'s (cost {cost:.5e})"
        )
    })
}

/// The bandwidth (rad/s) through which a predictor stage at `omega` that ended at `cost`
/// is rerun ([`Problem::run_predictor_refined`]): the geometric mean of `omega` and the
/// previous predictor stage's bandwidth, where the stage ended above
/// [`PREDICTOR_REFINE_FACTOR`] × the larger of `floor` (the noise floor's cost) and the
/// previous stage's end (`previous`: its ω, its cost). `None` for the first predictor
/// stage, a stage at a bandwidth not below the previous one's, or one that kept to the
/// path.
pub(super) fn refinement_bandwidth(
    omega: f64,
    cost: f64,
    previous: Option<(f64, f64)>,
    floor: f64,
) -> Option<f64> {
    let (omega_previous, cost_previous) = previous?;
    let lost = cost > PREDICTOR_REFINE_FACTOR * floor.max(cost_previous);
    (lost && omega_previous > omega).then(|| (omega_previous * omega).sqrt())
}

/// One predictor stage as run ([`Problem::run_predictor_stage`]): how it ended, the
/// report's note on its step and refinement, and its cost (Σ r² of the predictor's errors)
/// at its end, infinite where they cannot be simulated.
struct PredictorRun {
    outcome: StageOutcome,
    note: String,
    cost: f64,
}

/// One start as run: where it ended (scaled parameters) and its summary.
#[derive(Debug, Clone)]
struct StartRun {
    u: Vec<f64>,
    summary: StartSummary,
    /// The records with the initial positions this start estimated
    /// ([`OutputErrorOptions::estimate_initial_positions`]); `None`: the problem's own.
    records: Option<Vec<Record>>,
}

impl Problem {
    /// Fit from the plant's values and `options.starts − 1` random starts (in parallel),
    /// keeping the lowest cost. `progress` is called after every cost evaluation.
    ///
    /// # Errors
    /// No start to fit (no horizons and no warm-up), or every start fails (the whole
    /// files cannot be simulated from where its final stage begins, or the optimiser
    /// reports an input error); the message names the first failure.
    pub fn fit(&self, progress: &(dyn Fn(Progress) + Sync)) -> Result<FitResult> {
        let started = Instant::now();
        let n = self.names.len();
        let p0 = self.initial_values();
        let mut rng = generated::inertia::Xorshift(self.options.seed.max(1));
        // (start point, warm-up): the plant's values through the horizons, the plant's
        // values through the segments and through the equation error when asked for,
        // then random points through the horizons.
        if !self.options.fits_the_plant_values() {
            bail!(
                "configuration '{}': no start to fit: without horizons one of the segments, \
                 the equation error or the predictor must warm up the plant's values",
                self.conf.name
            );
        }
        let mut starts: Vec<(Vec<f64>, WarmUp)> = Vec::new();
        if !self.options.horizons.is_empty() {
            starts.push((self.to_scaled(&p0), WarmUp::Horizons));
        }
        if !self.options.segments.is_empty() {
            starts.push((self.to_scaled(&p0), WarmUp::Segments));
        }
        let equation_error = match self.options.equation_error {
            Some(cutoff) => {
                starts.push((self.to_scaled(&p0), WarmUp::EquationError));
                Some(self.equation_error_stage(cutoff))
            }
            None => None,
        };
        if equation_error.is_none() && !self.options.predictor.is_empty() {
            starts.push((self.to_scaled(&p0), WarmUp::Predictor));
        }
        for _ in 1..self.options.starts.max(1) {
            starts.push((
                (0..n).map(|_| rng.uniform(0.0, 1.0)).collect(),
                WarmUp::Horizons,
            ));
        }
        let cost_before = self.cost(&p0);
        let evaluations = AtomicUsize::new(0);
        let jacobians = AtomicUsize::new(0);
        let nstarts = starts.len();
        let runs: Vec<StartRun> = starts
            .into_par_iter()
            .enumerate()
            .map(|(s, (u0, warm_up))| {
                let context = StageContext {
                    start: s,
                    starts: nstarts,
                    evaluations: &evaluations,
                    jacobians: &jacobians,
                    started,
                    progress,
                    jacobian: JacobianPolicy::of(&self.options),
                };
                let stages = self.stages(warm_up);
                self.run_start(&context, u0, warm_up, &stages, equation_error.as_ref())
            })
            .collect();
        let mut runs = runs;
        let lowest = runs
            .iter()
            .filter(|r| r.summary.cost.is_finite())
            .min_by(|a, b| a.summary.cost.total_cmp(&b.summary.cost));
        let reseed = lowest
            .filter(|_| self.options.stribeck_reseed)
            .and_then(|r| self.stribeck_reseed(&r.u));
        if let Some((u, note, count)) = reseed {
            evaluations.fetch_add(count, Ordering::Relaxed);
            let context = StageContext {
                start: nstarts,
                starts: nstarts + 1,
                evaluations: &evaluations,
                jacobians: &jacobians,
                started,
                progress,
                jacobian: JacobianPolicy::of(&self.options),
            };
            let stages = self.stages(WarmUp::StribeckBranch);
            let mut run = self.run_start(&context, u, WarmUp::StribeckBranch, &stages, None);
            run.summary.status = format!("{note}; {}", run.summary.status);
            runs.push(run);
        }
        let best = runs
            .iter()
            .filter(|r| r.summary.cost.is_finite())
            .min_by(|a, b| {
                (a.summary.cost + self.prior_penalty(&a.u))
                    .total_cmp(&(b.summary.cost + self.prior_penalty(&b.u)))
            })
            .cloned();
        let Some(best) = best else {
            bail!(
                "configuration '{}': no start could be fitted: {}",
                self.conf.name,
                runs[0].summary.status
            );
        };
        let mut p = self.to_physical(&best.u);
        let mut cost_after = best.summary.cost;
        // The files as the winning start fitted them: with its estimated initial positions
        // (OutputErrorOptions::estimate_initial_positions), else as measured.
        let fitted_on = match &best.records {
            Some(records) => {
                std::borrow::Cow::Owned(self.with_records(records.clone(), self.sqrt_w.clone()))
            }
            None => std::borrow::Cow::Borrowed(self),
        };
        let initial_positions = best.records.as_ref().map(|records| {
            records
                .iter()
                .zip(&self.records)
                .map(|(e, r)| {
                    self.conf
                        .free
                        .iter()
                        .map(|&j| e.q_all[j] - r.q_all[j])
                        .collect()
                })
                .collect()
        });
        let least_change = if self.options.least_change {
            // The cost at the minimum is the winning start's (no second simulation); the
            // only failure left, the barycentric parameters, would stop the statistics too.
            Some(fitted_on.least_change(&p, best.summary.cost)?).inspect(|lc| {
                p.clone_from(&lc.fitted);
                cost_after = lc.cost;
            })
        } else {
            None
        };
        // The statistics with the held ties the least change scaled.
        let held = least_change.as_ref().map_or(&[][..], |lc| &lc.held[..]);
        let at = fitted_on.with_plant_values(held);
        let mut stats = at.statistics(&p)?;
        // Other starts' minima as good as the kept one within the noise: what they move is
        // not determined, whatever the kept minimum's standard errors say.
        let objective = |r: &StartRun| r.summary.cost + self.prior_penalty(&r.u);
        let kept = objective(&best);
        let others: Vec<(usize, f64, Vec<f64>)> = runs
            .iter()
            .filter(|r| r.summary.start != best.summary.start && r.summary.cost.is_finite())
            .map(|r| (r.summary.start, objective(r) - kept, self.to_physical(&r.u)))
            .collect();
        stats.mark_other_minima(
            &self.names,
            &self.to_physical(&best.u),
            &others,
            self.noise_residual_rms().powi(2),
        );
        let prior_penalty = self.prior_penalty(&self.to_scaled(&p));
        Ok(FitResult {
            configuration: self.conf.name.to_string(),
            cost_after,
            prior_penalty,
            least_change,
            statistics: stats,
            starts: runs.iter().map(|r| r.summary.clone()).collect(),
            best_start: best.summary.start,
            residuals: self.m,
            files: self.records.iter().map(|r| r.file.clone()).collect(),
            initial_positions,
            ..FitResult::over(
                &self.space(),
                (p0, p),
                cost_before,
                (&evaluations, &jacobians, started),
            )
        })
    }

    /// The stages a start warmed up by `warm_up` runs, ending with the whole files.
    fn stages(&self, warm_up: WarmUp) -> Vec<Stage> {
        let horizons = self.options.horizons.iter().map(|&h| Stage::Horizon(h));
        let predictor = self.options.predictor.iter().map(|&w| Stage::Predictor(w));
        match warm_up {
            WarmUp::Segments => self
                .options
                .segments
                .iter()
                .map(|&s| Stage::Segments(s))
                .chain([Stage::Horizon(1.0)])
                .collect(),
            WarmUp::Horizons if self.options.horizons.is_empty() => vec![Stage::Horizon(1.0)],
            WarmUp::Horizons => horizons.collect(),
            WarmUp::EquationError => [Stage::EquationError]
                .into_iter()
                .chain(predictor)
                .chain([Stage::Horizon(1.0)])
                .collect(),
            WarmUp::Predictor | WarmUp::Sequence => {
                predictor.chain([Stage::Horizon(1.0)]).collect()
            }
            WarmUp::StribeckBranch => predictor
                .filter(|s| matches!(s, Stage::Predictor(w) if *w <= STRIBECK_BRANCH_OMEGA))
                .chain([Stage::Horizon(1.0)])
                .collect(),
        }
    }

    /// One start: `stages` in turn from scaled parameters `u0` (the equation-error stage
    /// on `equation_error`), each warm-starting the next; a final stage whose start cannot
    /// be simulated, or whose optimiser fails, ends the start. Where warm-ups come first
    /// the whole files need not be simulable from `u0` (a start whose open loop runs away
    /// on the data: the warm-ups take it from there).
    fn run_start(
        &self,
        context: &StageContext,
        u0: Vec<f64>,
        warm_up: WarmUp,
        stages: &[Stage],
        equation_error: Option<&Result<Problem>>,
    ) -> StartRun {
        let start = context.start;
        // A start the whole files diverge from is still warmed up where there are warm-ups:
        // the equation error simulates nothing, and the predictor's output injection holds
        // a simulation on the data that runs away without it.
        let warmed_up = stages.iter().any(|s| !s.is_final());
        let (start_cost, start_note) = match self.residuals(&self.to_physical(&u0)) {
            Ok(r) => (r.iter().map(|x| x * x).sum(), None),
            Err(why) if warmed_up => (
                f64::INFINITY,
                Some(format!(
                    "the start cannot be simulated ({}): warmed up from there",
                    why
                )),
            ),
            Err(why) => {
                return StartRun {
                    u: u0,
                    summary: StartSummary {
                        start,
                        start_cost: f64::INFINITY,
                        cost: f64::INFINITY,
                        iterations: 0,
                        status: format!("the start cannot be simulated: {}", why),
                        diverged: 0,
                        warm_up,
                        stages: Vec::new(),
                    },
                    records: None,
                };
            }
        };
        let mut u = u0;
        let mut iterations = 0;
        let mut diverged = 0;
        // How each stage ended, for the report.
        let mut ended: Vec<String> = start_note.into_iter().collect();
        let mut records: Vec<StageRecord> = Vec::new();
        // The records with estimated initial positions, once the whole files' stage ran on
        // them.
        let mut estimated: Option<Problem> = None;
        // The warm-ups' results the whole files can be simulated from, with their cost
        // (4.2)/(4.3): the start first, where they can be simulated from it.
        let mut simulable = Vec::new();
        if start_cost.is_finite() {
            simulable.push(("the start".to_string(), start_cost, u.clone()));
        }
        // The whole files' cost at `u`, where known (after the start and each warm-up; not
        // after a final stage, which moves `u` with the records it estimates).
        let mut cost_u = Some(start_cost);
        // The last predictor stage's bandwidth (rad/s) and its cost at its end, for the
        // refinement of the next ([`Problem::run_predictor_refined`]).
        let mut previous_predictor: Option<(f64, f64)> = None;
        for &stage in stages {
            let clock = StageClock::start(context);
            if stage.is_final() {
                let at_u = cost_u.take().unwrap_or_else(|| self.cost_at(&u));
                if let Some(note) = start_final_stage(&mut u, &simulable, at_u) {
                    ended.push(note);
                }
            }
            if stage.is_final() && self.options.estimate_initial_positions {
                let (outcome, problem) =
                    self.run_final_estimating_initial_positions(&mut u, context);
                diverged += outcome.failures;
                iterations += outcome.iterations;
                ended.push(format!("{stage}: {}", outcome.status));
                records.push(
                    StageRecord::ran(
                        stage.to_string(),
                        self.stage_optimiser(stage),
                        &outcome,
                        None,
                    )
                    .spent(&clock, context),
                );
                estimated = Some(problem);
                if outcome.stop {
                    break;
                }
                continue;
            }
            let staged;
            let mut step_note = String::new();
            let problem = match stage {
                Stage::Segments(seconds) => {
                    staged = self.segmented(seconds);
                    &staged
                }
                Stage::Horizon(frac) if frac < 1.0 => {
                    staged = self.truncated(frac);
                    // A horizon too short to determine the parameters (a short file)
                    // cannot warm anything up: go on to the next.
                    if staged.residual_count() <= 2 * u.len() {
                        let why = format!(
                            "skipped ({} residuals for {} parameters)",
                            staged.residual_count(),
                            u.len()
                        );
                        ended.push(format!("{stage}: {why}"));
                        records.push(StageRecord::skipped(stage, why));
                        continue;
                    }
                    &staged
                }
                Stage::Horizon(_) | Stage::Joint | Stage::Predictor(_) => self,
                Stage::EquationError => match equation_error {
                    Some(Ok(p)) => p,
                    Some(Err(e)) => {
                        ended.push(format!("{stage}: {e:#}"));
                        records.push(StageRecord::skipped(stage, format!("{e:#}")));
                        continue;
                    }
                    None => continue,
                },
            };
            let outcome = if let Stage::Predictor(omega) = stage {
                let run = self.run_predictor_refined(
                    omega,
                    &mut u,
                    context,
                    previous_predictor,
                    PREDICTOR_REFINEMENTS,
                );
                previous_predictor = Some((omega, run.cost));
                step_note = run.note;
                run.outcome
            } else {
                problem.run_stage(stage, &mut u, context)
            };
            diverged += outcome.failures;
            iterations += outcome.iterations;
            // What the warm-up's result is worth on the whole files, which the final stage
            // fits.
            let mut whole_files_cost = None;
            let whole = if stage.is_final() {
                String::new()
            } else {
                let cost = self.cost_at(&u);
                cost_u = Some(cost);
                if cost.is_finite() {
                    simulable.push((stage.to_string(), cost, u.clone()));
                    whole_files_cost = Some(cost);
                    format!(", whole files' cost {cost:.5e}")
                } else {
                    ", the whole files cannot be simulated from its result".to_string()
                }
            };
            records.push(
                StageRecord::ran(
                    format!("{stage}{step_note}"),
                    self.stage_optimiser(stage),
                    &outcome,
                    whole_files_cost,
                )
                .spent(&clock, context),
            );
            ended.push(format!(
                "{stage}{step_note}: {}{}{whole}",
                outcome.status,
                problem.equation_error_note()
            ));
            if outcome.stop {
                break;
            }
        }
        let cost = estimated
            .as_ref()
            .unwrap_or(self)
            .cost(&self.to_physical(&u));
        StartRun {
            u,
            summary: StartSummary {
                start,
                start_cost,
                cost,
                iterations,
                status: ended.join("; "),
                diverged,
                warm_up,
                stages: records,
            },
            records: estimated.map(|p| p.records),
        }
    }

    /// One predictor stage at bandwidth `omega` (rad/s) from scaled parameters `u`, which it
    /// updates in place: on [`OutputErrorOptions::predictor_step`] where that step's check
    /// allows ([`Problem::checked_predictor`]), and rerun on the user's step from where it
    /// began when its result cannot be simulated there. A coarse predictor stage (ETDRK4
    /// takes the friction's stiffness exactly) can end where RK4 on the user's step
    /// diverges, and then no later stage starts (k3 of the Freedom 6S after ω = 100 rad/s:
    /// q2 at 270 rad/s by t = 3.4 s).
    fn run_predictor_stage(
        &self,
        omega: f64,
        u: &mut [f64],
        context: &StageContext,
    ) -> PredictorRun {
        let stage = Stage::Predictor(omega);
        let before = u.to_vec();
        let (problem, mut note) = self.checked_predictor(omega, u);
        let mut outcome = problem.run_stage(stage, u, context);
        let coarse = problem.options.predictor_step.is_some() && omega > 0.0;
        let mut ran_on = problem;
        if coarse {
            let user = self.predictor_on_user_step(omega);
            if let Err(why) = user.residuals(&self.to_physical(u)) {
                u.copy_from_slice(&before);
                let rerun = user.run_stage(stage, u, context);
                note = format!(
                    "{note} (its result could not be simulated on the user's step, {}: rerun there)",
                    why
                );
                outcome = StageOutcome {
                    iterations: outcome.iterations + rerun.iterations,
                    failures: outcome.failures + rerun.failures,
                    ..rerun
                };
                ran_on = user;
            }
        }
        PredictorRun {
            cost: ran_on.cost(&self.to_physical(u)),
            outcome,
            note,
        }
    }

    /// [`Problem::run_predictor_stage`] with the homotopy's step refined where the stage
    /// lost the track: when it ends above [`PREDICTOR_REFINE_FACTOR`] times the larger of
    /// the noise floor (m s̄², [`Problem::noise_residual_rms`]) and the cost at the end of
    /// the previous predictor stage `previous` (its ω, its cost), it is run again from its
    /// start through the geometric mean of the two bandwidths, each of those two refined in
    /// turn while `depth` > 0, and the lower of the two ends at `omega` is kept. A
    /// predictor's minima at neighbouring bandwidths are close when the plant is near the
    /// data, and its cost at ω stays at or below the output error's floor; a jump means the
    /// stage left the path. k4 of the Freedom 6S from the rerun's k3 plant: ω = 30 rad/s
    /// ended at 0.386 (floor ≈ 0.30), ω = 10 at 4.99 with the whole files diverging from
    /// its result, and the fit at 5488; through ω = 17.32 rad/s, 0.261 then 0.278 at
    /// ω = 10, and the fit at the floor (0.30158).
    fn run_predictor_refined(
        &self,
        omega: f64,
        u: &mut [f64],
        context: &StageContext,
        previous: Option<(f64, f64)>,
        depth: usize,
    ) -> PredictorRun {
        let before = u.to_vec();
        let first = self.run_predictor_stage(omega, u, context);
        let floor = self.noise_residual_rms().powi(2) * self.residual_count() as f64;
        let refined = refinement_bandwidth(omega, first.cost, previous, floor);
        let (Some(omega_between), Some((omega_previous, cost_previous))) = (refined, previous)
        else {
            return first;
        };
        if depth == 0 || first.outcome.stop {
            return first;
        }
        let mut v = before;
        let between =
            self.run_predictor_refined(omega_between, &mut v, context, previous, depth - 1);
        let again = self.run_predictor_refined(
            omega,
            &mut v,
            context,
            Some((omega_between, between.cost)),
            depth - 1,
        );
        let iterations =
            first.outcome.iterations + between.outcome.iterations + again.outcome.iterations;
        let failures = first.outcome.failures + between.outcome.failures + again.outcome.failures;
        let kept = again.cost < first.cost;
        let why = format!(
            "ended at {:.5e}, above {PREDICTOR_REFINE_FACTOR} × {:.4e} (the larger of the noise floor and {}'s end)",
            first.cost,
            floor.max(cost_previous),
            Stage::Predictor(omega_previous),
        );
        // The stage between with its own step's note and refinement, if any.
        let through = format!(
            "through {}{} ({}, {:.5e})",
            Stage::Predictor(omega_between),
            between.note,
            between.outcome.status,
            between.cost
        );
        let (mut run, note) = if kept {
            u.copy_from_slice(&v);
            let note = format!(
                "{}: {}, {why}: rerun from its start {through}, then again{}, kept ({:.5e})",
                first.note, first.outcome.status, again.note, again.cost
            );
            (again, note)
        } else {
            let note = format!(
                "{}, {why}; tried from its start {through}, then again{} ({}, {:.5e}): not lower, the first run kept",
                first.note, again.note, again.outcome.status, again.cost
            );
            (first, note)
        };
        run.note = note;
        run.outcome.iterations = iterations;
        run.outcome.failures = failures;
        run
    }

    /// The cost (4.2)/(4.3) of the whole files at scaled parameters `u`; infinite where
    /// they cannot be simulated.
    fn cost_at(&self, u: &[f64]) -> f64 {
        self.cost(&self.to_physical(u))
    }

    /// The whole files' stage with the free joints' initial positions estimated
    /// ([`OutputErrorOptions::estimate_initial_positions`]): first the stage from the
    /// measured first samples (estimated where the parameters are still off, the starts
    /// absorb the model's error: k1 of the Freedom 6S estimated from the predictor's end
    /// moved q5(0) by 3.2 σ̂ and stalled at 4.19, where the first samples reach 0.607);
    /// then per round a Gauss–Newton step of every file's q(0) at `u`
    /// ([`Problem::estimate_initial_positions`], from the last round's estimate, taken only
    /// where it lowers the cost) and the stage again from `u`, which it updates. The rounds
    /// end once an estimate moves no initial position by more than
    /// [`INITIAL_POSITION_SETTLED`] × its joint's σ̂, after [`INITIAL_POSITION_ROUNDS`]
    /// stages, or when a stage cannot go on. Returns the summed outcome (its status names every round and the
    /// largest move) and the problem on the final initial positions.
    fn run_final_estimating_initial_positions(
        &self,
        u: &mut [f64],
        context: &StageContext,
    ) -> (StageOutcome, Problem) {
        let stage = Stage::Horizon(1.0);
        let mut outcome = StageOutcome {
            status: String::new(),
            iterations: 0,
            failures: 0,
            stop: false,
        };
        let mut notes = Vec::new();
        let mut current = self.with_records(self.records.clone(), self.sqrt_w.clone());
        for round in 1..=INITIAL_POSITION_ROUNDS + 1 {
            let mut moved = 0.0;
            if round > 1 {
                let p = self.to_physical(u);
                let records = match current.estimate_initial_positions(&self.plant_at(&p)) {
                    Ok(records) => records,
                    Err(why) => {
                        notes.push(format!("initial positions not estimated: {}", why));
                        break;
                    }
                };
                // A Gauss–Newton step that does not lower the cost is not taken (an
                // initial position the weighted samples barely see).
                let next = self.with_records(records, self.sqrt_w.clone());
                if next.cost(&p) < current.cost(&p) {
                    moved = self.initial_position_move(&current.records, &next.records);
                    current = next;
                }
                if round > INITIAL_POSITION_ROUNDS || moved <= INITIAL_POSITION_SETTLED {
                    notes.push(format!(
                        "initial positions {} (last move {moved:.2} σ̂)",
                        if moved <= INITIAL_POSITION_SETTLED {
                            "settled"
                        } else {
                            "not settled"
                        }
                    ));
                    break;
                }
            }
            let o = current.run_stage(stage, u, context);
            outcome.iterations += o.iterations;
            outcome.failures += o.failures;
            notes.push(if round == 1 {
                format!("from the first samples: {}", o.status)
            } else {
                format!(
                    "round {round}, initial positions moved up to {moved:.2} σ̂: {}",
                    o.status
                )
            });
            if o.stop {
                outcome.stop = true;
                break;
            }
        }
        outcome.status = notes.join(", ");
        (outcome, current)
    }

    /// The largest change of a free joint's initial position from `before` to `after`
    /// (records of this problem's files, in order), in units of that joint's noise σ̂.
    pub(crate) fn initial_position_move(&self, before: &[Record], after: &[Record]) -> f64 {
        before
            .iter()
            .zip(after)
            .flat_map(|(b, a)| {
                self.conf
                    .free
                    .iter()
                    .zip(&self.noise)
                    .map(move |(&j, &s)| (a.q_all[j] - b.q_all[j]).abs() / s.max(f64::MIN_POSITIVE))
            })
            .fold(0.0, f64::max)
    }

    /// The optimiser of `stage`: [`OutputErrorOptions::predictor_optimiser`] for the
    /// predictor's stages, [`OutputErrorOptions::whole_files_optimiser`] for the final one,
    /// rmpfit's Levenberg–Marquardt elsewhere.
    pub fn stage_optimiser(&self, stage: Stage) -> StageOptimiser {
        match stage {
            Stage::Predictor(_) => self.options.predictor_optimiser,
            s if s.is_final() => self.options.whole_files_optimiser,
            _ => StageOptimiser::LevenbergMarquardt,
        }
    }

    /// One bounded least-squares run of `stage` on this problem from the scaled
    /// parameters `u`, which it updates in place, on the stage's stopping rules
    /// ([`stage_rules`]), by the stage's optimiser
    /// ([`OutputErrorOptions::predictor_optimiser`],
    /// [`OutputErrorOptions::whole_files_optimiser`]; rmpfit's Levenberg–Marquardt
    /// elsewhere).
    fn run_stage(&self, stage: Stage, u: &mut [f64], context: &StageContext) -> StageOutcome {
        let warm_up = !stage.is_final();
        let start_cost = self.cost(&self.to_physical(u));
        if !start_cost.is_finite() {
            return StageOutcome {
                status: "the stage's start cannot be simulated".into(),
                iterations: 0,
                failures: 0,
                // A warm-up stage only prepares the next one: go on from here.
                stop: !warm_up,
            };
        }
        let frozen: Vec<bool> = self.names.iter().map(|n| self.is_frozen(n)).collect();
        let run = StageRun {
            problem: self,
            stage,
            frozen: &frozen,
            rules: stage_rules(&self.options, stage),
            context,
            start_cost,
        };
        self.stage_optimiser(stage).solver().minimise(&run, u)
    }

    /// Stribeck re-seed of scaled parameters `u` (a fitted minimum) for
    /// [`WarmUp::StribeckBranch`]. Where a joint's fitted Stribeck dip has collapsed
    /// (Fs ≤ (1 + `STRIBECK_COLLAPSED`) Fc) or its Stribeck velocity vs sits on a bound, the cost does not depend
    /// on vs (at Fs = Fc) or barely (vs past the files' velocities), and the gradient
    /// cannot bring the dip back: k3 of the Freedom 6S from the Appendix D guess ended with
    /// vs_q2 on its upper bound, Fs_q2 = Fc_q2 and q4 at 1.66 σ̂ (truth: vs_q2 = 0.019 rad/s,
    /// Fs_q2 = 1.61 Fc_q2). Per such joint, the whole files' cost on a grid of
    /// `STRIBECK_VS_GRID` Stribeck velocities log-spaced over vs's bounds times levels
    /// Fs = Fc (1 + r), r in `STRIBECK_RATIOS`, the other parameters kept. Where vs sits
    /// on its upper bound, the friction the files saw was Fs at every velocity
    /// (g(v) = Fc + (Fs − Fc) e^{−(v/vs)²} ≈ Fs) and Fc was unseen, so the grid also tries
    /// Fc = that Fs: the rerun's k3 ended with vs_q2 = 9.48 rad/s on its bound, Fs_q2 =
    /// 0.0444 N·m (the truth's Fc_q2: 0.0444) and Fc_q2 = 0.026, and the grid on Fc alone
    /// seeded vs_q2 = 3.56 rad/s, a branch that ended at 0.489 against 0.429. The grid's
    /// best point seeds the branch even where it is above the minimum's cost (the other
    /// parameters have adapted to the missing dip: on k3 every grid point was). Returns
    /// the seed, a note for the report and the cost evaluations, or `None` when no joint
    /// collapsed. `u` and the seed are scaled ([`Problem::to_scaled`]), one per fitted
    /// parameter.
    pub fn stribeck_reseed(&self, u: &[f64]) -> Option<(Vec<f64>, String, usize)> {
        let mut notes = Vec::new();
        let mut evaluations = 0;
        let mut p = self.to_physical(u);
        for &(ic, is) in &self.pairs {
            let joint = &self.names[is]["Fs_".len()..];
            let Some(iv) = self.names.iter().position(|n| n == &format!("vs_{joint}")) else {
                continue;
            };
            let collapsed = p[is] <= (1.0 + STRIBECK_COLLAPSED) * p[ic];
            // Within this fraction of vs's bound width from a bound counts as on it.
            const NEAR: f64 = 1e-3;
            let uv = (p[iv] - self.lower[iv]) / (self.upper[iv] - self.lower[iv]);
            let on_bound = !(NEAR..=1.0 - NEAR).contains(&uv);
            if !(collapsed || on_bound) || self.lower[iv] <= 0.0 {
                continue;
            }
            let (lo, hi) = (self.lower[iv], self.upper[iv]);
            // The friction level the files saw, kept as Fc: Fc itself, and also Fs where
            // vs sits on its upper bound (g(v) ≈ Fs at every velocity below vs).
            let mut levels = vec![p[ic]];
            if uv > 1.0 - NEAR && p[is] > p[ic] {
                levels.push(p[is].clamp(self.lower[ic], self.upper[ic]));
            }
            let intervals = (STRIBECK_VS_GRID - 1) as f64;
            let candidates: Vec<Vec<f64>> = (0..STRIBECK_VS_GRID)
                .flat_map(|g| {
                    let vs = lo * (hi / lo).powf(g as f64 / intervals);
                    levels
                        .iter()
                        .flat_map(move |&fc| STRIBECK_RATIOS.iter().map(move |&r| (vs, fc, r)))
                })
                .map(|(vs, fc, r)| {
                    let mut q = p.clone();
                    q[iv] = vs;
                    q[ic] = fc;
                    q[is] = (fc * (1.0 + r))
                        .clamp(self.lower[is], self.upper[is])
                        .max(fc);
                    q
                })
                .collect();
            evaluations += candidates.len();
            let best = candidates
                .into_par_iter()
                .map(|q| (self.cost(&q), q))
                .filter(|(c, _)| c.is_finite())
                .min_by(|a, b| a.0.total_cmp(&b.0));
            if let Some((cost, q)) = best {
                let fc_note = if q[ic] == p[ic] {
                    String::new()
                } else {
                    format!(
                        ", Fc {:.4} → {:.4} (the level vs on its upper bound left)",
                        p[ic], q[ic]
                    )
                };
                notes.push(format!(
                    "joint {joint}: vs {:.4} → {:.4} rad/s, Fs {:.4} → {:.4}{fc_note} (cost {cost:.4e})",
                    p[iv], q[iv], p[is], q[is]
                ));
                p = q;
            }
        }
        (!notes.is_empty()).then(|| {
            (
                self.to_scaled(&p),
                format!("Stribeck re-seed of {}", notes.join(", ")),
                evaluations,
            )
        })
    }

    /// The equation-error estimate alone: from the plant's values, the minimum of the
    /// equation error of the whole files ([`Problem::equation_error_stage`], cut-off
    /// `cutoff` of the Nyquist frequency) within the bounds and Fs ≥ Fc, as the warm start
    /// of [`OutputErrorOptions::equation_error`] finds it. Returns the physical parameters
    /// and how the optimiser ended.
    ///
    /// # Errors
    /// A file too short for the filter, a cut-off outside (0, 1), or the plant cannot be
    /// configured at the start.
    pub fn fit_equation_error(&self, cutoff: Cutoff) -> Result<(Vec<f64>, String)> {
        let ee = self.equation_error_stage(cutoff)?;
        let mut u = self.to_scaled(&self.initial_values());
        ee.residuals(&self.to_physical(&u))
            .map_err(|e| anyhow::anyhow!("{}", e))?;
        let (evaluations, jacobians) = (AtomicUsize::new(0), AtomicUsize::new(0));
        let context =
            StageContext::alone(&evaluations, &jacobians, JacobianPolicy::of(&ee.options));
        let outcome = ee.run_stage(Stage::EquationError, &mut u, &context);
        Ok((self.to_physical(&u), outcome.status))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The refinement's rule on the predictor stages' ends of the Freedom 6S's coupled
    /// steps: those that lost the path are refined, those on it are not.
    #[test]
    fn a_predictor_stage_that_lost_the_path_is_refined_and_one_on_it_is_not() {
        // Stage ends (ω, cost) recorded on the Freedom 6S's coupled steps, floor ≈ 0.30.
        let floor = 0.30;
        // k4 from the rerun's k3 plant: ω = 30 ended at 0.386, ω = 10 at 4.99 (the whole
        // files diverged from it).
        let w = refinement_bandwidth(10.0, 4.99, Some((30.0, 0.386)), floor).unwrap();
        assert!((w - 300f64.sqrt()).abs() < 1e-12, "{w}");
        // k5 of that path: ω = 10 at 0.306, ω = 3 at 0.728.
        assert!(refinement_bandwidth(3.0, 0.728, Some((10.0, 0.306)), floor).is_some());
        // Paths that reached the floor: k4 of the status table (ω = 30 at 0.273, 10 at
        // 0.278), k5 (ω = 3 at 0.342, 1 at 0.419), k3's first stage after ω = 100 (0.110 →
        // 0.238: below twice the floor, whatever its ratio to the previous end).
        assert_eq!(
            refinement_bandwidth(10.0, 0.278, Some((30.0, 0.273)), floor),
            None
        );
        assert_eq!(
            refinement_bandwidth(1.0, 0.419, Some((3.0, 0.342)), floor),
            None
        );
        assert_eq!(
            refinement_bandwidth(30.0, 0.238, Some((100.0, 0.110)), floor),
            None
        );
        // The first predictor stage, and a bandwidth above the previous one.
        assert_eq!(refinement_bandwidth(100.0, 50.0, None, floor), None);
        assert_eq!(
            refinement_bandwidth(3.0, 50.0, Some((1.0, 0.3)), floor),
            None
        );
    }

    /// The final stage starts from the lowest whole files' cost among the start and the
    /// warm-ups' results: the warm-ups' end where it is the lowest, else the lowest earlier
    /// result (also where the whole files cannot be simulated from the end), not the start
    /// unless it is the lowest.
    #[test]
    fn the_final_stage_starts_from_the_lowest_cost_simulable_warm_up() {
        let simulable = vec![
            ("the start".to_string(), 5.0e4, vec![0.5, 0.5]),
            ("predictor ω = 30 rad/s".to_string(), 0.26, vec![0.2, 0.7]),
            ("predictor ω = 10 rad/s".to_string(), 3.1, vec![0.1, 0.9]),
        ];
        let mut u = vec![0.0, 1.0];
        assert_eq!(start_final_stage(&mut u, &simulable, 0.25), None);
        assert_eq!(u, [0.0, 1.0]);
        let note = start_final_stage(&mut u, &simulable, 3.1).unwrap();
        assert_eq!(u, [0.2, 0.7]);
        assert!(
            note.contains("predictor ω = 30 rad/s's result (whole files' cost 2.60000e-1), lower than the warm-ups' end (3.10000e0)"),
            "{note}"
        );
        let mut u = vec![0.0, 1.0];
        let note = start_final_stage(&mut u, &simulable, f64::INFINITY).unwrap();
        assert_eq!(u, [0.2, 0.7]);
        assert!(
            note.contains("cannot be simulated")
                && note.contains("predictor ω = 30 rad/s's (cost 2.60000e-1)"),
            "{note}"
        );
        let mut u = vec![0.0, 1.0];
        let only_start = &simulable[..1];
        assert!(start_final_stage(&mut u, only_start, f64::INFINITY).is_some());
        assert_eq!(u, [0.5, 0.5]);
    }
}
