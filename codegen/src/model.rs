//! The robot description file (`model/*.toml`): schema, loading and validation.
//!
//! The format is documented field by field in `model/README.md`. In short: joint variables,
//! numeric constants (known lengths), DH chains (standard or modified), extra frames built
//! from elementary transforms, links attached to frames with inertial symbols, locked-joint
//! configurations and locking sequences (thesis Tables 4.2 and 4.6).

use crate::expr::Expr;
use serde::Deserialize;
use std::collections::{BTreeMap, BTreeSet};
use std::fmt;
use std::path::{Path, PathBuf};

/// A model-file error: the file, the item in it and what was expected.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelError {
    /// The model file.
    pub file: PathBuf,
    /// The item, e.g. `chain 'DH1' row 3 field 'theta'`.
    pub item: String,
    /// What is wrong and what was expected.
    pub reason: String,
}

impl fmt::Display for ModelError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.item.is_empty() {
            write!(f, "{}: {}", self.file.display(), self.reason)
        } else {
            write!(f, "{}: {}: {}", self.file.display(), self.item, self.reason)
        }
    }
}

impl std::error::Error for ModelError {}

/// A number or an expression string in the model file.
#[derive(Debug, Clone, Deserialize)]
#[serde(untagged)]
pub enum Scalar {
    /// A plain TOML number.
    Num(f64),
    /// An expression, e.g. `"q2 - pi/2"` or `"-L5 - L6"`.
    Text(String),
}

/// A constant: a number, or a table `{ value, assumed, note }`.
#[derive(Debug, Clone, Deserialize)]
#[serde(untagged)]
pub enum ConstantSpec {
    /// Just the value (SI units).
    Value(f64),
    /// The value with provenance.
    Detailed {
        /// Value in SI units.
        value: f64,
        /// True when the value is an assumption, not a measurement or a published figure.
        #[serde(default)]
        assumed: bool,
        /// Free text: source or reason.
        #[serde(default)]
        note: Option<String>,
    },
}

/// `[robot]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotSpec {
    /// Model name (also the generated module name).
    pub name: String,
    /// One line on what the robot is.
    #[serde(default)]
    pub description: String,
    /// Source of the data (paper, table, toolbox).
    #[serde(default)]
    pub source: String,
    /// Joint variables in the order of the q vector. With `urdf`, optional: the names of the
    /// URDF's independent moving joints in tree order (default: the URDF joint names).
    #[serde(default)]
    pub joints: Vec<String>,
    /// Gravity vector in frame 0 (m/s²); `[0, 0, -9.81]` when z is up. With `urdf`,
    /// optional (default `[0, 0, -9.81]`, ROS's convention).
    #[serde(default)]
    pub gravity: Option<[Scalar; 3]>,
    /// A URDF robot description (path relative to this file) that gives the frames and
    /// links; the model file then adds configurations, sequences and defaults.
    #[serde(default)]
    pub urdf: Option<String>,
    /// With `urdf`: the URDF links whose inertial values are known numbers rather than
    /// symbols to identify (e.g. a tool).
    #[serde(default)]
    pub known_links: Vec<String>,
}

/// DH convention of a chain.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Convention {
    /// Standard DH: A = Rot_z(θ) Trans_z(d) Trans_x(a) Rot_x(α) (thesis 3.1).
    Standard,
    /// Modified (Craig) DH: A = Rot_x(α) Trans_x(a) Rot_z(θ) Trans_z(d).
    Modified,
}

/// One DH row.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DhRowSpec {
    /// Joint angle θ (rad).
    pub theta: Scalar,
    /// Link offset d (m).
    pub d: Scalar,
    /// Link length a (m).
    pub a: Scalar,
    /// Link twist α (rad).
    pub alpha: Scalar,
}

/// `[[chain]]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChainSpec {
    /// Chain name; its frames are `<name>.0` (the parent) to `<name>.<n>`, and `<name>.e`.
    pub name: String,
    /// `standard` or `modified`.
    pub convention: Convention,
    /// Frame the chain starts from (default `world`).
    #[serde(default)]
    pub parent: Option<String>,
    /// The rows, base to tip.
    pub rows: Vec<DhRowSpec>,
}

