//! The model-versus-measurement loop on the command line: `compare`, `diagnose` (with
//! `--apply` to add the leading finding and refit it), `refit`, `effect add`, and the
//! self-contained HTML report that collects them with the plant's history.

use crate::compare::{compare_observation, compare_output, plot, write_residual_csv, Comparison};
use crate::diagnose::{diagnose_output, Finding, OutputOptions};
use crate::effects::{Effect, EffectKind};
use crate::files::write_atomic;
use crate::identify::idim::{observation, IdimOptions};
use crate::identify::output_error::Record;
use crate::identify::refit::{refit, Refit, RefitOptions};
use crate::identify::sequence::{discover, read_record_with_notes};
use crate::measurement::Measurement;
use crate::plant::{HistoryEntry, Plant};
use crate::report::plot::{figure, Panel, Series, Style};
use anyhow::{anyhow, bail, Context, Result};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Where model and measurement are compared.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Space {
    /// Inverse model on torque-measured data.
    Torque,
    /// Simulated positions on position-measured data.
    Output,
}

impl Space {
    /// `torque`, `output`, or `auto`: chosen by the data, not by the plant (adding an
    /// effect never moves the loop to the other space): torque space where the records'
    /// torques are measured, output space where they are commands and the positions the
    /// measurement ([`crate::measurement::SideFile::torque_kind`]). Returns the space and
    /// why.
    ///
    /// # Errors
    /// Another word; records of both kinds; an unreadable side file.
    pub fn choose(requested: &str, data: &[PathBuf]) -> Result<(Space, String)> {
        match requested {
            "torque" => Ok((Space::Torque, "given".into())),
            "output" => Ok((Space::Output, "given".into())),
            "auto" => {
                use crate::measurement::TorqueKind;
                let files = crate::measurement::expand_data_paths(data)?;
                let mut seen: Option<(TorqueKind, &'static str, &Path)> = None;
                for f in &files {
                    let (k, why) = crate::measurement::read_side_file(f)?.torque_kind();
                    match seen {
                        None => seen = Some((k, why, f)),
                        Some((k0, _, f0)) if k0 != k => bail!(
                            "{} has {} torques and {} {}: compare them separately, or give \
                             --space",
                            f0.display(),
                            kind_word(k0),
                            f.display(),
                            kind_word(k)
                        ),
                        _ => {}
                    }
                }
                Ok(match seen {
                    Some((TorqueKind::Commanded, why, _)) => (
                        Space::Output,
                        format!("the records' torques are commands ({why})"),
                    ),
                    Some((TorqueKind::Measured, why, _)) => (
                        Space::Torque,
                        format!("the records' torques are measured ({why})"),
                    ),
                    None => (Space::Torque, "no records".into()),
                })
            }
            other => bail!("--space: expected auto, torque or output, got '{other}'"),
        }
    }
}

fn kind_word(k: crate::measurement::TorqueKind) -> &'static str {
    match k {
        crate::measurement::TorqueKind::Measured => "measured",
        crate::measurement::TorqueKind::Commanded => "commanded",
    }
}

/// What the loop's commands need besides the plant: data, configuration, space settings.
#[derive(Debug, Clone)]
pub struct Inputs {
    /// Measurement files or directories.
    pub data: Vec<PathBuf>,
    /// Configuration (default: the side files', else `full` in torque space).
    pub config: Option<String>,
    /// Space requested (auto, torque, output).
    pub space: String,
    /// Torque space: preparation of the records (the filter order, window and speed
    /// threshold; the cut-off and decimation are resolved for the records by
    /// [`Inputs::load`] unless `preparation` fixes them).
    pub idim: IdimOptions,
    /// Torque space: the cut-off and decimation the user fixed.
    pub preparation: crate::identify::preparation::Requested,
    /// Output space: integration step (s).
    pub h: f64,
    /// Output space: integration scheme.
    pub integrator: crate::simulation::Integrator,
    /// Output space: samples skipped at the start of each file.
    pub skip: usize,
    /// Output space: largest motion (rad) of a locked joint.
    pub locked_tolerance: f64,
    /// Output space: estimate the initial positions (else the first samples).
    pub estimate_initial: bool,
    /// Output space: how the torques were applied between samples for every file (`None`:
    /// each file's side file's, else zero-order).
    pub hold: Option<crate::simulation::Hold>,
    /// Output-space diagnosis: refit the configuration's values first and beside each
    /// candidate ([`OutputOptions::refit_values`]).
    pub refit_values: bool,
    /// Diagnosis: the user's candidate effects ([`crate::diagnose::candidates`]).
    pub candidates: Vec<crate::diagnose::candidates::UserCandidate>,
    /// Output space: how the fits' Jacobians are formed (diagnosis, refit); `None`: the
    /// thesis preset's ([`RefitOptions::jacobian`]). Given with torque-space data, an error
    /// ([`Inputs::load`]): the fits there are linear least squares.
    pub jacobian: Option<crate::identify::output_error::JacobianMethod>,
}

