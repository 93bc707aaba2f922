//! Output-space diagnosis on data with a hidden effect (issue 6): `lockstep excite` and
//! `lockstep simulate` make position data from a truth plant; the starting plant is the
//! truth without one effect. Diagnose must rank the hidden effect first; adding it and
//! refitting its parameters must cut the position error by at least half. With nothing
//! missing, diagnose must say so.

use lockstep::diagnose::{diagnose_output, Finding, OutputDiagnosis, OutputOptions};
use lockstep::effects::EffectKind;
use lockstep::identify::output_error::Record;
use lockstep::identify::refit::{refit, RefitOptions};
use lockstep::identify::sequence::read_record;
use lockstep::plant::Plant;
use std::path::Path;

mod common;
use common::{fails, lockstep, ok};

/// The Appendix D coupled-method plant with I4_33 made positive.
fn base() -> Plant {
    common::appendix_d_coupled()
}

/// Simulate `truth` on 8 s of an excitation of `config` (table, test) with noise
/// 2e-4 rad and quantisation 1e-4 rad, and read the file back as a record.
fn data(dir: &Path, truth: &Plant, config: &str, table: &str, test: Option<&str>) -> Record {
    let tau = dir.join(format!("tau_{config}.csv"));
    let truth_file = dir.join(format!("truth_{config}.toml"));
    truth.save(&truth_file).unwrap();
    let mut args = vec![
        "excite",
        "--model",
        "freedom6s",
        "--table",
        table,
        "--config",
        config,
        "--duration",
        "8",
        "-o",
        tau.to_str().unwrap(),
    ];
    if let Some(t) = test {
        args.extend(["--test", t]);
    }
    ok(&lockstep(&args));
    let out = dir.join(format!("{config}_run.csv"));
    ok(&lockstep(&[
        "simulate",
        "--plant",
        truth_file.to_str().unwrap(),
        "--input",
        tau.to_str().unwrap(),
        "--noise",
        "2e-4",
        "--quantisation",
        "1e-4",
        "--seed",
        "5",
        "-o",
        out.to_str().unwrap(),
    ]));
    let m = truth.model;
    let conf = m.configurations.iter().find(|c| c.name == config).unwrap();
    read_record(&out, m, conf, 0.01).unwrap()
}

fn show(d: &OutputDiagnosis) -> String {
    lockstep::diagnose::table(&d.findings, 6)
}

/// Diagnose, check the first finding, apply it, refit its parameters: (fall of the RMS
/// position error, the finding).
fn diagnose_and_fix(
    start: &Plant,
    config: &str,
    record: &Record,
    expect: (EffectKind, &str, Option<&str>),
) -> (Plant, f64, Finding) {
    let d = diagnose_output(
        start,
        config,
        std::slice::from_ref(record),
        &OutputOptions::default(),
    )
    .unwrap();
    let text = show(&d);
    eprintln!("{config}:\n{text}simulations {}", d.simulations);
    let f = d.findings[0].clone();
    assert!(f.significant, "{text}");
    assert_eq!(f.kind, Some(expect.0), "{text}");
    assert_eq!(f.joint, expect.1, "{text}");
    assert_eq!(f.from.as_deref(), expect.2, "{text}");
    let applied = f.apply(start).unwrap();
    let r = refit(
        start,
        &applied,
        config,
        std::slice::from_ref(record),
        &f.parameter_names(),
        &RefitOptions::default(),
    )
    .unwrap();
    eprintln!(
        "RMS before {:?}, after {:?}, values {:?}",
        r.before, r.after, r.fit.fitted
    );
    let before: f64 = r.before.iter().map(|x| x.1 * x.1).sum::<f64>().sqrt();
    let after: f64 = r.after.iter().map(|x| x.1 * x.1).sum::<f64>().sqrt();
    (r.plant, after / before, f)
}

fn tmp() -> tempfile::TempDir {
    tempfile::tempdir().unwrap()
}

#[test]
fn hidden_cable_drag_spring_on_joint_3_c3() {
    let dir = tmp();
    let truth = base();
    let mut start = truth.clone();
    start
        .effects
        .retain(|e| !(e.kind == EffectKind::Spring && e.joint == 3));
    let rec = data(dir.path(), &truth, "c3", "4.3", Some("J3"));
    let (_, ratio, _) = diagnose_and_fix(&start, "c3", &rec, (EffectKind::Spring, "q3", None));
    assert!(ratio < 0.5, "error ratio {ratio}");
}

