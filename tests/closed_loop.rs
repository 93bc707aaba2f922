//! Closed-loop output error (issue 59): a device measured under its own controller is
//! simulated in closed loop on the measured reference, and the force and velocity are
//! compared. The reference figures are the EMPS benchmark's own (Janot, Gautier, Brunot
//! 2019; data/emps/README.md): its published model simulated in closed loop by its
//! Simulink model.

mod common;

use lockstep::control::controller::{compare_closed_loop, ClosedLoopRecord, Controller};
use lockstep::measurement::Table;
use lockstep::plant::Plant;
use std::path::{Path, PathBuf};

fn manifest(p: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(p)
}

/// The relative errors (%) of force and velocity of the published model in closed loop on
/// `file`.
fn published_errors(file: &str) -> (f64, f64) {
    let plant = Plant::load(&manifest("model/plants/emps_published.toml")).unwrap();
    let c = Controller::load(&manifest("model/control/emps_controller.toml"), &plant).unwrap();
    let table = Table::read(&manifest(file)).unwrap();
    let record = ClosedLoopRecord::from_table(&table, &plant, &c).unwrap();
    let (cmp, run) = compare_closed_loop(&plant, &c, &record).unwrap();
    let [force, velocity] = &cmp[0];
    // The run follows the reference: its position error is a small part of the motion.
    let e: f64 = record.q[0]
        .iter()
        .zip(&run.q[0])
        .map(|(a, b)| (a - b).powi(2))
        .sum::<f64>()
        .sqrt();
    let norm: f64 = record.q[0].iter().map(|a| a * a).sum::<f64>().sqrt();
    eprintln!(
        "{file}: force {:.3} %, velocity {:.3} %, position {:.4} %",
        force.relative_error,
        velocity.relative_error,
        100.0 * e / norm
    );
    assert!(100.0 * e / norm < 0.1);
    (force.relative_error, velocity.relative_error)
}

/// The benchmark's published symmetric model (M 95.1089, Fv 203.5034, Fc 20.3935, offset
/// −3.1648) under the benchmark's controller (cascade kp = 160.18 1/s, kv = 243.45 V/(m/s),
/// velocity from the half-sum of two positions, one sample of delay, ±10 V, gtau =
/// 35.15065188 N/V) reproduces the published closed-loop errors on the training record:
/// force 5.848 %, velocity 0.229 % (each to 1 %). On the pulses record (its pulses a
/// disturbance inside the command) the force error is within 10 % of the published 8.941 %;
/// the velocity error is 0.401 % against the published 0.479 % (16 % below it; not
/// explained: delays of 0 and 2, the pulse one sample later and the record's own sample
/// period all move it away, docs/src/record/closed-loop.md), asserted between 0.3 % and the
/// published figure.
#[test]
fn the_published_emps_model_gives_the_benchmarks_closed_loop_errors() {
    let (force, velocity) = published_errors("data/emps/emps_train.csv");
    assert!((force / 5.848 - 1.0).abs() < 0.01, "force {force}");
    assert!((velocity / 0.229 - 1.0).abs() < 0.01, "velocity {velocity}");
    let (force, velocity) = published_errors("data/emps/emps_test_pulses.csv");
    assert!((force / 8.941 - 1.0).abs() < 0.10, "force {force}");
    assert!(velocity > 0.3 && velocity <= 0.479, "velocity {velocity}");
}

/// The pulses matter: without the record's disturbance column the same simulation misses
/// the pulses, and its force error is several times the published one (the check that the
/// disturbance is read can fail).
#[test]
fn the_pulses_record_without_its_disturbance_is_far_off() {
    let plant = Plant::load(&manifest("model/plants/emps_published.toml")).unwrap();
    let c = Controller::load(&manifest("model/control/emps_controller.toml"), &plant).unwrap();
    let table = Table::read(&manifest("data/emps/emps_test_pulses.csv")).unwrap();
    let mut record = ClosedLoopRecord::from_table(&table, &plant, &c).unwrap();
    assert!(record.disturbance[0].contains(&5.0));
    record.disturbance[0].iter_mut().for_each(|d| *d = 0.0);
    let (cmp, _) = compare_closed_loop(&plant, &c, &record).unwrap();
    eprintln!(
        "without the pulses: force {:.3} %",
        cmp[0][0].relative_error
    );
    assert!(cmp[0][0].relative_error > 3.0 * 8.941);
}

