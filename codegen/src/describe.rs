//! What the generator read from a model file, as text (`lockstep model show`): the joints
//! (with the URDF joint each comes from), the frames as products of elementary transforms,
//! the links with their inertial values or symbols and the symbols' default values, the
//! configurations and sequences, and the consistency warnings. A user reads it to check a
//! URDF's translation before trusting the kernels.

use crate::expr::Expr;
use crate::model::{Model, Transform};
use std::fmt::Write;

/// `Σ c_k q_k + offset` with the model's joint names.
fn linear(model: &Model, coef: impl Fn(usize) -> f64, offset: f64, angle: bool) -> String {
    let mut s = String::new();
    for (k, name) in model.joints.iter().enumerate() {
        let c = coef(k);
        if c == 0.0 {
            continue;
        }
        let sign = if c < 0.0 {
            "-"
        } else if s.is_empty() {
            ""
        } else {
            "+"
        };
        let mag = c.abs();
        let term = if mag == 1.0 {
            name.clone()
        } else {
            format!("{mag}·{name}")
        };
        if s.is_empty() {
            write!(s, "{sign}{term}").ok();
        } else {
            write!(s, " {sign} {term}").ok();
        }
    }
    if offset != 0.0 || s.is_empty() {
        let o = if angle {
            let k = offset / std::f64::consts::FRAC_PI_2;
            if (k - k.round()).abs() < 1e-12 && k != 0.0 {
                match k.round() as i64 {
                    1 => "π/2".to_string(),
                    -1 => "-π/2".to_string(),
                    2 | -2 => "π".to_string(),
                    n => format!("{n}π/2"),
                }
            } else {
                format!("{offset}")
            }
        } else {
            format!("{offset}")
        };
        if s.is_empty() {
            s = o;
        } else if let Some(rest) = o.strip_prefix('-') {
            write!(s, " - {rest}").ok();
        } else {
            write!(s, " + {o}").ok();
        }
    }
    s
}

/// A frame's transforms, consecutive translations merged into one vector.
fn transforms(model: &Model, ts: &[Transform]) -> String {
    let mut parts = Vec::new();
    let mut pending: Option<[String; 3]> = None;
    let flush = |pending: &mut Option<[String; 3]>, parts: &mut Vec<String>| {
        if let Some(p) = pending.take() {
            parts.push(format!("trans({}, {}, {})", p[0], p[1], p[2]));
        }
    };
    for t in ts {
        match t {
            Transform::Trans {
                axis,
                joints,
                offset,
            } => {
                let p = pending.get_or_insert_with(|| std::array::from_fn(|_| "0".to_string()));
                let term = linear(model, |k| joints[k], *offset, false);
                p[*axis] = if p[*axis] == "0" {
                    term
                } else {
                    format!("{} + {term}", p[*axis])
                };
            }
            Transform::Rot {
                axis,
                joints,
                offset,
            } => {
                if joints.iter().all(|&n| n == 0) && *offset == 0.0 {
                    continue;
                }
                flush(&mut pending, &mut parts);
                let a = ["x", "y", "z"][*axis];
                parts.push(format!(
                    "rot_{a}({})",
                    linear(model, |k| joints[k] as f64, *offset, true)
                ));
            }
        }
    }
    flush(&mut pending, &mut parts);
    if parts.is_empty() {
        "identity".into()
    } else {
        parts.join(" · ")
    }
}

fn value(model: &Model, e: &Expr) -> String {
    match e {
        Expr::Sym(s) if !model.constants.contains_key(s) => match model.defaults.get(s) {
            Some(v) => format!("{s} (default {v})"),
            None => s.clone(),
        },
        other => other.to_string(),
    }
}

/// The description of `model`: joints, frames, links, defaults, configurations, warnings.
pub fn describe(model: &Model) -> String {
    let mut s = String::new();
    let file = model
        .file
        .file_name()
        .map(|f| f.to_string_lossy().into_owned())
        .unwrap_or_default();
    writeln!(s, "model {} (file {file})", model.name).ok();
    if !model.spec.robot.description.is_empty() {
        writeln!(s, "  {}", model.spec.robot.description).ok();
    }
    if let Some((urdf, _)) = &model.urdf {
        let f = urdf
            .file_name()
            .map(|f| f.to_string_lossy().into_owned())
            .unwrap_or_default();
        writeln!(s, "  frames and links read from the URDF {f}").ok();
    }
    writeln!(
        s,
        "gravity in frame 0: [{}, {}, {}] m/s²",
        model.gravity[0], model.gravity[1], model.gravity[2]
    )
    .ok();
    writeln!(s, "joints (the order of q):").ok();
    for (k, j) in model.joints.iter().enumerate() {
        let from = model.urdf.as_ref().and_then(|(_, js)| {
            js.iter().find(|u| u.variable.as_ref() == Some(j)).map(|u| {
                let lim = u
                    .limits
                    .map(|(lo, hi)| format!(", limits [{lo}, {hi}]"))
                    .unwrap_or_default();
                format!(
                    " <- URDF joint '{}' ({}, axis [{}, {}, {}]{lim}, {} -> {})",
                    u.name, u.kind, u.axis[0], u.axis[1], u.axis[2], u.parent, u.child
                )
            })
        });
        writeln!(s, "  q[{k}] = {j}{}", from.unwrap_or_default()).ok();
    }
    if let Some((_, js)) = &model.urdf {
        for u in js.iter().filter(|u| u.variable.is_none()) {
            writeln!(
                s,
                "  URDF joint '{}' ({}, mimic) moves by {}",
                u.name, u.kind, u.motion
            )
            .ok();
        }
    }
    writeln!(
        s,
        "frames (parent, then the transforms from it, left to right):"
    )
    .ok();
    for f in model.frames.iter().skip(1) {
        let parent = f
            .parent
            .map(|p| model.frames[p].name.as_str())
            .unwrap_or("");
        writeln!(
            s,
            "  {} <- {parent}: {}",
            f.name,
            transforms(model, &f.transforms)
        )
        .ok();
    }
    writeln!(
        s,
        "links (mass kg; centroid m and inertia about it kg·m², in the link frame):"
    )
    .ok();
    for l in &model.links {
        let frame = &model.frames[l.frame].name;
        writeln!(s, "  {} (frame {frame})", l.name).ok();
        writeln!(s, "    mass {}", value(model, &l.mass)).ok();
        let c: Vec<String> = l.com.iter().map(|e| value(model, e)).collect();
        writeln!(s, "    centroid [{}]", c.join(", ")).ok();
        let i: Vec<String> = l.inertia.iter().map(|e| value(model, e)).collect();
        writeln!(
            s,
            "    inertia [I11, I12, I13, I22, I23, I33] = [{}]",
            i.join(", ")
        )
        .ok();
    }
    writeln!(s, "configurations:").ok();
    for c in &model.configurations {
        let free: Vec<&str> = c.free.iter().map(|&k| model.joints[k].as_str()).collect();
        writeln!(s, "  {}: free {}", c.name, free.join(", ")).ok();
    }
    for (name, steps) in &model.sequences {
        let names: Vec<&str> = steps
            .iter()
            .map(|&i| model.configurations[i].name.as_str())
            .collect();
        writeln!(s, "sequence {name}: {}", names.join(" -> ")).ok();
    }
    for w in &model.warnings {
        writeln!(s, "warning: {w}").ok();
    }
    s
}
