//! The URDF reader: joint motions against Rodrigues' rotation formula, and bad input refused
//! with one line naming the element. (Reading only: no Symbolica call.)

use codegen::expr::Expr;
use codegen::model::{Model, Scalar, TransformSpec};
use std::collections::BTreeMap;
use std::path::Path;

type M4 = [[f64; 4]; 4];

fn mul(a: &M4, b: &M4) -> M4 {
    std::array::from_fn(|i| std::array::from_fn(|j| (0..4).map(|k| a[i][k] * b[k][j]).sum()))
}

fn value(s: &Scalar, q: &BTreeMap<String, f64>) -> f64 {
    match s {
        Scalar::Num(x) => *x,
        Scalar::Text(t) => Expr::parse(t).unwrap().eval(q).unwrap(),
    }
}

/// The homogeneous transform of a list of elementary transforms at joint values `q`.
fn compose(ts: &[TransformSpec], q: &BTreeMap<String, f64>) -> M4 {
    let mut t: M4 = std::array::from_fn(|i| std::array::from_fn(|j| f64::from(i == j)));
    for e in ts {
        let mut m: M4 = std::array::from_fn(|i| std::array::from_fn(|j| f64::from(i == j)));
        match e {
            TransformSpec::Trans(xyz) => {
                for k in 0..3 {
                    m[k][3] = value(&xyz[k], q);
                }
            }
            TransformSpec::RotX(a) | TransformSpec::RotY(a) | TransformSpec::RotZ(a) => {
                let (s, c) = value(a, q).sin_cos();
                let (i, j) = match e {
                    TransformSpec::RotX(_) => (1, 2),
                    TransformSpec::RotY(_) => (2, 0),
                    _ => (0, 1),
                };
                m[i][i] = c;
                m[j][j] = c;
                m[i][j] = -s;
                m[j][i] = s;
            }
            _ => unreachable!("the URDF reader emits trans and rot only"),
        }
        t = mul(&t, &m);
    }
    t
}

/// Rodrigues: rotation by `a` about the unit axis `u`.
fn rodrigues(u: [f64; 3], a: f64) -> [[f64; 3]; 3] {
    let (s, c) = a.sin_cos();
    let k = [[0.0, -u[2], u[1]], [u[2], 0.0, -u[0]], [-u[1], u[0], 0.0]];
    std::array::from_fn(|i| {
        std::array::from_fn(|j| {
            let kk: f64 = (0..3).map(|m| k[i][m] * k[m][j]).sum();
            f64::from(i == j) + s * k[i][j] + (1.0 - c) * kk
        })
    })
}

fn rpy(r: f64, p: f64, y: f64) -> [[f64; 3]; 3] {
    let rx = rodrigues([1.0, 0.0, 0.0], r);
    let ry = rodrigues([0.0, 1.0, 0.0], p);
    let rz = rodrigues([0.0, 0.0, 1.0], y);
    let m = |a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]| -> [[f64; 3]; 3] {
        std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| a[i][k] * b[k][j]).sum()))
    };
    m(&m(&rz, &ry), &rx)
}

const OBLIQUE: &str = r#"<robot name="oblique">
  <link name="base"/>
  <joint name="a" type="revolute">
    <origin xyz="0.1 -0.2 0.3" rpy="0.3 -0.7 1.1"/>
    <parent link="base"/><child link="l1"/>
    <axis xyz="1 2 -2"/>
  </joint>
  <link name="l1"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
  <joint name="b" type="prismatic">
    <origin xyz="0 0 0.2"/>
    <parent link="l1"/><child link="l2"/>
    <axis xyz="0 3 4"/>
  </joint>
  <link name="l2"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
  <joint name="c" type="revolute">
    <parent link="l2"/><child link="l3"/>
    <axis xyz="0 -1 0"/>
    <mimic joint="a" multiplier="2" offset="0.3"/>
  </joint>
  <link name="l3"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
</robot>"#;