/// Position records of one configuration: `config` or the files' own (side file or file
/// name prefix), which must agree.
///
/// # Errors
/// A path that does not exist, files without a configuration or of different
/// configurations, unreadable records (file and column named).
pub fn output_records(plant: &Plant, inputs: &Inputs) -> Result<(String, Vec<Record>)> {
    let m = plant.model;
    let (files, ignored) = discover(&inputs.data, m)?;
    let config = match &inputs.config {
        Some(c) => c.clone(),
        None => {
            if let Some(why) = ignored.first() {
                bail!("{why} (or give --config)");
            }
            let mut cs: Vec<&str> = files.iter().map(|f| f.config.as_str()).collect();
            cs.dedup();
            match cs.as_slice() {
                [c] => c.to_string(),
                [] => bail!("no measurement files (*.csv, *.mat) in {:?}", inputs.data),
                many => bail!(
                    "the files are of several configurations ({}): give one with --config",
                    many.join(", ")
                ),
            }
        }
    };
    let conf = crate::util::configuration(m, &config).map_err(|e| anyhow!("--config: {e}"))?;
    // Files named directly are used as given; from directories, the files of this
    // configuration.
    let paths: Vec<PathBuf> = inputs
        .data
        .iter()
        .flat_map(|p| {
            if p.is_dir() {
                files
                    .iter()
                    .filter(|f| f.path.starts_with(p) && f.config == config)
                    .map(|f| f.path.clone())
                    .collect()
            } else {
                vec![p.clone()]
            }
        })
        .collect();
    let mut records = Vec::new();
    for p in &paths {
        let (record, notes) = read_record_with_notes(p, m, conf, inputs.locked_tolerance)?;
        for n in notes {
            crate::errln!("note: {n}");
        }
        records.push(record);
    }
    if records.is_empty() {
        bail!("no measurement files for configuration '{config}'");
    }
    Ok((config, records))
}

/// Measurements read once for the loop's commands, in the space they are compared in.
#[derive(Debug, Clone)]
pub enum Data {
    /// Position records of one configuration (output space).
    Output {
        /// Configuration.
        config: String,
        /// Records.
        records: Vec<Record>,
    },
    /// Torque-measured records (torque space).
    Torque {
        /// Configuration (default `full`).
        config: String,
        /// Records.
        records: Vec<Measurement>,
        /// Their preparation: the cut-off and decimation resolved for them
        /// ([`crate::identify::preparation::Requested::resolve`]).
        idim: IdimOptions,
    },
}

impl Inputs {
    /// Read the data in the space [`Space::choose`] picks for `plant`.
    ///
    /// # Errors
    /// As [`output_records`], or an unreadable torque-measured file (file, row, column).
    pub fn load(&self, plant: &Plant) -> Result<Data> {
        let (space, why) = Space::choose(&self.space, &self.data)?;
        // Said once the data are read (an unreadable file is then the only line).
        let said_space = format!(
            "space: {} ({why})",
            match space {
                Space::Torque => "torque (inverse model)",
                Space::Output => "output (simulated positions)",
            }
        );
        Ok(match space {
            Space::Output => {
                let (config, records) = output_records(plant, self)?;
                crate::outln!("{said_space}");
                Data::Output { config, records }
            }
            Space::Torque => {
                if let Some(j) = self.jacobian {
                    bail!(
                        "--jacobian {j}: a Jacobian of simulated positions is for output space; these data are in torque space ({why}), where the fits are linear least squares (drop --jacobian, or --space output for commanded torques)"
                    );
                }
                let config = self.config.clone().unwrap_or_else(|| "full".into());
                let (records, idim, said) =
                    torque_records(plant, &self.data, &config, self.idim, &self.preparation)?;
                crate::outln!("{said_space}");
                crate::outln!("preparation: {said}");
                Data::Torque {
                    config,
                    records,
                    idim,
                }
            }
        })
    }
}

/// The torque-measured records of `data` (files or directories; [`read_noted`]) and their
/// preparation for configuration `config`: `base` with the cut-off, decimation and
/// differentiator `requested` fixes or the records choose
/// ([`crate::identify::preparation::Requested::resolve`]), and the line saying which.
///
/// # Errors
/// As [`read_noted`]; an unknown configuration; as `resolve`.
pub fn torque_records(
    plant: &Plant,
    data: &[PathBuf],
    config: &str,
    base: IdimOptions,
    requested: &crate::identify::preparation::Requested,
) -> Result<(Vec<Measurement>, IdimOptions, String)> {
    let records = read_noted(
        &crate::measurement::expand_data_paths(data)?,
        plant.model.joints,
    )?;
    let free = crate::util::configuration(plant.model, config)?
        .free
        .to_vec();
    let (idim, said) = requested.resolve(base, &records, &free, Some((plant, config)))?;
    Ok((records, idim, said))
}

/// The torque-measured records in `paths` ([`Measurement::read`], for a model whose joints
/// are named `joints`), what reading did to each printed as a note.
///
/// # Errors
/// As [`Measurement::read`].
pub fn read_noted(paths: &[PathBuf], joints: &[&str]) -> Result<Vec<Measurement>> {
    let mut records = Vec::new();
    for p in paths {
        let m = Measurement::read(p, joints)?;
        for n in &m.notes {
            crate::errln!("note: {n}");
        }
        records.push(m);
    }
    Ok(records)
}

fn stem(p: &Path) -> String {
    p.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// The comparisons of `plant` with `data`, per record and free joint (output space: the
/// simulation; torque space: the inverse model); with `announce`, the space, the step's
/// check and the hold are printed.
///
/// # Errors
/// As [`compare_output`] / [`compare_observation`].
fn comparisons(
    plant: &Plant,
    inputs: &Inputs,
    data: &Data,
    announce: bool,
) -> Result<Vec<Comparison>> {
    Ok(match data {
        Data::Output { config, records } => {
            let c = compare_output(plant, config, records, &refit_options(inputs))?;
            if announce {
                crate::outln!("output space (simulated positions), configuration {config}");
                crate::outln!("{}", c.step.summary());
                crate::outln!("{}", hold_text(records, &c.holds, inputs.hold.is_some()));
                if let Some((better, e, used)) = c.better_hold() {
                    crate::errln!(
                        "note: --hold {better} fits markedly better (RMS {e:.3e} against {used:.3e} with the hold used): was the input applied that way?"
                    );
                }
            }
            c.comparisons
        }
        Data::Torque {
            config,
            records,
            idim,
        } => {
            if announce {
                crate::outln!("torque space (inverse model), configuration {config}");
            }
            let mut v = Vec::new();
            for m in records {
                let obs = observation(plant, config, std::slice::from_ref(m), idim)?;
                v.extend(compare_observation(plant, &obs, &m.file)?);
            }
            v
        }
    })
}

/// A comparison with the starting plant of a loop of diagnosis: its figures are drawn
/// beside the model's.
pub struct StartComparison<'a> {
    /// The starting plant (same model as the plant compared).
    pub plant: &'a Plant,
    /// Its file, for messages.
    pub file: &'a Path,
}