/// `lockstep compare --controller` on the command line: the closed-loop table with both
/// records' force and velocity errors, a residual CSV and a figure per signal; each mistake
/// in a controller file or a record is one clear line naming the file and the field, exit
/// ≠ 0, nothing written.
#[test]
fn compare_in_closed_loop_on_the_command_line_and_its_mistakes() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let plant = manifest("model/plants/emps_published.toml");
    let data = manifest("data/emps");
    let run = |controller: &Path, data: &Path, out: &Path| {
        common::lockstep(&[
            "compare",
            "--plant",
            &s(&plant),
            "--data",
            &s(data),
            "--controller",
            &s(controller),
            "--out",
            &s(out),
        ])
    };
    let out = d.join("cl");
    let text = common::ok(&run(
        &manifest("model/control/emps_controller.toml"),
        &data,
        &out,
    ));
    eprintln!("{text}");
    assert!(text.contains("closed-loop space"), "{text}");
    let line = |record: &str, signal: &str| -> f64 {
        text.lines()
            .find(|l| l.starts_with(record) && l.contains(signal))
            .and_then(|l| l.split_whitespace().nth(4))
            .unwrap_or_else(|| panic!("no {record} {signal} in\n{text}"))
            .parse()
            .unwrap()
    };
    assert_eq!(line("emps_train", "force"), 5.848);
    assert_eq!(line("emps_train", "velocity"), 0.229);
    for f in [
        "emps_train_q0_force.csv",
        "emps_train_q0_velocity.svg",
        "emps_test_pulses_q0_force.png",
    ] {
        assert!(out.join(f).exists(), "{f}");
    }
    // Mistakes in the controller file.
    let good = std::fs::read_to_string(manifest("model/control/emps_controller.toml")).unwrap();
    let bad = |edit: &dyn Fn(&str) -> String, needles: &[&str]| {
        let f = d.join("bad_controller.toml");
        std::fs::write(&f, edit(&good)).unwrap();
        let o = d.join("not_written");
        common::fails(&run(&f, &data, &o), needles);
        assert!(!o.exists(), "nothing written for {needles:?}");
    };
    bad(
        &|t| t.replace("saturation = [-10.0, 10.0]", "saturation = [10.0, -10.0]"),
        &[
            "bad_controller.toml",
            "saturation = [10, -10]",
            "lower limit",
        ],
    );
    bad(
        &|t| t.replace("step = 1e-4", "step = 3e-4"),
        &["bad_controller.toml", "does not divide the period"],
    );
    bad(
        &|t| t.replace("law = \"cascade\"", "law = \"cascaded\""),
        &["[joints.q0] law = 'cascaded'", "'cascade', 'pd' or 'pid'"],
    );
    bad(
        &|t| t.replace("kv = 243.45", "kd = 243.45"),
        &["[joints.q0]", "law 'cascade' needs 'kv'"],
    );
    bad(
        &|t| t.replace("reference = \"qref0\"", "reference = \"qref9\""),
        &["qref9", "emps_test_pulses.csv", "reference of joint q0"],
    );
    // A record sampled at another rate than the controller.
    let other = d.join("data");
    std::fs::create_dir_all(&other).unwrap();
    let csv = std::fs::read_to_string(manifest("data/emps/emps_train.csv")).unwrap();
    let decimated: String = csv
        .lines()
        .enumerate()
        .filter(|(i, _)| *i == 0 || (i - 1) % 2 == 0)
        .map(|(_, l)| format!("{l}\n"))
        .collect();
    std::fs::write(other.join("half.csv"), decimated).unwrap();
    std::fs::copy(
        manifest("data/emps/emps_train.toml"),
        other.join("half.toml"),
    )
    .unwrap();
    let o = d.join("not_written");
    common::fails(
        &run(&manifest("model/control/emps_controller.toml"), &other, &o),
        &[
            "half.csv",
            "sampled every 2.000000e-3 s",
            "runs every 0.001 s",
        ],
    );
    assert!(!o.exists());
}

