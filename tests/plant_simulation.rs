//! The full plant on the Freedom 6S: Appendix D plant files, the consistency check before
//! simulation, input holds and output resampling, the tendon-coupling beat (4.3.4), the
//! friction position bias, static Stribeck friction, RK4 convergence on the coupled-method
//! parameters, and measurement files (CSV and MAT) round trips.

use lockstep::effects::{Effect, EffectKind};
use lockstep::measurement::{Measurement, Table};
use lockstep::plant::{ConsistencyPolicy, Plant};
use lockstep::simulation::{Hold, InputSignal, Integrator, State};
use std::path::{Path, PathBuf};

fn plant_file(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("model/plants")
        .join(format!("freedom6s_appendix_d_{name}.toml"))
}

/// The coupled-method plant with I4_33 made positive (issue 5's synthetic truth).
fn coupled_consistent() -> Plant {
    let mut p = Plant::load(&plant_file("coupled")).unwrap();
    p.parameters.insert("I4_33".into(), 1.7449e-4);
    p
}

#[test]
fn appendix_d_plant_files_load_with_the_ocr_fixes() {
    let init = Plant::load(&plant_file("initial")).unwrap();
    let iso = Plant::load(&plant_file("isolated")).unwrap();
    let cpl = Plant::load(&plant_file("coupled")).unwrap();
    assert_eq!(init.parameters["Ks_q1"], 1.5694e-1);
    assert_eq!(iso.parameters["Ks_q2"], 4.59e-2);
    assert_eq!(iso.parameters["sigma1_q3"], 9e-4);
    assert_eq!(cpl.parameters["qeq_q0"], -2.1791e-2);
    assert_eq!(cpl.parameters["m7"], 6.0061e-2);
    assert_eq!(cpl.parameters["sigma2_q5"], 0.0019215);
    // Thesis G54 = 0.20362 enters τ'_4 with a minus sign.
    assert_eq!(cpl.parameters["G_q5_to_q4"], -0.20362);
    assert_eq!(cpl.parameters["G_q4_to_q5"], 1.01);
    // 59 effect parameters + 64 Appendix D inertial values + 6 symbols that appear nowhere.
    assert_eq!(cpl.parameters.len(), 129);
    assert_eq!(iso.parameters.len(), 129 - 5);
    // Only the initial-guess file carries bounds: the thesis rule on the rigid body.
    assert_eq!(init.bounds["m2"], (0.1972 * 0.5, 0.1972 * 1.5));
    let (lo, hi) = init.bounds["x2"];
    assert!((lo + 2.6e-3 * 1.3).abs() < 1e-15 && (hi + 2.6e-3 * 0.7).abs() < 1e-15);
    let (lo, hi) = init.bounds["I2_11"];
    assert!((lo + 1.518e-2 * 0.2).abs() < 1e-15 && (hi - 1.518e-2 * 2.2).abs() < 1e-15);
}

#[test]
fn consistency_is_checked_before_every_simulation() {
    let cpl = Plant::load(&plant_file("coupled")).unwrap();
    let q = [0.0; 6];
    // Link L4 (I4_33 < 0) enters k3 but not k1.
    let e = cpl
        .simulator("k3", &q, ConsistencyPolicy::Refuse)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("link 'L4'")
            && e.contains("not positive definite")
            && e.contains("--allow-inconsistent"),
        "{e}"
    );
    let warned = cpl.simulator("k3", &q, ConsistencyPolicy::Warn).unwrap();
    assert!(warned
        .findings
        .iter()
        .any(|f| f.link == "L4" && f.is_blocking()));
    let k1 = cpl.simulator("k1", &q, ConsistencyPolicy::Refuse).unwrap();
    // Only link L7 enters k1; its tensor violates the triangle inequality (reported, not blocking).
    assert!(k1
        .findings
        .iter()
        .all(|f| f.link == "L7" && !f.is_blocking()));
    assert!(!k1.findings.is_empty());
    // With I4_33 positive, every configuration simulates.
    let fixed = coupled_consistent();
    for c in fixed.model.configurations {
        fixed
            .simulator(c.name, &q, ConsistencyPolicy::Refuse)
            .unwrap();
    }
    // The initial guess has negative diagonal inertias (I1_33, I2_33, I3_11, I4_33, I5_33).
    let init = Plant::load(&plant_file("initial")).unwrap();
    let p = init.barycentric(init.model.configuration("k5")).unwrap();
    let bad: Vec<String> = init
        .consistency(&p, None)
        .into_iter()
        .filter(|f| f.is_blocking())
        .map(|f| f.link)
        .collect();
    assert_eq!(bad, vec!["L1", "L2", "L5", "L3", "L4"]);
}

