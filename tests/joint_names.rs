//! Columns, effect parameters and expression symbols carry the model's joint names
//! (`tau_q3`, `Fc_q3`, `qd_q3`), and the numbered form of earlier versions (joints from 0:
//! `tau2`, `Fc_2`, `qd2`) is still read as the joint at that index. The Puma 560's joints are
//! `q1..q6`, so the two forms differ by one: `Fc_2` is joint `q3`'s.

mod common;

use common::{fails, lockstep, ok};
use lockstep::expression::Expression;
use lockstep::measurement::Measurement;
use lockstep::plant::Plant;
use std::path::Path;

const PUMA: [&str; 6] = ["q1", "q2", "q3", "q4", "q5", "q6"];

/// A Puma 560 plant written with the numbered names of earlier versions.
const NUMBERED: &str = r#"model = "puma560"
[[effect]]
kind = "viscous"
joints = ["q1", "q3"]
[[effect]]
kind = "spring"
joints = ["q3"]
[[effect]]
kind = "input_coupling"
from = "q6"
to = "q5"
[[expression]]
name = "drag"
joints = ["q5"]
torque = "c*qd4*abs(qd4)"
parameters = ["c"]
[parameters]
Fv_0 = 0.1
Fv_2 = 0.3
Ks_2 = 2.0
qeq_2 = 0.5
G_5to4 = -0.2
c = 0.01
[bounds]
Fv_2 = [0.0, 1.0]
[standard_errors]
Fv_2 = 0.01
Ks_2 = 0.02
[correlations.Fv_2]
Ks_2 = 0.5
"#;

fn plant(text: &str) -> anyhow::Result<Plant> {
    Plant::from_file(toml::from_str(text)?, None)
}

#[test]
fn numbered_names_are_read_as_the_joint_at_that_index_and_written_by_name_puma560() {
    let p = plant(NUMBERED).unwrap();
    let values: Vec<(&str, f64)> = p
        .parameters
        .iter()
        .filter(|(n, _)| !p.model.inertial_symbols.contains(&n.as_str()))
        .map(|(n, &v)| (n.as_str(), v))
        .collect();
    assert_eq!(
        values,
        [
            ("Fv_q1", 0.1),
            ("Fv_q3", 0.3),
            ("G_q6_to_q5", -0.2),
            ("Ks_q3", 2.0),
            ("c", 0.01),
            ("qeq_q3", 0.5),
        ]
    );
    assert_eq!(p.bounds["Fv_q3"], (0.0, 1.0));
    assert_eq!(p.standard_errors["Ks_q3"], 0.02);
    assert_eq!(p.correlation("Fv_q3", "Ks_q3"), 0.5);
    // A numbered name still finds its value; an unknown one is an error naming it.
    assert_eq!(p.value("Fv_2").unwrap(), 0.3);
    assert_eq!(p.value("G_5to4").unwrap(), -0.2);
    let e = p.value("Fv_1").unwrap_err().to_string();
    assert!(e.contains("'Fv_1' has no value"), "{e}");
    // Written by name only.
    let text = p.to_toml().unwrap();
    assert!(
        text.contains("Fv_q3 = 0.3") && text.contains("G_q6_to_q5 = -0.2"),
        "{text}"
    );
    for numbered in ["Fv_2", "Ks_2", "qeq_2", "G_5to4"] {
        assert!(!text.contains(numbered), "{numbered} in {text}");
    }
    // The expression's numbered qd4 is joint q5's velocity, as qd_q5 is.
    let c = vec!["c".to_string()];
    let numbered = Expression::parse("c*qd4*abs(qd4)", &PUMA, &c).unwrap();
    let named = Expression::parse("c*qd_q5*abs(qd_q5)", &PUMA, &c).unwrap();
    assert_eq!(numbered.root.to_string(), named.root.to_string());
    assert_eq!(
        p.expressions[0].expression.root.to_string(),
        named.root.to_string()
    );
}

#[test]
fn a_value_under_both_names_and_a_numbered_name_of_nothing_are_refused() {
    let both = NUMBERED.replace("Fv_0 = 0.1", "Fv_0 = 0.1\nFv_q1 = 0.2");
    let e = plant(&both).unwrap_err().to_string();
    assert!(
        e.contains("[parameters]: 'Fv_0' and 'Fv_q1' name the same parameter ('Fv_q1')"),
        "{e}"
    );
    // Joint q2 (index 1) has no viscous friction: the numbered name is refused as written.
    let nothing = NUMBERED.replace("Fv_0 = 0.1", "Fv_0 = 0.1\nFv_1 = 0.2");
    let e = plant(&nothing).unwrap_err().to_string();
    assert!(e.contains("[parameters] 'Fv_1' belongs to nothing"), "{e}");
}

fn write_csv(path: &Path, header: &[String], rows: usize) {
    let mut s = header.join(",") + "\n";
    for k in 0..rows {
        let row: Vec<String> = (0..header.len())
            .map(|c| {
                if c == 0 {
                    format!("{}", k as f64 * 0.01)
                } else {
                    format!("{}", c as f64 + 1e-3 * k as f64)
                }
            })
            .collect();
        s += &(row.join(",") + "\n");
    }
    std::fs::write(path, s).unwrap();
}

