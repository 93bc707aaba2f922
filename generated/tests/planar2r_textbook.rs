//! The generated kernels of model/planar2r.toml against the closed forms of Spong,
//! Hutchinson, Vidyasagar (2006), §7.4.1: an independent derivation by hand.

const A1: f64 = 0.3;
const A2: f64 = 0.2;
const G: f64 = 9.81;

struct Arm {
    m1: f64,
    m2: f64,
    lc1: f64,
    lc2: f64,
    i1: f64,
    i2: f64,
}

const ARM: Arm = Arm {
    m1: 1.3,
    m2: 0.8,
    lc1: 0.12,
    lc2: 0.09,
    i1: 0.011,
    i2: 0.004,
};

fn params() -> [f64; generated::planar2r::NP] {
    // Model symbols in file order: m1, x1, I1, m2, x2, I2 (centroid at x = -(a - lc)).
    let a = &ARM;
    generated::planar2r::barycentric_from_symbols(&[
        a.m1,
        -(A1 - a.lc1),
        a.i1,
        a.m2,
        -(A2 - a.lc2),
        a.i2,
    ])
}

fn textbook(q: [f64; 2], qd: [f64; 2]) -> ([[f64; 2]; 2], [[f64; 2]; 2], [f64; 2]) {
    let a = &ARM;
    let (c1, c2, c12) = (q[0].cos(), q[1].cos(), (q[0] + q[1]).cos());
    let s2 = q[1].sin();
    let d11 = a.m1 * a.lc1 * a.lc1
        + a.m2 * (A1 * A1 + a.lc2 * a.lc2 + 2.0 * A1 * a.lc2 * c2)
        + a.i1
        + a.i2;
    let d12 = a.m2 * (a.lc2 * a.lc2 + A1 * a.lc2 * c2) + a.i2;
    let d22 = a.m2 * a.lc2 * a.lc2 + a.i2;
    let h = -a.m2 * A1 * a.lc2 * s2;
    let c = [[h * qd[1], h * qd[0] + h * qd[1]], [-h * qd[0], 0.0]];
    let phi = [
        (a.m1 * a.lc1 + a.m2 * A1) * G * c1 + a.m2 * a.lc2 * G * c12,
        a.m2 * a.lc2 * G * c12,
    ];
    ([[d11, d12], [d12, d22]], c, phi)
}

fn close(a: f64, b: f64) {
    assert!((a - b).abs() <= 1e-12 * (1.0 + b.abs()), "{a} vs {b}");
}

#[test]
fn full_model_matches_textbook() {
    use generated::planar2r::full;
    let p = params();
    for (q, qd, qdd) in [
        ([0.3, -1.1], [0.7, -0.4], [1.2, 0.5]),
        ([2.0, 0.4], [-1.5, 2.5], [-0.3, 0.9]),
        ([0.0, 0.0], [0.0, 0.0], [0.0, 0.0]),
    ] {
        let (d, c, phi) = textbook(q, qd);
        let dm = full::mass_matrix(&q, &p);
        let cm = full::christoffel_matrix(&q, &qd, &p);
        let g = full::gravity(&q, &p);
        for i in 0..2 {
            close(g[i], phi[i]);
            for j in 0..2 {
                close(dm[i][j], d[i][j]);
                close(cm[i][j], c[i][j]);
            }
        }
        let tau = full::inverse_dynamics(&q, &qd, &qdd, &p);
        let y = full::regressor(&q, &qd, &qdd);
        for i in 0..2 {
            let want =
                d[i][0] * qdd[0] + d[i][1] * qdd[1] + c[i][0] * qd[0] + c[i][1] * qd[1] + phi[i];
            close(tau[i], want);
            close(y[i].iter().zip(&p).map(|(a, b)| a * b).sum(), want);
        }
        let acc = full::forward_dynamics(&q, &qd, &tau, &p);
        for i in 0..2 {
            assert!((acc[i] - qdd[i]).abs() < 1e-10, "{acc:?} vs {qdd:?}");
        }
    }
}

#[test]
fn locked_shoulder_keeps_the_elbow_row_and_column() {
    use generated::planar2r::{elbow, full};
    let p = params();
    let q = [0.8, -0.6];
    let (d, _, phi) = textbook(q, [0.0, 0.0]);
    close(elbow::mass_matrix(&q, &p)[0][0], d[1][1]);
    close(elbow::gravity(&q, &p)[0], phi[1]);
    // With q̇0 = q̈0 = 0 the elbow torque is the full model's second row.
    let (qd1, qdd1) = (1.7, -2.2);
    let full_tau = full::inverse_dynamics(&q, &[0.0, qd1], &[0.0, qdd1], &p);
    close(
        elbow::inverse_dynamics(&q, &[qd1], &[qdd1], &p)[0],
        full_tau[1],
    );
    assert_eq!(elbow::FREE, [1]);
}