#[test]
fn zero_order_hold_and_linear_interpolation() {
    let tau = vec![vec![0.0, 1.0, 3.0]];
    let s = |hold| InputSignal {
        t0: 10.0,
        dt: 0.5,
        tau: &tau,
        hold,
    };
    let at = |hold, t| {
        let mut o = [0.0];
        s(hold).at(t, &mut o);
        o[0]
    };
    assert_eq!(at(Hold::Zoh, 10.25), 0.0);
    assert_eq!(at(Hold::Zoh, 10.5), 1.0);
    assert_eq!(at(Hold::Zoh, 10.5 - 1e-12), 1.0); // a stage time at a sample up to rounding
    assert_eq!(at(Hold::Zoh, 99.0), 3.0);
    assert_eq!(at(Hold::Linear, 10.25), 0.5);
    assert_eq!(at(Hold::Linear, 10.75), 2.0);
    assert_eq!(at(Hold::Linear, 9.0), 0.0);
}

/// The continuous holds against a signal known between its samples: a 5 Hz sinusoid
/// sampled at 100 Hz (ωh = 0.31), read at 997 times inside the record (away from its
/// ends, where the reconstruction takes the end values as held). Reference errors: the
/// linear interpolation's h²ω²/8 = 1.2 % of the amplitude; the Catmull–Rom cubic's is
/// O((ωh)³); the band-limited reconstruction's only the window's truncation.
#[test]
fn continuous_holds_reconstruct_a_sampled_sinusoid() {
    let (dt, f) = (0.01, 5.0);
    let w = 2.0 * std::f64::consts::PI * f;
    let u = |t: f64| (w * t + 0.3).sin();
    let tau = vec![(0..400).map(|k| u(k as f64 * dt)).collect::<Vec<f64>>()];
    let worst = |hold| {
        let s = InputSignal {
            t0: 0.0,
            dt,
            tau: &tau,
            hold,
        };
        let mut e: f64 = 0.0;
        for i in 0..997 {
            let t = 1.0 + i as f64 * 0.002003;
            let mut o = [0.0];
            s.at(t, &mut o);
            let mut left = [0.0];
            s.before(t, &mut left);
            assert_eq!(o, left, "{hold}: a continuous hold has no jump at t = {t}");
            e = e.max((o[0] - u(t)).abs());
        }
        e
    };
    let (linear, cubic, band) = (
        worst(Hold::Linear),
        worst(Hold::Cubic),
        worst(Hold::Bandlimited),
    );
    assert!((0.008..0.0125).contains(&linear), "linear {linear}");
    assert!(cubic < 0.004 && cubic < 0.5 * linear, "cubic {cubic}");
    assert!(band < 1e-5, "band-limited {band}");
    // Exact at the samples; constants reproduced; a quadratic exact under the cubic.
    let ramp: Vec<Vec<f64>> = vec![(0..50).map(|k| (k as f64 * 0.1).powi(2)).collect()];
    for hold in [Hold::Cubic, Hold::Bandlimited] {
        let s = InputSignal {
            t0: 0.0,
            dt: 1.0,
            tau: &tau,
            hold,
        };
        let mut o = [0.0];
        s.at(37.0, &mut o);
        assert_eq!(o[0], tau[0][37], "{hold} at a sample");
        let c = vec![vec![2.5; 40]];
        let s = InputSignal { tau: &c, ..s };
        s.at(17.3, &mut o);
        assert!((o[0] - 2.5).abs() < 1e-14, "{hold}: constant {}", o[0]);
    }
    let s = InputSignal {
        t0: 0.0,
        dt: 1.0,
        tau: &ramp,
        hold: Hold::Cubic,
    };
    let mut o = [0.0];
    s.at(20.37, &mut o);
    assert!(
        (o[0] - (2.037f64).powi(2)).abs() < 1e-12,
        "cubic on a quadratic {}",
        o[0]
    );
}

/// k1 of the coupled plant with linear friction (viscous) so the response is a sum of
/// sinusoids, driven by cosines at ω4 on joint 4 and ω5 on joint 5.
fn k1_response(coupling: bool, w4: f64, w5: f64, t_end: f64) -> (Vec<f64>, Vec<Vec<f64>>) {
    let mut p = coupled_consistent();
    p.effects.retain(|e| {
        matches!(
            e.kind,
            EffectKind::Gain | EffectKind::Spring | EffectKind::InputCoupling
        )
    });
    if !coupling {
        p.effects.retain(|e| e.kind != EffectKind::InputCoupling);
    }
    for j in [4, 5] {
        p.add_effect(Effect::on(EffectKind::Viscous, j)).unwrap();
        p.parameters.insert(format!("Fv_q{j}"), 2e-3);
    }
    let s = p
        .simulator("k1", &[0.0; 6], ConsistencyPolicy::Refuse)
        .unwrap();
    let dt = 0.01;
    let n = (t_end / dt) as usize + 1;
    let t: Vec<f64> = (0..n).map(|k| k as f64 * dt).collect();
    let tau = vec![
        t.iter()
            .map(|&x| 0.002 * (w4 * x).cos())
            .collect::<Vec<_>>(),
        t.iter()
            .map(|&x| 0.002 * (w5 * x).cos())
            .collect::<Vec<_>>(),
    ];
    let input = InputSignal {
        t0: 0.0,
        dt,
        tau: &tau,
        hold: Hold::Linear,
    };
    let tr = s
        .model
        .simulate_at(
            State::at_rest(vec![0.0, 0.0]),
            1.0 / 6000.0,
            &input,
            &t,
            100.0,
        )
        .unwrap();
    (t, tr.q)
}

