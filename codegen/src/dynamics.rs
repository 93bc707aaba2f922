//! The dynamic model of one configuration, formed symbolically on a [`Graph`]:
//!
//! - inverse dynamics, C(q, q̇) q̇ and φ(q) by the recursive Newton–Euler algorithm (Luh,
//!   Walker & Paul 1980; in the customised symbolic form of Khalil & Kleinfinger), over a tree
//!   of elementary transforms in which each rotation angle and translation is linear in the
//!   joint variables (so parallelogram couplings like θ = −q2 − π/2 need no special case:
//!   the generalised force of joint k is Σ_e (∂θ_e/∂q_k) τ_e by virtual work);
//! - the inertia matrix D_FF(q) (thesis 3.2) by the composite-rigid-body algorithm;
//! - the Christoffel matrix (thesis 3.3), C_kj = Σ_i ½(∂D_kj/∂q_i + ∂D_ki/∂q_j − ∂D_ij/∂q_k) q̇_i,
//!   written as C = ½(Ḋ + A − Aᵀ) with A_kj = ∂(D q̇)_k/∂q_j, both by forward-mode
//!   differentiation through the graph;
//! - the regressor Y_F = ∂τ_F/∂p (τ is linear in the barycentric parameters p).
//!
//! Vectors are in the frame of the node they belong to; the wrench of a node is taken at its
//! origin. Locked joints have q̇ = q̈ = 0: their velocity symbols never enter.

use crate::graph::{Direction, Graph, Inputs};
use crate::model::{Model, Transform};
use crate::symbolic::{rational, sincos, Barycentric, Vars};
use symbolica::atom::Atom;

type V3 = [Atom; 3];

/// One elementary joint of the kinematic tree.
#[derive(Debug, Clone)]
enum Motion {
    /// The world frame.
    World,
    /// Rotation about `axis` by `Σ n_k q_k + offset`.
    Rot {
        axis: usize,
        joints: Vec<i64>,
        offset: f64,
    },
    /// Translation by `p = Σ_k u_k q_k + p0` (consecutive translations merged).
    Trans { u: Vec<[f64; 3]>, p0: [f64; 3] },
}

/// A node of the tree: a frame reached from its parent by one elementary motion.
#[derive(Debug, Clone)]
struct Node {
    parent: usize,
    motion: Motion,
    links: Vec<usize>,
}

/// The model's frames as a tree of elementary motions, pruned to what carries a link.
pub struct Tree {
    nodes: Vec<Node>,
}

impl Tree {
    /// Build the tree of `model`.
    pub fn new(model: &Model) -> Tree {
        let n = model.joints.len();
        let mut nodes = vec![Node {
            parent: usize::MAX,
            motion: Motion::World,
            links: vec![],
        }];
        let mut frame_node = vec![0usize; model.frames.len()];
        for (fi, f) in model.frames.iter().enumerate() {
            let Some(pf) = f.parent else {
                continue;
            };
            let mut cur = frame_node[pf];
            let mut pending: Option<(Vec<[f64; 3]>, [f64; 3])> = None;
            let flush = |cur: &mut usize,
                         pending: &mut Option<(Vec<[f64; 3]>, [f64; 3])>,
                         nodes: &mut Vec<Node>| {
                if let Some((u, p0)) = pending.take() {
                    if u.iter().flatten().any(|&x| x != 0.0) || p0.iter().any(|&x| x != 0.0) {
                        nodes.push(Node {
                            parent: *cur,
                            motion: Motion::Trans { u, p0 },
                            links: vec![],
                        });
                        *cur = nodes.len() - 1;
                    }
                }
            };
            for t in &f.transforms {
                match t {
                    Transform::Trans {
                        axis,
                        joints,
                        offset,
                    } => {
                        let (u, p0) = pending.get_or_insert_with(|| (vec![[0.0; 3]; n], [0.0; 3]));
                        for (k, &c) in joints.iter().enumerate() {
                            u[k][*axis] += c;
                        }
                        p0[*axis] += offset;
                    }
                    Transform::Rot {
                        axis,
                        joints,
                        offset,
                    } => {
                        flush(&mut cur, &mut pending, &mut nodes);
                        if joints.iter().all(|&x| x == 0) && *offset == 0.0 {
                            continue;
                        }
                        nodes.push(Node {
                            parent: cur,
                            motion: Motion::Rot {
                                axis: *axis,
                                joints: joints.clone(),
                                offset: *offset,
                            },
                            links: vec![],
                        });
                        cur = nodes.len() - 1;
                    }
                }
            }
            flush(&mut cur, &mut pending, &mut nodes);
            frame_node[fi] = cur;
        }
        for (li, l) in model.links.iter().enumerate() {
            nodes[frame_node[l.frame]].links.push(li);
        }
        // Prune nodes whose subtree carries no link (children come after parents).
        let mut carries = vec![false; nodes.len()];
        for i in (0..nodes.len()).rev() {
            carries[i] |= !nodes[i].links.is_empty();
            if i > 0 && carries[i] {
                carries[nodes[i].parent] = true;
            }
        }
        let mut map = vec![usize::MAX; nodes.len()];
        let mut kept = Vec::new();
        for (i, node) in nodes.into_iter().enumerate() {
            if i == 0 || carries[i] {
                map[i] = kept.len();
                let mut node = node;
                if i > 0 {
                    node.parent = map[node.parent];
                }
                kept.push(node);
            }
        }
        Tree { nodes: kept }
    }
}

