//! `identify sequence --profile FILE` and `--set FIELD=VALUE`: output-error options by
//! their field names, merged onto the options the flags built.

use super::*;

/// The fields of [`OutputErrorOptions`] each command-line flag sets (clap ids): a given flag
/// wins over `--profile` for its fields.
pub(super) const FIELD_FLAGS: &[(&str, &[&str])] = &[
    ("weighting", &["cost", "skip"]),
    ("interest_weight", &["weight"]),
    ("h", &["step"]),
    ("integrator", &["integrator"]),
    ("hold", &["hold"]),
    ("xtol", &["xtol"]),
    ("ftol", &["ftol"]),
    ("max_iter", &["max_iter"]),
    ("starts", &["starts"]),
    ("seed", &["seed"]),
    ("jacobian", &["jacobian"]),
    ("jacobian_refresh", &["jacobian_refresh"]),
    ("horizons", &["horizons"]),
    ("segments", &["segments"]),
    ("least_change", &["least_change"]),
    ("prior", &["prior"]),
    ("carried_prior", &["carried_prior"]),
    ("equation_error", &["equation_error"]),
    ("predictor", &["predictor"]),
    ("predictor_step", &["predictor_step"]),
    ("predictor_optimiser", &["predictor_optimiser"]),
    ("whole_files_optimiser", &["whole_files_optimiser"]),
    ("estimate_initial_positions", &["initial_positions"]),
    ("noise_sigma", &["noise_sigma"]),
];

/// The option fields a profile file sets: a TOML table of [`OutputErrorOptions`] fields,
/// or a `report.json` whose `options` it takes (any other JSON: the object itself).
///
/// # Errors
/// The file cannot be read or parsed, or is not a table.
pub(super) fn profile_fields(
    path: &std::path::Path,
) -> Result<serde_json::Map<String, serde_json::Value>> {
    use anyhow::Context as _;
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read the profile", path.display()))?;
    let is_json = path.extension().is_some_and(|e| e == "json");
    let fields: serde_json::Value = if is_json {
        let v: serde_json::Value = serde_json::from_str(&text)
            .with_context(|| format!("{}: not a JSON file", path.display()))?;
        v.get("options").cloned().unwrap_or(v)
    } else {
        let t: toml::Table =
            toml::from_str(&text).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
        serde_json::to_value(t)?
    };
    match fields {
        serde_json::Value::Object(m) => Ok(m),
        _ => bail!("{}: expected a table of option fields", path.display()),
    }
}

/// One `--set FIELD=VALUE`: the field and its value read as TOML (a bare word that is not
/// TOML, such as `Etdrk4`, as a string).
///
/// # Errors
/// No `=`, or an empty field name.
pub(super) fn set_field(kv: &str) -> Result<(String, serde_json::Value)> {
    let Some((k, v)) = kv.split_once('=').filter(|(k, _)| !k.trim().is_empty()) else {
        bail!("--set '{kv}': expected FIELD=VALUE, e.g. max_speed=300");
    };
    let (k, v) = (k.trim(), v.trim());
    let value = match toml::from_str::<toml::Table>(&format!("x = {v}")) {
        Ok(mut t) => serde_json::to_value(t.remove("x"))?,
        Err(_) => serde_json::Value::String(v.to_string()),
    };
    Ok((k.to_string(), value))
}

/// `base` with `fields` (named [`OutputErrorOptions`] fields and their values; `origin`,
/// a file or `--set`, names them in errors), but for those `kept` names.
///
/// # Errors
/// A field that is not an option, or a value of the wrong type (both named with `origin`).
pub(super) fn with_fields(
    base: &OutputErrorOptions,
    fields: &serde_json::Map<String, serde_json::Value>,
    origin: &str,
    kept: &dyn Fn(&str) -> bool,
) -> Result<OutputErrorOptions> {
    let mut merged = serde_json::to_value(base)?;
    let known: Vec<String> = merged
        .as_object()
        .map(|m| m.keys().cloned().collect())
        .unwrap_or_default();
    for (k, v) in fields {
        if !known.contains(k) {
            bail!(
                "{origin}: '{k}' is not an output-error option (expected one of: {})",
                known.join(", ")
            );
        }
        if !kept(k) {
            merged[k] = v.clone();
        }
    }
    serde_json::from_value(merged).map_err(|e| anyhow::anyhow!("{origin}: {e}"))
}
