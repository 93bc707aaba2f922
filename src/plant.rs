//! Plant files: a generated robot model plus the effects acting on its joints, the parameter
//! values and their bounds, in a TOML file the user edits.
//!
//! ```toml
//! model = "freedom6s"                  # a model of model/*.toml (generated kernels)
//! description = "Appendix D, coupled method"
//!
//! [[effect]]
//! kind = "lugre"                       # see `EffectKind`: viscous, coulomb, asymmetric_friction,
//! joints = ["q4", "q5"]                # offset, gain, stribeck, lugre, spring, friction_bias
//!
//! [[effect]]
//! kind = "input_coupling"              # pairwise: the command of `from` reaches `to`
//! from = "q5"
//! to = "q4"
//!
//! [parameters]                         # SI; rigid body in the model file's symbols
//! m4 = 0.0679                          # (m, centroid, inertia about it) or barycentric
//! sigma0_q4 = 0.17618                  # names, one form per link; effects' named by
//! G_q5_to_q4 = -0.20362                # joint (crate::names; Fc_3 of earlier versions read)
//!
//! [bounds]                             # [lower, upper], used by identification
//! m4 = [0.03395, 0.10185]
//! ```
//!
//! Adding or removing an effect is an edit of the `[[effect]]` list (or [`Plant::add_effect`]).
//! Before any simulation, [`Plant::simulator`] checks the physical consistency of the rigid
//! body (mass > 0, inertia positive definite, triangle inequality) and reports by link.

use crate::effects::{Effect, EffectKind};
use crate::expression::Expression;
use crate::files::write_atomic;
use crate::simulation::{InputCoupling, JointTerms, LuGre, PlantModel, Stribeck};
use anyhow::{bail, Context, Result};
use generated::inertia::{CentroidalInertia, InconsistencyKind};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

mod file;
pub use file::*;

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
    /// User-defined effects ([`crate::expression`]), in file order.
    pub expressions: Vec<ExpressionEffect>,
    /// Parameter values by name: rigid body (the model file's inertial symbols or
    /// barycentric parameters) and effect parameters.
    pub parameters: BTreeMap<String, f64>,
    /// Bounds `(lower, upper)` by parameter name.
    pub bounds: BTreeMap<String, (f64, f64)>,
    /// Changes and refits, oldest first.
    pub history: Vec<HistoryEntry>,
    /// Rigid-body symbols fitted by a sequence step but not determined there
    /// ([`PlantFile::undetermined`]).
    pub undetermined: Vec<String>,
    /// Standard errors of fitted values from the step that last fitted them
    /// ([`PlantFile::standard_errors`]).
    pub standard_errors: BTreeMap<String, f64>,
    /// Correlations of recorded values one step fitted together, each pair once with the
    /// lexically smaller name first ([`PlantFile::correlations`], [`Plant::correlation`]).
    pub correlations: BTreeMap<String, BTreeMap<String, f64>>,
    /// Plant-gain scale families no step has determined, by the step that last formed
    /// each: values a sequence step fitted whose common scale its data could not fix
    /// ([`PlantFile::scale_families`]).
    pub scale_families: BTreeMap<String, Vec<String>>,
}

/// A user-defined effect: a named torque term, written as an expression of the joints'
/// states and its own parameters ([`crate::expression`]), taken from each joint it acts on
/// (τ_i = [D q̈ + C q̇ + φ]_i + Σ effects_i, as the built-ins).
#[derive(Debug, Clone, PartialEq)]
pub struct ExpressionEffect {
    /// Name, unique in the plant.
    pub name: String,
    /// Joint indices it acts on.
    pub joints: Vec<usize>,
    /// The torque (N·m or N) and its declared parameters (plant parameter names).
    pub expression: Expression,
}

impl ExpressionEffect {
    /// Whether the effect acts in a configuration with free joints `free`: on at least
    /// one of them.
    pub fn acts_with(&self, free: &[usize]) -> bool {
        self.joints.iter().any(|j| free.contains(j))
    }
}

/// One physical-consistency finding of a link of a plant.
#[derive(Debug, Clone, PartialEq)]
pub struct Finding {
    /// Link name.
    pub link: String,
    /// Which condition fails.
    pub kind: InconsistencyKind,
    /// What is wrong, with the numbers.
    pub message: String,
}

impl Finding {
    /// True for what no body can have and a simulation should not accept by default
    /// (mass ≤ 0, inertia not positive definite); false for a triangle-inequality violation,
    /// which leaves the equations of motion well posed (every Appendix D link has one).
    pub fn is_blocking(&self) -> bool {
        self.kind != InconsistencyKind::TriangleInequality
    }
}

impl std::fmt::Display for Finding {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "link '{}': {}", self.link, self.message)
    }
}

/// What to do with physically inconsistent rigid-body parameters before a simulation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ConsistencyPolicy {
    /// Refuse on blocking findings ([`Finding::is_blocking`]); report the others.
    Refuse,
    /// Report every finding and simulate anyway.
    Warn,
}

/// A plant configured for simulation, with the consistency findings it was built with.
#[derive(Debug, Clone)]
pub struct Configured {
    /// The simulator.
    pub model: PlantModel,
    /// Non-blocking (or, under [`ConsistencyPolicy::Warn`], all) findings, for the user.
    pub findings: Vec<Finding>,
}

impl Plant {
    /// The plant's file name for messages, or "plant" when it has none.
    pub fn name(&self) -> String {
        self.file
            .as_ref()
            .map(|p| p.display().to_string())
            .unwrap_or_else(|| "plant".into())
    }

    /// A plant of `model` with the given effects and no parameter values.
    ///
    /// # Errors
    /// Unknown model name.
    pub fn new(model: &str, effects: Vec<Effect>) -> Result<Plant> {
        let m = crate::util::model(model)?;
        let mut plant = Plant {
            file: None,
            model: m,
            description: String::new(),
            effects,
            expressions: Vec::new(),
            parameters: BTreeMap::new(),
            bounds: BTreeMap::new(),
            history: Vec::new(),
            undetermined: Vec::new(),
            standard_errors: BTreeMap::new(),
            correlations: BTreeMap::new(),
            scale_families: BTreeMap::new(),
        };
        plant.fill_model_defaults();
        Ok(plant)
    }

    /// Give each inertial symbol that has a default in the model file (its `[defaults]` or
    /// its URDF's `<inertial>` numbers) and no value here its default, on every link the
    /// plant does not give in barycentric form.
    fn fill_model_defaults(&mut self) {
        let m = self.model;
        for l in 0..m.links.len() {
            let syms = self.link_symbols(l);
            let barycentric_given = (0..m.params.len()).any(|j| {
                m.param_link[j] == l
                    && !syms.contains(&m.params[j])
                    && self.parameters.contains_key(m.params[j])
            });
            if barycentric_given {
                continue;
            }
            for (i, s) in m.inertial_symbols.iter().enumerate() {
                if let (true, Some(d)) = (m.symbol_link[i] == l, m.symbol_defaults[i]) {
                    self.parameters.entry(s.to_string()).or_insert(d);
                }
            }
        }
    }

