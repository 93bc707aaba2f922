//! The plant file's format (TOML): the model, the effects on its joints, the parameter
//! values and bounds, and the history of changes ([`PlantFile`]).

use super::*;

/// `[[effect]]` as written in the file.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EffectSpec {
    /// Which effect.
    pub kind: EffectKind,
    /// Joint variables it acts on (every kind but `input_coupling`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub joints: Vec<String>,
    /// For `input_coupling`: the joint whose command is passed on.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub from: Option<String>,
    /// For `input_coupling`: the joint that receives it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub to: Option<String>,
}

/// `[[expression]]` as written: a user-defined effect ([`crate::expression`]).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExpressionSpec {
    /// Name of the effect (unique in the plant), e.g. `cubic_stiffness_q3`.
    pub name: String,
    /// Joint variables it acts on: the torque is taken from each of them.
    pub joints: Vec<String>,
    /// The torque the effect takes from each joint (N·m or N), e.g. `K3*(q3 - qeq3)^3`.
    pub torque: String,
    /// Its parameters (names used in `torque`; values under `[parameters]`).
    #[serde(default)]
    pub parameters: Vec<String>,
}

/// The plant file as written.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlantFile {
    /// Name of the generated model.
    pub model: String,
    /// Free text.
    #[serde(default)]
    pub description: String,
    /// Effects.
    #[serde(default, rename = "effect")]
    pub effects: Vec<EffectSpec>,
    /// User-defined effects.
    #[serde(default, rename = "expression", skip_serializing_if = "Vec::is_empty")]
    pub expressions: Vec<ExpressionSpec>,
    /// Parameter values (SI).
    #[serde(default)]
    pub parameters: BTreeMap<String, f64>,
    /// Parameter bounds `[lower, upper]` (SI); exactly two numbers each.
    #[serde(
        default,
        skip_serializing_if = "BTreeMap::is_empty",
        deserialize_with = "two_numbers_each"
    )]
    pub bounds: BTreeMap<String, [f64; 2]>,
    /// What was changed and refitted, oldest first (`lockstep diagnose --apply`, `lockstep
    /// refit`).
    #[serde(default, rename = "history", skip_serializing_if = "Vec::is_empty")]
    pub history: Vec<HistoryEntry>,
    /// Rigid-body symbols a step of a locking sequence fitted but could not determine (not
    /// called identifiable); the next step where they appear fits them again
    /// ([`crate::identify::sequence::run`]), also when it is run alone with `--config`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub undetermined: Vec<String>,
    /// Standard errors (SI) of fitted values, from the step that last fitted them at the
    /// noise floor (its Jacobian, the uncertainty of what it held included: what that
    /// step's data say about them, also where that is not enough to call them
    /// identifiable). A later step that holds them adds their uncertainty to its own
    /// standard errors ([`crate::identify::output_error::Statistics::held`]); one that fits
    /// an undetermined symbol again takes it as a prior with `--carried-prior on`
    /// ([`crate::identify::output_error::OutputErrorOptions::carried_prior`]). Relative
    /// to the scale of the value's family in `scale_families`, if it has one.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub standard_errors: BTreeMap<String, f64>,
    /// Correlations of values with recorded standard errors that one step fitted together
    /// (`[correlations.a] b = ρ`, each pair once, a < b; absent pairs 0): the estimates of
    /// one fit are correlated (a value and what it trades with), and a later step that
    /// holds both propagates their joint uncertainty Σ_h = D R D, D the standard errors,
    /// R these correlations (the two-stage estimator needs the first stage's covariance,
    /// not its diagonal; Murphy and Topel 1985). A step that fits a value again drops its
    /// pairs.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub correlations: BTreeMap<String, BTreeMap<String, f64>>,
    /// Plant-gain scale families whose scale no step determined (`[scale_families] k1 =
    /// ["Kp_q4", "Fc_q4", "m7", ...]`, named by the step that last formed the family): a
    /// step that fits every joint's gain with every force it sees leaves them on an exact
    /// symmetry (Kp τ = D q̈ + … all × α; position data cannot fix α), and its least change
    /// sets their scale arbitrarily, near the plant's values. A later step that holds some
    /// of them counts their common scale as unknown: what it fits that moves with that
    /// scale gets an infinite standard error, not one conditional on the arbitrary scale
    /// ([`crate::identify::output_error::Statistics::held_scales`]), and joins the family.
    /// A member's entry in `[standard_errors]` is relative to the family's scale; a value
    /// is in at most one family.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub scale_families: BTreeMap<String, Vec<String>>,
}

/// One step of a plant's history: a change (an effect added, parameters refitted), the
/// data it was fitted on and the RMS error per joint before and after (position error, or
/// torque residual in torque space: `space`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HistoryEntry {
    /// What changed, e.g. "added spring on q3".
    pub change: String,
    /// Configuration of the data.
    pub configuration: String,
    /// Data files.
    #[serde(default)]
    pub files: Vec<String>,
    /// Fitted values (SI).
    #[serde(default)]
    pub fitted: BTreeMap<String, f64>,
    /// RMS position error per joint before the change (rad or m).
    #[serde(default)]
    pub rms_before: BTreeMap<String, f64>,
    /// … and after the refit.
    #[serde(default)]
    pub rms_after: BTreeMap<String, f64>,
    /// The space of the figures: `torque` when `rms_before`/`rms_after` are the inverse
    /// model's torque residuals (N·m or N, [`crate::identify::refit::refit_torque`]);
    /// `closed loop` when they are the closed-loop force or torque errors (N·m or N,
    /// `refit --controller`); absent for position errors (output space).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub space: Option<String>,
}

/// `[bounds]` entries as `[lower, upper]`, refusing any other length (serde's fixed-size
/// arrays would drop extra elements silently).
pub(super) fn two_numbers_each<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> std::result::Result<BTreeMap<String, [f64; 2]>, D::Error> {
    use serde::de::Error;
    let raw = BTreeMap::<String, Vec<f64>>::deserialize(d)?;
    raw.into_iter()
        .map(|(k, v)| match v.as_slice() {
            [lo, hi] => Ok((k, [*lo, *hi])),
            _ => Err(D::Error::custom(format!(
                "[bounds] '{k}': expected [lower, upper] (two numbers), found {} number(s)",
                v.len()
            ))),
        })
        .collect()
}