/// The plant of `file` with its IDIM-LS values on the training record (DIDIM's start),
/// and the training record for the closed loop.
fn idim_start(file: &str) -> (Plant, Controller, ClosedLoopRecord) {
    use lockstep::identify::idim::{least_squares, observation, IdimOptions};
    let mut plant = Plant::load(&manifest(file)).unwrap();
    let table = Table::read(&manifest("data/emps/emps_train.csv")).unwrap();
    let m = lockstep::measurement::Measurement::from_table(&table, 1).unwrap();
    least_squares(&observation(&plant, "full", &[m], &IdimOptions::default()).unwrap())
        .unwrap()
        .apply(&mut plant)
        .unwrap();
    let c = Controller::load(&manifest("model/control/emps_controller.toml"), &plant).unwrap();
    let record = ClosedLoopRecord::from_table(&table, &plant, &c).unwrap();
    (plant, c, record)
}

/// DIDIM and the diagnosis in closed-loop space on EMPS, the benchmark's own story: from
/// the mass + viscous model (IDIM-LS start) DIDIM converges (≤ 10 iterations) at ≈ 18 %
/// force error; the closed-loop diagnosis names Coulomb friction; with it, DIDIM again and
/// the diagnosis names the offset; with both, DIDIM converges to force and velocity errors
/// within 10 % of the published closed-loop figures on the training record (5.848 %,
/// 0.229 %), and the pulses record simulated with those values is within 10 % of its
/// published force error (8.941 %).
#[test]
fn didim_and_the_closed_loop_diagnosis_find_coulomb_then_the_offset_emps() {
    use lockstep::diagnose::table;
    use lockstep::effects::{Effect, EffectKind};
    use lockstep::identify::didim::{
        closed_loop_errors, diagnose_closed_loop, didim, DidimOptions,
    };
    let (mut plant, c, record) = idim_start("model/plants/emps_viscous.toml");
    let records = [record];
    let options = DidimOptions::default();
    let run = |p: &Plant, tag: &str| {
        let r = didim(p, &c, &records, &options, &|i, it| {
            eprintln!(
                "{tag} {i}: force {:.4} %, velocity {:.4} %, {:?}",
                it.force_error, it.velocity_error, it.values
            )
        })
        .unwrap();
        assert!(r.converged, "{tag}: not converged");
        assert!(
            r.iterations.len() <= 11,
            "{tag}: {} iterations",
            r.iterations.len() - 1
        );
        r
    };
    let viscous = run(&plant, "M + Fv");
    assert!(viscous.iterations.last().unwrap().force_error > 15.0);
    plant = viscous.plant;
    for (expected, symbol) in [
        (EffectKind::Coulomb, "Fc_0"),
        (EffectKind::Offset, "offset_0"),
    ] {
        let (d, _) = diagnose_closed_loop(&plant, &c, &records, &options.idim, &[]).unwrap();
        let text = table(&d.findings, 4);
        eprintln!("{text}");
        assert_eq!(d.findings[0].kind, Some(expected), "{text}");
        assert!(d.findings[0].significant, "{text}");
        plant.add_effect(Effect::on(expected, 0)).unwrap();
        plant
            .parameters
            .insert(symbol.into(), d.findings[0].estimate[0].1);
        plant = run(&plant, symbol).plant;
    }
    let last = closed_loop_errors(&plant, &c, &records).unwrap();
    eprintln!("with both: force {:.4} %, velocity {:.4} %", last.0, last.1);
    assert!((last.0 / 5.848 - 1.0).abs() < 0.10, "force {}", last.0);
    assert!((last.1 / 0.229 - 1.0).abs() < 0.10, "velocity {}", last.1);
    let table = Table::read(&manifest("data/emps/emps_test_pulses.csv")).unwrap();
    let pulses = ClosedLoopRecord::from_table(&table, &plant, &c).unwrap();
    let (force, velocity) = closed_loop_errors(&plant, &c, &[pulses]).unwrap();
    eprintln!("pulses: force {force:.4} %, velocity {velocity:.4} %");
    assert!((force / 8.941 - 1.0).abs() < 0.10, "pulses force {force}");
}