#[test]
fn hidden_tendon_coupling_5_to_4_k1() {
    let dir = tmp();
    let truth = base();
    let mut start = truth.clone();
    start
        .effects
        .retain(|e| !(e.kind == EffectKind::InputCoupling && e.from == Some(5)));
    let rec = data(dir.path(), &truth, "k1", "4.7", None);
    let (_, ratio, f) = diagnose_and_fix(
        &start,
        "k1",
        &rec,
        (EffectKind::InputCoupling, "q4", Some("q5")),
    );
    assert!(ratio < 0.5, "error ratio {ratio}");
    let g = f.values.iter().find(|v| v.0 == "G_q5_to_q4").unwrap().1;
    assert!((g + 0.20362).abs() < 0.02, "G_q5_to_q4 = {g}");
}

#[test]
fn hidden_strong_stribeck_on_joint_5_c2() {
    let dir = tmp();
    let mut truth = base();
    truth.parameters.insert("Fs_q5".into(), 0.1);
    truth.parameters.insert("vs_q5".into(), 0.1);
    let mut start = truth.clone();
    start.parameters.insert("Fs_q5".into(), 0.02);
    let rec = data(dir.path(), &truth, "c2", "4.3", Some("J5"));
    let (_, ratio, _) = diagnose_and_fix(&start, "c2", &rec, (EffectKind::Stribeck, "q5", None));
    assert!(ratio < 0.5, "error ratio {ratio}");
}

#[test]
fn hidden_plant_gain_error_on_joint_2_c4() {
    let dir = tmp();
    let mut truth = base();
    let kp = truth.parameters["Kp_q2"];
    truth.parameters.insert("Kp_q2".into(), 1.3 * kp);
    let start = base();
    let rec = data(dir.path(), &truth, "c4", "4.3", Some("J2"));
    let (_, ratio, f) = diagnose_and_fix(&start, "c4", &rec, (EffectKind::Gain, "q2", None));
    assert!(ratio < 0.5, "error ratio {ratio}");
    let fitted = f.values.iter().find(|v| v.0 == "Kp_q2").unwrap().1;
    assert!(
        (fitted / kp - 1.3).abs() < 0.03,
        "Kp_q2 = {fitted}, truth {}",
        1.3 * kp
    );
}

/// The friction bias missing on q0 and q1 (c7), on the simulator's own file: two diagnoses
/// in turn. `independent_data.rs`'s `hidden_friction_bias_on_independent_data_c7` runs the
/// same loop on data from another integrator.
#[test]
fn hidden_friction_bias_on_joints_0_and_1_c7() {
    let dir = tmp();
    let truth = base();
    let mut start = truth.clone();
    start
        .effects
        .retain(|e| !(e.kind == EffectKind::FrictionBias && e.joint <= 1));
    let rec = data(dir.path(), &truth, "c7", "4.4", Some("J01-1"));
    let (next, ratio1, f1) =
        diagnose_and_fix(&start, "c7", &rec, (EffectKind::FrictionBias, "q0", None));
    let (_, ratio2, _) =
        diagnose_and_fix(&next, "c7", &rec, (EffectKind::FrictionBias, "q1", None));
    eprintln!("{f1:?}");
    assert!(ratio1 * ratio2 < 0.5, "error ratios {ratio1}, {ratio2}");
}

#[test]
fn nothing_missing_is_reported_as_nothing_c3() {
    let dir = tmp();
    let truth = base();
    let rec = data(dir.path(), &truth, "c3", "4.3", Some("J3"));
    let d = diagnose_output(&truth, "c3", &[rec], &OutputOptions::default()).unwrap();
    let text = show(&d);
    eprintln!("{text}");
    assert!(!d.findings[0].significant, "{text}");
    assert!(text.contains("nothing significant is missing"), "{text}");
}

