//! Which physical effect is missing, in output space: position-measured data, the plant
//! simulated on the measured torques.
//!
//! The residual is r = y − ŷ(plant), the measured minus the simulated positions of every
//! free joint of every file, stacked (the first `skip` samples of each file left out). Each
//! candidate of the catalogue changes the plant by one size β (a friction level, a
//! stiffness, a coupling gain, a gain factor) from the value β₀ at which it has no effect;
//! its signature is the sensitivity of the simulated positions,
//!
//! s = ∂ŷ/∂β ≈ (ŷ(β₀ + δ) − ŷ(β₀ − δ)) / 2δ   (central difference, forward where β₀ − δ
//! cannot be simulated),
//!
//! and r is fitted on s by least squares with β kept in its physical range (a spring's
//! stiffness, a friction level ≥ 0): β̂ = clamp(β₀ + sᵀr / sᵀs), SSE = ‖r − (β̂ − β₀) s‖².
//! A second, nonlinear parameter (Stribeck velocity vs, the equilibrium position qeq of a
//! spring or friction bias) is scanned on a grid and counts as a fitted number in ΔBIC.
//! The candidates that pass this first screen (significant when linearised, and the leading
//! three whatever their figures) are then confirmed, in parallel: the candidate is added at
//! β̂ and its parameters refitted by output error
//! ([`crate::identify::output_error::Problem`]), and its figures become those of the fitted
//! plant (the linearisation understates large effects such as a 30 % gain error), so the
//! ranking is that of the fitted costs. Where the plant gives bounds, the values the
//! configuration determines ([`super::apply::configuration_values`]) are refitted first
//! (from the plant's values through growing horizons and, where those end above the noise,
//! through the coupled preset's warm-ups too: [`OutputOptions::values_warm_ups`]) —
//! r is then the residual of that plant — and again beside each candidate in its
//! confirming fit, whose ΔBIC counts only the candidate's own numbers
//! ([`OutputOptions::refit_values`]). The diagnosis also reports the effective number of
//! independent samples ([`super::effective_samples`]) of the residual all candidates'
//! sensitivities fitted together leave: far below n, the residual holds structure no
//! candidate describes.
//!
//! Catalogue (per free joint i; an effect the joint already has is not offered again):
//! Coulomb (Fc_i), viscous (Fv_i), offset (offset_i), Stribeck/stiction (Fs_i above Fc_i,
//! vs_i on a grid; on a LuGre or Stribeck joint the existing law's Fs_i, on a Coulomb joint
//! the law replaced by Stribeck), LuGre in place of a Coulomb or Stribeck law (σ0_i on a
//! grid of presliding deflections, screened from its own difference: no σ0 is neutral),
//! cable-drag spring (Ks_i, qeq_i on a grid unless a friction
//! bias fixes it), friction position bias (FrictionBias_i, qeq_i shared with the spring
//! when there is one), an existing spring's or bias's equilibrium position off (qeq_i), tendon input coupling from each other free joint (G_{j→i}; where the
//! plant has it, its gain off, either sign), and a plant-gain error (Kp_i; added as a gain
//! when the joint has none). Rigid-body parameter
//! errors are not candidates here: identification refits them.
//!
//! Structure outside the catalogue: where no catalogued candidate explains
//! [`super::STRUCTURE_SEARCH_BELOW`] of the residual or takes the error to the noise, each
//! joint above its noise gets a candidate from a library of functions
//! ([`super::structure`]): their
//! output sensitivities, the residual's sparse model on them, written as a user-defined
//! effect and confirmed by an output-error fit ([`super::STRUCTURE_MARGIN`] decides against a
//! catalogued effect it does not clearly beat).

use super::{effective_samples, Finding};
use crate::effects::{Effect, EffectKind};
use crate::identify::output_error::{JointFit, Problem, Record, FLOOR_FACTOR};
use crate::identify::refit::{refit, Refit, RefitOptions};
use crate::names;
use crate::plant::Plant;
use crate::simulation::{Hold, Trajectory};
use anyhow::{anyhow, bail, Result};
use rayon::prelude::*;

/// Settings of an output-space diagnosis.
#[derive(Debug, Clone)]
pub struct OutputOptions {
    /// Simulation and fit settings (integration step and scheme, hold, transient skip, initial positions,
    /// iterations of a confirmation fit).
    pub fit: RefitOptions,
    /// Leading candidates confirmed by a nonlinear fit whatever their linearised figures
    /// (0: none beyond the significant ones).
    pub confirm: usize,
    /// Most candidates confirmed: the leading `confirm` and every candidate whose
    /// linearised fit is significant (the first screen), best first.
    pub confirm_max: usize,
    /// Refit the values the configuration determines and the plant gives bounds for
    /// ([`super::apply::configuration_values`]) before ranking, and beside each candidate in
    /// its confirming fit: a missing effect is then judged against the best the plant as it
    /// is can do, not against values that are merely off (a plant without bounds, such as
    /// the thesis's tables, is taken as it is).
    pub refit_values: bool,
    /// Most Levenberg–Marquardt iterations of that first refit of the values: it is the
    /// null every candidate is judged against, and a candidate's confirming fit refits the
    /// values again beside it, so a first refit stopped short of its minimum would credit
    /// the rest of the way to whichever candidate is confirmed.
    pub values_max_iter: usize,
    /// Where that first refit through the growing horizons ends above the noise on some
    /// joint ([`FLOOR_FACTOR`] × σ̂), it is run again with the warm-ups
    /// ([`RefitOptions::warm_ups`]) and the lower cost kept: from a start far off (a CAD
    /// model, a datasheet) the output error of a long file has local minima the horizons
    /// end in (DIDIM starts from the torque balance too).
    pub values_warm_ups: bool,
    /// The user's candidate effects ([`super::candidates`]), each fitted by output error
    /// and ranked with the catalogue (those the plant has already are left out).
    pub candidates: Vec<super::candidates::UserCandidate>,
}

impl Default for OutputOptions {
    fn default() -> Self {
        OutputOptions {
            fit: RefitOptions {
                max_iter: 30,
                ..RefitOptions::default()
            },
            confirm: 3,
            confirm_max: 12,
            refit_values: true,
            values_max_iter: 200,
            values_warm_ups: true,
            candidates: Vec::new(),
        }
    }
}

impl OutputOptions {
    /// The settings of the joint refit that applies a finding
    /// ([`super::apply::apply_finding`]): the fit's settings with the refit's own iteration
    /// cap, through the warm-ups where the values are refitted
    /// ([`OutputOptions::values_warm_ups`]; the joint refit starts from the plant as given).
    pub fn joint_refit(&self) -> RefitOptions {
        RefitOptions {
            max_iter: RefitOptions::default().max_iter,
            warm_ups: self.refit_values && self.values_warm_ups,
            ..self.fit.clone()
        }
    }
}

/// The result of [`diagnose_output`].
#[derive(Debug, Clone)]
pub struct OutputDiagnosis {
    /// Configuration.
    pub configuration: String,
    /// Candidates, best (lowest ΔBIC) first.
    pub findings: Vec<Finding>,
    /// Fit figures per free joint of the plant as it is (RMS, max, NRMSE fit; all samples,
    /// as `compare` reports them).
    pub joints: Vec<JointFit>,
    /// Residual samples n (all files and free joints).
    pub samples: usize,
    /// The effective number of independent samples of the residual all candidates fitted
    /// together leave ([`super::effective_samples`]); far below `samples`: the residual
    /// holds structure no candidate of the catalogue describes (or correlated noise).
    pub effective_samples: f64,
    /// Free joints whose RMS error exceeds [`FLOOR_FACTOR`] × their noise σ̂ estimated
    /// from the data, as "q3 9.0 σ̂". With no significant finding, a non-empty list means
    /// the residual is not noise yet nothing in the catalogue explains it
    /// ([`OutputDiagnosis::verdict`]).
    pub above_noise: Vec<String>,
    /// Free joints whose residual is not white ([`super::not_white`]). With no significant
    /// finding, a non-empty list (or `above_noise`) means something is left that nothing
    /// in the catalogue or the library explains ([`OutputDiagnosis::verdict`]).
    pub not_white: Vec<String>,
    /// Simulations run.
    pub simulations: usize,
    /// The integration step's check against the noise (the step used, and the floor).
    pub step: crate::accuracy::StepCheck,
    /// The numerical floor's share of the residual energy: what the step and the input's
    /// reconstruction can account for ([`crate::accuracy`]); no candidate that explains
    /// less is significant.
    pub floor_share: f64,
    /// The refit of the configuration's values that came first
    /// ([`OutputOptions::refit_values`]; None when off or the plant gives no bounds): the
    /// findings, `joints` and `above_noise` are those of its plant.
    pub values_refit: Option<Refit>,
}

