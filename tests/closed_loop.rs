//! Closed-loop output error (issue 59): a device measured under its own controller is
//! simulated in closed loop on the measured reference, and the force and velocity are
//! compared. The reference figures are the EMPS benchmark's own (Janot, Gautier, Brunot
//! 2019; data/emps/README.md): its published model simulated in closed loop by its
//! Simulink model.

mod common;

use lockstep::control::controller::{compare_closed_loop, ClosedLoopRecord, Controller};
use lockstep::measurement::Table;
use lockstep::plant::Plant;
use lockstep::simulation::Hold;
use std::path::{Path, PathBuf};

fn manifest(p: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(p)
}

/// The relative errors (%) of force and velocity of the published model in closed loop on
/// `file`, under the bundled controller file with its disturbance held by `hold`.
fn published_errors(file: &str, hold: Hold) -> (f64, f64) {
    let plant = Plant::load(&manifest("model/plants/emps_published.toml")).unwrap();
    let mut c = Controller::load(&manifest("model/control/emps_controller.toml"), &plant).unwrap();
    assert_eq!(c.disturbance_hold, Hold::Zoh, "the bundled file's default");
    c.disturbance_hold = hold;
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
/// force 5.848 %, velocity 0.229 % (each to 1 %).
///
/// The pulses record (its pulses a disturbance inside the command): with the pulses fed as
/// a continuous signal, linearly interpolated between samples (what an interpolating
/// input block such as Simulink's From Workspace, its default, feeds a continuous plant),
/// force and velocity are within 10 % of the published 8.941 % and 0.479 %. Held as the
/// digital controller applied them (the bundled file's default), the force stays within
/// 10 % and the velocity error falls to about 0.40 %: the record fits the held pulses
/// better than the published simulation did (docs/src/record/closed-loop.md).
#[test]
fn the_published_emps_model_gives_the_benchmarks_closed_loop_errors() {
    let (force, velocity) = published_errors("data/emps/emps_train.csv", Hold::Zoh);
    assert!((force / 5.848 - 1.0).abs() < 0.01, "force {force}");
    assert!((velocity / 0.229 - 1.0).abs() < 0.01, "velocity {velocity}");
    let pulses = "data/emps/emps_test_pulses.csv";
    let (force, velocity) = published_errors(pulses, Hold::Linear);
    assert!((force / 8.941 - 1.0).abs() < 0.10, "force {force}");
    assert!((velocity / 0.479 - 1.0).abs() < 0.10, "velocity {velocity}");
    let (force_held, velocity_held) = published_errors(pulses, Hold::Zoh);
    assert!(
        (force_held / 8.941 - 1.0).abs() < 0.10,
        "force {force_held}"
    );
    assert!(
        velocity_held < 0.9 * velocity && velocity_held > 0.3,
        "held pulses: velocity {velocity_held} against {velocity} interpolated"
    );
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
    assert!(
        text.contains("the records' disturbance held between samples (zoh)"),
        "{text}"
    );
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
        &|t| t.replace("step = 1e-4", "step = 1e-4\ndisturbance_hold = \"spline\""),
        &[
            "bad_controller.toml",
            "disturbance_hold",
            "expected `zoh`, `linear`, `cubic` or `bandlimited`, got `spline`",
        ],
    );
    bad(
        &|t| t.replace("reference = \"qref_q0\"", "reference = \"qref_q9\""),
        &["qref_q9", "emps_test_pulses.csv", "reference of joint q0"],
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
    // A record whose side file names another configuration than the controller's.
    std::fs::copy(manifest("data/emps/emps_train.csv"), other.join("half.csv")).unwrap();
    let side = std::fs::read_to_string(manifest("data/emps/emps_train.toml")).unwrap();
    std::fs::write(
        other.join("half.toml"),
        side.replace("[columns]", "configuration = \"other\"\n\n[columns]"),
    )
    .unwrap();
    common::fails(
        &run(&manifest("model/control/emps_controller.toml"), &other, &o),
        &["half.csv", "configuration 'other'", "is for 'full'"],
    );
    assert!(!o.exists());
}

/// The plant of `file` with its IDIM-LS values on the training record (DIDIM's start),
/// and the training record for the closed loop.
fn idim_start(file: &str) -> (Plant, Controller, ClosedLoopRecord) {
    use lockstep::identify::idim::{least_squares, observation, IdimOptions};
    let mut plant = Plant::load(&manifest(file)).unwrap();
    let table = Table::read(&manifest("data/emps/emps_train.csv")).unwrap();
    let m = lockstep::measurement::Measurement::from_table(&table, &["q0"]).unwrap();
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
/// published force error (8.941 %), and of both published figures (8.941 %, 0.479 %) with
/// the pulses fed as the published simulation fed them (linearly interpolated).
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
        (EffectKind::Coulomb, "Fc_q0"),
        (EffectKind::Offset, "offset_q0"),
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
    let (force, velocity) = closed_loop_errors(&plant, &c, std::slice::from_ref(&pulses)).unwrap();
    eprintln!("pulses: force {force:.4} %, velocity {velocity:.4} %");
    assert!((force / 8.941 - 1.0).abs() < 0.10, "pulses force {force}");
    // The pulses fed as the published simulation fed them (linearly interpolated): both
    // figures within 10 % of the published ones.
    let mut interpolated = c.clone();
    interpolated.disturbance_hold = lockstep::simulation::Hold::Linear;
    let (force, velocity) = closed_loop_errors(&plant, &interpolated, &[pulses]).unwrap();
    eprintln!("pulses, interpolated: force {force:.4} %, velocity {velocity:.4} %");
    assert!((force / 8.941 - 1.0).abs() < 0.10, "pulses force {force}");
    assert!(
        (velocity / 0.479 - 1.0).abs() < 0.10,
        "pulses velocity {velocity}"
    );
}

/// `identify didim` and `diagnose --controller` on the command line: DIDIM from the mass +
/// viscous IDIM-LS values writes its plant, the closed-loop diagnosis of it names Coulomb
/// friction, and `--apply 1` adds it and refits by DIDIM (Fc within 5 % of the benchmark's
/// 20.39 N, the offset still missing); `refit --controller --params Fc_q0` takes Fc from 10 N
/// back to that value (1 %) with the others held and records the step; a user's candidate is ranked beside the catalogue; a
/// plant whose effect the inverse model cannot fit is refused with the reason
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
    let fc = fitted.parameters["Fc_q0"];
    // Without the offset yet, the closed-loop fit puts Fc a little below the full model's.
    assert!((fc / 20.3935 - 1.0).abs() < 0.05, "Fc {fc}");
    // `refit --controller`: Fc_q0 alone refitted from 10 N, the others held; the step in
    // the history with the closed-loop force RMS before and after.
    let mut off = fitted.clone();
    off.parameters.insert("Fc_q0".into(), 10.0);
    let (p6, p7) = (d.join("p6.toml"), d.join("p7.toml"));
    off.save(&p6).unwrap();
    let refit_with = |params: &str, out: &Path, more: &[&str]| {
        let (p6, out) = (s(&p6), s(out));
        let mut args = vec![
            "refit",
            "--plant",
            &p6,
            "--data",
            &data,
            "--controller",
            &controller,
            "--params",
            params,
            "--out",
            &out,
        ];
        args.extend_from_slice(more);
        common::lockstep(&args)
    };
    let refit = |params: &str, out: &Path| refit_with(params, out, &[]);
    common::ok(&refit("Fc_q0", &p7));
    let refitted = Plant::load(&p7).unwrap();
    let back = refitted.parameters["Fc_q0"];
    assert!((back / fc - 1.0).abs() < 0.01, "Fc {back} against {fc}");
    assert_eq!(refitted.parameters["Fv_q0"], fitted.parameters["Fv_q0"]);
    let step = refitted.history.last().unwrap();
    assert_eq!(step.space.as_deref(), Some("closed loop"));
    assert!(
        step.rms_after["q0"] < 0.5 * step.rms_before["q0"],
        "{step:?}"
    );
    let p8 = d.join("p8.toml");
    common::fails(
        &refit("Ks_q0", &p8),
        &["'Ks_q0' is not a parameter of the inverse model"],
    );
    common::fails(
        &refit_with("Fc_q0", &p8, &["--jacobian", "differences"]),
        &["--jacobian differences", "DIDIM"],
    );
    assert!(!p8.exists());
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
    spring.parameters.insert("Ks_q0".into(), 1.0);
    spring.parameters.insert("qeq_q0".into(), 0.1);
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

/// The plant's derivative with one work space (the equations only), and the state and
/// derivative it reads and writes.
type HeldWork<'a> = std::cell::RefCell<(
    lockstep::simulation::Stepper<'a>,
    lockstep::simulation::State,
    lockstep::simulation::State,
)>;

