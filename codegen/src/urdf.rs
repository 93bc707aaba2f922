//! URDF robot descriptions (ROS `urdf` format) read into the generator's frames and links.
//!
//! A URDF is a tree of links joined by joints. Each joint's placement in its parent link is
//! `origin` (xyz, then roll-pitch-yaw: R = Rz(yaw) Ry(pitch) Rx(roll)), then the joint's
//! motion about or along its unit `axis` (any direction). The reader turns every joint into
//! the elementary transforms the DH path already uses:
//!
//! - `Trans(x, y, z)`, `RotZ(yaw)`, `RotY(pitch)`, `RotX(roll)` for the origin, angles within
//!   1e-9 rad of a multiple of π/2 written as that exact multiple (URDFs print π/2 as
//!   `1.57079632679`), so that the generator folds their sines and cosines to 0 and ±1;
//! - for the motion, `Rot_i(±q)` when the axis is ±x, ±y or ±z, otherwise
//!   `RotZ(φ) RotY(θ) RotZ(q) RotY(−θ) RotZ(−φ)` with the axis at polar angle θ and azimuth
//!   φ; a prismatic joint is the translation `q·axis`;
//! - a `<mimic>` joint moves by `multiplier·q_master + offset` (the Freedom 6S parallelogram
//!   is this case); a revolute mimic needs an integer multiplier, as every angle of the
//!   generator is an integer combination of joint variables.
//!
//! Fixed joints merge their child link into its parent: the bodies of the dynamic model are
//! the links reached by a moving joint, each with the mass, centroid and inertia of
//! everything fixed to it (parallel-axis theorem, rotated into the body frame). The root
//! link and what is fixed to it are the ground and carry no dynamics.
//!
//! Every body's ten inertial quantities become symbols of the equations — `m_<link>`,
//! `cx_<link>` … (centroid in the body frame, m) and `Ixx_<link>` … (inertia about the
//! centroid in the body frame, tensor entries, kg·m²) — and the URDF's numbers are their
//! default values (the prior); bodies listed as known keep the numbers instead.
//!
//! Refused, each with one line naming the element: malformed XML (line and column), xacro
//! markup (expand it first), a joint whose parent or child link does not exist, a link with
//! two parent joints or a cycle (a kinematic loop: URDF describes trees), floating and
//! planar joints, a zero axis, a mimic of an unknown joint. Negative masses and inertias that
//! are not positive semidefinite or break the triangle inequality are reported as
//! warnings.

use crate::model::{LinkSpec, ModelError, Scalar, TransformSpec};
use std::collections::BTreeMap;
use std::path::Path;

/// A frame of the URDF as the generator sees it.
#[derive(Debug, Clone)]
pub struct UrdfFrame {
    /// Frame name (the body link's identifier).
    pub name: String,
    /// Parent frame (`world` for the root body).
    pub parent: String,
    /// Transforms from the parent, left to right.
    pub transforms: Vec<TransformSpec>,
}

/// One moving joint of the URDF, for reports.
#[derive(Debug, Clone)]
pub struct UrdfJoint {
    /// The URDF joint name.
    pub name: String,
    /// `revolute`, `continuous` or `prismatic`.
    pub kind: String,
    /// The joint variable it is (`None` for a mimic joint).
    pub variable: Option<String>,
    /// What it moves by: its variable, or `multiplier·q + offset` for a mimic joint.
    pub motion: String,
    /// Parent and child link names.
    pub parent: String,
    /// Child link name.
    pub child: String,
    /// Unit axis in the joint frame.
    pub axis: [f64; 3],
    /// Position limits (rad or m), when given.
    pub limits: Option<(f64, f64)>,
}