impl OutputDiagnosis {
    /// The verdict in one line ([`super::verdict`] with what this diagnosis's residual
    /// shows that is not noise, [`OutputDiagnosis::left`]).
    pub fn verdict(&self) -> String {
        super::verdict(&self.findings, &self.left())
    }

    /// The ranking (top `k`) and the verdict as text.
    pub fn table(&self, k: usize) -> String {
        super::table_with(&self.findings, k, &self.left())
    }

    /// What the residual shows that is not noise: the joints above their noise, then the
    /// joints whose residual is not white.
    pub fn left(&self) -> Vec<String> {
        self.above_noise
            .iter()
            .chain(&self.not_white)
            .cloned()
            .collect()
    }

    /// The plant the findings are relative to: `given` (the plant diagnosed) with the
    /// configuration's values refitted when they were ([`OutputDiagnosis::values_refit`]).
    pub fn judged<'a>(&'a self, given: &'a Plant) -> &'a Plant {
        self.values_refit.as_ref().map_or(given, |r| &r.plant)
    }
}

/// The size a candidate changes: a plant parameter, its no-effect value β₀, the
/// sensitivity step δ and the physical range.
#[derive(Debug, Clone)]
struct Size {
    name: String,
    zero: f64,
    step: f64,
    lo: f64,
    hi: f64,
}

/// A candidate plant change with one linear size.
#[derive(Debug, Clone)]
struct Candidate {
    name: String,
    kind: EffectKind,
    joint: usize,
    from: Option<usize>,
    /// Effect to add (None: an existing effect's parameter changes).
    effect: Option<Effect>,
    replaces: Option<EffectKind>,
    /// Values set with the change (a new effect's other parameters, a grid value).
    fixed: Vec<(String, f64)>,
    size: Size,
    /// A grid-scanned parameter (refitted in the confirmation, counted in ΔBIC): its
    /// name and range.
    grid: Option<(String, f64, f64)>,
    /// The candidate at its size's `zero` is not the plant itself (a replacement with no
    /// neutral value: LuGre for a static law); the screen then fits the residual with the
    /// difference at `zero` plus the size's sensitivity there.
    shifted: bool,
}

impl Candidate {
    /// The plant with the candidate at size `beta`.
    fn plant(&self, base: &Plant, beta: f64) -> Result<Plant> {
        let mut p = base.clone();
        if let Some(e) = self.effect {
            super::replace_law(&mut p, e, self.replaces);
            p.add_effect(e)?;
        }
        for (n, v) in &self.fixed {
            p.parameters.insert(n.clone(), *v);
        }
        p.parameters.insert(self.size.name.clone(), beta);
        Ok(p)
    }
}

/// A candidate's sensitivity column of the stacked outputs to its size, and for a shifted
/// candidate its difference from the plant at its zero.
type Sensitivity = (Vec<f64>, Option<Vec<f64>>);

/// Simulation of plants on the records, stacked into one output vector.
struct Outputs {
    problem: Problem,
    skip: usize,
}

impl Outputs {
    fn trajectories(&self, plant: &Plant) -> Result<Vec<Trajectory>> {
        self.problem
            .records
            .iter()
            .map(|r| self.problem.simulate(plant, r).map_err(anyhow::Error::from))
            .collect()
    }

    fn stack(&self, trajectories: &[Trajectory]) -> Vec<f64> {
        let mut y = Vec::new();
        for t in trajectories {
            for qa in &t.q {
                y.extend_from_slice(&qa[self.skip.min(qa.len())..]);
            }
        }
        y
    }

    /// Lengths of the stacked segments (each file's free joints, after `skip`).
    fn segments(&self) -> Vec<usize> {
        self.problem
            .records
            .iter()
            .flat_map(|r| r.q.iter().map(|qa| qa.len() - self.skip.min(qa.len())))
            .collect()
    }

    fn measured(&self) -> Vec<f64> {
        let mut y = Vec::new();
        for r in &self.problem.records {
            for qa in &r.q {
                y.extend_from_slice(&qa[self.skip.min(qa.len())..]);
            }
        }
        y
    }

    fn simulate(&self, plant: &Plant) -> Result<Vec<f64>> {
        Ok(self.stack(&self.trajectories(plant)?))
    }
}

fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt()
}

/// Quantile `f` of `v` (sorted copy).
pub(super) fn quantile(v: &[f64], f: f64) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    s[((s.len() - 1) as f64 * f).round() as usize]
}

