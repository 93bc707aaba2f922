//! Locking sequences (thesis 4.2–4.4): the method of isolated joints (c1..c7, Table 4.2)
//! and the method of coupling joints (k1..k5, Table 4.6), each step an output-error fit
//! ([`super::output_error`]) of the parameters that appear first in its configuration,
//! with everything identified earlier held at its fitted value.
//!
//! Which rigid-body quantities a step identifies comes from the generated equations
//! ([`super::identifiability::occurrence`], Figure 4.2); an effect's parameters are
//! identified at the first step where its joint (both joints, for an input coupling) is
//! free. After every step the updated plant and the report are written atomically, so an
//! interrupted run (Ctrl-C) leaves the last completed step's results intact.

use super::identifiability::{
    occurrence, spanning_symbols, spanning_symbols_across, structural_companions, Occurrence,
};
use super::joint::JointProblem;
use super::output_error::{
    scales_with_the_gain, EarlierInformation, FitResult, OutputErrorOptions, Problem, Progress,
    Record, Residuals, Statistics,
};
use crate::files::write_all_atomic;
use crate::measurement::{check_sampling, Table};
use crate::plant::Plant;
use anyhow::{bail, Context, Result};
use generated::{Configuration, Model};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

mod balance;
mod data;
mod earlier_refit;
mod final_check;
mod gain_families;
mod initial_positions;
mod refinements;
mod release;
mod steps;
mod tie_reach;
mod warm_ups;
pub use balance::*;
pub use data::*;
pub use earlier_refit::*;
pub use final_check::*;
pub use gain_families::*;
pub use initial_positions::*;
pub use refinements::*;
pub use release::*;
use steps::*;
pub use tie_reach::*;
pub use warm_ups::*;

/// One step of a locking sequence.
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct Step {
    /// Configuration name.
    pub config: String,
    /// Free joints (model indices).
    pub free: Vec<usize>,
    /// Joints free here for the first time (weight λ in the cost).
    pub interest: Vec<usize>,
    /// Parameters fitted here: rigid-body quantities, then effect parameters.
    pub fitted: Vec<String>,
    /// Of `fitted`, the values carried from earlier steps: rigid-body symbols that entered
    /// there only in exact combinations with others (their base parameters,
    /// [`structural_companions`]; known from the plan), or — added by [`run`] — that the
    /// fit did not call identifiable, which stay free until a configuration determines
    /// them; and, under [`SequenceOptions::earlier_information`], the plant-gain scale
    /// families of joints that earlier steps left apart and this step frees together
    /// ([`gain_families_carried_into`]).
    pub carried: Vec<String>,
    /// Parameters that first appear here but are held (bounds with lower = upper).
    pub held: Vec<String>,
    /// Rigid-body symbols of this step held at their values because the fitted ones span
    /// the configuration's base parameters without them ([`RigidBodyFit::Spanning`],
    /// [`spanning_symbols`]); they stay undetermined for the later steps.
    pub tied_held: Vec<String>,
}

/// Which rigid-body symbols a step fits (`lockstep identify sequence --rigid-body`, default
/// [`RigidBodyFit::Spanning`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, serde::Deserialize)]
pub enum RigidBodyFit {
    /// Every symbol the step identifies or carries; exact ties among them are left to the
    /// optimiser and resolved afterwards by the least change.
    All,
    /// A set that spans the configuration's base parameters ([`spanning_symbols`]); the
    /// rest are held at their values: the same dynamics within reach, without the exact
    /// ties (c5 of the isolated method: 42 symbols appear, 3 base parameters where its
    /// files hold the locked joints).
    Spanning,
}

/// The steps of sequence `sequence` of the plant's model, from step `only` alone if given.
///
/// # Errors
/// Unknown sequence or step (the known ones listed); a rigid-body quantity the step
/// identifies without a value in the plant.
pub fn plan(plant: &Plant, sequence: &str) -> Result<Vec<Step>> {
    plan_with(plant, sequence, &occurrence(plant.model))
}