/// Compare, print the table and write residual CSVs and figures under `out`; returns the
/// comparisons, the starting plant's (when `start` is given: drawn beside the model in each
/// figure and listed in the table) and the SVG figure of each.
///
/// # Errors
/// As [`compare_output`] / [`crate::compare::compare_torque`]; a starting plant of another
/// model (file named) or that cannot be simulated on the data; I/O (path named).
pub fn compare_command(
    plant: &Plant,
    inputs: &Inputs,
    data: &Data,
    out: &Path,
    start: Option<&StartComparison>,
    described: Option<&Finding>,
) -> Result<Vec<Compared>> {
    let cmps = comparisons(plant, inputs, data, true)?;
    let described = match described {
        Some(f) => described_by(f, plant, inputs, data, &cmps)?,
        None => vec![None; cmps.len()],
    };
    let starts: Vec<Option<Comparison>> = match start {
        None => vec![None; cmps.len()],
        Some(s) => {
            if s.plant.model.name != plant.model.name {
                bail!(
                    "--start {}: a plant of model '{}', the plant compared is of model '{}'",
                    s.file.display(),
                    s.plant.model.name,
                    plant.model.name
                );
            }
            let v = comparisons(s.plant, inputs, data, false)
                .with_context(|| format!("--start {}", s.file.display()))?;
            crate::outln!("starting plant {}", s.file.display());
            v.into_iter().map(Some).collect()
        }
    };
    crate::outln!(
        "{:<24} {:<5} {:>8} {:>9} {:>11} {:>11} {:>9} {:>10} {:>10}",
        "record",
        "joint",
        "fit %",
        "error %",
        "RMSE",
        "max |e|",
        "at t (s)",
        "at q",
        "at qd"
    );
    let mut outv = Vec::new();
    for ((c, start), described) in cmps.into_iter().zip(starts).zip(described) {
        let s = stem(&c.file);
        let base = out.join(format!("{s}_{}", c.joint));
        write_residual_csv(&base.with_extension("csv"), &c, described.as_ref())?;
        let [svg, _] = plot(&base, &c, &s, start.as_ref(), described.as_ref())?;
        crate::outln!(
            "{:<24} {:<5} {:>8.2} {:>9.3} {:>11.4e} {:>11.4e} {:>9.3} {:>10.4} {:>10.4}",
            s,
            c.joint,
            c.nrmse_fit,
            c.relative_error,
            c.rmse,
            c.max_error.0.abs(),
            c.max_error.1,
            c.max_error_q,
            c.max_error.2
        );
        if let Some(st) = &start {
            crate::outln!(
                "    starting plant: fit {:.2} %, RMSE {:.4e}",
                st.nrmse_fit,
                st.rmse
            );
        }
        crate::outln!("    {}", c.tests.verdict());
        if matches!(data, Data::Torque { .. }) {
            let (a, b) = c.sign_step;
            crate::outln!("    residual ~ a*sign(qd) + b + c*qd: a = {a:.4}, b = {b:.4} (a step of 2a at qd = 0 means missing Coulomb friction; b, an offset)");
        }
        outv.push(Compared {
            comparison: c,
            start,
            svg,
        });
    }
    crate::outln!("residual CSVs and plots (PNG, SVG) in {}", out.display());
    Ok(outv)
}

/// What `finding` describes of each comparison's residual (`cmps`, in the order
/// [`comparisons`] gives them): the outputs of the plant with the finding applied less the
/// plant's ([`crate::compare::Described`]). None for every comparison where the finding is
/// not a plant edit (it is about the input or the values) or the plant with it cannot be
/// compared (the reason printed).
///
/// # Errors
/// Comparisons of the plant with the finding in another order or length than `cmps`.
fn described_by(
    finding: &Finding,
    plant: &Plant,
    inputs: &Inputs,
    data: &Data,
    cmps: &[Comparison],
) -> Result<Vec<Option<crate::compare::Described>>> {
    let none = vec![None; cmps.len()];
    let Ok(with) = finding.apply(plant) else {
        return Ok(none);
    };
    let after = match comparisons(&with, inputs, data, false) {
        Ok(v) => v,
        Err(e) => {
            crate::outln!(
                "(the figures do not show '{}': the plant with it cannot be compared: {e:#})",
                finding.name
            );
            return Ok(none);
        }
    };
    if after.len() != cmps.len() {
        bail!(
            "the plant with '{}' gave {} comparisons, the plant {}",
            finding.name,
            after.len(),
            cmps.len()
        );
    }
    let name = format!("finding 1: {} on {}", finding.name, finding.joint);
    cmps.iter()
        .zip(after)
        .map(|(c, a)| {
            if (&a.file, &a.joint, a.yhat.len()) != (&c.file, &c.joint, c.yhat.len()) {
                bail!(
                    "the plant with '{}' compared {} {} where the plant compared {} {}",
                    finding.name,
                    a.file.display(),
                    a.joint,
                    c.file.display(),
                    c.joint
                );
            }
            Ok(Some(crate::compare::Described {
                name: name.clone(),
                e: a.yhat.iter().zip(&c.yhat).map(|(w, b)| w - b).collect(),
            }))
        })
        .collect()
}

/// One record and joint of [`compare_command`].
pub struct Compared {
    /// The plant's comparison.
    pub comparison: Comparison,
    /// The starting plant's, when one was given.
    pub start: Option<Comparison>,
    /// Its figure (SVG; a PNG beside it).
    pub svg: PathBuf,
}

