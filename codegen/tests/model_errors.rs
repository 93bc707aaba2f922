//! Bad model files are rejected with the file, the item and what was expected.
//! (Validation only: no Symbolica call, so these tests may run in parallel.)

use codegen::model::Model;
use std::path::Path;

const GOOD: &str = r#"
[robot]
name = "two"
joints = ["q0", "q1"]
gravity = [0, 0, -9.81]
[constants]
L1 = 0.3
[[chain]]
name = "arm"
convention = "standard"
rows = [
  { theta = "q0", d = 0, a = "L1", alpha = 0 },
  { theta = "q1 - pi/2", d = 0, a = 0.2, alpha = 0 },
]
[[link]]
name = "l1"
frame = "arm.1"
mass = "m1"
com = ["x1", 0, 0]
[[link]]
name = "l2"
frame = "arm.e"
mass = "m2"
[[configuration]]
name = "c1"
free = ["q1"]
"#;

fn err(text: &str) -> String {
    Model::from_toml(Path::new("model/two.toml"), text)
        .unwrap_err()
        .to_string()
}

#[test]
fn a_good_model_loads() {
    let m = Model::from_toml(Path::new("model/two.toml"), GOOD).unwrap();
    assert_eq!(m.joints, vec!["q0", "q1"]);
    assert_eq!(m.frames.len(), 3);
    assert_eq!(
        m.inertial_symbols
            .iter()
            .map(|s| s.0.as_str())
            .collect::<Vec<_>>(),
        vec!["m1", "x1", "m2"]
    );
    // c1 plus the automatic `full`.
    assert_eq!(m.configurations.len(), 2);
    assert_eq!(m.gravity, [0.0, 0.0, -9.81]);
}

#[test]
fn unknown_field_is_named_with_its_line() {
    let e = err(&GOOD.replace(
        "convention = \"standard\"",
        "convention = \"standard\"\ncolour = 1",
    ));
    assert!(
        e.contains("model/two.toml") && e.contains("colour") && e.contains("line 11"),
        "{e}"
    );
}

#[test]
fn unknown_symbol_names_the_field_and_the_expected_names() {
    let e = err(&GOOD.replace("a = \"L1\"", "a = \"L9\""));
    assert!(
        e.contains("chain 'arm' row 1 field 'a'")
            && e.contains("unknown symbol 'L9'")
            && e.contains("L1"),
        "{e}"
    );
}

#[test]
fn malformed_expression_names_position() {
    let e = err(&GOOD.replace("\"q1 - pi/2\"", "\"q1 - * pi\""));
    assert!(
        e.contains("row 2 field 'theta'")
            && e.contains("malformed expression")
            && e.contains("character 6"),
        "{e}"
    );
}

#[test]
fn nonlinear_angle_is_rejected() {
    let e = err(&GOOD.replace("\"q1 - pi/2\"", "\"q1*q0\""));
    assert!(
        e.contains("field 'theta'") && e.contains("two joint variables"),
        "{e}"
    );
}

#[test]
fn link_on_missing_frame_is_rejected() {
    let e = err(&GOOD.replace("frame = \"arm.e\"", "frame = \"arm.7\""));
    assert!(
        e.contains("link 'l2' field 'frame'") && e.contains("'arm.7' does not exist"),
        "{e}"
    );
}

#[test]
fn configuration_freeing_unknown_joint_is_rejected() {
    let e = err(&GOOD.replace("free = [\"q1\"]", "free = [\"q5\"]"));
    assert!(
        e.contains("configuration 'c1' field 'free'") && e.contains("unknown joint 'q5'"),
        "{e}"
    );
}

#[test]
fn joint_in_no_chain_is_rejected() {
    let e = err(&GOOD.replace(
        "joints = [\"q0\", \"q1\"]",
        "joints = [\"q0\", \"q1\", \"q2\"]",
    ));
    assert!(e.contains("joint 'q2' appears in no chain"), "{e}");
}

#[test]
fn joint_in_inertial_field_and_shared_symbols_are_rejected() {
    let e = err(&GOOD.replace("mass = \"m2\"", "mass = \"q0\""));
    assert!(
        e.contains("link 'l2' field 'mass'") && e.contains("joint variable 'q0'"),
        "{e}"
    );
    let e = err(&GOOD.replace("mass = \"m2\"", "mass = \"m1\""));
    assert!(
        e.contains("already an inertial parameter of link 'l1'"),
        "{e}"
    );
}

#[test]
fn toml_syntax_error_names_the_line() {
    let e = err(&GOOD.replace("[[link]]\nname = \"l2\"", "[[link]\nname = \"l2\""));
    assert!(e.contains("model/two.toml") && e.contains("line"), "{e}");
}

#[test]
fn the_bundled_models_load() {
    for f in codegen::model_files(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../model")).unwrap()
    {
        codegen::load(&f).unwrap();
    }
}

#[test]
fn nonlinear_translation_is_rejected() {
    let e = err(&GOOD.replace(r#"a = "L1""#, r#"a = "L1 * sin(q0)""#));
    assert!(
        e.contains("row 1 field 'a'") || e.contains("field 'a'"),
        "{e}"
    );
    assert!(
        e.contains("a joint variable in a translation may appear only linearly"),
        "{e}"
    );
}
