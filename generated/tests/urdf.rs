//! Models read from URDF (model/urdf/) against independent references:
//!
//! - the Staubli TX40 (FIGAROH's URDF) and the Panda against Pinocchio 4 reading the same
//!   URDF files, and the UR5 (joint axes along y, rpy origins) likewise
//!   (M, C, g, C q̇, τ and forward dynamics at ten random states; the numbers were
//!   printed by bench/pinocchio_urdf.py and are committed in tests/data/);
//! - the Panda from URDF against the hand-written modified-DH file panda.toml;
//! - the planar parallelogram with a `<mimic>` joint against its twin written with a coupled
//!   angle and the merged tip computed by hand (parallelogram_dh.toml).

use lockstep_rng::Xorshift;

/// One state with Pinocchio's values (filled by the files in tests/data/).
pub struct PinocchioState<const N: usize> {
    pub q: [f64; N],
    pub qd: [f64; N],
    pub qdd: [f64; N],
    pub tau_in: [f64; N],
    pub m: [[f64; N]; N],
    pub g: [f64; N],
    pub c: [[f64; N]; N],
    pub cqd: [f64; N],
    pub tau: [f64; N],
    /// Forward dynamics for `tau_in` (`None` where M is singular: the TX40).
    pub qdd_of_tau_in: Option<[f64; N]>,
}

#[allow(dead_code)]
mod pinocchio_tx40 {
    include!("data/pinocchio_tx40.rs");
}
#[allow(dead_code)]
mod pinocchio_panda_urdf {
    include!("data/pinocchio_panda_urdf.rs");
}
#[allow(dead_code)]
mod pinocchio_ur5 {
    include!("data/pinocchio_ur5.rs");
}

/// The model's default parameter vector: barycentric parameters from the symbols' defaults.
fn defaults(m: &generated::Model) -> Vec<f64> {
    let u: Vec<f64> = m
        .symbol_defaults
        .iter()
        .map(|d| d.expect("every symbol of a URDF model has a default"))
        .collect();
    let mut p = vec![0.0; m.params.len()];
    (m.barycentric_from_symbols)(&u, &mut p);
    p
}

/// The outputs of a model's full configuration at one state.
struct Outputs {
    m: Vec<f64>,
    c: Vec<f64>,
    cqd: Vec<f64>,
    g: Vec<f64>,
    tau: Vec<f64>,
    acc: Vec<f64>,
}

fn outputs(model: &str, q: &[f64], qd: &[f64], qdd: &[f64], tau_in: &[f64]) -> Outputs {
    let m = generated::model(model).unwrap_or_else(|| panic!("model {model} is generated"));
    let c = m.configuration("full").unwrap();
    let p = defaults(m);
    let n = q.len();
    let mut o = Outputs {
        m: vec![0.0; n * n],
        c: vec![0.0; n * n],
        cqd: vec![0.0; n],
        g: vec![0.0; n],
        tau: vec![0.0; n],
        acc: vec![0.0; n],
    };
    (c.mass_matrix)(q, &p, &mut o.m);
    (c.christoffel_matrix)(q, qd, &p, &mut o.c);
    (c.coriolis)(q, qd, &p, &mut o.cqd);
    (c.gravity)(q, &p, &mut o.g);
    (c.inverse_dynamics)(q, qd, qdd, &p, &mut o.tau);
    (c.forward_dynamics)(q, qd, tau_in, &p, &mut o.acc);
    o
}

/// Max |x − r| ≤ rel · max(|r|, floor).
fn close(what: &str, x: &[f64], r: &[f64], rel: f64) {
    assert_eq!(x.len(), r.len(), "{what}");
    let scale = r.iter().fold(1e-3f64, |m, v| m.max(v.abs()));
    let err = x
        .iter()
        .zip(r)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(
        err <= rel * scale,
        "{what}: error {err:e} (scale {scale:e})\n lockstep {x:?}\n reference {r:?}"
    );
}

fn against_pinocchio<const N: usize>(model: &str, states: &[PinocchioState<N>]) {
    for (i, s) in states.iter().enumerate() {
        let o = outputs(model, &s.q, &s.qd, &s.qdd, &s.tau_in);
        let w = |k: &str| format!("{model} state {i} {k}");
        close(&w("M"), &o.m, s.m.as_flattened(), 1e-10);
        close(&w("g"), &o.g, &s.g, 1e-10);
        close(&w("C qd"), &o.cqd, &s.cqd, 1e-10);
        close(&w("C"), &o.c, s.c.as_flattened(), 1e-10);
        close(&w("tau"), &o.tau, &s.tau, 1e-10);
        if let Some(acc) = &s.qdd_of_tau_in {
            close(&w("qdd"), &o.acc, acc, 1e-10);
        }
    }
}

