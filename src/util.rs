//! Small shared helpers: atomic file output, TOML errors with line numbers, configuration
//! lookup.

use anyhow::{Context, Result};
use std::io::Write;
use std::path::Path;

/// Write `bytes` to `path` through a temporary file in the same directory and a rename, so
/// that a reader never sees a half-written file and a failure leaves no partial output.
///
/// # Errors
/// The directory cannot be created, or the write or rename fails (the path is named).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomic_with(path, |f| f.write_all(bytes).map_err(Into::into))
}

/// Like [`write_atomic`] with a writer callback; the temporary file is removed on error.
///
/// # Errors
/// As [`write_atomic`], or the callback's error.
pub fn write_atomic_with(
    path: &Path,
    fill: impl FnOnce(&mut std::io::BufWriter<std::fs::File>) -> Result<()>,
) -> Result<()> {
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    let tmp = dir.join(format!(".{name}.tmp{}", std::process::id()));
    let result = (|| -> Result<()> {
        let f = std::fs::File::create(&tmp)
            .with_context(|| format!("cannot create {}", tmp.display()))?;
        let mut w = std::io::BufWriter::new(f);
        fill(&mut w)?;
        w.flush()?;
        std::fs::rename(&tmp, path).with_context(|| format!("cannot write {}", path.display()))?;
        Ok(())
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
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
