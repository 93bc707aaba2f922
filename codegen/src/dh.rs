//! The equivalent modified (Craig) DH table of a serial model, where one exists
//! (`lockstep model dh`): for a URDF, the table a user would otherwise derive by hand, printed
//! as model-file TOML (a `[[chain]]` with the link frames as `[[frame]]`s on it) so that it
//! can be checked or pasted.
//!
//! Method (J. J. Craig, *Introduction to Robotics*, 3rd ed., §3.4): at q = 0 every joint is a
//! line (a point and a unit direction in the world frame). Frame i has z_i on joint i's line
//! and x_i along the common normal from line i to line i + 1 (through the foot of x_{i−1} on
//! line i when the two lines are parallel, along z_i × z_{i+1} when they intersect); frame 0
//! is frame 1 at q = 0, reached from the world by a fixed base transform; frame n keeps
//! x_{n−1}'s direction. Then α_{i−1}, a_{i−1}, d_i and the offset of θ_i are read off the
//! frames. The link frames (where the inertial values are given) follow as fixed transforms
//! from the DH frame of the last joint before them. The table is checked against the model's
//! own forward kinematics at random joint values before it is printed.
//!
//! No table exists for a tree (several branches), for a joint that appears in more than one
//! transform (a coupled or mimic joint), or for a scaled joint (θ = 2q, d = 0.5q).

use crate::model::{Model, Transform};
use std::fmt::Write;

type V3 = [f64; 3];
type M3 = [[f64; 3]; 3];

/// A rigid transform.
#[derive(Debug, Clone, Copy)]
struct Pose {
    r: M3,
    p: V3,
}

const I3: M3 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