/// Amplitude of the component of `x` at `w` (rad/s) over the second half of the record.
fn amplitude_at(t: &[f64], x: &[f64], w: f64) -> f64 {
    let h = t.len() / 2;
    let (mut c, mut s) = (0.0, 0.0);
    for k in h..t.len() {
        c += x[k] * (w * t[k]).cos();
        s += x[k] * (w * t[k]).sin();
    }
    2.0 * (c * c + s * s).sqrt() / (t.len() - h) as f64
}

#[test]
fn tendon_coupling_beats_at_the_difference_frequency() {
    // Thesis 4.3.4: joints 4 and 5 driven at close frequencies. With the tendon coupling
    // (G45 = 1.01: joint 5 receives joint 4's command), joint 5 carries ω4 as well as its own
    // ω5 and beats at ω4 − ω5; without it, the rigid-body coupling alone leaves joint 5
    // nearly pure (q4 carries some ω5 either way, through the inertia matrix).
    let (w4, w5) = (
        2.0 * std::f64::consts::PI * 0.5,
        2.0 * std::f64::consts::PI * 0.4,
    );
    let (t, with) = k1_response(true, w4, w5, 200.0);
    let (_, without) = k1_response(false, w4, w5, 200.0);
    let q5 = |q: &Vec<Vec<f64>>| q[1].clone();
    let (a_with, own_with) = (
        amplitude_at(&t, &q5(&with), w4),
        amplitude_at(&t, &q5(&with), w5),
    );
    let (a_without, own_without) = (
        amplitude_at(&t, &q5(&without), w4),
        amplitude_at(&t, &q5(&without), w5),
    );
    assert!(
        a_with > 10.0 * a_without && a_with > 0.3 * own_with && a_without < 0.05 * own_without,
        "q5 at ω4: {a_with:.3e} with coupling, {a_without:.3e} without; at ω5 {own_with:.3e}, {own_without:.3e}"
    );
    // The beat: x = a cos ω4 t + b cos ω5 t makes x² carry a·b at ω4 − ω5. Over 0.2..1.5
    // rad/s the spectrum of x² peaks there, with about that amplitude.
    let x = q5(&with);
    let h = t.len() / 2;
    let mean = x[h..].iter().sum::<f64>() / (t.len() - h) as f64;
    let sq: Vec<f64> = x.iter().map(|v| (v - mean).powi(2)).collect();
    let beat = w4 - w5;
    let best = (20..150)
        .map(|k| k as f64 * 0.01)
        .max_by(|a, b| {
            amplitude_at(&t, &sq, *a)
                .partial_cmp(&amplitude_at(&t, &sq, *b))
                .unwrap()
        })
        .unwrap();
    let depth = amplitude_at(&t, &sq, beat) / (a_with * own_with);
    assert!(
        (0.7..1.3).contains(&depth),
        "beat amplitude / (a·b) = {depth:.3}"
    );
    assert!(
        (best - beat).abs() < 0.03,
        "envelope peaks at {best} rad/s, beat {beat:.4}"
    );
}

#[test]
fn friction_bias_scales_friction_below_the_equilibrium() {
    let mut p = Plant::new("freedom6s", vec![]).unwrap();
    p.parameters = coupled_consistent().parameters;
    p.parameters
        .retain(|k, _| !k.contains('_') || k.starts_with('I'));
    for e in [EffectKind::Coulomb, EffectKind::FrictionBias] {
        p.add_effect(Effect::on(e, 5)).unwrap();
    }
    p.parameters.insert("Fc_q5".into(), 0.01);
    p.parameters.insert("FrictionBias_q5".into(), 1.8);
    p.parameters.insert("qeq_q5".into(), 0.1);
    let s = p
        .simulator("c2", &[0.0; 6], ConsistencyPolicy::Refuse)
        .unwrap()
        .model;
    assert_eq!(s.friction(0, 0.2, 1.0, 0.0).0, 0.01);
    assert!((s.friction(0, 0.0, 1.0, 0.0).0 - 0.018).abs() < 1e-15);
    assert!((s.friction(0, 0.0, -1.0, 0.0).0 + 0.018).abs() < 1e-15);
}

