//! Diagnosis in torque space (issue 6, first part): the missing effect is ranked first on the
//! real EMPS data with Coulomb friction and offset hidden, the error falls below the
//! benchmark's 4.3 % once they are added, and on data the model explains nothing significant
//! is reported.

mod common;

use lockstep::diagnose::{diagnose_torque, Finding};
use lockstep::effects::{Effect, EffectKind};
use lockstep::identify::idim::{least_squares, least_squares_base, observation, IdimOptions};
use lockstep::measurement::Measurement;
use lockstep::plant::Plant;
use std::path::PathBuf;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn opts() -> IdimOptions {
    IdimOptions {
        cutoff_hz: 100.0,
        filter_order: 4,
        decimation: 10,
        window: None,
        min_speed: None,
        differentiator: lockstep::signal::Differentiator::Central,
        trim_moving_edges: false,
    }
}

/// IDIM fit of `plant` on `m` (values applied), then the diagnosis on the same observation:
/// (relative error %, ranking).
fn fit_and_diagnose(plant: &mut Plant, m: &Measurement) -> (f64, Vec<Finding>) {
    let obs = observation(plant, "full", std::slice::from_ref(m), &opts()).unwrap();
    let fit = least_squares(&obs).unwrap();
    fit.apply(plant).unwrap();
    (fit.relative_error, diagnose_torque(plant, &obs).unwrap())
}

#[test]
fn emps_hidden_coulomb_friction_is_named_first_and_adding_it_brings_the_error_below_4_3_percent() {
    let m = Measurement::read(&root().join("data/emps/emps_train.csv"), &["q0"]).unwrap();
    let mut plant = Plant::load(&root().join("model/plants/emps_viscous.toml")).unwrap();
    let (error, f) = fit_and_diagnose(&mut plant, &m);
    assert!(error >= 15.0, "{error}");
    assert_eq!(
        f[0].kind,
        Some(EffectKind::Coulomb),
        "{}",
        lockstep::diagnose::table(&f, 5)
    );
    assert!(f[0].significant && f[0].explained > 0.5, "{:?}", f[0]);
    // Estimated size near the benchmark's Fc ≈ 20 N.
    assert!(
        (f[0].estimate[0].1 - 20.0).abs() < 5.0,
        "{:?}",
        f[0].estimate
    );
    // Add it (and the offset, next in the ranking once Coulomb is in) and refit.
    plant
        .add_effect(Effect::on(EffectKind::Coulomb, 0))
        .unwrap();
    plant.parameters.insert("Fc_q0".into(), 0.0);
    let (_, f) = fit_and_diagnose(&mut plant, &m);
    // Next: a constant, alone (offset, −3.1 N) or inside a spring (Ks (q − qeq) has a constant
    // column; on EMPS it explains 68.3 % against the offset's 67.8 %).
    let t = lockstep::diagnose::table(&f, 5);
    assert!(
        matches!(f[0].kind, Some(EffectKind::Offset | EffectKind::Spring)),
        "{t}"
    );
    let off = f
        .iter()
        .find(|x| x.kind == Some(EffectKind::Offset))
        .unwrap();
    assert!(
        off.significant && f[0].explained - off.explained < 0.02,
        "{t}"
    );
    assert!((off.estimate[0].1 + 3.1).abs() < 0.5, "{t}");
    plant.add_effect(Effect::on(EffectKind::Offset, 0)).unwrap();
    plant.parameters.insert("offset_q0".into(), 0.0);
    let (error, _) = fit_and_diagnose(&mut plant, &m);
    assert!(error <= 4.3, "{error}");
}

/// A synthetic torque-measured record of the EMPS model with every effect it has,
/// y = M q̈ + Fv q̇ + Fc sign(q̇) + offset + K3 q³ + white noise (σ = 1 N), written under
/// `dir`.
fn synthetic_emps(dir: &std::path::Path, k3: f64) -> Measurement {
    synthetic_emps_with(dir, k3, 0.0)
}