/// A URDF read into frames, links and default values.
#[derive(Debug, Clone)]
pub struct UrdfModel {
    /// `<robot name>`.
    pub robot: String,
    /// The URDF names of the independent joint variables, in tree order (depth first,
    /// children in file order).
    pub joint_names: Vec<String>,
    /// The joint variable of each of [`UrdfModel::joint_names`].
    pub joint_vars: Vec<String>,
    /// Every moving joint, mimic joints included, in tree order.
    pub joints: Vec<UrdfJoint>,
    /// Frames, parents first.
    pub frames: Vec<UrdfFrame>,
    /// Links (bodies with mass or inertia).
    pub links: Vec<LinkSpec>,
    /// Default value of every inertial symbol (the URDF's numbers).
    pub defaults: BTreeMap<String, f64>,
    /// Consistency warnings (negative mass, inertia not positive semidefinite, …).
    pub warnings: Vec<String>,
}

/// A 3×3 matrix, row major.
type M3 = [[f64; 3]; 3];

fn mul(a: &M3, b: &M3) -> M3 {
    let mut c = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            c[i][j] = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    c
}

fn transpose(a: &M3) -> M3 {
    std::array::from_fn(|i| std::array::from_fn(|j| a[j][i]))
}

fn apply(a: &M3, x: &[f64; 3]) -> [f64; 3] {
    std::array::from_fn(|i| (0..3).map(|k| a[i][k] * x[k]).sum())
}

/// Exact sine and cosine where the angle is a multiple of π/2 (as the generator folds it).
fn sincos(a: f64) -> (f64, f64) {
    match snap_quarter(a) {
        Some(k) => match k.rem_euclid(4) {
            0 => (0.0, 1.0),
            1 => (1.0, 0.0),
            2 => (0.0, -1.0),
            _ => (-1.0, 0.0),
        },
        None => a.sin_cos(),
    }
}

fn rot(axis: usize, a: f64) -> M3 {
    let (s, c) = sincos(a);
    match axis {
        0 => [[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]],
        1 => [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]],
        _ => [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]],
    }
}

/// R = Rz(yaw) Ry(pitch) Rx(roll) (URDF's fixed-axis roll-pitch-yaw).
fn rpy_matrix(rpy: &[f64; 3]) -> M3 {
    mul(&mul(&rot(2, rpy[2]), &rot(1, rpy[1])), &rot(0, rpy[0]))
}

/// `Some(k)` when `a` is within 1e-9 rad of k·π/2.
fn snap_quarter(a: f64) -> Option<i64> {
    let k = (a / std::f64::consts::FRAC_PI_2).round();
    ((a - k * std::f64::consts::FRAC_PI_2).abs() < 1e-9).then_some(k as i64)
}

/// An angle as the model file writes it: the exact multiple of π/2 when it is one.
fn angle_scalar(a: f64) -> Scalar {
    match snap_quarter(a) {
        Some(0) => Scalar::Num(0.0),
        Some(k) => Scalar::Text(format!("{k}*pi/2")),
        None => Scalar::Num(a),
    }
}

/// A rigid transform (rotation, translation) with f64 entries.
#[derive(Debug, Clone, Copy)]
struct Pose {
    r: M3,
    p: [f64; 3],
}

impl Pose {
    const IDENTITY: Pose = Pose {
        r: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        p: [0.0; 3],
    };
    fn then(&self, o: &Pose) -> Pose {
        let q = apply(&self.r, &o.p);
        Pose {
            r: mul(&self.r, &o.r),
            p: [self.p[0] + q[0], self.p[1] + q[1], self.p[2] + q[2]],
        }
    }
}

/// `<origin>` of a joint or an inertial: xyz and rpy.
#[derive(Debug, Clone, Copy, Default)]
struct Origin {
    xyz: [f64; 3],
    rpy: [f64; 3],
}

impl Origin {
    fn pose(&self) -> Pose {
        Pose {
            r: rpy_matrix(&self.rpy),
            p: self.xyz,
        }
    }
    fn transforms(&self) -> Vec<TransformSpec> {
        let mut t = Vec::new();
        if self.xyz.iter().any(|&x| x != 0.0) {
            t.push(TransformSpec::Trans(self.xyz.map(Scalar::Num)));
        }
        let [r, p, y] = self.rpy;
        if snap_quarter(y) != Some(0) {
            t.push(TransformSpec::RotZ(angle_scalar(y)));
        }
        if snap_quarter(p) != Some(0) {
            t.push(TransformSpec::RotY(angle_scalar(p)));
        }
        if snap_quarter(r) != Some(0) {
            t.push(TransformSpec::RotX(angle_scalar(r)));
        }
        t
    }
}