    /// The current name of parameter `name`: itself, or for an effect parameter in the
    /// numbered form of earlier versions (`Fc_2`) the name with the model's joint name
    /// (`Fc_q3` on a model whose joints are `q1..`; [`crate::names::renamed_parameter`]). A
    /// parameter of a user-defined effect keeps its name.
    pub fn current_name(&self, name: &str) -> String {
        let declared = self.parameters.contains_key(name)
            || self
                .expressions
                .iter()
                .any(|x| x.expression.parameters.iter().any(|p| p == name));
        if declared {
            return name.to_string();
        }
        // Renamed only to a name the plant has (a numbered name of an effect it lacks is
        // refused as written).
        match crate::names::renamed_parameter(self.model.joints, name) {
            Some(current) if self.known_names().contains(&current) => current,
            _ => name.to_string(),
        }
    }

    /// `spec` with its parameter names in the current form ([`Plant::current_name`]);
    /// refused when a value is given under both names.
    fn renamed_spec(&self, mut spec: PlantFile) -> Result<PlantFile> {
        fn rename<V>(
            plant: &Plant,
            table: &str,
            map: BTreeMap<String, V>,
        ) -> Result<BTreeMap<String, V>> {
            let mut out = BTreeMap::new();
            let mut given: BTreeMap<String, String> = BTreeMap::new();
            for (k, v) in map {
                let current = plant.current_name(&k);
                if let Some(first) = given.insert(current.clone(), k.clone()) {
                    bail!("{table}: '{first}' and '{k}' name the same parameter ('{current}'); give it once");
                }
                out.insert(current, v);
            }
            Ok(out)
        }
        spec.parameters = rename(self, "[parameters]", spec.parameters)?;
        spec.bounds = rename(self, "[bounds]", spec.bounds)?;
        spec.standard_errors = rename(self, "[standard_errors]", spec.standard_errors)?;
        let mut correlations = BTreeMap::new();
        for (a0, row) in spec.correlations {
            let a = self.current_name(&a0);
            for (b0, r) in row {
                let b = self.current_name(&b0);
                // A renamed pair may no longer be in lexical order; a pair as written is
                // kept as written (its order is checked).
                let renamed = a != a0 || b != b0;
                let (x, y) = if renamed && b < a {
                    (b, a.clone())
                } else {
                    (a.clone(), b)
                };
                let row: &mut BTreeMap<String, f64> = correlations.entry(x.clone()).or_default();
                if row.insert(y.clone(), r).is_some() {
                    bail!("[correlations.{x}] '{y}': the pair is given twice (under its numbered name too)");
                }
            }
        }
        spec.correlations = correlations;
        for (family, members) in &mut spec.scale_families {
            for m in members.iter_mut() {
                *m = self.current_name(m);
            }
            let mut seen = std::collections::BTreeSet::new();
            if let Some(m) = members.iter().find(|m| !seen.insert(m.as_str())) {
                bail!(
                    "[scale_families] {family}: '{m}' is given twice (under its numbered name too)"
                );
            }
        }
        for h in &mut spec.history {
            h.fitted = std::mem::take(&mut h.fitted)
                .into_iter()
                .map(|(k, v)| (self.current_name(&k), v))
                .collect();
        }
        Ok(spec)
    }

    fn joint_index(&self, name: &str, item: &str) -> Result<usize> {
        self.model
            .joints
            .iter()
            .position(|x| *x == name)
            .ok_or_else(|| {
                anyhow::anyhow!(
                    "{item}: unknown joint '{name}' (model '{}' has {})",
                    self.model.name,
                    self.model.joints.join(", ")
                )
            })
    }

