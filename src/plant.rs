//! Plant files: a generated robot model plus the effects acting on its joints and the
//! parameter values, in a TOML file the user edits.
//!
//! ```toml
//! model = "emps"                       # a model of model/*.toml (generated kernels)
//! description = "mass, viscous and Coulomb friction, offset"
//!
//! [[effect]]
//! kind = "viscous"                     # viscous | coulomb | asymmetric_friction | offset
//! joints = ["q0"]
//!
//! [parameters]                         # optional; written by `lockstep identify`
//! M = 95.1089
//! Fv_0 = 203.5034
//! ```
//!
//! Adding or removing an effect is an edit of the `[[effect]]` list (or [`Plant::add_effect`]).

use crate::effects::{Effect, EffectKind};
use crate::util::write_atomic;
use anyhow::{bail, Context, Result};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// `[[effect]]` as written in the file.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EffectSpec {
    /// Which effect.
    pub kind: EffectKind,
    /// Joint variables it acts on.
    pub joints: Vec<String>,
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
    /// Parameter values (SI).
    #[serde(default)]
    pub parameters: BTreeMap<String, f64>,
}

/// A validated plant: model kernels, effects resolved to joint indices, parameter values.
#[derive(Debug, Clone)]
pub struct Plant {
    /// Where it was read from (None when built in code).
    pub file: Option<PathBuf>,
    /// The generated model.
    pub model: &'static generated::Model,
    /// Free text.
    pub description: String,
    /// Effects in file order.
    pub effects: Vec<Effect>,
    /// Parameter values by name (rigid-body barycentric parameters and effect parameters).
    pub parameters: BTreeMap<String, f64>,
}

impl Plant {
    /// A plant of `model` with the given effects and no parameter values.
    ///
    /// # Errors
    /// Unknown model name.
    pub fn new(model: &str, effects: Vec<Effect>) -> Result<Plant> {
        let m = generated::model(model).with_context(|| {
            format!(
                "unknown model '{model}' (generated models: {})",
                generated::MODELS
                    .iter()
                    .map(|m| m.name)
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        })?;
        Ok(Plant {
            file: None,
            model: m,
            description: String::new(),
            effects,
            parameters: BTreeMap::new(),
        })
    }

    /// Read and validate a plant file.
    ///
    /// # Errors
    /// Unreadable file, TOML error (with line), unknown field, unknown model, unknown joint,
    /// the same effect twice on a joint, a parameter that belongs to nothing in the plant.
    pub fn load(path: &Path) -> Result<Plant> {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("{}: cannot read the plant file", path.display()))?;
        let spec: PlantFile = toml::from_str(&text).map_err(|e| {
            let line = e
                .span()
                .map(|s| text[..s.start.min(text.len())].matches('\n').count() + 1);
            anyhow::anyhow!(
                "{}{}: {}",
                path.display(),
                line.map(|l| format!(": line {l}")).unwrap_or_default(),
                e.message().replace('`', "'")
            )
        })?;
        let mut plant = Plant::new(&spec.model, vec![])
            .map_err(|e| anyhow::anyhow!("{}: field 'model': {e}", path.display()))?;
        plant.file = Some(path.to_path_buf());
        plant.description = spec.description.clone();
        for (i, e) in spec.effects.iter().enumerate() {
            for j in &e.joints {
                let joint = plant
                    .model
                    .joints
                    .iter()
                    .position(|x| x == j)
                    .ok_or_else(|| {
                        anyhow::anyhow!(
                            "{}: effect {} ({}): unknown joint '{j}' (model '{}' has {})",
                            path.display(),
                            i + 1,
                            e.kind,
                            plant.model.name,
                            plant.model.joints.join(", ")
                        )
                    })?;
                plant
                    .add_effect(Effect {
                        kind: e.kind,
                        joint,
                    })
                    .map_err(|err| {
                        anyhow::anyhow!("{}: effect {}: {err}", path.display(), i + 1)
                    })?;
            }
        }
        let known = plant.parameter_names();
        for (k, v) in &spec.parameters {
            if !known.contains(k) {
                bail!(
                    "{}: [parameters] '{k}' belongs to nothing in this plant (parameters: {})",
                    path.display(),
                    known.join(", ")
                );
            }
            if !v.is_finite() {
                bail!(
                    "{}: [parameters] '{k}': expected a finite number",
                    path.display()
                );
            }
        }
        plant.parameters = spec.parameters;
        Ok(plant)
    }

    /// Add an effect.
    ///
    /// # Errors
    /// The same kind already acts on that joint, or it conflicts (Coulomb or viscous beside
    /// asymmetric friction on one joint: their regressor columns would be dependent).
    pub fn add_effect(&mut self, e: Effect) -> Result<()> {
        let joint = &self.model.joints[e.joint];
        for other in self.effects.iter().filter(|o| o.joint == e.joint) {
            let conflict = other.kind == e.kind
                || matches!(
                    (other.kind, e.kind),
                    (
                        EffectKind::AsymmetricFriction,
                        EffectKind::Coulomb | EffectKind::Viscous
                    ) | (
                        EffectKind::Coulomb | EffectKind::Viscous,
                        EffectKind::AsymmetricFriction
                    )
                );
            if conflict {
                bail!(
                    "'{}' on joint '{joint}' conflicts with '{}' already there",
                    e.kind,
                    other.kind
                );
            }
        }
        self.effects.push(e);
        Ok(())
    }

    /// All parameter names: the model's rigid-body parameters, then each effect's.
    pub fn parameter_names(&self) -> Vec<String> {
        let mut v: Vec<String> = self.model.params.iter().map(|s| s.to_string()).collect();
        for e in &self.effects {
            v.extend(e.parameter_names());
        }
        v
    }

    /// Write the plant file atomically (temporary file, then rename).
    ///
    /// # Errors
    /// I/O errors, with the path.
    pub fn save(&self, path: &Path) -> Result<()> {
        let mut effects: Vec<EffectSpec> = Vec::new();
        for e in &self.effects {
            let j = self.model.joints[e.joint].to_string();
            match effects.iter_mut().find(|s| s.kind == e.kind) {
                Some(s) => s.joints.push(j),
                None => effects.push(EffectSpec {
                    kind: e.kind,
                    joints: vec![j],
                }),
            }
        }
        let spec = PlantFile {
            model: self.model.name.to_string(),
            description: self.description.clone(),
            effects,
            parameters: self.parameters.clone(),
        };
        let text = toml::to_string_pretty(&spec).context("serialising the plant")?;
        write_atomic(path, text.as_bytes())
    }
}