#[test]
fn static_stribeck_friction_reaches_its_terminal_velocity() {
    // EMPS mass with Stribeck + viscous friction under a constant force τ: the terminal
    // velocity solves τ = Fc + (Fs − Fc) e^{−(v/vs)²} + Fv v.
    let mut p = Plant::new(
        "emps",
        vec![
            Effect::on(EffectKind::Stribeck, 0),
            Effect::on(EffectKind::Viscous, 0),
        ],
    )
    .unwrap();
    for (k, v) in [
        ("M", 95.0),
        ("Fc_q0", 20.0),
        ("Fs_q0", 35.0),
        ("vs_q0", 0.05),
        ("Fv_q0", 200.0),
    ] {
        p.parameters.insert(k.into(), v);
    }
    let s = p
        .simulator("full", &[0.0], ConsistencyPolicy::Refuse)
        .unwrap()
        .model;
    let tau = 60.0;
    let mut x = State::at_rest(vec![0.0]);
    x.qd[0] = 0.1;
    let x = s
        .simulate(x, 1e-3, 20_000, 10.0, |_, u| u[0] = tau, |_, _| {})
        .unwrap();
    let v = x.qd[0];
    let residual = tau - (20.0 + 15.0 * (-(v / 0.05f64).powi(2)).exp() + 200.0 * v);
    assert!(
        residual.abs() < 1e-8 && (v - 0.2).abs() < 1e-6,
        "v = {v}, residual {residual}"
    );
}

/// Configuration `config` (free joints `free`) of the coupled-method plant, and the Table
/// 4.7 inputs of its free joints for `secs` seconds at 100 Hz: (model, sample times,
/// torques per free joint).
fn table_4_7(
    config: &str,
    free: &[usize],
    secs: f64,
) -> (lockstep::simulation::PlantModel, Vec<f64>, Vec<Vec<f64>>) {
    let p = coupled_consistent();
    let s = p
        .simulator(config, &[0.0; 6], ConsistencyPolicy::Refuse)
        .unwrap()
        .model;
    let ex = lockstep::excitation::Excitations::bundled(p.model).unwrap();
    let test = ex.table("4.7").unwrap().test(None).unwrap();
    let (t, u, _) = test.sample(6, free, secs, 100.0);
    (s, t, free.iter().map(|&j| u[j].clone()).collect())
}

/// k2 (joints 3, 4, 5) of [`table_4_7`].
fn k2_table_4_7(secs: f64) -> (lockstep::simulation::PlantModel, Vec<f64>, Vec<Vec<f64>>) {
    table_4_7("k2", &[3, 4, 5], secs)
}

/// Largest |x − y| over all joints and samples.
fn max_deviation(x: &[Vec<f64>], y: &[Vec<f64>]) -> f64 {
    x.iter()
        .zip(y)
        .flat_map(|(p, q)| p.iter().zip(q).map(|(u, v)| (u - v).abs()))
        .fold(0.0, f64::max)
}

#[test]
fn the_thesis_step_diverges_near_the_wrist_singularity_and_halving_it_converges() {
    // k2 (joints 3, 4, 5) with the full coupled-method plant on the Table 4.7 inputs: at the
    // thesis's 1/6000 s, RK4 leaves its stability region (docs/src/design/digest.md §2: a mode of link 7's
    // tiny inertia against LuGre damping) and the simulator reports the time and joint;
    // 1/12000 s and below converge.
    let (s, t, tau) = k2_table_4_7(5.0);
    let input = InputSignal {
        t0: 0.0,
        dt: 0.01,
        tau: &tau,
        hold: Hold::Linear,
    };
    let run = |h: f64| s.simulate_at(State::at_rest(vec![0.0; 3]), h, &input, &t, 100.0);
    let d = run(1.0 / 6000.0).unwrap_err();
    assert_eq!(d.joint, 1, "{d}"); // free joint 1 of k2 is q4
    assert!(
        d.t > 0.0 && d.t < 5.0 && d.to_string().contains("(step 0.000166"),
        "{d}"
    );
    let (a, b, c) = (
        run(1.0 / 12000.0).unwrap().q,
        run(1.0 / 24000.0).unwrap().q,
        run(1.0 / 48000.0).unwrap().q,
    );
    let (d1, d2) = (max_deviation(&a, &b), max_deviation(&b, &c));
    // The friction laws have kinks (|v|, sign v), so the order is below four here (the
    // smooth case in tests/simulation.rs shows 16×); the changes are far below the 1e-4 rad
    // encoder step and shrink with the step.
    assert!(d1 < 1e-6, "1/12000 vs 1/24000: {d1:.3e} rad");
    assert!(d1 / d2 > 3.0, "ratio {:.2} ({d1:.3e}, {d2:.3e})", d1 / d2);
}