/// `identify didim` and `diagnose --controller` on the command line: DIDIM from the mass +
/// viscous IDIM-LS values writes its plant, the closed-loop diagnosis of it names Coulomb
/// friction, and `--apply 1` adds it and refits by DIDIM (Fc within 1 % of the benchmark's
/// 20.39 N); a user's candidate is ranked beside the catalogue; a plant whose effect the inverse model cannot fit is refused with the reason
/// and nothing written.
#[test]
fn didim_and_the_closed_loop_diagnosis_on_the_command_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let data = s(&manifest("data/emps/emps_train.csv"));
    let controller = s(&manifest("model/control/emps_controller.toml"));
    let (p1, p2, p3) = (d.join("p1.toml"), d.join("p2.toml"), d.join("p3.toml"));
    common::ok(&common::lockstep(&[
        "identify",
        "idim",
        "--plant",
        &s(&manifest("model/plants/emps_viscous.toml")),
        "--data",
        &data,
        "--out",
        &s(&p1),
    ]));
    let text = common::ok(&common::lockstep(&[
        "identify",
        "didim",
        "--plant",
        &s(&p1),
        "--data",
        &data,
        "--controller",
        &controller,
        "--out",
        &s(&p2),
    ]));
    assert!(text.contains("DIDIM") && text.contains("wrote"), "{text}");
    let text = common::ok(&common::lockstep(&[
        "diagnose",
        "--plant",
        &s(&p2),
        "--data",
        &data,
        "--controller",
        &controller,
        "--apply",
        "1",
        "--out",
        &s(&p3),
    ]));
    eprintln!("{text}");
    assert!(
        text.contains("most likely missing: coulomb on q0"),
        "{text}"
    );
    let fitted = Plant::load(&p3).unwrap();
    let fc = fitted.parameters["Fc_0"];
    assert!((fc / 20.3935 - 1.0).abs() < 0.01, "Fc {fc}");
    // The user's candidates are ranked beside the catalogue in closed-loop space too.
    let candidates = d.join("candidates.toml");
    std::fs::write(
        &candidates,
        r#"
[[candidate]]
name = "drag"
joints = ["q0"]
torque = "c*qd0*abs(qd0)"
parameters = { c = { start = 0.0, bounds = [-1e5, 1e5] } }
"#,
    )
    .unwrap();
    let text = common::ok(&common::lockstep(&[
        "diagnose",
        "--plant",
        &s(&p3),
        "--data",
        &data,
        "--controller",
        &controller,
        "--candidates",
        &s(&candidates),
        "--top",
        "20",
    ]));
    assert!(text.contains("candidate drag"), "{text}");
    // The inverse model cannot fit a spring's rest angle: refused, nothing written.
    let mut spring = Plant::load(&p2).unwrap();
    spring
        .add_effect(lockstep::effects::Effect::on(
            lockstep::effects::EffectKind::Spring,
            0,
        ))
        .unwrap();
    spring.parameters.insert("Ks_0".into(), 1.0);
    spring.parameters.insert("qeq_0".into(), 0.1);
    let p4 = d.join("p4.toml");
    spring.save(&p4).unwrap();
    let p5 = d.join("p5.toml");
    common::fails(
        &common::lockstep(&[
            "identify",
            "didim",
            "--plant",
            &s(&p4),
            "--data",
            &data,
            "--controller",
            &controller,
            "--out",
            &s(&p5),
        ]),
        &["'spring' on joint 'q0'", "not linear in its parameters"],
    );
    assert!(!p5.exists());
}
