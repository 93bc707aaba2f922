//! Torque space on a synthetic 7-joint arm (the Panda, `model/panda.toml`): torques by the
//! generated inverse dynamics along a smooth excitation (positions, velocities and
//! accelerations in closed form: no simulator of lockstep's in the loop), plus friction, an
//! offset, a spring with a rest angle and Stribeck friction, with noise on q and τ. Checked:
//! the base parameters, the nonlinear values fitted by variable projection, and the
//! diagnosis loop that names the hidden spring and adds and refits it in torque space.

use generated::inertia::Xorshift;
use lockstep::effects::{Effect, EffectKind};
use lockstep::identify::idim::{
    observation, predict, relative_error, separable_fit, IdimOptions, Weighting,
};
use lockstep::measurement::Measurement;
use lockstep::plant::Plant;

const NJ: usize = 7;
const RATE: f64 = 500.0;
const SECONDS: f64 = 24.0;
const TORQUE_NOISE: f64 = 0.02;

/// Gaussian samples (Box–Muller on xorshift64*).
fn gauss(rng: &mut Xorshift) -> f64 {
    let u1 = rng.uniform(1e-12, 1.0);
    let u2 = rng.uniform(0.0, 1.0);
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// The truth: the Panda's published rigid body, viscous and Coulomb friction on every
/// joint, offsets on q3 and q5, a spring (Ks 15 N·m/rad, rest angle 0.4 rad) on q1 — the
/// vertical axis, where gravity does not act: on a joint that lifts the arm over a small
/// range, K q is nearly a combination of the gravity columns and only K·qeq stands out — and
/// Stribeck friction (Fc 0.6, Fs 1.4 N·m, vs 0.15 rad/s) on q4.
fn truth() -> Plant {
    let mut p = Plant::new("panda", vec![]).unwrap();
    for j in 0..NJ {
        p.add_effect(Effect::on(EffectKind::Viscous, j)).unwrap();
        p.parameters
            .insert(format!("Fv_q{}", j + 1), 0.4 + 0.1 * j as f64);
        if j != 3 {
            p.add_effect(Effect::on(EffectKind::Coulomb, j)).unwrap();
            p.parameters
                .insert(format!("Fc_q{}", j + 1), 0.5 + 0.05 * j as f64);
        }
    }
    for j in [2, 4] {
        p.add_effect(Effect::on(EffectKind::Offset, j)).unwrap();
        p.parameters.insert(format!("offset_q{}", j + 1), 0.3);
    }
    p.add_effect(Effect::on(EffectKind::Spring, 0)).unwrap();
    p.parameters.insert("Ks_q1".into(), 15.0);
    p.parameters.insert("qeq_q1".into(), 0.4);
    p.add_effect(Effect::on(EffectKind::Stribeck, 3)).unwrap();
    p.parameters.insert("Fc_q4".into(), 0.6);
    p.parameters.insert("Fs_q4".into(), 1.4);
    p.parameters.insert("vs_q4".into(), 0.15);
    p
}

/// The record: q(t) a sum of three sines per joint about the middle of its range, τ from the
/// generated inverse dynamics and the effects' laws written out here, noise on both.
fn record(truth: &Plant) -> Measurement {
    record_with(truth, None)
}

/// [`record`] with joint `frozen` held at its centre.
fn record_with(truth: &Plant, frozen: Option<usize>) -> Measurement {
    let m = truth.model;
    let conf = m.configuration("full").unwrap();
    let p = truth.barycentric(None).unwrap();
    let mut rng = Xorshift(0x5eed_7a57);
    let waves: Vec<Vec<(f64, f64, f64)>> = (0..NJ)
        .map(|_| {
            (0..3)
                .map(|_| {
                    (
                        rng.uniform(0.15, 0.35),
                        rng.uniform(0.1, 0.6),
                        rng.uniform(0.0, std::f64::consts::TAU),
                    )
                })
                .collect()
        })
        .collect();
    let centre = [0.0, 0.2, 0.0, -1.6, 0.0, 1.8, 0.0];
    let n = (SECONDS * RATE) as usize;
    let t: Vec<f64> = (0..n).map(|k| k as f64 / RATE).collect();
    let mut q = vec![vec![0.0; n]; NJ];
    let mut tau = vec![vec![0.0; n]; NJ];
    let v = |name: &str| truth.parameters[name];
    for k in 0..n {
        let mut qk = [0.0; NJ];
        let mut qdk = [0.0; NJ];
        let mut qddk = [0.0; NJ];
        for j in 0..NJ {
            qk[j] = centre[j];
            if frozen == Some(j) {
                continue;
            }
            for &(a, f, ph) in &waves[j] {
                let w = std::f64::consts::TAU * f;
                let x = w * t[k] + ph;
                qk[j] += a * x.sin();
                qdk[j] += a * w * x.cos();
                qddk[j] -= a * w * w * x.sin();
            }
        }
        let mut tk = [0.0; NJ];
        (conf.inverse_dynamics)(&qk, &qdk, &qddk, &p, &mut tk);
        for j in 0..NJ {
            let s = lockstep::effects::sign(qdk[j]);
            tk[j] += v(&format!("Fv_q{}", j + 1)) * qdk[j];
            if j == 3 {
                let e = (-(qdk[j] / v("vs_q4")).powi(2)).exp();
                tk[j] += (v("Fc_q4") + (v("Fs_q4") - v("Fc_q4")) * e) * s;
            } else {
                tk[j] += v(&format!("Fc_q{}", j + 1)) * s;
            }
            if j == 2 || j == 4 {
                tk[j] += 0.3;
            }
            if j == 0 {
                tk[j] += v("Ks_q1") * (qk[0] - v("qeq_q1"));
            }
            // A still joint reads a constant (its encoder's quantum is larger than the noise).
            let noise = 1e-6 * gauss(&mut rng);
            q[j][k] = qk[j] + if frozen == Some(j) { 0.0 } else { noise };
            tau[j][k] = tk[j] + TORQUE_NOISE * gauss(&mut rng);
        }
    }
    Measurement {
        file: "panda_synthetic.csv".into(),
        t,
        tau,
        q,
        qd: vec![None; NJ],
        tau_m: vec![None; NJ],
        notes: Vec::new(),
    }
}

/// The residual RMS of the truth itself on the observation: the noise floor after the
/// filter and the decimation (N·m).
fn floor(truth: &Plant, records: &[Measurement]) -> f64 {
    let obs = observation(truth, "full", records, &options()).unwrap();
    let e = &obs.y - predict(truth, &obs).unwrap();
    (e.norm_squared() / e.len() as f64).sqrt()
}

fn options() -> IdimOptions {
    IdimOptions {
        cutoff_hz: 10.0,
        filter_order: 4,
        decimation: 10,
        // The record starts and ends in motion: the zero-phase filter's edges are left out.
        window: Some((0.5, SECONDS - 0.5)),
        min_speed: None,
        differentiator: lockstep::signal::Differentiator::Central,
        trim_moving_edges: false,
    }
}

/// The linear least squares of the loop's commands, for variable projection.
fn linear(
    records: &[Measurement],
) -> impl Fn(
    &Plant,
    &lockstep::identify::idim::Observation,
) -> anyhow::Result<lockstep::identify::idim::Fit>
       + '_ {
    move |p: &Plant, obs| {
        let locked_at = lockstep::identify::idim::locked_positions(records);
        Ok(lockstep::identify::idim::base_fit(
            p,
            obs,
            "full",
            &locked_at,
            &options(),
            Weighting::Ols,
        )?
        .0)
    }
}