/// The loop as a user runs it: diagnose --apply, the report with its history, and the hand
/// route effect add → refit; bad edits refused with the item named.
#[test]
fn the_loop_on_the_command_line_c3() {
    let dir = tmp();
    let d = dir.path();
    let truth = base();
    let mut start = truth.clone();
    start
        .effects
        .retain(|e| !(e.kind == EffectKind::Spring && e.joint == 3));
    start.parameters.remove("Ks_q3");
    start.parameters.remove("qeq_q3");
    start.bounds.remove("Ks_q3");
    start.bounds.remove("qeq_q3");
    let start_file = d.join("start.toml");
    start.save(&start_file).unwrap();
    data(d, &truth, "c3", "4.3", Some("J3"));
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let run_csv = s(&d.join("c3_run.csv"));
    let fixed = s(&d.join("fixed.toml"));
    let out = ok(&lockstep(&[
        "diagnose",
        "--plant",
        &s(&start_file),
        "--data",
        &run_csv,
        "--apply",
        "1",
        "--out",
        &fixed,
    ]));
    assert!(out.contains("most likely missing: spring on q3"), "{out}");
    let p = Plant::load(Path::new(&fixed)).unwrap();
    assert_eq!(p.history.len(), 1);
    let h = &p.history[0];
    assert_eq!(h.change, "added spring on q3");
    assert!(h.rms_after["q3"] < 0.01 * h.rms_before["q3"], "{h:?}");
    assert!((h.fitted["Ks_q3"] / 0.0064599 - 1.0).abs() < 0.05, "{h:?}");
    // The report: self-contained (figures inlined, nothing fetched), with the history and
    // the starting plant drawn beside the model.
    let rep = d.join("rep");
    let printed = ok(&lockstep(&[
        "report",
        "--plant",
        &fixed,
        "--data",
        &run_csv,
        "--out",
        &s(&rep),
        "--start",
        &s(&start_file),
    ]));
    // The compare table's q3 row (RMSE in the fifth column), then the starting plant's line.
    let lines: Vec<&str> = printed.lines().collect();
    let row = lines
        .iter()
        .position(|l| l.starts_with("c3_run") && l.contains(" q3 "))
        .unwrap_or_else(|| panic!("no q3 row in\n{printed}"));
    let rmse: f64 = lines[row]
        .split_whitespace()
        .nth(4)
        .unwrap()
        .parse()
        .unwrap();
    let start_rmse: f64 = lines[row + 1]
        .rsplit("RMSE ")
        .next()
        .unwrap()
        .trim()
        .parse()
        .unwrap_or_else(|_| panic!("no starting plant's RMSE in {}", lines[row + 1]));
    assert!(
        (start_rmse - h.rms_before["q3"]).abs() < 0.05 * h.rms_before["q3"],
        "starting plant {start_rmse:e}, history before {:e}",
        h.rms_before["q3"]
    );
    assert!(start_rmse > 50.0 * rmse, "{start_rmse:e} against {rmse:e}");
    let html = std::fs::read_to_string(rep.join("report.html")).unwrap();
    for needle in [
        "<svg",
        "Compare",
        "Diagnose",
        "History",
        "added spring on q3",
        "NRMSE fit",
        "starting plant",
    ] {
        assert!(html.contains(needle), "report lacks {needle}");
    }
    assert!(!html.contains("src=\"http") && !html.contains("<link") && !html.contains("<script"));
    // By hand: add the spring with bounds, refit it.
    let hand = s(&d.join("hand.toml"));
    let o = ok(&lockstep(&[
        "effect",
        "add",
        "spring",
        "--joint",
        "q3",
        "--plant",
        &s(&start_file),
        "--set",
        "qeq_q3=0.1",
        "--bound",
        "Ks_q3=0:0.1",
        "--bound",
        "qeq_q3=-2:2",
        "--out",
        &hand,
    ]));
    assert!(o.contains("Ks_q3 = 0") && o.contains("qeq_q3 = 0.1"), "{o}");
    let refit_hand = |more: &[&str]| {
        let mut args = vec![
            "refit",
            "--plant",
            &hand,
            "--data",
            &run_csv,
            "--params",
            "Ks_q3,qeq_q3",
        ];
        args.extend_from_slice(more);
        ok(&lockstep(&args))
    };
    let by_sensitivities = s(&d.join("hand_sensitivities.toml"));
    let o = refit_hand(&["--jacobian", "sensitivities", "--out", &by_sensitivities]);
    assert!(o.contains("simulations of the files"), "{o}");
    let sens = Plant::load(Path::new(&by_sensitivities)).unwrap();
    let o = refit_hand(&[]);
    let p = Plant::load(Path::new(&hand)).unwrap();
    let h = &p.history[0];
    assert!(h.rms_after["q3"] < 0.5 * h.rms_before["q3"], "{o}");
    // `--jacobian sensitivities` reaches the same minimum (the same data, the same start).
    for n in ["Ks_q3", "qeq_q3"] {
        let (a, b) = (sens.parameters[n], p.parameters[n]);
        assert!(
            (a / b - 1.0).abs() < 1e-4,
            "{n}: {a} by sensitivities, {b} by differences"
        );
    }
    // Refusals.
    let st = s(&start_file);
    fails(
        &lockstep(&[
            "effect",
            "add",
            "frobnicate",
            "--joint",
            "q3",
            "--plant",
            &st,
        ]),
        &["unknown effect 'frobnicate'", "input_coupling"],
    );
    fails(
        &lockstep(&["effect", "add", "spring", "--joint", "q9", "--plant", &st]),
        &["--joint: unknown joint 'q9'"],
    );
    fails(
        &lockstep(&["effect", "add", "gain", "--joint", "q3", "--plant", &st]),
        &["conflicts with 'gain'"],
    );
    fails(
        &lockstep(&["effect", "add", "coupling", "--plant", &st, "--from", "q5"]),
        &["needs --from and --to"],
    );
    fails(
        &lockstep(&[
            "effect", "add", "offset", "--joint", "q3", "--plant", &st, "--set", "Kx_3=1",
        ]),
        &["--set Kx_3", "offset_q3"],
    );
    fails(
        &lockstep(&[
            "refit", "--plant", &st, "--data", &run_csv, "--params", "Fs_q9",
        ]),
        &["Fs_q9"],
    );
    fails(
        &lockstep(&[
            "refit", "--plant", &st, "--data", &run_csv, "--params", "Fc_q3",
        ]),
        &["'Fc_q3'", "no bounds"],
    );
    // The start plant file is untouched by the refused edits.
    assert_eq!(
        Plant::load(&start_file).unwrap().effects.len(),
        start.effects.len()
    );
}