/// Rank the catalogue against the position residual of `plant` in configuration
/// `conf_name` on `records` (prepared by [`crate::identify::sequence::read_record`]),
/// best first, with the leading `options.confirm` candidates confirmed by a nonlinear fit.
///
/// # Errors
/// Unknown configuration, no records or too few samples after `skip`, a plant parameter
/// without value, or the plant itself cannot be simulated on a record (file named).
pub fn diagnose_output(
    plant: &Plant,
    conf_name: &str,
    records: &[Record],
    options: &OutputOptions,
) -> Result<OutputDiagnosis> {
    let m = plant.model;
    let conf = crate::util::configuration(m, conf_name).map_err(|e| anyhow!("{e}"))?;
    if records.is_empty() {
        bail!("configuration '{conf_name}': no measurement files");
    }
    // The values the configuration determines, refitted first: the findings are judged
    // against them, and refitted beside each candidate.
    let values = if options.refit_values {
        super::apply::configuration_values(plant, conf_name, records)?
    } else {
        Vec::new()
    };
    let values_refit = if values.is_empty() {
        None
    } else {
        // The growing horizons first; the warm-ups only where those stop above the noise.
        Some(
            super::apply::escalated(
                &RefitOptions {
                    max_iter: options.values_max_iter,
                    warm_ups: options.values_warm_ups,
                    ..options.fit.clone()
                },
                |o| refit(plant, plant, conf_name, records, &values, o),
            )
            .map_err(|e| anyhow!("refitting the plant's values first: {e:#}"))?,
        )
    };
    let plant = values_refit.as_ref().map_or(plant, |r| &r.plant);
    let (mut problem, step) =
        crate::accuracy::checked_simulation(plant, conf, records, &options.fit)
            .map_err(|e| anyhow!("the plant itself cannot be simulated accurately: {e:#}"))?;
    let oe = problem.options().clone();
    if options.fit.estimate_initial {
        problem = problem
            .with_initial_positions_of(plant)
            .map_err(|e| anyhow!("the plant itself cannot be simulated: {}", e))?;
    }
    let out = Outputs {
        problem,
        skip: options.fit.skip,
    };
    let records = &out.problem.records;
    let base = out
        .trajectories(plant)
        .map_err(|e| anyhow!("the plant itself cannot be simulated: {e:#}"))?;
    let y = out.measured();
    let yhat = out.stack(&base);
    let r: Vec<f64> = y.iter().zip(&yhat).map(|(a, b)| a - b).collect();
    let n = r.len();
    let sst: f64 = r.iter().map(|x| x * x).sum();
    let joints = out.problem.joint_fits(&base);
    let segments = out.segments();
    // Per free joint: above its noise, not white (each with its reason).
    let above: Vec<Option<String>> = joints
        .iter()
        .map(|j| {
            (j.noise > 0.0 && j.rms > FLOOR_FACTOR * j.noise)
                .then(|| format!("{} {:.1} σ̂", j.joint, j.rms / j.noise))
        })
        .collect();
    let coloured = not_white_joints(m, conf, &r, &segments);
    let cands = catalogue(plant, conf, records, &base)?;
    // Sensitivity columns, all candidates in parallel.
    let columns: Vec<Option<Sensitivity>> = cands
        .par_iter()
        .map(|c| {
            let at = |b: f64| c.plant(plant, b).and_then(|p| out.simulate(&p));
            let s = &c.size;
            let plus = at(s.zero + s.step).ok()?;
            let (minus, width, offset) = if c.shifted {
                // Its difference from the plant at `zero`, and the central sensitivity there
                // (its zero is no neutral point to difference from).
                let lo = (s.zero - s.step).max(s.lo);
                let y0 = at(s.zero).ok()?;
                let offset = y0.iter().zip(&yhat).map(|(a, b)| a - b).collect();
                (at(lo).ok()?, s.zero + s.step - lo, Some(offset))
            } else if s.zero - s.step >= s.lo {
                match at(s.zero - s.step) {
                    Ok(v) => (v, 2.0 * s.step, None),
                    Err(_) => (yhat.clone(), s.step, None),
                }
            } else {
                (yhat.clone(), s.step, None)
            };
            Some((
                plus.iter()
                    .zip(&minus)
                    .map(|(a, b)| (a - b) / width)
                    .collect(),
                offset,
            ))
        })
        .collect();
    let mut simulations = 1 + cands
        .iter()
        .map(|c| 2 + usize::from(c.shifted))
        .sum::<usize>();
    // Linear fits; a grid-scanned candidate keeps its best grid point.
    struct Linear {
        cand: Candidate,
        beta: f64,
        sse: f64,
        p: usize,
        column: Vec<f64>,
    }
    let mut best: Vec<Linear> = Vec::new();
    for (c, col) in cands.into_iter().zip(columns) {
        let Some((s, offset)) = col else { continue };
        let ss: f64 = s.iter().map(|x| x * x).sum();
        if ss <= 0.0 || !ss.is_finite() {
            continue;
        }
        // What the size has to explain: the residual less a shifted candidate's own
        // difference at its zero.
        let rc: Vec<f64> = match &offset {
            Some(o) => r.iter().zip(o).map(|(a, b)| a - b).collect(),
            None => r.clone(),
        };
        if !rc.iter().all(|x| x.is_finite()) {
            continue;
        }
        let sr: f64 = s.iter().zip(&rc).map(|(a, b)| a * b).sum();
        let beta = (c.size.zero + sr / ss).clamp(c.size.lo, c.size.hi);
        let d = beta - c.size.zero;
        let sse: f64 = s.iter().zip(&rc).map(|(a, b)| (b - d * a).powi(2)).sum();
        // The column the candidate adds to the residual's joint model: its whole change.
        let s = match offset {
            Some(o) => o.iter().zip(&s).map(|(a, b)| a + d * b).collect(),
            None => s,
        };
        let p = 1 + usize::from(c.grid.is_some());
        match best
            .iter_mut()
            .find(|b| (&b.cand.name, b.cand.joint, b.cand.from) == (&c.name, c.joint, c.from))
        {
            Some(b) if b.sse <= sse => {}
            Some(b) => {
                *b = Linear {
                    cand: c,
                    beta,
                    sse,
                    p,
                    column: s,
                }
            }
            None => best.push(Linear {
                cand: c,
                beta,
                sse,
                p,
                column: s,
            }),
        }
    }
    // The effective number of independent samples of the residual that all candidates'
    // sensitivities fitted together leave (reported, not counted in ΔBIC: where much is
    // missing that no candidate describes, the residual stays correlated and counting
    // only its independent samples called a 10 %-off plant's missing spring chance;
    // docs/src/record/independent-data.md).
    let columns: Vec<&[f64]> = best.iter().map(|l| l.column.as_slice()).collect();
    let columns_len = columns.len();
    let effective = {
        let left = super::least_squares_residual(&columns, &r).unwrap_or_else(|| r.clone());
        effective_samples(&left, &segments)
    };
    let finding = |l: &Linear, values: Vec<(String, f64)>, sse: f64, p: usize| -> Finding {
        let c = &l.cand;
        let mut f = Finding::new(
            m.joints[c.joint],
            c.name.clone(),
            Some(c.kind),
            c.from.map(|k| m.joints[k].to_string()),
            values.clone(),
            (sse, sst, n as f64, p),
        );
        f.effect = c.effect;
        f.replaces = c.replaces;
        let range = |name: &str| -> (f64, f64) {
            if *name == c.size.name {
                (c.size.lo, c.size.hi)
            } else if let Some((_, lo, hi)) = c.grid.as_ref().filter(|g| g.0 == name) {
                (*lo, *hi)
            } else {
                let v = values.iter().find(|x| x.0 == name).map_or(0.0, |x| x.1);
                let (lo, hi) = super::bounds_about(v, 1.0);
                // LuGre's stiffness and dampings are not negative, its vs positive.
                if name.starts_with("sigma") {
                    (lo.max(0.0), hi)
                } else if name.starts_with("vs_") {
                    (lo.max(1e-3 * v.abs()), hi)
                } else {
                    (lo, hi)
                }
            }
        };
        f.bounds = values.iter().map(|(k, _)| range(k)).collect();
        f.values = values;
        f
    };
    let values_of = |c: &Candidate, beta: f64| -> Vec<(String, f64)> {
        let mut v: Vec<(String, f64)> = c.fixed.clone();
        v.push((c.size.name.clone(), beta));
        v
    };
    // The nonlinear fit of one candidate's parameters from its linear estimate: the
    // confirmed finding (None when the fit fails) and the simulations it ran.
    let confirm = |l: &Linear, lin: &Finding| -> (Option<Finding>, usize) {
        let c = &l.cand;
        let mut names = vec![c.size.name.clone()];
        if let Some((g, _, _)) = &c.grid {
            names.push(g.clone());
        }
        let own = names.len();
        for v in &values {
            if !names.contains(v) {
                names.push(v.clone());
            }
        }
        let Ok(start) = lin.apply(plant) else {
            return (None, 0);
        };
        // A replacement removes values (the viscous friction LuGre's σ2 takes over).
        names.retain(|n| start.parameters.contains_key(n));
        // The candidate plant's own initial positions (a nuisance of each model).
        let Some(fit) = fit_from(&start, conf, names.clone(), records, &oe, options) else {
            return (None, 0);
        };
        // The fitted cost replaces the linearised one even where it is higher: the
        // linearisation only predicts what the candidate can explain.
        if !fit.cost_after.is_finite() {
            return (None, fit.evaluations);
        }
        let mut found = values_of(c, l.beta);
        for (nm, v) in fit.names.iter().zip(&fit.fitted).take(own) {
            match found.iter_mut().find(|x| x.0 == *nm) {
                Some(x) => x.1 = *v,
                None => found.push((nm.clone(), *v)),
            }
        }
        let mut f = finding(l, found, fit.cost_after, own);
        f.confirmed = true;
        (Some(f), fit.evaluations)
    };
    let mut findings: Vec<Finding> = best
        .iter()
        .map(|l| finding(l, values_of(&l.cand, l.beta), l.sse, l.p))
        .collect();
    // Confirm by a nonlinear output-error fit of their parameters: the leading
    // `options.confirm` candidates and every one the linearisation calls significant (the
    // first screen), at most `options.confirm_max`, in parallel. The ranking is then that
    // of the fitted costs.
    let mut order: Vec<usize> = (0..findings.len()).collect();
    order.sort_by(|&a, &b| findings[a].delta_bic.total_cmp(&findings[b].delta_bic));
    let screened: Vec<usize> = order
        .iter()
        .enumerate()
        .filter(|&(rank, &i)| {
            (rank < options.confirm && findings[i].explained >= 0.01) || findings[i].significant
        })
        .map(|(_, &i)| i)
        .take(options.confirm_max.max(options.confirm))
        .collect();
    let confirmed: Vec<(usize, Option<Finding>, usize)> = screened
        .par_iter()
        .map(|&i| {
            let (f, sims) = confirm(&best[i], &findings[i]);
            (i, f, sims)
        })
        .collect();
    for (i, f, sims) in confirmed {
        simulations += sims;
        if let Some(f) = f {
            findings[i] = f;
        }
    }
    // The user's candidates: each added at its start values and its parameters fitted
    // beside the configuration's values, as a confirmation is.
    let (user, _) = super::candidates::for_plant(&options.candidates, plant)?;
    let fitted: Vec<(Finding, usize)> = user
        .par_iter()
        .map(|u| fit_candidate(u, plant, conf, &values, records, (&oe, options), (sst, n)))
        .collect();
    for (f, sims) in fitted {
        simulations += sims;
        findings.push(f);
    }
    let columns: Vec<&[f64]> = columns
        .into_iter()
        .chain(std::iter::repeat_n(&[][..], findings.len() - columns_len))
        .collect();
    // Candidates the data cannot tell apart: sensitivities nearly collinear.
    for i in 0..findings.len() {
        findings[i].alike = (0..findings.len())
            .filter(|&k| k != i && findings[k].explained > 0.0)
            .filter(|&k| cosine(columns[i], columns[k]).abs() >= ALIKE_COSINE)
            .map(|k| format!("{} on {}", findings[k].name, findings[k].joint))
            .collect();
    }
    // Structure outside the catalogue (a sparse model of the residual on a library's
    // sensitivities, confirmed by an output-error fit), only where no significant
    // catalogued candidate explains STRUCTURE_SEARCH_BELOW of the residual or leaves less
    // than FLOOR_FACTOR² times the noise's energy (σ̂² per sample of each joint; the
    // segments are each file's joints in turn): what a catalogued effect leaves is
    // searched once it is applied.
    let nf = conf.free.len();
    let noise_energy: f64 = segments
        .iter()
        .enumerate()
        .map(|(i, &len)| joints.get(i % nf).map_or(0.0, |j| j.noise * j.noise) * len as f64)
        .sum();
    let catalogue_suffices = findings.iter().filter(|f| f.significant).any(|f| {
        f.explained >= super::STRUCTURE_SEARCH_BELOW
            || sst * (1.0 - f.explained) <= FLOOR_FACTOR * FLOOR_FACTOR * noise_energy
    });
    // Searched where the position error is above the noise or the residual is not white
    // (the equation error's own sparse model was significant on the truth's data too: its
    // filtering and estimated velocities leave structure of their own, so it does not
    // decide where to search).
    let searched: Vec<bool> = (0..conf.free.len())
        .map(|a| {
            above.get(a).is_some_and(Option::is_some)
                || coloured.get(a).is_some_and(Option::is_some)
        })
        .collect();
    if !catalogue_suffices {
        let structures =
            structure_candidates(plant, conf, (&out, &yhat, &r), &searched, &oe, options)?;
        simulations += structures.1;
        findings.extend(structures.0);
    }
    // How the input was applied: the other holds, and a delay.
    let timing = timing_candidates(plant, &out, (&y, &r), sst, records)?;
    simulations += timing.1;
    findings.extend(timing.0);
    // The numerics' floor: nothing that explains less than it is significant.
    for f in &mut findings {
        if f.explained * sst <= step.floor_energy {
            f.significant = false;
        }
    }
    super::refuse_unphysical_signs(&mut findings);
    super::sort_findings(&mut findings);
    prefer_edits_among_equals(&mut findings);
    super::prefer_the_catalogue(&mut findings);
    Ok(OutputDiagnosis {
        configuration: conf.name.to_string(),
        findings,
        joints,
        samples: n,
        effective_samples: effective,
        above_noise: above.into_iter().flatten().collect(),
        not_white: coloured.into_iter().flatten().collect(),
        simulations,
        floor_share: if sst > 0.0 {
            step.floor_energy / sst
        } else {
            0.0
        },
        step,
        values_refit,
    })
}

