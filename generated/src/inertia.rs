//! Inertial parameters of one link: barycentric form (m, m·c, inertia about the link-frame
//! origin; the form in which D, C, φ are linear, thesis 3.2 and docs/src/design/digest.md §3) and the thesis's
//! form (m, centroid c, inertia about the centroid, Appendix D), with conversions and the
//! physical-consistency check.
//!
//! Inertia tensors are stored as `[I11, I12, I13, I22, I23, I33]` (kg·m²), tensor entries
//! (off-diagonal I12 = −∫x·y dm), in the link frame.

/// Names of the ten barycentric kinds (Khalil's notation).
pub const BARYCENTRIC_KINDS: [&str; 10] =
    ["M", "MX", "MY", "MZ", "XX", "XY", "XZ", "YY", "YZ", "ZZ"];

/// The deterministic random generator (xorshift64*) of checks and reports that sample random
/// states and parameters, shared with the generator.
pub use lockstep_rng::Xorshift;

/// One link in the thesis's form.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CentroidalInertia {
    /// Mass (kg).
    pub m: f64,
    /// Centroid in the link frame (m).
    pub c: [f64; 3],
    /// Inertia about the centroid `[I11, I12, I13, I22, I23, I33]` (kg·m²).
    pub i_c: [f64; 6],
}

impl CentroidalInertia {
    /// Barycentric vector `[m, m·cx, m·cy, m·cz, XX, XY, XZ, YY, YZ, ZZ]` with the inertia
    /// moved to the frame origin by the parallel-axis theorem
    /// I_O = I_c + m((c·c)E − c cᵀ).
    pub fn to_barycentric(&self) -> [f64; 10] {
        let [x, y, z] = self.c;
        let m = self.m;
        let i = self.i_c;
        [
            m,
            m * x,
            m * y,
            m * z,
            i[0] + m * (y * y + z * z),
            i[1] - m * x * y,
            i[2] - m * x * z,
            i[3] + m * (x * x + z * z),
            i[4] - m * y * z,
            i[5] + m * (x * x + y * y),
        ]
    }

    /// A random physically consistent link: m ∈ [0.5, 2] kg, centroid within ±0.1 m,
    /// centroidal inertia diagonal in [0.02, 0.05] kg·m² with products within ±0.005
    /// (diagonally dominant, so positive definite and satisfying the triangle inequality).
    pub fn random(rng: &mut Xorshift) -> CentroidalInertia {
        let m = rng.uniform(0.5, 2.0);
        let c = std::array::from_fn(|_| rng.uniform(-0.1, 0.1));
        let i_c = [
            rng.uniform(0.02, 0.05),
            rng.uniform(-0.005, 0.005),
            rng.uniform(-0.005, 0.005),
            rng.uniform(0.02, 0.05),
            rng.uniform(-0.005, 0.005),
            rng.uniform(0.02, 0.05),
        ];
        CentroidalInertia { m, c, i_c }
    }

    /// Inverse of [`CentroidalInertia::to_barycentric`]. Returns `None` when m = 0 (the
    /// centroid is then undefined).
    pub fn from_barycentric(b: &[f64; 10]) -> Option<CentroidalInertia> {
        let m = b[0];
        if m == 0.0 || !m.is_finite() {
            return None;
        }
        let c = [b[1] / m, b[2] / m, b[3] / m];
        let [x, y, z] = c;
        let i_c = [
            b[4] - m * (y * y + z * z),
            b[5] + m * x * y,
            b[6] + m * x * z,
            b[7] - m * (x * x + z * z),
            b[8] + m * y * z,
            b[9] - m * (x * x + y * y),
        ];
        Some(CentroidalInertia { m, c, i_c })
    }

    /// Physical-consistency findings (empty when consistent): mass > 0, inertia about the
    /// centroid positive definite, and the triangle inequalities of its principal moments
    /// (each ≤ the sum of the other two). Tolerance 1e-12 relative to the trace.
    pub fn consistency(&self) -> Vec<String> {
        self.check().into_iter().map(|f| f.message).collect()
    }

    /// The principal moments of the inertia about the centroid (kg·m²), the eigenvalues of
    /// `i_c` ([`symmetric_eigenvalues`]).
    pub fn principal_moments(&self) -> [f64; 3] {
        let i = self.i_c;
        symmetric_eigenvalues([[i[0], i[1], i[2]], [i[1], i[3], i[4]], [i[2], i[4], i[5]]])
    }

