//! Names of per-joint columns and effect parameters, in files and on the command line.
//!
//! Both carry the model's joint name: joint `q3`'s torque column is `tau_q3`, its position
//! `q_q3`, its velocity `qd_q3`, its reference `qref_q3`; its Coulomb level is `Fc_q3`; the
//! tendon gain from joint `q6` to joint `q5` is `G_q6_to_q5`. Earlier versions numbered
//! joints from 0 whatever the model called them (`tau2`, `q2`, `Fc_2`, `G_5to4`: on a model
//! whose joints are `q1..q6`, all of them joint `q3` or, for the gain, `q6` to `q5`). That
//! form is still read, as the joint at that index, and never written.

use crate::effects::EffectKind;

/// Column of `signal` (`q`, `qd`, `tau`, `qref`, …) for joint `joint`: `tau_q3`.
pub fn column(signal: &str, joint: &str) -> String {
    format!("{signal}_{joint}")
}

/// The numbered column of earlier versions: `tau2` for the joint at index 2.
pub fn numbered_column(signal: &str, index: usize) -> String {
    format!("{signal}{index}")
}

/// The joint a column name belongs to, for `signal`: `tau_q3` (by name) or `tau2` (numbered,
/// from 0); `None` for a column of another signal or an unknown joint.
pub fn column_joint(joints: &[&str], signal: &str, name: &str) -> Option<usize> {
    joint_after(joints, name.strip_prefix(signal)?).filter(|&k| k < joints.len())
}

/// The joint that follows a signal's prefix: `_J` by name, or a numbered index (unchecked).
fn joint_after(joints: &[&str], rest: &str) -> Option<usize> {
    match rest.strip_prefix('_') {
        Some(joint) => joints.iter().position(|j| *j == joint),
        None => index(rest),
    }
}

/// Parameter `symbol` of joint `joint`: `Fc_q3`.
pub fn parameter(symbol: &str, joint: &str) -> String {
    format!("{symbol}_{joint}")
}

/// A parameter of two joints together (a motor that turns with both): `Fm_q5_q6`.
pub fn pair_parameter(symbol: &str, a: &str, b: &str) -> String {
    format!("{symbol}_{a}_{b}")
}

/// The input-coupling gain from joint `from` to joint `to` (thesis eq. 2.14): `G_q6_to_q5`.
pub fn coupling_gain(from: &str, to: &str) -> String {
    format!("G_{from}_to_{to}")
}

/// The joint (index into `joints`) whose parameter `symbol` `name` is: `Fc_q3`, or the
/// numbered `Fc_2`; `None` when `name` is not `symbol` of a joint of the model.
pub fn parameter_joint(joints: &[&str], symbol: &str, name: &str) -> Option<usize> {
    let rest = name.strip_prefix(symbol)?.strip_prefix('_')?;
    joints
        .iter()
        .position(|j| *j == rest)
        .or_else(|| index(rest).filter(|&k| k < joints.len()))
}

/// A per-joint parameter name split into its symbol and joint (index into `joints`):
/// `Fv_pos_q3` → (`Fv_pos`, 2) on a model whose joints are `q1..` (a joint name may hold
/// `_`); `None` when no joint of the model ends the name.
pub fn split_parameter<'a>(joints: &[&str], name: &'a str) -> Option<(&'a str, usize)> {
    // The longest joint name that ends the name (`Fc_a_1` is joint `a_1`, not `1`).
    joints
        .iter()
        .enumerate()
        .filter_map(|(k, j)| {
            let symbol = name.strip_suffix(j)?.strip_suffix('_')?;
            (!symbol.is_empty()).then_some((symbol, k, j.len()))
        })
        .max_by_key(|&(_, _, len)| len)
        .map(|(symbol, k, _)| (symbol, k))
}

/// The current name of an effect parameter given in the numbered form of earlier versions
/// (`Fc_2` → `Fc_q3` on a model whose joints are `q1..`, `G_5to4` → `G_q6_to_q5`); `None`
/// for any other name (a current name, an inertial parameter, an expression's parameter).
/// Only the built-in effects' symbols ([`EffectKind::symbols`]) are renamed.
pub fn renamed_parameter(joints: &[&str], name: &str) -> Option<String> {
    if let Some(rest) = name.strip_prefix("G_") {
        let (from, to) = rest.split_once("to")?;
        let (from, to) = (index(from)?, index(to)?);
        return Some(coupling_gain(joints.get(from)?, joints.get(to)?));
    }
    let (symbol, k) = name.rsplit_once('_')?;
    let k = index(k)?;
    let known = EffectKind::ALL
        .iter()
        .any(|kind| kind.symbols().contains(&symbol));
    // A joint that is itself named by digits keeps its name.
    if !known || joints.contains(&&name[symbol.len() + 1..]) {
        return None;
    }
    Some(parameter(symbol, joints.get(k)?))
}

/// The state-variable prefixes of an expression ([`crate::expression`]): position,
/// velocity, acceleration, commanded torque, LuGre bristle deflection.
pub const STATE_SIGNALS: [&str; 5] = ["qdd", "qd", "q", "tau", "z"];

/// The joint (index into `joints`) and signal of an expression's state variable: `q_q3`,
/// `qd_q3`, … by name, or the numbered `q2`, `qd2` of earlier versions; `None` for any
/// other name. The numbered form is returned with an unchecked index (the parser names
/// the range).
pub fn state_variable(joints: &[&str], name: &str) -> Option<(&'static str, usize)> {
    STATE_SIGNALS.into_iter().find_map(|signal| {
        let k = joint_after(joints, name.strip_prefix(signal)?)?;
        Some((signal, k))
    })
}