/// [`synthetic_emps`] with a drifting load disturbance added: d_k = φ d_{k−1} + s w_k at
/// 1 kHz, φ = 0.995 (time constant 0.2 s), stationary RMS `drift` N — a force with a state
/// of its own, a function of neither q nor q̇.
fn synthetic_emps_with(dir: &std::path::Path, k3: f64, drift: f64) -> Measurement {
    let dt = 1e-3;
    let n = 20_000;
    let t: Vec<f64> = (0..n).map(|k| k as f64 * dt).collect();
    let w = [(0.02, 1.1), (0.01, 2.7), (0.005, 4.9)];
    let q: Vec<f64> = t
        .iter()
        .map(|&t| w.iter().map(|(a, f)| a * (f * t).sin()).sum())
        .collect();
    let qd: Vec<f64> = t
        .iter()
        .map(|&t| w.iter().map(|(a, f)| a * f * (f * t).cos()).sum())
        .collect();
    let qdd: Vec<f64> = t
        .iter()
        .map(|&t| w.iter().map(|(a, f)| -a * f * f * (f * t).sin()).sum())
        .collect();
    let mut s = 99u64;
    let mut noise = || {
        // Box–Muller on xorshift.
        let mut u = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            ((s >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        let (a, b) = (u(), u());
        (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
    };
    let phi: f64 = 0.995;
    let s_w = drift * (1.0 - phi * phi).sqrt();
    let mut d = 0.0;
    let y: Vec<f64> = (0..n)
        .map(|k| {
            let white = noise();
            if drift > 0.0 {
                d = phi * d + s_w * noise();
            }
            95.0 * qdd[k] + 200.0 * qd[k] + 20.0 * qd[k].signum() - 3.0
                + k3 * q[k].powi(3)
                + d
                + white
        })
        .collect();
    let path = dir.join(format!("synthetic_{k3}_{drift}.csv"));
    let mut text = String::from("t,tau0,q0\n");
    for k in 0..n {
        text += &format!("{},{},{}\n", t[k], y[k], q[k]);
    }
    std::fs::write(&path, text).unwrap();
    Measurement::read(&path, &["q0"]).unwrap()
}

/// The truth's residual, filtered and decimated, passes the whiteness test, so the verdict
/// is "nothing significant is missing".
#[test]
fn nothing_significant_is_missing_when_the_model_is_the_truth() {
    let dir = tempfile::tempdir().unwrap();
    let m = synthetic_emps(dir.path(), 0.0);
    let mut plant = Plant::load(&root().join("model/plants/emps_symmetric.toml")).unwrap();
    let (_, f) = fit_and_diagnose(&mut plant, &m);
    let obs = observation(&plant, "full", std::slice::from_ref(&m), &opts()).unwrap();
    let d = lockstep::diagnose::torque::diagnosis(&plant, &obs).unwrap();
    let table = d.table(5);
    eprintln!("{table}");
    assert!(!f.iter().any(|x| x.significant), "{table}");
    assert!(d.not_white.is_empty(), "{table}");
    assert!(table.contains("nothing significant is missing"), "{table}");
    // The same data against the plant without Coulomb friction: named first.
    let mut viscous = Plant::load(&root().join("model/plants/emps_viscous.toml")).unwrap();
    let (_, f) = fit_and_diagnose(&mut viscous, &m);
    assert_eq!(
        f[0].kind,
        Some(EffectKind::Coulomb),
        "{}",
        lockstep::diagnose::table(&f, 5)
    );
}

/// A drifting load (a force with a state of its own, outside the catalogue and the
/// library) on the truth's data: no candidate and no library term is significant, but the
/// residual is not white, so the verdict is "unexplained", not "nothing significant is
/// missing" (issue 54: the third outcome only when the residual tests pass).
#[test]
fn a_drifting_load_is_unexplained_not_nothing_missing() {
    let dir = tempfile::tempdir().unwrap();
    let m = synthetic_emps_with(dir.path(), 0.0, 3.0);
    let mut plant = Plant::load(&root().join("model/plants/emps_symmetric.toml")).unwrap();
    fit_and_diagnose(&mut plant, &m);
    let obs = observation(&plant, "full", std::slice::from_ref(&m), &opts()).unwrap();
    let d = lockstep::diagnose::torque::diagnosis(&plant, &obs).unwrap();
    let table = d.table(5);
    eprintln!("{table}");
    assert_eq!(d.not_white.len(), 1, "{table}");
    assert!(
        d.not_white[0].starts_with("q0 not white: Ljung–Box Q = "),
        "{table}"
    );
    assert!(!table.contains("nothing significant is missing"), "{table}");
    assert!(
        table.contains("unexplained: what is left is not noise (q0 not white: Ljung–Box"),
        "{table}"
    );
}

/// The loop on the command line in torque space (EMPS): identify the mass + viscous plant,
/// `diagnose --apply all-significant` adds Coulomb friction and refits the whole inverse
/// model (17.95 % → 7.10 %), then stops at the spring, whose rest angle the least squares
/// cannot refit; `--apply` of the offset (ranked next, 67.8 % against the spring's 68.3 %)
/// brings the error below the benchmark's 4.3 %. The history records both steps with their
/// torque residuals; the report reads them.
#[test]
fn the_loop_in_torque_space_on_the_command_line_emps() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let s = |p: &std::path::Path| p.to_str().unwrap().to_string();
    let data = s(&root().join("data/emps/emps_train.csv"));
    let (p1, p2, p3) = (d.join("p1.toml"), d.join("p2.toml"), d.join("p3.toml"));
    common::ok(&common::lockstep(&[
        "identify",
        "idim",
        "--plant",
        &s(&root().join("model/plants/emps_viscous.toml")),
        "--data",
        &data,
        "--out",
        &s(&p1),
    ]));
    let out = common::ok(&common::lockstep(&[
        "diagnose",
        "--plant",
        &s(&p1),
        "--data",
        &data,
        "--apply",
        "all-significant",
        "--out",
        &s(&p2),
    ]));
    assert!(out.contains("step: added coulomb on q0"), "{out}");
    // The spring ranks first next but is not proposed: its rest angle (1.01 m) lies outside
    // the motion, so these data see an offset plus a stiffness; the offset is added.
    assert!(
        out.contains("its rest angle 1.0143 lies outside the motion"),
        "{out}"
    );
    assert!(out.contains("step: added offset on q0"), "{out}");
    let plant = Plant::load(&p2).unwrap();
    assert!(plant.has_effect(0, EffectKind::Coulomb));
    assert!(!plant.has_effect(0, EffectKind::Spring));
    let h = &plant.history[0];
    assert_eq!(h.change, "added coulomb on q0");
    assert_eq!(h.space.as_deref(), Some("torque"));
    // The before figure is the identified plant's residual: 17.95 % of the force's RMS.
    assert!(
        (h.rms_before["q0"] / h.rms_after["q0"] - 9.6227 / 3.8065).abs() < 0.05,
        "{h:?}"
    );
    assert!((h.fitted["Fc_q0"] - 20.37).abs() < 0.5, "{h:?}");
    let rel: f64 = out
        .lines()
        .rev()
        .find_map(|l| l.strip_prefix("relative error "))
        .and_then(|l| l.split(" → ").nth(1))
        .and_then(|l| l.split_whitespace().next())
        .unwrap_or_else(|| panic!("no relative error in\n{out}"))
        .parse()
        .unwrap();
    assert!(rel <= 4.3, "{out}");
    assert_eq!(plant.history.len(), 2);
    assert_eq!(plant.history[1].change, "added offset on q0");
    assert!((plant.history[1].fitted["offset_q0"] + 3.1).abs() < 0.5);
    std::fs::copy(&p2, &p3).unwrap();
    // Against the demo's own IDIM-LS of the same model (an independent path: the library's
    // least squares on the plant with both effects): the same relative error.
    let mut by_hand = Plant::load(&root().join("model/plants/emps_viscous.toml")).unwrap();
    for k in [EffectKind::Coulomb, EffectKind::Offset] {
        by_hand.add_effect(Effect::on(k, 0)).unwrap();
    }
    by_hand.parameters.insert("Fc_q0".into(), 0.0);
    by_hand.parameters.insert("offset_q0".into(), 0.0);
    let m = Measurement::read(&root().join("data/emps/emps_train.csv"), &["q0"]).unwrap();
    let (error, _) = fit_and_diagnose(&mut by_hand, &m);
    assert!((error - rel).abs() < 1e-3, "{error} against {rel}");
    // By hand: `refit --params` in torque space fits the named values, the others held;
    // a name the inverse model does not have is refused with the ones it has.
    let p4 = d.join("p4.toml");
    let refit = |params: &str| {
        common::lockstep(&[
            "refit",
            "--plant",
            &s(&p3),
            "--data",
            &data,
            "--params",
            params,
            "--out",
            &s(&p4),
        ])
    };
    let out = common::ok(&refit("offset_q0"));
    assert!(out.contains("torque space"), "{out}");
    let refitted = Plant::load(&p4).unwrap();
    assert!((refitted.parameters["offset_q0"] / plant.parameters["offset_q0"] - 1.0).abs() < 1e-6);
    common::fails(
        &refit("Ks_q0"),
        &[
            "'Ks_q0' is not a parameter of the inverse model",
            "M, Fv_q0, Fc_q0, offset_q0",
        ],
    );
    // A Jacobian of simulated positions has no place in torque space: refused, not ignored.
    common::fails(
        &common::lockstep(&[
            "diagnose",
            "--plant",
            &s(&p3),
            "--data",
            &data,
            "--jacobian",
            "sensitivities",
        ]),
        &[
            "--jacobian sensitivities",
            "torque space",
            "linear least squares",
        ],
    );
    // The report reads the torque-space history.
    let rep = d.join("rep");
    common::ok(&common::lockstep(&[
        "report",
        "--plant",
        &s(&p3),
        "--data",
        &data,
        "--out",
        &s(&rep),
    ]));
    let html = std::fs::read_to_string(rep.join("report.html")).unwrap();
    assert!(html.contains("added offset on q0"));
}

/// A cubic stiffness K3 q³ (K3 = 2e5 N/m³: 5 N at 3 cm, 5 σ) hidden in the same synthetic
/// record, outside the catalogue: the full EMPS model's diagnosis names the built-in cubic
/// stiffness first (issue 54 item 2), the structure search's description (q³ first, its
/// lower powers completing it) next, not "nothing missing"; adding it as a user-defined
/// effect and refitting the inverse model takes the residual to that of the true model on
/// the same noise (within 1 %) with K3 within 1 %.
#[test]
fn a_hidden_cubic_stiffness_is_named_in_torque_space() {
    let dir = tempfile::tempdir().unwrap();
    let m = synthetic_emps(dir.path(), 2e5);
    let mut plant = Plant::load(&root().join("model/plants/emps_symmetric.toml")).unwrap();
    let (_, f) = fit_and_diagnose(&mut plant, &m);
    let table = lockstep::diagnose::table(&f, 5);
    eprintln!("{table}");
    assert_eq!(f[0].name, "cubic stiffness", "{table}");
    assert!(
        table.contains("most likely missing: cubic stiffness on q0"),
        "{table}"
    );
    assert!(
        f.iter()
            .any(|x| x.structure && x.name.starts_with("structure: q_q0^3")),
        "{table}"
    );
    let r = lockstep::diagnose::torque::apply_finding(
        &plant,
        &f[0],
        "full",
        std::slice::from_ref(&m),
        &opts(),
    )
    .unwrap();
    let k3 = r.plant.parameters["K3_q0"];
    let rms = r.after[0].1;
    // The floor: the true model on the same noise without the cubic.
    let mut truth = Plant::load(&root().join("model/plants/emps_symmetric.toml")).unwrap();
    let m0 = synthetic_emps(dir.path(), 0.0);
    fit_and_diagnose(&mut truth, &m0);
    let floor = lockstep::identify::refit::refit_torque(&truth, &truth, "full", &[m0], &opts())
        .unwrap()
        .after[0]
        .1;
    eprintln!(
        "K3 {k3:.4e}, residual {rms:.4} N (before {:.4}), floor {floor:.4} N",
        r.before[0].1
    );
    assert!((k3 / 2e5 - 1.0).abs() < 0.01, "K3 {k3}");
    assert!(rms <= 1.01 * floor, "residual {rms}, floor {floor}");
}

/// The synthetic record with the cubic stiffness 2e5 q³ hidden ([`synthetic_emps`]) in
/// `dir`, and the symmetric model identified on it by `lockstep identify idim`, written to
/// `dir/p1.toml`.
fn identified_synthetic_emps(dir: &std::path::Path) -> (Measurement, PathBuf) {
    let m = synthetic_emps(dir, 2e5);
    let p1 = dir.join("p1.toml");
    let s = |p: &std::path::Path| p.to_str().unwrap().to_string();
    common::ok(&common::lockstep(&[
        "identify",
        "idim",
        "--plant",
        &s(&root().join("model/plants/emps_symmetric.toml")),
        "--data",
        &s(&m.file),
        "--out",
        &s(&p1),
    ]));
    (m, p1)
}

/// `lockstep report` draws the diagnosis's leading finding over the residual figures and
/// writes it beside the residual (issue 54 item 4): on the synthetic record with the cubic
/// stiffness hidden, the figure's legend names "finding 1: cubic stiffness on q0" and the
/// CSV's `described` column (the torque the finding adds, K3 (q − qc)³ as the diagnosis
/// estimated it with the plant's values held, before any refit) is the hidden 2e5 q³ to
/// 5 % RMS (2.6 % measured; 100 % if it drew anything else); `compare` alone writes no
/// such column.
#[test]
fn the_report_draws_the_leading_finding_over_the_residual_emps() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let s = |p: &std::path::Path| p.to_str().unwrap().to_string();
    let (m, p1) = identified_synthetic_emps(d);
    let data = s(&m.file);
    let rep = d.join("rep");
    common::ok(&common::lockstep(&[
        "report",
        "--plant",
        &s(&p1),
        "--data",
        &data,
        "--out",
        &s(&rep),
    ]));
    let stem = m.file.file_stem().unwrap().to_str().unwrap();
    let svg = std::fs::read_to_string(rep.join(format!("{stem}_q0.svg"))).unwrap();
    assert!(svg.contains("finding 1: cubic stiffness on q0"));
    let mut r = csv::Reader::from_path(rep.join(format!("{stem}_q0.csv"))).unwrap();
    let header = r.headers().unwrap().clone();
    let col = |n: &str| header.iter().position(|h| h == n).unwrap();
    let (iq, id) = (col("q"), col("described"));
    let (mut diff, mut norm) = (0.0, 0.0);
    for row in r.records() {
        let row = row.unwrap();
        let q: f64 = row[iq].parse().unwrap();
        let described: f64 = row[id].parse().unwrap();
        let hidden = 2e5 * q.powi(3);
        diff += (described - hidden).powi(2);
        norm += hidden * hidden;
    }
    let rel = (diff / norm).sqrt();
    eprintln!("described vs hidden: {rel:.4} relative RMS");
    assert!(rel < 0.05, "{rel}");
    let cmp = d.join("cmp");
    common::ok(&common::lockstep(&[
        "compare",
        "--plant",
        &s(&p1),
        "--data",
        &data,
        "--out",
        &s(&cmp),
    ]));
    let text = std::fs::read_to_string(cmp.join(format!("{stem}_q0.csv"))).unwrap();
    assert!(!text.lines().next().unwrap().contains("described"));
}

/// `diagnose --candidates` on the command line (torque space, the cubic stiffness of
/// [`synthetic_emps`] hidden): the user's cubic `K3*q0^3` is tested beside the catalogue
/// and named first (ahead of the structure search's description of the same residual:
/// one parameter against three), a decoy ripple is not significant, a candidate not
/// linear in its parameters is left out with its reason printed; `--apply 1` writes the
/// plant with the user-defined effect and K3 within 1 % of the truth. Mistakes in the
/// file are one clear line naming the file and the candidate, exit ≠ 0, nothing written.
#[test]
fn the_users_candidates_are_ranked_with_the_catalogue_and_applied_emps() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let s = |p: &std::path::Path| p.to_str().unwrap().to_string();
    let (m, p1) = identified_synthetic_emps(d);
    let data = s(&m.file);
    let p2 = d.join("p2.toml");
    let candidates = d.join("candidates.toml");
    std::fs::write(
        &candidates,
        r#"
[[candidate]]
name = "cubic"
joints = ["q0"]
torque = "K3*q0^3"
meaning = "a hardening spring"
parameters = { K3 = { start = 0.0, bounds = [-1e7, 1e7] } }

[[candidate]]
name = "ripple"
joints = ["q0"]
torque = "A*sin(3000*q0) + B*cos(3000*q0)"
parameters = { A = { start = 0.0, bounds = [-10, 10] }, B = { start = 0.0, bounds = [-10, 10] } }

[[candidate]]
name = "shifted_cubic"
joints = ["q0"]
torque = "K*(q0 - a)^3"
parameters = { K = { start = 1e5, bounds = [0, 1e7] }, a = { start = 0.0, bounds = [-0.1, 0.1] } }
"#,
    )
    .unwrap();
    let diagnose = |file: &std::path::Path, out: &std::path::Path| {
        common::lockstep(&[
            "diagnose",
            "--plant",
            &s(&p1),
            "--data",
            &data,
            "--candidates",
            &s(file),
            "--top",
            "8",
            "--apply",
            "1",
            "--out",
            &s(out),
            // The EMPS benchmark's preparation (the synthetic record's side file declares
            // none). Chosen from the data (fit band 20 Hz, ×20), the built-in cubic
            // stiffness and the user's cubic tie within ΔBIC 0.3 and the built-in is named.
            "--cutoff",
            "100",
            "--decimate",
            "10",
        ])
    };
    let out = common::ok(&diagnose(&candidates, &p2));
    eprintln!("{out}");
    assert!(
        out.contains("most likely missing: candidate cubic on q0"),
        "{out}"
    );
    assert!(
        out.contains("candidate 'shifted_cubic' (torque space)") && out.contains("not linear"),
        "{out}"
    );
    let ripple = out
        .lines()
        .find(|l| l.contains("candidate ripple"))
        .unwrap_or_else(|| panic!("{out}"));
    assert!(ripple.contains("(not significant)"), "{ripple}");
    let plant = Plant::load(&p2).unwrap();
    assert_eq!(plant.expressions.len(), 1);
    assert_eq!(plant.expressions[0].name, "cubic");
    let k3 = plant.parameters["K3"];
    assert!((k3 / 2e5 - 1.0).abs() < 0.01, "K3 {k3}");
    // Mistakes: one line naming the file and the candidate; nothing written.
    let bad = |text: &str, needles: &[&str]| {
        let f = d.join("bad.toml");
        std::fs::write(&f, text).unwrap();
        let p3 = d.join("p3.toml");
        common::fails(&diagnose(&f, &p3), needles);
        assert!(!p3.exists(), "nothing written on a refusal");
    };
    let one = |name: &str, torque: &str, params: &str| {
        format!(
            "[[candidate]]\nname = \"{name}\"\njoints = [\"q0\"]\ntorque = \"{torque}\"\nparameters = {{ {params} }}\n"
        )
    };
    let k = "K = { start = 0.0, bounds = [-1, 1] }";
    bad(
        &format!("{}{}", one("a", "K*q0", k), one("a", "K*qd0", k)),
        &["bad.toml", "candidate 'a'", "given twice"],
    );
    bad(&one("b", "K*q9", k), &["candidate 'b'", "q9"]);
    bad(
        &one("c", "K*q0", "K = { start = 0.0, bounds = [1, -1] }"),
        &[
            "bad.toml",
            "candidate 'c'",
            "parameter 'K'",
            "lower < upper",
        ],
    );
    bad(
        &one("e", "K*q0", "K = { start = 5.0, bounds = [-1, 1] }"),
        &["candidate 'e'", "outside its bounds"],
    );
    bad(
        &one("f", "M*q0", "M = { start = 0.0, bounds = [-1, 1] }"),
        &["candidate 'f'", "'M'", "already a parameter"],
    );
    bad(
        "[[candidate]]\nname = \"g\"\n",
        &["bad.toml", "missing field"],
    );
}