/// Per-node kinematic data of a configuration.
struct Kin {
    /// sin and cos of a rotation node's angle.
    sc: Vec<Option<(Atom, Atom)>>,
    /// Translation vector of a translation node.
    p: Vec<Option<V3>>,
}

/// The symbolic dynamics of one configuration (all entries are values of `graph`).
pub struct ConfigDynamics {
    /// The graph holding every intermediate.
    pub graph: Graph,
    /// D_FF, NF × NF.
    pub d: Vec<Vec<Atom>>,
    /// Christoffel matrix C_FF, NF × NF.
    pub c: Vec<Vec<Atom>>,
    /// C_FF q̇_F, NF.
    pub cqd: Vec<Atom>,
    /// φ_F, NF.
    pub phi: Vec<Atom>,
    /// C_FF q̇_F + φ_F, NF (forward dynamics).
    pub h: Vec<Atom>,
    /// τ_F = D q̈ + C q̇ + φ, NF.
    pub tau: Vec<Atom>,
    /// Y_F, NF × NP.
    pub y: Vec<Vec<Atom>>,
}

fn zero3() -> V3 {
    [Atom::num(0), Atom::num(0), Atom::num(0)]
}

fn cross(a: &V3, b: &V3) -> V3 {
    [
        &a[1] * &b[2] - &a[2] * &b[1],
        &a[2] * &b[0] - &a[0] * &b[2],
        &a[0] * &b[1] - &a[1] * &b[0],
    ]
}

fn dot3(a: &V3, b: &V3) -> Atom {
    (0..3).fold(Atom::num(0), |acc, x| acc + &a[x] * &b[x])
}

fn add3(a: &V3, b: &V3) -> V3 {
    [&a[0] + &b[0], &a[1] + &b[1], &a[2] + &b[2]]
}

fn scale3(a: &V3, s: &Atom) -> V3 {
    [&a[0] * s, &a[1] * s, &a[2] * s]
}

fn unit(axis: usize, s: Atom) -> V3 {
    let mut v = zero3();
    v[axis] = s;
    v
}

/// The index pair (i, j) rotated by a rotation about `axis`.
fn plane(axis: usize) -> (usize, usize) {
    match axis {
        0 => (1, 2),
        1 => (2, 0),
        _ => (0, 1),
    }
}

/// R x for a rotation about `axis` with sine `s` and cosine `c`.
fn rot(axis: usize, s: &Atom, c: &Atom, x: &V3) -> V3 {
    let (i, j) = plane(axis);
    let mut y = x.clone();
    y[i] = c * &x[i] - s * &x[j];
    y[j] = s * &x[i] + c * &x[j];
    y
}

/// Rᵀ x.
fn rot_t(axis: usize, s: &Atom, c: &Atom, x: &V3) -> V3 {
    let (i, j) = plane(axis);
    let mut y = x.clone();
    y[i] = c * &x[i] + s * &x[j];
    y[j] = c * &x[j] - s * &x[i];
    y
}

/// A symmetric 3×3 tensor as `[xx, xy, xz, yy, yz, zz]`.
type Sym3 = [Atom; 6];