/// Diagnose: the ranked findings, per record in torque space, for all records together in
/// output space (with the configuration).
///
/// # Errors
/// As [`diagnose_output`] / [`crate::diagnose::torque::diagnosis`].
pub fn diagnose(plant: &Plant, inputs: &Inputs, data: &Data) -> Result<Vec<Diagnosed>> {
    match data {
        Data::Output { config, records } => {
            let d = diagnose_output(plant, config, records, &output_options(inputs))?;
            Ok(vec![(
                output_title(config, records, &d),
                d.findings.clone(),
                d.left(),
            )])
        }
        Data::Torque {
            config,
            records,
            idim,
        } => records
            .iter()
            .enumerate()
            .map(|(k, m)| {
                let obs = observation(plant, config, std::slice::from_ref(m), idim)?;
                let one = std::slice::from_ref(m);
                let (mut user, left_out) = crate::diagnose::candidates::columns(
                    &inputs.candidates,
                    plant,
                    config,
                    one,
                    idim,
                )?;
                let conf = crate::util::configuration(plant.model, config)?;
                let builtin = crate::diagnose::candidates::coupled_motor_candidates(plant, conf);
                user.extend(crate::diagnose::candidates::columns_together(
                    &builtin, plant, config, one, idim,
                )?);
                if k == 0 {
                    for line in left_out
                        .iter()
                        .filter(|l| !l.contains("has this effect already"))
                    {
                        crate::outln!("{line}");
                    }
                }
                let d = crate::diagnose::torque::diagnosis_with(plant, &obs, &user)?;
                Ok((stem(&m.file), d.findings, d.not_white))
            })
            .collect(),
    }
}

/// One diagnosis of [`diagnose`]: its title, the findings best first, and what its
/// residual shows that is not noise (joints above their noise, in output space; joints
/// whose residual is not white), which the verdict needs ([`crate::diagnose::verdict`]).
pub type Diagnosed = (String, Vec<Finding>, Vec<String>);

/// Which hold each record's input was simulated with, and where it came from.
fn hold_text(records: &[Record], holds: &[crate::simulation::Hold], given: bool) -> String {
    let mut distinct: Vec<String> = Vec::new();
    for (r, h) in records.iter().zip(holds) {
        let from = if given {
            "--hold"
        } else if crate::measurement::read_side_file(&r.file)
            .ok()
            .and_then(|s| s.hold)
            .is_some()
        {
            "side file"
        } else {
            "default"
        };
        let t = format!("{h} ({from})");
        if !distinct.contains(&t) {
            distinct.push(t);
        }
    }
    format!("input hold: {}", distinct.join(", "))
}

/// The output-space diagnosis settings of `inputs` (the diagnosis's own preset for the
/// confirmation fits' iterations).
fn output_options(inputs: &Inputs) -> OutputOptions {
    OutputOptions {
        fit: RefitOptions {
            max_iter: OutputOptions::default().fit.max_iter,
            ..refit_options(inputs)
        },
        refit_values: inputs.refit_values,
        candidates: inputs.candidates.clone(),
        ..OutputOptions::default()
    }
}

/// The heading of an output-space diagnosis: configuration, files, samples, simulations,
/// the step's check and the numerical floor.
fn output_title(config: &str, records: &[Record], d: &crate::diagnose::OutputDiagnosis) -> String {
    let files: Vec<String> = records.iter().map(|r| stem(&r.file)).collect();
    let mut title = format!(
        "configuration {config}, {} ({} residual samples, {:.0} independent in what all candidates together leave; {} simulations)\n{}; numerical floor (step and input reconstruction) {:.2} % of the residual energy",
        files.join(", "),
        d.samples,
        d.effective_samples,
        d.simulations,
        d.step.summary(),
        100.0 * d.floor_share
    );
    if let Some(r) = &d.values_refit {
        let rms: Vec<String> = r
            .before
            .iter()
            .zip(&r.after)
            .map(|((j, b), (_, a))| format!("{j} {b:.3e} → {a:.3e}"))
            .collect();
        title += &format!(
            "\nthe configuration's {} values refitted first, within the plant's bounds (RMS {}); the candidates are judged against that plant and refitted beside it",
            r.fit.names.len(),
            rms.join(", ")
        );
    }
    title
}

fn refit_options(inputs: &Inputs) -> RefitOptions {
    RefitOptions {
        h: inputs.h,
        integrator: inputs.integrator,
        hold: inputs.hold,
        skip: inputs.skip,
        estimate_initial: inputs.estimate_initial,
        jacobian: inputs.jacobian.unwrap_or(RefitOptions::default().jacobian),
        ..RefitOptions::default()
    }
}

/// The before/after table of a refit.
pub fn refit_table(r: &Refit) -> String {
    let mut s = format!(
        "{}\n{:<6} {:>13} {:>13} {:>8}\n",
        r.step.summary(),
        "joint",
        "RMS before",
        "RMS after",
        "fall %"
    );
    for ((j, b), (_, a)) in r.before.iter().zip(&r.after) {
        s += &format!(
            "{:<6} {:>13.4e} {:>13.4e} {:>8.1}\n",
            j,
            b,
            a,
            100.0 * (1.0 - a / b.max(1e-300))
        );
    }
    let st = &r.fit.statistics;
    for (i, (n, v)) in r.fit.names.iter().zip(&r.fit.fitted).enumerate() {
        let se = st.std_err.get(i).copied().unwrap_or(f64::NAN);
        let verdict = if st.identifiable.get(i).copied().unwrap_or(false) {
            "determined"
        } else if st.at_bound.get(i).copied().unwrap_or(false) {
            "at a bound"
        } else if !st.above_floor.is_empty() {
            "no verdict: the fit is above the noise floor"
        } else {
            "not determined by these data"
        };
        s += &format!("  {n} = {v:.6e} ± {se:.2e} ({verdict})\n");
    }
    for (a, b, rho) in &st.correlated {
        s += &format!("  {a} and {b} trade with each other (correlation {rho:+.3})\n");
    }
    s += &format!(
        "  {} simulations of the files ({} Jacobians among them), {:.1} s\n",
        r.fit.evaluations, r.fit.jacobians, r.fit.wall_s
    );
    s
}

