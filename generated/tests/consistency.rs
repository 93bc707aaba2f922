//! The physical-consistency check on the thesis's Appendix D values for link 4 (thesis
//! Table D, OCR text checked against the design digest (docs/src/design/digest.md)): the coupled-method result has a negative
//! principal moment (I4_33 = −1.7449e-4 kg·m²) and is flagged; the isolated-joint result is
//! positive definite but violates the triangle inequality (I4_22 > I4_11 + I4_33), as
//! the design digest (docs/src/design/digest.md) reports for every Appendix D link; a physical tensor passes.

use generated::inertia::CentroidalInertia;

#[test]
fn appendix_d_coupled_link_4_is_flagged_not_positive_definite() {
    let coupled = CentroidalInertia {
        m: 6.79e-2,
        c: [-1.4726e-1, -1.8605e-3, 1.6083e-2],
        i_c: [
            2.1006e-3, -2e-7, -2.7218e-5, 8.3644e-3, 1.8487e-6, -1.7449e-4,
        ],
    };
    let f = coupled.consistency();
    assert!(
        f.iter().any(|s| s.contains("not positive definite")),
        "{f:?}"
    );
    // The same numbers pass through the barycentric form unchanged.
    let back = CentroidalInertia::from_barycentric(&coupled.to_barycentric()).unwrap();
    for k in 0..6 {
        assert!((back.i_c[k] - coupled.i_c[k]).abs() < 1e-15);
    }
}

#[test]
fn appendix_d_isolated_link_4_violates_the_triangle_inequality() {
    let isolated = CentroidalInertia {
        m: 6.79e-2,
        c: [-1.993e-1, -2e-3, 1e-2],
        i_c: [9.5511e-4, -1e-6, -3.281e-6, 5.5e-3, 0.0, 9.4753e-4],
    };
    let f = isolated.consistency();
    assert_eq!(f.len(), 1, "{f:?}");
    assert!(f[0].contains("triangle inequality"), "{f:?}");
}

#[test]
fn a_solid_box_is_consistent() {
    // 2 kg box 0.1 × 0.2 × 0.3 m: I = m/12 (b² + c², a² + c², a² + b²).
    let m = 2.0;
    let (a, b, c) = (0.1f64, 0.2f64, 0.3f64);
    let boxed = CentroidalInertia {
        m,
        c: [0.05, 0.0, -0.02],
        i_c: [
            m / 12.0 * (b * b + c * c),
            0.0,
            0.0,
            m / 12.0 * (a * a + c * c),
            0.0,
            m / 12.0 * (a * a + b * b),
        ],
    };
    assert!(boxed.consistency().is_empty());
}