/// The entries (row, column) of a [`Sym3`] in its storage order ([`sym_index`]'s inverse).
const SYM_PAIRS: [(usize, usize); 6] = [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)];

fn sym_index(r: usize, c: usize) -> usize {
    match (r.min(c), r.max(c)) {
        (0, 0) => 0,
        (0, 1) => 1,
        (0, 2) => 2,
        (1, 1) => 3,
        (1, 2) => 4,
        _ => 5,
    }
}

fn sym_mul(j: &Sym3, x: &V3) -> V3 {
    std::array::from_fn(|r| (0..3).fold(Atom::num(0), |acc, c| acc + &j[sym_index(r, c)] * &x[c]))
}

/// Barycentric inertial parameters of the links on a node, summed: (m, h = m·c, J about the
/// node origin), as sums of parameter symbols.
#[derive(Clone)]
struct NodeInertia {
    m: Atom,
    h: V3,
    j: Sym3,
}

impl NodeInertia {
    fn zero() -> NodeInertia {
        NodeInertia {
            m: Atom::num(0),
            h: zero3(),
            j: std::array::from_fn(|_| Atom::num(0)),
        }
    }

    fn is_zero(&self) -> bool {
        self.m.is_zero() && self.h.iter().all(|x| x.is_zero()) && self.j.iter().all(|x| x.is_zero())
    }
}

/// The configuration's dynamics for the free joints `free` (ascending joint indices).
pub fn config_dynamics(
    model: &Model,
    vars: &Vars,
    tree: &Tree,
    params: &[Barycentric],
    p_sym: &[symbolica::atom::Symbol],
    free: &[usize],
) -> ConfigDynamics {
    let nf = free.len();
    let inputs = Inputs {
        vars: vars.clone(),
        p: p_sym.to_vec(),
        free: free.to_vec(),
    };
    let mut g = Graph::new(inputs, "");
    let nodes = &tree.nodes;
    // Kinematics shared by every pass.
    let mut kin = Kin {
        sc: vec![None; nodes.len()],
        p: vec![None; nodes.len()],
    };
    for (i, node) in nodes.iter().enumerate() {
        match &node.motion {
            Motion::Rot { joints, offset, .. } => {
                let (s, c) = sincos(vars, joints, *offset);
                kin.sc[i] = Some((g.value(s), g.value(c)));
            }
            Motion::Trans { u, p0 } => {
                let p = std::array::from_fn(|a| {
                    let mut e = rational(p0[a]);
                    for (k, uk) in u.iter().enumerate() {
                        if uk[a] != 0.0 {
                            e += rational(uk[a]) * Atom::var(vars.q[k]);
                        }
                    }
                    e
                });
                kin.p[i] = Some(g.values(p));
            }
            Motion::World => {}
        }
    }
    let inertia: Vec<NodeInertia> = nodes
        .iter()
        .map(|node| {
            let mut ni = NodeInertia::zero();
            for (pi, b) in params.iter().enumerate() {
                if !node.links.contains(&b.link) {
                    continue;
                }
                let p = Atom::var(p_sym[pi]);
                match b.kind {
                    0 => ni.m += p,
                    1..=3 => ni.h[b.kind - 1] += p,
                    k => ni.j[k - 4] += p,
                }
            }
            ni
        })
        .collect();

    // The kernels from the locked subtrees folded into composite bodies; the regressor from
    // the links one by one, where its columns are cheaper (a folded body's parameters enter
    // through its transfer's rotations).
    let mut folded = inertia.clone();
    let any_folded = fold_locked(&mut g, nodes, &kin, &mut folded, free);
    let tau_links =
        any_folded.then(|| rnea(&mut g, nodes, &kin, &inertia, model, free, true, true, true));
    let inertia = folded;
    let tau = rnea(&mut g, nodes, &kin, &inertia, model, free, true, true, true);
    let cqd = rnea(
        &mut g, nodes, &kin, &inertia, model, free, true, false, false,
    );
    let phi = rnea(
        &mut g, nodes, &kin, &inertia, model, free, false, false, true,
    );
    let h = rnea(
        &mut g, nodes, &kin, &inertia, model, free, true, false, true,
    );
    let d = crba(&mut g, nodes, &kin, &inertia, free);

    // Christoffel matrix C = ½(Ḋ + A − Aᵀ), A_kj = ∂(D q̇)_k/∂q_j.
    let momentum: Vec<Atom> = (0..nf)
        .map(|k| {
            let e = (0..nf).fold(Atom::num(0), |acc, i| {
                acc + &d[k][i] * Atom::var(vars.qd[free[i]])
            });
            g.value(e)
        })
        .collect();
    let mut a = vec![vec![Atom::num(0); nf]; nf];
    for k in 0..nf {
        for j in 0..nf {
            a[k][j] = g.derivative(&momentum[k], Direction::Joint(free[j]));
        }
    }
    let mut c = vec![vec![Atom::num(0); nf]; nf];
    for k in 0..nf {
        for j in 0..nf {
            let ddot = g.derivative(&d[k][j], Direction::Time);
            let e = (ddot + &a[k][j] - &a[j][k]) * Atom::num((1, 2));
            c[k][j] = g.value(e);
        }
    }
    let tau_y = tau_links.as_ref().unwrap_or(&tau);
    let y = (0..nf)
        .map(|r| {
            (0..params.len())
                .map(|j| g.derivative(&tau_y[r], Direction::Param(j)))
                .collect()
        })
        .collect();
    ConfigDynamics {
        graph: g,
        d,
        c,
        cqd,
        phi,
        h,
        tau,
        y,
    }
}

