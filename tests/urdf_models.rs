//! Models read from URDF through the command line: `model show` prints what was read,
//! `model dh` the equivalent DH table (or why none exists), and a plant of a URDF model takes
//! the URDF's inertial values as its defaults.

mod common;
use common::{fails, lockstep, ok};

#[test]
fn model_show_prints_the_urdf_joints_frames_and_default_values() {
    let out = ok(&lockstep(&["model", "show", "tx40"]));
    for needle in [
        "frames and links read from the URDF tx40.urdf",
        "q[0] = q1 <- URDF joint 'joint_1' (revolute, axis [0, 0, 1], limits [-3.14, 3.14], base_link -> link_1)",
        "link_2 <- link_1: rot_x(-π/2) · rot_z(q2)",
        "link_6 <- link_5: rot_y(π) · rot_x(π/2) · rot_z(q6)",
        "mass m_link_1 (default 10.5)",
        "configuration",
        "arm5: free q1, q2, q3, q4, q5",
        "warning: link 'link_6': the inertia about the centroid is singular",
    ] {
        assert!(out.contains(needle), "'{needle}' not in:\n{out}");
    }
    let out = ok(&lockstep(&["model", "show", "parallelogram"]));
    assert!(
        out.contains("URDF joint 'j3' (revolute, mimic) moves by -1·q2 + 1.5707963267948966"),
        "{out}"
    );
    fails(&lockstep(&["model", "show", "nope"]), &["nope"]);
}

#[test]
fn model_dh_prints_a_checked_table_or_why_there_is_none() {
    let out = ok(&lockstep(&["model", "dh", "ur5"]));
    assert!(out.contains("convention = \"modified\""), "{out}");
    assert!(
        out.contains(r#"{ alpha = 0, a = 0.425, theta = "q3", d = 0 }"#),
        "{out}"
    );
    fails(
        &lockstep(&["model", "dh", "freedom6s"]),
        &["model 'freedom6s' has no DH table: joint q0 moves more than one transform"],
    );
}

#[test]
fn a_plant_of_a_urdf_model_takes_the_urdf_values_as_defaults() {
    // A plant file that names only the model: every link has the URDF's values, so the UR5
    // checks as consistent and its barycentric parameters are the URDF's.
    let d = tempfile::tempdir().unwrap();
    let plant = d.path().join("ur5.toml");
    std::fs::write(&plant, "model = \"ur5\"\n").unwrap();
    let out = ok(&lockstep(&["check", "--plant", plant.to_str().unwrap()]));
    assert!(out.contains("every link is physically consistent"), "{out}");
    let p = lockstep::plant::Plant::load(&plant).unwrap();
    assert_eq!(p.value("m_upper_arm_link").unwrap(), 8.393);
    let m = generated::model("ur5").unwrap();
    let b = p.barycentric(None).unwrap();
    let j = m
        .params
        .iter()
        .position(|n| *n == "MZ_upper_arm_link")
        .unwrap();
    assert!((b[j] - 8.393 * 0.28).abs() < 1e-12, "{}", b[j]);
    // A value in the plant wins over the default.
    std::fs::write(
        &plant,
        "model = \"ur5\"\n[parameters]\nm_upper_arm_link = 9.0\n",
    )
    .unwrap();
    let p = lockstep::plant::Plant::load(&plant).unwrap();
    let b = p.barycentric(None).unwrap();
    assert!((b[j] - 9.0 * 0.28).abs() < 1e-12, "{}", b[j]);
}

#[test]
fn plant_new_starts_from_the_model_and_identifies_to_a_consistent_plant() {
    // A starting plant for the TX40 from its URDF model: 60 inertial values and four
    // effects per joint; IDIM with --consistent writes a plant whose links are all bodies.
    let d = tempfile::tempdir().unwrap();
    let start = d.path().join("start.toml");
    let out = ok(&lockstep(&[
        "plant",
        "new",
        "--model",
        "tx40",
        "--effects",
        "armature,viscous,coulomb,offset",
        "--out",
        start.to_str().unwrap(),
    ]));
    assert!(
        out.contains("60 inertial symbol(s) at the model file's values, 0 link(s) in numbers in the model file, 24 effect(s)"),
        "{out}"
    );
    let p = lockstep::plant::Plant::load(&start).unwrap();
    assert_eq!(p.value("m_link_2").unwrap(), 3.6);
    assert_eq!(p.value("Fv_q4").unwrap(), 0.0);
    let fitted = d.path().join("fitted.toml");
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let out = ok(&lockstep(&[
        "identify",
        "idim",
        "--plant",
        start.to_str().unwrap(),
        "--data",
        root.join("data/staubli_tx40/tx40_joint_5kHz.csv")
            .to_str()
            .unwrap(),
        "--window",
        "0.1:5.5",
        "--cutoff",
        "20",
        "--decimate",
        "100",
        "--min-speed",
        "1%",
        "--consistent",
        "--out",
        fitted.to_str().unwrap(),
    ]));
    assert!(out.contains("physically consistent set"), "{out}");
    let check = ok(&lockstep(&["check", "--plant", fitted.to_str().unwrap()]));
    assert!(
        check.contains("every link is physically consistent"),
        "{check}"
    );
    // Bad input: an unknown kind, a pairwise kind, an unknown joint.
    fails(
        &lockstep(&[
            "plant",
            "new",
            "--model",
            "tx40",
            "--effects",
            "glue",
            "--out",
            "x.toml",
        ]),
        &["unknown effect 'glue'"],
    );
    fails(
        &lockstep(&[
            "plant",
            "new",
            "--model",
            "tx40",
            "--effects",
            "input_coupling",
            "--out",
            "x.toml",
        ]),
        &["acts between two joints"],
    );
    fails(
        &lockstep(&[
            "plant",
            "new",
            "--model",
            "tx40",
            "--joints",
            "q9",
            "--effects",
            "viscous",
            "--out",
            "x.toml",
        ]),
        &["unknown joint 'q9'"],
    );
    assert!(!std::path::Path::new("x.toml").exists());
}
