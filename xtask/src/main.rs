//! `cargo xtask gen --model NAME [--config NAME]`: regenerate kernels by hand and print
//! what was written, the operation counts and the generation time.
//! `cargo xtask model show|dh FILE`: what the generator reads from any model file (`.toml` or
//! `.urdf`, in `model/` or not) and its equivalent DH table, without building it.
//!
//! `cargo build` regenerates the kernels by itself (generated/build.rs) whenever a model or
//! the generator changes; this command is for inspecting one model or configuration.

use anyhow::{bail, Context, Result};
use clap::{Parser, Subcommand};
use std::path::PathBuf;
use std::time::Instant;

#[derive(Parser)]
#[command(name = "xtask")]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Generate the kernels of one model (all configurations, or one).
    Gen {
        /// Model name (file model/<name>.toml); the default is the flagship, the Freedom 6S.
        #[arg(long, default_value = "freedom6s")]
        model: String,
        /// Only this configuration (name or 1-based index).
        #[arg(long)]
        config: Option<String>,
        /// Output directory.
        #[arg(long, default_value = "target/xtask-gen")]
        out: PathBuf,
    },
    /// Print what the generator reads from a model file, or its equivalent DH table.
    Model {
        /// `show` or `dh`.
        #[arg(value_parser = ["show", "dh"])]
        action: String,
        /// A model file (`.toml` or `.urdf`) or the name of one in model/.
        file: String,
    },
}

fn main() {
    // One line on stderr and exit 1, never a backtrace: the errors name file and item.
    if let Err(e) = run() {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

fn run() -> Result<()> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    let (model, config, out) = match Cli::parse().cmd {
        Cmd::Gen { model, config, out } => (model, config, out),
        Cmd::Model { action, file } => {
            let mut path = PathBuf::from(&file);
            if !path.exists() {
                path = root.join("model").join(format!("{file}.toml"));
            }
            let m = codegen::load(&path)?;
            if action == "show" {
                print!("{}", codegen::describe::describe(&m));
            } else {
                match codegen::dh::equivalent_dh(&m) {
                    Ok(t) => print!("{t}"),
                    Err(e) => bail!("{}: no DH table: {e}", path.display()),
                }
            }
            return Ok(());
        }
    };
    let file = root.join("model").join(format!("{model}.toml"));
    if !file.exists() {
        bail!("{}: no such model file", file.display());
    }
    let m = codegen::load(&file)?;
    let only = match &config {
        None => None,
        Some(c) => {
            let name = match c.parse::<usize>() {
                Ok(i) if i >= 1 && i <= m.configurations.len() => {
                    // A number names a configuration of the first sequence, or the i-th one.
                    match m.sequences.first() {
                        Some((_, steps)) if i <= steps.len() => {
                            m.configurations[steps[i - 1]].name.clone()
                        }
                        _ => m.configurations[i - 1].name.clone(),
                    }
                }
                _ => c.clone(),
            };
            Some(vec![name])
        }
    };
    let t0 = Instant::now();
    let g = codegen::generate::generate(&m, only.as_deref()).map_err(|e| anyhow::anyhow!("{e}"))?;
    let secs = t0.elapsed().as_secs_f64();
    std::fs::create_dir_all(&out).with_context(|| format!("cannot create {}", out.display()))?;
    let suffix = only
        .as_ref()
        .map(|o| format!("_{}", o[0]))
        .unwrap_or_default();
    let path = out.join(format!("{}{suffix}.rs", m.name));
    codegen::write_if_changed(&path, &g.source)?;
    eprintln!(
        "model {} ({}): symbolic model {:.2} s",
        m.name,
        file.display(),
        g.model_seconds
    );
    for c in &g.configs {
        let total: usize = c.ops.iter().map(|(_, o)| o.total()).sum();
        eprintln!(
            "  configuration {} (free {}): {} operations, {:.2} s",
            c.name,
            c.free.join(", "),
            total,
            c.seconds
        );
        for (k, o) in &c.ops {
            eprintln!(
                "    {k:<20} {:>6} add {:>6} mul {:>4} other",
                o.add, o.mul, o.other
            );
        }
    }
    eprintln!("wrote {} in {secs:.2} s", path.display());
    Ok(())
}