    /// [`CentroidalInertia::consistency`] with the kind of each finding.
    pub fn check(&self) -> Vec<Inconsistency> {
        let mut out = Vec::new();
        if self.m.is_nan() || self.m <= 0.0 {
            out.push(Inconsistency {
                kind: InconsistencyKind::Mass,
                message: format!("mass {} kg is not positive", self.m),
            });
        }
        let i = self.i_c;
        let ev = self.principal_moments();
        let tr = (i[0] + i[3] + i[5]).abs().max(1e-300);
        let tol = 1e-12 * tr;
        if ev.iter().any(|&l| l <= tol) {
            out.push(Inconsistency {
                kind: InconsistencyKind::NotPositiveDefinite,
                message: format!(
                    "inertia about the centroid is not positive definite (principal moments {:.4e}, {:.4e}, {:.4e} kg·m²)",
                    ev[0], ev[1], ev[2]
                ),
            });
        }
        for k in 0..3 {
            let (a, b, c) = (ev[k], ev[(k + 1) % 3], ev[(k + 2) % 3]);
            if a > b + c + tol {
                out.push(Inconsistency {
                    kind: InconsistencyKind::TriangleInequality,
                    message: format!(
                        "principal moments violate the triangle inequality: {a:.4e} > {b:.4e} + {c:.4e} kg·m²"
                    ),
                });
                break;
            }
        }
        out
    }
}

/// What is physically wrong with a link's inertial parameters.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InconsistencyKind {
    /// Mass ≤ 0 (or not a number).
    Mass,
    /// Inertia about the centroid has a principal moment ≤ 0.
    NotPositiveDefinite,
    /// A principal moment exceeds the sum of the other two (impossible for a rigid body,
    /// though the equations of motion stay well posed).
    TriangleInequality,
}

/// One physical-consistency finding of a link.
#[derive(Debug, Clone, PartialEq)]
pub struct Inconsistency {
    /// Which condition fails.
    pub kind: InconsistencyKind,
    /// A sentence with the numbers (SI units).
    pub message: String,
}

/// Eigenvalues of a symmetric 3×3 matrix, ascending (closed form, Smith 1961).
pub fn symmetric_eigenvalues(a: [[f64; 3]; 3]) -> [f64; 3] {
    let p1 = a[0][1].powi(2) + a[0][2].powi(2) + a[1][2].powi(2);
    if p1 == 0.0 {
        let mut d = [a[0][0], a[1][1], a[2][2]];
        d.sort_by(f64::total_cmp);
        return d;
    }
    let q = (a[0][0] + a[1][1] + a[2][2]) / 3.0;
    let p2 = (a[0][0] - q).powi(2) + (a[1][1] - q).powi(2) + (a[2][2] - q).powi(2) + 2.0 * p1;
    let p = (p2 / 6.0).sqrt();
    let mut b = [[0.0; 3]; 3];
    for r in 0..3 {
        for c in 0..3 {
            b[r][c] = (a[r][c] - if r == c { q } else { 0.0 }) / p;
        }
    }
    let det = b[0][0] * (b[1][1] * b[2][2] - b[1][2] * b[2][1])
        - b[0][1] * (b[1][0] * b[2][2] - b[1][2] * b[2][0])
        + b[0][2] * (b[1][0] * b[2][1] - b[1][1] * b[2][0]);
    let r = (det / 2.0).clamp(-1.0, 1.0);
    let phi = r.acos() / 3.0;
    let e1 = q + 2.0 * p * phi.cos();
    let e3 = q + 2.0 * p * (phi + 2.0 * std::f64::consts::PI / 3.0).cos();
    let e2 = 3.0 * q - e1 - e3;
    let mut d = [e1, e2, e3];
    d.sort_by(f64::total_cmp);
    d
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parallel_axis_round_trip() {
        let l = CentroidalInertia {
            m: 2.0,
            c: [0.1, -0.2, 0.3],
            i_c: [0.05, 0.001, -0.002, 0.04, 0.003, 0.03],
        };
        let b = l.to_barycentric();
        // XX = Ixx + m(y² + z²) = 0.05 + 2·(0.04 + 0.09)
        assert!((b[4] - 0.31).abs() < 1e-15);
        let back = CentroidalInertia::from_barycentric(&b).unwrap();
        for k in 0..6 {
            assert!((back.i_c[k] - l.i_c[k]).abs() < 1e-15);
        }
        assert!(l.consistency().is_empty());
    }

    #[test]
    fn flags_negative_inertia_and_triangle_violation() {
        // Appendix D coupled-method I4_33 is negative.
        let bad = CentroidalInertia {
            m: 0.1,
            c: [0.0; 3],
            i_c: [1e-4, 0.0, 0.0, 1e-4, 0.0, -1.7449e-4],
        };
        assert!(bad
            .consistency()
            .iter()
            .any(|s| s.contains("positive definite")));
        let tri = CentroidalInertia {
            m: 0.1,
            c: [0.0; 3],
            i_c: [1e-4, 0.0, 0.0, 1e-5, 0.0, 1e-5],
        };
        let f = tri.consistency();
        assert!(f.iter().any(|s| s.contains("triangle")), "{f:?}");
        assert!(CentroidalInertia { m: -1.0, ..tri }.consistency()[0].contains("mass"));
    }

    #[test]
    fn eigenvalues_of_known_matrix() {
        let e = symmetric_eigenvalues([[2.0, 1.0, 0.0], [1.0, 2.0, 0.0], [0.0, 0.0, 5.0]]);
        assert!(
            (e[0] - 1.0).abs() < 1e-12 && (e[1] - 3.0).abs() < 1e-12 && (e[2] - 5.0).abs() < 1e-12
        );
    }
}