/// The plant's state equation under a command held over one sample.
struct Held<'w, 'a> {
    work: &'w HeldWork<'a>,
    tau: Vec<f64>,
}

impl ode_solvers::System<f64, ode_solvers::DVector<f64>> for Held<'_, '_> {
    fn system(&self, t: f64, y: &ode_solvers::DVector<f64>, dy: &mut ode_solvers::DVector<f64>) {
        let nf = self.tau.len();
        let mut work = self.work.borrow_mut();
        let (stepper, x, d) = &mut *work;
        for a in 0..nf {
            x.q[a] = y[a];
            x.qd[a] = y[nf + a];
        }
        stepper.derivative_into(t, x, &self.tau, &[], d);
        for a in 0..nf {
            dy[a] = d.q[a];
            dy[nf + a] = d.qd[a];
        }
    }
}

/// PD gains [kp, kd] of the Puma's three arm joints (N·m/rad, N·m·s/rad).
const PUMA_PD: [[f64; 2]; 3] = [[300.0, 20.0], [400.0, 30.0], [200.0, 10.0]];

/// The Puma's references (rad): two sines per joint.
fn puma_reference(a: usize, t: f64) -> f64 {
    let tau = std::f64::consts::TAU;
    let (amp, f1, f2) = [(0.5, 0.3, 0.9), (0.4, 0.4, 1.1), (0.4, 0.5, 1.3)][a];
    amp * ((tau * f1 * t).sin() + 0.5 * (tau * f2 * t + 1.0).sin())
}