#[test]
fn a_spring_rest_angle_and_a_stribeck_speed_are_fitted_in_torque_space() {
    let truth = truth();
    let records = vec![record(&truth)];
    // The right structure from a wrong start: rest angle 0, Stribeck speed 0.5 rad/s.
    let mut start = truth.clone();
    start.parameters.insert("qeq_q1".into(), 0.0);
    start.parameters.insert("vs_q4".into(), 0.5);
    let s = separable_fit(&start, "full", &records, &options(), &linear(&records)).unwrap();
    let mut fitted = s.plant.clone();
    s.fit.apply(&mut fitted).unwrap();
    let nl = |n: &str| s.nonlinear.iter().find(|x| x.0 == n).unwrap().1;
    let within = |what: &str, x: f64, want: f64, pct: f64| {
        assert!(
            (x - want).abs() <= pct / 100.0 * want.abs(),
            "{what}: {x} against {want} (±{pct} %)"
        );
    };
    within("qeq_q1", nl("qeq_q1"), 0.4, 1.0);
    within("vs_q4", nl("vs_q4"), 0.15, 5.0);
    within("Ks_q1", s.fit.get("Ks_q1").unwrap(), 15.0, 1.0);
    within("Fs_q4", s.fit.get("Fs_q4").unwrap(), 1.4, 5.0);
    within("Fc_q4", s.fit.get("Fc_q4").unwrap(), 0.6, 5.0);
    // The base parameters where the data determine them to 0.5 %: within 1 % of the truth's
    // combinations (β = θ_kept + Σ k θ_dependent).
    let tv = truth.values_with_barycentric().unwrap();
    let mut checked = 0;
    for b in &s.fit.base {
        if b.std > 0.005 * b.value.abs() {
            continue;
        }
        let want = tv[&b.parameter.name]
            + b.parameter
                .terms
                .iter()
                .map(|(k, n)| k * tv[n])
                .sum::<f64>();
        within(&b.parameter.to_string(), b.value, want, 1.0);
        checked += 1;
    }
    assert!(
        checked >= 5,
        "only {checked} base parameters determined to 0.5 %"
    );
    // The physically consistent standard set nearest to this fit and to the published
    // values: every link a body.
    let c = lockstep::identify::consistent::consistent_parameters(
        &s.observation,
        &s.plant,
        &s.fit,
        &Default::default(),
    )
    .unwrap();
    let mut consistent = s.plant.clone();
    c.apply(&mut consistent).unwrap();
    let conf = consistent.model.configuration("full").unwrap();
    let reasons = lockstep::identify::idim::implausible(&consistent, conf).unwrap();
    assert!(reasons.is_empty(), "{reasons:?}");
    assert!(c.consistent_error <= c.unconstrained_error * 1.05);
    // At the noise floor: the residual's RMS is the truth's own.
    let obs = &s.observation;
    let e = &obs.y - predict(&fitted, obs).unwrap();
    let rms = (e.norm_squared() / e.len() as f64).sqrt();
    let floor = floor(&truth, &records);
    assert!(
        rms <= 1.02 * floor,
        "residual RMS {rms}, the truth's {floor}"
    );
}

