//! The `lockstep` command line.

use anyhow::{bail, Result};
use clap::{ArgMatches, Args, Parser, Subcommand};
use lockstep::identify::equation_error::Cutoff;
use lockstep::identify::identifiability::{base_parameters, markdown, occurrence};
use lockstep::identify::idim::{observation, IdimOptions};
use lockstep::identify::output_error::{OutputErrorOptions, StageOptimiser};
use lockstep::identify::sequence::{JointFitMode, RigidBodyFit, SequenceOptions};
use lockstep::measurement::Measurement;
use lockstep::plant::Plant;
use lockstep::report::diagnosis::{
    apply_all_command, apply_finding, compare_command, diagnose, effect_add, refit_command,
    report_command, Inputs, StartComparison,
};
use lockstep::report::fit_table;
use lockstep::simulation::{Hold, Integrator};
use std::path::PathBuf;

mod args;
mod identify;
mod profile;
pub use args::*;
pub use identify::*;
use profile::*;

/// lockstep: symbolic robot models to Rust kernels; identification, model-vs-measurement
/// diagnosis and haptic control.
#[derive(Debug, Parser)]
#[command(name = "lockstep", version, about)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// Subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Run the main job on the bundled EMPS measurements: fit, see where the model fails,
    /// add the missing effects, watch the error fall.
    Demo {
        /// Output directory.
        #[arg(long, default_value = "lockstep-out/demo")]
        out: PathBuf,
    },
    /// Fit a plant's parameters: `identify idim` (IDIM-LS on torque measurements) or
    /// `identify sequence --preset isolated|coupled` (output error along a locking sequence
    /// on position measurements).
    Identify {
        /// The method.
        #[command(subcommand)]
        method: IdentifyMethod,
    },
    /// Compare a plant with measurements (MATLAB compare and resid): fit, errors and where
    /// they occur, residual CSVs, plots (residual vs time, position, velocity, torques;
    /// spectrum; autocorrelation and cross-correlation with 99 % bounds).
    Compare {
        #[command(flatten)]
        common: Common,
        #[command(flatten)]
        space: SpaceArgs,
        /// Output directory for residual CSVs and plots.
        #[arg(long, default_value = "lockstep-out/compare")]
        out: PathBuf,
        /// A starting plant (e.g. the plant before `diagnose --apply`), compared on the same
        /// data and drawn beside the model in each figure.
        #[arg(long)]
        start: Option<PathBuf>,
        /// A controller file (e.g. model/control/emps_controller.toml): compare in
        /// closed-loop space, the plant simulated under that controller on each file's
        /// reference, force or torque and velocity compared (DIDIM's simulation).
        #[arg(long, conflicts_with = "start")]
        controller: Option<PathBuf>,
    },
    /// Name the missing physical effect: rank a catalogue of candidate effects by how much
    /// of the residual each explains (ΔBIC), in torque space (inverse model) or output space
    /// (simulated positions); where none suffices, the built-ins outside the plant's own
    /// effects (cubic stiffness, cogging, quadratic drag, load-dependent friction) and a
    /// sparse description of the residual. `--apply K --out P.toml` adds finding K, refits
    /// it and records the step in the plant's history.
    Diagnose {
        #[command(flatten)]
        common: Common,
        #[command(flatten)]
        space: SpaceArgs,
        #[command(flatten)]
        fit: FitArgs,
        /// Candidates to print.
        #[arg(long, default_value_t = 5)]
        top: usize,
        /// Add finding K (1 = the first) to the plant and refit: output space, its
        /// parameters jointly with the changes recorded earlier on the configuration;
        /// torque space, every parameter of the inverse model (effects linear in their
        /// parameters). `all-significant`: apply the leading finding and diagnose again
        /// until nothing significant is missing.
        #[arg(long, requires = "out")]
        apply: Option<Apply>,
        /// With --apply: where to write the changed plant.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Output space: judge the candidates against the plant's values as they are. By
        /// default the values the configuration determines (those the plant gives bounds
        /// for) are refitted first and beside each candidate.
        #[arg(long)]
        keep_values: bool,
        /// A TOML file of candidate effects of your own ([[candidate]]: name, joints,
        /// torque, parameters with start and bounds), tested and ranked beside the
        /// catalogue; --apply adds one as a user-defined effect.
        #[arg(long)]
        candidates: Option<PathBuf>,
        /// A controller file: diagnose in closed-loop space (the catalogue on the inverse
        /// model of the plant simulated under that controller, against the measured forces
        /// or torques); --apply adds the finding and refits by DIDIM.
        #[arg(long, conflicts_with = "keep_values")]
        controller: Option<PathBuf>,
    },
    /// Refit chosen parameters (output error on position data; the inverse model's least
    /// squares, the other parameters held, on torque-measured data); print the error per
    /// joint before and after; append the step to the plant's history.
    Refit {
        #[command(flatten)]
        common: Common,
        #[command(flatten)]
        space: SpaceArgs,
        #[command(flatten)]
        fit: FitArgs,
        /// Parameters to fit (in output space each needs bounds in the plant file), e.g.
        /// Ks_q3,qeq_q3.
        #[arg(long, value_delimiter = ',', required = true)]
        params: Vec<String>,
        /// What changed, for the history (default: "refitted <params>").
        #[arg(long)]
        change: Option<String>,
        /// Plant file to write (default: the plant file itself).
        #[arg(long)]
        out: Option<PathBuf>,
        /// A controller file: refit in closed-loop space by DIDIM, the other parameters
        /// held (the inverse model's, so effects linear in their parameters).
        #[arg(long)]
        controller: Option<PathBuf>,
    },
    /// Start a plant: `plant new --model M --effects viscous,coulomb --out P.toml`.
    Plant {
        #[command(subcommand)]
        action: PlantAction,
    },
    /// Edit a plant's effects: `effect add KIND --joint q3 --plant P` (or `--from q5 --to
    /// q4` for input_coupling).
    Effect {
        #[command(subcommand)]
        action: EffectAction,
    },
    /// Compare, diagnose and the plant's history in one self-contained HTML report
    /// (`OUT/report.html`, figures inlined).
    Report {
        #[command(flatten)]
        common: Common,
        #[command(flatten)]
        space: SpaceArgs,
        #[command(flatten)]
        fit: FitArgs,
        /// Candidates listed.
        #[arg(long, default_value_t = 8)]
        top: usize,
        /// Output directory.
        #[arg(long, default_value = "lockstep-out/report")]
        out: PathBuf,
        /// A starting plant (e.g. the plant before `diagnose --apply`), compared on the same
        /// data and drawn beside the model in each figure.
        #[arg(long)]
        start: Option<PathBuf>,
    },
    /// List the generated models, their joints, parameters and configurations.
    Models,
    /// What the generator read for one model (joints, frames, links with default values,
    /// configurations), or its equivalent DH table.
    Model {
        #[command(subcommand)]
        action: ModelAction,
    },
    /// Sample an excitation of the thesis (Tables 4.3, 4.4, 4.5, 4.7, 4.9) for a configuration
    /// and write a torque (or position-command) file with a side file naming the configuration.
    Excite {
        /// Model name.
        #[arg(long)]
        model: String,
        /// Table id (4.3, 4.4, 4.5, 4.7, 4.9).
        #[arg(long)]
        table: String,
        /// Test of the table (needed when it has several; the error lists them).
        #[arg(long)]
        test: Option<String>,
        /// Configuration: only its free joints are driven.
        #[arg(long)]
        config: String,
        /// Duration (s).
        #[arg(value_parser = parse_positive, long, default_value_t = 60.0)]
        duration: f64,
        /// Sampling rate (Hz).
        #[arg(value_parser = parse_positive, long, default_value_t = 100.0)]
        rate: f64,
        /// Excitation file (default: the tables bundled for the model).
        #[arg(long)]
        excitation: Option<PathBuf>,
        /// Output file (.csv or .mat).
        #[arg(long, short)]
        out: PathBuf,
    },
    /// Run a plant on a torque file (RK4 or ETDRK4) and write a measurement file, optionally with
    /// position noise and quantisation: synthetic data with any effect switched on.
    Simulate(Box<SimulateArgs>),
    /// Check a plant: physical consistency of every link (mass, positive-definite inertia,
    /// triangle inequality) and, per configuration, what a simulation needs.
    Check {
        /// Plant file.
        #[arg(long)]
        plant: PathBuf,
        /// A plant file of values a fit from `--plant` should be able to reach (a published
        /// result, the truth of synthetic data): lists those outside `--plant`'s bounds.
        #[arg(long)]
        against: Option<PathBuf>,
    },
    /// Closed-loop PD verification (thesis 4.5): PD per joint with the filtered error
    /// derivative (4.7), position commands of Table 4.9, small and big gains of Table 4.8;
    /// simulated vs commanded (and measured, if given) positions, fit figures, plots.
    Closedloop {
        /// Closed-loop file (gains, filter, commands, plant).
        #[arg(long, default_value = "model/control/freedom6s_closedloop.toml")]
        spec: PathBuf,
        /// Plant file replacing the closed-loop file's.
        #[arg(long)]
        plant: Option<PathBuf>,
        /// Gain sets to run (default: all in the file).
        #[arg(long, num_args = 1..)]
        gains: Vec<String>,
        /// Measured closed-loop runs, one per gain set in the same order (CSV or .mat with
        /// t and q_J of each joint J).
        #[arg(long, num_args = 1..)]
        measured: Vec<PathBuf>,
        /// Duration (s), replacing the file's.
        #[arg(long, value_parser = parse_positive)]
        duration: Option<f64>,
        /// Output directory.
        #[arg(long, default_value = "lockstep-out/closedloop")]
        out: PathBuf,
    },
    /// Haptic virtual wall on joint 0 (thesis Chapter 5): PD vs fuzzy over the approach
    /// speeds and the hand sweep, chatter metrics, position plots (Figures 5.10-5.12),
    /// control surfaces (5.7-5.9), rule tables as FLL and FIS. `wall tune` tunes the rules.
    #[command(args_conflicts_with_subcommands = true)]
    Wall {
        /// `tune`: tune the fuzzy rules against the simulated user.
        #[command(subcommand)]
        action: Option<WallAction>,
        #[command(flatten)]
        args: WallArgs,
    },
    /// Parameter occurrence per configuration and along each locking sequence (thesis
    /// Figure 4.2), and the base (identifiable) parameters of every configuration; writes
    /// parameters.md and parameters.json.
    Params {
        /// Model name (see `lockstep models`).
        #[arg(long)]
        model: String,
        /// Output directory.
        #[arg(long, default_value = "lockstep-out/params")]
        out: PathBuf,
    },
}