/// [`plan`] with the model's occurrence table `occ` already computed.
fn plan_with(plant: &Plant, sequence: &str, occ: &Occurrence) -> Result<Vec<Step>> {
    let model = plant.model;
    let Some(seq) = occ.sequences.iter().find(|s| s.name == sequence) else {
        bail!(
            "model '{}' has no locking sequence '{sequence}' (it has: {})",
            model.name,
            occ.sequences
                .iter()
                .map(|s| s.name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        );
    };
    let mut seen_free: Vec<usize> = Vec::new();
    let mut effect_done: Vec<String> = Vec::new();
    let mut steps = Vec::new();
    // Rigid-body symbols that the steps so far could not separate from others.
    let mut tied: Vec<String> = Vec::new();
    for (cname, first) in &seq.steps {
        let conf = crate::util::configuration(model, cname)?;
        let interest: Vec<usize> = conf
            .free
            .iter()
            .copied()
            .filter(|j| !seen_free.contains(j))
            .collect();
        let mut names: Vec<String> = Vec::new();
        for s in first {
            if !plant.parameters.contains_key(s) {
                bail!(
                    "{}: step '{cname}' identifies '{s}' but the plant gives it no value (give link '{}' in the model file's symbols)",
                    plant.name(),
                    link_of(model, s)
                );
            }
            names.push(s.clone());
        }
        let carried = carried_into(&tied, occ, cname, &names);
        names.extend(carried.iter().cloned());
        for e in &plant.effects {
            if !e.acts_with(conf.free) {
                continue;
            }
            for n in e.parameter_names(model.joints) {
                if !effect_done.contains(&n) {
                    effect_done.push(n.clone());
                    names.push(n);
                }
            }
        }
        for n in plant.expression_parameters_with(conf.free) {
            if !effect_done.contains(&n) {
                effect_done.push(n.clone());
                names.push(n);
            }
        }
        let (held, fitted): (Vec<String>, Vec<String>) = names
            .into_iter()
            .partition(|n| plant.bounds.get(n).is_some_and(|&(lo, hi)| lo == hi));
        seen_free.extend(interest.iter().copied());
        let companions = structural_companions(plant, conf, &fitted, &bound_width(plant, &fitted))?;
        tied.retain(|s| !fitted.contains(s));
        for (n, c) in fitted.iter().zip(&companions) {
            if !c.is_empty() {
                tied.push(n.clone());
            }
        }
        steps.push(Step {
            config: cname.clone(),
            free: conf.free.to_vec(),
            interest,
            fitted,
            carried,
            held,
            tied_held: Vec::new(),
        });
    }
    Ok(steps)
}

/// Width of the bounds of `names[i]` in `plant` (1 for a name without bounds; never 0): the
/// spread the user gave each value, the unit of the identifiability checks.
fn bound_width<'a>(plant: &'a Plant, names: &'a [String]) -> impl Fn(usize) -> f64 + 'a {
    move |i| {
        plant
            .bounds
            .get(&names[i])
            .map_or(1.0, |&(lo, hi)| (hi - lo).abs().max(1e-300))
    }
}

/// Of the `candidates` left undetermined by earlier steps, those that appear in
/// configuration `config`'s equations and are not among its `fitted` already: the step
/// fits them again.
fn carried_into(
    candidates: &[String],
    occ: &Occurrence,
    config: &str,
    fitted: &[String],
) -> Vec<String> {
    candidates
        .iter()
        .filter(|n| occ.appears_in(n, config) && !fitted.contains(n))
        .cloned()
        .collect()
}

fn link_of(model: &Model, symbol: &str) -> String {
    model
        .inertial_symbols
        .iter()
        .position(|s| *s == symbol)
        .map(|i| model.links[model.symbol_link[i]].to_string())
        .unwrap_or_else(|| "?".into())
}

/// What a sequence run did, step by step.
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct SequenceReport {
    /// Sequence name.
    pub sequence: String,
    /// The plant file started from.
    pub plant: String,
    /// Settings.
    pub options: OutputErrorOptions,
    /// Completed steps.
    pub steps: Vec<StepReport>,
    /// The joint fit of the steps ([`JointFitMode`]), when run: its `step` lists every
    /// configuration's free joints and the parameters fitted; its fit's statistics are
    /// those of all the files.
    pub joint: Option<StepReport>,
    /// Files not used, with the reason.
    pub ignored: Vec<String>,
    /// What reading did to the files' rows: repeats dropped, stale rows, uneven times
    /// resampled ([`crate::measurement::sampling`]).
    #[serde(default)]
    pub data_notes: Vec<String>,
    /// The plant written on every file of the steps the run fitted
    /// ([`final_check`]; empty for a run of one step, and in reports written before
    /// stop 83).
    #[serde(default)]
    pub final_check: Vec<FinalCheck>,
    /// The values a step called identifiable that the plant written holds elsewhere
    /// ([`moved_since`]).
    #[serde(default)]
    pub moved_since: Vec<MovedValue>,
}

impl SequenceReport {
    /// The completed steps' configurations, e.g. "k1, k2".
    pub fn step_list(&self) -> String {
        self.steps
            .iter()
            .map(|s| s.step.config.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// One completed step.
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct StepReport {
    /// The plan.
    pub step: Step,
    /// The fit.
    pub fit: FitResult,
    /// Links whose fitted rigid-body symbols leave them physically impossible (mass ≤ 0
    /// or inertia not positive definite), from [`impossible_links`]: the fit is valid for
    /// this configuration's data, but the configurations named there cannot be simulated.
    pub impossible: Vec<String>,
    /// With [`OutputErrorOptions::carried_prior`]: the carried symbols held to their values
    /// by a prior, with its standard deviation (SI; the earlier step's standard error).
    pub carried_prior: Vec<(String, f64)>,
    /// The release of held values ([`SequenceOptions::release_held`]), when tried.
    pub release: Option<Release>,
    /// The reach across held ties ([`StepRefit::reach_across_held_ties`]), when tried.
    pub tie_reach: Option<TieReach>,
    /// The balanced refit ([`SequenceOptions::balance`], [`StepRefit::balance`]), when tried.
    pub balance: Option<Balance>,
    /// The warm-up start ([`SequenceOptions::warm_up_start`], [`StepRefit::warm_up_start`]),
    /// when tried (absent from reports written before stop 82).
    #[serde(default)]
    pub warm_up_start: Option<WarmUpStart>,
    /// The initial-positions refit ([`SequenceOptions::initial_positions_refit`],
    /// [`StepRefit::refit_initial_positions`]), when tried (absent from reports written
    /// before stop 83).
    #[serde(default)]
    pub initial_positions_refit: Option<InitialPositionsRefit>,
    /// The warm-up start run because the residual at the floor was not white
    /// ([`StepRefit::whiteness_start`], with [`SequenceOptions::warm_up_start`]), when run
    /// (absent from reports written before stop 84).
    #[serde(default)]
    pub whiteness_start: Option<WhitenessStart>,
    /// Whether the step was fitted under the earlier steps' information
    /// ([`SequenceOptions::earlier_information`]; false for the first step).
    #[serde(default)]
    pub earlier_information: bool,
    /// The values this step's files do not see that the earlier steps' information moved
    /// after it: (name, before, after), SI.
    #[serde(default)]
    pub following: Vec<(String, f64, f64)>,
    /// Whether `following` was reverted: the sum over the earlier steps' files of their
    /// worst RMS / σ̂ was higher with it than without.
    #[serde(default)]
    pub following_reverted: bool,
    /// The earlier steps whose files the plant no longer reproduced after this step, and
    /// the refit of their values this step does not see ([`EarlierRefit`]).
    #[serde(default)]
    pub earlier_refits: Vec<EarlierRefit>,
    /// This step fitted once more with the earlier steps whose files it left off although
    /// it saw every value they fitted ([`JointRefit`]), when run.
    #[serde(default)]
    pub joint_refit: Option<JointRefit>,
    /// This step's information where a later step's refit of its files left its values
    /// ([`EarlierRefit::information`]), which replaces the fit's own in the priors of the
    /// steps after that.
    #[serde(default)]
    pub information_now: Option<super::output_error::Information>,
}

impl StepReport {
    /// The report of `step` fitted as `fit`, with nothing else recorded (no impossible
    /// link, refinement, following or refit).
    pub fn of(step: Step, fit: FitResult) -> StepReport {
        StepReport {
            step,
            fit,
            impossible: Vec::new(),
            carried_prior: Vec::new(),
            release: None,
            tie_reach: None,
            balance: None,
            warm_up_start: None,
            initial_positions_refit: None,
            whiteness_start: None,
            earlier_information: false,
            following: Vec::new(),
            following_reverted: false,
            earlier_refits: Vec::new(),
            joint_refit: None,
            information_now: None,
        }
    }

    /// This step's information for the later steps' priors: where a later refit left its
    /// values, else at its fit.
    pub fn information(&self) -> Option<&super::output_error::Information> {
        self.information_now
            .as_ref()
            .or(self.fit.statistics.information.as_ref())
    }
}

/// Links that `plant` leaves physically impossible ([`crate::plant::Finding::is_blocking`])
/// among those with a symbol in `fitted`, one line each: the finding, the fitted symbols
/// of the link, and the model's configurations whose equations contain the link (their
/// inertia matrix D(q) may be indefinite, and a simulation then fails at once).
///
/// # Errors
/// A rigid-body parameter without a value (named).
pub fn impossible_links(plant: &Plant, fitted: &[String]) -> Result<Vec<String>> {
    let m = plant.model;
    let findings = plant.consistency(&plant.barycentric(None)?, None);
    let mut out = Vec::new();
    for f in findings.iter().filter(|f| f.is_blocking()) {
        let Some(l) = m.links.iter().position(|n| *n == f.link) else {
            continue;
        };
        let mine: Vec<&str> = plant
            .link_symbols(l)
            .into_iter()
            .filter(|n| fitted.iter().any(|x| x == n))
            .collect();
        if mine.is_empty() {
            continue;
        }
        let configs: Vec<&str> = m
            .configurations
            .iter()
            .filter(|c| plant.configuration_has_link(c, l))
            .map(|c| c.name)
            .collect();
        out.push(format!(
            "{f} (fitted here: {}; configurations with this link: {})",
            mine.join(", "),
            configs.join(", ")
        ));
    }
    Ok(out)
}

/// Settings of a sequence run.
#[derive(Debug, Clone)]
pub struct SequenceOptions {
    /// Sequence name in the model file (`isolated`, `coupled`).
    pub sequence: String,
    /// Run this step only (the plant must hold the earlier steps' values).
    pub only: Option<String>,
    /// Fit settings.
    pub fit: OutputErrorOptions,
    /// Largest motion (rad) of a locked joint's measured position.
    pub locked_tolerance: f64,
    /// Output directory: `plant.toml`, `report.md`, `report.json`.
    pub out: PathBuf,
    /// Which rigid-body symbols each step fits.
    pub rigid_body: RigidBodyFit,
    /// Whether a joint fit of the steps follows (or replaces) the step-by-step fits.
    pub joint: JointFitMode,
    /// Release held values where a step ends above the noise floor
    /// ([`StepRefit::release_held`]): the values earlier steps fitted that this step's data see
    /// better than those steps did (ρ > [`RELEASE_INFORMATION`]) are fitted again, under a
    /// prior of their recorded standard errors.
    pub release_held: bool,
    /// Reach across held ties where a step ends above the noise floor with a spanning
    /// rigid-body symbol on a bound ([`StepRefit::reach_across_held_ties`]).
    pub tie_reach: bool,
    /// Balanced refit after every step whose joints of interest carry a weight other than
    /// the rest's ([`StepRefit::balance`]): the whole files once more with every free joint
    /// weighted 1, kept when the worst free joint's RMS / σ̂ falls.
    pub balance: bool,
    /// A second start through the warm-ups where a step's fit through the growing horizons
    /// ends above the noise floor ([`StepRefit::warm_up_start`]), or at the floor with a
    /// residual that is not white ([`StepRefit::whiteness_start`]); the lower cost is kept.
    pub warm_up_start: bool,
    /// After the warm-up start, the step's kept minimum, where at the noise floor, fitted
    /// once more with the initial positions estimated
    /// ([`StepRefit::refit_initial_positions`]); kept where the cost falls. No effect
    /// where [`OutputErrorOptions::estimate_initial_positions`] estimates them in every
    /// start already.
    pub initial_positions_refit: bool,
    /// Each step fitted under the earlier steps' information ([`EarlierInformation`]: the
    /// second-order expansion of their files' costs), every value its files do not see
    /// moved after it to the earlier costs' conditional minimum
    /// ([`EarlierInformation::following`]): so that a step that refits a carried symbol
    /// keeps what earlier files determined (c4 of the isolated method refits I7_22, which
    /// c2 sees only over Kp_q5).
    pub earlier_information: bool,
    /// After the run's last step (after every step under
    /// [`SequenceOptions::earlier_information`]), the earlier steps whose files the plant
    /// no longer reproduces (worst free joint above 1.02 × its own end figure) refitted:
    /// the values only their files see, on them (`refit_earlier_steps`), and where the
    /// last step's files see every value they fitted, those steps and the last fitted
    /// together on all their files ([`joint_refit`]). Every coupled step frees the joints
    /// of the one before, so the last step refits every value they fitted on its own files
    /// and can leave their locked configurations' combinations off (held-out seed 11: k3's
    /// files at 3.42 σ̂ after k4; the sensitivities record, stop 89).
    pub earlier_refit: bool,
    /// Continue the sequence recorded in `out` ([`previous_report`]): the steps its report
    /// lists as completed are skipped; the plant given to [`run`] should be `out`'s
    /// `plant.toml` ([`resume_plant`]).
    pub resume: bool,
}

impl SequenceOptions {
    /// The preset of a locking sequence: `sequence` (`isolated` or `coupled`, the model
    /// file's names) with [`OutputErrorOptions::isolated`] or [`OutputErrorOptions::coupled`]
    /// (any other name: the coupled fit), every step of it, written to `out`; locked joints
    /// may move 0.01 rad; spanning rigid-body symbols; no joint fit; the warm-up start where
    /// the horizons end above the floor, then the initial-positions refit; held values
    /// released, ties reached across and the balanced refit after each step; the earlier
    /// steps' information for the isolated method; the earlier steps' files checked and
    /// refitted after the last step (after each under the earlier information).
    pub fn preset(sequence: &str, out: PathBuf) -> Self {
        SequenceOptions {
            sequence: sequence.to_string(),
            only: None,
            fit: OutputErrorOptions::for_sequence(sequence),
            locked_tolerance: 0.01,
            out,
            rigid_body: RigidBodyFit::Spanning,
            joint: JointFitMode::Off,
            release_held: true,
            tie_reach: true,
            balance: true,
            warm_up_start: true,
            initial_positions_refit: true,
            earlier_information: sequence == "isolated",
            earlier_refit: true,
            resume: false,
        }
    }
}

/// The report a run of `sequence` left in `out` (`report.json`), if any. Its completed steps
/// are kept by the next run into `out` (a step run alone with `--config` adds to them, it
/// does not replace them).
///
/// # Errors
/// `report.json` exists but is not readable as a report; it is from another sequence.
pub fn previous_report(out: &Path, sequence: &str) -> Result<Option<SequenceReport>> {
    let path = out.join("report.json");
    if !path.exists() {
        return Ok(None);
    }
    let text = std::fs::read_to_string(&path)
        .with_context(|| format!("{}: cannot read", path.display()))?;
    let report: SequenceReport = crate::util::from_json_with_nan(&text)
        .with_context(|| format!("{}: not a sequence report of this version", path.display()))?;
    if report.sequence != sequence {
        bail!(
            "{}: a report of the '{}' sequence, not '{sequence}': give another --out",
            path.display(),
            report.sequence
        );
    }
    Ok(Some(report))
}

/// The plant a resumed run starts from: `out/plant.toml`, written by the last completed
/// step.
///
/// # Errors
/// It does not exist (nothing to resume) or is not a valid plant file.
pub fn resume_plant(out: &Path) -> Result<Plant> {
    let path = out.join("plant.toml");
    if !path.exists() {
        bail!(
            "--resume: {} does not exist: {} holds no interrupted run",
            path.display(),
            out.display()
        );
    }
    Plant::load(&path)
}

/// The joint fit of a sequence's steps (`lockstep identify sequence --joint-fit`,
/// [`super::joint::JointProblem`]): every parameter the steps fit, on every step's files at
/// once, from the values the steps left. It covers the steps of the sequence up to the
/// last one run (all, or up to `--config`'s).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum JointFitMode {
    /// The steps only (the thesis).
    Off,
    /// The steps, then the joint fit.
    After,
    /// The joint fit alone, from the plant's values (a plant a sequence run wrote).
    Only,
}

/// A run's inputs, checked before the first fit ([`check_inputs`]).
struct CheckedInputs {
    /// Each step's problem, on its files, with the plant's values.
    steps: Vec<Problem>,
    /// The joint fit's files per configuration.
    joint: Vec<(&'static Configuration, Vec<Record>)>,
    /// Files not used, with the reason.
    ignored: Vec<String>,
    /// What reading did to the files' rows ([`read_record_with_notes`]).
    notes: Vec<String>,
    /// The steps an earlier run completed (kept in the report) whose files are in the data:
    /// their problems, for the refit of their files after a later step
    /// ([`refit_earlier_steps`]).
    earlier: Vec<(String, Problem)>,
}

/// Everything a run needs, checked before its first fit: every step (and every step of the
/// joint fit) has measurement files of its configuration in `data`, and each step's
/// problem can be set up on them (bounds of every fitted value, including the symbols the
/// plant still lists as undetermined); the files of no step are listed as ignored.
///
/// # Errors
/// A step without files (naming the step, `data` and the files found), or a problem that
/// cannot be set up (naming the step).
fn check_inputs(
    plant: &Plant,
    data: &[PathBuf],
    opts: &SequenceOptions,
    occ: &Occurrence,
    steps: &[Step],
    joint_steps: &[Step],
    completed: &[StepReport],
) -> Result<CheckedInputs> {
    let model = plant.model;
    let (files, mut ignored) = discover(data, model)?;
    let searched = data
        .iter()
        .map(|d| d.display().to_string())
        .collect::<Vec<_>>()
        .join(", ");
    // Each configuration's files read once (a step and the joint fit share them), and what
    // reading did to them noted once.
    let mut notes = Vec::new();
    let mut read: BTreeMap<String, (&'static Configuration, Vec<Record>)> = BTreeMap::new();
    let mut records_for = |config: &str| -> Result<(&'static Configuration, Vec<Record>)> {
        if let Some((conf, recs)) = read.get(config) {
            return Ok((*conf, recs.clone()));
        }
        let (conf, recs, said) = records_of(&files, model, config, opts.locked_tolerance)?;
        notes.extend(said);
        read.insert(config.to_string(), (conf, recs.clone()));
        Ok((conf, recs))
    };
    let mut checked: Vec<Problem> = Vec::new();
    for s in steps {
        let (conf, recs) = records_for(&s.config)?;
        if recs.is_empty() {
            let found = if files.is_empty() {
                "none".to_string()
            } else {
                files
                    .iter()
                    .map(|f| format!("{} ({})", f.path.display(), f.config))
                    .collect::<Vec<_>>()
                    .join(", ")
            };
            bail!(
                "step '{}': no measurement file of configuration '{}' in {searched} (files found: {found})",
                s.config,
                s.config,
            );
        }
        // With the symbols the plant file says are still undetermined, so that their
        // bounds are checked here too.
        let mut fitted = s.fitted.clone();
        fitted.extend(carried_into(&plant.undetermined, occ, &s.config, &s.fitted));
        checked.push(
            Problem::new(plant, conf, fitted, recs, &s.interest, opts.fit.clone())
                .with_context(|| format!("step '{}'", s.config))?,
        );
    }
    let mut joint = Vec::new();
    for s in joint_steps {
        let (conf, recs) = records_for(&s.config)?;
        if recs.is_empty() {
            bail!(
                "joint fit: step '{}' has no measurement file of its configuration in {searched} (the joint fit covers the steps up to {})",
                s.config,
                joint_steps.last().map_or("", |s| s.config.as_str())
            );
        }
        joint.push((conf, recs));
    }
    // The completed steps' files, where given: their problems on the plant's values.
    let mut earlier = Vec::new();
    for d in completed {
        if steps.iter().any(|s| s.config == d.step.config) {
            continue;
        }
        let (conf, recs) = records_for(&d.step.config)?;
        if recs.is_empty() {
            continue;
        }
        let problem = Problem::new(
            plant,
            conf,
            d.fit.names.clone(),
            recs,
            &d.step.interest,
            opts.fit.clone(),
        )
        .with_context(|| format!("the files of completed step '{}'", d.step.config))?;
        earlier.push((d.step.config.clone(), problem));
    }
    for f in &files {
        if !steps
            .iter()
            .chain(joint_steps)
            .any(|s| s.config == f.config)
            && !earlier.iter().any(|(c, _)| *c == f.config)
        {
            ignored.push(format!(
                "{}: configuration '{}' is not a step of this run",
                f.path.display(),
                f.config
            ));
        }
    }
    Ok(CheckedInputs {
        steps: checked,
        joint,
        ignored,
        notes,
        earlier,
    })
}

/// Run a locking sequence: check every step's data and bounds first, then fit step by
/// step, writing the plant and report after each. `progress(step, p)` reports progress.
///
/// # Errors
/// Before any fit: unknown sequence or step, a step without data, a file that does not
/// match its configuration, a fitted parameter without bounds or outside them. During:
/// a step where no start can be simulated.
pub fn run(
    plant: &Plant,
    data: &[PathBuf],
    opts: &SequenceOptions,
    progress: &(dyn Fn(&str, Progress) + Sync),
) -> Result<SequenceReport> {
    let model = plant.model;
    let occ = occurrence(model);
    // An earlier run into the same directory: its completed steps are kept.
    let previous = match previous_report(&opts.out, &opts.sequence) {
        Ok(p) => p,
        Err(e) if opts.resume => return Err(e),
        // Without --resume a report that cannot be continued is replaced.
        Err(_) => None,
    };
    let Selection {
        steps,
        joint_steps,
        plan_order,
    } = select_steps(plant, opts, &occ, previous.as_ref())?;
    // The outputs are checked before the first fit, not after it.
    crate::files::check_output_dir(&opts.out)?;
    crate::files::check_writable(&[
        &opts.out.join("plant.toml"),
        &opts.out.join("report.json"),
        &opts.out.join("report.md"),
    ])?;
    let completed: &[StepReport] = previous.as_ref().map_or(&[], |p| &p.steps);
    let CheckedInputs {
        steps: checked,
        joint: joint_files,
        ignored,
        notes,
        earlier: completed_files,
    } = check_inputs(plant, data, opts, &occ, &steps, &joint_steps, completed)?;
    let mut report = starting_report(
        plant,
        opts,
        previous,
        (&steps, &joint_steps),
        (ignored, notes),
    );
    let mut current = plant.clone();
    // The steps this run fits, with their problems (configuration and files), after the
    // completed steps whose files are given.
    let mut ran: Vec<(String, Problem)> = completed_files;
    // Rigid-body symbols a completed step fitted but did not determine, starting with those
    // the plant file records (a step run alone with `--config` after an earlier run).
    let mut undetermined: Vec<String> = plant.undetermined.clone();
    let position = |c: &str| plan_order.iter().position(|x| x == c).unwrap_or(usize::MAX);
    let last_step = steps.len().saturating_sub(1);
    for (index, (mut s, first)) in steps.into_iter().zip(checked).enumerate() {
        // Symbols an earlier step of this run fitted but could not determine (not called
        // identifiable: tied, poorly determined or at a bound) stay free where they appear
        // again: held at an arbitrary point of their uncertain direction they would bias
        // every later step.
        let more = carried_into(&undetermined, &occ, &s.config, &s.fitted);
        s.fitted.extend(more.iter().cloned());
        s.carried.extend(more);
        // Plant-gain scale families that earlier steps set apart and this one couples —
        // only under the earlier information, which keeps those steps' files as the
        // families move (without it, c7 of the isolated method reached the floor while the
        // written plant lost c2, c4 and c6: the sensitivities record, stop 83).
        if opts.earlier_information {
            let families = undetermined_gain_families(
                model,
                report
                    .steps
                    .iter()
                    .filter(|d| position(&d.step.config) < position(&s.config)),
            );
            let more = gain_families_carried_into(&families, &s.free, &s.fitted);
            s.fitted.extend(more.iter().cloned());
            s.carried.extend(more);
        }
        if opts.rigid_body == RigidBodyFit::Spanning {
            hold_tied_symbols(&current, &first, &mut s)?;
        }
        // The checked problem's files, with the plant as the earlier steps left it.
        let problem = Problem::new(
            &current,
            first.configuration(),
            s.fitted.clone(),
            first.records,
            &s.interest,
            opts.fit.clone(),
        )
        .with_context(|| format!("step '{}'", s.config))?
        .with_held_ties(s.tied_held.clone());
        // What the earlier steps' files determined (the steps before this one in the plan).
        let earlier = if opts.earlier_information {
            EarlierInformation::gather(
                report
                    .steps
                    .iter()
                    .filter(|d| position(&d.step.config) < position(&s.config))
                    .filter_map(StepReport::information),
                &current,
            )
        } else {
            None
        };
        let problem = match &earlier {
            Some(e) => problem.with_earlier_information(e.clone())?,
            None => problem,
        };
        let before = current.clone();
        let carried_prior = problem.carried_prior();
        let cname = s.config.clone();
        let fit = problem.fit(&|p| progress(&cname, p))?;
        let step_progress = |p: Progress| progress(&cname, p);
        let refit = StepRefit {
            problem: &problem,
            interest: &s.interest,
            held_ties: &s.tied_held,
            progress: &step_progress,
        };
        let (fit, warm_up_start) = if opts.warm_up_start {
            refit.warm_up_start(&current, fit)?
        } else {
            (fit, None)
        };
        let (fit, initial_positions_refit) = if opts.initial_positions_refit {
            refit.refit_initial_positions(&current, fit)?
        } else {
            (fit, None)
        };
        // At the floor with a residual that is not white: a wrong minimum near the floor.
        let (fit, whiteness_start) = if opts.warm_up_start {
            refit.whiteness_start(&current, fit)?
        } else {
            (fit, None)
        };
        let refined = refit.refine(&mut current, fit, opts)?;
        keep_step(
            &mut current,
            &s.config,
            &mut undetermined,
            &refined,
            &s.tied_held,
        );
        let following = match &earlier {
            Some(e) => follow(e, &before, &mut current, &occ, problem.configuration()),
            None => Vec::new(),
        };
        // The earlier steps of the plan whose files are given.
        let before_this: Vec<&(String, Problem)> = ran
            .iter()
            .filter(|(c, _)| position(c) < position(&cname))
            .collect();
        // Kept where it leaves the earlier steps' files no further off than without it.
        let (following_reverted, checked) = if following.is_empty() {
            (false, Vec::new())
        } else {
            let (helps, checked) =
                following_helps(&current, &following, &before_this, &report.steps);
            (!helps, checked)
        };
        if following_reverted {
            for (n, old, _) in &following {
                current.parameters.insert(n.clone(), *old);
            }
        }
        let Refined {
            fit,
            tie_reach,
            release,
            balance,
            ..
        } = refined;
        let impossible = impossible_links(&current, &fit.names)?;
        report.steps.push(StepReport {
            step: s,
            fit,
            impossible,
            carried_prior,
            release,
            tie_reach,
            balance,
            warm_up_start,
            initial_positions_refit,
            whiteness_start,
            earlier_information: earlier.is_some(),
            following,
            following_reverted,
            earlier_refits: Vec::new(),
            joint_refit: None,
            information_now: None,
        });
        report.steps.sort_by_key(|d| position(&d.step.config));
        if earlier.is_some() || (opts.earlier_refit && index == last_step) {
            // The earlier steps' files the linear following (or, without the earlier
            // information, this step's refit of their values) left off, refitted.
            let conf = problem.configuration();
            let enters = |n: &str| super::output_error::enters(plant, &occ, conf, n);
            let refits = refit_earlier_steps(
                &mut current,
                &cname,
                &enters,
                &before_this,
                &report.steps,
                &checked,
                progress,
            )?;
            // The earlier steps left off with nothing of theirs to refit alone: fitted
            // again together with this step.
            let left_off: Vec<String> = refits
                .iter()
                .filter(|r| r.names.is_empty())
                .map(|r| r.config.clone())
                .collect();
            // Without the earlier information, with the steps whose files see their values.
            let left_off = if earlier.is_none() && !left_off.is_empty() {
                let steps: Vec<(&str, &Configuration, &[String])> = before_this
                    .iter()
                    .filter_map(|(c, p)| {
                        let st = report.steps.iter().find(|d| d.step.config == *c)?;
                        Some((c.as_str(), p.configuration(), st.fit.names.as_slice()))
                    })
                    .collect();
                closed_over_seen_values(&left_off, &steps, &current, &occ)
            } else {
                left_off
            };
            let joint = match report.steps.iter().find(|d| d.step.config == cname) {
                Some(st) if !left_off.is_empty() => joint_refit(
                    &mut current,
                    (st, &problem),
                    &left_off,
                    &before_this,
                    &report.steps,
                    &occ,
                    progress,
                ),
                _ => None,
            };
            // Each refitted step's information where its values now are (the joint refit's
            // last: it may refit a step's values again).
            let informed = refits
                .iter()
                .filter_map(|r| Some((&r.config, r.information.as_ref()?)))
                .chain(
                    joint
                        .iter()
                        .flat_map(|j| j.information.iter().map(|(c, i)| (c, i))),
                );
            for (config, info) in informed {
                if let Some(d) = report.steps.iter_mut().find(|d| d.step.config == *config) {
                    d.information_now = Some(info.clone());
                }
            }
            if let Some(d) = report.steps.iter_mut().find(|d| d.step.config == cname) {
                d.earlier_refits = refits;
                d.joint_refit = joint;
            }
        }
        ran.push((cname, problem));
        current.description = format!(
            "{} — identified by lockstep ({} method, steps {})",
            plant.description,
            opts.sequence,
            report.step_list()
        );
        save(&current, &report, &opts.out, model)?;
    }
    if !joint_files.is_empty() {
        report.joint = Some(joint_fit(
            &mut current,
            &joint_steps,
            joint_files,
            &occ,
            opts,
            &|p| progress("joint", p),
        )?);
        current.description = format!(
            "{} — identified by lockstep ({} method{}, then the joint fit of {})",
            plant.description,
            opts.sequence,
            if report.steps.is_empty() {
                String::new()
            } else {
                format!(", steps {}", report.step_list())
            },
            config_list(&joint_steps)
        );
        save(&current, &report, &opts.out, model)?;
    }
    // The plant written, on every file of the steps this run fitted and of the completed
    // steps whose files are given, in the plan's order.
    if ran.len() >= 2 || report.joint.is_some() {
        ran.sort_by_key(|(c, _)| position(c));
        let steps: Vec<(&StepReport, &Problem)> = ran
            .iter()
            .filter_map(|(c, p)| Some((report.steps.iter().find(|d| d.step.config == *c)?, p)))
            .collect();
        report.final_check = final_check(&current, &steps);
        report.moved_since = moved_since(&current, &report.steps);
        save(&current, &report, &opts.out, model)?;
    }
    Ok(report)
}

/// The values configuration `conf`'s files do not see, moved in `current` to the earlier
/// steps' conditional minimum ([`EarlierInformation::following`]) given what the step moved
/// from `before`; (name, before, after) of each value moved.
fn follow(
    earlier: &EarlierInformation,
    before: &Plant,
    current: &mut Plant,
    occ: &Occurrence,
    conf: &Configuration,
) -> Vec<(String, f64, f64)> {
    let moved: Vec<(String, f64)> = current
        .parameters
        .iter()
        .filter(|(n, _)| earlier.knows(n))
        .filter_map(|(n, &v)| {
            let d = v - before.parameters.get(n)?;
            (d != 0.0).then(|| (n.clone(), d))
        })
        .collect();
    let enters = |n: &str| super::output_error::enters(before, occ, conf, n);
    let mut out = Vec::new();
    for (n, d) in earlier.following(&moved, enters) {
        let Some(v) = current.parameters.get_mut(&n) else {
            continue;
        };
        let old = *v;
        let mut new = old + d;
        // Within the value's bounds.
        if let Some(&(lo, hi)) = current.bounds.get(&n) {
            new = new.clamp(lo, hi);
        }
        *v = new;
        out.push((n, old, new));
    }
    out
}

/// Write the plant and the report (Markdown and JSON) into `out`, atomically and together
/// ([`crate::files::write_all_atomic`]).
///
/// # Errors
/// A file cannot be written.
fn save(plant: &Plant, report: &SequenceReport, out: &Path, model: &Model) -> Result<()> {
    write_all_atomic(&[
        (out.join("plant.toml"), plant.to_toml()?.into_bytes()),
        (
            out.join("report.json"),
            serde_json::to_string_pretty(report)?.into_bytes(),
        ),
        (
            out.join("report.md"),
            crate::report::sequence::markdown(report, model).into_bytes(),
        ),
    ])
}

/// The joint fit of `steps` (as planned) on their `files` from `plant`'s values, which it
/// updates (values, undetermined symbols, standard errors); its report. The parameters: every one the steps fit (rigid-body
/// symbols and effects), less, under [`RigidBodyFit::Spanning`], the rigid-body symbols
/// that the others span the base parameters of all the configurations without
/// ([`spanning_symbols_across`]; held, and left undetermined).
///
/// # Errors
/// Bounds missing or infeasible; the start cannot be simulated.
fn joint_fit(
    plant: &mut Plant,
    steps: &[Step],
    files: Vec<(&'static Configuration, Vec<Record>)>,
    occ: &Occurrence,
    opts: &SequenceOptions,
    progress: &(dyn Fn(Progress) + Sync),
) -> Result<StepReport> {
    let model = plant.model;
    let mut names: Vec<String> = Vec::new();
    let mut free: Vec<usize> = Vec::new();
    let mut held: Vec<String> = Vec::new();
    for s in steps {
        for n in &s.fitted {
            if !names.contains(n) {
                names.push(n.clone());
            }
        }
        free.extend(
            s.free
                .iter()
                .filter(|j| !free.contains(j))
                .copied()
                .collect::<Vec<_>>(),
        );
        held.extend(s.held.iter().cloned());
    }
    free.sort_unstable();
    let mut tied_held = Vec::new();
    if opts.rigid_body == RigidBodyFit::Spanning {
        let locked_at: Vec<Vec<Vec<f64>>> = files
            .iter()
            .map(|(_, recs)| recs.iter().map(|r| r.q_all.clone()).collect())
            .collect();
        let places: Vec<(&Configuration, &[Vec<f64>])> = files
            .iter()
            .zip(&locked_at)
            .map(|((conf, _), at)| (*conf, at.as_slice()))
            .collect();
        let keep = spanning_symbols_across(plant, &places, &names, &bound_width(plant, &names))
            .context("joint fit")?;
        tied_held = names
            .iter()
            .enumerate()
            .filter(|&(i, n)| model.inertial_symbols.contains(&n.as_str()) && !keep.contains(&i))
            .map(|(_, n)| n.clone())
            .collect();
        names.retain(|n| !tied_held.contains(n));
    }
    let problem = JointProblem::new(plant, names, tied_held.clone(), files, &opts.fit, occ)?;
    let fit = problem.fit(progress)?;
    fit.apply(plant);
    let mut undetermined = tied_held.clone();
    for (i, n) in fit.names.iter().enumerate() {
        if model.inertial_symbols.contains(&n.as_str())
            && !fit.statistics.identifiable_given_scale(i)
        {
            undetermined.push(n.clone());
        }
    }
    plant.undetermined = undetermined;
    record_standard_errors(plant, &fit.names, &fit.statistics);
    record_scale_families(plant, "joint", &fit.names, &fit.statistics);
    let impossible = impossible_links(plant, &fit.names)?;
    Ok(StepReport {
        impossible,
        ..StepReport::of(
            Step {
                config: "joint".into(),
                free,
                interest: Vec::new(),
                fitted: fit.names.clone(),
                carried: Vec::new(),
                held,
                tied_held,
            },
            fit,
        )
    })
}

/// Keep in `plant` ([`Plant::standard_errors`]) the standard errors of `names` (a fit's
/// parameters, with its `stats`; the held values' share included), when the fit reached
/// the noise floor (elsewhere the residuals are not noise and the standard errors say
/// nothing), have a finite one and are not at a bound (there the Jacobian's one-sided
/// information is no Gaussian), widened to the value's distance to an equally good minimum
/// of another start ([`Statistics::other_minima`]); drop the records of those this fit did
/// not qualify and of names the plant no longer has. The correlations of the recorded
/// values with each other (the held values' share included,
/// [`Statistics::correlation_with_held`]) replace every pair this fit's values had
/// ([`Plant::correlations`]).
fn record_standard_errors(plant: &mut Plant, names: &[String], stats: &Statistics) {
    let at_floor = stats.above_floor.is_empty();
    plant.forget_correlations(|n| names.iter().any(|m| m == n));
    let mut recorded = Vec::new();
    for (i, n) in names.iter().enumerate() {
        // A value that differs between equally good minima is known to no better than
        // that difference.
        let spread = stats.other_minima_spread(i, n);
        // Relative to the held scale families' scale: what the fit determines; the scale
        // itself is their family's ([`record_scale_families`]).
        let se = stats.std_err_given_scale(i).max(spread);
        if at_floor && se.is_finite() && se > 0.0 && !stats.at_bound[i] {
            plant.standard_errors.insert(n.clone(), se);
            recorded.push(i);
        } else {
            plant.standard_errors.remove(n);
        }
    }
    let correlation = &stats.correlation_with_held;
    for (a, &i) in recorded.iter().enumerate() {
        for &j in &recorded[a + 1..] {
            let r = correlation.get(i).and_then(|row| row.get(j)).copied();
            if let Some(r) = r.filter(|r| *r != 0.0 && r.is_finite()) {
                plant.set_correlation(&names[i], &names[j], r);
            }
        }
    }
    let known = plant.parameters.clone();
    plant.standard_errors.retain(|n, _| known.contains_key(n));
    let recorded_names = plant.standard_errors.clone();
    plant.forget_correlations(|n| !recorded_names.contains_key(n));
}

/// Keep in `plant` ([`Plant::scale_families`]) the plant-gain scale families after a fit of
/// `names` (configuration `config`, statistics `stats`): the values it fitted leave their
/// families; where the fit reached the noise floor, those it fitted that scale with the
/// gain ([`scales_with_the_gain`], nonzero) and got no finite standard error form a family
/// named `config`, together with the families whose held members the fit saw
/// ([`Statistics::held_scales`]): it fixed its values relative to their scale, so one
/// scale now moves them all (their standard errors relative to it are
/// [`record_standard_errors`]'s). A fit above the floor records no standard errors (its
/// values are then held as exact) and forms no family.
///
/// Why: a step whose data cannot fix the plant-gain scale leaves it where its least change
/// put it (the coupled k1 of the Freedom 6S: the guess's gains, which are the truth's,
/// within 0.06 %); a later step that holds that family and was told nothing of it called
/// the values coupled to it identifiable, with standard errors 8 × smaller than their
/// error (k2: Kp_q3 +0.046 %, z 8.4; k3: Kp_q2, z 8.0).
fn record_scale_families(plant: &mut Plant, config: &str, names: &[String], stats: &Statistics) {
    for n in names {
        plant.forget_scale_family_member(n);
    }
    let model = plant.model;
    let members: Vec<String> = names
        .iter()
        .zip(&stats.std_err)
        .filter(|(n, se)| {
            !se.is_finite()
                && scales_with_the_gain(model, n)
                && plant.parameters.get(*n).is_some_and(|v| *v != 0.0)
        })
        .map(|(n, _)| n.clone())
        .collect();
    if !stats.above_floor.is_empty() || members.is_empty() {
        return;
    }
    let mut family = members;
    for (used, _) in &stats.held_scales {
        if let Some(m) = plant.scale_families.remove(used) {
            family.extend(m);
        }
    }
    if let Some(m) = plant.scale_families.remove(config) {
        family.extend(m);
    }
    family.sort();
    family.dedup();
    plant.scale_families.insert(config.to_string(), family);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The values of a fit at the noise floor with a finite standard error off their
    /// bounds are recorded; an earlier record of a value this fit does not qualify, or of a
    /// name the plant does not have, is dropped.
    #[test]
    fn standard_errors_are_recorded_for_the_values_of_a_fit_at_the_floor() {
        let mut plant = Plant::new("planar2r", vec![]).unwrap();
        for n in ["m1", "m2", "I2", "I1", "Kp_q0"] {
            plant.parameters.insert(n.into(), 1.0);
        }
        plant.standard_errors.insert("I1".into(), 9.0);
        plant.standard_errors.insert("gone".into(), 1.0);
        let names: Vec<String> = ["m1", "m2", "I2", "I1", "Kp_q0"].map(String::from).to_vec();
        let mut stats = Statistics {
            std_err: vec![0.1, f64::INFINITY, 0.3, 0.4, 0.5],
            at_bound: vec![false, false, false, true, false],
            ..Statistics::default()
        };
        record_standard_errors(&mut plant, &names, &stats);
        let recorded: Vec<(&str, f64)> = plant
            .standard_errors
            .iter()
            .map(|(n, &v)| (n.as_str(), v))
            .collect();
        assert_eq!(recorded, [("I2", 0.3), ("Kp_q0", 0.5), ("m1", 0.1)]);
        stats.above_floor = vec!["q0 RMS 3.1 σ̂".into()];
        record_standard_errors(&mut plant, &names, &stats);
        assert!(plant.standard_errors.is_empty());
    }

    /// The plant-gain scale families as a coupled sequence leaves them: "k1" (q1 free) fits
    /// the gain, friction and link 2 without fixing their scale, and the family is its
    /// undetermined values that scale with the gain (not the centre of mass x2, nor a
    /// determined value); "k2" (both joints) holds k1's gain and friction, fits q0's and
    /// link 2 again, determines m2 and leaves the rest relative to k1's scale: one family
    /// "k2" of both; a fit above the floor takes its values out of the families and forms
    /// none; the plant file keeps the families and rejects a malformed one (a member may
    /// keep a standard error: relative to the family's scale).
    #[test]
    fn scale_families_are_formed_merged_and_left_by_the_steps() {
        let mut plant = Plant::new("planar2r", vec![]).unwrap();
        for n in [
            "m1", "m2", "I1", "I2", "x2", "Kp_q0", "Kp_q1", "Fc_q0", "Fc_q1",
        ] {
            plant.parameters.insert(n.into(), 0.5);
        }
        plant.parameters.insert("I1".into(), 0.0);
        let inf = f64::INFINITY;
        let names = |v: &[&str]| -> Vec<String> { v.iter().map(|s| s.to_string()).collect() };
        let k1 = names(&["Kp_q1", "Fc_q1", "m2", "I2", "x2", "I1"]);
        let stats = Statistics {
            std_err: vec![inf, inf, inf, 0.01, inf, inf],
            ..Statistics::default()
        };
        record_scale_families(&mut plant, "k1", &k1, &stats);
        assert_eq!(
            plant.scale_families,
            BTreeMap::from([("k1".to_string(), names(&["Fc_q1", "Kp_q1", "m2"]))])
        );
        let k2 = names(&["Kp_q0", "Fc_q0", "m2", "I2"]);
        let stats = Statistics {
            std_err: vec![inf, inf, 0.02, inf],
            held_scales: vec![("k1".into(), names(&["Kp_q1", "Fc_q1"]))],
            ..Statistics::default()
        };
        record_scale_families(&mut plant, "k2", &k2, &stats);
        assert_eq!(
            plant.scale_families,
            BTreeMap::from([(
                "k2".to_string(),
                names(&["Fc_q0", "Fc_q1", "I2", "Kp_q0", "Kp_q1"])
            )])
        );
        let mut rigid = Plant::new("planar2r", vec![]).unwrap();
        rigid.parameters.insert("m2".into(), 0.5);
        rigid.parameters.insert("I2".into(), 0.01);
        rigid.parameters.insert("x2".into(), 0.1);
        rigid
            .scale_families
            .insert("k2".into(), names(&["I2", "m2"]));
        let text = rigid.to_toml().unwrap();
        let back = Plant::from_file(toml::from_str(&text).unwrap(), None).unwrap();
        assert_eq!(back.scale_families, rigid.scale_families);
        let above = Statistics {
            std_err: vec![inf],
            above_floor: vec!["q0 RMS 3.1 σ̂".into()],
            ..Statistics::default()
        };
        record_scale_families(&mut plant, "k3", &names(&["Kp_q0"]), &above);
        assert_eq!(
            plant.scale_families["k2"],
            names(&["Fc_q0", "Fc_q1", "I2", "Kp_q1"])
        );
        assert!(!plant.scale_families.contains_key("k3"));
        for (table, expected) in [
            (
                "k2 = [\"Kp_q9\"]",
                "[scale_families] k2: 'Kp_q9': not a parameter",
            ),
            ("k2 = []", "[scale_families] k2: expected the names"),
            (
                "a = [\"m2\"]\nb = [\"m2\"]",
                "[scale_families] b: 'm2': already in family a",
            ),
        ] {
            let text = format!(
                "model = \"planar2r\"\n[parameters]\nm2 = 0.5\n[scale_families]\n{table}\n"
            );
            let e = Plant::from_file(toml::from_str(&text).unwrap(), None).unwrap_err();
            assert!(e.to_string().contains(expected), "{e}");
        }
    }

    /// The joint refit's group without the earlier information
    /// ([`closed_over_seen_values`]), on the Freedom 6S: k3 (q2..q5 free) left off after
    /// fitting Fc_q2 draws in k4 (q1..q5), whose files see it, and not c2 (q5 alone),
    /// whose files do not; once k4 fitted Fc_q5 too, c2 joins, by the second round.
    #[test]
    fn the_joint_refits_group_closes_over_the_steps_that_see_its_values() {
        let plant = Plant::load(
            &Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("model/plants/freedom6s_appendix_d_initial_widened.toml"),
        )
        .unwrap();
        let occ = occurrence(plant.model);
        let conf = |c: &str| plant.model.configuration(c).unwrap();
        let names = |n: &[&str]| n.iter().map(|x| x.to_string()).collect::<Vec<_>>();
        let (c2, k3) = (names(&["Fc_q5"]), names(&["Fc_q2"]));
        let group = |k4: &[String]| {
            closed_over_seen_values(
                &["k3".to_string()],
                &[
                    ("c2", conf("c2"), c2.as_slice()),
                    ("k3", conf("k3"), k3.as_slice()),
                    ("k4", conf("k4"), k4),
                ],
                &plant,
                &occ,
            )
        };
        assert_eq!(group(&names(&["Fc_q1"])), ["k3", "k4"]);
        assert_eq!(group(&names(&["Fc_q1", "Fc_q5"])), ["c2", "k3", "k4"]);
        // Nothing left off: no group.
        assert!(
            closed_over_seen_values(&[], &[("k3", conf("k3"), k3.as_slice())], &plant, &occ)
                .is_empty()
        );
    }

    /// The correlations of the recorded values are kept pairwise (each pair once), those
    /// of a value not recorded (infinite standard error) are not, and a fit of a value
    /// again replaces its pairs; the plant file keeps them and rejects a malformed pair.
    #[test]
    fn correlations_of_recorded_values_are_kept_and_replaced_by_a_refit() {
        let mut plant = Plant::load(
            &Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("model/plants/freedom6s_appendix_d_initial_widened.toml"),
        )
        .unwrap();
        let names: Vec<String> = ["m7", "z7", "x7"].map(String::from).to_vec();
        let stats = Statistics {
            std_err: vec![0.1, 0.2, f64::INFINITY],
            at_bound: vec![false; 3],
            correlation_with_held: vec![
                vec![1.0, -0.97, 0.3],
                vec![-0.97, 1.0, 0.5],
                vec![0.3, 0.5, 1.0],
            ],
            ..Statistics::default()
        };
        record_standard_errors(&mut plant, &names, &stats);
        assert_eq!(plant.correlation("z7", "m7"), -0.97);
        assert_eq!(plant.correlation("m7", "z7"), -0.97);
        assert_eq!(plant.correlation("m7", "x7"), 0.0);
        assert_eq!(plant.correlation("x7", "x7"), 1.0);
        assert_eq!(plant.correlations.len(), 1);
        // Through the plant file and back.
        let text = toml::to_string(&plant.to_file()).unwrap();
        assert!(text.contains("[correlations.m7]\nz7 = -0.97"), "{text}");
        let back = Plant::from_file(toml::from_str(&text).unwrap(), None).unwrap();
        assert_eq!(back.correlations, plant.correlations);
        let mut bad: crate::plant::PlantFile = toml::from_str(&text).unwrap();
        bad.correlations = [("z7".to_string(), [("m7".to_string(), 0.5)].into())].into();
        let e = Plant::from_file(bad.clone(), None).unwrap_err().to_string();
        assert!(
            e.contains("[correlations.z7] 'm7'") && e.contains("once"),
            "{e}"
        );
        bad.correlations = [("m7".to_string(), [("z7".to_string(), 1.5)].into())].into();
        let e = Plant::from_file(bad, None).unwrap_err().to_string();
        assert!(e.contains("[-1, 1], found 1.5"), "{e}");
        // A refit of m7 alone drops its pair with z7 and records none (nothing else fitted).
        let refit = Statistics {
            std_err: vec![0.05],
            at_bound: vec![false],
            correlation_with_held: vec![vec![1.0]],
            ..Statistics::default()
        };
        record_standard_errors(&mut plant, &names[..1], &refit);
        assert!(plant.correlations.is_empty());
        assert_eq!(plant.standard_errors["m7"], 0.05);
    }
}