/// A closed-loop record of `truth`'s Puma arm (q1..q3 free, the wrist locked at 0) written
/// without lockstep's closed loop: the test's own digital controller at 1 kHz (PD on the
/// measured position, velocity (q(k) − q(k−2))/2T, the truth's gravity at the measured
/// positions fed forward, one sample of delay) reading positions with Gaussian noise σ,
/// the plant integrated between samples by Dop853 at a fixed 1e-4 s; the file holds the
/// applied torques, the measured positions and the references.
fn puma_closed_loop_record(truth: &Plant, path: &Path, seconds: f64, sigma: f64) {
    use ode_solvers::DVector;
    use std::fmt::Write as _;
    const T: f64 = 1e-3;
    let model = truth
        .simulator("arm", &[0.0; 6], lockstep::plant::ConsistencyPolicy::Warn)
        .unwrap()
        .model;
    let n = (seconds / T).round() as usize + 1;
    let at_rest = || lockstep::simulation::State::at_rest(vec![0.0; 3]);
    let work: HeldWork = std::cell::RefCell::new((model.stepper(), at_rest(), at_rest()));
    let mut noise = common::independent::Noise(11);
    let mut y = DVector::zeros(6);
    for a in 0..3 {
        y[a] = puma_reference(a, 0.0);
    }
    let gravity = |q: &[f64]| {
        let mut full = [0.0; 6];
        full[..3].copy_from_slice(q);
        let mut g = vec![0.0; 3];
        (model.conf.gravity)(&full, &model.p, &mut g);
        g
    };
    let q0: Vec<f64> = (0..3).map(|a| y[a]).collect();
    let mut applied = gravity(&q0);
    let mut history = vec![q0.clone(), q0.clone()];
    let mut csv =
        String::from("t,tau0,tau1,tau2,tau3,tau4,tau5,q0,q1,q2,q3,q4,q5,qref0,qref1,qref2\n");
    for k in 0..n {
        let t = k as f64 * T;
        let measured: Vec<f64> = (0..3).map(|a| y[a] + sigma * noise.gaussian()).collect();
        let g = gravity(&measured);
        let u: Vec<f64> = (0..3)
            .map(|a| {
                let v = (measured[a] - history[1][a]) / (2.0 * T);
                PUMA_PD[a][0] * (puma_reference(a, t) - measured[a]) - PUMA_PD[a][1] * v + g[a]
            })
            .collect();
        history.remove(1);
        history.insert(0, measured.clone());
        write!(csv, "{t:e}").unwrap();
        // The three arm joints, then the locked wrist's three zeros.
        for v in applied.iter().chain(&[0.0; 3]) {
            write!(csv, ",{v:e}").unwrap();
        }
        for v in measured.iter().chain(&[0.0; 3]) {
            write!(csv, ",{v:e}").unwrap();
        }
        for a in 0..3 {
            write!(csv, ",{:e}", puma_reference(a, t)).unwrap();
        }
        csv.push('\n');
        if k + 1 == n {
            break;
        }
        // Over [t, t + T): the command of the sample before (one sample of delay).
        let system = Held {
            work: &work,
            tau: applied.clone(),
        };
        let mut solver =
            common::independent::fixed_step_dop853(system, (t, t + 1.5 * T), T, y.clone(), 1e-4);
        solver.integrate().expect("Dop853");
        y = solver.y_out()[1].clone();
        applied = u;
    }
    std::fs::write(path, csv).unwrap();
    std::fs::write(
        path.with_extension("toml"),
        "description = \"Puma 560 arm under PD with gravity feed-forward (tests/closed_loop.rs)\"\nconfiguration = \"arm\"\n",
    )
    .unwrap();
}