/// One elementary transform of an extra frame.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields, rename_all = "snake_case")]
pub enum TransformSpec {
    /// Standard DH block `[θ, d, a, α]`.
    Dh([Scalar; 4]),
    /// Modified DH block `[α, a, θ, d]`.
    Mdh([Scalar; 4]),
    /// Translation `[x, y, z]` (m).
    Trans([Scalar; 3]),
    /// Rotation about x (rad).
    RotX(Scalar),
    /// Rotation about y (rad).
    RotY(Scalar),
    /// Rotation about z (rad).
    RotZ(Scalar),
}

/// `[[frame]]`: a frame defined by a product of elementary transforms.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FrameSpec {
    /// Frame name.
    pub name: String,
    /// Frame it is expressed in (default `world`).
    #[serde(default)]
    pub parent: Option<String>,
    /// Transforms applied left to right.
    pub transforms: Vec<TransformSpec>,
}

/// `[[link]]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinkSpec {
    /// Link name (suffix of its barycentric parameter names).
    pub name: String,
    /// Frame the link is rigidly attached to.
    pub frame: String,
    /// Mass (kg): a symbol to identify or a number.
    pub mass: Scalar,
    /// Centroid in the link frame (m).
    #[serde(default = "zero3")]
    pub com: [Scalar; 3],
    /// Inertia about the centroid in the link frame, `[I11, I12, I13, I22, I23, I33]` (kg·m²).
    #[serde(default = "zero6")]
    pub inertia: [Scalar; 6],
    /// Free text.
    #[serde(default)]
    pub note: String,
}

fn zero3() -> [Scalar; 3] {
    std::array::from_fn(|_| Scalar::Num(0.0))
}
fn zero6() -> [Scalar; 6] {
    std::array::from_fn(|_| Scalar::Num(0.0))
}

/// `[[configuration]]`: which joints are free; the others are locked (q̇ = q̈ = 0).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ConfigurationSpec {
    /// Name, e.g. `c7` or `k3`.
    pub name: String,
    /// Free joint variables.
    pub free: Vec<String>,
    /// Free text.
    #[serde(default)]
    pub description: String,
}

/// `[[sequence]]`: a locking sequence, configurations in identification order.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SequenceSpec {
    /// Name, e.g. `isolated` or `coupled`.
    pub name: String,
    /// Configuration names in order.
    pub steps: Vec<String>,
    /// Free text (source table).
    #[serde(default)]
    pub description: String,
}

/// The whole file as written.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelFile {
    /// `[robot]`.
    pub robot: RobotSpec,
    /// `[constants]`: known numbers substituted before any symbolic work.
    #[serde(default)]
    pub constants: BTreeMap<String, ConstantSpec>,
    /// `[[chain]]`.
    #[serde(default, rename = "chain")]
    pub chains: Vec<ChainSpec>,
    /// `[[frame]]`.
    #[serde(default, rename = "frame")]
    pub frames: Vec<FrameSpec>,
    /// `[[link]]`.
    #[serde(default, rename = "link")]
    pub links: Vec<LinkSpec>,
    /// `[[configuration]]`.
    #[serde(default, rename = "configuration")]
    pub configurations: Vec<ConfigurationSpec>,
    /// `[[sequence]]`.
    #[serde(default, rename = "sequence")]
    pub sequences: Vec<SequenceSpec>,
    /// `[defaults]`: default values of inertial symbols (the prior: CAD, a URDF, a paper),
    /// used where a plant gives no value.
    #[serde(default)]
    pub defaults: BTreeMap<String, f64>,
}

/// An elementary transform with parsed entries.
#[derive(Debug, Clone)]
pub enum Transform {
    /// Rotation about an axis (0 = x, 1 = y, 2 = z) by an angle linear in the joints.
    Rot {
        /// 0, 1 or 2.
        axis: usize,
        /// Integer coefficients of the joint variables.
        joints: Vec<i64>,
        /// Constant part (rad).
        offset: f64,
    },
    /// Translation along an axis by `Σ c_k q_k + offset` (prismatic when a coefficient is
    /// not zero).
    Trans {
        /// 0, 1 or 2.
        axis: usize,
        /// Real coefficients of the joint variables (m per unit of q_k).
        joints: Vec<f64>,
        /// Constant part (m).
        offset: f64,
    },
}