#[test]
fn etdrk4_runs_the_wrist_at_a_step_where_rk4_diverges() {
    // The same k2 run: RK4 diverges at 1/2000 s (joint 4's LuGre damping over its inertia puts
    // an eigenvalue near −2.5e4 s⁻¹ on the state Jacobian); ETDRK4 at 1/2000 s, which takes
    // that damping exactly, stays within 5e-5 rad (a quarter of the synthetic data's noise σ)
    // of RK4 at 1/48000 s over a 10 s run that spins joint 4 through 10 rad with many
    // stick-slip switches, and within 2e-6 rad at 1/4000 s.
    let (mut s, t, tau) = k2_table_4_7(10.0);
    let input = InputSignal {
        t0: 0.0,
        dt: 0.01,
        tau: &tau,
        hold: Hold::Zoh,
    };
    let run = |s: &lockstep::simulation::PlantModel, h: f64| {
        s.simulate_at(State::at_rest(vec![0.0; 3]), h, &input, &t, 100.0)
    };
    assert!(run(&s, 1.0 / 2000.0).is_err());
    let reference = run(&s, 1.0 / 48000.0).unwrap().q;
    s.integrator = Integrator::Etdrk4;
    let diff = |x: &Vec<Vec<f64>>| max_deviation(x, &reference);
    let spread = reference
        .iter()
        .map(|q| q.iter().fold(0.0_f64, |m, v| m.max(v.abs())))
        .fold(0.0, f64::max);
    let d2000 = diff(&run(&s, 1.0 / 2000.0).unwrap().q);
    let d4000 = diff(&run(&s, 1.0 / 4000.0).unwrap().q);
    assert!(spread > 1.0, "the run moves: {spread:.3e} rad");
    assert!(d2000 < 5e-5, "1/2000 s: {d2000:.3e} rad");
    assert!(d4000 < 2e-6, "1/4000 s: {d4000:.3e} rad");
}

/// k3 (joints 2..5) on the Table 4.7 inputs for 40 s, the identification files' length,
/// from rest at zero, by `integrator` at step `h` (s); with `observer` = (ω, y) the
/// predictor pulled toward positions y (`PlantModel::predict_at`). Positions per free joint
/// at 100 Hz (rad).
fn k3_40_s(integrator: Integrator, h: f64, observer: Option<(f64, &[Vec<f64>])>) -> Vec<Vec<f64>> {
    let (mut s, t, tau) = table_4_7("k3", &[2, 3, 4, 5], 40.0);
    s.integrator = integrator;
    let input = InputSignal {
        t0: 0.0,
        dt: 0.01,
        tau: &tau,
        hold: Hold::Zoh,
    };
    s.predict_at(State::at_rest(vec![0.0; 4]), h, &input, observer, &t, 100.0)
        .unwrap()
        .q
}

#[test]
fn over_a_40_s_file_etdrk4_needs_steps_near_rk4s_for_the_noise_level() {
    // k3 (joints 2..5) on the Table 4.7 inputs for 40 s, the identification files' length.
    // The trajectory amplifies a small early difference a thousandfold by the time the wrist
    // whips round at up to 47 rad/s (after 20 s), so what counts is the local error, and
    // ETDRK4's, from the explicit part (the rigid body's fast nonlinear terms, the friction
    // away from the frozen slopes), is far above RK4's at 1/12000 s: against RK4 at 1/24000 s,
    // ETDRK4 deviates by 3.0e-3 rad at 1/2000 s (15 × the synthetic noise σ = 2e-4 rad) and
    // 2.4e-4 rad at 1/4000 s (fourth order: 12.5×), RK4 at 1/12000 s by 2.1e-6 rad. Fits of
    // these files therefore run RK4 at 1/12000 s; ETDRK4's stable 1/2000 s serves shorter
    // or less sensitive runs (the 10 s k2 run above: 2.3e-5 rad).
    let run = |integrator: Integrator, h: f64| k3_40_s(integrator, h, None);
    let reference = run(Integrator::Rk4, 1.0 / 24000.0);
    let rk4 = max_deviation(&run(Integrator::Rk4, 1.0 / 12000.0), &reference);
    let e2000 = max_deviation(&run(Integrator::Etdrk4, 1.0 / 2000.0), &reference);
    let e4000 = max_deviation(&run(Integrator::Etdrk4, 1.0 / 4000.0), &reference);
    assert!(rk4 < 5e-6, "RK4 1/12000 s: {rk4:.3e} rad");
    assert!(
        e2000 / e4000 > 8.0,
        "ETDRK4 order: {e2000:.3e} → {e4000:.3e} rad"
    );
    assert!(
        (1e-3..1e-2).contains(&e2000) && (1e-4..1e-3).contains(&e4000),
        "ETDRK4 1/2000 s {e2000:.3e}, 1/4000 s {e4000:.3e} rad"
    );
}