#[test]
fn the_hidden_spring_is_named_added_and_refitted_in_torque_space() {
    let truth = truth();
    let records = vec![record(&truth)];
    // The plant without the spring, its other values fitted.
    let mut plant = truth.clone();
    plant.effects.retain(|e| e.kind != EffectKind::Spring);
    plant.parameters.remove("Ks_q1");
    plant.parameters.remove("qeq_q1");
    let s = separable_fit(&plant, "full", &records, &options(), &linear(&records)).unwrap();
    let mut start = s.plant.clone();
    s.fit.apply(&mut start).unwrap();
    let before = relative_error(&s.observation.y, &predict(&start, &s.observation).unwrap());
    let done = lockstep::diagnose::torque::apply_all_significant(
        &start,
        "full",
        &records,
        (&options(), &[]),
        lockstep::diagnose::apply::max_applied_steps(NJ),
        &|_| {},
    )
    .unwrap();
    let first = done
        .steps
        .iter()
        .find_map(|(f, _)| f.as_ref())
        .expect("a step");
    assert_eq!(
        (first.joint.as_str(), first.kind),
        ("q1", Some(EffectKind::Spring)),
        "first step {} on {}",
        first.name,
        first.joint
    );
    let qeq = done.plant.parameters["qeq_q1"];
    assert!((qeq - 0.4).abs() < 0.004, "qeq_q1 = {qeq}");
    let obs = observation(&done.plant, "full", &records, &options()).unwrap();
    let e = &obs.y - predict(&done.plant, &obs).unwrap();
    let rms = (e.norm_squared() / e.len() as f64).sqrt();
    let after = relative_error(&obs.y, &predict(&done.plant, &obs).unwrap());
    let floor = floor(&truth, &records);
    eprintln!(
        "hidden spring: {before:.3} % -> {after:.3} %, residual RMS {rms:.4} N·m (truth {floor:.4})"
    );
    assert!(
        rms <= 1.02 * floor,
        "residual RMS {rms}, the truth's {floor}"
    );
}

#[test]
fn a_joint_the_record_does_not_move_is_named_with_its_excitation() {
    // q6 held still (its encoder reads a constant): the columns that only its motion
    // separates are dependent in these data but not structurally; IDIM says that q6 does
    // not move and which of its terms that leaves undetermined.
    let truth = truth();
    let records = vec![record_with(&truth, Some(5))];
    let e = match separable_fit(&truth, "full", &records, &options(), &linear(&records)) {
        Ok(_) => panic!("a record without q6's motion was fitted"),
        Err(e) => format!("{e:#}"),
    };
    assert!(
        e.contains("joint 'q6' does not move in these records"),
        "{e}"
    );
    assert!(e.contains("too little excitation"), "{e}");
}

#[test]
fn a_seven_joint_report_fits_a_screen_and_three_megabytes() {
    // The synthetic Panda record as a file, its plant identified, its report: every figure
    // at most 1500 px tall, the self-contained HTML at most 3 MB.
    let truth = truth();
    let r = record(&truth);
    let d = tempfile::tempdir().unwrap();
    let csv = d.path().join("panda7.csv");
    let mut text = String::from("t");
    for j in 0..NJ {
        text.push_str(&format!(",tau{j}"));
    }
    for j in 0..NJ {
        text.push_str(&format!(",q{j}"));
    }
    text.push('\n');
    for k in 0..r.t.len() {
        text.push_str(&format!("{}", r.t[k]));
        for j in 0..NJ {
            text.push_str(&format!(",{}", r.tau[j][k]));
        }
        for j in 0..NJ {
            text.push_str(&format!(",{}", r.q[j][k]));
        }
        text.push('\n');
    }
    std::fs::write(&csv, text).unwrap();
    let plant = d.path().join("plant.toml");
    truth.save(&plant).unwrap();
    let out = d.path().join("rep");
    let run = std::process::Command::new(env!("CARGO_BIN_EXE_lockstep"))
        .args(["report", "--plant"])
        .arg(&plant)
        .arg("--data")
        .arg(&csv)
        .args([
            "--config", "full", "--space", "torque", "--cutoff", "10", "--out",
        ])
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let html = std::fs::metadata(out.join("report.html")).unwrap().len();
    assert!(html <= 3_000_000, "report.html is {html} bytes");
    for j in 1..=NJ {
        let png = std::fs::read(out.join(format!("panda7_q{j}.png"))).unwrap();
        let height = u32::from_be_bytes([png[20], png[21], png[22], png[23]]);
        assert!(height <= 1600, "q{j}: {height} px tall");
    }
}