/// The controller file of [`puma_closed_loop_record`]'s controller.
fn puma_controller(path: &Path) {
    let mut text =
        String::from("configuration = \"arm\"\nperiod = 0.001\ndelay = 1\nstep = 1e-4\n");
    for (a, [kp, kd]) in PUMA_PD.iter().enumerate() {
        text += &format!(
            "\n[joints.q{}]\nlaw = \"pd\"\nkp = {kp}\nkd = {kd}\nvelocity = [0.5, 0.0, -0.5]\nreference = \"qref{a}\"\nfeedforward = \"gravity\"\n",
            a + 1
        );
    }
    std::fs::write(path, text).unwrap();
}

/// A multi-joint closed loop (issue 59): the Puma 560's arm under PD with gravity
/// feed-forward, Coulomb friction 3 and 2 N·m hidden on q2 and q3, data written by the
/// test's own controller and Dop853 with σ = 1e-5 rad on the positions the controller
/// reads. The open-loop simulation of the same data goes far off (its position error more
/// than 100 times the noise); in closed-loop space, from the truth without the Coulomb
/// friction, the diagnosis names Coulomb on one of the two joints, then on the other; each
/// added and refitted by DIDIM and its closed-loop output-error polish, the force error
/// falls to the truth's own on the same data (within 1 %: the noise floor, the part of the
/// commands the controller's noisy readings made) with Fc within 1 %.
#[test]
fn hidden_coulomb_on_two_joints_of_a_puma_under_pd_in_closed_loop_space() {
    use lockstep::effects::{Effect, EffectKind};
    use lockstep::identify::didim::{
        closed_loop_errors, diagnose_closed_loop, didim, DidimOptions,
    };
    let dir = tempfile::tempdir().unwrap();
    let mut truth = Plant::new(
        "puma560",
        vec![
            Effect::on(EffectKind::Viscous, 0),
            Effect::on(EffectKind::Viscous, 1),
            Effect::on(EffectKind::Viscous, 2),
            Effect::on(EffectKind::Coulomb, 1),
            Effect::on(EffectKind::Coulomb, 2),
        ],
    )
    .unwrap();
    for (n, v) in [
        ("Fv_q1", 2.0),
        ("Fv_q2", 2.0),
        ("Fv_q3", 1.0),
        ("Fc_q2", 3.0),
        ("Fc_q3", 2.0),
    ] {
        truth.parameters.insert(n.into(), v);
    }
    let file = dir.path().join("puma_arm.csv");
    let sigma = 1e-5;
    puma_closed_loop_record(&truth, &file, 10.0, sigma);
    let controller = dir.path().join("puma_pd.toml");
    puma_controller(&controller);
    let c = Controller::load(&controller, &truth).unwrap();
    let table = Table::read(&file).unwrap();
    let records = [ClosedLoopRecord::from_table(&table, &truth, &c).unwrap()];
    let floor = closed_loop_errors(&truth, &c, &records).unwrap();
    eprintln!("truth: force {:.4} %, velocity {:.4} %", floor.0, floor.1);
    // Open loop on the recorded torques: far off or diverged.
    {
        use lockstep::simulation::{Hold, InputSignal, State};
        let model = truth
            .simulator("arm", &[0.0; 6], lockstep::plant::ConsistencyPolicy::Warn)
            .unwrap()
            .model;
        let m = &records[0].measurement;
        let tau: Vec<Vec<f64>> = (0..3).map(|a| m.tau[a].clone()).collect();
        let signal = InputSignal {
            t0: m.t[0],
            dt: 1e-3,
            tau: &tau,
            hold: Hold::Zoh,
        };
        let x0 = State::at_rest((0..3).map(|a| m.q[a][0]).collect());
        match model.simulate_at(x0, 1e-4, &signal, &m.t, 1e3) {
            Err(d) => eprintln!("open loop: {}", d.message("?")),
            Ok(traj) => {
                let e: f64 = (0..3)
                    .flat_map(|a| traj.q[a].iter().zip(&m.q[a]).map(|(x, y)| (x - y).powi(2)))
                    .sum::<f64>();
                let rms = (e / (3 * m.t.len()) as f64).sqrt();
                eprintln!("open loop: position RMS error {rms:.3e} rad");
                assert!(rms > 100.0 * sigma, "open loop {rms}");
            }
        }
    }
    let mut plant = truth.clone();
    plant.effects.retain(|e| e.kind != EffectKind::Coulomb);
    plant.parameters.remove("Fc_q2");
    plant.parameters.remove("Fc_q3");
    let options = DidimOptions::default();
    let refit = |p: &Plant| {
        let r = didim(p, &c, &records, &options, &|i, it| {
            eprintln!(
                "  {i}: force {:.4} %, velocity {:.4} %",
                it.force_error, it.velocity_error
            )
        })
        .unwrap();
        assert!(r.converged);
        r.plant
    };
    plant = refit(&plant);
    let mut named = Vec::new();
    for _ in 0..2 {
        let (d, _) = diagnose_closed_loop(&plant, &c, &records, &options.idim, &[]).unwrap();
        let text = lockstep::diagnose::table(&d.findings, 4);
        eprintln!("{text}");
        let f = &d.findings[0];
        assert!(
            f.significant && f.kind == Some(EffectKind::Coulomb),
            "{text}"
        );
        named.push(f.joint.to_string());
        plant = refit(&f.apply(&plant).unwrap());
    }
    named.sort();
    assert_eq!(named, ["q2", "q3"]);
    let last = closed_loop_errors(&plant, &c, &records).unwrap();
    eprintln!(
        "with both: force {:.4} % (truth {:.4} %), Fc {:.4} / {:.4}",
        last.0, floor.0, plant.parameters["Fc_q2"], plant.parameters["Fc_q3"]
    );
    assert!(
        last.0 <= 1.01 * floor.0,
        "force {} truth {}",
        last.0,
        floor.0
    );
    assert!((plant.parameters["Fc_q2"] / 3.0 - 1.0).abs() < 0.01);
    assert!((plant.parameters["Fc_q3"] / 2.0 - 1.0).abs() < 0.01);
}