#[test]
fn under_the_predictors_pull_etdrk4_at_1_2000_s_serves_a_40_s_file_as_a_warm_up() {
    // The same k3 file as above, now predicted: the state pulled toward "measured" positions
    // (RK4 at 1/24000 s) by the output injection of the identification's predictor stages
    // (`--predictor 100,30,10,3,1`). The pull damps an early difference instead of letting
    // the trajectory amplify it, so ETDRK4 at 1/2000 s, 15 × the noise σ = 2e-4 rad off on
    // the whole file, deviates from RK4 at 1/24000 s by 2.8e-5, 3.6e-5, 5.0e-5 rad at
    // ω = 100, 30, 10 rad/s and, the pull weakening, 1.5e-4 and 2.2e-4 rad at 3 and 1 rad/s
    // (at 1/4000 s: 4.6e-6 … 3.9e-5). Good enough for the warm-up stages that
    // `--predictor-step 1/2000` runs (the whole files' stage then ends the fit on RK4 at
    // 1/12000 s and removes what is left), not for the fit itself.
    let y = k3_40_s(Integrator::Rk4, 1.0 / 24000.0, None);
    let predict = |integrator: Integrator, h: f64, omega: f64| {
        k3_40_s(integrator, h, Some((omega, y.as_slice())))
    };
    for omega in [100.0, 30.0, 10.0, 3.0, 1.0] {
        let reference = predict(Integrator::Rk4, 1.0 / 24000.0, omega);
        let d2000 = max_deviation(
            &predict(Integrator::Etdrk4, 1.0 / 2000.0, omega),
            &reference,
        );
        let d4000 = max_deviation(
            &predict(Integrator::Etdrk4, 1.0 / 4000.0, omega),
            &reference,
        );
        let bound = if omega >= 10.0 { 6e-5 } else { 3e-4 };
        assert!(
            d2000 < bound,
            "ω = {omega} rad/s: ETDRK4 1/2000 s {d2000:.3e} rad"
        );
        // Converging with the step (not rounding, not a wrong reference).
        assert!(
            d2000 / d4000 > 3.0 && d4000 > 1e-7,
            "ω = {omega} rad/s: 1/2000 s {d2000:.3e}, 1/4000 s {d4000:.3e} rad"
        );
    }
}

#[test]
fn measurement_files_round_trip_in_csv_and_mat() {
    let d = tempfile::tempdir().unwrap();
    let n = 50;
    let t: Vec<f64> = (0..n).map(|k| k as f64 * 0.01).collect();
    let m = Measurement {
        file: d.path().join("x.csv"),
        t: t.clone(),
        tau: vec![
            t.iter().map(|x| (3.0 * x).sin() / 7.0).collect(),
            vec![0.0; n],
        ],
        q: vec![t.iter().map(|x| x.cos() * 1e-3).collect(), vec![0.25; n]],
        qd: vec![Some(t.iter().map(|x| -x.sin()).collect()), None],
        tau_m: vec![None, Some(vec![1.0 / 3.0; n])],
        notes: Vec::new(),
    };
    for ext in ["csv", "mat"] {
        let path = d.path().join(format!("x.{ext}"));
        m.write(&path, &["q0", "q1"]).unwrap();
        let back = Measurement::read(&path, &["q0", "q1"]).unwrap();
        assert_eq!(back.t, m.t, "{ext}");
        assert_eq!(back.tau, m.tau, "{ext}");
        assert_eq!(back.q, m.q, "{ext}");
        assert_eq!(back.qd, m.qd, "{ext}");
        assert_eq!(back.tau_m, m.tau_m, "{ext}");
        // No temporary file is left beside it.
        assert_eq!(
            std::fs::read_dir(d.path()).unwrap().count(),
            if ext == "csv" { 1 } else { 2 }
        );
    }
}