/// The output-error fit of `names` of `start` (configuration `conf`) on `records`, from
/// each file's initial positions estimated for `start` where the options ask for it; None
/// when the problem cannot be set up or the fit fails.
fn fit_from(
    start: &Plant,
    conf: &'static generated::Configuration,
    names: Vec<String>,
    records: &[Record],
    oe: &crate::identify::output_error::OutputErrorOptions,
    options: &OutputOptions,
) -> Option<crate::identify::output_error::FitResult> {
    let problem =
        Problem::new(start, conf, names, records.to_vec(), &[], oe.clone()).and_then(|p| {
            if options.fit.estimate_initial {
                p.with_initial_positions_of(start)
                    .map_err(anyhow::Error::from)
            } else {
                Ok(p)
            }
        });
    problem.and_then(|p| p.fit(&|_| {})).ok()
}

/// The output-error fit of the candidate effect `u` added to `plant` at its start values:
/// its parameters, and `values` (the configuration's values) beside them, from each file's
/// initial positions; as a finding against the residual energy `sst` over `n` samples,
/// confirmed, with the simulations run. A candidate the plant refuses, or whose fit fails or
/// diverges, is a finding that explains nothing and says why in its meaning.
fn fit_candidate(
    u: &super::candidates::UserCandidate,
    plant: &Plant,
    conf: &'static generated::Configuration,
    values: &[String],
    records: &[Record],
    (oe, options): (
        &crate::identify::output_error::OutputErrorOptions,
        &OutputOptions,
    ),
    (sst, n): (f64, usize),
) -> (Finding, usize) {
    let failed = |why: &str, sims: usize| {
        let mut f = u.finding(&u.start, (sst, sst, n as f64));
        f.meaning = format!("{} (not tested: {why})", f.meaning);
        (f, sims)
    };
    let Ok(start) = u.plant(plant) else {
        return failed("the plant refused it", 0);
    };
    let mut names = u.spec.parameters.clone();
    for v in values {
        if !names.contains(v) {
            names.push(v.clone());
        }
    }
    let Some(fit) = fit_from(&start, conf, names, records, oe, options) else {
        return failed("its output-error fit failed", 0);
    };
    if !fit.cost_after.is_finite() {
        return failed("its output-error fit diverged", fit.evaluations);
    }
    let own: Vec<f64> = u
        .spec
        .parameters
        .iter()
        .zip(&u.start)
        .map(|(p, s)| {
            fit.names
                .iter()
                .position(|x| x == p)
                .map_or(*s, |i| fit.fitted[i])
        })
        .collect();
    let mut f = u.finding(&own, (fit.cost_after, sst, n as f64));
    f.confirmed = true;
    (f, fit.evaluations)
}

/// Per free joint of `conf` (in order), whether its stacked residual `r` (segments of
/// lengths `segments`, file by file, each file's free joints in order) is not white, with
/// the reason ([`super::not_white`]).
fn not_white_joints(
    m: &generated::Model,
    conf: &generated::Configuration,
    r: &[f64],
    segments: &[usize],
) -> Vec<Option<String>> {
    let nfree = conf.free.len().max(1);
    let mut start = 0;
    let mut by_joint: Vec<Vec<&[f64]>> = vec![Vec::new(); nfree];
    for (i, &len) in segments.iter().enumerate() {
        by_joint[i % nfree].push(&r[start..start + len]);
        start += len;
    }
    conf.free
        .iter()
        .zip(&by_joint)
        .map(|(&j, segs)| super::not_white(m.joints[j], segs))
        .collect()
}

/// Most library terms per joint whose output sensitivities the structure search simulates
/// (the ones whose equation-error columns are most aligned with the joint's equation
/// error).
pub const STRUCTURE_TERMS: usize = 24;

