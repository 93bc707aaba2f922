//! The `lockstep` command line.

use crate::compare::{compare_torque, plot, write_residual_csv};
use crate::identify::identifiability::{base_parameters, markdown, occurrence};
use crate::identify::idim::{least_squares, observation, IdimOptions};
use crate::measurement::Measurement;
use crate::plant::Plant;
use crate::report::fit_table;
use crate::util::write_atomic;
use anyhow::{bail, Result};
use clap::{Args, Parser, Subcommand};
use std::path::PathBuf;

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
    /// Fit a plant's parameters to torque-measured data by IDIM-LS.
    Identify {
        #[command(flatten)]
        common: Common,
        /// Write the plant with the fitted values here.
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Compare a plant (with parameter values) with measurements: errors, residual CSV, plots.
    Compare {
        #[command(flatten)]
        common: Common,
        /// Output directory for residual CSVs and plots.
        #[arg(long, default_value = "lockstep-out/compare")]
        out: PathBuf,
    },
    /// List the generated models, their joints, parameters and configurations.
    Models,
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

/// Options shared by identify and compare.
#[derive(Debug, Args)]
pub struct Common {
    /// Plant file (model + effects + parameter values).
    #[arg(long)]
    pub plant: PathBuf,
    /// Measurement files (CSV; a side file <name>.toml may map the columns).
    #[arg(long, required = true, num_args = 1..)]
    pub data: Vec<PathBuf>,
    /// Configuration (set of free joints) of the data.
    #[arg(long, default_value = "full")]
    pub config: String,
    /// Cut-off of the zero-phase Butterworth on positions (Hz).
    #[arg(long, default_value_t = 100.0)]
    pub cutoff: f64,
    /// Order of that Butterworth.
    #[arg(long, default_value_t = 4)]
    pub order: usize,
    /// Parallel decimation factor.
    #[arg(long, default_value_t = 10)]
    pub decimate: usize,
}

impl Common {
    fn load(&self) -> Result<(Plant, Vec<Measurement>, IdimOptions)> {
        let plant = Plant::load(&self.plant)?;
        let nj = plant.model.joints.len();
        let records = self
            .data
            .iter()
            .map(|d| Measurement::read_csv(d, nj))
            .collect::<Result<Vec<_>, _>>()?;
        if self.order == 0 || self.order > 12 {
            bail!("--order: expected 1 to 12, got {}", self.order);
        }
        if self.decimate == 0 {
            bail!("--decimate: expected 1 or more");
        }
        Ok((
            plant,
            records,
            IdimOptions {
                cutoff_hz: self.cutoff,
                filter_order: self.order,
                decimation: self.decimate,
            },
        ))
    }
}

/// Run a parsed command line.
///
/// # Errors
/// Any failure, with a message naming the file or option.
pub fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Demo { out } => {
            let r = crate::demo::run(&crate::demo::bundled_data_dir(), &out)?;
            print!("{}", r.text);
            println!("\nOutputs (plant files, residual CSVs, plots as PNG and SVG, summary.txt) are in {}", r.out.display());
        }
        Command::Identify { common, out } => {
            let (mut plant, records, opts) = common.load()?;
            let fit = least_squares(&observation(&plant, &common.config, &records, &opts)?)?;
            println!(
                "IDIM-LS, plant {}, configuration {}, {} record(s)",
                common.plant.display(),
                common.config,
                records.len()
            );
            print!("{}", fit_table(&fit));
            if let Some(out) = out {
                fit.apply(&mut plant);
                plant.save(&out)?;
                println!("wrote {}", out.display());
            }
        }
        Command::Compare { common, out } => {
            let (plant, records, opts) = common.load()?;
            let cmps = compare_torque(&plant, &common.config, &records, &opts)?;
            println!(
                "{:<28} {:<6} {:>10} {:>12} {:>12} {:>10} {:>12}",
                "record", "joint", "error %", "RMSE", "max |e|", "at t (s)", "at qd"
            );
            for c in &cmps {
                let stem = c
                    .file
                    .file_stem()
                    .map(|s| s.to_string_lossy().into_owned())
                    .unwrap_or_default();
                let base = out.join(format!("{stem}_{}", c.joint));
                write_residual_csv(&base.with_extension("csv"), c)?;
                plot(&base, c, &stem)?;
                println!(
                    "{:<28} {:<6} {:>10.3} {:>12.4e} {:>12.4e} {:>10.3} {:>12.4e}",
                    stem,
                    c.joint,
                    c.relative_error,
                    c.rmse,
                    c.max_error.0.abs(),
                    c.max_error.1,
                    c.max_error.2
                );
                let (a, b) = c.sign_step;
                println!("    residual ~ a*sign(qd) + b + c*qd: a = {a:.4}, b = {b:.4} (a step of 2a at qd = 0 means missing Coulomb friction; b, an offset)");
            }
            println!("residual CSVs and plots (PNG, SVG) in {}", out.display());
        }
        Command::Params { model, out } => {
            let Some(m) = generated::model(&model) else {
                bail!(
                    "--model: unknown model '{model}' (generated models: {})",
                    generated::MODELS
                        .iter()
                        .map(|m| m.name)
                        .collect::<Vec<_>>()
                        .join(", ")
                );
            };
            let occ = occurrence(m);
            let bases: Vec<_> = m
                .configurations
                .iter()
                .map(|c| base_parameters(m, c))
                .collect();
            for seq in &occ.sequences {
                println!(
                    "sequence {}: {} first identified per step",
                    seq.name, occ.quantity
                );
                for (c, first) in &seq.steps {
                    println!("  {c:<6} {:>3}  {}", first.len(), first.join(", "));
                }
                println!(
                    "  nowhere {:>2}  {}",
                    seq.nowhere.len(),
                    seq.nowhere.join(", ")
                );
            }
            for b in &bases {
                println!(
                    "configuration {}: {} barycentric parameters appear, {} base parameters",
                    b.configuration, b.appearing, b.rank
                );
            }
            let md = markdown(&occ, &bases);
            let json = serde_json::to_string_pretty(&serde_json::json!({
                "occurrence": occ,
                "base_parameters": bases,
            }))?;
            std::fs::create_dir_all(&out)
                .map_err(|e| anyhow::anyhow!("{}: cannot create: {e}", out.display()))?;
            write_atomic(&out.join("parameters.md"), md.as_bytes())?;
            write_atomic(&out.join("parameters.json"), json.as_bytes())?;
            println!(
                "wrote {0}/parameters.md and {0}/parameters.json",
                out.display()
            );
        }
        Command::Models => {
            for m in generated::MODELS {
                println!(
                    "{}: joints {}; {} barycentric parameters ({})",
                    m.name,
                    m.joints.join(", "),
                    m.params.len(),
                    m.params.join(", ")
                );
                for c in m.configurations {
                    let free: Vec<&str> = c.free.iter().map(|&j| m.joints[j]).collect();
                    println!(
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
