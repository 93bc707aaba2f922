//! An independent numeric reference for the generated kernels: the Lagrangian of the model
//! formed from forward kinematics composed numerically from the model file's elementary
//! transforms, with exact derivatives by (nested) dual numbers. It shares nothing with the
//! generator (symbolic Newton–Euler, composite-rigid-body algorithm, forward-mode symbolic
//! differentiation) except the parsed model file.
//!
//! - D(q) (thesis 3.2) = Σ_links m AᵀA + Aᵀ[B × h] + [A × h]... written per entry:
//!   D_kj = Σ m A_k·A_j − A_k·(h × B_j) + B_k·(h × A_j) + B_k·(J B_j), where A_k, B_k are the
//!   body-frame linear and angular velocity of the link frame per unit q̇_k (from ∂R/∂q_k and
//!   ∂p/∂q_k), h = m·c and J the inertia about the frame origin.
//! - Γ_ijk = ½(∂D_kj/∂q_i + ∂D_ki/∂q_j − ∂D_ij/∂q_k) (3.3), φ_k = ∂V/∂q_k with
//!   V = −g·(m p + R h) (3.4).
#![allow(dead_code, clippy::needless_range_loop)]

use codegen::model::{Model, Transform};
use std::ops::{Add, Mul, Neg, Sub};

/// Arithmetic the reference needs.
pub trait Scalar:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Neg<Output = Self>
{
    fn cst(x: f64) -> Self;
    fn sin(self) -> Self;
    fn cos(self) -> Self;
}

impl Scalar for f64 {
    fn cst(x: f64) -> f64 {
        x
    }
    fn sin(self) -> f64 {
        f64::sin(self)
    }
    fn cos(self) -> f64 {
        f64::cos(self)
    }
}

/// A dual number v + d·ε (ε² = 0): d carries an exact directional derivative.
#[derive(Clone, Copy, Debug)]
pub struct Dual<T> {
    pub v: T,
    pub d: T,
}

impl<T: Scalar> Add for Dual<T> {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        Dual {
            v: self.v + o.v,
            d: self.d + o.d,
        }
    }
}
impl<T: Scalar> Sub for Dual<T> {
    type Output = Self;
    fn sub(self, o: Self) -> Self {
        Dual {
            v: self.v - o.v,
            d: self.d - o.d,
        }
    }
}
impl<T: Scalar> Mul for Dual<T> {
    type Output = Self;
    fn mul(self, o: Self) -> Self {
        Dual {
            v: self.v * o.v,
            d: self.v * o.d + self.d * o.v,
        }
    }
}
impl<T: Scalar> Neg for Dual<T> {
    type Output = Self;
    fn neg(self) -> Self {
        Dual {
            v: -self.v,
            d: -self.d,
        }
    }
}
impl<T: Scalar> Scalar for Dual<T> {
    fn cst(x: f64) -> Self {
        Dual {
            v: T::cst(x),
            d: T::cst(0.0),
        }
    }
    fn sin(self) -> Self {
        Dual {
            v: self.v.sin(),
            d: self.d * self.v.cos(),
        }
    }
    fn cos(self) -> Self {
        Dual {
            v: self.v.cos(),
            d: -(self.d * self.v.sin()),
        }
    }
}

type M3<T> = [[T; 3]; 3];
type V3<T> = [T; 3];