/// `diagnose --apply k`: add finding `k` (1-based) of the diagnosis to the plant, refit,
/// record the step in the plant's history, print the refit and save the plant to `out`. In
/// output space the refit is joint with the changes recorded earlier on the configuration
/// ([`crate::diagnose::apply_finding`]); in torque space it is the inverse model's least
/// squares of every parameter ([`crate::diagnose::torque::apply_finding`], all records
/// together). Returns the number of history steps of the saved plant.
///
/// # Errors
/// No such finding, a finding that is not a plant edit (or, in torque space, not linear in
/// its parameters), the refit fails, I/O.
pub fn apply_finding(
    plant: &Plant,
    inputs: &Inputs,
    data: &Data,
    findings: &[Finding],
    k: usize,
    out: &Path,
) -> Result<usize> {
    let f = findings
        .get(k.wrapping_sub(1))
        .ok_or_else(|| anyhow!("--apply {k}: there are {} findings", findings.len()))?;
    let saved = match data {
        Data::Output { config, records } => {
            let r = crate::diagnose::apply_finding(
                plant,
                f,
                config,
                records,
                &output_options(inputs).joint_refit(),
            )?;
            crate::outln!("applied finding {k} and refitted jointly:");
            crate::out!("{}", refit_table(&r));
            r.plant
        }
        Data::Torque {
            config,
            records,
            idim,
        } => {
            let r = crate::diagnose::torque::apply_finding(plant, f, config, records, idim)?;
            crate::outln!(
                "applied finding {k} and refitted in torque space (IDIM-LS, every parameter):"
            );
            crate::out!("{}", torque_refit_table(&r));
            r.plant
        }
    };
    saved.save(out)?;
    Ok(saved.history.len())
}

/// The before/after table of a torque-space refit: RMS torque residual per joint, the
/// relative error, and the fitted values.
pub fn torque_refit_table(r: &crate::identify::refit::TorqueRefit) -> String {
    let mut s = format!(
        "{:<8} {:>14} {:>14} {:>8}\n",
        "joint", "RMS before", "RMS after", "fall %"
    );
    for ((j, b), (_, a)) in r.before.iter().zip(&r.after) {
        let _ = writeln!(
            s,
            "{j:<8} {b:>14.4e} {a:>14.4e} {:>8.1}",
            100.0 * (1.0 - a / b)
        );
    }
    let _ = writeln!(
        s,
        "relative error {:.3} % → {:.3} % (torque residual, N·m or N)",
        r.relative.0, r.relative.1
    );
    s += &crate::report::fit_table(&r.fit);
    s
}

/// `diagnose --apply all-significant`: apply the leading finding and diagnose again until
/// nothing significant is missing, printing each diagnosis (its `top` findings) and each
/// step's refit table as they end; the plant after the last kept step is saved to `out`.
/// Output space: [`crate::diagnose::apply_all_significant`]; torque space (all records
/// together): [`crate::diagnose::torque::apply_all_significant`]. Returns why the loop
/// stopped, the steps kept and the saved plant's history length.
///
/// # Errors
/// As those loops; I/O.
pub fn apply_all_command(
    plant: &Plant,
    inputs: &Inputs,
    data: &Data,
    out: &Path,
    top: usize,
) -> Result<(crate::diagnose::LoopEnd, usize, usize)> {
    let (config, records) = match data {
        Data::Output { config, records } => (config, records),
        Data::Torque {
            config,
            records,
            idim,
        } => {
            let done = crate::diagnose::torque::apply_all_significant(
                plant,
                config,
                records,
                (idim, &inputs.candidates),
                crate::diagnose::apply::max_applied_steps(
                    crate::util::configuration(plant.model, config)?.free.len(),
                ),
                &|turn| match turn {
                    crate::diagnose::torque::Turn::Diagnosed(d) => {
                        crate::outln!(
                            "plant {}, torque space (inverse model), configuration {config}, {} record(s) together:",
                            plant.name(),
                            records.len()
                        );
                        crate::out!("{}", d.table(top));
                    }
                    crate::diagnose::torque::Turn::Applied(f, r) => {
                        if f.values.is_empty() {
                            crate::outln!("step: refitted the plant's own parameters ({:.1} % of the residual); IDIM-LS:", 100.0 * f.explained);
                        } else {
                            crate::outln!(
                                "step: {} ({:.1} % explained, ΔBIC {:.1}); IDIM-LS, every parameter:",
                                crate::diagnose::apply::change_text(f),
                                100.0 * f.explained,
                                f.delta_bic
                            );
                        }
                        crate::out!("{}", torque_refit_table(r));
                    }
                },
            )?;
            done.plant.save(out)?;
            return Ok((done.end, done.steps.len(), done.plant.history.len()));
        }
    };
    let done = crate::diagnose::apply_all_significant(
        plant,
        config,
        records,
        &output_options(inputs),
        crate::diagnose::apply::max_applied_steps(
            crate::util::configuration(plant.model, config)?.free.len(),
        ),
        &|turn| match turn {
            crate::diagnose::Turn::Diagnosed(d) => {
                crate::outln!(
                    "plant {}, {}:",
                    plant.name(),
                    output_title(config, records, d)
                );
                crate::out!("{}", d.table(top));
            }
            crate::diagnose::Turn::Applied(s) => {
                crate::outln!(
                    "step: {} ({:.1} % explained, ΔBIC {:.1}); refitted jointly:",
                    crate::diagnose::apply::change_text(&s.finding),
                    100.0 * s.finding.explained,
                    s.finding.delta_bic
                );
                crate::out!("{}", refit_table(&s.refit));
            }
        },
    )?;
    for r in &done.removed {
        crate::outln!("{r}");
    }
    done.plant.save(out)?;
    Ok((done.end, done.steps.len(), done.plant.history.len()))
}