/// A frame of the validated model: its parent and the transforms from the parent.
#[derive(Debug, Clone)]
pub struct Frame {
    /// Name (`world`, `<chain>.<k>` or an extra frame's name).
    pub name: String,
    /// Index of the parent frame in [`Model::frames`] (`None` for `world`).
    pub parent: Option<usize>,
    /// Elementary transforms from the parent, left to right.
    pub transforms: Vec<Transform>,
}

/// A link of the validated model.
#[derive(Debug, Clone)]
pub struct Link {
    /// Name.
    pub name: String,
    /// Index in [`Model::frames`].
    pub frame: usize,
    /// Mass (kg).
    pub mass: Expr,
    /// Centroid in the link frame (m).
    pub com: [Expr; 3],
    /// Inertia about the centroid `[I11, I12, I13, I22, I23, I33]` (kg·m²).
    pub inertia: [Expr; 6],
}

/// A configuration of the validated model.
#[derive(Debug, Clone)]
pub struct Configuration {
    /// Name.
    pub name: String,
    /// Indices of the free joints, ascending.
    pub free: Vec<usize>,
    /// Free text.
    pub description: String,
}

/// A validated model: every name resolved, every expression parsed and checked.
#[derive(Debug, Clone)]
pub struct Model {
    /// Source file.
    pub file: PathBuf,
    /// The file as written (for reports).
    pub spec: ModelFile,
    /// Model name.
    pub name: String,
    /// Joint variable names.
    pub joints: Vec<String>,
    /// Constants (SI).
    pub constants: BTreeMap<String, f64>,
    /// Gravity in frame 0 (m/s²).
    pub gravity: [f64; 3],
    /// Frames; index 0 is `world`.
    pub frames: Vec<Frame>,
    /// Links.
    pub links: Vec<Link>,
    /// Inertial parameter symbols in order of appearance, with the link index that owns each
    /// and the role of the field it first appears in (0 = mass, 1 = centroid, 2 = inertia).
    pub inertial_symbols: Vec<(String, usize, usize)>,
    /// Configurations (a `full` configuration freeing every joint is added when absent).
    pub configurations: Vec<Configuration>,
    /// Locking sequences: name and configuration indices.
    pub sequences: Vec<(String, Vec<usize>)>,
    /// Default value of inertial symbols (`[defaults]`, or a URDF's `<inertial>` numbers).
    pub defaults: BTreeMap<String, f64>,
    /// The URDF the frames and links were read from, and its moving joints.
    pub urdf: Option<(PathBuf, Vec<crate::urdf::UrdfJoint>)>,
    /// Warnings of the physical-consistency check of the URDF's inertial values.
    pub warnings: Vec<String>,
}

impl Model {
    /// Read and validate a model file.
    ///
    /// # Errors
    /// [`ModelError`] naming the file, the item and the reason: unreadable file, TOML
    /// syntax, unknown field, unknown symbol, malformed expression, a link attached to a
    /// frame that does not exist, a joint that appears in no transform, a configuration
    /// freeing an unknown joint, duplicate names.
    pub fn load(path: &Path) -> Result<Model, ModelError> {
        let text = std::fs::read_to_string(path).map_err(|e| ModelError {
            file: path.to_path_buf(),
            item: String::new(),
            reason: format!("cannot read the model file: {e}"),
        })?;
        if path.extension().is_some_and(|x| x == "urdf") {
            return Model::from_urdf(path, &text);
        }
        Model::from_toml(path, &text)
    }