/// Joint-rate combination Σ_{k∈F} coef_k · x_k (x = q̇ or q̈ symbols).
fn rate(coef: impl Fn(usize) -> f64, free: &[usize], x: &[symbolica::atom::Symbol]) -> Atom {
    free.iter().fold(Atom::num(0), |acc, &k| {
        let c = coef(k);
        if c == 0.0 {
            acc
        } else {
            acc + rational(c) * Atom::var(x[k])
        }
    })
}

/// Recursive Newton–Euler: generalised forces of the free joints with the velocity,
/// acceleration and gravity terms switched on or off.
#[allow(clippy::too_many_arguments)]
fn rnea(
    g: &mut Graph,
    nodes: &[Node],
    kin: &Kin,
    inertia: &[NodeInertia],
    model: &Model,
    free: &[usize],
    vel: bool,
    acc: bool,
    grav: bool,
) -> Vec<Atom> {
    let qd = g.inputs.vars.qd.clone();
    let qdd = g.inputs.vars.qdd.clone();
    let n = nodes.len();
    let mut w: Vec<V3> = vec![zero3(); n];
    let mut wd: Vec<V3> = vec![zero3(); n];
    let mut vd: Vec<V3> = vec![zero3(); n];
    if grav {
        // The base accelerates upwards at g: gravity acts on every link (Luh, Walker, Paul).
        vd[0] = g.values(model.gravity.map(|x| -rational(x)));
    }
    // U = [ω̇]× + [ω]×[ω]× per node, formed on demand.
    let mut u_cache: Vec<Option<[[Atom; 3]; 3]>> = vec![None; n];
    let mut u_of = |g: &mut Graph, i: usize, w: &V3, wd: &V3| -> [[Atom; 3]; 3] {
        if let Some(u) = &u_cache[i] {
            return u.clone();
        }
        let sq = [
            g.value(&w[0] * &w[0]),
            g.value(&w[1] * &w[1]),
            g.value(&w[2] * &w[2]),
        ];
        let w01 = g.value(&w[0] * &w[1]);
        let w02 = g.value(&w[0] * &w[2]);
        let w12 = g.value(&w[1] * &w[2]);
        let u = [
            [
                g.value(-(&sq[1] + &sq[2])),
                g.value(&w01 - &wd[2]),
                g.value(&w02 + &wd[1]),
            ],
            [
                g.value(&w01 + &wd[2]),
                g.value(-(&sq[0] + &sq[2])),
                g.value(&w12 - &wd[0]),
            ],
            [
                g.value(&w02 - &wd[1]),
                g.value(&w12 + &wd[0]),
                g.value(-(&sq[0] + &sq[1])),
            ],
        ];
        u_cache[i] = Some(u.clone());
        u
    };
    let umul = |u: &[[Atom; 3]; 3], x: &V3| -> V3 {
        std::array::from_fn(|r| (0..3).fold(Atom::num(0), |acc, c| acc + &u[r][c] * &x[c]))
    };
    for i in 1..n {
        let pi = nodes[i].parent;
        match &nodes[i].motion {
            Motion::Rot { axis, joints, .. } => {
                let (s, c) = kin.sc[i].clone().expect("rotation node has sin/cos");
                let thd = if vel {
                    g.value(rate(|k| joints[k] as f64, free, &qd))
                } else {
                    Atom::num(0)
                };
                let thdd = if acc {
                    g.value(rate(|k| joints[k] as f64, free, &qdd))
                } else {
                    Atom::num(0)
                };
                let wp = w[pi].clone();
                let ww = g.values(add3(&wp, &unit(*axis, thd.clone())));
                w[i] = g.values(rot_t(*axis, &s, &c, &ww));
                let e = unit(*axis, Atom::num(1));
                let wdd = add3(
                    &add3(&wd[pi], &scale3(&cross(&wp, &e), &thd)),
                    &unit(*axis, thdd),
                );
                let wdd = g.values(wdd);
                wd[i] = g.values(rot_t(*axis, &s, &c, &wdd));
                vd[i] = g.values(rot_t(*axis, &s, &c, &vd[pi]));
            }
            Motion::Trans { u, .. } => {
                let p = kin.p[i].clone().expect("translation node has p");
                w[i] = w[pi].clone();
                wd[i] = wd[pi].clone();
                let pd: V3 = std::array::from_fn(|a| {
                    if vel {
                        rate(|k| u[k][a], free, &qd)
                    } else {
                        Atom::num(0)
                    }
                });
                let pdd: V3 = std::array::from_fn(|a| {
                    if acc {
                        rate(|k| u[k][a], free, &qdd)
                    } else {
                        Atom::num(0)
                    }
                });
                let up = u_of(g, pi, &w[pi].clone(), &wd[pi].clone());
                let up = umul(&up, &p);
                let up = g.values(up);
                let cor = g.values(scale3(&cross(&w[pi], &pd), &Atom::num(2)));
                vd[i] = g.values(add3(&add3(&vd[pi], &up), &add3(&cor, &pdd)));
            }
            Motion::World => {}
        }
    }
    // Backward: wrenches at node origins, in node frames.
    let mut f: Vec<V3> = vec![zero3(); n];
    let mut nn: Vec<V3> = vec![zero3(); n];
    let nf = free.len();
    let mut tau = vec![Atom::num(0); nf];
    for i in (1..n).rev() {
        let ni = &inertia[i];
        if !ni.is_zero() {
            let u = u_of(g, i, &w[i].clone(), &wd[i].clone());
            let uh = g.values(umul(&u, &ni.h));
            let mv = g.values(scale3(&vd[i], &ni.m));
            let fl = add3(&mv, &uh);
            let jw = g.values(sym_mul(&ni.j, &w[i]));
            let jwd = g.values(sym_mul(&ni.j, &wd[i]));
            let gyro = g.values(cross(&w[i], &jw));
            let hv = g.values(cross(&ni.h, &vd[i]));
            let nl = add3(&add3(&jwd, &gyro), &hv);
            f[i] = add3(&f[i], &fl);
            nn[i] = add3(&nn[i], &nl);
        }
        let fi = g.values(f[i].clone());
        let ni_ = g.values(nn[i].clone());
        // Generalised forces: the wrench across node i projected on each free joint's
        // motion (virtual work), then the wrench moved to the parent.
        for (a, &k) in free.iter().enumerate() {
            if let Some((angular, s)) = joint_columns(&nodes[i], k) {
                tau[a] = &tau[a] + dot3(&s, if angular { &ni_ } else { &fi });
            }
        }
        let pi = nodes[i].parent;
        let (fp, np) = transport(g, &nodes[i], kin, i, &fi, &ni_);
        f[pi] = add3(&f[pi], &fp);
        nn[pi] = add3(&nn[pi], &np);
    }
    tau.into_iter().map(|t| g.value(t)).collect()
}