#[test]
fn tx40_from_urdf_matches_pinocchio() {
    against_pinocchio("tx40", &pinocchio_tx40::STATES);
    // Forward dynamics with q6 locked (configuration arm5) against Pinocchio's reduced model.
    let m = generated::model("tx40").unwrap();
    let c = m.configuration("arm5").unwrap();
    let p = defaults(m);
    for (i, (s, r)) in pinocchio_tx40::STATES
        .iter()
        .zip(&pinocchio_tx40::LOCKED_LAST_QDD)
        .enumerate()
    {
        let mut acc = [0.0; 5];
        (c.forward_dynamics)(&s.q, &s.qd[..5], &s.tau_in[..5], &p, &mut acc);
        close(&format!("tx40 arm5 state {i} qdd"), &acc, r, 1e-10);
    }
}

#[test]
fn ur5_from_urdf_matches_pinocchio() {
    // Four joints about y, rpy origins, a world link and massless fixed frames.
    against_pinocchio("ur5", &pinocchio_ur5::STATES);
}

#[test]
fn panda_from_urdf_matches_pinocchio() {
    against_pinocchio("panda_urdf", &pinocchio_panda_urdf::STATES);
}

fn random_state(rng: &mut Xorshift, n: usize) -> [Vec<f64>; 4] {
    std::array::from_fn(|k| {
        let r = [std::f64::consts::PI, 2.0, 3.0, 5.0][k];
        (0..n).map(|_| rng.uniform(-r, r)).collect()
    })
}

fn same_dynamics(a: &str, b: &str, n: usize) {
    let mut rng = Xorshift(58);
    for i in 0..10 {
        let [q, qd, qdd, tau] = random_state(&mut rng, n);
        let (x, y) = (
            outputs(a, &q, &qd, &qdd, &tau),
            outputs(b, &q, &qd, &qdd, &tau),
        );
        let w = |k: &str| format!("{a} vs {b} state {i} {k}");
        close(&w("M"), &x.m, &y.m, 1e-12);
        close(&w("C"), &x.c, &y.c, 1e-12);
        close(&w("C qd"), &x.cqd, &y.cqd, 1e-12);
        close(&w("g"), &x.g, &y.g, 1e-12);
        close(&w("tau"), &x.tau, &y.tau, 1e-12);
        close(&w("qdd"), &x.acc, &y.acc, 1e-12);
    }
}

#[test]
fn panda_from_urdf_equals_the_hand_written_dh_file() {
    same_dynamics("panda_urdf", "panda", 7);
}

#[test]
fn mimic_parallelogram_equals_its_coupled_angle_twin() {
    same_dynamics("parallelogram", "parallelogram_dh", 2);
    // And the emitted kernels are the same text, parameter for parameter.
    let src = |n: &str| {
        let s = generated::SOURCES.iter().find(|(m, _)| *m == n).unwrap().1;
        let a = s.find("pub mod full").unwrap();
        let b = s[a..].find("pub static MODEL").unwrap();
        s[a..a + b].to_string()
    };
    assert_eq!(src("parallelogram"), src("parallelogram_dh"));
}

#[test]
fn urdf_inertial_values_are_symbols_with_defaults() {
    // Every moving TX40 link has its ten inertial quantities as symbols (zero ones too:
    // link 6's inertia is all zeros in the URDF), each with the URDF number as default.
    let m = generated::model("tx40").unwrap();
    assert_eq!(m.links.len(), 6);
    assert_eq!(m.inertial_symbols.len(), 60);
    assert_eq!(m.params.len(), 60);
    let d = |s: &str| {
        let i = m.inertial_symbols.iter().position(|x| *x == s).unwrap();
        m.symbol_defaults[i].unwrap()
    };
    assert_eq!(d("m_link_1"), 10.5);
    assert_eq!(d("Izz_link_6"), 0.0);
    // link_2's inertial frame is turned -π/2 about z: ixx and iyy swap, ixz becomes -iyz'…
    assert_eq!((d("Ixx_link_2"), d("Iyy_link_2")), (0.038, 0.009));
    assert_eq!((d("cx_link_2"), d("cy_link_2")), (0.109, -0.002));
}

/// Operations of a model's `full` configuration, from the generated module's header.
fn full_operations(model: &str) -> usize {
    let s = generated::SOURCES
        .iter()
        .find(|(m, _)| *m == model)
        .unwrap()
        .1;
    let line = s
        .lines()
        .find(|l| l.starts_with("// Configuration full:"))
        .unwrap();
    let n = line.split("; ").nth(1).unwrap().split(' ').next().unwrap();
    n.parse().unwrap()
}

#[test]
fn the_urdf_panda_kernels_are_as_small_as_the_dh_ones() {
    // The URDF places each joint by a translation then rpy, DH by rot_x, trans_x, rot_z,
    // trans_z: the same tree up to where translations sit; at most 10 % more operations.
    let (urdf, dh) = (full_operations("panda_urdf"), full_operations("panda"));
    assert!(urdf as f64 <= 1.1 * dh as f64, "URDF {urdf}, DH {dh}");
    assert!(
        urdf >= dh / 2,
        "URDF {urdf}, DH {dh}: the header parse is wrong"
    );
}