    /// A bare URDF as a model: its name is the `<robot name>`, its joints the URDF's
    /// independent moving joints, every body's inertial values symbols with the URDF's
    /// numbers as defaults, one configuration `full`.
    ///
    /// # Errors
    /// As [`crate::urdf::read`], and the validation of [`Model::from_toml`].
    pub fn from_urdf(path: &Path, text: &str) -> Result<Model, ModelError> {
        let u = crate::urdf::read(path, text, &[], None)?;
        let mut spec = ModelFile {
            robot: RobotSpec {
                name: crate::urdf::identifier(&u.robot),
                description: format!("URDF robot '{}'", u.robot),
                source: path.display().to_string(),
                joints: vec![],
                gravity: None,
                urdf: Some(path.display().to_string()),
                known_links: vec![],
            },
            constants: BTreeMap::new(),
            chains: vec![],
            frames: vec![],
            links: vec![],
            configurations: vec![],
            sequences: vec![],
            defaults: BTreeMap::new(),
        };
        let (warnings, joints) = fill_from_urdf(&mut spec, u);
        Model::from_spec(path, spec, Some((path.to_path_buf(), joints)), warnings)
    }

    /// Validate model text; `path` is used in error messages only.
    ///
    /// # Errors
    /// As [`Model::load`].
    pub fn from_toml(path: &Path, text: &str) -> Result<Model, ModelError> {
        let err = |item: &str, reason: String| ModelError {
            file: path.to_path_buf(),
            item: item.to_string(),
            reason,
        };
        let spec: ModelFile = toml::from_str(text).map_err(|e| {
            let msg = e.message().to_string();
            let line = e
                .span()
                .map(|s| text[..s.start.min(text.len())].matches('\n').count() + 1);
            err(
                &line.map(|l| format!("line {l}")).unwrap_or_default(),
                msg.replace('`', "'"),
            )
        })?;
        let (mut spec, mut urdf, mut warnings) = (spec, None, Vec::new());
        if let Some(u) = spec.robot.urdf.clone() {
            if !spec.chains.is_empty() || !spec.frames.is_empty() || !spec.links.is_empty() {
                return Err(err(
                    "[robot] field 'urdf'",
                    "a model read from a URDF takes its frames and links from it: remove the [[chain]], [[frame]] and [[link]] tables".into(),
                ));
            }
            let file = path.parent().unwrap_or(Path::new(".")).join(&u);
            let utext = std::fs::read_to_string(&file).map_err(|e| {
                err(
                    "[robot] field 'urdf'",
                    format!("cannot read '{}': {e}", file.display()),
                )
            })?;
            let vars = (!spec.robot.joints.is_empty()).then(|| spec.robot.joints.clone());
            let read = crate::urdf::read(&file, &utext, &spec.robot.known_links, vars.as_deref())?;
            let (w, joints) = fill_from_urdf(&mut spec, read);
            warnings = w;
            urdf = Some((file, joints));
        } else if !spec.robot.known_links.is_empty() {
            return Err(err(
                "[robot] field 'known_links'",
                "only a model read from a URDF ('urdf = \"…\"') has known links".into(),
            ));
        }
        Model::from_spec(path, spec, urdf, warnings)
    }