/// The findings of structure outside the catalogue ([`super::structure`]) and of the
/// built-ins beyond it, and the simulations run. Per free joint `searched` marks (its
/// position error above [`FLOOR_FACTOR`] σ̂, or its residual not white): the library's
/// terms (at most [`STRUCTURE_TERMS`], those most aligned with the joint's equation error,
/// cut-offs by residual analysis) are each added as a small torque u = β φ on the joint
/// and their output sensitivities ∂ŷ/∂β simulated. The best significant built-in the
/// terms span ([`super::structure::Named`]) is confirmed by an output-error fit of its own
/// parameters, named by its physics; each pair of searched joints gets a coupled motor's
/// friction ([`coupled_motor_candidates`]). The position residual's sparse model
/// on them ([`super::structure::sparse_model`]: stepwise on the BIC, polynomial
/// hierarchy) is written as a user-defined effect `structure_qj` (coefficients `sj_1`, …,
/// bounds ±10 times each coefficient's size) and confirmed by an output-error fit of its
/// coefficients, its figures those of the fitted plant. The equation error alone chose the
/// wrong support (q² + q + 1 for a cubic, measured on c3) and finds structure of its own
/// on the truth's data (its filtering and estimated velocities): it only ranks the terms
/// and sizes the probes here. Without an equation error (a file too short for the
/// filter) the library's first terms are probed at unit size.
///
/// # Errors
/// None beyond the plant's own simulation (kept as `Result` for the callers' `?`).
fn structure_candidates(
    plant: &Plant,
    conf: &'static generated::Configuration,
    (out, yhat, r): (&Outputs, &[f64], &[f64]),
    searched: &[bool],
    oe: &crate::identify::output_error::OutputErrorOptions,
    options: &OutputOptions,
) -> Result<(Vec<Finding>, usize)> {
    use crate::identify::equation_error::{Cutoff, EquationError};
    let m = plant.model;
    let records = &out.problem.records;
    let sst: f64 = r.iter().map(|x| x * x).sum();
    let n = r.len();
    if sst <= 0.0 {
        return Ok((Vec::new(), 0));
    }
    let above = |a: usize| searched.get(a).copied().unwrap_or(false);
    if !(0..conf.free.len()).any(above) {
        return Ok((Vec::new(), 0));
    }
    // The equation error, split by joint: its columns rank each joint's terms and set each
    // probe's size.
    let ee = EquationError::new(plant, conf, records, Cutoff::Residual)
        .ok()
        .and_then(|ee| {
            let e = ee.residuals(plant).ok()?;
            let by_joint = ee.by_joint(&e).0;
            Some((ee, by_joint))
        });
    let segments = out.segments();
    let mut simulations = 0;
    // Per joint searched: its index, the library terms to probe (indices), the library's
    // texts and each probe's size.
    type Search = (usize, Vec<usize>, (Vec<String>, Vec<bool>), Vec<f64>);
    let mut searches: Vec<Search> = Vec::new();
    for (a, &j) in conf.free.iter().enumerate() {
        if !above(a) {
            continue;
        }
        let lib = super::structure::library(j, conf.free, m.joints);
        let texts: Vec<String> = lib.iter().map(|t| t.text.clone()).collect();
        let lead: Vec<bool> = lib.iter().map(|t| !t.catalogued).collect();
        let mut order: Vec<usize> = (0..lib.len()).collect();
        let mut size = vec![1.0; lib.len()];
        if let Some((ee, by_joint)) = &ee {
            let fns: Vec<_> = lib
                .iter()
                .map(|t| move |q: &[f64], qd: &[f64], tau: &[f64]| t.value(conf.free, q, qd, tau))
                .collect();
            let refs: Vec<(usize, crate::identify::equation_error::TorqueFn)> = fns
                .iter()
                .map(|f| (a, f as crate::identify::equation_error::TorqueFn))
                .collect();
            if let Ok(columns) = ee.torque_columns(plant, &refs) {
                let cols: Vec<Vec<f64>> = columns
                    .iter()
                    .map(|c| ee.by_joint(c).0.swap_remove(a))
                    .collect();
                let ra = &by_joint[a];
                let align: Vec<f64> = cols.iter().map(|c| cosine(c, ra).abs()).collect();
                order.sort_by(|&x, &y| align[y].total_cmp(&align[x]));
                // A probe whose torque is 1e-3 of the joint's commanded torque (RMS):
                // the columns are torques over Kp s.
                for (k, c) in cols.iter().enumerate() {
                    let rms = rms(c);
                    if rms > 0.0 && rms.is_finite() {
                        size[k] = 1e-3 / rms;
                    }
                }
            }
        }
        order.truncate(STRUCTURE_TERMS);
        searches.push((j, order, (texts, lead), size));
    }
    // The output sensitivities of a joint's terms, each added as a small torque to `base`
    // whose simulated positions are `base_y`.
    let probe = |base: &Plant, base_y: &[f64], (j, order, (texts, lead), size): &Search| {
        let probes: Vec<Option<Vec<f64>>> = order
            .par_iter()
            .map(|&k| {
                let mut p = base.clone();
                let param = "lockstep_probe_beta";
                p.add_expression(
                    "lockstep_structure_probe",
                    vec![*j],
                    &format!("{param}*({})", texts[k]),
                    &[param.to_string()],
                )
                .ok()?;
                p.parameters.insert(param.into(), size[k]);
                let y = out.simulate(&p).ok()?;
                let col: Vec<f64> = y
                    .iter()
                    .zip(base_y)
                    .map(|(a, b)| (a - b) / size[k])
                    .collect();
                col.iter().all(|v| v.is_finite()).then_some(col)
            })
            .collect();
        let mut cols = Vec::new();
        let mut kept = Vec::new();
        let mut leads = Vec::new();
        for (&k, c) in order.iter().zip(probes) {
            if let Some(c) = c {
                cols.push(c);
                kept.push(texts[k].clone());
                leads.push(lead[k]);
            }
        }
        (cols, kept, leads)
    };
    // The structure as a finding, confirmed by an output-error fit of its coefficients
    // from `plant`, and the fitted plant.
    let confirm = |st: &super::structure::Structure| -> (Option<(Finding, Plant)>, usize) {
        let mut f = Finding::of_structure(plant, st, (sst, n), 0.0);
        let Ok(start) = f.apply(plant) else {
            return (None, 0);
        };
        let Some(fit) = fit_from(&start, conf, f.parameter_names(), records, oe, options) else {
            return (None, 0);
        };
        if !fit.cost_after.is_finite() {
            return (None, fit.evaluations);
        }
        for (v, fitted) in f.values.iter_mut().zip(&fit.fitted) {
            v.1 = *fitted;
        }
        for (e, fitted) in f.estimate.iter_mut().zip(&fit.fitted) {
            e.1 = *fitted;
        }
        let (delta_bic, explained) = super::bic(fit.cost_after, sst, n as f64, f.values.len());
        f.delta_bic = delta_bic;
        f.explained = explained;
        f.significant = super::significant(delta_bic, explained);
        f.confirmed = true;
        let Ok(fitted) = f.apply(plant) else {
            return (None, fit.evaluations);
        };
        (Some((f, fitted)), fit.evaluations)
    };
    // The built-ins the joint's terms span ([`super::structure::Named`]): the best one the
    // linearisation calls significant, confirmed by an output-error fit of its own
    // parameters, named by its physics.
    let named_candidate = |j: usize,
                           cols: &[Vec<f64>],
                           kept: &[String],
                           structure: Option<&Finding>|
     -> (Vec<Finding>, usize) {
        let joint = m.joints[j];
        let span = conf.free.iter().position(|&f| f == j).map_or(0.0, |a| {
            let (lo, hi) = records
                .iter()
                .flat_map(|rec| rec.q[a].iter())
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &x| {
                    (lo.min(x), hi.max(x))
                });
            hi - lo
        });
        let best = super::structure::named_fits(j, r, cols, kept, span)
            .into_iter()
            .filter(|(_, c, sse)| {
                let (delta_bic, explained) = super::bic(*sse, sst, n as f64, c.len());
                super::significant(delta_bic, explained)
            })
            .filter_map(|(named, c, _)| {
                // The structure's fitted coefficients of the built-in's terms, where it has
                // its leading term, are a better start than the linearisation at the
                // given plant (a cogging from there stopped at 17 σ, measured on c3).
                let terms = named.terms(j);
                let coefficient = |t: &String| {
                    let t = crate::names::expression_text(t, m.joints);
                    structure.and_then(|f| f.estimate.iter().find(|(x, _)| *x == t).map(|x| x.1))
                };
                let c = if coefficient(&terms[0]).is_some() {
                    terms
                        .iter()
                        .map(|t| coefficient(t).unwrap_or(0.0))
                        .collect()
                } else {
                    c
                };
                Some((named, named.effect(j, m.joints, &c, false)?))
            })
            .find(|(_, e)| {
                !plant.expressions.iter().any(|x| x.name == e.name)
                    && !e
                        .parameters
                        .iter()
                        .any(|p| plant.parameters.contains_key(p))
            });
        let Some((named, e)) = best else {
            return (Vec::new(), 0);
        };
        let u = super::candidates::UserCandidate {
            spec: crate::plant::ExpressionSpec {
                name: e.name,
                joints: vec![joint.to_string()],
                torque: e.torque,
                parameters: e.parameters,
            },
            meaning: named.meaning().to_string(),
            start: e.values,
            bounds: e.bounds,
        };
        let (mut f, sims) = fit_candidate(&u, plant, conf, &[], records, (oe, options), (sst, n));
        f.name = named.name();
        (vec![f], sims)
    };
    let y: Vec<f64> = r.iter().zip(yhat).map(|(a, b)| a + b).collect();
    // The structure of one search's probes (None when not significant or its fit
    // fails), and the simulations run.
    let structure_of = |search: &Search,
                        (cols, kept, leads): (&[Vec<f64>], &[String], &[bool])|
     -> (Option<Finding>, usize) {
        let mut sims = 0;
        let Some(st) = super::structure::sparse_model(search.0, r, &segments, cols, (kept, leads))
            .filter(|st| st.significant())
        else {
            return (None, sims);
        };
        let (first, s) = confirm(&st);
        sims += s;
        let Some((first, fitted)) = first else {
            return (None, sims);
        };
        // Once more, linearised at the fitted plant, where the sensitivities describe
        // what the structure does (at the given plant a large effect's linearisation
        // asks for extra terms: a cubic came with q̇³, q̇ and sin(4q) beside its
        // powers, measured on c3): the residual with the structure's own share put
        // back, y − ŷ(fitted) + Σ θ_k s_k(fitted), selected again.
        let Ok(y1) = out.simulate(&fitted) else {
            return (Some(first), sims);
        };
        sims += 1;
        let (cols1, kept1, leads1) = probe(&fitted, &y1, search);
        sims += cols1.len();
        let mut augmented: Vec<f64> = y.iter().zip(&y1).map(|(a, b)| a - b).collect();
        for ((text, _), (_, theta)) in first.estimate.iter().zip(&first.values) {
            if let Some(c) = kept1.iter().position(|t| t == text) {
                for (v, s) in augmented.iter_mut().zip(&cols1[c]) {
                    *v += theta * s;
                }
            }
        }
        let again = super::structure::sparse_model(
            search.0,
            &augmented,
            &segments,
            &cols1,
            (&kept1, &leads1),
        )
        .filter(|st2| {
            st2.significant() && {
                let mut a: Vec<&str> = st2.terms.iter().map(|t| t.text.as_str()).collect();
                let mut b: Vec<&str> = st.terms.iter().map(|t| t.text.as_str()).collect();
                a.sort();
                b.sort();
                a != b
            }
        });
        let Some(st2) = again else {
            return (Some(first), sims);
        };
        let (second, s) = confirm(&st2);
        sims += s;
        match second {
            Some((second, _)) if second.delta_bic < first.delta_bic => (Some(second), sims),
            _ => (Some(first), sims),
        }
    };
    let found: Vec<(Vec<Finding>, usize)> = searches
        .par_iter()
        .map(|search| {
            let (cols, kept, leads) = probe(plant, yhat, search);
            let mut sims = cols.len();
            let (structure, s) = structure_of(search, (&cols, &kept, &leads));
            sims += s;
            let (mut here, s) = named_candidate(search.0, &cols, &kept, structure.as_ref());
            sims += s;
            here.extend(structure);
            (here, sims)
        })
        .collect();
    simulations += found.iter().map(|c| c.1).sum::<usize>();
    let mut findings: Vec<Finding> = found.into_iter().flat_map(|c| c.0).collect();
    let (pairs, sims) =
        coupled_motor_candidates(plant, conf, (out, yhat, r), &above, (oe, options));
    simulations += sims;
    findings.extend(pairs);
    Ok((findings, simulations))
}