fn mm(a: &M3, b: &M3) -> M3 {
    std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| a[i][k] * b[k][j]).sum()))
}
fn mv(a: &M3, x: &V3) -> V3 {
    std::array::from_fn(|i| (0..3).map(|k| a[i][k] * x[k]).sum())
}
fn tr(a: &M3) -> M3 {
    std::array::from_fn(|i| std::array::from_fn(|j| a[j][i]))
}
fn dot(a: &V3, b: &V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: &V3, b: &V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn sub(a: &V3, b: &V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn add(a: &V3, b: &V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
fn scale(a: &V3, s: f64) -> V3 {
    [a[0] * s, a[1] * s, a[2] * s]
}
fn norm(a: &V3) -> f64 {
    dot(a, a).sqrt()
}
fn unit(a: &V3) -> V3 {
    scale(a, 1.0 / norm(a))
}

fn rot(axis: usize, a: f64) -> M3 {
    let (s, c) = a.sin_cos();
    match axis {
        0 => [[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]],
        1 => [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]],
        _ => [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]],
    }
}

impl Pose {
    const IDENTITY: Pose = Pose { r: I3, p: [0.0; 3] };
    fn then(&self, o: &Pose) -> Pose {
        Pose {
            r: mm(&self.r, &o.r),
            p: add(&self.p, &mv(&self.r, &o.p)),
        }
    }
    fn inverse(&self) -> Pose {
        let rt = tr(&self.r);
        Pose {
            r: rt,
            p: scale(&mv(&rt, &self.p), -1.0),
        }
    }
    fn rot(axis: usize, a: f64) -> Pose {
        Pose {
            r: rot(axis, a),
            p: [0.0; 3],
        }
    }
    fn trans(p: V3) -> Pose {
        Pose { r: I3, p }
    }
}

/// One elementary transform evaluated at `q`.
fn elementary(t: &Transform, q: &[f64]) -> Pose {
    match t {
        Transform::Rot {
            axis,
            joints,
            offset,
        } => {
            let a = offset
                + joints
                    .iter()
                    .zip(q)
                    .map(|(&n, &x)| n as f64 * x)
                    .sum::<f64>();
            Pose::rot(*axis, a)
        }
        Transform::Trans {
            axis,
            joints,
            offset,
        } => {
            let mut p = [0.0; 3];
            p[*axis] = offset + joints.iter().zip(q).map(|(&c, &x)| c * x).sum::<f64>();
            Pose::trans(p)
        }
    }
}

/// World pose of every frame of the model at `q`.
fn frame_poses(model: &Model, q: &[f64]) -> Vec<Pose> {
    let mut poses = vec![Pose::IDENTITY; model.frames.len()];
    for (i, f) in model.frames.iter().enumerate() {
        if let Some(p) = f.parent {
            let mut t = poses[p];
            for e in &f.transforms {
                t = t.then(&elementary(e, q));
            }
            poses[i] = t;
        }
    }
    poses
}

/// A joint's line at q = 0 and its kind.
struct JointLine {
    point: V3,
    dir: V3,
    prismatic: bool,
    /// Frame the joint's transform belongs to, and the transform's index in it.
    at: (usize, usize),
}

/// One row of the table: α_{i−1}, a_{i−1}, θ_i offset, d_i offset (rad, m).
struct Row {
    alpha: f64,
    a: f64,
    theta: f64,
    d: f64,
    prismatic: bool,
}

fn ancestors(model: &Model, f: usize) -> Vec<usize> {
    let mut v = vec![f];
    let mut cur = f;
    while let Some(p) = model.frames[cur].parent {
        v.push(p);
        cur = p;
    }
    v.reverse();
    v
}

/// An angle as the model file writes it (`pi/2`, `-pi`, or a number).
fn angle(a: f64) -> String {
    let k = a / std::f64::consts::FRAC_PI_2;
    if (k - k.round()).abs() < 1e-12 {
        match k.round() as i64 {
            0 => "0".into(),
            1 => "\"pi/2\"".into(),
            -1 => "\"-pi/2\"".into(),
            2 | -2 => "\"pi\"".into(),
            n => format!("\"{n}*pi/2\""),
        }
    } else {
        clean(a)
    }
}

/// The shortest decimal within 1e-13 (relative) of `x`: 0.384, not 0.3839999999999999.
fn clean(x: f64) -> String {
    for digits in 1..=16 {
        let s = format!("{x:.*e}", digits - 1);
        if let Ok(y) = s.parse::<f64>() {
            if (y - x).abs() <= 1e-13 * x.abs().max(1e-300) {
                return format!("{y:?}");
            }
        }
    }
    format!("{x:?}")
}

fn length(x: f64) -> String {
    if x.abs() < 1e-14 {
        "0".into()
    } else {
        clean(x)
    }
}

/// Roll, pitch, yaw of R = Rz(yaw) Ry(pitch) Rx(roll).
fn rpy(r: &M3) -> V3 {
    let sp = (-r[2][0]).clamp(-1.0, 1.0);
    let pitch = sp.asin();
    if sp.abs() > 1.0 - 1e-12 {
        [0.0, pitch, (-r[0][1]).atan2(r[1][1])]
    } else {
        [r[2][1].atan2(r[2][2]), pitch, r[1][0].atan2(r[0][0])]
    }
}

/// A fixed transform as model-file `transforms` (translation, then rot_z, rot_y, rot_x).
fn transforms(p: &Pose) -> String {
    let mut parts = Vec::new();
    if p.p.iter().any(|x| x.abs() >= 1e-14) {
        parts.push(format!(
            "{{ trans = [{}, {}, {}] }}",
            length(p.p[0]),
            length(p.p[1]),
            length(p.p[2])
        ));
    }
    let [r, pi, y] = rpy(&p.r);
    for (name, a) in [("rot_z", y), ("rot_y", pi), ("rot_x", r)] {
        if a.abs() >= 1e-14 {
            parts.push(format!("{{ {name} = {} }}", angle(a)));
        }
    }
    format!("[{}]", parts.join(", "))
}

/// The equivalent modified DH table of `model` as model-file TOML, or why none exists.
///
/// # Errors
/// A text naming why the model has no DH table (a tree, a coupled or scaled joint, joints
/// out of chain order), or that the check against the model's kinematics failed.
pub fn equivalent_dh(model: &Model) -> Result<String, String> {
    let n = model.joints.len();
    // Each joint in exactly one elementary transform (consecutive translations of a frame
    // count as one), with unit coefficient.
    let mut lines: Vec<Option<JointLine>> = (0..n).map(|_| None).collect();
    let zero = vec![0.0; n];
    let poses = frame_poses(model, &zero);
    for (fi, f) in model.frames.iter().enumerate() {
        let Some(parent) = f.parent else { continue };
        let mut t = poses[parent];
        let mut ti = 0;
        while ti < f.transforms.len() {
            match &f.transforms[ti] {
                Transform::Rot {
                    axis,
                    joints,
                    offset,
                } => {
                    for (k, &c) in joints.iter().enumerate() {
                        if c == 0 {
                            continue;
                        }
                        if lines[k].is_some() {
                            return Err(format!(
                                "joint {} moves more than one transform (a coupled or mimic joint)",
                                model.joints[k]
                            ));
                        }
                        if c.abs() != 1 || joints.iter().filter(|&&x| x != 0).count() > 1 {
                            return Err(format!("joint {} enters an angle with coefficient {c} or beside another joint", model.joints[k]));
                        }
                        let before = t.then(&Pose::rot(*axis, *offset));
                        let col: V3 = std::array::from_fn(|i| before.r[i][*axis]);
                        lines[k] = Some(JointLine {
                            point: t.p,
                            dir: scale(&col, c as f64),
                            prismatic: false,
                            at: (fi, ti),
                        });
                    }
                    t = t.then(&elementary(&f.transforms[ti], &zero));
                    ti += 1;
                }
                Transform::Trans { .. } => {
                    // The run of consecutive translations: u_k per joint.
                    let start = ti;
                    let mut u = vec![[0.0; 3]; n];
                    let mut p0 = [0.0; 3];
                    while let Some(Transform::Trans {
                        axis,
                        joints,
                        offset,
                    }) = f.transforms.get(ti)
                    {
                        for (k, &c) in joints.iter().enumerate() {
                            u[k][*axis] += c;
                        }
                        p0[*axis] += offset;
                        ti += 1;
                    }
                    for (k, uk) in u.iter().enumerate() {
                        if uk.iter().all(|&x| x == 0.0) {
                            continue;
                        }
                        if lines[k].is_some() {
                            return Err(format!(
                                "joint {} moves more than one transform (a coupled or mimic joint)",
                                model.joints[k]
                            ));
                        }
                        if (norm(uk) - 1.0).abs() > 1e-12 {
                            return Err(format!(
                                "joint {} is a scaled translation ({} m per unit)",
                                model.joints[k],
                                norm(uk)
                            ));
                        }
                        lines[k] = Some(JointLine {
                            point: add(&t.p, &mv(&t.r, &p0)),
                            dir: mv(&t.r, uk),
                            prismatic: true,
                            at: (fi, start),
                        });
                    }
                    if u.iter().filter(|uk| uk.iter().any(|&x| x != 0.0)).count() > 1 {
                        return Err("two joints share one translation".into());
                    }
                    t = t.then(&Pose::trans(p0));
                }
            }
        }
    }
    let lines: Vec<JointLine> = lines
        .into_iter()
        .enumerate()
        .map(|(k, l)| l.ok_or_else(|| format!("joint {} moves nothing", model.joints[k])))
        .collect::<Result<_, _>>()?;
    // One chain: the link frames lie on one path, and the joints along it in q order.
    let deepest = model
        .links
        .iter()
        .map(|l| ancestors(model, l.frame))
        .max_by_key(|a| a.len())
        .ok_or("no links")?;
    for l in &model.links {
        if !deepest.contains(&l.frame) {
            return Err(format!(
                "link {} is on another branch: a tree has no single DH table",
                l.name
            ));
        }
    }
    let order = |at: (usize, usize)| -> Option<(usize, usize)> {
        deepest.iter().position(|&f| f == at.0).map(|i| (i, at.1))
    };
    let mut prev = None;
    for (k, l) in lines.iter().enumerate() {
        let o = order(l.at).ok_or_else(|| {
            format!(
                "joint {} does not move the deepest link: a tree has no single DH table",
                model.joints[k]
            )
        })?;
        if prev.is_some_and(|p| o <= p) {
            return Err(format!(
                "joint {} comes before joint {} along the chain: reorder the joints for a DH table",
                model.joints[k],
                model.joints[k - 1]
            ));
        }
        prev = Some(o);
    }

    // DH frames at q = 0.
    let mut frames: Vec<Pose> = Vec::with_capacity(n);
    let mut foot = lines[0].point; // where x_{i−1} meets line i
    for i in 0..n {
        let (z, p) = (lines[i].dir, lines[i].point);
        // Origin and x_i from the common normal to the next line.
        let (o, x) = if i + 1 < n {
            let (z2, p2) = (lines[i + 1].dir, lines[i + 1].point);
            let c = cross(&z, &z2);
            if norm(&c) < 1e-12 {
                // Parallel: the normal through the foot of x_{i−1} (d_i = 0).
                let o = add(&p, &scale(&z, dot(&sub(&foot, &p), &z)));
                let w = sub(&p2, &o);
                let perp = sub(&w, &scale(&z, dot(&w, &z)));
                let x = if norm(&perp) > 1e-12 {
                    unit(&perp)
                } else {
                    let xp: V3 = std::array::from_fn(|r| poses[lines[i].at.0].r[r][0]);
                    let v = sub(&xp, &scale(&z, dot(&xp, &z)));
                    if norm(&v) > 1e-12 {
                        unit(&v)
                    } else {
                        any_perpendicular(&z)
                    }
                };
                (o, x)
            } else {
                // Closest points of the two lines.
                let w0 = sub(&p, &p2);
                let (a, b, cc, d, e) = (
                    dot(&z, &z),
                    dot(&z, &z2),
                    dot(&z2, &z2),
                    dot(&z, &w0),
                    dot(&z2, &w0),
                );
                let den = a * cc - b * b;
                let s = (b * e - cc * d) / den;
                let t = (a * e - b * d) / den;
                let o = add(&p, &scale(&z, s));
                let q2 = add(&p2, &scale(&z2, t));
                let w = sub(&q2, &o);
                let x = if norm(&w) > 1e-12 { unit(&w) } else { unit(&c) };
                (o, x)
            }
        } else {
            // The last frame: the model's own frame's x where it is normal to the axis, else
            // x_{n−1}'s direction; the origin at the foot.
            let o = add(&p, &scale(&z, dot(&sub(&foot, &p), &z)));
            let own: V3 = std::array::from_fn(|r| poses[lines[i].at.0].r[r][0]);
            let xp: V3 = if dot(&own, &z).abs() < 1e-12 || i == 0 {
                own
            } else {
                std::array::from_fn(|r| frames[i - 1].r[r][0])
            };
            let v = sub(&xp, &scale(&z, dot(&xp, &z)));
            let x = if norm(&v) > 1e-12 {
                unit(&v)
            } else {
                any_perpendicular(&z)
            };
            (o, x)
        };
        // Of the two directions of the normal, the one nearer the model's own frame after
        // joint i (so that a URDF whose frames are already DH frames gives them back, a
        // negative a where the published table has one).
        let xref: V3 = std::array::from_fn(|r| poses[lines[i].at.0].r[r][0]);
        let x = if dot(&x, &xref) < -1e-12 {
            scale(&x, -1.0)
        } else {
            x
        };
        let y = cross(&z, &x);
        let r: M3 = std::array::from_fn(|row| [x[row], y[row], z[row]]);
        frames.push(Pose { r, p: o });
        // The foot of x_i on the next line.
        if i + 1 < n {
            let (z2, p2) = (lines[i + 1].dir, lines[i + 1].point);
            // o + s x meets line i+1: take the closest point of line i+1 to the x_i line.
            let w0 = sub(&o, &p2);
            let (a, b, cc, d, e) = (
                dot(&x, &x),
                dot(&x, &z2),
                dot(&z2, &z2),
                dot(&x, &w0),
                dot(&z2, &w0),
            );
            let den = a * cc - b * b;
            let t = if den.abs() < 1e-12 {
                dot(&sub(&o, &p2), &z2)
            } else {
                (a * e - b * d) / den
            };
            foot = add(&p2, &scale(&z2, t));
        }
    }
    // Rows: frame i−1 → frame i (frame 0 = frame 1 at q = 0).
    let base = frames[0];
    let mut rows = Vec::with_capacity(n);
    for i in 0..n {
        let prev = if i == 0 { base } else { frames[i - 1] };
        let rel = prev.inverse().then(&frames[i]);
        // rel = Rot_x(α) Trans_x(a) Rot_z(θ) Trans_z(d): z_i in frame i−1 is
        // (0, −sin α, cos α), the origin is (a, −d sin α, d cos α).
        let zc: V3 = std::array::from_fn(|r| rel.r[r][2]);
        let alpha = (-zc[1]).atan2(zc[2]);
        let a = rel.p[0];
        let d = -rel.p[1] * alpha.sin() + rel.p[2] * alpha.cos();
        let rz = mm(&tr(&rot(0, alpha)), &rel.r);
        let theta = rz[1][0].atan2(rz[0][0]);
        rows.push(Row {
            alpha,
            a,
            theta,
            d,
            prismatic: lines[i].prismatic,
        });
    }
    // The chain's kinematics, for the check and the link frames.
    let chain = |q: &[f64]| -> Vec<Pose> {
        let mut t = base;
        rows.iter()
            .enumerate()
            .map(|(i, row)| {
                let (theta, d) = if row.prismatic {
                    (row.theta, row.d + q[i])
                } else {
                    (row.theta + q[i], row.d)
                };
                t = t
                    .then(&Pose::rot(0, row.alpha))
                    .then(&Pose::trans([row.a, 0.0, 0.0]))
                    .then(&Pose::rot(2, theta))
                    .then(&Pose::trans([0.0, 0.0, d]));
                t
            })
            .collect()
    };
    // Each link frame from the DH frame of the last joint before it.
    let joint_before = |frame: usize| -> Option<usize> {
        let pos = deepest.iter().position(|&f| f == frame)?;
        lines
            .iter()
            .rposition(|l| order(l.at).is_some_and(|(fi, _)| fi <= pos))
    };
    let dh0 = chain(&zero);
    let mut link_frames = Vec::new();
    for l in &model.links {
        let k = joint_before(l.frame);
        let from = k.map(|k| dh0[k]).unwrap_or(Pose::IDENTITY);
        link_frames.push((k, from.inverse().then(&poses[l.frame])));
    }
    // The check: every link frame at random joint values.
    let mut rng = lockstep_rng::Xorshift(0x005e_edd4);
    for _ in 0..5 {
        let q: Vec<f64> = (0..n).map(|_| rng.uniform(-3.0, 3.0)).collect();
        let want = frame_poses(model, &q);
        let got = chain(&q);
        for (l, (k, rel)) in model.links.iter().zip(&link_frames) {
            let p = k.map(|k| got[k]).unwrap_or(Pose::IDENTITY).then(rel);
            let w = want[l.frame];
            let err = (0..3)
                .map(|i| (p.p[i] - w.p[i]).abs())
                .chain((0..9).map(|i| (p.r[i / 3][i % 3] - w.r[i / 3][i % 3]).abs()))
                .fold(0.0, f64::max);
            if err > 1e-9 {
                return Err(format!(
                    "the DH table found does not reproduce link {}'s frame (error {err:e}): please report this model",
                    l.name
                ));
            }
        }
    }

    let mut s = String::new();
    writeln!(
        s,
        "# Equivalent modified (Craig) DH table of model '{}', checked against its kinematics.",
        model.name
    )
    .ok();
    writeln!(s, "# Frame dh.0 is frame dh.1 at q = 0; the link frames (where the inertial values are given)").ok();
    writeln!(s, "# hang from the DH frames as [[frame]]s.").ok();
    let has_base = base.p.iter().any(|x| x.abs() >= 1e-14)
        || (0..3).any(|i| (0..3).any(|j| (base.r[i][j] - I3[i][j]).abs() >= 1e-14));
    if has_base {
        writeln!(
            s,
            "\n[[frame]]\nname = \"dh_base\"\ntransforms = {}",
            transforms(&base)
        )
        .ok();
    }
    writeln!(s, "\n[[chain]]\nname = \"dh\"\nconvention = \"modified\"").ok();
    if has_base {
        writeln!(s, "parent = \"dh_base\"").ok();
    }
    writeln!(s, "rows = [").ok();
    for (i, r) in rows.iter().enumerate() {
        let j = &model.joints[i];
        let (theta, d) = if r.prismatic {
            (angle(r.theta), with_joint(j, r.d, false))
        } else {
            (with_joint(j, r.theta, true), length(r.d))
        };
        writeln!(
            s,
            "  {{ alpha = {}, a = {}, theta = {theta}, d = {d} }},",
            angle(r.alpha),
            length(r.a)
        )
        .ok();
    }
    writeln!(s, "]").ok();
    for (l, (k, rel)) in model.links.iter().zip(&link_frames) {
        let parent = k.map(|k| format!("dh.{}", k + 1)).unwrap_or("world".into());
        writeln!(
            s,
            "\n[[frame]]\nname = \"{}_frame\"\nparent = \"{parent}\"\ntransforms = {}",
            l.name,
            transforms(rel)
        )
        .ok();
    }
    Ok(s)
}

/// `"q2 - pi/2"` style: a joint plus an offset.
fn with_joint(j: &str, offset: f64, is_angle: bool) -> String {
    if offset.abs() < 1e-14 {
        return format!("\"{j}\"");
    }
    let o = if is_angle {
        angle(offset.abs()).trim_matches('"').to_string()
    } else {
        clean(offset.abs())
    };
    let sign = if offset < 0.0 { '-' } else { '+' };
    format!("\"{j} {sign} {o}\"")
}

fn any_perpendicular(z: &V3) -> V3 {
    let e = if z[0].abs() < 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    unit(&sub(&e, &scale(z, dot(&e, z))))
}