    /// Validate a parsed model file; `path` is used in error messages only.
    fn from_spec(
        path: &Path,
        spec: ModelFile,
        urdf: Option<(PathBuf, Vec<crate::urdf::UrdfJoint>)>,
        warnings: Vec<String>,
    ) -> Result<Model, ModelError> {
        let err = |item: &str, reason: String| ModelError {
            file: path.to_path_buf(),
            item: item.to_string(),
            reason,
        };
        let joints = spec.robot.joints.clone();
        if joints.is_empty() {
            return Err(err(
                "[robot] field 'joints'",
                "expected at least one joint variable".into(),
            ));
        }
        let mut seen = BTreeSet::new();
        for j in &joints {
            if !is_identifier(j) || j == "pi" {
                return Err(err(
                    "[robot] field 'joints'",
                    format!("'{j}' is not a valid joint variable name (letters, digits, '_')"),
                ));
            }
            if !seen.insert(j.clone()) {
                return Err(err(
                    "[robot] field 'joints'",
                    format!("joint '{j}' is listed twice"),
                ));
            }
        }
        let mut constants = BTreeMap::new();
        for (k, v) in &spec.constants {
            if !is_identifier(k) || joints.contains(k) || k == "pi" {
                return Err(err(
                    &format!("[constants] '{k}'"),
                    "a constant needs a name that is not a joint variable or 'pi'".into(),
                ));
            }
            let value = match v {
                ConstantSpec::Value(x) => *x,
                ConstantSpec::Detailed { value, .. } => *value,
            };
            if !value.is_finite() {
                return Err(err(
                    &format!("[constants] '{k}'"),
                    "expected a finite number".into(),
                ));
            }
            constants.insert(k.clone(), value);
        }
        let known = |e: &Expr, allow_joints: bool| -> Result<(), String> {
            for s in e.symbols() {
                let is_joint = joints.contains(&s);
                if !(constants.contains_key(&s) || (allow_joints && is_joint)) {
                    let mut expected = Vec::new();
                    if allow_joints {
                        expected.push(format!("a joint variable ({})", joints.join(", ")));
                    }
                    expected.push(if constants.is_empty() {
                        "a constant (none defined in [constants])".to_string()
                    } else {
                        format!(
                            "a constant ({})",
                            constants.keys().cloned().collect::<Vec<_>>().join(", ")
                        )
                    });
                    return Err(format!(
                        "unknown symbol '{s}': expected {} or 'pi'",
                        expected.join(" or ")
                    ));
                }
            }
            Ok(())
        };
        let parse = |item: &str, s: &Scalar, allow_joints: bool| -> Result<Expr, ModelError> {
            let e = match s {
                Scalar::Num(x) => Expr::Num(*x),
                Scalar::Text(t) => Expr::parse(t)
                    .map_err(|e| err(item, format!("malformed expression '{t}': {e}")))?,
            };
            known(&e, allow_joints).map_err(|r| err(item, r))?;
            Ok(e)
        };
        let Some(gravity_spec) = &spec.robot.gravity else {
            return Err(err(
                "[robot]",
                "missing field 'gravity' (gravity in frame 0, m/s², e.g. [0, 0, -9.81])".into(),
            ));
        };
        let gravity_expr: Vec<Expr> = gravity_spec
            .iter()
            .enumerate()
            .map(|(i, g)| parse(&format!("[robot] field 'gravity'[{i}]"), g, false))
            .collect::<Result<_, _>>()?;
        let mut gravity = [0.0; 3];
        for (i, g) in gravity_expr.iter().enumerate() {
            gravity[i] = g
                .eval(&constants)
                .ok_or_else(|| err("[robot] field 'gravity'", "expected numbers".into()))?;
        }

        let angle = |item: &str, s: &Scalar| -> Result<(Vec<i64>, f64), ModelError> {
            let e = parse(item, s, true)?;
            e.linear_angle(&joints, &constants)
                .map_err(|r| err(item, r))
        };
        let translation = |item: &str, axis: usize, s: &Scalar| -> Result<Transform, ModelError> {
            let e = parse(item, s, true)?;
            let (joints, offset) = e
                .linear(&joints, &constants, "a translation")
                .map_err(|r| err(item, r))?;
            Ok(Transform::Trans {
                axis,
                joints,
                offset,
            })
        };
        let mut frames = vec![Frame {
            name: "world".into(),
            parent: None,
            transforms: vec![],
        }];
        let mut names: BTreeMap<String, usize> = BTreeMap::new();
        names.insert("world".into(), 0);
        let lookup = |names: &BTreeMap<String, usize>, item: &str, name: &str| {
            names.get(name).copied().ok_or_else(|| {
                err(
                    item,
                    format!(
                        "frame '{name}' does not exist (known frames: {})",
                        names.keys().cloned().collect::<Vec<_>>().join(", ")
                    ),
                )
            })
        };
        let dh_block = |item: &str,
                        conv: Convention,
                        theta: &Scalar,
                        d: &Scalar,
                        a: &Scalar,
                        alpha: &Scalar|
         -> Result<Vec<Transform>, ModelError> {
            let (tj, t0) = angle(&format!("{item} field 'theta'"), theta)?;
            let tz = translation(&format!("{item} field 'd'"), 2, d)?;
            let tx = translation(&format!("{item} field 'a'"), 0, a)?;
            let (aj, a0) = angle(&format!("{item} field 'alpha'"), alpha)?;
            let rz = Transform::Rot {
                axis: 2,
                joints: tj,
                offset: t0,
            };
            let rx = Transform::Rot {
                axis: 0,
                joints: aj,
                offset: a0,
            };
            Ok(match conv {
                Convention::Standard => vec![rz, tz, tx, rx],
                Convention::Modified => vec![rx, tx, rz, tz],
            })
        };
        // Chains and extra frames may refer to each other in any order: resolve in passes.
        let mut pending_chains: Vec<&ChainSpec> = spec.chains.iter().collect();
        let mut pending_frames: Vec<&FrameSpec> = spec.frames.iter().collect();
        let mut seen_names = BTreeSet::new();
        for c in &spec.chains {
            if !is_identifier(&c.name) || !seen_names.insert(c.name.clone()) {
                return Err(err(
                    &format!("chain '{}'", c.name),
                    "chain names must be unique identifiers".into(),
                ));
            }
            if c.rows.is_empty() {
                return Err(err(
                    &format!("chain '{}'", c.name),
                    "expected at least one row".into(),
                ));
            }
        }
        for f in &spec.frames {
            if f.name == "world" || f.name.contains('.') || !seen_names.insert(f.name.clone()) {
                return Err(err(
                    &format!("frame '{}'", f.name),
                    "frame names must be unique, not 'world' and without '.'".into(),
                ));
            }
        }
        while !pending_chains.is_empty() || !pending_frames.is_empty() {
            let before = pending_chains.len() + pending_frames.len();
            let mut rest = Vec::new();
            for c in pending_chains {
                let parent = c.parent.clone().unwrap_or_else(|| "world".into());
                let Some(&p) = names.get(&parent) else {
                    rest.push(c);
                    continue;
                };
                names.insert(format!("{}.0", c.name), p);
                let mut prev = p;
                for (r, row) in c.rows.iter().enumerate() {
                    let item = format!("chain '{}' row {}", c.name, r + 1);
                    let transforms =
                        dh_block(&item, c.convention, &row.theta, &row.d, &row.a, &row.alpha)?;
                    frames.push(Frame {
                        name: format!("{}.{}", c.name, r + 1),
                        parent: Some(prev),
                        transforms,
                    });
                    prev = frames.len() - 1;
                    names.insert(format!("{}.{}", c.name, r + 1), prev);
                }
                names.insert(format!("{}.e", c.name), prev);
            }
            pending_chains = rest;
            let mut rest = Vec::new();
            for f in pending_frames {
                let parent = f.parent.clone().unwrap_or_else(|| "world".into());
                let Some(&p) = names.get(&parent) else {
                    rest.push(f);
                    continue;
                };
                let mut transforms = Vec::new();
                for (t, tr) in f.transforms.iter().enumerate() {
                    let item = format!("frame '{}' transform {}", f.name, t + 1);
                    match tr {
                        TransformSpec::Dh([th, d, a, al]) => {
                            transforms.extend(dh_block(&item, Convention::Standard, th, d, a, al)?)
                        }
                        TransformSpec::Mdh([al, a, th, d]) => {
                            transforms.extend(dh_block(&item, Convention::Modified, th, d, a, al)?)
                        }
                        TransformSpec::Trans(xyz) => {
                            for (axis, s) in xyz.iter().enumerate() {
                                transforms.push(translation(
                                    &format!("{item} 'trans'[{axis}]"),
                                    axis,
                                    s,
                                )?);
                            }
                        }
                        TransformSpec::RotX(s)
                        | TransformSpec::RotY(s)
                        | TransformSpec::RotZ(s) => {
                            let axis = match tr {
                                TransformSpec::RotX(_) => 0,
                                TransformSpec::RotY(_) => 1,
                                _ => 2,
                            };
                            let (joints, offset) = angle(&item, s)?;
                            transforms.push(Transform::Rot {
                                axis,
                                joints,
                                offset,
                            });
                        }
                    }
                }
                frames.push(Frame {
                    name: f.name.clone(),
                    parent: Some(p),
                    transforms,
                });
                names.insert(f.name.clone(), frames.len() - 1);
            }
            pending_frames = rest;
            if pending_chains.len() + pending_frames.len() == before {
                let (what, parent) = if let Some(c) = pending_chains.first() {
                    (
                        format!("chain '{}'", c.name),
                        c.parent.clone().unwrap_or_default(),
                    )
                } else {
                    let f = pending_frames[0];
                    (
                        format!("frame '{}'", f.name),
                        f.parent.clone().unwrap_or_default(),
                    )
                };
                return Err(err(
                    &format!("{what} field 'parent'"),
                    format!("frame '{parent}' does not exist or the parents form a cycle"),
                ));
            }
        }

        // Links and their inertial symbols.
        let mut links = Vec::new();
        let mut inertial_symbols: Vec<(String, usize, usize)> = Vec::new();
        let mut link_names = BTreeSet::new();
        for (li, l) in spec.links.iter().enumerate() {
            let item = format!("link '{}'", l.name);
            if !is_identifier(&l.name) || !link_names.insert(l.name.clone()) {
                return Err(err(&item, "link names must be unique identifiers".into()));
            }
            let frame = lookup(&names, &format!("{item} field 'frame'"), &l.frame)?;
            let mut inertial = |field: &str, s: &Scalar| -> Result<Expr, ModelError> {
                let role = if field == "mass" {
                    0
                } else if field.starts_with("com") {
                    1
                } else {
                    2
                };
                let fitem = format!("{item} field '{field}'");
                let e = match s {
                    Scalar::Num(x) => Expr::Num(*x),
                    Scalar::Text(t) => Expr::parse(t)
                        .map_err(|e| err(&fitem, format!("malformed expression '{t}': {e}")))?,
                };
                for s in e.symbols() {
                    if joints.contains(&s) {
                        return Err(err(
                            &fitem,
                            format!("joint variable '{s}' may not appear in an inertial parameter"),
                        ));
                    }
                    if constants.contains_key(&s) {
                        continue;
                    }
                    match inertial_symbols.iter().find(|(n, _, _)| *n == s) {
                        Some((_, owner, _)) if *owner != li => {
                            return Err(err(
                                &fitem,
                                format!(
                                    "symbol '{s}' is already an inertial parameter of link '{}'",
                                    spec.links[*owner].name
                                ),
                            ))
                        }
                        Some(_) => {}
                        None => inertial_symbols.push((s, li, role)),
                    }
                }
                Ok(e)
            };
            let mass = inertial("mass", &l.mass)?;
            let com = [
                inertial("com[0]", &l.com[0])?,
                inertial("com[1]", &l.com[1])?,
                inertial("com[2]", &l.com[2])?,
            ];
            let inertia = [
                inertial("inertia[0]", &l.inertia[0])?,
                inertial("inertia[1]", &l.inertia[1])?,
                inertial("inertia[2]", &l.inertia[2])?,
                inertial("inertia[3]", &l.inertia[3])?,
                inertial("inertia[4]", &l.inertia[4])?,
                inertial("inertia[5]", &l.inertia[5])?,
            ];
            links.push(Link {
                name: l.name.clone(),
                frame,
                mass,
                com,
                inertia,
            });
        }
        if links.is_empty() {
            return Err(err("[[link]]", "expected at least one link".into()));
        }

        // Every joint must move something: appear in a transform on the path of some link.
        let mut used = vec![false; joints.len()];
        for f in &frames {
            for t in &f.transforms {
                match t {
                    Transform::Rot { joints: c, .. } => {
                        for (k, &n) in c.iter().enumerate() {
                            used[k] |= n != 0;
                        }
                    }
                    Transform::Trans { joints: c, .. } => {
                        for (k, &x) in c.iter().enumerate() {
                            used[k] |= x != 0.0;
                        }
                    }
                }
            }
        }
        if let Some(k) = used.iter().position(|u| !u) {
            return Err(err(
                "[robot] field 'joints'",
                format!("joint '{}' appears in no chain or frame", joints[k]),
            ));
        }

        let mut configurations = Vec::new();
        let mut conf_names = BTreeSet::new();
        for c in &spec.configurations {
            let item = format!("configuration '{}'", c.name);
            if !conf_names.insert(c.name.clone()) {
                return Err(err(&item, "configuration names must be unique".into()));
            }
            let mut free = Vec::new();
            for j in &c.free {
                let k = joints.iter().position(|x| x == j).ok_or_else(|| {
                    err(
                        &format!("{item} field 'free'"),
                        format!("unknown joint '{j}' (joints: {})", joints.join(", ")),
                    )
                })?;
                if free.contains(&k) {
                    return Err(err(
                        &format!("{item} field 'free'"),
                        format!("joint '{j}' listed twice"),
                    ));
                }
                free.push(k);
            }
            if free.is_empty() {
                return Err(err(
                    &format!("{item} field 'free'"),
                    "expected at least one free joint".into(),
                ));
            }
            free.sort_unstable();
            configurations.push(Configuration {
                name: c.name.clone(),
                free,
                description: c.description.clone(),
            });
        }
        if !configurations.iter().any(|c| c.free.len() == joints.len()) {
            configurations.push(Configuration {
                name: "full".into(),
                free: (0..joints.len()).collect(),
                description: "all joints free".into(),
            });
        }
        let mut sequences = Vec::new();
        for s in &spec.sequences {
            let item = format!("sequence '{}' field 'steps'", s.name);
            let steps = s
                .steps
                .iter()
                .map(|n| {
                    configurations
                        .iter()
                        .position(|c| c.name == *n)
                        .ok_or_else(|| err(&item, format!("unknown configuration '{n}'")))
                })
                .collect::<Result<Vec<_>, _>>()?;
            sequences.push((s.name.clone(), steps));
        }
        let symbol_names: BTreeSet<&str> = inertial_symbols
            .iter()
            .map(|(n, _, _)| n.as_str())
            .collect();
        for (k, v) in &spec.defaults {
            if !symbol_names.contains(k.as_str()) {
                return Err(err(
                    &format!("[defaults] '{k}'"),
                    format!(
                        "not an inertial symbol of a link (symbols: {})",
                        symbol_names.iter().copied().collect::<Vec<_>>().join(", ")
                    ),
                ));
            }
            if !v.is_finite() {
                return Err(err(
                    &format!("[defaults] '{k}'"),
                    "expected a finite number".into(),
                ));
            }
        }
        Ok(Model {
            file: path.to_path_buf(),
            name: spec.robot.name.clone(),
            defaults: spec.defaults.clone(),
            urdf,
            warnings,
            spec,
            joints,
            constants,
            gravity,
            frames,
            links,
            inertial_symbols,
            configurations,
            sequences,
        })
    }