/// Mass, centroid and inertia about the centroid, in some frame.
#[derive(Debug, Clone, Copy)]
struct Inertial {
    m: f64,
    c: [f64; 3],
    i: M3,
}

impl Inertial {
    /// Expressed in a frame where the current one sits at `pose`.
    fn moved(&self, pose: &Pose) -> Inertial {
        let c = apply(&pose.r, &self.c);
        Inertial {
            m: self.m,
            c: [c[0] + pose.p[0], c[1] + pose.p[1], c[2] + pose.p[2]],
            i: mul(&mul(&pose.r, &self.i), &transpose(&pose.r)),
        }
    }
    /// The composite body of two (parallel-axis theorem).
    fn plus(&self, o: &Inertial) -> Inertial {
        let m = self.m + o.m;
        if m == 0.0 {
            let mut i = self.i;
            for (r, row) in i.iter_mut().enumerate() {
                for (k, x) in row.iter_mut().enumerate() {
                    *x += o.i[r][k];
                }
            }
            return Inertial { m, c: self.c, i };
        }
        let c: [f64; 3] = std::array::from_fn(|k| (self.m * self.c[k] + o.m * o.c[k]) / m);
        let shift = |b: &Inertial| -> M3 {
            let d: [f64; 3] = std::array::from_fn(|k| b.c[k] - c[k]);
            let dd = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            std::array::from_fn(|r| {
                std::array::from_fn(|k| {
                    b.i[r][k] + b.m * (if r == k { dd } else { 0.0 } - d[r] * d[k])
                })
            })
        };
        let (a, b) = (shift(self), shift(o));
        Inertial {
            m,
            c,
            i: std::array::from_fn(|r| std::array::from_fn(|k| a[r][k] + b[r][k])),
        }
    }
}

/// The first child element of `n` named `tag`.
fn child<'a, 'i>(n: &roxmltree::Node<'a, 'i>, tag: &str) -> Option<roxmltree::Node<'a, 'i>> {
    n.children()
        .find(|c| c.is_element() && c.tag_name().name() == tag)
}

/// Sanitised identifier of a URDF name (letters, digits, `_`).
pub fn identifier(name: &str) -> String {
    let mut s: String = name
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    if !s.starts_with(|c: char| c.is_ascii_alphabetic() || c == '_') {
        s.insert(0, '_');
    }
    s
}

struct JointEl {
    name: String,
    kind: String,
    line: u32,
    origin: Origin,
    parent: String,
    child: String,
    axis: [f64; 3],
    mimic: Option<(String, f64, f64)>,
    limits: Option<(f64, f64)>,
}