#[test]
fn joint_motions_equal_rodrigues_rotations_about_the_urdf_axes() {
    let u = codegen::urdf::read(Path::new("oblique.urdf"), OBLIQUE, &[], None).unwrap();
    assert_eq!(u.joint_names, ["a", "b"]);
    let q: BTreeMap<String, f64> = [("a".to_string(), 0.83), ("b".to_string(), -0.31)]
        .into_iter()
        .collect();
    // Joint a: origin (xyz, rpy), then a rotation of q_a about (1, 2, -2)/3.
    let t = compose(&u.frames[0].transforms, &q);
    let r = {
        let o = rpy(0.3, -0.7, 1.1);
        let j = rodrigues([1.0 / 3.0, 2.0 / 3.0, -2.0 / 3.0], 0.83);
        let m: [[f64; 3]; 3] = std::array::from_fn(|i| {
            std::array::from_fn(|k| (0..3).map(|m| o[i][m] * j[m][k]).sum())
        });
        m
    };
    for i in 0..3 {
        for k in 0..3 {
            assert!(
                (t[i][k] - r[i][k]).abs() < 1e-14,
                "R[{i}][{k}]: {} vs {}",
                t[i][k],
                r[i][k]
            );
        }
    }
    for (k, x) in [0.1, -0.2, 0.3].iter().enumerate() {
        assert!((t[k][3] - x).abs() < 1e-15);
    }
    // Joint b: a translation of q_b along (0, 3, 4)/5 after the origin.
    let t = compose(&u.frames[1].transforms, &q);
    let p = [0.0, 0.6 * -0.31, 0.2 + 0.8 * -0.31];
    for k in 0..3 {
        assert!(
            (t[k][3] - p[k]).abs() < 1e-15,
            "p[{k}] {} vs {}",
            t[k][3],
            p[k]
        );
    }
    // Joint c: a mimic of a (2 q_a + 0.3) about -y.
    let t = compose(&u.frames[2].transforms, &q);
    let r = rodrigues([0.0, -1.0, 0.0], 2.0 * 0.83 + 0.3);
    for i in 0..3 {
        for k in 0..3 {
            assert!((t[i][k] - r[i][k]).abs() < 1e-14);
        }
    }
}

#[test]
fn fixed_links_merge_into_their_body_by_the_parallel_axis_theorem() {
    // Two point-like masses fixed 1 m apart along x of the body: centroid in the middle,
    // inertia about it m·d² on y and z for each.
    let text = r#"<robot name="m"><link name="b"/>
      <joint name="j" type="continuous"><parent link="b"/><child link="l"/><axis xyz="0 0 1"/></joint>
      <link name="l"><inertial><mass value="2"/><inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial></link>
      <joint name="f" type="fixed"><origin xyz="1 0 0" rpy="0 0 1.5707963267949"/><parent link="l"/><child link="t"/></joint>
      <link name="t"><inertial><origin xyz="0 0 0"/><mass value="2"/><inertia ixx="0.1" ixy="0" ixz="0" iyy="0.3" iyz="0" izz="0"/></inertial></link>
    </robot>"#;
    let u = codegen::urdf::read(Path::new("m.urdf"), text, &[], None).unwrap();
    assert_eq!(u.links.len(), 1);
    let d = |s: &str| u.defaults[s];
    assert_eq!(d("m_l"), 4.0);
    assert!((d("cx_l") - 0.5).abs() < 1e-15);
    // The tip's inertia turned π/2 about z: its ixx 0.1 becomes the body's yy, iyy 0.3 its xx.
    assert!((d("Ixx_l") - 0.3).abs() < 1e-15);
    assert!((d("Iyy_l") - (0.1 + 4.0 * 0.25)).abs() < 1e-15);
    assert!((d("Izz_l") - 4.0 * 0.25).abs() < 1e-15);
    assert!(u.warnings.is_empty(), "{:?}", u.warnings);
}

fn urdf_err(text: &str) -> String {
    codegen::urdf::read(Path::new("model/urdf/bad.urdf"), text, &[], None)
        .unwrap_err()
        .to_string()
}

const ARM: &str = r#"<robot name="arm">
  <link name="base"/>
  <joint name="j1" type="revolute">
    <parent link="base"/><child link="l1"/><axis xyz="0 0 1"/>
  </joint>
  <link name="l1"><inertial><mass value="1"/><inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial></link>
</robot>"#;

#[test]
fn the_reference_arm_reads() {
    let u = codegen::urdf::read(Path::new("arm.urdf"), ARM, &[], None).unwrap();
    assert_eq!(u.joint_vars, ["j1"]);
}

#[test]
fn malformed_xml_names_line_and_column() {
    let e = urdf_err("<robot name=\"x\">\n  <link name=\"a\">\n</robot>");
    assert!(e.starts_with("model/urdf/bad.urdf: line 3 column "), "{e}");
    assert!(e.contains("malformed XML"), "{e}");
}

#[test]
fn a_missing_parent_link_is_named() {
    let e = urdf_err(&ARM.replace("<parent link=\"base\"/>", "<parent link=\"bse\"/>"));
    assert!(
        e.contains("joint 'j1'")
            && e.contains("parent link 'bse' does not exist (links: base, l1)"),
        "{e}"
    );
    assert!(e.contains("line 3"), "{e}");
}

