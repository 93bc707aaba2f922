//! Models that parse but cannot be generated are rejected at generation with the file, the
//! configuration and the reason. One test in this binary: the generator runs Symbolica,
//! which allows one thread at a time without a licence.

use codegen::model::Model;
use std::path::Path;

#[test]
fn singular_inertia_matrix_is_rejected_with_the_configuration() {
    // q0 and q1 rotate the only link about the same axis through the same point: the two
    // columns of D are equal for every parameter value.
    let text = r#"
[robot]
name = "twins"
joints = ["q0", "q1"]
gravity = [0, 0, -9.81]
[[chain]]
name = "arm"
convention = "standard"
rows = [
  { theta = "q0", d = 0, a = 0, alpha = 0 },
  { theta = "q1", d = 0, a = 0.2, alpha = 0 },
]
[[link]]
name = "l2"
frame = "arm.e"
mass = "m2"
com = ["x2", 0, 0]
inertia = [0, 0, 0, 0, 0, "I2"]
[[configuration]]
name = "one"
free = ["q1"]
"#;
    let m = Model::from_toml(Path::new("model/twins.toml"), text).unwrap();
    // One free joint is fine.
    let ok = codegen::generate::generate(&m, Some(&["one".to_string()]));
    assert!(ok.is_ok(), "{:?}", ok.err().map(|e| e.to_string()));
    let e = codegen::generate::generate(&m, None)
        .err()
        .expect("singular D_FF rejected")
        .to_string();
    assert!(e.contains("model/twins.toml"), "{e}");
    assert!(e.contains("configuration 'full'"), "{e}");
    assert!(e.contains("singular"), "{e}");
    assert!(e.contains("'q1'"), "{e}");
}