/// Move a wrench (F, N) at node `i`'s origin, in its frame, to its parent's.
fn transport(g: &mut Graph, node: &Node, kin: &Kin, i: usize, fw: &V3, nw: &V3) -> (V3, V3) {
    match &node.motion {
        Motion::Rot { axis, .. } => {
            let (s, c) = kin.sc[i].clone().expect("rotation node has sin/cos");
            (
                g.values(rot(*axis, &s, &c, fw)),
                g.values(rot(*axis, &s, &c, nw)),
            )
        }
        Motion::Trans { .. } => {
            let p = kin.p[i].clone().expect("translation node has p");
            let pf = cross(&p, fw);
            (fw.clone(), g.values(add3(nw, &pf)))
        }
        Motion::World => (fw.clone(), nw.clone()),
    }
}

/// The motion of node `i` per unit rate of free joint `k`: `Some((angular?, axis-or-u))`.
fn joint_columns(node: &Node, k: usize) -> Option<(bool, V3)> {
    match &node.motion {
        Motion::Rot { axis, joints, .. } if joints[k] != 0 => {
            Some((true, unit(*axis, Atom::num(joints[k]))))
        }
        Motion::Trans { u, .. } if u[k].iter().any(|&x| x != 0.0) => {
            Some((false, u[k].map(rational)))
        }
        _ => None,
    }
}