#[test]
fn mat_files_from_other_tools_and_bad_mat_files() {
    // Written by SciPy 1.17 (header "MATLAB 5.0 MAT-file Platform: …", no comma): t, tau0 and
    // a 12×2 matrix q giving q0 and q1; a text variable is skipped.
    let f = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/scipy_v5.mat");
    let m = Measurement::read(&f, &["q0"]).unwrap();
    assert_eq!(m.len(), 12);
    assert!((m.q[0][3] - (0.03f64).sin()).abs() < 1e-15);
    let table = Table::read(&f).unwrap();
    assert_eq!(table.get("q1").unwrap().unwrap()[3], 2.0 * (0.03f64).sin());
    let e = Measurement::read(&f, &["q0", "q1"])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("missing column 'tau_q1'") && e.contains("variables are"),
        "{e}"
    );
    let d = tempfile::tempdir().unwrap();
    let v73 = d.path().join("v73.mat");
    let mut bytes = b"MATLAB 7.3 MAT-file, Platform: GLNXA64".to_vec();
    bytes.resize(512, 0);
    std::fs::write(&v73, bytes).unwrap();
    let e = Measurement::read(&v73, &["q0"]).unwrap_err().to_string();
    assert!(e.contains("v7.3") && e.contains("-v7"), "{e}");
    let junk = d.path().join("junk.mat");
    std::fs::write(&junk, b"not a mat file at all").unwrap();
    let e = Measurement::read(&junk, &["q0"]).unwrap_err().to_string();
    assert!(e.contains("junk.mat") && e.contains("MAT file"), "{e}");
}

/// The friction position bias switches the friction by a factor where q crosses qeq: a jump
/// of the right-hand side. The simulator splits each RK4 step at the switch
/// ([`PlantModel::simulate_at`]). Joint 2 of the coupled-method plant (LuGre, spring, bias)
/// under the Table 4.3 chirp crosses qeq several times in 20 s.
///
/// What the output-error fits need is the sensitivity of the positions to the parameters.
/// Where the right-hand side jumps, the true sensitivity has a jump term from the shift of
/// the switching time; plain RK4 (the switch decided at each stage, [`PlantModel::simulate`])
/// fixes the switch to its stage grid and misses that term at any step: its slope of Σ q(t_k)
/// in ln Kp is a quarter of the split steps' (measured −382 against −1548), and in the bias
/// factor of the wrong sign (−47 against +293). The split steps' slopes must not depend on
/// the step (1/2000 s against 1/32000 s, 1 %), and must differ from plain RK4's (jump term
/// present); the positions at 1/2000 s must be closer to the split steps at 1/32000 s than
/// plain RK4's at 1/2000 s are (measured 2.7e-4 against 4.2e-4 rad).
#[test]
fn the_friction_bias_switch_is_located_within_the_step() {
    let truth = coupled_consistent();
    let ex = lockstep::excitation::Excitations::bundled(truth.model).unwrap();
    let test = ex.table("4.3").unwrap().test(Some("J2")).unwrap();
    let (t, u, _) = test.sample(6, &[2], 20.0, 100.0);
    let tau = vec![u[2].clone()];
    let input = InputSignal {
        t0: 0.0,
        dt: 0.01,
        tau: &tau,
        hold: Hold::Zoh,
    };
    let qeq = truth.parameters["qeq_q2"];
    // Positions at the sample times: split steps (simulate_at) or plain RK4 (simulate),
    // `per_sample` steps per 0.01 s sample.
    let run = |name: &str, factor: f64, split: bool, per_sample: usize| -> Vec<f64> {
        let mut p = truth.clone();
        *p.parameters.get_mut(name).unwrap() *= factor;
        let s = p
            .simulator("c4", &[0.0; 6], ConsistencyPolicy::Warn)
            .unwrap()
            .model;
        let h = 0.01 / per_sample as f64;
        if split {
            return s
                .simulate_at(State::at_rest(vec![0.0]), h, &input, &t, 100.0)
                .unwrap()
                .q
                .swap_remove(0);
        }
        let mut q = vec![0.0];
        let mut n = 0;
        s.simulate(
            State::at_rest(vec![0.0]),
            h,
            (t.len() - 1) * per_sample,
            100.0,
            |tt, out| input.at(tt, out),
            |_, x| {
                n += 1;
                if n % per_sample == 0 {
                    q.push(x.q[0]);
                }
            },
        )
        .unwrap();
        q
    };
    let worst = |a: &[f64], b: &[f64]| {
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max)
    };
    let reference = run("Kp_q2", 1.0, true, 320);
    let crossings = reference
        .windows(2)
        .filter(|w| (w[0] < qeq) != (w[1] < qeq))
        .count();
    assert!(crossings >= 6, "only {crossings} crossings of qeq");
    let e_split = worst(&run("Kp_q2", 1.0, true, 20), &reference);
    let e_plain = worst(&run("Kp_q2", 1.0, false, 20), &reference);
    println!("{crossings} crossings; position error at 1/2000 s: split {e_split:.3e}, plain {e_plain:.3e} rad");
    assert!(e_split < 0.8 * e_plain, "{e_split:.3e} vs {e_plain:.3e}");
    for name in ["Kp_q2", "FrictionBias_q2"] {
        let slope = |split: bool, per_sample: usize| {
            let rel = 1e-6;
            let (a, b) = (
                run(name, 1.0 + rel, split, per_sample),
                run(name, 1.0 - rel, split, per_sample),
            );
            a.iter().zip(&b).map(|(x, y)| x - y).sum::<f64>() / (2.0 * rel)
        };
        let (fine, coarse, plain) = (slope(true, 320), slope(true, 20), slope(false, 20));
        println!("{name}: d Σq / d ln p: split {coarse:.6e} (1/2000 s), {fine:.6e} (1/32000 s); plain RK4 {plain:.6e}");
        assert!((coarse - fine).abs() <= 1e-2 * fine.abs(), "{name}");
        assert!((plain - fine).abs() > 0.5 * fine.abs(), "{name}");
    }
}

