//! The simulator against closed forms on the EMPS axis (a point mass M on a prismatic joint,
//! no gravity): terminal velocity with Coulomb + viscous friction, the LuGre steady state,
//! a spring's natural frequency, RK4's fourth order, energy, and divergence reports.

use lockstep::simulation::{JointTerms, LuGre, PlantModel, State};

const M: f64 = 95.0;

fn emps(terms: JointTerms) -> PlantModel {
    let m = generated::model("emps").unwrap();
    PlantModel {
        conf: m.configuration("full").unwrap(),
        p: vec![M],
        q_locked: vec![0.0],
        terms: vec![terms],
        couplings: vec![],
    }
}

#[test]
fn constant_force_reaches_the_terminal_velocity() {
    // M v̇ = τ − Fc − Fv v  →  v∞ = (τ − Fc)/Fv.
    let plant = emps(JointTerms {
        viscous: 200.0,
        coulomb: 20.0,
        ..JointTerms::default()
    });
    let x = plant
        .simulate(
            State::at_rest(vec![0.0]),
            1e-3,
            10_000,
            10.0,
            |_, tau| tau[0] = 50.0,
            |_, _| {},
        )
        .unwrap();
    // After 10 s = 21 time constants M/Fv.
    assert!((x.qd[0] - 0.15).abs() < 1e-8, "v = {}", x.qd[0]);
}

#[test]
fn lugre_steady_state_is_the_stribeck_curve_plus_viscous() {
    let l = LuGre {
        sigma0: 1e4,
        sigma1: 50.0,
        sigma2: 100.0,
        fc: 20.0,
        fs: 35.0,
        vs: 0.3,
    };
    let plant = emps(JointTerms {
        lugre: Some(l),
        ..JointTerms::default()
    });
    let tau = 40.0;
    let x = plant
        .simulate(
            State::at_rest(vec![0.0]),
            2e-4,
            100_000,
            10.0,
            |_, t| t[0] = tau,
            |_, _| {},
        )
        .unwrap();
    let v = x.qd[0];
    // At constant velocity the applied force balances g(v) sign(v) + σ2 v, and
    // z = g(v)/σ0.
    assert!(
        (l.steady_state(v) - tau).abs() < 1e-6 * tau,
        "v = {v}, F = {}",
        l.steady_state(v)
    );
    assert!((x.z[0] - l.g(v) / l.sigma0).abs() < 1e-9, "z = {}", x.z[0]);
    // The Stribeck part is visible: the steady state differs from the Coulomb-only one.
    assert!((v - (tau - l.fc) / l.sigma2).abs() > 1e-3);
}

#[test]
fn spring_oscillates_at_the_natural_frequency_and_conserves_energy() {
    let ks = 950.0; // ω = √(Ks/M) = √10 rad/s
    let plant = emps(JointTerms {
        spring: Some((ks, 0.02)),
        ..JointTerms::default()
    });
    let mut crossings = Vec::new();
    let mut prev = (0.0, 0.1 - 0.02);
    let mut e_err = 0.0f64;
    let e0 = 0.5 * ks * 0.08f64.powi(2);
    plant
        .simulate(
            State::at_rest(vec![0.1]),
            1e-4,
            100_000,
            10.0,
            |_, t| t[0] = 0.0,
            |t, x| {
                let y = x.q[0] - 0.02;
                if prev.1 > 0.0 && y <= 0.0 {
                    // Linear interpolation of the downward zero crossing.
                    crossings.push(prev.0 + (t - prev.0) * prev.1 / (prev.1 - y));
                }
                prev = (t, y);
                let e = 0.5 * M * x.qd[0].powi(2) + 0.5 * ks * y * y;
                e_err = e_err.max((e - e0).abs() / e0);
            },
        )
        .unwrap();
    let period = (crossings.last().unwrap() - crossings[0]) / (crossings.len() - 1) as f64;
    let expected = 2.0 * std::f64::consts::PI / 10f64.sqrt();
    assert!(
        (period - expected).abs() < 1e-6 * expected,
        "period {period} vs {expected}"
    );
    assert!(e_err < 1e-9, "energy error {e_err:e}");
}

#[test]
fn rk4_converges_at_fourth_order() {
    // Damped oscillator with a smooth force: M ẍ + c ẋ + k x = 0, closed form.
    let (c, k) = (60.0, 950.0);
    let plant = emps(JointTerms {
        viscous: c,
        spring: Some((k, 0.0)),
        ..JointTerms::default()
    });
    let exact = |t: f64| {
        let a = c / (2.0 * M);
        let w = (k / M - a * a).sqrt();
        0.1 * (-a * t).exp() * ((w * t).cos() + a / w * (w * t).sin())
    };
    let err = |h: f64| {
        let n = (1.0 / h).round() as usize;
        let x = plant
            .simulate(
                State::at_rest(vec![0.1]),
                h,
                n,
                10.0,
                |_, t| t[0] = 0.0,
                |_, _| {},
            )
            .unwrap();
        (x.q[0] - exact(1.0)).abs()
    };
    let (e1, e2) = (err(0.02), err(0.01));
    let ratio = e1 / e2;
    assert!(
        (14.0..18.0).contains(&ratio),
        "error ratio {ratio} ({e1:e}, {e2:e})"
    );
}

#[test]
fn dissipative_effects_never_add_energy() {
    // Spring + viscous + LuGre without σ1 (passive): the stored energy
    // ½ M v² + ½ Ks q² + ½ σ0 z² never increases without input.
    let l = LuGre {
        sigma0: 2e3,
        sigma1: 0.0,
        sigma2: 5.0,
        fc: 2.0,
        fs: 3.0,
        vs: 0.05,
    };
    let ks = 950.0;
    let plant = emps(JointTerms {
        viscous: 10.0,
        spring: Some((ks, 0.0)),
        lugre: Some(l),
        ..JointTerms::default()
    });
    let energy = |x: &State| {
        0.5 * M * x.qd[0].powi(2) + 0.5 * ks * x.q[0].powi(2) + 0.5 * l.sigma0 * x.z[0].powi(2)
    };
    let x0 = State::at_rest(vec![0.1]);
    let mut last = energy(&x0);
    let e0 = last;
    let mut worst = 0.0f64;
    plant
        .simulate(
            x0,
            1e-4,
            50_000,
            10.0,
            |_, t| t[0] = 0.0,
            |_, x| {
                let e = energy(x);
                worst = worst.max(e - last);
                last = e;
            },
        )
        .unwrap();
    assert!(worst <= 1e-12 * e0, "energy rose by {worst:e}");
    assert!(last < 0.5 * e0, "energy {last} of {e0}: nothing dissipated");
}

#[test]
fn divergence_is_reported_with_time_and_joint() {
    // A stiff spring with a step far beyond RK4's stability limit (h·ω ≫ 2.8).
    let plant = emps(JointTerms {
        spring: Some((95.0e6, 0.0)),
        ..JointTerms::default()
    });
    let e = plant
        .simulate(
            State::at_rest(vec![0.01]),
            1e-2,
            1000,
            1e3,
            |_, t| t[0] = 0.0,
            |_, _| {},
        )
        .unwrap_err();
    assert_eq!(e.joint, 0);
    assert!(e.t > 0.0 && e.t < 1.0, "{e}");
    assert!(e.to_string().contains("try a smaller step"), "{e}");
}