/// `compare` on a file shorter than the identification's transient skip (1000 samples):
/// every sample is compared (as MATLAB `compare`), the truth sits at the noise floor, and
/// `--skip` leaves samples out of the figures or, leaving none, is refused naming the file.
#[test]
fn compare_uses_the_whole_of_a_short_file_and_its_skip_c2() {
    let dir = tmp();
    let d = dir.path();
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let truth_file = d.join("truth.toml");
    base().save(&truth_file).unwrap();
    let (tau, run_csv) = (d.join("tau.csv"), d.join("c2_run.csv"));
    lockstep(&[
        "excite",
        "--model",
        "freedom6s",
        "--table",
        "4.3",
        "--test",
        "J5",
        "--config",
        "c2",
        "--duration",
        "5",
        "-o",
        &s(&tau),
    ]);
    lockstep(&[
        "simulate",
        "--plant",
        &s(&truth_file),
        "--input",
        &s(&tau),
        "--step",
        "1/12000",
        "--noise",
        "2e-4",
        "--quantisation",
        "1e-4",
        "--seed",
        "9",
        "-o",
        &s(&run_csv),
    ]);
    let compare = |skip: &str| {
        lockstep(&[
            "compare",
            "--plant",
            &s(&truth_file),
            "--data",
            &s(&run_csv),
            "--step",
            "1/12000",
            "--skip",
            skip,
            "--out",
            &s(&d.join(format!("cmp{skip}"))),
        ])
    };
    // (fit %, RMSE) of q5's row.
    let q5_row = |skip: &str| {
        let out = ok(&compare(skip));
        let row: Vec<&str> = out
            .lines()
            .find(|l| l.split_whitespace().nth(1) == Some("q5"))
            .unwrap_or_else(|| panic!("no q5 row in:\n{out}"))
            .split_whitespace()
            .collect();
        let fit: f64 = row[2].parse().unwrap();
        let rmse: f64 = row[4].parse().unwrap();
        (fit, rmse)
    };
    for skip in ["0", "200"] {
        let (fit, rmse) = q5_row(skip);
        // Noise 2e-4 rad and quantisation 1e-4 rad (σ 2.9e-5): RMS ≈ 2.02e-4 rad.
        assert!(fit > 99.0, "skip {skip}: fit {fit} %");
        assert!((1.7e-4..2.4e-4).contains(&rmse), "skip {skip}: RMSE {rmse}");
    }
    fails(
        &compare("501"),
        &["c2_run.csv", "--skip 501 leaves no samples", "501"],
    );
}