/// `lockstep model …`.
#[derive(Debug, Subcommand)]
pub enum ModelAction {
    /// Print the joints (with the URDF joint each comes from), the frames as products of
    /// elementary transforms, the links with their inertial symbols and default values, the
    /// configurations and the consistency warnings.
    Show {
        /// Model name (see `lockstep models`).
        model: String,
    },
    /// Print the equivalent modified (Craig) DH table as model-file TOML, checked against
    /// the model's kinematics; exit 1 with the reason where none exists (a tree, a coupled
    /// or mimic joint).
    Dh {
        /// Model name (see `lockstep models`).
        model: String,
    },
}

/// Run a parsed command line.
///
/// # Errors
/// Any failure, with a message naming the file or option.
pub fn run(cli: Cli) -> Result<()> {
    // A command's outputs are written together at its end, or not at all
    // ([`lockstep::files::all_or_nothing`]); the identification sequences instead keep each
    // completed step's files, so that an interrupted run can be resumed.
    let keeps_each_step = matches!(
        &cli.command,
        Command::Identify {
            method: IdentifyMethod::Sequence(_)
        }
    );
    if keeps_each_step {
        run_command(cli)
    } else {
        lockstep::files::all_or_nothing(|| run_command(cli))
    }
}

/// The starting plant of `--start`, when given, with its file.
fn start_comparison<'a>(
    plant: &'a Option<Plant>,
    file: Option<&'a std::path::Path>,
) -> Option<StartComparison<'a>> {
    Some(StartComparison {
        plant: plant.as_ref()?,
        file: file?,
    })
}