#[test]
fn a_kinematic_loop_is_refused() {
    let looped = ARM.replace(
        "</robot>",
        r#"<joint name="j2" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/></joint></robot>"#,
    );
    let e = urdf_err(&looped);
    assert!(
        e.contains("joint 'j2'") && e.contains("already the child of joint 'j1': a kinematic loop"),
        "{e}"
    );
    // A cycle with no root at all.
    let cycle = r#"<robot name="c"><link name="a"/><link name="b"/>
      <joint name="x" type="fixed"><parent link="a"/><child link="b"/></joint>
      <joint name="y" type="fixed"><parent link="b"/><child link="a"/></joint></robot>"#;
    let e = urdf_err(cycle);
    assert!(e.contains("kinematic loop"), "{e}");
}

#[test]
fn floating_and_planar_joints_are_refused() {
    for kind in ["floating", "planar"] {
        let e = urdf_err(&ARM.replace("type=\"revolute\"", &format!("type=\"{kind}\"")));
        assert!(
            e.contains(&format!("joint 'j1': type '{kind}' is not supported")),
            "{e}"
        );
    }
}

#[test]
fn a_zero_axis_is_refused() {
    let e = urdf_err(&ARM.replace("<axis xyz=\"0 0 1\"/>", "<axis xyz=\"0 0 0\"/>"));
    assert!(
        e.contains("joint 'j1'") && e.contains("the axis must not be zero"),
        "{e}"
    );
}

#[test]
fn xacro_markup_is_refused_with_the_way_out() {
    let e = urdf_err(&ARM.replace(
        "<link name=\"base\"/>",
        "<xacro:property name=\"l\" value=\"1\"/><link name=\"base\"/>",
    ));
    assert!(e.contains("xacro markup is not supported"), "{e}");
    assert!(e.contains("xacro robot.urdf.xacro > robot.urdf"), "{e}");
}

#[test]
fn a_revolute_mimic_needs_an_integer_multiplier() {
    let text = ARM.replace(
        "</robot>",
        r#"<joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/><axis xyz="0 0 1"/><mimic joint="j1" multiplier="0.5"/></joint>
        <link name="l2"><inertial><mass value="1"/><inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial></link></robot>"#,
    );
    let e = urdf_err(&text);
    assert!(
        e.contains("joint 'j2'") && e.contains("integer multiplier"),
        "{e}"
    );
    let e = urdf_err(
        &text
            .replace("multiplier=\"0.5\"", "multiplier=\"1\"")
            .replace("joint=\"j1\"", "joint=\"j9\""),
    );
    assert!(
        e.contains("<mimic joint=\"j9\">: no joint of that name"),
        "{e}"
    );
}

#[test]
fn inconsistent_inertials_are_warnings_not_errors() {
    let text = ARM
        .replace("<mass value=\"1\"/>", "<mass value=\"-1\"/>")
        .replace("ixx=\"0.1\"", "ixx=\"0.5\"");
    let u = codegen::urdf::read(Path::new("arm.urdf"), &text, &[], None).unwrap();
    assert_eq!(u.warnings.len(), 2, "{:?}", u.warnings);
    assert!(u.warnings[0].contains("link 'l1': negative mass -1 kg"));
    assert!(u.warnings[1].contains("triangle inequality"));
    let text = ARM.replace("ixy=\"0\"", "ixy=\"0.2\"");
    let u = codegen::urdf::read(Path::new("arm.urdf"), &text, &[], None).unwrap();
    assert!(
        u.warnings[0].contains("not positive semidefinite"),
        "{:?}",
        u.warnings
    );
}