#[test]
fn columns_are_read_by_name_or_by_number_and_refused_under_both() {
    let d = tempfile::tempdir().unwrap();
    let named: Vec<String> = std::iter::once("t".to_string())
        .chain(PUMA.iter().map(|j| format!("tau_{j}")))
        .chain(PUMA.iter().map(|j| format!("q_{j}")))
        .collect();
    let numbered: Vec<String> = std::iter::once("t".to_string())
        .chain((0..6).map(|k| format!("tau{k}")))
        .chain((0..6).map(|k| format!("q{k}")))
        .collect();
    let (a, b) = (d.path().join("named.csv"), d.path().join("numbered.csv"));
    write_csv(&a, &named, 20);
    write_csv(&b, &numbered, 20);
    let (ma, mb) = (
        Measurement::read(&a, &PUMA).unwrap(),
        Measurement::read(&b, &PUMA).unwrap(),
    );
    assert_eq!(ma.tau, mb.tau);
    assert_eq!(ma.q, mb.q);
    // Joint q3's torque is the fourth column in both (t first).
    assert_eq!(ma.tau[2][0], 3.0);
    // One joint's torque under both names: refused, both named.
    let mut both = named.clone();
    both.push("tau2".into());
    let c = d.path().join("both.csv");
    write_csv(&c, &both, 20);
    let e = Measurement::read(&c, &PUMA).unwrap_err().to_string();
    assert!(
        e.contains("columns 'tau_q3' and 'tau2' both give tau of joint 'q3'"),
        "{e}"
    );
    // A missing column is named in the current form, the numbered one offered.
    let e = Measurement::read(&a, &["q1", "q2", "q3", "q4", "q5", "q6", "q7"])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("missing column 'tau_q7' (or 'tau6', numbered from 0"),
        "{e}"
    );
}

#[test]
fn simulate_writes_joint_named_columns_and_the_commands_take_numbered_names_puma560() {
    let d = tempfile::tempdir().unwrap();
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let p = d.path().join("p.toml");
    std::fs::write(
        &p,
        "model = \"puma560\"\n[[effect]]\nkind = \"viscous\"\njoints = [\"q1\", \"q2\", \"q3\", \"q4\", \"q5\", \"q6\"]\n[parameters]\nFv_0 = 1.0\nFv_1 = 1.0\nFv_2 = 1.0\nFv_3 = 0.1\nFv_4 = 0.1\nFv_5 = 0.1\n",
    )
    .unwrap();
    // A numbered torque file of earlier versions.
    let mut csv = String::from("t,tau0,tau1,tau2,tau3,tau4,tau5\n");
    for k in 0..=300 {
        let t = k as f64 * 1e-3;
        let u: Vec<String> = (0..6)
            .map(|j| format!("{}", 0.5 * ((j + 1) as f64 * t).sin()))
            .collect();
        csv += &format!("{t},{}\n", u.join(","));
    }
    let tau = d.path().join("tau.csv");
    std::fs::write(&tau, csv).unwrap();
    let run = d.path().join("run.csv");
    ok(&lockstep(&[
        "simulate",
        "--plant",
        &s(&p),
        "--input",
        &s(&tau),
        "--config",
        "full",
        "--allow-inconsistent",
        "-o",
        &s(&run),
    ]));
    let header = std::fs::read_to_string(&run).unwrap();
    let header = header.lines().next().unwrap();
    assert!(
        header.starts_with("t,tau_q1,q_q1,qd_q1,tau_q2,q_q2,qd_q2,tau_q3,"),
        "{header}"
    );
    // The input came through at the right joint: q3's torque is 0.5 sin 3t.
    let m = Measurement::read(&run, &PUMA).unwrap();
    let k = 200;
    assert!(
        (m.tau[2][k] - 0.5 * (3.0 * m.t[k]).sin()).abs() < 1e-12,
        "{}",
        m.tau[2][k]
    );
    // `effect add --set` and `--bound` take the numbered name; the file holds the name.
    let add_coulomb_q3 = |more: &[&str], out: &Path| {
        let plant = s(&p);
        let out = s(out);
        let mut args = vec![
            "effect", "add", "coulomb", "--joint", "q3", "--plant", &plant, "--out", &out,
        ];
        args.extend_from_slice(more);
        lockstep(&args)
    };
    let p2 = d.path().join("p2.toml");
    let out = ok(&add_coulomb_q3(
        &["--set", "Fc_2=0.5", "--bound", "Fc_2=0:1"],
        &p2,
    ));
    assert!(out.contains("Fc_q3 = 0.5"), "{out}");
    let text = std::fs::read_to_string(&p2).unwrap();
    assert!(
        text.contains("Fc_q3 = 0.5") && !text.contains("Fc_2"),
        "{text}"
    );
    // A numbered name of another joint: refused as written, nothing written.
    let p3 = d.path().join("p3.toml");
    fails(
        &add_coulomb_q3(&["--set", "Fc_1=0.5"], &p3),
        &["--set Fc_1: the plant has no parameter 'Fc_1' (the new effect's are Fc_q3)"],
    );
    assert!(!p3.exists());
}