fn save_with_history(r: &Refit, change: &str, records: &[Record], out: &Path) -> Result<()> {
    let mut p = r.plant.clone();
    p.history.push(r.history(change, records));
    p.save(out)
}

/// `lockstep refit`: fit `names` of the plant on the data, print before/after, append the
/// step to the history, save to `out`. Position data: output error ([`refit`]) through the
/// growing horizons, and the warm-ups where those end above the noise
/// ([`crate::diagnose::apply::escalated`]);
/// torque-measured data: the inverse model's least squares of `names`, the others held
/// ([`crate::identify::refit::refit_torque_names`]).
///
/// # Errors
/// As [`refit`] / [`crate::identify::refit::refit_torque_names`]; I/O.
pub fn refit_command(
    plant: &Plant,
    inputs: &Inputs,
    names: &[String],
    change: &str,
    out: &Path,
) -> Result<()> {
    if names.is_empty() {
        bail!("--params: name the parameters to refit, e.g. --params Ks_q3,qeq_q3");
    }
    match inputs.load(plant)? {
        Data::Output { config, records } => {
            // Through the growing horizons, and the warm-ups where those stop above the
            // noise (a new effect refitted from a neutral start: a cubic stiffness's
            // horizons stopped at 33 σ, the warm-ups reached 1.03 σ).
            let options = RefitOptions {
                warm_ups: true,
                ..refit_options(inputs)
            };
            let r = crate::diagnose::apply::escalated(&options, |o| {
                refit(plant, plant, &config, &records, names, o)
            })?;
            crate::out!("{}", refit_table(&r));
            save_with_history(&r, change, &records, out)
        }
        Data::Torque {
            config,
            records,
            idim,
        } => {
            let r =
                crate::identify::refit::refit_torque_names(plant, &config, &records, &idim, names)?;
            crate::outln!("torque space (inverse model), configuration {config}:");
            crate::out!("{}", torque_refit_table(&r));
            let mut p = r.plant.clone();
            p.history.push(r.history(change, &config, &records));
            p.save(out)
        }
    }
}

/// Default value of a new effect's parameter: no effect where that exists (levels 0, gain
/// and friction-bias factor 1), small positive friction levels for LuGre (it divides by
/// g(v)), vs = 0.1, and an existing qeq shared with the spring or friction bias.
fn neutral(symbol: &str, existing: Option<f64>) -> f64 {
    match symbol {
        "Kp" | "FrictionBias" => 1.0,
        "vs" => 0.1,
        "sigma0" => 1.0,
        "Fc" | "Fs" => 1e-3,
        "qeq" => existing.unwrap_or(0.0),
        _ => 0.0,
    }
}