/// A body's barycentric parameters (m, h = m·c, J about the origin) in node `i`'s frame,
/// expressed in its parent's (the composite-rigid-body transfer); None for the world node.
fn to_parent(
    g: &mut Graph,
    node: &Node,
    kin: &Kin,
    i: usize,
    (m, h, j): (Atom, V3, Sym3),
) -> Option<(Atom, V3, Sym3)> {
    match &node.motion {
        Motion::Rot { axis, .. } => {
            let (s, c) = kin.sc[i].clone().expect("rotation node has sin/cos");
            let hr = g.values(rot(*axis, &s, &c, &h));
            // R J Rᵀ, column by column: R (J Rᵀ e_c) = R J (row c of R)ᵀ.
            let rows: [V3; 3] = std::array::from_fn(|r| {
                let e = rot_t(*axis, &s, &c, &unit(r, Atom::num(1)));
                let je = g.values(sym_mul(&j, &e));
                g.values(rot(*axis, &s, &c, &je))
            });
            let jr: Sym3 = std::array::from_fn(|k| {
                let (r, cc) = SYM_PAIRS[k];
                rows[cc][r].clone()
            });
            Some((m, hr, jr))
        }
        Motion::Trans { .. } => {
            let p = kin.p[i].clone().expect("translation node has p");
            // J_parent = J + m(|p|² I − p pᵀ) − (h pᵀ + p hᵀ) + 2 (p·h) I.
            let pp = g.value((0..3).fold(Atom::num(0), |acc, a| acc + &p[a] * &p[a]));
            let ph = g.value((0..3).fold(Atom::num(0), |acc, a| acc + &p[a] * &h[a]));
            let mp = g.values(scale3(&p, &m));
            let jp: Sym3 = std::array::from_fn(|k| {
                let (r, cc) = SYM_PAIRS[k];
                let mut e = &j[k] - &mp[r] * &p[cc] - &h[r] * &p[cc] - &p[r] * &h[cc];
                if r == cc {
                    e = e + &m * &pp + Atom::num(2) * &ph;
                }
                e
            });
            let hp = add3(&h, &mp);
            Some((m, hp, jp))
        }
        Motion::World => None,
    }
}