#[test]
fn a_model_file_with_urdf_gets_its_frames_links_and_defaults() {
    let dir = std::env::temp_dir().join(format!("lockstep-urdf-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("arm.urdf"), ARM).unwrap();
    let toml =
        "[robot]\nname = \"arm\"\nurdf = \"arm.urdf\"\njoints = [\"q1\"]\n[defaults]\nm_l1 = 2.5\n";
    let m = Model::from_toml(&dir.join("arm.toml"), toml).unwrap();
    assert_eq!(m.joints, ["q1"]);
    assert_eq!(m.gravity, [0.0, 0.0, -9.81]);
    assert_eq!(m.defaults["m_l1"], 2.5, "the model file's default wins");
    assert_eq!(m.defaults["Izz_l1"], 0.1);
    // A joint count that does not match, a [[link]] beside the URDF, a wrong known link.
    let e = Model::from_toml(
        &dir.join("arm.toml"),
        &toml.replace("[\"q1\"]", "[\"q1\", \"q2\"]"),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains(
            "[robot] field 'joints': 2 names given; the URDF has 1 independent moving joints (j1)"
        ),
        "{e}"
    );
    let e = Model::from_toml(
        &dir.join("arm.toml"),
        &format!("{toml}[[link]]\nname = \"x\"\nframe = \"world\"\nmass = 1\n"),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("takes its frames and links from it"), "{e}");
    let e = Model::from_toml(
        &dir.join("arm.toml"),
        &toml.replace(
            "joints = [\"q1\"]",
            "joints = [\"q1\"]\nknown_links = [\"l7\"]",
        ),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("'l7' is not a moving link of the URDF (moving links: l1)"),
        "{e}"
    );
    let e = Model::from_toml(
        &dir.join("arm.toml"),
        &toml.replace("arm.urdf", "nope.urdf"),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("[robot] field 'urdf': cannot read"), "{e}");
    let e = Model::from_toml(&dir.join("arm.toml"), &format!("{toml}m_l9 = 1\n"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("[defaults] 'm_l9': not an inertial symbol"),
        "{e}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

fn shipped(name: &str) -> Model {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../model");
    Model::load(&dir.join(format!("{name}.toml"))).unwrap()
}

#[test]
fn the_panda_urdf_gives_back_frankas_published_dh_table() {
    // Franka Robotics' published modified DH table (model/panda.toml), row by row.
    let t = codegen::dh::equivalent_dh(&shipped("panda_urdf")).unwrap();
    let rows = [
        r#"{ alpha = 0, a = 0, theta = "q1", d = 0 }"#,
        r#"{ alpha = "-pi/2", a = 0, theta = "q2", d = 0 }"#,
        r#"{ alpha = "pi/2", a = 0, theta = "q3", d = 0.316 }"#,
        r#"{ alpha = "pi/2", a = 0.0825, theta = "q4", d = 0 }"#,
        r#"{ alpha = "-pi/2", a = -0.0825, theta = "q5", d = 0.384 }"#,
        r#"{ alpha = "pi/2", a = 0, theta = "q6", d = 0 }"#,
        r#"{ alpha = "pi/2", a = 0.088, theta = "q7", d = 0 }"#,
    ];
    for r in rows {
        assert!(t.contains(r), "{r} not in\n{t}");
    }
    // The base is the URDF's 0.333 m lift; every link frame is its DH frame.
    assert!(
        t.contains("transforms = [{ trans = [0, 0, 0.333] }]"),
        "{t}"
    );
    assert_eq!(t.matches("transforms = []").count(), 7, "{t}");
}

#[test]
fn the_printed_dh_table_is_a_model_file_that_loads() {
    // The TX40's table with its links hung on the printed frames is a valid model file.
    let m = shipped("tx40");
    let t = codegen::dh::equivalent_dh(&m).unwrap();
    let mut toml = String::from(
        "[robot]\nname = \"tx40_dh\"\njoints = [\"q1\", \"q2\", \"q3\", \"q4\", \"q5\", \"q6\"]\ngravity = [0, 0, -9.81]\n",
    );
    toml.push_str(&t);
    for l in &m.links {
        toml.push_str(&format!(
            "[[link]]\nname = \"{0}\"\nframe = \"{0}_frame\"\nmass = \"m_{0}\"\n",
            l.name
        ));
    }
    let dh = Model::from_toml(Path::new("tx40_dh.toml"), &toml).unwrap();
    assert_eq!(dh.links.len(), 6);
    // The TX40's modified DH geometry as published for it (FIGAROH's "mdh" model):
    // a3 = 0.225 m, d3 = 0.035 m, d4 = 0.225 m, alternating ±π/2 twists.
    assert!(
        t.contains(r#"{ alpha = 0, a = 0.225, theta = "q3", d = 0.035 }"#),
        "{t}"
    );
    assert!(
        t.contains(r#"{ alpha = "pi/2", a = 0, theta = "q4", d = 0.225 }"#),
        "{t}"
    );
}

#[test]
fn coupled_joints_and_trees_have_no_dh_table() {
    let e = codegen::dh::equivalent_dh(&shipped("parallelogram")).unwrap_err();
    assert!(e.contains("joint q2 moves more than one transform"), "{e}");
    let tree = r#"<robot name="t"><link name="b"/>
      <joint name="j1" type="revolute"><parent link="b"/><child link="l1"/><axis xyz="0 0 1"/></joint>
      <link name="l1"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
      <joint name="j2" type="revolute"><parent link="b"/><child link="l2"/><origin xyz="1 0 0"/><axis xyz="0 0 1"/></joint>
      <link name="l2"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
    </robot>"#;
    let dir = std::env::temp_dir().join(format!("lockstep-tree-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("t.urdf"), tree).unwrap();
    let m = Model::load(&dir.join("t.urdf")).unwrap();
    let e = codegen::dh::equivalent_dh(&m).unwrap_err();
    assert!(e.contains("another branch"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}