/// The inertia matrix the simulator integrates with (D_FF(q) and the effects' inertia,
/// NF × NF) at the first record's start: the scale of an inertia candidate's probe.
fn start_inertia(
    plant: &Plant,
    conf: &'static generated::Configuration,
    records: &[Record],
) -> Option<nalgebra::DMatrix<f64>> {
    let rec = records.first()?;
    let model = plant
        .simulator(conf.name, &rec.q_all, crate::plant::ConsistencyPolicy::Warn)
        .ok()?
        .model;
    let q0: Vec<f64> = conf.free.iter().map(|&j| rec.q_all[j]).collect();
    Some(model.inertia_matrix(&q0))
}

/// Smoothing speed ε (rad/s) of the coupled motor's friction tanh((q̇a + q̇b)/ε).
pub const COUPLED_MOTOR_EPSILON: f64 = 0.01;

/// The coupled motor of each pair of searched free joints (issue 54 item 2): a motor that
/// drives both through a differential turns at q̇a + q̇b, and its friction
/// Fm tanh((q̇a + q̇b)/ε) ([`COUPLED_MOTOR_EPSILON`]) and its rotor's inertia
/// Jm (q̈a + q̈b) are taken from both joints (the transmission's transpose; the inertia
/// enters the inertia matrix, [`crate::simulation::TorqueTerm::inertia`]). Each one's output
/// sensitivity is simulated (one probe: the friction at 1e-3 of joint a's command RMS, the
/// inertia at 1e-3 of the larger of the pair's diagonal entries of D(q) at the start);
/// where the linearised fit is significant the effect is confirmed by an output-error fit of
/// its parameter, as a user-defined effect `coupled_motor_qa_qb` (friction) or
/// `coupled_rotor_qa_qb` (inertia) on both joints. Returns the findings and the
/// simulations run.
fn coupled_motor_candidates(
    plant: &Plant,
    conf: &'static generated::Configuration,
    (out, yhat, r): (&Outputs, &[f64], &[f64]),
    above: &dyn Fn(usize) -> bool,
    (oe, options): (
        &crate::identify::output_error::OutputErrorOptions,
        &OutputOptions,
    ),
) -> (Vec<Finding>, usize) {
    let m = plant.model;
    let records = &out.problem.records;
    let sst: f64 = r.iter().map(|x| x * x).sum();
    let n = r.len();
    let nf = conf.free.len();
    // D(q) at the first record's start, for the inertia probe's size.
    let inertia = start_inertia(plant, conf, records);
    struct Variant {
        name: String,
        joints: [String; 2],
        param: String,
        torque: String,
        meaning: &'static str,
        label: String,
        size: f64,
    }
    let variants: Vec<Variant> = (0..nf)
        .flat_map(|a| (a + 1..nf).map(move |b| (a, b)))
        .filter(|&(a, b)| above(a) && above(b))
        .flat_map(|(a, b)| {
            let (ja, jb) = (conf.free[a], conf.free[b]);
            let (qa, qb) = (m.joints[ja], m.joints[jb]);
            let command = rms(&records
                .iter()
                .flat_map(|rec| rec.tau[a].iter().copied())
                .collect::<Vec<_>>());
            let d = inertia
                .as_ref()
                .map_or(0.0, |d| d[(a, a)].abs().max(d[(b, b)].abs()));
            [
                Variant {
                    name: format!("coupled_motor_{qa}_{qb}"),
                    joints: [qa.to_string(), qb.to_string()],
                    torque: format!(
                        "{}*tanh((qd_{qa} + qd_{qb})/{COUPLED_MOTOR_EPSILON})",
                        names::pair_parameter("Fm", qa, qb)
                    ),
                    param: names::pair_parameter("Fm", qa, qb),
                    meaning: "a motor driving both joints through a differential: its friction, at the motor's speed qd_a + qd_b, is taken from both",
                    label: format!("coupled-motor friction ({qa} + {qb})"),
                    size: 1e-3 * if command > 0.0 { command } else { 1.0 },
                },
                Variant {
                    name: format!("coupled_rotor_{qa}_{qb}"),
                    joints: [qa.to_string(), qb.to_string()],
                    torque: format!(
                        "{}*(qdd_{qa} + qdd_{qb})",
                        names::pair_parameter("Jm", qa, qb)
                    ),
                    param: names::pair_parameter("Jm", qa, qb),
                    meaning: "a motor driving both joints through a differential: its rotor's inertia, at the motor's acceleration qdd_a + qdd_b, is taken from both",
                    label: format!("coupled-motor inertia ({qa} + {qb})"),
                    size: 1e-3 * if d > 0.0 && d.is_finite() { d } else { 1.0 },
                },
            ]
        })
        .collect();
    let found: Vec<(Option<Finding>, usize)> = variants
        .par_iter()
        .map(|v| {
            if plant.expressions.iter().any(|x| x.name == v.name)
                || plant.parameters.contains_key(&v.param)
            {
                return (None, 0);
            }
            let mut probe = plant.clone();
            let spec = crate::plant::ExpressionSpec {
                name: v.name.clone(),
                joints: v.joints.to_vec(),
                torque: v.torque.clone(),
                parameters: vec![v.param.clone()],
            };
            if probe.add_expression_spec(&spec, "coupled motor").is_err() {
                return (None, 0);
            }
            probe.parameters.insert(v.param.clone(), v.size);
            let Ok(y) = out.simulate(&probe) else {
                return (None, 1);
            };
            let col: Vec<f64> = y.iter().zip(yhat).map(|(p, q)| (p - q) / v.size).collect();
            let Some((x, sse)) = super::fit(std::slice::from_ref(&col), r) else {
                return (None, 1);
            };
            let (delta_bic, explained) = super::bic(sse, sst, n as f64, 1);
            if !super::significant(delta_bic, explained) {
                return (None, 1);
            }
            let u = super::candidates::UserCandidate {
                spec,
                meaning: v.meaning.into(),
                start: vec![x[0]],
                bounds: vec![super::bounds_about(x[0], v.size)],
            };
            let (mut f, sims) =
                fit_candidate(&u, plant, conf, &[], records, (oe, options), (sst, n));
            f.name = v.label.clone();
            (Some(f), 1 + sims)
        })
        .collect();
    let sims = found.iter().map(|c| c.1).sum();
    (found.into_iter().filter_map(|c| c.0).collect(), sims)
}

/// ΔBIC differences below this are not worth more than a bare mention (Kass and Raftery
/// 1995, "Bayes factors", Table: 0–2).
pub const BARE_MENTION_DELTA_BIC: f64 = 2.0;

/// Among findings the data cannot tell apart ([`Finding::alike`]) whose ΔBIC differ by less
/// than [`BARE_MENTION_DELTA_BIC`], put one that changes a value the plant already has ahead
/// of one that adds an effect: the simpler model first. (A spring's rest angle moved by Δ is
/// exactly a torque offset of −Ks·Δ; the plant already has the spring.) `findings` is sorted
/// by ΔBIC.
fn prefer_edits_among_equals(findings: &mut [Finding]) {
    for i in 1..findings.len() {
        let mut k = i;
        while k > 0 {
            let (a, b) = (&findings[k - 1], &findings[k]);
            let tied = (b.delta_bic - a.delta_bic).abs() < BARE_MENTION_DELTA_BIC
                && a.alike.contains(&format!("{} on {}", b.name, b.joint));
            if tied && a.effect.is_some() && b.effect.is_none() && !b.values.is_empty() {
                findings.swap(k - 1, k);
                k -= 1;
            } else {
                break;
            }
        }
    }
}