fn run_command(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Demo { out } => {
            lockstep::files::check_output_dir(&out)?;
            let r = lockstep::demo::run(&lockstep::demo::bundled_data_dir(), &out)?;
            lockstep::out!("{}", r.text);
            lockstep::outln!("\nOutputs (plant files, residual CSVs, plots as PNG and SVG, summary.txt) are in {}", r.out.display());
        }
        Command::Identify { method } => match method {
            IdentifyMethod::Idim {
                common,
                out,
                allow_inconsistent,
                weighting,
                consistent,
            } => identify_idim(&common, out, allow_inconsistent, weighting, consistent)?,
            IdentifyMethod::Sequence(args) => identify_sequence(&args)?,
            IdentifyMethod::Didim {
                files,
                controller,
                out,
            } => {
                if let Some(out) = &out {
                    lockstep::files::check_writable(&[out])?;
                }
                let plant = Plant::load(&files.plant)?;
                lockstep::report::control::didim_command(
                    &plant,
                    &controller,
                    &files.data,
                    (&[], None),
                    out.as_deref(),
                )?;
            }
        },
        Command::Compare {
            common,
            space: _,
            out,
            start: _,
            controller: Some(controller),
        } => {
            lockstep::files::check_output_dir(&out)?;
            let (plant, _) = common.load_plant()?;
            lockstep::report::control::closed_loop_compare_command(
                &plant,
                &controller,
                &common.files.data,
                &out,
            )?;
        }
        Command::Compare {
            common,
            space,
            out,
            start,
            controller: None,
        } => {
            lockstep::files::check_output_dir(&out)?;
            let (plant, inputs) = common.inputs(&space)?;
            let start_plant = start.as_deref().map(Plant::load).transpose()?;
            let start = start_comparison(&start_plant, start.as_deref());
            compare_command(
                &plant,
                &inputs,
                &inputs.load(&plant)?,
                &out,
                start.as_ref(),
                None,
            )?;
        }
        Command::Diagnose {
            common,
            space,
            fit,
            top,
            apply,
            out,
            keep_values,
            candidates,
            controller,
        } => {
            if let Some(out) = &out {
                lockstep::files::check_writable(&[out])?;
            }
            if let Some(controller) = controller {
                fit.closed_loop()?;
                let (plant, _) = common.load_plant()?;
                let user = match &candidates {
                    Some(path) => lockstep::diagnose::candidates::read(path)?,
                    None => Vec::new(),
                };
                let apply = apply.map(|a| match a {
                    Apply::Finding(k) => (k, false),
                    Apply::AllSignificant => (1, true),
                });
                lockstep::report::control::closed_loop_diagnose_command(
                    &plant,
                    &controller,
                    &common.files.data,
                    (top, &user),
                    apply,
                    out.as_deref(),
                )?;
                return Ok(());
            }
            let (plant, mut inputs) = common.inputs(&space)?;
            inputs.refit_values = !keep_values;
            fit.apply(&mut inputs);
            if let Some(path) = &candidates {
                use lockstep::diagnose::candidates;
                inputs.candidates = candidates::read(path)?;
                let (_, left_out) = candidates::for_plant(&inputs.candidates, &plant)
                    .map_err(|e| anyhow::anyhow!("{}: {e:#}", path.display()))?;
                for line in left_out {
                    lockstep::outln!("{line}");
                }
            }
            let data = inputs.load(&plant)?;
            if let (Some(Apply::AllSignificant), Some(out)) = (apply, &out) {
                // The loop diagnoses (and prints) the plant itself, before each step.
                let (end, steps, history) = apply_all_command(&plant, &inputs, &data, out, top)?;
                lockstep::outln!(
                    "{end}; wrote {} ({steps} steps applied, history: {history} steps)",
                    out.display(),
                );
                return Ok(());
            }
            let results = diagnose(&plant, &inputs, &data)?;
            for (title, findings, above_noise) in &results {
                lockstep::outln!("plant {}, {title}:", plant.name());
                lockstep::out!(
                    "{}",
                    lockstep::diagnose::table_with(findings, top, above_noise)
                );
            }
            if let (Some(Apply::Finding(k)), Some(out)) = (apply, out) {
                // Torque space diagnoses each record; a step is taken on all of them
                // together, so with several records their joint diagnosis is printed too.
                let joint = match &data {
                    lockstep::report::diagnosis::Data::Torque {
                        config,
                        records,
                        idim,
                    } if records.len() > 1 => {
                        let obs = observation(&plant, config, records, idim)?;
                        let (user, _) = lockstep::diagnose::candidates::columns(
                            &inputs.candidates,
                            &plant,
                            config,
                            records,
                            idim,
                        )?;
                        let d = lockstep::diagnose::torque::diagnosis_with(&plant, &obs, &user)?;
                        lockstep::outln!(
                            "plant {}, all {} records together:",
                            plant.name(),
                            records.len()
                        );
                        lockstep::out!("{}", d.table(top));
                        Some(d.findings)
                    }
                    _ => None,
                };
                let findings = joint.as_deref().unwrap_or(&results[0].1);
                let history = apply_finding(&plant, &inputs, &data, findings, k, &out)?;
                lockstep::outln!("wrote {} (history: {history} steps)", out.display());
            }
        }
        Command::Refit {
            common,
            space,
            fit,
            params,
            change,
            out,
            controller,
        } => {
            let out = out.unwrap_or_else(|| common.files.plant.clone());
            lockstep::files::check_writable(&[&out])?;
            if let Some(controller) = controller {
                fit.closed_loop()?;
                let (plant, _) = common.load_plant()?;
                let params: Vec<String> = params.iter().map(|p| plant.current_name(p)).collect();
                let change = change.unwrap_or_else(|| {
                    format!("refitted {} in closed loop (DIDIM)", params.join(", "))
                });
                lockstep::report::control::didim_command(
                    &plant,
                    &controller,
                    &common.files.data,
                    (&params, Some(&change)),
                    Some(&out),
                )?;
                return Ok(());
            }
            let (plant, mut inputs) = common.inputs(&space)?;
            fit.apply(&mut inputs);
            let params: Vec<String> = params.iter().map(|p| plant.current_name(p)).collect();
            let change = change.unwrap_or_else(|| format!("refitted {}", params.join(", ")));
            refit_command(&plant, &inputs, &params, &change, &out)?;
            lockstep::outln!("wrote {}", out.display());
        }
        Command::Plant {
            action:
                PlantAction::New {
                    model,
                    effects,
                    joints,
                    out,
                },
        } => {
            lockstep::files::check_writable(&[&out])?;
            let p = lockstep::report::diagnosis::plant_new(&model, &effects, &joints)?;
            p.save(&out)?;
            let m = p.model;
            let numeric = (0..m.links.len())
                .filter(|&l| !m.symbol_link.contains(&l))
                .count();
            lockstep::outln!(
                "wrote {}: model {}, {} inertial symbol(s) at the model file's values, {} link(s) in numbers in the model file, {} effect(s)",
                out.display(),
                m.name,
                m.inertial_symbols
                    .iter()
                    .filter(|s| p.parameters.contains_key(**s))
                    .count(),
                numeric,
                p.effects.len()
            );
        }
        Command::Effect {
            action:
                EffectAction::Add {
                    kind,
                    plant,
                    joint,
                    name,
                    torque,
                    params,
                    from,
                    to,
                    set,
                    bound,
                    out,
                },
        } => {
            let p = Plant::load(&plant)?;
            let out = out.unwrap_or_else(|| plant.clone());
            lockstep::files::check_writable(&[&out])?;
            let kind = if kind == "coupling" {
                "input_coupling".to_string()
            } else {
                kind
            };
            let set: Vec<(String, f64)> = merged("--set", set)?.into_iter().collect();
            let (new, added) = if kind == "expression" {
                let (Some(name), Some(joint), Some(torque)) = (&name, &joint, &torque) else {
                    bail!("expression needs --name, --joint and --torque (e.g. --name cubic --joint q3 --torque \"K3*q_q3^3\" --params K3)");
                };
                let new = lockstep::report::diagnosis::expression_add(
                    &p,
                    name,
                    joint,
                    (torque, &params),
                    &set,
                    &bound,
                    &out,
                )?;
                (new, params)
            } else {
                if name.is_some() || torque.is_some() || !params.is_empty() {
                    bail!("--name, --torque and --params are for 'expression' (a user-defined effect), not '{kind}'");
                }
                let (new, effect) = effect_add(
                    &p,
                    &kind,
                    joint.as_deref(),
                    (from.as_deref(), to.as_deref()),
                    &set,
                    &bound,
                    &out,
                )?;
                let names = effect.parameter_names(new.model.joints);
                (new, names)
            };
            lockstep::outln!(
                "added {kind} to {}: {}",
                out.display(),
                added
                    .iter()
                    .map(|n| format!("{n} = {}", new.parameters[n]))
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
        Command::Report {
            common,
            space,
            fit,
            top,
            out,
            start,
        } => {
            lockstep::files::check_output_dir(&out)?;
            let (plant, mut inputs) = common.inputs(&space)?;
            fit.apply(&mut inputs);
            let start_plant = start.as_deref().map(Plant::load).transpose()?;
            let start = start_comparison(&start_plant, start.as_deref());
            let path = report_command(&plant, &inputs, &out, top, start.as_ref())?;
            lockstep::outln!("wrote {}", path.display());
        }
        Command::Excite {
            model,
            table,
            test,
            config,
            duration,
            rate,
            excitation,
            out,
        } => {
            let m = model_named(&model)?;
            let inputs: Vec<&std::path::Path> = excitation.iter().map(|p| p.as_path()).collect();
            lockstep::measurement::check_side_file_target(&out, &inputs)?;
            let ex = match &excitation {
                Some(p) => lockstep::excitation::Excitations::load(p, m)?,
                None => lockstep::excitation::Excitations::bundled(m)?,
            };
            let e = lockstep::synthetic::excite(
                m,
                &ex,
                &table,
                test.as_deref(),
                &config,
                duration,
                rate,
            )?;
            e.write(&out)?;
            if !e.left_out.is_empty() {
                lockstep::errln!(
                    "note: {} locked in configuration {config}: their signals of table {table} are not applied",
                    e.left_out.join(", ")
                );
            }
            lockstep::outln!(
                "wrote {} ({} samples, {}) and its side file {}",
                out.display(),
                e.t.len(),
                e.side.description,
                out.with_extension("toml").display()
            );
        }
        Command::Simulate(args) => {
            let SimulateArgs {
                plant, input, out, ..
            } = &*args;
            lockstep::measurement::check_side_file_target(out, &[plant, input])?;
            let p = Plant::load(plant)?;
            let opts = args.options()?;
            let started = std::time::Instant::now();
            let sim = lockstep::synthetic::simulate_file(&p, input, &opts)?;
            let elapsed = started.elapsed().as_secs_f64();
            for f in &sim.findings {
                lockstep::errln!("warning: {}: {f}", plant.display());
            }
            for n in &sim.notes {
                lockstep::errln!("note: {n}");
            }
            sim.write(out)?;
            let m = &sim.measurement;
            let span = m.t[m.len() - 1] - m.t[0];
            lockstep::outln!(
                "simulated {span:.3} s of configuration {} in {elapsed:.3} s ({:.0} RK4 steps/s); wrote {} and {}",
                sim.side.configuration.as_deref().unwrap_or("?"),
                span / opts.h / elapsed.max(1e-9),
                out.display(),
                out.with_extension("toml").display()
            );
        }
        Command::Check { plant, against } => {
            let p = Plant::load(&plant)?;
            let m = p.model;
            let reference = match &against {
                Some(other) => {
                    let o = Plant::load(other)?;
                    if o.model.name != m.name {
                        bail!(
                            "{}: model '{}', but {} is of model '{}'",
                            other.display(),
                            o.model.name,
                            plant.display(),
                            m.name
                        );
                    }
                    Some((other, o))
                }
                None => None,
            };
            lockstep::outln!(
                "plant {} (model {}): {}",
                plant.display(),
                m.name,
                p.description
            );
            let all = p.consistency(&p.barycentric(None)?, None);
            if all.is_empty() {
                lockstep::outln!("every link is physically consistent");
            }
            for f in &all {
                lockstep::outln!(
                    "  {} {f}",
                    if f.is_blocking() {
                        "IMPOSSIBLE "
                    } else {
                        "implausible"
                    }
                );
            }
            for c in m.configurations {
                let q = vec![0.0; m.joints.len()];
                match p.simulator(c.name, &q, lockstep::plant::ConsistencyPolicy::Warn) {
                    Ok(s) => {
                        let blocking = s.findings.iter().filter(|f| f.is_blocking()).count();
                        lockstep::outln!(
                            "  configuration {:<6} simulates{}",
                            c.name,
                            if blocking > 0 {
                                format!(" only with --allow-inconsistent ({blocking} impossible link(s) in its equations)")
                            } else {
                                String::new()
                            }
                        );
                    }
                    Err(e) => {
                        lockstep::outln!("  configuration {:<6} cannot simulate: {e:#}", c.name)
                    }
                }
            }
            if let Some((other, o)) = reference {
                let outside = p.outside_bounds(&o.parameters);
                if outside.is_empty() {
                    lockstep::outln!("every value of {} lies within the bounds", other.display());
                } else {
                    lockstep::outln!(
                        "{} value(s) of {} outside the bounds (a fit from this plant cannot reach them):",
                        outside.len(),
                        other.display()
                    );
                }
                for (n, v, (lo, hi)) in &outside {
                    lockstep::outln!("  {n} = {v:.5e} outside [{lo:.5e}, {hi:.5e}]");
                }
            }
        }
        Command::Params { model, out } => {
            let m = model_named(&model)?;
            let occ = occurrence(m);
            let bases: Vec<_> = m
                .configurations
                .iter()
                .map(|c| base_parameters(m, c))
                .collect();
            // The files first: a reader that closes the pipe early loses nothing.
            let md = markdown(&occ, &bases);
            let json = serde_json::to_string_pretty(&serde_json::json!({
                "occurrence": occ,
                "base_parameters": bases,
            }))?;
            lockstep::files::check_output_dir(&out)?;
            lockstep::files::write_all_atomic(&[
                (out.join("parameters.md"), md.into_bytes()),
                (out.join("parameters.json"), json.into_bytes()),
            ])?;
            for seq in &occ.sequences {
                lockstep::outln!(
                    "sequence {}: {} first identified per step",
                    seq.name,
                    occ.quantity
                );
                for (c, first) in &seq.steps {
                    lockstep::outln!("  {c:<6} {:>3}  {}", first.len(), first.join(", "));
                }
                lockstep::outln!(
                    "  nowhere {:>2}  {}",
                    seq.nowhere.len(),
                    seq.nowhere.join(", ")
                );
            }
            for b in &bases {
                lockstep::outln!(
                    "configuration {}: {} barycentric parameters appear, {} base parameters",
                    b.configuration,
                    b.appearing,
                    b.rank
                );
            }
            lockstep::outln!(
                "wrote {0}/parameters.md and {0}/parameters.json",
                out.display()
            );
        }
        Command::Closedloop {
            spec,
            plant,
            gains,
            measured,
            duration,
            out,
        } => lockstep::report::control::closedloop_command(
            &bundled_path(&spec),
            plant.as_deref(),
            &gains,
            &measured,
            duration,
            &out,
        )?,
        Command::Wall { action, args } => match action {
            None => lockstep::report::control::wall_command(&bundled_wall_args(args))?,
            Some(WallAction::Tune { args }) => {
                lockstep::report::control::tune_command(&bundled_wall_args(args))?
            }
        },
        Command::Model { action } => match action {
            ModelAction::Show { model } => {
                lockstep::outln!("{}", model_named(&model)?.description.trim_end());
            }
            ModelAction::Dh { model } => {
                let m = model_named(&model)?;
                match m.dh_table {
                    Ok(t) => lockstep::outln!("{}", t.trim_end()),
                    Err(e) => bail!("model '{model}' has no DH table: {e}"),
                }
            }
        },
        Command::Models => {
            for m in generated::MODELS {
                lockstep::outln!(
                    "{}: joints {}; {} barycentric parameters ({})",
                    m.name,
                    m.joints.join(", "),
                    m.params.len(),
                    m.params.join(", ")
                );
                for c in m.configurations {
                    let free: Vec<&str> = c.free.iter().map(|&j| m.joints[j]).collect();
                    lockstep::outln!(
                        "  configuration {}: free {}; parameters present {}",
                        c.name,
                        free.join(", "),
                        c.params_present.len()
                    );
                }
            }
        }
    }
    Ok(())
}
