//! Every kernel of every configuration of every generated model agrees with an independent
//! numeric Lagrangian (tests/support: forward kinematics + dual numbers) at random states
//! and random physically consistent parameters, to 1e-10 relative.

mod support;

use support::{link_params, model_file, random_params, reference, Rng};

/// ‖x − r‖∞ ≤ 1e-10 · max(‖r‖∞, 1e-3): relative to the size of the whole output.
fn close(what: &str, x: &[f64], r: &[f64]) {
    assert_eq!(x.len(), r.len(), "{what}: length");
    let scale = r.iter().fold(1e-3f64, |m, v| m.max(v.abs()));
    let err = x
        .iter()
        .zip(r)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(
        err <= 1e-10 * scale,
        "{what}: max error {err:e} against scale {scale:e}\n kernel    {x:?}\n reference {r:?}"
    );
}

#[test]
fn every_kernel_matches_the_numeric_lagrangian() {
    let mut rng = Rng(0x1234_5678_9abc_def1);
    let mut checked = 0;
    for gm in generated::MODELS {
        let model = model_file(gm);
        let nj = gm.joints.len();
        for conf in gm.configurations {
            let nf = conf.free.len();
            for _ in 0..3 {
                let q: Vec<f64> = (0..nj).map(|_| rng.uniform(-3.0, 3.0)).collect();
                let qd: Vec<f64> = (0..nf).map(|_| rng.uniform(-2.0, 2.0)).collect();
                let qdd: Vec<f64> = (0..nf).map(|_| rng.uniform(-5.0, 5.0)).collect();
                let p = random_params(gm, &mut rng);
                let bary = link_params(gm, &p);
                let r = reference(&model, &bary, conf.free, &q, &qd, &qdd);
                let what = |k: &str| format!("{} {} {k}", gm.name, conf.name);
                let mut m = vec![0.0; nf * nf];
                (conf.mass_matrix)(&q, &p, &mut m);
                close(&what("mass_matrix"), &m, &r.d.concat());
                (conf.christoffel_matrix)(&q, &qd, &p, &mut m);
                close(&what("christoffel_matrix"), &m, &r.c.concat());
                let mut v = vec![0.0; nf];
                (conf.gravity)(&q, &p, &mut v);
                close(&what("gravity"), &v, &r.phi);
                (conf.inverse_dynamics)(&q, &qd, &qdd, &p, &mut v);
                close(&what("inverse_dynamics"), &v, &r.tau);
                let zero = vec![0.0; nf];
                (conf.inverse_dynamics)(&q, &qd, &zero, &p, &mut v);
                let cqd_phi: Vec<f64> = (0..nf).map(|a| r.cqd[a] + r.phi[a]).collect();
                close(&what("inverse_dynamics at q̈ = 0"), &v, &cqd_phi);
                // Regressor: Y p = τ, and each column is τ of a unit parameter vector.
                let np = gm.params.len();
                let mut y = vec![0.0; nf * np];
                (conf.regressor)(&q, &qd, &qdd, &mut y);
                let yp: Vec<f64> = (0..nf)
                    .map(|a| (0..np).map(|j| y[a * np + j] * p[j]).sum())
                    .collect();
                close(&what("regressor · p"), &yp, &r.tau);
                for j in 0..np {
                    let mut e = vec![0.0; np];
                    e[j] = 1.0;
                    let rj = reference(&model, &link_params(gm, &e), conf.free, &q, &qd, &qdd);
                    let col: Vec<f64> = (0..nf).map(|a| y[a * np + j]).collect();
                    close(
                        &what(&format!("regressor column {}", gm.params[j])),
                        &col,
                        &rj.tau,
                    );
                }
                // Forward dynamics inverts the reference τ.
                let mut acc = vec![0.0; nf];
                (conf.forward_dynamics)(&q, &qd, &r.tau, &p, &mut acc);
                close(&what("forward_dynamics"), &acc, &qdd);
                checked += 1;
            }
        }
    }
    assert!(checked >= 3 * 12, "only {checked} states checked");
}

#[test]
fn coriolis_kernel_is_christoffel_times_velocity() {
    let mut rng = Rng(7);
    for gm in generated::MODELS {
        let model = model_file(gm);
        for conf in gm.configurations {
            let nf = conf.free.len();
            let q: Vec<f64> = (0..gm.joints.len())
                .map(|_| rng.uniform(-3.0, 3.0))
                .collect();
            let qd: Vec<f64> = (0..nf).map(|_| rng.uniform(-2.0, 2.0)).collect();
            let p = random_params(gm, &mut rng);
            let r = reference(
                &model,
                &link_params(gm, &p),
                conf.free,
                &q,
                &qd,
                &vec![0.0; nf],
            );
            let mut v = vec![0.0; nf];
            (conf.coriolis)(&q, &qd, &p, &mut v);
            close(&format!("{} {} coriolis", gm.name, conf.name), &v, &r.cqd);
        }
    }
}