/// `text`, an expression, with its numbered state variables (`q2`, `qd2`, `tau2`) written
/// with the joints' names (`q_q3`, `qd_q3`, `tau_q3` on a model whose joints are `q1..`);
/// numbers, functions and parameters unchanged.
pub fn expression_text(text: &str, joints: &[&str]) -> String {
    let chars: Vec<char> = text.chars().collect();
    let mut out = String::with_capacity(text.len() + 8);
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        if c.is_alphabetic() || c == '_' {
            let start = i;
            while i < chars.len() && (chars[i].is_alphanumeric() || chars[i] == '_') {
                i += 1;
            }
            let word: String = chars[start..i].iter().collect();
            let renamed = STATE_SIGNALS.iter().find_map(|s| {
                let k = index(word.strip_prefix(s)?)?;
                Some(column(s, joints.get(k)?))
            });
            out.push_str(renamed.as_deref().unwrap_or(&word));
        } else if c.is_ascii_digit() || c == '.' {
            // A number, its exponent included (`1e-3` is not the name `e`).
            while i < chars.len() && (chars[i].is_ascii_digit() || chars[i] == '.') {
                out.push(chars[i]);
                i += 1;
            }
            if i < chars.len() && (chars[i] == 'e' || chars[i] == 'E') {
                out.push(chars[i]);
                i += 1;
                if i < chars.len() && (chars[i] == '+' || chars[i] == '-') {
                    out.push(chars[i]);
                    i += 1;
                }
                while i < chars.len() && chars[i].is_ascii_digit() {
                    out.push(chars[i]);
                    i += 1;
                }
            }
        } else {
            out.push(c);
            i += 1;
        }
    }
    out
}

/// A joint index written in decimal without leading zeros (`0`, `12`; not `01`, `+1`).
fn index(s: &str) -> Option<usize> {
    let digits = !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    if !digits || (s.len() > 1 && s.starts_with('0')) {
        return None;
    }
    s.parse().ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    const FROM_1: [&str; 6] = ["q1", "q2", "q3", "q4", "q5", "q6"];
    const FROM_0: [&str; 6] = ["q0", "q1", "q2", "q3", "q4", "q5"];

    #[test]
    fn numbered_names_are_read_as_the_joint_at_that_index() {
        // Joints named from 1: the numbered form is one below the name.
        assert_eq!(renamed_parameter(&FROM_1, "Fc_2").as_deref(), Some("Fc_q3"));
        assert_eq!(renamed_parameter(&FROM_0, "Fc_2").as_deref(), Some("Fc_q2"));
        assert_eq!(
            renamed_parameter(&FROM_1, "Fv_pos_0").as_deref(),
            Some("Fv_pos_q1")
        );
        assert_eq!(
            renamed_parameter(&FROM_1, "G_5to4").as_deref(),
            Some("G_q6_to_q5")
        );
        // Current names, inertial parameters, unknown symbols, joints out of range: kept.
        for kept in [
            "Fc_q3", "I7_33", "m1", "K3_2", "Fc_6", "Fc_02", "G_6to4", "Gain_1",
        ] {
            assert_eq!(renamed_parameter(&FROM_1, kept), None, "{kept}");
        }
        // A joint named by digits keeps its name.
        assert_eq!(renamed_parameter(&["1", "0"], "Fc_0"), None);
    }

    #[test]
    fn expressions_are_written_with_joint_names() {
        assert_eq!(
            expression_text("K3_2*(q2 - 1e-3)^3 + Fm_45*tanh((qd4 + qd5)/0.01)", &FROM_1),
            "K3_2*(q_q3 - 1e-3)^3 + Fm_45*tanh((qd_q5 + qd_q6)/0.01)"
        );
        assert_eq!(
            expression_text("abs(tau0)*sign(qdd1) + z5 + q6 + 2.5E+2*t", &FROM_1),
            "abs(tau_q1)*sign(qdd_q2) + z_q6 + q6 + 2.5E+2*t"
        );
        assert_eq!(state_variable(&FROM_1, "qdd_q2"), Some(("qdd", 1)));
        assert_eq!(state_variable(&FROM_1, "qd4"), Some(("qd", 4)));
        assert_eq!(state_variable(&FROM_1, "q_q9"), None);
        assert_eq!(state_variable(&FROM_1, "qeq"), None);
    }

    #[test]
    fn columns_and_parameters_name_their_joint_in_either_form() {
        assert_eq!(column("tau", "q3"), "tau_q3");
        assert_eq!(column_joint(&FROM_1, "tau", "tau_q3"), Some(2));
        assert_eq!(column_joint(&FROM_1, "tau", "tau2"), Some(2));
        assert_eq!(column_joint(&FROM_1, "q", "q_q1"), Some(0));
        assert_eq!(column_joint(&FROM_1, "q", "qd_q1"), None);
        assert_eq!(column_joint(&FROM_1, "tau", "tau6"), None);
        assert_eq!(column_joint(&FROM_1, "tau", "tau_q7"), None);
        assert_eq!(parameter_joint(&FROM_1, "qeq", "qeq_q4"), Some(3));
        assert_eq!(parameter_joint(&FROM_1, "qeq", "qeq_3"), Some(3));
        assert_eq!(parameter_joint(&FROM_1, "qeq", "qeqq_3"), None);
        assert_eq!(parameter_joint(&FROM_1, "Fs", "Fs_q9"), None);
        assert_eq!(split_parameter(&FROM_1, "Fv_pos_q3"), Some(("Fv_pos", 2)));
        assert_eq!(split_parameter(&["1", "a_1"], "Fc_a_1"), Some(("Fc", 1)));
        assert_eq!(split_parameter(&FROM_1, "Fc_2"), None);
    }
}