#[test]
fn a_divergence_from_an_indefinite_inertia_matrix_says_so() {
    // c6 (joint 0 alone): I1_33, link 1's inertia about its own z axis (joint 0's axis),
    // enters D_00 with coefficient 1, so lowering it by D_00(0) + 1e-3 leaves D_00 = -1e-3
    // kg·m². The isolated method's c6 fit lands in such a region (the plant-gain scale
    // family drives I1_33 negative), and the simulator must then name the inertia matrix,
    // not the step.
    let mut p = coupled_consistent();
    let sim = |p: &Plant| {
        p.simulator("c6", &[0.0; 6], ConsistencyPolicy::Warn)
            .unwrap()
            .model
    };
    let d00 = sim(&p).inertia_matrix(&[0.0])[(0, 0)];
    assert!(d00 > 1e-3, "D_00 = {d00}");
    let i1_33 = p.parameters["I1_33"];
    p.parameters.insert("I1_33".into(), i1_33 - d00 - 1e-3);
    let s = sim(&p);
    let d00_bad = s.inertia_matrix(&[0.0])[(0, 0)];
    assert!((d00_bad + 1e-3).abs() < 1e-12, "D_00 = {d00_bad}");
    let tau = vec![vec![0.02; 101]];
    let input = InputSignal {
        t0: 0.0,
        dt: 0.01,
        tau: &tau,
        hold: Hold::Zoh,
    };
    let t: Vec<f64> = (0..=100).map(|k| k as f64 * 0.01).collect();
    let run = |s: &lockstep::simulation::PlantModel| {
        s.simulate_at(State::at_rest(vec![0.0]), 1e-4, &input, &t, 100.0)
    };
    let d = run(&s).unwrap_err();
    let lambda = d.inertia_min_eigenvalue.expect("indefinite D not reported");
    assert!(lambda < 0.0, "{lambda}");
    let msg = d.to_string();
    assert!(
        msg.contains("not positive definite") && !msg.contains("try a smaller step"),
        "{msg}"
    );
    // The same torque on the physical plant stays finite over the second.
    run(&sim(&coupled_consistent())).unwrap();
}

/// A plant of a model whose file gives the links in numbers (the Puma 560, no inertial
/// symbol) takes those numbers: without any parameter, its simulator's gravity at q = 0 is
/// the Robotics Toolbox's documented g(qz) = [0, 37.4837, 0.2489] N·m on the three arm
/// joints (the wrist locked at 0), and its inertia matrix is positive definite. A plant
/// that gives a link's barycentric parameters uses them instead (the check can fail).
#[test]
fn a_plant_takes_the_model_files_numeric_inertial_values_puma560() {
    let plant = Plant::new("puma560", vec![]).unwrap();
    let model = plant
        .simulator("arm", &[0.0; 6], ConsistencyPolicy::Warn)
        .unwrap()
        .model;
    let mut g = [0.0; 3];
    (model.conf.gravity)(&[0.0; 6], &model.p, &mut g);
    eprintln!("g(0) = {g:?}");
    for (a, published) in [0.0, 37.4837, 0.2489].iter().enumerate() {
        assert!((g[a] - published).abs() < 5e-5, "g(0) = {g:?}");
    }
    let eig = model.inertia_matrix(&[0.0; 3]).symmetric_eigenvalues();
    assert!(eig.iter().all(|&l| l > 0.0), "{eig:?}");
    // Link 2's barycentric mass given: the link takes the plant's numbers.
    let mut heavier = plant.clone();
    let m2 = plant.values_with_barycentric().unwrap()["M_link2"];
    for (n, v) in plant.values_with_barycentric().unwrap() {
        if n.ends_with("_link2") {
            heavier.parameters.insert(n, v);
        }
    }
    heavier.parameters.insert("M_link2".into(), 2.0 * m2);
    let model = heavier
        .simulator("arm", &[0.0; 6], ConsistencyPolicy::Warn)
        .unwrap()
        .model;
    (model.conf.gravity)(&[0.0; 6], &model.p, &mut g);
    assert!((g[1] - 37.4837).abs() > 1.0, "g(0) = {g:?}");
}