/// Candidates whose sensitivities have |cos| at least this are reported together
/// ([`Finding::alike`]): the data cannot tell them apart.
pub const ALIKE_COSINE: f64 = 0.95;

fn cosine(a: &[f64], b: &[f64]) -> f64 {
    let ab: f64 = a.iter().zip(b).map(|(x, y)| x * y).sum();
    let aa: f64 = a.iter().map(|x| x * x).sum();
    let bb: f64 = b.iter().map(|x| x * x).sum();
    if aa > 0.0 && bb > 0.0 {
        ab / (aa * bb).sqrt()
    } else {
        0.0
    }
}

/// The input-timing candidates: every record's input held by each other [`Hold`] (no
/// fitted number), and a pure delay δ of the input (one number: linearised at δ = 0 by
/// central differences of ±dt/4, then simulated at δ̂ for its figures). Returns the
/// findings and the simulations run; `y` the stacked measurement, `r` the residual.
fn timing_candidates(
    plant: &Plant,
    out: &Outputs,
    (y, r): (&[f64], &[f64]),
    sst: f64,
    records: &[Record],
) -> Result<(Vec<Finding>, usize)> {
    let with = |problem: Problem| Outputs {
        problem,
        skip: out.skip,
    };
    let n = y.len() as f64;
    // SSE with the input applied as `p` says.
    let sse_of = |p: Problem| -> Option<f64> {
        let yhat = with(p).simulate(plant).ok()?;
        Some(y.iter().zip(&yhat).map(|(a, b)| (a - b).powi(2)).sum())
    };
    let mut findings = Vec::new();
    let mut simulations = 0;
    let used: Vec<Hold> = records
        .iter()
        .map(|r| out.problem.options().hold.unwrap_or(r.hold))
        .collect();
    for hold in Hold::ALL {
        if used.iter().all(|&h| h == hold) {
            continue;
        }
        simulations += 1;
        // A hold that fits no better than the one used is no candidate.
        let Some(sse) = sse_of(out.problem.with_hold(Some(hold))).filter(|&e| e < sst) else {
            continue;
        };
        let mut f = Finding::new(
            "all",
            format!("input hold {hold}"),
            None,
            None,
            vec![],
            (sse, sst, n, 0),
        );
        f.meaning = format!(
            "the torques were applied as {} between samples, not as the hold used ({}): {}",
            hold,
            used.iter()
                .map(|h| h.to_string())
                .collect::<Vec<_>>()
                .join(", "),
            hold_meaning(hold)
        );
        f.advice = Some(format!(
            "rerun with --hold {hold}, or write hold = \"{hold}\" in the files' side files"
        ));
        findings.push(f);
    }
    let dt = records.iter().map(|r| r.dt).fold(f64::INFINITY, f64::min);
    let delta = dt / 4.0;
    simulations += 2;
    if let (Ok(plus), Ok(minus)) = (
        with(out.problem.with_input_delay(delta)).simulate(plant),
        with(out.problem.with_input_delay(-delta)).simulate(plant),
    ) {
        let sens: Vec<f64> = plus
            .iter()
            .zip(&minus)
            .map(|(a, b)| (a - b) / (2.0 * delta))
            .collect();
        let ss: f64 = sens.iter().map(|x| x * x).sum();
        if ss > 0.0 {
            let d = (sens.iter().zip(r).map(|(a, b)| a * b).sum::<f64>() / ss)
                .clamp(-2.0 * dt, 2.0 * dt);
            simulations += 1;
            if let Some(sse) = sse_of(out.problem.with_input_delay(d)).filter(|&e| e < sst) {
                let mut f = Finding::new(
                    "all",
                    "input delay".into(),
                    None,
                    None,
                    vec![("delay".into(), d)],
                    (sse, sst, n, 1),
                );
                f.meaning = "the torques reached the joints later (delay > 0) than their time stamps: a transport delay, or a continuous signal reconstructed by a hold that lags it (a zero-order hold lags by half a sample)".into();
                f.advice = Some(
                    "check how the input was applied (--hold) and the time stamps of the torque and position columns".into(),
                );
                findings.push(f);
            }
        }
    }
    Ok((findings, simulations))
}

fn hold_meaning(hold: Hold) -> &'static str {
    match hold {
        Hold::Zoh => "each command held until the next, as a digital controller's output",
        Hold::Linear => "straight lines between the samples",
        Hold::Cubic | Hold::Bandlimited => {
            "a continuous signal sampled for the file (give the side file hold = \"bandlimited\")"
        }
    }
}