/// An effect kind by its plant-file name (`-` read as `_`).
///
/// # Errors
/// An unknown name, with the kinds there are.
fn effect_kind(kind: &str) -> Result<EffectKind> {
    serde_json::from_value(serde_json::Value::String(kind.replace('-', "_"))).map_err(|_| {
        anyhow!(
            "unknown effect '{kind}' (expected one of: {})",
            EffectKind::ALL
                .iter()
                .map(|k| k.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        )
    })
}

/// `lockstep plant new`: a plant of `model` with every inertial symbol at the model file's
/// value ([`Plant::new`] fills the defaults) and each effect kind of `effects` on each joint
/// of `joints` (every joint when empty) at neutral values.
///
/// # Errors
/// Unknown model, kind or joint; a pairwise kind (input_coupling needs `effect add
/// --from --to`); conflicting effects (two friction laws on a joint).
pub fn plant_new(model: &str, effects: &[String], joints: &[String]) -> Result<Plant> {
    let mut p = Plant::new(model, Vec::new())?;
    let m = p.model;
    p.description = format!("starting plant of model {model}: the model file's values");
    let js: Vec<usize> = if joints.is_empty() {
        (0..m.joints.len()).collect()
    } else {
        joints
            .iter()
            .map(|j| {
                m.joints.iter().position(|x| x == j).ok_or_else(|| {
                    anyhow!(
                        "--joints: unknown joint '{j}' (model '{}' has {})",
                        m.name,
                        m.joints.join(", ")
                    )
                })
            })
            .collect::<Result<_>>()?
    };
    for kind in effects {
        let k = effect_kind(kind).map_err(|e| anyhow!("--effects: {e}"))?;
        if k.is_pairwise() {
            bail!(
                "--effects: {k} acts between two joints: add it with `effect add {k} --from --to`"
            );
        }
        for &j in &js {
            let e = Effect::on(k, j);
            p.add_effect(e)?;
            for (n, sym) in e.parameter_names(p.model.joints).iter().zip(k.symbols()) {
                p.parameters.entry(n.clone()).or_insert(neutral(sym, None));
            }
        }
    }
    Ok(p)
}

/// `lockstep effect add`: add an effect of `kind` on `joint` (or a coupling `from` → `to`)
/// with neutral values, then `set` (name → value) and `bounds` (name → [lo, hi]); save to
/// `out`. Returns the new plant and the effect added.
///
/// # Errors
/// Unknown kind or joint, missing --joint / --from/--to, a conflicting effect on the joint,
/// a set or bound for a parameter the plant does not have, a value outside its bounds.
pub fn effect_add(
    plant: &Plant,
    kind: &str,
    joint: Option<&str>,
    from_to: (Option<&str>, Option<&str>),
    set: &[(String, f64)],
    bounds: &[(String, f64, f64)],
    out: &Path,
) -> Result<(Plant, Effect)> {
    let k = effect_kind(kind)?;
    let m = plant.model;
    let index = |name: &str, opt: &str| -> Result<usize> {
        m.joints.iter().position(|j| *j == name).ok_or_else(|| {
            anyhow!(
                "{opt}: unknown joint '{name}' (model '{}' has {})",
                m.name,
                m.joints.join(", ")
            )
        })
    };
    let e = if k.is_pairwise() {
        let (Some(f), Some(t)) = from_to else {
            bail!("input_coupling needs --from and --to (e.g. --from q5 --to q4)");
        };
        Effect::coupling(index(f, "--from")?, index(t, "--to")?)
    } else {
        let Some(j) = joint else {
            bail!("{k} needs --joint (e.g. --joint q3)");
        };
        Effect::on(k, index(j, "--joint")?)
    };
    let mut p = plant.clone();
    p.add_effect(e)?;
    let names = e.parameter_names(m.joints);
    for (n, sym) in names.iter().zip(k.symbols()) {
        if !p.parameters.contains_key(n) {
            p.parameters.insert(n.clone(), neutral(sym, None));
        }
    }
    let checked = set_and_save(p, &names, set, bounds, out)?;
    Ok((checked, e))
}

/// `lockstep effect add expression`: add the user-defined effect `name` on `joints`
/// (joint names separated by commas) with torque `torque` and parameters `parameters`
/// ([`crate::expression`]), each 0 until `set` gives it a value, `bounds` (name → [lo,
/// hi]); save to `out`. Returns the new plant.
///
/// # Errors
/// An unknown joint; the expression refused ([`Plant::add_expression`]: syntax, unknown
/// symbol, a parameter name taken, with the column); a set or bound for a parameter the
/// plant does not have; a divisor parameter without bounds that exclude 0.
pub fn expression_add(
    plant: &Plant,
    name: &str,
    joints: &str,
    (torque, parameters): (&str, &[String]),
    set: &[(String, f64)],
    bounds: &[(String, f64, f64)],
    out: &Path,
) -> Result<Plant> {
    let m = plant.model;
    let joints = joints
        .split(',')
        .map(|j| {
            let j = j.trim();
            m.joints.iter().position(|x| *x == j).ok_or_else(|| {
                anyhow!(
                    "--joint: unknown joint '{j}' (model '{}' has {})",
                    m.name,
                    m.joints.join(", ")
                )
            })
        })
        .collect::<Result<Vec<_>>>()?;
    let mut p = plant.clone();
    p.add_expression(name, joints, torque, parameters)?;
    for n in parameters {
        p.parameters.insert(n.clone(), 0.0);
    }
    set_and_save(p, parameters, set, bounds, out)
}

/// The tail of `effect add`: `set` and `bounds` applied to `p` (whose new parameters are
/// `names`), validated as a file would be, saved to `out`.
fn set_and_save(
    mut p: Plant,
    names: &[String],
    set: &[(String, f64)],
    bounds: &[(String, f64, f64)],
    out: &Path,
) -> Result<Plant> {
    let known = p.known_names();
    for (given, v) in set {
        let n = &p.current_name(given);
        if !known.contains(n) {
            bail!(
                "--set {n}: the plant has no parameter '{n}' (the new effect's are {})",
                names.join(", ")
            );
        }
        p.parameters.insert(n.clone(), *v);
    }
    for (given, lo, hi) in bounds {
        let n = &p.current_name(given);
        if !known.contains(n) {
            bail!("--bound {given}: the plant has no parameter '{given}'");
        }
        if lo > hi {
            bail!("--bound {n}: lower {lo} is above upper {hi}");
        }
        p.bounds.insert(n.clone(), (*lo, *hi));
    }
    // Validate as a file would be.
    let checked = Plant::from_file(p.to_file(), None)?;
    checked.save(out)?;
    Ok(checked)
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

fn inline_svg(path: &Path) -> Result<String> {
    let text =
        crate::files::read_output(path).with_context(|| format!("reading {}", path.display()))?;
    let start = text.find("<svg").unwrap_or(0);
    Ok(format!(
        "<div class=\"fig\">{}</div>\n",
        text[start..].replacen("<svg", "<svg style=\"max-width:100%;height:auto\"", 1)
    ))
}

fn findings_html(title: &str, findings: &[Finding], left: &[String], top: usize) -> String {
    let mut s = format!(
        "<h3>{}</h3>\n<table><tr><th>rank</th><th>joint</th><th>candidate</th><th>explained</th><th>ΔBIC</th><th>estimate</th><th>meaning</th></tr>\n",
        esc(title)
    );
    for (i, f) in findings.iter().take(top).enumerate() {
        let est = f.estimate_text();
        let _ = writeln!(
            s,
            "<tr class=\"{}\"><td>{}</td><td>{}</td><td>{}</td><td>{:.1} %</td><td>{:.1}</td><td>{}{}</td><td>{}</td></tr>",
            if f.significant { "sig" } else { "ns" },
            i + 1,
            esc(&f.joint),
            esc(&f.name),
            100.0 * f.explained,
            f.delta_bic,
            esc(&est),
            if f.confirmed { " (fitted)" } else { "" },
            esc(&f.meaning)
        );
    }
    s += "</table>\n";
    let _ = writeln!(
        s,
        "<p class=\"verdict\">{}</p>",
        esc(&crate::diagnose::verdict(findings, left))
    );
    s
}

fn history_html(history: &[HistoryEntry], out: &Path) -> Result<String> {
    if history.is_empty() {
        return Ok("<p>No changes recorded yet: <code>lockstep diagnose --apply 1</code> or <code>lockstep refit</code> add entries.</p>\n".into());
    }
    let mut s = "<table><tr><th>step</th><th>change</th><th>configuration</th><th>fitted</th><th>RMS before → after (per joint: position error, or torque residual in torque space)</th></tr>\n".to_string();
    for (i, h) in history.iter().enumerate() {
        let fitted = h
            .fitted
            .iter()
            .map(|(n, v)| format!("{n} = {v:.4e}"))
            .collect::<Vec<_>>()
            .join(", ");
        let rms = h
            .rms_before
            .iter()
            .map(|(j, b)| {
                let a = h.rms_after.get(j).copied().unwrap_or(f64::NAN);
                format!(
                    "{j}: {b:.3e} → {a:.3e} ({:.1} % less)",
                    100.0 * (1.0 - a / b)
                )
            })
            .collect::<Vec<_>>()
            .join("<br>");
        let _ = writeln!(
            s,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            i + 1,
            esc(&h.change),
            esc(&match &h.space {
                Some(space) => format!("{} ({space} space)", h.configuration),
                None => h.configuration.clone(),
            }),
            esc(&fitted),
            rms
        );
    }
    s += "</table>\n";
    // The error per joint along the history (log10 of the RMS).
    let mut joints: Vec<String> = Vec::new();
    for h in history {
        for j in h.rms_before.keys() {
            if !joints.contains(j) {
                joints.push(j.clone());
            }
        }
    }
    let series: Vec<Series> = joints
        .iter()
        .map(|j| {
            let mut x = Vec::new();
            let mut y = Vec::new();
            for (i, h) in history.iter().enumerate() {
                if let (Some(b), Some(a)) = (h.rms_before.get(j), h.rms_after.get(j)) {
                    x.extend([i as f64, i as f64 + 1.0]);
                    y.extend([b.log10(), a.log10()]);
                }
            }
            Series {
                name: j.clone(),
                x,
                y,
                style: Style::Line,
            }
        })
        .collect();
    let [svg, _] = figure(
        &out.join("history"),
        &[Panel {
            title: "RMS error per joint before and after each step".into(),
            x_label: "step".into(),
            y_label: "log10 RMS error".into(),
            series,
        }],
        900,
    )?;
    s += &inline_svg(&svg)?;
    Ok(s)
}

/// `lockstep report`: compare, diagnose and the plant's history in one self-contained HTML
/// file (`out/report.html`, figures inlined as SVG; also written beside it as SVG and PNG).
///
/// # Errors
/// As the commands it runs; I/O (path named).
pub fn report_command(
    plant: &Plant,
    inputs: &Inputs,
    out: &Path,
    top: usize,
    start: Option<&StartComparison>,
) -> Result<PathBuf> {
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let data = inputs.load(plant)?;
    // The diagnosis first: its leading significant finding is drawn over the residuals.
    let diag = diagnose(plant, inputs, &data)?;
    let leading = diag
        .first()
        .and_then(|(_, findings, _)| findings.iter().find(|f| f.significant));
    let cmps = compare_command(plant, inputs, &data, out, start, leading)?;
    let mut h = String::new();
    h += "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n";
    let _ = writeln!(h, "<title>lockstep report: {}</title>", esc(&plant.name()));
    h += "<style>body{font-family:sans-serif;max-width:1100px;margin:2em auto;color:#222}table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #ccc;padding:4px 8px;font-size:14px;text-align:left}th{background:#f0f0f0}tr.sig td{background:#fff4e0}tr.ns td{color:#777}.verdict{font-size:16px}.fig{margin:1em 0;border:1px solid #eee}code{background:#f4f4f4;padding:1px 4px}</style>\n</head><body>\n";
    let _ = writeln!(
        h,
        "<h1>Model versus measurement</h1>\n<p>Plant <code>{}</code> (model {}), {} space; data: {}.</p>",
        esc(&plant.name()),
        plant.model.name,
        if matches!(data, Data::Output { .. }) {
            "output (simulated positions)"
        } else {
            "torque (inverse model)"
        },
        esc(&inputs
            .data
            .iter()
            .map(|p| p.display().to_string())
            .collect::<Vec<_>>()
            .join(", "))
    );
    h += "<h2>Compare</h2>\n";
    if let Some(s) = start {
        let _ = writeln!(
            h,
            "<p>Beside the model, the starting plant <code>{}</code> (the line \"starting plant\" in each figure).</p>",
            esc(&s.file.display().to_string())
        );
    }
    h += "<table><tr><th>record</th><th>joint</th>";
    if start.is_some() {
        h += "<th>starting plant: NRMSE fit, RMSE</th>";
    }
    h += "<th>NRMSE fit</th><th>RMSE</th><th>max |e|</th><th>at t (s)</th><th>at q</th><th>at q̇</th><th>residual tests</th></tr>\n";
    for Compared {
        comparison: c,
        start: st,
        ..
    } in &cmps
    {
        let started = st.as_ref().map_or(String::new(), |s| {
            format!("<td>{:.2} %, {:.4e}</td>", s.nrmse_fit, s.rmse)
        });
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td>{}</td>{}<td>{:.2} %</td><td>{:.4e}</td><td>{:.4e}</td><td>{:.3}</td><td>{:.4}</td><td>{:.4}</td><td>{}</td></tr>",
            esc(&stem(&c.file)),
            esc(&c.joint),
            started,
            c.nrmse_fit,
            c.rmse,
            c.max_error.0.abs(),
            c.max_error.1,
            c.max_error_q,
            c.max_error.2,
            esc(&c.tests.verdict())
        );
    }
    h += "</table>\n";
    for Compared {
        comparison: c, svg, ..
    } in &cmps
    {
        let _ = writeln!(h, "<h3>{} — {}</h3>", esc(&stem(&c.file)), esc(&c.joint));
        h += &inline_svg(svg)?;
    }
    h += "<h2>Diagnose</h2>\n<p>Candidate effects ranked by ΔBIC = n ln(SSE/SST) + p ln n; significant when ΔBIC &lt; −10 and at least 5 % of the residual is explained; nothing is called missing only where the residual is white.</p>\n";
    for (title, f, left) in &diag {
        h += &findings_html(title, f, left, top);
    }
    h += "<h2>History</h2>\n";
    h += &history_html(&plant.history, out)?;
    h += "</body></html>\n";
    let path = out.join("report.html");
    write_atomic(&path, h.as_bytes())?;
    Ok(path)
}