/// Read a URDF. `known` lists the URDF link names whose inertial values stay numbers;
/// `joint_vars`, when given, names the joint variables (one per independent moving joint, in
/// tree order); by default they are the URDF joint names made identifiers.
///
/// # Errors
/// [`ModelError`] naming `path`, the element (with its line) and what was expected.
pub fn read(
    path: &Path,
    text: &str,
    known: &[String],
    joint_vars: Option<&[String]>,
) -> Result<UrdfModel, ModelError> {
    let err = |item: String, reason: String| ModelError {
        file: path.to_path_buf(),
        item,
        reason,
    };
    // An expanded URDF may keep the xacro namespace declaration; markup is what matters.
    if text.contains("<xacro:") || text.contains("${") || text.contains("$(") {
        return Err(err(
            String::new(),
            "xacro markup is not supported: expand the file first (`xacro robot.urdf.xacro > robot.urdf`, ROS) and give the URDF".into(),
        ));
    }
    let doc = roxmltree::Document::parse(text).map_err(|e| {
        let pos = e.pos();
        err(
            format!("line {} column {}", pos.row, pos.col),
            format!("malformed XML: {e}"),
        )
    })?;
    let line = |n: &roxmltree::Node| doc.text_pos_at(n.range().start).row;
    let root = doc.root_element();
    if root.tag_name().name() != "robot" {
        return Err(err(
            format!("line {} <{}>", line(&root), root.tag_name().name()),
            "expected the root element <robot name=\"…\">".into(),
        ));
    }
    let robot = root.attribute("name").unwrap_or("robot").to_string();
    let numbers = |n: &roxmltree::Node,
                   attr: &str,
                   what: &str,
                   default: Option<[f64; 3]>|
     -> Result<[f64; 3], ModelError> {
        let item = format!("line {} <{}> of {what}", line(n), n.tag_name().name());
        let Some(v) = n.attribute(attr) else {
            return default
                .ok_or_else(|| err(item, format!("attribute '{attr}' is missing (3 numbers)")));
        };
        let parts: Vec<&str> = v.split_whitespace().collect();
        let vals: Vec<f64> = parts
            .iter()
            .map(|p| p.parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|_| {
                err(
                    item.clone(),
                    format!("attribute '{attr}' = \"{v}\": expected 3 numbers"),
                )
            })?;
        if vals.len() != 3 || vals.iter().any(|x| !x.is_finite()) {
            return Err(err(
                item,
                format!("attribute '{attr}' = \"{v}\": expected 3 finite numbers"),
            ));
        }
        Ok([vals[0], vals[1], vals[2]])
    };
    let number = |n: &roxmltree::Node, attr: &str, what: &str| -> Result<f64, ModelError> {
        let item = format!("line {} <{}> of {what}", line(n), n.tag_name().name());
        let v = n
            .attribute(attr)
            .ok_or_else(|| err(item.clone(), format!("attribute '{attr}' is missing")))?;
        v.trim()
            .parse::<f64>()
            .ok()
            .filter(|x| x.is_finite())
            .ok_or_else(|| {
                err(
                    item,
                    format!("attribute '{attr}' = \"{v}\": expected a number"),
                )
            })
    };
    let origin_of = |n: &roxmltree::Node, what: &str| -> Result<Origin, ModelError> {
        Ok(match child(n, "origin") {
            Some(o) => Origin {
                xyz: numbers(&o, "xyz", what, Some([0.0; 3]))?,
                rpy: numbers(&o, "rpy", what, Some([0.0; 3]))?,
            },
            None => Origin::default(),
        })
    };

    // Links.
    let mut link_order: Vec<String> = Vec::new();
    let mut inertials: BTreeMap<String, Option<Inertial>> = BTreeMap::new();
    for l in root
        .children()
        .filter(|c| c.is_element() && c.tag_name().name() == "link")
    {
        let Some(name) = l.attribute("name") else {
            return Err(err(
                format!("line {} <link>", line(&l)),
                "attribute 'name' is missing".into(),
            ));
        };
        let what = format!("link '{name}'");
        if inertials.contains_key(name) {
            return Err(err(
                format!("line {} {what}", line(&l)),
                "a link of this name is already defined".into(),
            ));
        }
        let inertial = match child(&l, "inertial") {
            None => None,
            Some(i) => {
                let o = origin_of(&i, &what)?;
                let m = match child(&i, "mass") {
                    Some(mn) => number(&mn, "value", &what)?,
                    None => 0.0,
                };
                let t = match child(&i, "inertia") {
                    Some(t) => {
                        let g = |a: &str| number(&t, a, &what);
                        let (xx, xy, xz, yy, yz, zz) = (
                            g("ixx")?,
                            g("ixy")?,
                            g("ixz")?,
                            g("iyy")?,
                            g("iyz")?,
                            g("izz")?,
                        );
                        [[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]]
                    }
                    None => [[0.0; 3]; 3],
                };
                // The inertia is given about the centroid in the inertial frame (origin).
                Some(
                    Inertial {
                        m,
                        c: [0.0; 3],
                        i: t,
                    }
                    .moved(&o.pose()),
                )
            }
        };
        link_order.push(name.to_string());
        inertials.insert(name.to_string(), inertial);
    }
    if link_order.is_empty() {
        return Err(err("<robot>".into(), "expected at least one <link>".into()));
    }

    // Joints.
    let mut joints: Vec<JointEl> = Vec::new();
    for j in root
        .children()
        .filter(|c| c.is_element() && c.tag_name().name() == "joint")
    {
        let ln = line(&j);
        let Some(name) = j.attribute("name") else {
            return Err(err(
                format!("line {ln} <joint>"),
                "attribute 'name' is missing".into(),
            ));
        };
        let what = format!("joint '{name}'");
        let item = format!("line {ln} {what}");
        let kind = j.attribute("type").unwrap_or("").to_string();
        match kind.as_str() {
            "revolute" | "continuous" | "prismatic" | "fixed" => {}
            "floating" | "planar" => {
                return Err(err(
                    item,
                    format!("type '{kind}' is not supported: lockstep models fixed-base arms with revolute, continuous, prismatic and fixed joints"),
                ))
            }
            other => {
                return Err(err(
                    item,
                    format!("type '{other}': expected revolute, continuous, prismatic or fixed"),
                ))
            }
        }
        if joints.iter().any(|k| k.name == name) {
            return Err(err(item, "a joint of this name is already defined".into()));
        }
        let link_of = |tag: &str| -> Result<String, ModelError> {
            let n = child(&j, tag)
                .ok_or_else(|| err(item.clone(), format!("<{tag} link=\"…\"> is missing")))?;
            let l = n
                .attribute("link")
                .ok_or_else(|| err(item.clone(), format!("<{tag}> has no attribute 'link'")))?;
            if !inertials.contains_key(l) {
                return Err(err(
                    item.clone(),
                    format!(
                        "{tag} link '{l}' does not exist (links: {})",
                        link_order.join(", ")
                    ),
                ));
            }
            Ok(l.to_string())
        };
        let parent = link_of("parent")?;
        let childl = link_of("child")?;
        let axis = match child(&j, "axis") {
            Some(a) => numbers(&a, "xyz", &what, Some([1.0, 0.0, 0.0]))?,
            None => [1.0, 0.0, 0.0],
        };
        let norm = axis.iter().map(|x| x * x).sum::<f64>().sqrt();
        if kind != "fixed" && norm < 1e-12 {
            return Err(err(
                item,
                "<axis xyz=\"0 0 0\">: the axis must not be zero".into(),
            ));
        }
        let axis = if kind == "fixed" {
            axis
        } else {
            axis.map(|x| x / norm)
        };
        let mimic = match child(&j, "mimic") {
            Some(m) => {
                let of = m
                    .attribute("joint")
                    .ok_or_else(|| err(item.clone(), "<mimic> has no attribute 'joint'".into()))?;
                let mult = if m.attribute("multiplier").is_some() {
                    number(&m, "multiplier", &what)?
                } else {
                    1.0
                };
                let off = if m.attribute("offset").is_some() {
                    number(&m, "offset", &what)?
                } else {
                    0.0
                };
                Some((of.to_string(), mult, off))
            }
            None => None,
        };
        let limits = match child(&j, "limit") {
            Some(l) if kind != "continuous" && l.attribute("lower").is_some() => {
                Some((number(&l, "lower", &what)?, number(&l, "upper", &what)?))
            }
            _ => None,
        };
        joints.push(JointEl {
            name: name.to_string(),
            kind,
            line: ln,
            origin: origin_of(&j, &what)?,
            parent,
            child: childl,
            axis,
            mimic,
            limits,
        });
    }

    // The tree: every link has at most one parent joint, one root, no cycle.
    let mut parent_joint: BTreeMap<&str, usize> = BTreeMap::new();
    for (k, j) in joints.iter().enumerate() {
        if let Some(&other) = parent_joint.get(j.child.as_str()) {
            return Err(err(
                format!("line {} joint '{}'", j.line, j.name),
                format!(
                    "link '{}' is already the child of joint '{}': a kinematic loop (URDF describes trees; close loops with <mimic> joints)",
                    j.child, joints[other].name
                ),
            ));
        }
        parent_joint.insert(&j.child, k);
    }
    let roots: Vec<&String> = link_order
        .iter()
        .filter(|l| !parent_joint.contains_key(l.as_str()))
        .collect();
    if roots.len() != 1 {
        return Err(err(
            "<robot>".into(),
            if roots.is_empty() {
                "every link is the child of a joint: the joints form a kinematic loop".into()
            } else {
                format!(
                    "{} links have no parent joint ({}); expected one root link",
                    roots.len(),
                    roots
                        .iter()
                        .map(|s| s.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            },
        ));
    }
    let root_link = roots[0].clone();
    // Depth first from the root, children in file order.
    let mut order: Vec<usize> = Vec::new();
    let mut stack: Vec<&str> = vec![&root_link];
    while let Some(l) = stack.pop() {
        let kids: Vec<usize> = (0..joints.len())
            .filter(|&k| joints[k].parent == l)
            .collect();
        for &k in kids.iter().rev() {
            stack.push(&joints[k].child);
        }
        // Keep the file order among siblings: push reversed, pop in order; joints are
        // recorded when their child is visited.
        if let Some(&k) = parent_joint.get(l) {
            order.push(k);
        }
    }
    if order.len() != joints.len() {
        let lost: Vec<&str> = joints
            .iter()
            .enumerate()
            .filter(|(k, _)| !order.contains(k))
            .map(|(_, j)| j.name.as_str())
            .collect();
        return Err(err(
            "<robot>".into(),
            format!(
                "joints {} are not reachable from the root link '{root_link}': a kinematic loop",
                lost.join(", ")
            ),
        ));
    }

    // Independent joint variables (moving, not mimic) and each moving joint's motion.
    let mut joint_names = Vec::new();
    for &k in &order {
        let j = &joints[k];
        if j.kind != "fixed" && j.mimic.is_none() {
            joint_names.push(j.name.clone());
        }
    }
    let vars: Vec<String> = match joint_vars {
        Some(v) if v.len() != joint_names.len() => {
            return Err(err(
                "[robot] field 'joints'".into(),
                format!(
                    "{} names given; the URDF has {} independent moving joints ({}), named in this order",
                    v.len(),
                    joint_names.len(),
                    joint_names.join(", ")
                ),
            ))
        }
        Some(v) => v.to_vec(),
        None => joint_names.iter().map(|n| identifier(n)).collect(),
    };
    let var = |n: &str| {
        let k = joint_names
            .iter()
            .position(|j| j == n)
            .expect("a master joint");
        vars[k].clone()
    };
    let motion_of = |k: usize| -> Result<(String, f64, f64), ModelError> {
        // (master joint, multiplier, offset), following mimic chains.
        let (mut name, mut mult, mut off) = (joints[k].name.clone(), 1.0, 0.0);
        let mut seen = vec![k];
        while let Some(j) = joints.iter().position(|j| j.name == name) {
            let Some((of, m, o)) = &joints[j].mimic else {
                break;
            };
            let Some(next) = joints.iter().position(|x| x.name == *of) else {
                return Err(err(
                    format!("line {} joint '{}'", joints[j].line, joints[j].name),
                    format!("<mimic joint=\"{of}\">: no joint of that name"),
                ));
            };
            if seen.contains(&next) || joints[next].kind == "fixed" {
                return Err(err(
                    format!("line {} joint '{}'", joints[j].line, joints[j].name),
                    format!("<mimic joint=\"{of}\">: expected a moving joint that is not a mimic of this one"),
                ));
            }
            seen.push(next);
            // q_j = m q_next + o, and q_k = mult q_j + off.
            off += mult * o;
            mult *= m;
            name = of.clone();
        }
        Ok((name, mult, off))
    };

    // Bodies: each link maps to (body link, pose of the link in the body frame).
    let mut body_of: BTreeMap<String, (String, Pose, Vec<TransformSpec>)> = BTreeMap::new();
    body_of.insert(root_link.clone(), ("world".into(), Pose::IDENTITY, vec![]));
    let mut frames = Vec::new();
    let mut urdf_joints = Vec::new();
    let mut body_order: Vec<String> = Vec::new();
    for &k in &order {
        let j = &joints[k];
        let (pbody, ppose, ptrans) = body_of[&j.parent].clone();
        let mut transforms = ptrans.clone();
        transforms.extend(j.origin.transforms());
        if j.kind == "fixed" {
            body_of.insert(
                j.child.clone(),
                (pbody, ppose.then(&j.origin.pose()), transforms),
            );
            continue;
        }
        let (master, mult, off) = motion_of(k)?;
        let item = format!("line {} joint '{}'", j.line, j.name);
        let qv = var(&master);
        let lin = |scale: f64| -> String {
            let c = mult * scale;
            let o = off * scale;
            if o == 0.0 {
                format!("({c:?})*{qv}")
            } else {
                format!("({c:?})*{qv} + ({o:?})")
            }
        };
        let revolute = j.kind != "prismatic";
        if revolute && j.mimic.is_some() && mult.fract() != 0.0 {
            return Err(err(
                item,
                format!("<mimic multiplier=\"{mult}\">: a revolute mimic joint needs an integer multiplier (lockstep's angles are integer combinations of joint variables)"),
            ));
        }
        let angle = |sign: f64| -> Scalar {
            let (c, o) = (mult * sign, off * sign);
            let mut s = if c == 1.0 {
                qv.clone()
            } else if c == -1.0 {
                format!("-{qv}")
            } else {
                format!("{}*{qv}", c as i64)
            };
            if let Some(kq) = snap_quarter(o) {
                if kq != 0 {
                    s.push_str(&format!(" + {kq}*pi/2"));
                }
            } else {
                s.push_str(&format!(" + ({o:?})"));
            }
            Scalar::Text(s)
        };
        let a = j.axis;
        let principal = (0..3).find(|&i| (a[i].abs() - 1.0).abs() < 1e-12);
        if revolute {
            match principal {
                Some(i) => {
                    let t = angle(a[i].signum());
                    transforms.push(match i {
                        0 => TransformSpec::RotX(t),
                        1 => TransformSpec::RotY(t),
                        _ => TransformSpec::RotZ(t),
                    })
                }
                None => {
                    let theta = a[2].clamp(-1.0, 1.0).acos();
                    let phi = a[1].atan2(a[0]);
                    transforms.push(TransformSpec::RotZ(angle_scalar(phi)));
                    transforms.push(TransformSpec::RotY(angle_scalar(theta)));
                    transforms.push(TransformSpec::RotZ(angle(1.0)));
                    transforms.push(TransformSpec::RotY(angle_scalar(-theta)));
                    transforms.push(TransformSpec::RotZ(angle_scalar(-phi)));
                }
            }
        } else {
            transforms.push(TransformSpec::Trans(std::array::from_fn(|i| {
                if a[i] == 0.0 {
                    Scalar::Num(0.0)
                } else {
                    Scalar::Text(lin(a[i]))
                }
            })));
        }
        let frame = identifier(&j.child);
        frames.push(UrdfFrame {
            name: frame.clone(),
            parent: if pbody == "world" {
                "world".into()
            } else {
                identifier(&pbody)
            },
            transforms,
        });
        urdf_joints.push(UrdfJoint {
            name: j.name.clone(),
            kind: j.kind.clone(),
            variable: j.mimic.is_none().then(|| qv.clone()),
            motion: if j.mimic.is_some() {
                format!("{mult}·{qv} + {off}")
            } else {
                qv.clone()
            },
            parent: j.parent.clone(),
            child: j.child.clone(),
            axis: a,
            limits: j.limits,
        });
        body_of.insert(j.child.clone(), (j.child.clone(), Pose::IDENTITY, vec![]));
        body_order.push(j.child.clone());
    }

    // Each body's composite inertial in its frame.
    let mut composite: BTreeMap<String, Inertial> = BTreeMap::new();
    for l in &link_order {
        let (body, pose, _) = &body_of[l];
        if body == "world" {
            continue;
        }
        if let Some(i) = inertials[l] {
            let moved = i.moved(pose);
            let e = composite.entry(body.clone()).or_insert(Inertial {
                m: 0.0,
                c: [0.0; 3],
                i: [[0.0; 3]; 3],
            });
            *e = e.plus(&moved);
        }
    }
    let mut links = Vec::new();
    let mut defaults = BTreeMap::new();
    let mut warnings = Vec::new();
    for b in &body_order {
        let Some(inr) = composite.get(b) else {
            continue;
        };
        if inr.m == 0.0 && inr.i.iter().flatten().all(|&x| x == 0.0) {
            continue;
        }
        let id = identifier(b);
        warnings.extend(consistency(b, inr));
        let values = [
            inr.m,
            inr.c[0],
            inr.c[1],
            inr.c[2],
            inr.i[0][0],
            inr.i[0][1],
            inr.i[0][2],
            inr.i[1][1],
            inr.i[1][2],
            inr.i[2][2],
        ];
        let names = [
            "m", "cx", "cy", "cz", "Ixx", "Ixy", "Ixz", "Iyy", "Iyz", "Izz",
        ];
        let field: Vec<Scalar> = if known.iter().any(|k| k == b) {
            values.iter().map(|&v| Scalar::Num(v)).collect()
        } else {
            names
                .iter()
                .zip(values)
                .map(|(n, v)| {
                    let s = format!("{n}_{id}");
                    defaults.insert(s.clone(), v);
                    Scalar::Text(s)
                })
                .collect()
        };
        links.push(LinkSpec {
            name: id.clone(),
            frame: id,
            mass: field[0].clone(),
            com: [field[1].clone(), field[2].clone(), field[3].clone()],
            inertia: std::array::from_fn(|k| field[4 + k].clone()),
            note: format!("URDF link '{b}' with the links fixed to it"),
        });
    }
    for k in known {
        if !body_order.contains(k) {
            return Err(err(
                "[robot] field 'known_links'".into(),
                format!(
                    "'{k}' is not a moving link of the URDF (moving links: {})",
                    body_order.join(", ")
                ),
            ));
        }
    }
    Ok(UrdfModel {
        robot,
        joint_names,
        joint_vars: vars,
        joints: urdf_joints,
        frames,
        links,
        defaults,
        warnings,
    })
}

/// Physical-consistency warnings of a body: negative mass, an inertia about the centroid
/// that is not positive semidefinite or breaks the triangle inequality (principal moments
/// a ≤ b + c).
fn consistency(link: &str, b: &Inertial) -> Vec<String> {
    let mut w = Vec::new();
    if b.m < 0.0 {
        w.push(format!("link '{link}': negative mass {} kg", b.m));
    }
    let i = &b.i;
    let scale = i.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()));
    let tol = 1e-12 * scale.max(1e-300);
    let minors = [
        i[0][0],
        i[1][1],
        i[2][2],
        i[0][0] * i[1][1] - i[0][1] * i[0][1],
        i[0][0] * i[2][2] - i[0][2] * i[0][2],
        i[1][1] * i[2][2] - i[1][2] * i[1][2],
        i[0][0] * (i[1][1] * i[2][2] - i[1][2] * i[1][2])
            - i[0][1] * (i[0][1] * i[2][2] - i[1][2] * i[0][2])
            + i[0][2] * (i[0][1] * i[1][2] - i[1][1] * i[0][2]),
    ];
    let tols = [
        tol,
        tol,
        tol,
        tol * scale,
        tol * scale,
        tol * scale,
        tol * scale * scale,
    ];
    if minors.iter().zip(tols).any(|(m, t)| *m < -t) {
        w.push(format!(
            "link '{link}': the inertia about the centroid is not positive semidefinite"
        ));
    } else if minors[6] <= tols[6] {
        w.push(format!(
            "link '{link}': the inertia about the centroid is singular (a point or a line): the plant's consistency check calls the link impossible until the inertia is identified or set"
        ));
    } else {
        let (a, b2, c) = (i[0][0], i[1][1], i[2][2]);
        // The triangle inequality on the diagonal (necessary for a real body).
        if a > b2 + c + tol || b2 > a + c + tol || c > a + b2 + tol {
            w.push(format!(
                "link '{link}': the inertia breaks the triangle inequality (Ixx ≤ Iyy + Izz and its permutations)"
            ));
        }
    }
    w
}