    /// Configuration by name.
    pub fn configuration(&self, name: &str) -> Option<&Configuration> {
        self.configurations.iter().find(|c| c.name == name)
    }
}

fn is_identifier(s: &str) -> bool {
    let mut c = s.chars();
    matches!(c.next(), Some(ch) if ch.is_ascii_alphabetic() || ch == '_')
        && c.all(|ch| ch.is_ascii_alphanumeric() || ch == '_')
}

/// Put a URDF's frames, links, joints and defaults into a model file's spec (defaults the
/// file gives itself win); returns the URDF's warnings and moving joints.
fn fill_from_urdf(
    spec: &mut ModelFile,
    u: crate::urdf::UrdfModel,
) -> (Vec<String>, Vec<crate::urdf::UrdfJoint>) {
    spec.robot.joints = u.joint_vars;
    if spec.robot.gravity.is_none() {
        spec.robot.gravity = Some([Scalar::Num(0.0), Scalar::Num(0.0), Scalar::Num(-9.81)]);
    }
    spec.frames = u
        .frames
        .into_iter()
        .map(|f| FrameSpec {
            name: f.name,
            parent: Some(f.parent),
            transforms: f.transforms,
        })
        .collect();
    spec.links = u.links;
    for (k, v) in u.defaults {
        spec.defaults.entry(k).or_insert(v);
    }
    (u.warnings, u.joints)
}