/// The links of every subtree in which no joint moves (its nodes' motions read only locked
/// joints) folded into the node it hangs from, as one composite body (the
/// composite-rigid-body transfer, [`to_parent`]): the recursive algorithms then neither
/// propagate velocities through the locked links nor form their wrenches one by one, and
/// the composite's parameters read only the locked joints and p, which the emitted
/// simulator kernel computes once per run.
fn fold_locked(
    g: &mut Graph,
    nodes: &[Node],
    kin: &Kin,
    inertia: &mut [NodeInertia],
    free: &[usize],
) -> bool {
    let n = nodes.len();
    let moves = |node: &Node| free.iter().any(|&k| joint_columns(node, k).is_some());
    let reads_a_joint = |node: &Node| match &node.motion {
        Motion::Rot { joints, .. } => joints.iter().any(|&c| c != 0),
        Motion::Trans { u, .. } => u.iter().flatten().any(|&x| x != 0.0),
        Motion::World => false,
    };
    // Bottom-up: whether a free joint moves a node of the subtree, and whether a (locked)
    // joint does.
    let mut moving_below = vec![false; n];
    let mut joint_below = vec![false; n];
    for i in (1..n).rev() {
        moving_below[i] |= moves(&nodes[i]);
        joint_below[i] |= reads_a_joint(&nodes[i]);
        let pi = nodes[i].parent;
        moving_below[pi] |= moving_below[i];
        joint_below[pi] |= joint_below[i];
    }
    // Top-down: a subtree no free joint moves is folded where it holds a locked joint (a
    // subtree of constant transforms alone, such as a last link's fixed rotation, stays:
    // folding it gains nothing and spreads its inertia over more terms).
    let mut fold = vec![false; n];
    for i in 1..n {
        let pi = nodes[i].parent;
        fold[i] = !moving_below[i]
            && if moving_below[pi] {
                joint_below[i]
            } else {
                fold[pi]
            };
    }
    let mut any = false;
    for i in (1..n).rev() {
        if !fold[i] {
            continue;
        }
        let ni = std::mem::replace(&mut inertia[i], NodeInertia::zero());
        if ni.is_zero() {
            continue;
        }
        let body = (g.value(ni.m), g.values(ni.h), g.values(ni.j));
        let pi = nodes[i].parent;
        any = true;
        if let Some((m, h, j)) = to_parent(g, &nodes[i], kin, i, body) {
            let parent = &mut inertia[pi];
            parent.m = &parent.m + &m;
            parent.h = add3(&parent.h, &h);
            for (a, b) in parent.j.iter_mut().zip(j) {
                *a = &*a + &b;
            }
        }
    }
    any
}

/// Composite-rigid-body algorithm: D_FF.
fn crba(
    g: &mut Graph,
    nodes: &[Node],
    kin: &Kin,
    inertia: &[NodeInertia],
    free: &[usize],
) -> Vec<Vec<Atom>> {
    let n = nodes.len();
    let nf = free.len();
    // Composite inertia of each node's subtree about its origin, in its frame.
    let mut cm: Vec<Atom> = inertia.iter().map(|x| x.m.clone()).collect();
    let mut ch: Vec<V3> = inertia.iter().map(|x| x.h.clone()).collect();
    let mut cj: Vec<Sym3> = inertia.iter().map(|x| x.j.clone()).collect();
    for i in (1..n).rev() {
        cm[i] = g.value(cm[i].clone());
        ch[i] = g.values(ch[i].clone());
        cj[i] = g.values(cj[i].clone());
        let pi = nodes[i].parent;
        let (m, h, j) = (cm[i].clone(), ch[i].clone(), cj[i].clone());
        if let Some((m, h, j)) = to_parent(g, &nodes[i], kin, i, (m, h, j)) {
            cm[pi] = &cm[pi] + &m;
            ch[pi] = add3(&ch[pi], &h);
            for (a, b) in cj[pi].iter_mut().zip(j) {
                *a = &*a + &b;
            }
        }
    }
    let mut d = vec![vec![Atom::num(0); nf]; nf];
    for e in 1..n {
        for (kf, &k) in free.iter().enumerate() {
            let Some((angular, s)) = joint_columns(&nodes[e], k) else {
                continue;
            };
            // Wrench that accelerates the composite body of `e` at unit rate of joint k.
            let (mut fw, mut nw) = if angular {
                (g.values(cross(&s, &ch[e])), g.values(sym_mul(&cj[e], &s)))
            } else {
                (g.values(scale3(&s, &cm[e])), g.values(cross(&ch[e], &s)))
            };
            let mut x = e;
            while x != 0 {
                for (lf, &l) in free.iter().enumerate() {
                    let Some((ang_l, sl)) = joint_columns(&nodes[x], l) else {
                        continue;
                    };
                    let w = if ang_l { &nw } else { &fw };
                    let val = g.value(dot3(&sl, w));
                    d[lf][kf] = &d[lf][kf] + &val;
                    if x != e {
                        d[kf][lf] = &d[kf][lf] + &val;
                    }
                }
                let (f2, n2) = transport(g, &nodes[x], kin, x, &fw, &nw);
                fw = f2;
                nw = n2;
                x = nodes[x].parent;
            }
        }
    }
    d.into_iter()
        .map(|row| row.into_iter().map(|e| g.value(e)).collect())
        .collect()
}
