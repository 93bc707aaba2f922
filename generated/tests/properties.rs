//! Properties every generated model must have, over random states and random physically
//! consistent parameters (proptest): D symmetric positive definite; Ḋ − 2C skew-symmetric;
//! energy conserved by frictionless RK4; the generated state derivatives of τ equal
//! differences of τ; locked configurations are the full model's rows and
//! columns with the locked velocities zeroed; the `_trig` forms (and forward dynamics from
//! its loop invariants) equal the plain ones.

mod support;

use generated::{Configuration, Model};
use proptest::prelude::*;
use support::{link_params, model_file, potential, random_params, Rng};

/// The configuration that frees every joint (`full`, or `k5` for the Freedom 6S).
fn full(m: &Model) -> &'static Configuration {
    m.configurations
        .iter()
        .find(|c| c.free.len() == m.joints.len())
        .unwrap()
}

fn models() -> impl Strategy<Value = &'static Model> {
    proptest::sample::select(generated::MODELS.to_vec())
}

fn state(rng: &mut Rng, nj: usize, nf: usize) -> (Vec<f64>, Vec<f64>) {
    (
        (0..nj).map(|_| rng.uniform(-3.0, 3.0)).collect(),
        (0..nf).map(|_| rng.uniform(-2.0, 2.0)).collect(),
    )
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn inertia_matrix_is_symmetric_positive_definite(m in models(), seed in any::<u64>()) {
        let mut rng = Rng(seed | 1);
        let p = random_params(m, &mut rng);
        for c in m.configurations {
            let nf = c.free.len();
            let (q, _) = state(&mut rng, m.joints.len(), nf);
            let mut d = vec![0.0; nf * nf];
            (c.mass_matrix)(&q, &p, &mut d);
            let dm = nalgebra::DMatrix::from_row_slice(nf, nf, &d);
            prop_assert!((&dm - dm.transpose()).amax() <= 1e-14 * dm.amax());
            prop_assert!(dm.cholesky().is_some(), "{} {}: D not positive definite", m.name, c.name);
        }
    }

    #[test]
    fn d_dot_minus_two_c_is_skew_symmetric(m in models(), seed in any::<u64>()) {
        let mut rng = Rng(seed | 1);
        let p = random_params(m, &mut rng);
        for c in m.configurations {
            let nf = c.free.len();
            let (q, qd) = state(&mut rng, m.joints.len(), nf);
            // Ḋ by a central difference along q̇ (free joints only move).
            let h = 1e-5;
            let shifted = |s: f64| {
                let mut qs = q.clone();
                for (a, &k) in c.free.iter().enumerate() {
                    qs[k] += s * h * qd[a];
                }
                let mut d = vec![0.0; nf * nf];
                (c.mass_matrix)(&qs, &p, &mut d);
                d
            };
            let (dp, dm) = (shifted(1.0), shifted(-1.0));
            let mut cm = vec![0.0; nf * nf];
            (c.christoffel_matrix)(&q, &qd, &p, &mut cm);
            let n: Vec<f64> = (0..nf * nf).map(|i| (dp[i] - dm[i]) / (2.0 * h) - 2.0 * cm[i]).collect();
            let scale = n.iter().fold(1e-3f64, |a, x| a.max(x.abs()));
            for a in 0..nf {
                for b in 0..nf {
                    let s = n[a * nf + b] + n[b * nf + a];
                    prop_assert!(s.abs() <= 1e-7 * scale, "{} {}: N + Nᵀ = {s:e} at ({a}, {b})", m.name, c.name);
                }
            }
        }
    }

    #[test]
    fn dynamics_derivatives_equal_differences_of_inverse_dynamics(m in models(), seed in any::<u64>()) {
        // An independent reference: ∂τ/∂q by Richardson-extrapolated central differences of
        // the inverse-dynamics kernel (error O(δ⁴)), ∂τ/∂q̇ by a central difference (exact up
        // to rounding: τ is quadratic in q̇), D from the mass-matrix kernel.
        let mut rng = Rng(seed | 1);
        let p = random_params(m, &mut rng);
        for c in m.configurations {
            let nf = c.free.len();
            let (q, qd) = state(&mut rng, m.joints.len(), nf);
            let qdd: Vec<f64> = (0..nf).map(|_| rng.uniform(-5.0, 5.0)).collect();
            let mut got = vec![0.0; 3 * nf * nf];
            (c.dynamics_derivatives)(&q, &qd, &qdd, &p, &mut got);
            let tau = |q: &[f64], qd: &[f64]| {
                let mut t = vec![0.0; nf];
                (c.inverse_dynamics)(q, qd, &qdd, &p, &mut t);
                t
            };
            let central = |b: usize, velocity: bool, h: f64| {
                let (mut qp, mut qm, mut vp, mut vm) = (q.clone(), q.clone(), qd.clone(), qd.clone());
                if velocity {
                    vp[b] += h;
                    vm[b] -= h;
                } else {
                    qp[c.free[b]] += h;
                    qm[c.free[b]] -= h;
                }
                let (tp, tm) = (tau(&qp, &vp), tau(&qm, &vm));
                (0..nf).map(|a| (tp[a] - tm[a]) / (2.0 * h)).collect::<Vec<f64>>()
            };
            let mut d = vec![0.0; nf * nf];
            (c.mass_matrix)(&q, &p, &mut d);
            let mut want = vec![0.0; 3 * nf * nf];
            for b in 0..nf {
                let (coarse, fine) = (central(b, false, 2e-3), central(b, false, 1e-3));
                let velocity = central(b, true, 1e-3);
                for a in 0..nf {
                    want[a * 3 * nf + b] = d[a * nf + b];
                    want[a * 3 * nf + nf + b] = (4.0 * fine[a] - coarse[a]) / 3.0;
                    want[a * 3 * nf + 2 * nf + b] = velocity[a];
                }
            }
            let scale = want.iter().fold(1e-3f64, |s, x| s.max(x.abs()));
            for (i, (g, w)) in got.iter().zip(&want).enumerate() {
                prop_assert!(
                    (g - w).abs() <= 1e-8 * scale,
                    "{} {}: entry ({}, {}) is {g:e}, differences give {w:e}",
                    m.name, c.name, i / (3 * nf), i % (3 * nf)
                );
            }
        }
    }

    #[test]
    fn locked_configurations_are_rows_and_columns_of_the_full_model(m in models(), seed in any::<u64>()) {
        let mut rng = Rng(seed | 1);
        let p = random_params(m, &mut rng);
        let f = full(m);
        let nj = m.joints.len();
        for c in m.configurations {
            let nf = c.free.len();
            let (q, qd) = state(&mut rng, nj, nf);
            let qdd: Vec<f64> = (0..nf).map(|_| rng.uniform(-5.0, 5.0)).collect();
            let (mut qd_full, mut qdd_full) = (vec![0.0; nj], vec![0.0; nj]);
            for (a, &k) in c.free.iter().enumerate() {
                qd_full[k] = qd[a];
                qdd_full[k] = qdd[a];
            }
            let mut d = vec![0.0; nf * nf];
            let mut dfull = vec![0.0; nj * nj];
            (c.mass_matrix)(&q, &p, &mut d);
            (f.mass_matrix)(&q, &p, &mut dfull);
            let mut cm = vec![0.0; nf * nf];
            let mut cfull = vec![0.0; nj * nj];
            (c.christoffel_matrix)(&q, &qd, &p, &mut cm);
            (f.christoffel_matrix)(&q, &qd_full, &p, &mut cfull);
            let mut tau = vec![0.0; nf];
            let mut tau_full = vec![0.0; nj];
            (c.inverse_dynamics)(&q, &qd, &qdd, &p, &mut tau);
            (f.inverse_dynamics)(&q, &qd_full, &qdd_full, &p, &mut tau_full);
            let tol = |x: f64| 1e-12 * x.abs().max(1.0);
            for (a, &ka) in c.free.iter().enumerate() {
                prop_assert!((tau[a] - tau_full[ka]).abs() <= tol(tau_full[ka]));
                for (b, &kb) in c.free.iter().enumerate() {
                    prop_assert!((d[a * nf + b] - dfull[ka * nj + kb]).abs() <= tol(dfull[ka * nj + kb]));
                    prop_assert!((cm[a * nf + b] - cfull[ka * nj + kb]).abs() <= tol(cfull[ka * nj + kb]));
                }
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 6, failure_persistence: None, ..ProptestConfig::default() })]

    /// 2 s of frictionless motion by RK4 at 0.1 ms conserve T + V to 1e-9 relative.
    #[test]
    fn rk4_conserves_energy_without_friction(m in models(), seed in any::<u64>()) {
        let mut rng = Rng(seed | 1);
        let p = random_params(m, &mut rng);
        let model = model_file(m);
        let bary = link_params(m, &p);
        let c = full(m);
        let nj = m.joints.len();
        let (mut q, mut qd) = state(&mut rng, nj, nj);
        for v in &mut qd {
            *v *= 0.5;
        }
        let energy = |q: &[f64], qd: &[f64]| {
            let mut d = vec![0.0; nj * nj];
            (c.mass_matrix)(q, &p, &mut d);
            let t: f64 = (0..nj).map(|a| (0..nj).map(|b| 0.5 * qd[a] * d[a * nj + b] * qd[b]).sum::<f64>()).sum();
            (t, potential(&model, &bary, q))
        };
        let zero = vec![0.0; nj];
        let acc = |q: &[f64], qd: &[f64]| {
            let mut a = vec![0.0; nj];
            (c.forward_dynamics)(q, qd, &zero, &p, &mut a);
            a
        };
        let (t0, v0) = energy(&q, &qd);
        let mut scale = t0.abs() + v0.abs();
        let mut worst = 0.0f64;
        let h = 1e-4;
        for _ in 0..20_000 {
            let k1 = (qd.clone(), acc(&q, &qd));
            let step = |k: &(Vec<f64>, Vec<f64>), s: f64| -> (Vec<f64>, Vec<f64>) {
                (
                    (0..nj).map(|i| q[i] + s * k.0[i]).collect(),
                    (0..nj).map(|i| qd[i] + s * k.1[i]).collect(),
                )
            };
            let (q2, qd2) = step(&k1, h / 2.0);
            let k2 = (qd2.clone(), acc(&q2, &qd2));
            let (q3, qd3) = step(&k2, h / 2.0);
            let k3 = (qd3.clone(), acc(&q3, &qd3));
            let (q4, qd4) = step(&k3, h);
            let k4 = (qd4.clone(), acc(&q4, &qd4));
            for i in 0..nj {
                q[i] += h / 6.0 * (k1.0[i] + 2.0 * k2.0[i] + 2.0 * k3.0[i] + k4.0[i]);
                qd[i] += h / 6.0 * (k1.1[i] + 2.0 * k2.1[i] + 2.0 * k3.1[i] + k4.1[i]);
            }
            let (t, v) = energy(&q, &qd);
            scale = scale.max(t.abs() + v.abs());
            worst = worst.max((t + v - t0 - v0).abs());
        }
        prop_assert!(q.iter().all(|x| x.is_finite()));
        prop_assert!(worst <= 1e-9 * scale, "{}: energy drift {worst:e} of {scale:e}", m.name);
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 16, failure_persistence: None, ..ProptestConfig::default() })]

    /// The `_trig` forms read only the joints in `trig`, and read there what the forms that
    /// compute their own trigonometry compute: with every other entry of the table NaN,
    /// each equals its plain form bit for bit. So does forward dynamics from its loop
    /// invariants, which are computed with the free joints' entries NaN too.
    #[test]
    fn trig_forms_read_only_their_table_and_equal_the_plain_forms(m in models(), seed in any::<u64>()) {
        let mut rng = Rng(seed | 1);
        let p = random_params(m, &mut rng);
        let nj = m.joints.len();
        for c in m.configurations {
            let nf = c.free.len();
            let (q, qd) = state(&mut rng, nj, nf);
            let (_, w) = state(&mut rng, nj, nf);
            let mut sc = vec![f64::NAN; 2 * nj];
            for &k in c.trig {
                (sc[2 * k], sc[2 * k + 1]) = q[k].sin_cos();
            }
            let np = m.params.len();
            // Forward dynamics' loop invariants read only the locked joints and p: computed
            // with the free joints' positions and table entries NaN.
            let (mut q_locked, mut sc_locked) = (q.clone(), sc.clone());
            for &k in c.free {
                q_locked[k] = f64::NAN;
                (sc_locked[2 * k], sc_locked[2 * k + 1]) = (f64::NAN, f64::NAN);
            }
            let mut inv = vec![0.0; c.forward_dynamics_invariant_count];
            (c.forward_dynamics_invariants)(&q_locked, &sc_locked, &p, &mut inv);
            prop_assert!(inv.iter().all(|x| x.is_finite()), "{} {}: an invariant reads a free joint", m.name, c.name);
            type Form<'a> = Box<dyn Fn(&mut [f64]) + 'a>;
            let pairs: [(usize, Form, Form); 5] = [
                (nf * nf, Box::new(|o| (c.mass_matrix)(&q, &p, o)), Box::new(|o| (c.mass_matrix_trig)(&q, &sc, &p, o))),
                (nf, Box::new(|o| (c.forward_dynamics)(&q, &qd, &w, &p, o)), Box::new(|o| (c.forward_dynamics_trig)(&q, &sc, &qd, &w, &p, o))),
                (3 * nf * nf, Box::new(|o| (c.dynamics_derivatives)(&q, &qd, &w, &p, o)), Box::new(|o| (c.dynamics_derivatives_trig)(&q, &sc, &qd, &w, &p, o))),
                (nf * np, Box::new(|o| (c.regressor)(&q, &qd, &w, o)), Box::new(|o| (c.regressor_trig)(&q, &sc, &qd, &w, o))),
                (nf, Box::new(|o| (c.forward_dynamics)(&q, &qd, &w, &p, o)), Box::new(|o| (c.forward_dynamics_trig_inv)(&q, &sc, &qd, &w, &p, &inv, o))),
            ];
            for (i, (len, plain, trig)) in pairs.iter().enumerate() {
                let (mut a, mut b) = (vec![0.0; *len], vec![0.0; *len]);
                plain(&mut a);
                trig(&mut b);
                prop_assert!(a.iter().all(|x| x.is_finite()), "{} {} kernel {i}: not finite", m.name, c.name);
                prop_assert!(a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()),
                    "{} {} kernel {i}: the _trig form differs (or read outside `trig`)", m.name, c.name);
            }
        }
    }
}
