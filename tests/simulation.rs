//! The simulator against closed forms on the EMPS axis (a point mass M on a prismatic joint,
//! no gravity): terminal velocity with Coulomb + viscous friction, the LuGre steady state,
//! a spring's natural frequency, RK4's and ETDRK4's fourth order, ETDRK4's exactness on a
//! damping-dominated joint, energy, and divergence reports.

mod common;

use lockstep::simulation::{phi1234, Integrator, JointTerms, LuGre, PlantModel, State};

const M: f64 = 95.0;

fn emps(terms: JointTerms) -> PlantModel {
    let m = generated::model("emps").unwrap();
    PlantModel {
        conf: m.configuration("full").unwrap(),
        p: vec![M],
        q_locked: vec![0.0],
        terms: vec![terms],
        couplings: vec![],
        integrator: Integrator::Rk4,
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
fn rk4_and_etdrk4_converge_at_fourth_order() {
    // Damped oscillator with a smooth force: M ẍ + c ẋ + k x = 0, closed form. ETDRK4 takes
    // the viscous term c/M exactly and the spring explicitly.
    let (c, k) = (60.0, 950.0);
    let exact = |t: f64| {
        let a = c / (2.0 * M);
        let w = (k / M - a * a).sqrt();
        0.1 * (-a * t).exp() * ((w * t).cos() + a / w * (w * t).sin())
    };
    for integrator in [Integrator::Rk4, Integrator::Etdrk4] {
        let plant = PlantModel {
            integrator,
            ..emps(JointTerms {
                viscous: c,
                spring: Some((k, 0.0)),
                ..JointTerms::default()
            })
        };
        // Largest error over [0, 1] s (at one time alone it may sit near a zero crossing).
        let err = |h: f64| {
            let n = (1.0 / h).round() as usize;
            let mut worst = 0.0_f64;
            plant
                .simulate(
                    State::at_rest(vec![0.1]),
                    h,
                    n,
                    10.0,
                    |_, t| t[0] = 0.0,
                    |t, x| worst = worst.max((x.q[0] - exact(t)).abs()),
                )
                .unwrap();
            worst
        };
        let (e1, e2) = (err(0.02), err(0.01));
        let ratio = e1 / e2;
        assert!(
            (14.0..18.0).contains(&ratio),
            "{integrator}: error ratio {ratio} ({e1:e}, {e2:e})"
        );
        assert!(e2 < 1e-7, "{integrator}: {e2:e}");
    }
}

#[test]
fn etdrk4_is_exact_on_a_damping_dominated_joint_where_rk4_diverges() {
    // M v̇ = τ − Fv v with Fv/M = 1000 s⁻¹ and h = 10 ms (hλ = −10, outside RK4's stability
    // interval [−2.78, 0]): v(t) = v∞ (1 − e^{−Fv t/M}), v∞ = τ/Fv.
    let (fv, tau) = (1000.0 * M, 950.0);
    let v_inf = tau / fv;
    let plant = |integrator| PlantModel {
        integrator,
        ..emps(JointTerms {
            viscous: fv,
            ..JointTerms::default()
        })
    };
    let run = |integrator, steps: usize, observe: &mut dyn FnMut(f64, &State)| {
        plant(integrator).simulate(
            State::at_rest(vec![0.0]),
            0.01,
            steps,
            10.0,
            |_, t| t[0] = tau,
            |t, x| observe(t, x),
        )
    };
    assert!(run(Integrator::Rk4, 100, &mut |_, _| {}).is_err());
    let mut worst = 0.0_f64;
    let mut q_half = 0.0;
    let x = run(Integrator::Etdrk4, 100, &mut |t, x| {
        let v = v_inf * (1.0 - (-1000.0 * t).exp());
        worst = worst.max((x.qd[0] - v).abs() / v_inf);
        if (t - 0.5).abs() < 1e-9 {
            q_half = x.q[0];
        }
    })
    .unwrap();
    assert!(worst < 1e-13, "velocity error {worst:e} of v∞");
    // After the transient the position grows at exactly v∞ (the transient's own position
    // error is bounded by v∞/λ = 1e-5 m here).
    let slope = (x.q[0] - q_half) / 0.5;
    assert!((slope / v_inf - 1.0).abs() < 1e-12, "{slope} vs {v_inf}");
    let q_exact = v_inf * (1.0 - (1.0 - (-1000.0_f64).exp()) / 1000.0);
    assert!((x.q[0] - q_exact).abs() < v_inf / 1000.0, "{}", x.q[0]);
}

#[test]
fn a_zero_order_hold_is_followed_exactly_by_both_integrators() {
    // A free mass under a piecewise-constant force: q is piecewise quadratic, which RK4 and
    // ETDRK4 (Λ = 0 here) integrate exactly, provided each step's last stage takes the force
    // held over the step, not the next sample's (InputSignal::before).
    use lockstep::simulation::{Hold, InputSignal};
    let tau = vec![vec![95.0, -190.0, 285.0, 0.0, -95.0, 47.5]];
    let t: Vec<f64> = (0..6).map(|k| k as f64 * 0.01).collect();
    let input = InputSignal {
        t0: 0.0,
        dt: 0.01,
        tau: &tau,
        hold: Hold::Zoh,
    };
    // Exact: on [t_k, t_k+1) q̈ = τ_k / M.
    let (mut q, mut v) = (vec![0.0], 0.0);
    for k in 0..5 {
        let a = tau[0][k] / M;
        q.push(q[k] + v * 0.01 + 0.5 * a * 1e-4);
        v += a * 0.01;
    }
    for integrator in [Integrator::Rk4, Integrator::Etdrk4] {
        let plant = PlantModel {
            integrator,
            ..emps(JointTerms::default())
        };
        let traj = plant
            .simulate_at(State::at_rest(vec![0.0]), 0.0025, &input, &t, 10.0)
            .unwrap();
        for (k, (a, b)) in traj.q[0].iter().zip(&q).enumerate() {
            assert!((a - b).abs() < 1e-15, "{integrator} sample {k}: {a} vs {b}");
        }
    }
}

#[test]
fn phi_functions_match_their_closed_forms_and_limits() {
    for x in [
        -3e4, -40.0, -2.0, -0.6, -0.4, -1e-3, 0.0, 1e-3, 0.3, 0.7, 3.0,
    ] {
        let [p1, p2, p3, p4] = phi1234(x);
        if x.abs() > 0.1 {
            let e: f64 = x.exp();
            let c = [
                (e - 1.0) / x,
                (e - 1.0 - x) / (x * x),
                (e - 1.0 - x - x * x / 2.0) / x.powi(3),
                (e - 1.0 - x - x * x / 2.0 - x.powi(3) / 6.0) / x.powi(4),
            ];
            for (k, (p, c)) in [p1, p2, p3, p4].iter().zip(c).enumerate() {
                assert!(
                    (p - c).abs() < 1e-10 * p.abs(),
                    "φ{}({x}) = {p} vs {c}",
                    k + 1
                );
            }
        } else {
            // Taylor: φk(x) ≈ 1/k! + x/(k+1)!.
            assert!((p1 - (1.0 + x / 2.0)).abs() <= x * x, "φ1({x})");
            assert!((p2 - (0.5 + x / 6.0)).abs() <= x * x, "φ2({x})");
            assert!((p3 - (1.0 / 6.0 + x / 24.0)).abs() <= x * x, "φ3({x})");
            assert!((p4 - (1.0 / 24.0 + x / 120.0)).abs() <= x * x, "φ4({x})");
        }
    }
    // Continuity across the switch from the series to the closed forms at |x| = 1/2.
    for x in [-0.5, 0.5] {
        let (a, b) = (phi1234(x * (1.0 - 1e-15)), phi1234(x * (1.0 + 1e-15)));
        for k in 0..4 {
            assert!((a[k] - b[k]).abs() < 1e-14, "{a:?} {b:?}");
        }
    }
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
    assert!(e.to_string().contains("(step 0.01 s)"), "{e}");
}

/// An armature Ia on the EMPS axis is mass: M = 95 with Ia = 5 moves as M = 100 without it
/// (the generated kernel's own inverse of D against the armature's (D + Ia)⁻¹ D q̈₀), with
/// RK4 and with ETDRK4 (whose linear part takes D + Ia), under friction, a spring and a
/// multisine, to 1e-12 of the motion.
#[test]
fn an_armature_on_the_emps_axis_moves_as_the_same_added_mass() {
    for integrator in [Integrator::Rk4, Integrator::Etdrk4] {
        let run = |mass: f64, armature: f64| {
            let mut plant = emps(JointTerms {
                viscous: 200.0,
                coulomb: 20.0,
                spring: Some((5000.0, 0.01)),
                armature,
                ..JointTerms::default()
            });
            plant.p = vec![mass];
            plant.integrator = integrator;
            common::emps_multisine_motion(&plant)
        };
        let (a, b) = (run(95.0, 5.0), run(100.0, 0.0));
        let c = run(95.0, 0.0);
        let span = a.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let worst = |u: &[f64], v: &[f64]| {
            u.iter()
                .zip(v)
                .map(|(x, y)| (x - y).abs())
                .fold(0.0, f64::max)
        };
        eprintln!(
            "{integrator:?}: |q| up to {span:.4} m; armature vs mass {:.2e} m, without it {:.2e} m",
            worst(&a, &b),
            worst(&a, &c)
        );
        assert!(worst(&a, &b) < 1e-12 * span.max(1e-3), "{integrator:?}");
        assert!(
            worst(&a, &c) > 1e-4 * span,
            "the armature changes the motion"
        );
    }
}