/// The joints' positions at the first sample of `m` (k5 locks none: any positions).
fn m_locked(m: &Measurement) -> Vec<f64> {
    m.q.iter().map(|q| q[0]).collect()
}

/// Torque space on a six-joint arm (k5, every joint of the Freedom 6S free; 8 s of the
/// independent generator's data, filtered at 20 Hz, not decimated), with the rigid body
/// and viscous + Coulomb friction only: each joint's residual is projected off the columns
/// that act on its rows. The whole 73-column block, mostly zero on the wrist's rows, made
/// nalgebra's SVD return NaN vectors and the diagnosis NaN figures. Here every figure is
/// finite, before and after the least squares on the base parameters; the unfitted
/// plant's "refit existing parameters" leads, and explains less after the fit.
#[test]
fn a_six_joint_torque_diagnosis_has_finite_figures_k5() {
    let truth = common::appendix_d_coupled();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("k5.csv");
    common::independent::write(
        &truth,
        &common::independent::Spec {
            config: "k5",
            table: "4.7",
            test: None,
            duration: 8.0,
            noise: 2e-4,
            quantisation: 1e-4,
            seed: 3,
        },
        &path,
    );
    let m = Measurement::read(&path, &["q0", "q1", "q2", "q3", "q4", "q5"]).unwrap();
    let mut plant = truth.clone();
    plant.effects.clear();
    for j in 0..6 {
        for kind in [EffectKind::Viscous, EffectKind::Coulomb] {
            plant.add_effect(Effect::on(kind, j)).unwrap();
            plant
                .parameters
                .entry(format!("{}_q{j}", kind.symbols()[0]))
                .or_insert(0.0);
        }
    }
    let options = IdimOptions {
        cutoff_hz: 20.0,
        filter_order: 4,
        decimation: 1,
        window: None,
        min_speed: None,
        differentiator: lockstep::signal::Differentiator::Central,
        trim_moving_edges: false,
    };
    let diagnose = |p: &Plant| {
        let obs = observation(p, "k5", std::slice::from_ref(&m), &options).unwrap();
        let d = lockstep::diagnose::torque::diagnosis(p, &obs).unwrap();
        for f in &d.findings {
            assert!(
                f.explained.is_finite() && f.delta_bic.is_finite(),
                "{} on {}: {} {}",
                f.name,
                f.joint,
                f.explained,
                f.delta_bic
            );
            assert!(f.estimate.iter().all(|(_, v)| v.is_finite()), "{f:?}");
        }
        (obs, d)
    };
    let (obs, d) = diagnose(&plant);
    eprintln!("{}", d.table(4));
    assert_eq!(
        d.findings[0].name,
        "refit existing parameters",
        "{}",
        d.table(4)
    );
    assert!(d.findings[0].significant);
    let conf = plant.model.configuration("k5").unwrap();
    let prior = plant.clone();
    least_squares_base(
        &obs,
        plant.model,
        conf,
        &[m_locked(&m)],
        &|n| prior.parameters.get(n).copied(),
        None,
    )
    .unwrap()
    .apply(&mut plant)
    .unwrap();
    let (_, after) = diagnose(&plant);
    eprintln!("{}", after.table(4));
    // The joint least squares moved the shared parameters: each joint's own refit explains
    // less of what is left (it refits them per joint, so it stays significant where the
    // plant lacks the truth's gains and LuGre friction).
    let refit = |d: &lockstep::diagnose::torque::TorqueDiagnosis, j: &str| {
        d.findings
            .iter()
            .find(|f| f.name == "refit existing parameters" && f.joint == j)
            .map_or(0.0, |f| f.explained)
    };
    assert!(refit(&after, "q1") < refit(&d, "q1"), "{}", after.table(6));
}
