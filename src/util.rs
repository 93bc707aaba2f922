//! Small shared helpers: TOML errors with line numbers, configuration lookup.

use anyhow::{Context, Result};
use std::io::Write;
use std::sync::atomic::{AtomicBool, Ordering};

static STDOUT_CLOSED: AtomicBool = AtomicBool::new(false);

/// Write to standard output; once the reader has gone (a closed pipe: `lockstep models |
/// head -1`), further output is dropped quietly and the command goes on to write its files
/// and exit 0, as coreutils do for a closed pipe. Used through [`out!`](crate::out) and
/// [`outln!`](crate::outln).
pub fn print_stdout(args: std::fmt::Arguments) {
    if STDOUT_CLOSED.load(Ordering::Relaxed) {
        return;
    }
    let mut out = std::io::stdout().lock();
    if out.write_fmt(args).and_then(|_| out.flush()).is_err() {
        STDOUT_CLOSED.store(true, Ordering::Relaxed);
    }
}

/// Write to standard error, ignoring a closed stream (warnings and progress).
pub fn print_stderr(args: std::fmt::Arguments) {
    let _ = std::io::stderr().lock().write_fmt(args);
}

/// `print!` that survives a closed pipe ([`util::print_stdout`](crate::util::print_stdout)).
#[macro_export]
macro_rules! out {
    ($($t:tt)*) => { $crate::util::print_stdout(format_args!($($t)*)) };
}

/// `println!` that survives a closed pipe ([`util::print_stdout`](crate::util::print_stdout)).
#[macro_export]
macro_rules! outln {
    () => { $crate::util::print_stdout(format_args!("\n")) };
    ($($t:tt)*) => { $crate::util::print_stdout(format_args!("{}\n", format_args!($($t)*))) };
}

/// `eprintln!` that survives a closed stream, for warnings and notes (stdout carries
/// results only).
#[macro_export]
macro_rules! errln {
    ($($t:tt)*) => { $crate::util::print_stderr(format_args!("{}\n", format_args!($($t)*))) };
}

/// Refuse a computation that would need about `bytes` of memory when that is more than half
/// of the memory available (Linux `MemAvailable`; elsewhere 8 GiB is assumed), or more
/// than 64 GiB: a clear message instead of an allocation failure (abort).
///
/// # Errors
/// Too large; `what` names the argument that sets the size.
pub fn check_memory(bytes: f64, what: &str) -> Result<()> {
    let available = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|t| {
            t.lines()
                .find(|l| l.starts_with("MemAvailable:"))
                .and_then(|l| l.split_whitespace().nth(1)?.parse::<f64>().ok())
        })
        .map_or(8.0 * (1u64 << 30) as f64, |kib| kib * 1024.0);
    let limit = (available / 2.0).min(64.0 * (1u64 << 30) as f64);
    if !(bytes <= limit) {
        anyhow::bail!(
            "{what}: would need about {:.1} GiB of memory, more than the {:.1} GiB this command allows itself (half of what is available); shorten it",
            bytes / (1u64 << 30) as f64,
            limit / (1u64 << 30) as f64
        );
    }
    Ok(())
}

/// Singular value decomposition (U and Vᵀ computed) that can neither hang nor panic: `None`
/// when `a` holds a non-finite entry or the iteration does not converge. nalgebra's `svd`
/// iterates forever on a NaN or infinite entry and panics sorting NaN singular values;
/// every least-squares solve of lockstep goes through here.
pub fn svd(a: nalgebra::DMatrix<f64>) -> Option<nalgebra::SVD<f64, nalgebra::Dyn, nalgebra::Dyn>> {
    if !a.iter().all(|x| x.is_finite()) {
        return None;
    }
    let limit = 1000 + 100 * a.nrows().min(a.ncols());
    a.try_svd(true, true, f64::EPSILON, limit)
}

/// Singular values only, under the same guards as [`svd`].
pub fn singular_values(a: &nalgebra::DMatrix<f64>) -> Option<nalgebra::DVector<f64>> {
    if !a.iter().all(|x| x.is_finite()) {
        return None;
    }
    let limit = 1000 + 100 * a.nrows().min(a.ncols());
    a.clone()
        .try_svd(false, false, f64::EPSILON, limit)
        .map(|s| s.singular_values)
}

/// A TOML parse error as one line: `origin: line N: message`.
pub fn toml_error(origin: &str, text: &str, e: &toml::de::Error) -> anyhow::Error {
    let line = e
        .span()
        .map(|s| text[..s.start.min(text.len())].matches('\n').count() + 1);
    anyhow::anyhow!(
        "{origin}{}: {}",
        line.map(|l| format!(": line {l}")).unwrap_or_default(),
        e.message().replace('`', "'")
    )
}

/// A generated model by name.
///
/// # Errors
/// Unknown name (the generated models are listed).
pub fn model(name: &str) -> Result<&'static generated::Model> {
    generated::model(name).with_context(|| {
        format!(
            "unknown model '{name}' (generated models: {})",
            generated::MODELS
                .iter()
                .map(|m| m.name)
                .collect::<Vec<_>>()
                .join(", ")
        )
    })
}

/// A configuration of `model` by name.
///
/// # Errors
/// Unknown name (the model's configurations are listed).
pub fn configuration(
    model: &'static generated::Model,
    name: &str,
) -> Result<&'static generated::Configuration> {
    model.configuration(name).with_context(|| {
        format!(
            "model '{}' has no configuration '{name}' (it has {})",
            model.name,
            model
                .configurations
                .iter()
                .map(|c| c.name)
                .collect::<Vec<_>>()
                .join(", ")
        )
    })
}