/// The candidates for the free joints of `conf` (grid points as separate candidates with
/// the same name).
fn catalogue(
    plant: &Plant,
    conf: &'static generated::Configuration,
    records: &[Record],
    base: &[Trajectory],
) -> Result<Vec<Candidate>> {
    use EffectKind as K;
    let m = plant.model;
    let mut out = Vec::new();
    let rms_tau: Vec<f64> = (0..conf.free.len())
        .map(|a| {
            rms(&records
                .iter()
                .flat_map(|r| r.tau[a].clone())
                .collect::<Vec<_>>())
        })
        .collect();
    let inertia = start_inertia(plant, conf, records);
    for (a, &j) in conf.free.iter().enumerate() {
        let has = |k: K| plant.has_effect(j, k);
        let law = plant.friction_law(j);
        let name = |s: &str| names::parameter(s, m.joints[j]);
        let value = |s: &str| plant.value(&name(s));
        // Positions as measured (a plant far off simulates a motion elsewhere, and the
        // equilibrium grid must cover where the joint really went); speeds as simulated
        // (the file holds no velocity).
        let q: Vec<f64> = records.iter().flat_map(|r| r.q[a].clone()).collect();
        let qd: Vec<f64> = base.iter().flat_map(|t| t.qd[a].clone()).collect();
        let (qmin, qmax) = q
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &x| {
                (l.min(x), h.max(x))
            });
        let span = (qmax - qmin).max(1e-6);
        let vmax = qd.iter().fold(0.0f64, |acc, v| acc.max(v.abs())).max(1e-9);
        let vrms = rms(&qd).max(1e-9);
        let tau = if rms_tau[a] > 0.0 { rms_tau[a] } else { 1e-3 };
        let dtau = 0.02 * tau;
        let big = 100.0 * tau;
        let size = |n: String, zero: f64, step: f64, lo: f64, hi: f64| Size {
            name: n,
            zero,
            step,
            lo,
            hi,
        };
        let add =
            |kind: K, s: Size, fixed: Vec<(String, f64)>, grid: Option<(String, f64, f64)>| {
                Candidate {
                    name: kind.to_string(),
                    kind,
                    joint: j,
                    from: None,
                    effect: Some(Effect::on(kind, j)),
                    replaces: None,
                    fixed,
                    size: s,
                    grid,
                    shifted: false,
                }
            };
        if law.is_none() {
            out.push(add(
                K::Coulomb,
                size(name("Fc"), 0.0, dtau, 0.0, big),
                vec![],
                None,
            ));
        }
        if !has(K::Viscous) && law != Some(K::Lugre) && law != Some(K::AsymmetricFriction) {
            out.push(add(
                K::Viscous,
                size(name("Fv"), 0.0, dtau / vrms, 0.0, big / vrms),
                vec![],
                None,
            ));
        }
        if !has(K::Offset) {
            out.push(add(
                K::Offset,
                size(name("offset"), 0.0, dtau, -big, big),
                vec![],
                None,
            ));
        }
        // Armature: the rotor's inertia through the gearing, on D(q)'s diagonal (a probe of
        // 1e-3 of the joint's entry at the start; up to 1000 times it: a rotor through a
        // gear of ratio N weighs N² times its own inertia).
        let d_jj = inertia.as_ref().map_or(0.0, |d| d[(a, a)]);
        if !has(K::Armature) && d_jj > 0.0 && d_jj.is_finite() {
            out.push(add(
                K::Armature,
                size(name("Ia"), 0.0, 1e-3 * d_jj, 0.0, 1e3 * d_jj),
                vec![],
                None,
            ));
        }
        // Backlash: the sensed position behind a play in the transmission; its sensitivity
        // at 0 is one-sided (the play is not negative), −1 or +1 by the last direction of
        // motion.
        if !has(K::Backlash) {
            out.push(add(
                K::Backlash,
                size(name("backlash"), 0.0, 1e-3 * span, 0.0, 0.25 * span),
                vec![],
                None,
            ));
        }
        // Stribeck / stiction: friction above the Coulomb level near zero velocity.
        let vs_grid: Vec<f64> = [0.01, 0.03, 0.1, 0.3].iter().map(|f| f * vmax).collect();
        let vs_range = (1e-3 * vmax, vmax);
        match law {
            Some(K::Lugre | K::Stribeck) => {
                let (fc, fs, vs) = (value("Fc")?, value("Fs")?, value("vs")?);
                let mut c = Candidate {
                    name: "stribeck".into(),
                    kind: K::Stribeck,
                    joint: j,
                    from: None,
                    effect: None,
                    replaces: None,
                    fixed: vec![],
                    size: size(name("Fs"), fs, dtau, fc, big),
                    grid: None,
                    shifted: false,
                };
                if fs - fc > 0.05 * fc.abs() && vs > 1e-6 * vmax {
                    // The law already has a Stribeck hump: its level may be off.
                    c.name = "stribeck (Fs off)".into();
                    out.push(c);
                } else {
                    for &v in &vs_grid {
                        let mut g = c.clone();
                        g.fixed = vec![(name("vs"), v)];
                        g.grid = Some((name("vs"), vs_range.0, vs_range.1));
                        out.push(g);
                    }
                }
            }
            Some(K::Coulomb) => {
                let fc = value("Fc")?;
                for &v in &vs_grid {
                    out.push(Candidate {
                        replaces: Some(K::Coulomb),
                        ..add(
                            K::Stribeck,
                            size(name("Fs"), fc, dtau, fc, big),
                            vec![(name("Fc"), fc), (name("vs"), v)],
                            Some((name("vs"), vs_range.0, vs_range.1)),
                        )
                    });
                }
            }
            Some(_) => {}
            None => {
                for &v in &vs_grid {
                    out.push(add(
                        K::Stribeck,
                        size(name("Fs"), 0.0, dtau, 0.0, big),
                        vec![(name("Fc"), 0.0), (name("vs"), v)],
                        Some((name("vs"), vs_range.0, vs_range.1)),
                    ));
                }
            }
        }
        // LuGre for a static law (Coulomb or Stribeck): the bristles' deflection before
        // sliding, z = g(v)/σ0 at steady state, shows as a compliance at every reversal
        // (presliding: Canudas de Wit et al., IEEE TAC 40(3), 1995). The static curve is
        // kept (Fc, Fs, vs; the joint's viscous friction becomes σ2), σ1 starts at 0, and
        // σ0 is scanned where the deflection is 0.3 % to 10 % of the motion's span. No
        // value of σ0 gives back the static law (it is the limit σ0 → ∞), so the candidate
        // is screened from its own difference at each grid point (`shifted`).
        if matches!(law, Some(K::Coulomb | K::Stribeck)) {
            let fc = value("Fc")?;
            let (fs, vs) = if law == Some(K::Stribeck) {
                (value("Fs")?, value("vs")?)
            } else {
                (fc, 0.1 * vmax)
            };
            let fv = if has(K::Viscous) { value("Fv")? } else { 0.0 };
            if fc > 0.0 && fs > 0.0 && vs > 0.0 {
                for f in [0.003, 0.01, 0.03, 0.1] {
                    let sigma0 = fc / (f * span);
                    out.push(Candidate {
                        name: "lugre".into(),
                        replaces: law,
                        shifted: true,
                        ..add(
                            K::Lugre,
                            size(
                                name("sigma0"),
                                sigma0,
                                0.2 * sigma0,
                                fc / span,
                                fc / (1e-3 * span),
                            ),
                            vec![
                                (name("Fc"), fc),
                                (name("Fs"), fs),
                                (name("vs"), vs),
                                (name("sigma1"), 0.0),
                                (name("sigma2"), fv),
                            ],
                            None,
                        )
                    });
                }
            }
        }
        // Equilibrium positions: the quantiles of the motion and beyond either end.
        let qeq_grid: Vec<f64> = super::apply::EQUILIBRIUM_QUANTILES
            .iter()
            .map(|&f| quantile(&q, f))
            .chain([qmin - span, qmax + span])
            .collect();
        let qeq_range = (qmin - 3.0 * span, qmax + 3.0 * span);
        let existing_qeq = plant.parameters.get(&name("qeq")).copied();
        if !has(K::Spring) {
            let s = size(name("Ks"), 0.0, dtau / span, 0.0, big / span);
            match (has(K::FrictionBias), existing_qeq) {
                (true, Some(_)) => out.push(add(K::Spring, s, vec![], None)),
                _ => {
                    for &g in &qeq_grid {
                        out.push(add(
                            K::Spring,
                            s.clone(),
                            vec![(name("qeq"), g)],
                            Some((name("qeq"), qeq_range.0, qeq_range.1)),
                        ));
                    }
                }
            }
        }
        // An existing equilibrium position off (a spring's rest angle, shared with a
        // friction bias on the joint): re-estimated over the measured motion.
        if let (true, Some(qeq)) = (has(K::Spring) || has(K::FrictionBias), existing_qeq) {
            let kind = if has(K::Spring) {
                K::Spring
            } else {
                K::FrictionBias
            };
            out.push(Candidate {
                name: format!("{kind} (qeq off)"),
                kind,
                joint: j,
                from: None,
                effect: None,
                replaces: None,
                fixed: vec![],
                size: size(name("qeq"), qeq, 0.01 * span, qeq_range.0, qeq_range.1),
                grid: None,
                shifted: false,
            });
        }
        if !has(K::FrictionBias) && (law.is_some() || has(K::Viscous)) {
            let s = size(name("FrictionBias"), 1.0, 0.05, 0.0, 20.0);
            match (has(K::Spring), existing_qeq) {
                (true, Some(_)) => out.push(add(K::FrictionBias, s, vec![], None)),
                _ => {
                    for &g in &qeq_grid[..super::apply::EQUILIBRIUM_QUANTILES.len()] {
                        out.push(add(
                            K::FrictionBias,
                            s.clone(),
                            vec![(name("qeq"), g)],
                            Some((name("qeq"), qmin, qmax)),
                        ));
                    }
                }
            }
        }
        // Tendon input coupling from each other driven free joint: a new one, or an
        // existing one's gain off (its sign flipped included: the range spans both signs).
        for (b, &k) in conf.free.iter().enumerate() {
            if k == j || rms_tau[b] <= 0.0 {
                continue;
            }
            let ratio = tau / rms_tau[b];
            if plant.has_coupling(k, j) {
                let g = plant.value(&names::coupling_gain(m.joints[k], m.joints[j]))?;
                let reach = 100.0 * ratio.max(g.abs());
                out.push(Candidate {
                    name: format!("input_coupling from {} (G off)", m.joints[k]),
                    kind: K::InputCoupling,
                    joint: j,
                    from: Some(k),
                    effect: None,
                    replaces: None,
                    fixed: vec![],
                    size: size(
                        names::coupling_gain(m.joints[k], m.joints[j]),
                        g,
                        0.02 * ratio,
                        -reach,
                        reach,
                    ),
                    grid: None,
                    shifted: false,
                });
                continue;
            }
            out.push(Candidate {
                name: format!("input_coupling from {}", m.joints[k]),
                kind: K::InputCoupling,
                joint: j,
                from: Some(k),
                effect: Some(Effect::coupling(k, j)),
                replaces: None,
                fixed: vec![],
                size: size(
                    names::coupling_gain(m.joints[k], m.joints[j]),
                    0.0,
                    0.02 * ratio,
                    -100.0 * ratio,
                    100.0 * ratio,
                ),
                grid: None,
                shifted: false,
            });
        }
        // Plant gain: an error of the existing gain, or a gain where there is none.
        if has(K::Gain) {
            let kp = value("Kp")?;
            out.push(Candidate {
                name: "gain (Kp off)".into(),
                kind: K::Gain,
                joint: j,
                from: None,
                effect: None,
                replaces: None,
                fixed: vec![],
                size: size(name("Kp"), kp, 0.01 * kp.abs(), 0.1 * kp, 10.0 * kp),
                grid: None,
                shifted: false,
            });
        } else {
            out.push(add(
                K::Gain,
                size(name("Kp"), 1.0, 0.01, 0.1, 10.0),
                vec![],
                None,
            ));
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::bic;

    #[test]
    fn quantiles_and_bic() {
        let v = [3.0, 1.0, 2.0, 5.0, 4.0];
        assert_eq!(quantile(&v, 0.0), 1.0);
        assert_eq!(quantile(&v, 0.5), 3.0);
        assert_eq!(quantile(&v, 1.0), 5.0);
        // Halving the residual energy over 100 samples with one number: 100 ln ½ + ln 100.
        let (d, e) = bic(50.0, 100.0, 100.0, 1);
        assert!((d - (100.0 * 0.5f64.ln() + 100f64.ln())).abs() < 1e-12);
        assert!((e - 0.5).abs() < 1e-15);
    }
}