    /// Read and validate a plant file.
    ///
    /// # Errors
    /// Unreadable file, TOML error (with line), unknown field, unknown model, unknown joint,
    /// conflicting effects on a joint, a parameter or bound that belongs to nothing in the
    /// plant, a non-finite value, a link given in both rigid-body forms or with some of its
    /// symbols missing, a bound with lower > upper or a value outside its bounds.
    pub fn load(path: &Path) -> Result<Plant> {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("{}: cannot read the plant file", path.display()))?;
        let spec: PlantFile = toml::from_str(&text)
            .map_err(|e| crate::util::toml_error(&path.display().to_string(), &text, &e))?;
        Plant::from_file(spec, Some(path)).map_err(|e| anyhow::anyhow!("{}: {e:#}", path.display()))
    }

    /// Validate a parsed plant file (`path` for messages and [`Plant::file`]).
    ///
    /// # Errors
    /// As [`Plant::load`], without the file name.
    pub fn from_file(mut spec: PlantFile, path: Option<&Path>) -> Result<Plant> {
        let mut plant =
            Plant::new(&spec.model, vec![]).map_err(|e| anyhow::anyhow!("field 'model': {e}"))?;
        plant.file = path.map(Path::to_path_buf);
        plant.description = spec.description.clone();
        plant.undetermined = spec.undetermined.clone();
        for (i, e) in spec.effects.iter().enumerate() {
            let item = format!("effect {} ({})", i + 1, e.kind);
            let mut effects = Vec::new();
            if e.kind.is_pairwise() {
                let (Some(from), Some(to)) = (&e.from, &e.to) else {
                    bail!("{item}: expected 'from' and 'to' joints");
                };
                if !e.joints.is_empty() {
                    bail!("{item}: takes 'from' and 'to', not 'joints'");
                }
                let from = plant.joint_index(from, &item)?;
                let to = plant.joint_index(to, &item)?;
                if from == to {
                    bail!("{item}: 'from' and 'to' are the same joint");
                }
                effects.push(Effect::coupling(from, to));
            } else {
                if e.from.is_some() || e.to.is_some() {
                    bail!("{item}: takes 'joints', not 'from'/'to'");
                }
                if e.joints.is_empty() {
                    bail!("{item}: expected at least one joint in 'joints'");
                }
                for j in &e.joints {
                    effects.push(Effect::on(e.kind, plant.joint_index(j, &item)?));
                }
            }
            for eff in effects {
                plant
                    .add_effect(eff)
                    .map_err(|err| anyhow::anyhow!("effect {}: {err}", i + 1))?;
            }
        }
        for (i, x) in spec.expressions.iter().enumerate() {
            plant.add_expression_spec(x, &format!("expression {} ('{}')", i + 1, x.name))?;
        }
        spec = plant.renamed_spec(spec)?;
        plant.history = spec.history.clone();
        plant.standard_errors = spec.standard_errors.clone();
        plant.correlations = spec.correlations.clone();
        plant.scale_families = spec.scale_families.clone();
        let known = plant.known_names();
        let check_name = |k: &str, what: &str| -> Result<()> {
            if !known.iter().any(|n| n == k) {
                bail!(
                    "{what} '{k}' belongs to nothing in this plant (parameters: {})",
                    known.join(", ")
                );
            }
            Ok(())
        };
        for (k, v) in &spec.parameters {
            check_name(k, "[parameters]")?;
            if !v.is_finite() {
                bail!("[parameters] '{k}': expected a finite number");
            }
        }
        for (k, [lo, hi]) in &spec.bounds {
            check_name(k, "[bounds]")?;
            if !(lo.is_finite() && hi.is_finite()) || lo > hi {
                bail!("[bounds] '{k}': expected [lower, upper] with finite lower ≤ upper, found [{lo}, {hi}]");
            }
            if let Some(v) = spec.parameters.get(k) {
                if v < lo || v > hi {
                    bail!("[bounds] '{k}': the value {v} lies outside [{lo}, {hi}]");
                }
            }
        }
        for k in &spec.undetermined {
            if !plant.model.inertial_symbols.contains(&k.as_str()) {
                bail!(
                    "'undetermined': '{k}' is not a rigid-body symbol of model '{}' (its symbols: {})",
                    plant.model.name,
                    plant.model.inertial_symbols.join(", ")
                );
            }
        }
        for (k, &se) in &spec.standard_errors {
            if !spec.parameters.contains_key(k) {
                bail!(
                    "[standard_errors] '{k}': not a parameter of this plant (standard errors \
                     are kept for values in [parameters] that a step fitted)"
                );
            }
            if !(se.is_finite() && se > 0.0) {
                bail!("[standard_errors] '{k}': expected a positive finite standard error, found {se}");
            }
        }
        for (a, row) in &spec.correlations {
            for (b, &r) in row {
                let item = format!("[correlations.{a}] '{b}'");
                for n in [a, b] {
                    if !spec.standard_errors.contains_key(n) {
                        bail!(
                            "{item}: '{n}' has no entry in [standard_errors] (correlations are \
                             kept between values with recorded standard errors)"
                        );
                    }
                }
                if a >= b {
                    bail!(
                        "{item}: expected each pair once with the lexically smaller name first \
                         ([correlations.{b}] {a} = ...)"
                    );
                }
                if !(r.is_finite() && r.abs() <= 1.0) {
                    bail!("{item}: expected a correlation in [-1, 1], found {r}");
                }
            }
        }
        let mut family_of: BTreeMap<&str, &str> = BTreeMap::new();
        for (family, members) in &spec.scale_families {
            if members.is_empty() {
                bail!("[scale_families] {family}: expected the names of the family's values, found none");
            }
            for m in members {
                let item = format!("[scale_families] {family}: '{m}'");
                if !spec.parameters.contains_key(m) {
                    bail!("{item}: not a parameter of this plant (a family lists values in [parameters] that a step fitted)");
                }
                if let Some(other) = family_of.insert(m, family) {
                    bail!("{item}: already in family {other} (a value belongs to one family)");
                }
            }
        }
        plant.parameters = spec.parameters;
        plant.fill_model_defaults();
        plant.bounds = spec
            .bounds
            .iter()
            .map(|(k, [lo, hi])| (k.clone(), (*lo, *hi)))
            .collect();
        plant.link_forms()?;
        plant.check_divisors()?;
        Ok(plant)
    }

    /// Add the user-defined effect `x` as written, its joints by name (`item` names it in
    /// an error: a plant file's entry, a candidate, a finding).
    ///
    /// # Errors
    /// An unknown joint (named with `item`); as [`Plant::add_expression`].
    pub fn add_expression_spec(&mut self, x: &ExpressionSpec, item: &str) -> Result<()> {
        let joints = x
            .joints
            .iter()
            .map(|j| self.joint_index(j, item))
            .collect::<Result<Vec<_>>>()?;
        self.add_expression(&x.name, joints, &x.torque, &x.parameters)
    }

    /// Add a user-defined effect: `torque` parsed for this model with the declared
    /// `parameters`, acting on the joints `joints` (model indices).
    ///
    /// # Errors
    /// A name that is empty, not unique or not a plain name; no joint, or a joint given
    /// twice; a parse error ([`Expression::parse`], with its column); a parameter whose
    /// name another part of the plant already uses (a rigid-body symbol, a built-in
    /// effect's or another expression's parameter).
    pub fn add_expression(
        &mut self,
        name: &str,
        joints: Vec<usize>,
        torque: &str,
        parameters: &[String],
    ) -> Result<()> {
        let item = format!("expression '{name}'");
        if name.is_empty() || !name.chars().all(|c| c.is_alphanumeric() || c == '_') {
            bail!("{item}: expected a name of letters, digits and '_'");
        }
        if self.expressions.iter().any(|x| x.name == name) {
            bail!("{item}: the plant already has an expression of that name");
        }
        if joints.is_empty() {
            bail!("{item}: expected at least one joint in 'joints'");
        }
        for (i, j) in joints.iter().enumerate() {
            if joints[..i].contains(j) {
                bail!("{item}: joint '{}' is given twice", self.model.joints[*j]);
            }
        }
        let expression = Expression::parse(torque, self.model.joints, parameters)
            .map_err(|e| anyhow::anyhow!("{item}: 'torque' {e}"))?;
        let taken = self.known_names();
        for p in parameters {
            if taken.contains(p) {
                bail!(
                    "{item}: parameter '{p}' is already a parameter of this plant (a rigid-body symbol, an effect's or another expression's); give it another name"
                );
            }
        }
        self.expressions.push(ExpressionEffect {
            name: name.to_string(),
            joints,
            expression,
        });
        Ok(())
    }

    /// Every parameter an expression divides by has bounds that exclude 0 (a fit cannot
    /// then reach a division by zero).
    ///
    /// # Errors
    /// A divisor parameter without bounds or with bounds that contain 0, named with the
    /// expression and the column of the division.
    pub fn check_divisors(&self) -> Result<()> {
        for x in &self.expressions {
            for &(i, col) in &x.expression.divisors {
                let p = &x.expression.parameters[i];
                match self.bounds.get(p) {
                    Some(&(lo, hi)) if lo > 0.0 || hi < 0.0 => {}
                    Some(&(lo, hi)) => bail!(
                        "expression '{}': column {col} divides by '{p}', whose bounds [{lo}, {hi}] contain 0; give bounds that exclude 0",
                        x.name
                    ),
                    None => bail!(
                        "expression '{}': column {col} divides by '{p}', which has no bounds; give it bounds that exclude 0 under [bounds]",
                        x.name
                    ),
                }
            }
        }
        Ok(())
    }

    /// Parameters of the user-defined effects that act with the free joints `free`
    /// ([`ExpressionEffect::acts_with`]), in plant order.
    pub fn expression_parameters_with(&self, free: &[usize]) -> Vec<String> {
        self.expressions
            .iter()
            .filter(|x| x.acts_with(free))
            .flat_map(|x| x.expression.parameters.iter().cloned())
            .collect()
    }

    /// True when every effect of the plant, built-in and user-defined, is linear in its
    /// parameters: then the inverse model's least squares (IDIM) fits them all.
    pub fn is_linear(&self) -> bool {
        self.effects.iter().all(|e| e.kind.is_linear())
            && self
                .expressions
                .iter()
                .all(|x| x.expression.is_linear_in_parameters())
    }

    /// Add an effect.
    ///
    /// # Errors
    /// The same effect is already there, or it conflicts with one on that joint: two friction
    /// laws (Coulomb, asymmetric, Stribeck, LuGre) except Coulomb + Stribeck, viscous beside
    /// asymmetric friction or LuGre (their viscous terms would be one parameter).
    pub fn add_effect(&mut self, e: Effect) -> Result<()> {
        use EffectKind as K;
        let joint = &self.model.joints[e.joint];
        for other in self.effects.iter().filter(|o| o.joint == e.joint) {
            let pair =
                |a: K, b: K| (other.kind == a && e.kind == b) || (other.kind == b && e.kind == a);
            let conflict = if e.kind.is_pairwise() || other.kind.is_pairwise() {
                *other == e
            } else {
                other.kind == e.kind
                    || (other.kind.is_friction_law() && e.kind.is_friction_law())
                    || pair(K::Viscous, K::AsymmetricFriction)
                    || pair(K::Viscous, K::Lugre)
            };
            if conflict {
                let what = |x: &Effect| match x.from {
                    Some(f) => format!("{} from '{}'", x.kind, self.model.joints[f]),
                    None => x.kind.to_string(),
                };
                bail!(
                    "'{}' on joint '{joint}' conflicts with '{}' already there",
                    what(&e),
                    what(other)
                );
            }
        }
        self.effects.push(e);
        Ok(())
    }

    /// True when joint `j` has an effect of `kind` of its own (an input coupling counts
    /// only through [`Plant::has_coupling`]).
    pub fn has_effect(&self, j: usize, kind: EffectKind) -> bool {
        self.effects
            .iter()
            .any(|e| e.joint == j && e.kind == kind && e.from.is_none())
    }

    /// True when the command of joint `from` already reaches joint `to`.
    pub fn has_coupling(&self, from: usize, to: usize) -> bool {
        self.effects
            .iter()
            .any(|e| e.joint == to && e.from == Some(from))
    }

    /// The friction law (Coulomb, asymmetric, Stribeck, LuGre) of joint `j`, if any.
    pub fn friction_law(&self, j: usize) -> Option<EffectKind> {
        self.effects
            .iter()
            .find(|e| e.joint == j && e.kind.is_friction_law())
            .map(|e| e.kind)
    }

    /// Effect parameter names, each once, in effect order (a spring and a friction bias on
    /// one joint share `qeq_i`).
    pub fn effect_parameter_names(&self) -> Vec<String> {
        let mut v: Vec<String> = Vec::new();
        for e in &self.effects {
            for n in e.parameter_names(self.model.joints) {
                if !v.contains(&n) {
                    v.push(n);
                }
            }
        }
        for x in &self.expressions {
            for n in &x.expression.parameters {
                if !v.contains(n) {
                    v.push(n.clone());
                }
            }
        }
        v
    }

    /// All parameter names in barycentric form: the model's barycentric parameters, then
    /// the effects' (the names inverse-dynamic identification fits).
    pub fn parameter_names(&self) -> Vec<String> {
        let mut v: Vec<String> = self.model.params.iter().map(|s| s.to_string()).collect();
        v.extend(self.effect_parameter_names());
        v
    }

    /// Every name `[parameters]` may hold: inertial symbols, barycentric parameters, effect
    /// parameters.
    pub fn known_names(&self) -> Vec<String> {
        let mut v: Vec<String> = self
            .model
            .inertial_symbols
            .iter()
            .map(|s| s.to_string())
            .collect();
        for p in self.model.params {
            if !v.iter().any(|x| x == p) {
                v.push(p.to_string());
            }
        }
        v.extend(self.effect_parameter_names());
        v
    }

    /// The model file's inertial symbols of link `l` (index into `model.links`), in the file's order.
    pub fn link_symbols(&self, l: usize) -> Vec<&'static str> {
        let m = self.model;
        (0..m.inertial_symbols.len())
            .filter(|&i| m.symbol_link[i] == l)
            .map(|i| m.inertial_symbols[i])
            .collect()
    }

    /// Per link: `Some(true)` when given in the model file's symbols (or when the model
    /// file gives the link in numbers only and the plant gives no barycentric parameter of
    /// it: the model file's values), `Some(false)` in barycentric form, `None` when nothing
    /// is given.
    fn link_forms(&self) -> Result<Vec<Option<bool>>> {
        let m = self.model;
        let mut forms = Vec::new();
        for (l, lname) in m.links.iter().enumerate() {
            let syms = self.link_symbols(l);
            let bary: Vec<&str> = (0..m.params.len())
                .filter(|&j| m.param_link[j] == l && !syms.contains(&m.params[j]))
                .map(|j| m.params[j])
                .collect();
            let has = |names: &[&str]| -> Vec<String> {
                names
                    .iter()
                    .filter(|n| self.parameters.contains_key(**n))
                    .map(|n| n.to_string())
                    .collect()
            };
            // A name that is both a symbol and a barycentric parameter (the mass, `m1`)
            // belongs to either form; only the others tell the forms apart.
            let link_params: Vec<&str> = (0..m.params.len())
                .filter(|&j| m.param_link[j] == l)
                .map(|j| m.params[j])
                .collect();
            let syms_only: Vec<&str> = syms
                .iter()
                .filter(|s| !link_params.contains(s))
                .copied()
                .collect();
            let shared: Vec<&str> = syms
                .iter()
                .filter(|s| link_params.contains(s))
                .copied()
                .collect();
            let (gs, gb) = (has(&syms_only), has(&bary));
            if !gs.is_empty() && !gb.is_empty() {
                bail!(
                    "link '{lname}': given both in the model file's symbols ({}) and as barycentric parameters ({}); use one form per link",
                    gs.join(", "),
                    gb.join(", ")
                );
            }
            // A link the model file gives in numbers only (no symbol) takes those numbers
            // unless the plant gives its barycentric parameters.
            let symbol_form =
                gb.is_empty() && (!gs.is_empty() || !has(&shared).is_empty() || syms.is_empty());
            if symbol_form {
                let missing: Vec<&str> = syms
                    .iter()
                    .filter(|n| !self.parameters.contains_key(**n))
                    .copied()
                    .collect();
                if !missing.is_empty() {
                    bail!(
                        "link '{lname}': symbols {} have no value (give every symbol of the link; 0 for those that appear in no configuration)",
                        missing.join(", ")
                    );
                }
            }
            forms.push(if symbol_form {
                Some(true)
            } else if !gb.is_empty() {
                Some(false)
            } else {
                None
            });
        }
        Ok(forms)
    }

    /// The barycentric parameter vector (NP) for a configuration: links in symbol form are
    /// converted ([`generated::Model::barycentric_from_symbols`]), links in barycentric form
    /// taken as given; parameters absent from the configuration's equations (or, with
    /// `conf = None`, without a value) default to 0.
    ///
    /// # Errors
    /// A parameter that the configuration needs has no value (named, with the link).
    pub fn barycentric(&self, conf: Option<&generated::Configuration>) -> Result<Vec<f64>> {
        let m = self.model;
        let forms = self.link_forms()?;
        let sym: Vec<f64> = m
            .inertial_symbols
            .iter()
            .map(|s| self.parameters.get(*s).copied().unwrap_or(0.0))
            .collect();
        let mut from_sym = vec![0.0; m.params.len()];
        (m.barycentric_from_symbols)(&sym, &mut from_sym);
        let mut p = vec![0.0; m.params.len()];
        for j in 0..m.params.len() {
            let l = m.param_link[j];
            p[j] = match forms[l] {
                Some(true) => from_sym[j],
                Some(false) => self.parameters.get(m.params[j]).copied().unwrap_or(0.0),
                None => 0.0,
            };
            let Some(conf) = conf else { continue };
            let needed = conf.params_present.contains(&j);
            let given = match forms[l] {
                Some(true) => true,
                Some(false) => self.parameters.contains_key(m.params[j]),
                None => false,
            };
            if needed && !given {
                let syms = self.link_symbols(l);
                bail!(
                    "{}: configuration '{}' needs link '{}' but parameter '{}' has no value (give the link's symbols {} or its barycentric parameters)",
                    self.name(),
                    conf.name,
                    m.links[l],
                    m.params[j],
                    syms.join(", ")
                );
            }
        }
        Ok(p)
    }

    /// True when configuration `conf`'s equations contain a barycentric parameter of link
    /// `l` (index into `model.links`).
    pub fn configuration_has_link(&self, conf: &generated::Configuration, l: usize) -> bool {
        let m = self.model;
        (0..m.params.len()).any(|j| m.param_link[j] == l && conf.params_present.contains(&j))
    }

    /// Physical consistency of the links of barycentric vector `p` that a configuration
    /// uses (all links when `conf` is None): mass > 0, and where the link has inertia
    /// parameters, inertia about the centroid positive definite and satisfying the triangle
    /// inequality.
    pub fn consistency(&self, p: &[f64], conf: Option<&generated::Configuration>) -> Vec<Finding> {
        let m = self.model;
        let mut out = Vec::new();
        for (l, lname) in m.links.iter().enumerate() {
            let params: Vec<usize> = (0..m.params.len())
                .filter(|&j| m.param_link[j] == l)
                .collect();
            if conf.is_some_and(|c| !self.configuration_has_link(c, l)) {
                continue;
            }
            let mut b = [0.0; 10];
            for &j in &params {
                b[m.param_kind[j]] = p[j];
            }
            let has_inertia = params.iter().any(|&j| m.param_kind[j] >= 4);
            let findings = match CentroidalInertia::from_barycentric(&b) {
                Some(ci) => ci.check(),
                None => vec![generated::inertia::Inconsistency {
                    kind: InconsistencyKind::Mass,
                    message: format!("mass {} kg is not positive", b[0]),
                }],
            };
            for f in findings {
                if f.kind != InconsistencyKind::Mass && !has_inertia {
                    continue;
                }
                out.push(Finding {
                    link: lname.to_string(),
                    kind: f.kind,
                    message: f.message,
                });
            }
        }
        out
    }

    /// A parameter's value.
    ///
    /// # Errors
    /// It has none (named, with the plant file).
    pub fn value(&self, name: &str) -> Result<f64> {
        let found = self.parameters.get(name).copied();
        found
            .or_else(|| self.parameters.get(&self.current_name(name)).copied())
            .with_context(|| {
                format!(
                    "{}: parameter '{name}' has no value (add it under [parameters])",
                    self.name()
                )
            })
    }

    /// Correlation of the recorded estimates of `a` and `b` ([`Plant::correlations`]): 1
    /// when `a` = `b`, 0 for a pair not recorded (values fitted by different steps, or
    /// not fitted).
    pub fn correlation(&self, a: &str, b: &str) -> f64 {
        if a == b {
            return 1.0;
        }
        let (a, b) = if a < b { (a, b) } else { (b, a) };
        self.correlations
            .get(a)
            .and_then(|row| row.get(b))
            .copied()
            .unwrap_or(0.0)
    }

    /// Record correlation `r` ∈ [−1, 1] of the estimates of `a` ≠ `b`
    /// ([`Plant::correlations`]), in the file's order (the lexically smaller name first).
    pub fn set_correlation(&mut self, a: &str, b: &str, r: f64) {
        let (a, b) = if a < b { (a, b) } else { (b, a) };
        self.correlations
            .entry(a.to_string())
            .or_default()
            .insert(b.to_string(), r.clamp(-1.0, 1.0));
    }

    /// Remove `name` from its plant-gain scale family ([`Plant::scale_families`]); a family
    /// left empty is dropped.
    pub fn forget_scale_family_member(&mut self, name: &str) {
        for members in self.scale_families.values_mut() {
            members.retain(|m| m != name);
        }
        self.scale_families.retain(|_, m| !m.is_empty());
    }

    /// The plant-gain scale family ([`Plant::scale_families`]) `name` belongs to.
    pub fn scale_family_of(&self, name: &str) -> Option<&str> {
        self.scale_families
            .iter()
            .find(|(_, m)| m.iter().any(|x| x == name))
            .map(|(f, _)| f.as_str())
    }

    /// Drop every recorded correlation of a value for which `drop` is true.
    pub fn forget_correlations(&mut self, drop: impl Fn(&str) -> bool) {
        self.correlations.retain(|a, _| !drop(a));
        for row in self.correlations.values_mut() {
            row.retain(|b, _| !drop(b));
        }
        self.correlations.retain(|_, row| !row.is_empty());
    }

    /// Every value by name as the equations use it: the plant's parameters, and for each
    /// link given in the model file's symbols its barycentric parameters, converted
    /// ([`Plant::barycentric`]).
    ///
    /// # Errors
    /// The plant's link forms are inconsistent.
    pub fn values_with_barycentric(&self) -> Result<BTreeMap<String, f64>> {
        let m = self.model;
        let forms = self.link_forms()?;
        let bary = self.barycentric(None)?;
        let mut values = self.parameters.clone();
        for j in (0..m.params.len()).filter(|&j| forms[m.param_link[j]] == Some(true)) {
            values.insert(m.params[j].to_string(), bary[j]);
        }
        Ok(values)
    }

    /// Set fitted values given as barycentric rigid-body parameters or effect parameters
    /// (IDIM's columns). A link given in the model file's symbols whose barycentric
    /// parameters are set is first converted to barycentric form, so that the plant keeps one
    /// form per link: its symbols (with their bounds, standard errors, correlations and
    /// undetermined marks) are removed and every barycentric parameter of the link is
    /// written from the current values.
    ///
    /// # Errors
    /// The plant's link forms are inconsistent, or a value the conversion needs is missing.
    pub fn set_barycentric_values(&mut self, names: &[String], values: &[f64]) -> Result<()> {
        let m = self.model;
        let forms = self.link_forms()?;
        let mut convert: Vec<usize> = names
            .iter()
            .filter_map(|n| {
                let j = m.params.iter().position(|p| p == n)?;
                let l = m.param_link[j];
                (forms[l] == Some(true) && !self.link_symbols(l).contains(&m.params[j]))
                    .then_some(l)
            })
            .collect();
        convert.sort_unstable();
        convert.dedup();
        if !convert.is_empty() {
            let bary = self.barycentric(None)?;
            for &l in &convert {
                for s in self.link_symbols(l) {
                    self.parameters.remove(s);
                    self.bounds.remove(s);
                    self.standard_errors.remove(s);
                    self.undetermined.retain(|u| u != s);
                    self.forget_scale_family_member(s);
                    self.forget_correlations(|x| x == s);
                }
                for j in (0..m.params.len()).filter(|&j| m.param_link[j] == l) {
                    self.parameters.insert(m.params[j].to_string(), bary[j]);
                }
            }
        }
        self.set_values(names, values);
        Ok(())
    }

    /// Set parameters `names` to `values` (SI, in the same order; a name without a value
    /// gets one).
    pub fn set_values(&mut self, names: &[String], values: &[f64]) {
        for (n, &v) in names.iter().zip(values) {
            self.parameters.insert(n.clone(), v);
        }
    }

    /// The simulator of configuration `conf_name` with locked joints at `q_locked` (NJ; the
    /// free joints' entries are ignored), after the physical-consistency check.
    ///
    /// # Errors
    /// Unknown configuration, wrong number of positions, a needed parameter without value,
    /// Stribeck or LuGre with vs ≤ 0, LuGre with Fc or Fs ≤ 0 (g(v) divides ż), asymmetric
    /// friction (an inverse-model effect); under [`ConsistencyPolicy::Refuse`], blocking
    /// consistency findings, listed by link.
    pub fn simulator(
        &self,
        conf_name: &str,
        q_locked: &[f64],
        policy: ConsistencyPolicy,
    ) -> Result<Configured> {
        let m = self.model;
        let name = self.name();
        let conf =
            crate::util::configuration(m, conf_name).map_err(|e| anyhow::anyhow!("{name}: {e}"))?;
        if q_locked.len() != m.joints.len() {
            bail!(
                "{name}: {} joint positions given, model '{}' has {} joints",
                q_locked.len(),
                m.name,
                m.joints.len()
            );
        }
        let p = self.barycentric(Some(conf))?;
        let findings = self.consistency(&p, Some(conf));
        if policy == ConsistencyPolicy::Refuse && findings.iter().any(Finding::is_blocking) {
            let (blocking, other): (Vec<&Finding>, Vec<&Finding>) =
                findings.iter().partition(|f| f.is_blocking());
            bail!(
                "{name}: physically impossible parameters for configuration '{}': {}{} (fix them, or simulate anyway with --allow-inconsistent)",
                conf.name,
                blocking
                    .iter()
                    .map(|f| f.to_string())
                    .collect::<Vec<_>>()
                    .join("; "),
                if other.is_empty() {
                    String::new()
                } else {
                    format!(
                        "; also implausible: {}",
                        other.iter().map(|f| f.link.as_str()).collect::<Vec<_>>().join(", ")
                    )
                }
            );
        }
        let free_index = |j: usize| conf.free.iter().position(|&k| k == j);
        let mut terms = vec![JointTerms::default(); conf.free.len()];
        let mut couplings = Vec::new();
        for e in &self.effects {
            let Some(a) = free_index(e.joint) else {
                continue;
            };
            let pname = |s: &str| e.parameter_name(s, m.joints);
            let v = |s: &str| self.value(&pname(s));
            let t = &mut terms[a];
            let positive = |s: &str, x: f64| -> Result<f64> {
                if x > 0.0 {
                    Ok(x)
                } else {
                    bail!(
                        "{name}: parameter '{}' must be positive, found {x}",
                        pname(s)
                    )
                }
            };
            let not_negative = |s: &str, what: &str| -> Result<f64> {
                let x = v(s)?;
                if x.is_nan() || x < 0.0 {
                    bail!(
                        "{name}: {} '{}' must be 0 or positive ({what}), found {x}",
                        e.kind,
                        pname(s)
                    );
                }
                Ok(x)
            };
            match e.kind {
                EffectKind::Viscous => t.viscous = v("Fv")?,
                EffectKind::Coulomb => t.coulomb = v("Fc")?,
                EffectKind::AsymmetricFriction => bail!(
                    "{name}: effect 'asymmetric_friction' on joint '{}' is for inverse-model fits only; the simulator takes coulomb + viscous, stribeck or lugre",
                    m.joints[e.joint]
                ),
                EffectKind::Offset => t.offset = v("offset")?,
                EffectKind::Gain => t.gain = v("Kp")?,
                EffectKind::Stribeck => {
                    t.stribeck = Some(Stribeck {
                        fc: v("Fc")?,
                        fs: v("Fs")?,
                        vs: positive("vs", v("vs")?)?,
                    })
                }
                EffectKind::Lugre => {
                    let l = LuGre {
                        sigma0: v("sigma0")?,
                        sigma1: v("sigma1")?,
                        sigma2: v("sigma2")?,
                        fc: v("Fc")?,
                        fs: v("Fs")?,
                        vs: positive("vs", v("vs")?)?,
                    };
                    if !(l.fc > 0.0 && l.fs > 0.0) {
                        bail!(
                            "{name}: LuGre on joint '{}' needs Fc > 0 and Fs > 0 (g(v) divides ż), found Fc = {}, Fs = {}",
                            m.joints[e.joint],
                            l.fc,
                            l.fs
                        );
                    }
                    t.lugre = Some(l);
                }
                EffectKind::Spring => t.spring = Some((v("Ks")?, v("qeq")?)),
                EffectKind::FrictionBias => t.bias = Some((v("FrictionBias")?, v("qeq")?)),
                EffectKind::Armature => {
                    t.armature = not_negative("Ia", "an inertia, kg·m² or kg")?;
                }
                EffectKind::Backlash => {
                    t.backlash = not_negative("backlash", "half the play, rad or m")?;
                }
                EffectKind::InputCoupling => {
                    let from = e.from.unwrap_or(e.joint);
                    if let Some(b) = free_index(from) {
                        couplings.push(InputCoupling {
                            from: b,
                            to: a,
                            g: self.value(&pname("G"))?,
                        });
                    }
                }
            }
        }
        for x in &self.expressions {
            for &j in &x.joints {
                if let Some(a) = free_index(j) {
                    let term = self.torque_term(x, j, conf.free, q_locked)?;
                    terms[a].extra.push(term);
                }
            }
        }
        let mut q = q_locked.to_vec();
        for &k in conf.free {
            q[k] = 0.0;
        }
        Ok(Configured {
            model: PlantModel {
                conf,
                p,
                q_locked: q,
                terms,
                couplings,
                integrator: crate::simulation::Integrator::default(),
            },
            findings,
        })
    }

    /// What parameter `name` is in the simulator of configuration `conf`
    /// ([`Plant::simulator`]), for its sensitivities
    /// ([`crate::simulation::PlantModel::predict_at_with_sensitivities`]): an effect's value
    /// on a free joint, an input coupling's share, or an inertial value (an inertial symbol of
    /// the model file or a barycentric parameter) as its direction ∂p/∂θ in the barycentric
    /// parameters. The direction is a central difference of [`Plant::barycentric`], exact up
    /// to rounding: each barycentric parameter is at most quadratic in any one symbol
    /// (I_O = I_c + m (c·c) E − m c cᵀ, Appendix D). Every effect that names the value takes
    /// it (a joint's `qeq` is its spring's and its friction bias's); one that acts in no
    /// effect of `conf` moves nothing.
    ///
    /// # Errors
    /// `name` is not a parameter of the plant, or one whose derivative is not implemented (a
    /// user-defined effect's, backlash, asymmetric friction).
    pub fn sensitivity_parameter(
        &self,
        name: &str,
        conf: &generated::Configuration,
    ) -> Result<crate::simulation::PlantParameter> {
        use crate::simulation::{EffectValue as V, PlantParameter};
        let m = self.model;
        let name = self.current_name(name);
        let free_index = |j: usize| conf.free.iter().position(|&k| k == j);
        let mut found = PlantParameter::default();
        let mut named = false;
        // Couplings are numbered as the simulator pushes them: the acting ones in order.
        let mut coupling = 0;
        for e in &self.effects {
            let acts = e.acts_with(conf.free);
            let index = e
                .kind
                .symbols()
                .iter()
                .position(|s| e.parameter_name(s, m.joints) == name);
            let this_coupling = coupling;
            if e.kind == EffectKind::InputCoupling && acts {
                coupling += 1;
            }
            let Some(index) = index else { continue };
            named = true;
            let Some(a) = free_index(e.joint).filter(|_| acts) else {
                continue;
            };
            let values: &[V] = match e.kind {
                EffectKind::Viscous => &[V::Viscous],
                EffectKind::Coulomb => &[V::Coulomb],
                EffectKind::Offset => &[V::Offset],
                EffectKind::Gain => &[V::Gain],
                EffectKind::Stribeck => &[V::StribeckFc, V::StribeckFs, V::StribeckVs],
                EffectKind::Lugre => &[V::Sigma0, V::Sigma1, V::Sigma2, V::LuGreFc, V::LuGreFs, V::LuGreVs],
                EffectKind::Spring => &[V::SpringStiffness, V::SpringRest],
                EffectKind::FrictionBias => &[V::BiasFactor, V::BiasRest],
                EffectKind::Armature => &[V::Armature],
                EffectKind::InputCoupling => {
                    found.couplings.push(this_coupling);
                    continue;
                }
                EffectKind::Backlash | EffectKind::AsymmetricFriction => bail!(
                    "{}: no sensitivity for '{name}' ({} is not differentiated; use finite differences)",
                    self.name(),
                    e.kind
                ),
            };
            found.effects.push((a, values[index]));
        }
        if named {
            return Ok(found);
        }
        let inertial =
            m.inertial_symbols.contains(&name.as_str()) || m.params.contains(&name.as_str());
        let Some(&value) = self.parameters.get(&name).filter(|_| inertial) else {
            bail!(
                "{}: no sensitivity for '{name}': not an effect's or an inertial value of the plant{}",
                self.name(),
                if self.expressions.iter().any(|x| x.expression.parameters.contains(&name)) {
                    " (a user-defined effect's values are not differentiated; use finite differences)"
                } else {
                    ""
                }
            );
        };
        let delta = 1e-3 * value.abs().max(1e-2);
        let at = |v: f64| -> Result<Vec<f64>> {
            let mut plant = self.clone();
            plant.parameters.insert(name.clone(), v);
            plant.barycentric(Some(conf))
        };
        let (up, down) = (at(value + delta)?, at(value - delta)?);
        Ok(PlantParameter {
            inertial: up
                .iter()
                .zip(&down)
                .enumerate()
                .filter(|(_, (u, d))| u != d)
                .map(|(k, (u, d))| (k, (u - d) / (2.0 * delta)))
                .collect(),
            ..PlantParameter::default()
        })
    }

    /// The user-defined effect `x` on joint `j` compiled for a simulation with free joints
    /// `free`: parameter values and the locked joints' positions `q_locked` (NJ) folded in,
    /// the locked joints' velocities, commands and deflections 0.
    ///
    /// # Errors
    /// A parameter without value; the torque is not linear in the accelerations it reads
    /// (their coefficients go into the inertia matrix) or nests too deeply.
    fn torque_term(
        &self,
        x: &ExpressionEffect,
        j: usize,
        free: &[usize],
        q_locked: &[f64],
    ) -> Result<crate::simulation::TorqueTerm> {
        use crate::expression::{Program, Symbol};
        use crate::simulation::TermInput;
        let name = self.name();
        let e = &x.expression;
        let values = e
            .parameters
            .iter()
            .map(|p| self.value(p))
            .collect::<Result<Vec<_>>>()?;
        let free_index = |k: usize| free.iter().position(|&f| f == k);
        // The accelerations go into the inertia matrix: the torque is compiled at q̈ = 0
        // and each coefficient ∂u/∂q̈_k of a free joint k apart.
        let fixed = |s: Symbol| -> Option<f64> {
            match s {
                Symbol::Param(i) => Some(values[i]),
                Symbol::Q(k) if free_index(k).is_none() => Some(q_locked[k]),
                Symbol::Qdd(_) => Some(0.0),
                Symbol::Qd(k) | Symbol::Tau(k) | Symbol::Z(k) if free_index(k).is_none() => {
                    Some(0.0)
                }
                _ => None,
            }
        };
        let build = |node: &crate::expression::Node| -> Result<(Program, Vec<TermInput>)> {
            let program = Program::compile(node, &fixed)
                .map_err(|m| anyhow::anyhow!("{name}: expression '{}': {m}", x.name))?;
            let inputs = program
                .inputs
                .iter()
                .map(|s| {
                    let a = |k: usize| free_index(k).unwrap_or(0);
                    match *s {
                        Symbol::Q(k) => Ok(TermInput::Q(a(k))),
                        Symbol::Qd(k) => Ok(TermInput::Qd(a(k))),
                        Symbol::Z(k) => Ok(TermInput::Z(a(k))),
                        Symbol::Tau(k) => Ok(TermInput::Tau(a(k))),
                        Symbol::T => Ok(TermInput::T),
                        Symbol::Qdd(k) => Err(anyhow::anyhow!(
                            "{name}: expression '{}': the acceleration qdd{k} was not taken into the inertia matrix",
                            x.name
                        )),
                        Symbol::Param(i) => Err(anyhow::anyhow!(
                            "{name}: expression '{}': parameter '{}' was not substituted",
                            x.name,
                            e.parameters[i]
                        )),
                    }
                })
                .collect::<Result<Vec<_>>>()?;
            Ok((program, inputs))
        };
        let (torque, inputs) = build(&e.root)?;
        let slope = if e.symbols().contains(&Symbol::Qd(j)) {
            Some(build(&e.derivative(Symbol::Qd(j)))?)
        } else {
            None
        };
        let mut inertia = Vec::new();
        for (k, coefficient) in e
            .acceleration_coefficients()
            .map_err(|m| anyhow::anyhow!("{name}: expression '{}': {m}", x.name))?
        {
            if let Some(a) = free_index(k) {
                let (program, inputs) = build(&coefficient)?;
                inertia.push((a, program, inputs));
            }
        }
        Ok(crate::simulation::TorqueTerm {
            name: x.name.clone(),
            torque,
            inputs,
            slope,
            inertia,
        })
    }

    /// Bounds by the thesis's rule (4.1.3, Appendix E) around the current values of the
    /// model file's inertial symbols: mass ±50 %, centroid ±30 %, inertia ±120 %
    /// (v ± f·|v|; a zero value gets the bound [0, 0], i.e. fixed). Existing bounds of other
    /// parameters are kept.
    pub fn apply_thesis_bounds(&mut self) {
        let m = self.model;
        for (i, s) in m.inertial_symbols.iter().enumerate() {
            let Some(&v) = self.parameters.get(*s) else {
                continue;
            };
            let f = [0.5, 0.3, 1.2][m.symbol_role[i].min(2)];
            self.bounds
                .insert(s.to_string(), (v - f * v.abs(), v + f * v.abs()));
        }
    }

    /// The values of `values` that lie outside this plant's bounds, by name (those without
    /// bounds here are not checked): `(name, value, (lower, upper))`, in name order. A
    /// fit started from this plant cannot reach them (a reference result, the truth of
    /// synthetic data: Appendix D's coupled m2, for one, lies outside the thesis bounds).
    pub fn outside_bounds(&self, values: &BTreeMap<String, f64>) -> Vec<(String, f64, (f64, f64))> {
        self.bounds
            .iter()
            .filter_map(|(n, &(lo, hi))| {
                let v = *values.get(n)?;
                (v < lo || v > hi).then(|| (n.clone(), v, (lo, hi)))
            })
            .collect()
    }

    /// The plant as a file.
    pub fn to_file(&self) -> PlantFile {
        let mut effects: Vec<EffectSpec> = Vec::new();
        for e in &self.effects {
            let j = self.model.joints[e.joint].to_string();
            if let Some(f) = e.from {
                effects.push(EffectSpec {
                    kind: e.kind,
                    joints: vec![],
                    from: Some(self.model.joints[f].to_string()),
                    to: Some(j),
                });
                continue;
            }
            match effects
                .iter_mut()
                .find(|s| s.kind == e.kind && s.from.is_none())
            {
                Some(s) => s.joints.push(j),
                None => effects.push(EffectSpec {
                    kind: e.kind,
                    joints: vec![j],
                    from: None,
                    to: None,
                }),
            }
        }
        let expressions = self
            .expressions
            .iter()
            .map(|x| ExpressionSpec {
                name: x.name.clone(),
                joints: x
                    .joints
                    .iter()
                    .map(|&j| self.model.joints[j].to_string())
                    .collect(),
                torque: x.expression.text.clone(),
                parameters: x.expression.parameters.clone(),
            })
            .collect();
        PlantFile {
            model: self.model.name.to_string(),
            description: self.description.clone(),
            effects,
            expressions,
            parameters: self.parameters.clone(),
            bounds: self
                .bounds
                .iter()
                .map(|(k, (lo, hi))| (k.clone(), [*lo, *hi]))
                .collect(),
            history: self.history.clone(),
            undetermined: self.undetermined.clone(),
            standard_errors: self.standard_errors.clone(),
            correlations: self.correlations.clone(),
            scale_families: self.scale_families.clone(),
        }
    }

    /// Write the plant file atomically (temporary file, then rename).
    ///
    /// # Errors
    /// I/O errors, with the path.
    pub fn save(&self, path: &Path) -> Result<()> {
        write_atomic(path, self.to_toml()?.as_bytes())
    }

    /// The plant file's text (TOML), as [`Plant::save`] writes it.
    ///
    /// # Errors
    /// Serialisation fails (a non-finite value).
    pub fn to_toml(&self) -> Result<String> {
        toml::to_string_pretty(&self.to_file()).context("serialising the plant")
    }
}