fn dot<T: Scalar>(a: &V3<T>, b: &V3<T>) -> T {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross<T: Scalar>(a: &V3<T>, b: &V3<T>) -> V3<T> {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// World pose (R, p) of every frame of the model at `q`.
pub fn frame_poses<T: Scalar>(model: &Model, q: &[T]) -> Vec<(M3<T>, V3<T>)> {
    let z = T::cst(0.0);
    let one = T::cst(1.0);
    let mut poses: Vec<(M3<T>, V3<T>)> = Vec::new();
    for f in &model.frames {
        let (mut r, mut p) = match f.parent {
            None => ([[one, z, z], [z, one, z], [z, z, one]], [z, z, z]),
            Some(i) => poses[i],
        };
        for t in &f.transforms {
            match t {
                Transform::Rot {
                    axis,
                    joints,
                    offset,
                } => {
                    let mut th = T::cst(*offset);
                    for (k, &n) in joints.iter().enumerate() {
                        th = th + T::cst(n as f64) * q[k];
                    }
                    let (s, c) = (th.sin(), th.cos());
                    let mut l = [[one, z, z], [z, one, z], [z, z, one]];
                    let (i, j) = match axis {
                        0 => (1, 2),
                        1 => (2, 0),
                        _ => (0, 1),
                    };
                    l[i][i] = c;
                    l[j][j] = c;
                    l[i][j] = -s;
                    l[j][i] = s;
                    let mut nr = [[z; 3]; 3];
                    for a in 0..3 {
                        for b in 0..3 {
                            nr[a][b] = r[a][0] * l[0][b] + r[a][1] * l[1][b] + r[a][2] * l[2][b];
                        }
                    }
                    r = nr;
                }
                Transform::Trans {
                    axis,
                    joints,
                    offset,
                } => {
                    let mut x = T::cst(*offset);
                    for (k, &c) in joints.iter().enumerate() {
                        x = x + T::cst(c) * q[k];
                    }
                    for a in 0..3 {
                        p[a] = p[a] + r[a][*axis] * x;
                    }
                }
            }
        }
        poses.push((r, p));
    }
    poses
}

/// Barycentric parameters per link `[m, mx, my, mz, xx, xy, xz, yy, yz, zz]` from the
/// kernel's parameter vector.
pub fn link_params(gm: &generated::Model, p: &[f64]) -> Vec<[f64; 10]> {
    let mut out = vec![[0.0; 10]; gm.links.len()];
    for (j, &v) in p.iter().enumerate() {
        out[gm.param_link[j]][gm.param_kind[j]] = v;
    }
    out
}

fn seeded<T: Scalar>(q: &[T], k: usize) -> Vec<Dual<T>> {
    q.iter()
        .enumerate()
        .map(|(i, &x)| Dual {
            v: x,
            d: T::cst(if i == k { 1.0 } else { 0.0 }),
        })
        .collect()
}

/// D(q), NJ × NJ.
pub fn mass_matrix<T: Scalar>(model: &Model, bary: &[[f64; 10]], q: &[T]) -> Vec<Vec<T>> {
    let n = q.len();
    let z = T::cst(0.0);
    // a[l][k], b[l][k]: body-frame linear / angular velocity of link l per unit q̇_k.
    let nl = model.links.len();
    let mut a = vec![vec![[z; 3]; n]; nl];
    let mut b = vec![vec![[z; 3]; n]; nl];
    for k in 0..n {
        let poses = frame_poses(model, &seeded(q, k));
        for (l, link) in model.links.iter().enumerate() {
            let (r, p) = poses[link.frame];
            for x in 0..3 {
                a[l][k][x] = (0..3).fold(z, |acc, m| acc + r[m][x].v * p[m].d);
            }
            // S = Rᵀ dR, ω = (S21, S02, S10).
            let s = |i: usize, j: usize| (0..3).fold(z, |acc, m| acc + r[m][i].v * r[m][j].d);
            b[l][k] = [s(2, 1), s(0, 2), s(1, 0)];
        }
    }
    let mut d = vec![vec![z; n]; n];
    for (l, bp) in bary.iter().enumerate() {
        let m = T::cst(bp[0]);
        let h = [T::cst(bp[1]), T::cst(bp[2]), T::cst(bp[3])];
        let j = [
            [T::cst(bp[4]), T::cst(bp[5]), T::cst(bp[6])],
            [T::cst(bp[5]), T::cst(bp[7]), T::cst(bp[8])],
            [T::cst(bp[6]), T::cst(bp[8]), T::cst(bp[9])],
        ];
        for k in 0..n {
            for i in 0..n {
                let jb: V3<T> = std::array::from_fn(|r| dot(&j[r], &b[l][i]));
                d[k][i] = d[k][i] + m * dot(&a[l][k], &a[l][i])
                    - dot(&a[l][k], &cross(&h, &b[l][i]))
                    + dot(&b[l][k], &cross(&h, &a[l][i]))
                    + dot(&b[l][k], &jb);
            }
        }
    }
    d
}

/// Potential energy V(q) = −g·Σ (m p + R h).
pub fn potential<T: Scalar>(model: &Model, bary: &[[f64; 10]], q: &[T]) -> T {
    let poses = frame_poses(model, q);
    let g = model.gravity.map(T::cst);
    let mut v = T::cst(0.0);
    for (l, link) in model.links.iter().enumerate() {
        let (r, p) = poses[link.frame];
        let bp = bary[l];
        let h = [T::cst(bp[1]), T::cst(bp[2]), T::cst(bp[3])];
        let rh: V3<T> = std::array::from_fn(|x| dot(&r[x], &h));
        let mp: V3<T> = std::array::from_fn(|x| T::cst(bp[0]) * p[x]);
        v = v - dot(&g, &mp) - dot(&g, &rh);
    }
    v
}

/// Everything the kernels of one configuration return, from the reference.
pub struct Reference {
    pub d: Vec<Vec<f64>>,
    pub c: Vec<Vec<f64>>,
    pub cqd: Vec<f64>,
    pub phi: Vec<f64>,
    pub tau: Vec<f64>,
}

/// The reference for free joints `free` (locked joints: q̇ = q̈ = 0) at (q, q̇_F, q̈_F).
pub fn reference(
    model: &Model,
    bary: &[[f64; 10]],
    free: &[usize],
    q: &[f64],
    qd: &[f64],
    qdd: &[f64],
) -> Reference {
    let n = q.len();
    let nf = free.len();
    let dfull = mass_matrix(model, bary, q);
    // ∂D/∂q_i by dual numbers.
    let dd: Vec<Vec<Vec<f64>>> = (0..n)
        .map(|i| {
            mass_matrix(model, bary, &seeded(q, i))
                .into_iter()
                .map(|row| row.into_iter().map(|x| x.d).collect())
                .collect()
        })
        .collect();
    let phifull: Vec<f64> = (0..n)
        .map(|k| potential(model, bary, &seeded(q, k)).d)
        .collect();
    let gamma = |i: usize, j: usize, k: usize| 0.5 * (dd[i][k][j] + dd[j][k][i] - dd[k][i][j]);
    let d: Vec<Vec<f64>> = free
        .iter()
        .map(|&a| free.iter().map(|&b| dfull[a][b]).collect())
        .collect();
    let c: Vec<Vec<f64>> = (0..nf)
        .map(|a| {
            (0..nf)
                .map(|b| {
                    (0..nf)
                        .map(|i| gamma(free[i], free[b], free[a]) * qd[i])
                        .sum()
                })
                .collect()
        })
        .collect();
    let cqd: Vec<f64> = (0..nf)
        .map(|a| (0..nf).map(|b| c[a][b] * qd[b]).sum())
        .collect();
    let phi: Vec<f64> = free.iter().map(|&a| phifull[a]).collect();
    let tau = (0..nf)
        .map(|a| (0..nf).map(|b| d[a][b] * qdd[b]).sum::<f64>() + cqd[a] + phi[a])
        .collect();
    Reference {
        d,
        c,
        cqd,
        phi,
        tau,
    }
}

pub use generated::inertia::Xorshift as Rng;

/// Random physically consistent barycentric parameters for the model's parameter vector.
pub fn random_params(gm: &generated::Model, rng: &mut Rng) -> Vec<f64> {
    let per_link: Vec<[f64; 10]> = (0..gm.links.len())
        .map(|_| generated::inertia::CentroidalInertia::random(rng).to_barycentric())
        .collect();
    (0..gm.params.len())
        .map(|j| per_link[gm.param_link[j]][gm.param_kind[j]])
        .collect()
}

/// The model file behind a generated model.
pub fn model_file(gm: &generated::Model) -> Model {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../model")
        .join(format!("{}.toml", gm.name));
    codegen::model::Model::load(&path).expect("model file loads")
}
