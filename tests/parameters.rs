//! Parameter occurrence and base parameters from the generated regressors.

use lockstep::identify::identifiability::{base_parameters, occurrence};

#[test]
fn freedom6s_isolated_sequence_reproduces_figure_4_2() {
    // Thesis Figure 4.2 (DESIGN.md §3): first identifications per configuration of the
    // isolated-joint sequence, and six symbols that appear nowhere.
    let m = generated::model("freedom6s").unwrap();
    let occ = occurrence(m);
    let iso = occ.sequences.iter().find(|s| s.name == "isolated").unwrap();
    assert_eq!(iso.counts(), vec![4, 4, 6, 13, 17, 16, 4]);
    let mut nowhere = iso.nowhere.clone();
    nowhere.sort();
    assert_eq!(nowhere, ["I1_11", "I1_12", "I1_13", "I1_22", "I1_23", "z1"]);
    // c1 (joint 4 alone, the wrist roll) sees only link 7's mass, planar centroid and I7_33.
    assert_eq!(iso.steps[0].1, ["m7", "x7", "y7", "I7_33"]);
    let coupled = occ.sequences.iter().find(|s| s.name == "coupled").unwrap();
    assert_eq!(coupled.counts().iter().sum::<usize>(), 64);
}

/// The base parameters reproduce the torques: W p = W_base p_base with
/// p_base = p_independent + Σ β p_dependent, at states the decomposition never saw.
#[test]
fn base_parameters_reproduce_the_torques() {
    for (model, config) in [
        ("planar2r", "full"),
        ("puma560", "full"),
        ("freedom6s", "c5"),
        ("freedom6s", "k3"),
    ] {
        let m = generated::model(model).unwrap();
        let conf = m.configuration(config).unwrap();
        let b = base_parameters(m, conf);
        let np = m.params.len();
        let idx = |n: &str| m.params.iter().position(|p| *p == n).unwrap();
        let p: Vec<f64> = (0..np)
            .map(|j| 0.3 + 0.7 * ((j * 37 % 11) as f64) / 11.0)
            .collect();
        let nf = conf.free.len();
        let q: Vec<f64> = (0..m.joints.len()).map(|k| 0.4 + 0.3 * k as f64).collect();
        let qd: Vec<f64> = (0..nf).map(|k| 0.5 - 0.2 * k as f64).collect();
        let qdd: Vec<f64> = (0..nf).map(|k| -0.3 + 0.25 * k as f64).collect();
        let mut y = vec![0.0; nf * np];
        (conf.regressor)(&q, &qd, &qdd, &mut y);
        for a in 0..nf {
            let full: f64 = (0..np).map(|j| y[a * np + j] * p[j]).sum();
            let base: f64 = b
                .base
                .iter()
                .map(|bp| {
                    let pb =
                        p[idx(&bp.name)] + bp.terms.iter().map(|(c, n)| c * p[idx(n)]).sum::<f64>();
                    y[a * np + idx(&bp.name)] * pb
                })
                .sum();
            assert!(
                (full - base).abs() <= 1e-9 * full.abs().max(1.0),
                "{model} {config} joint {a}: {full} vs {base}"
            );
        }
        assert!(b.rank < b.appearing || model == "planar2r" || config == "c1");
    }
}

#[test]
fn planar_2r_has_the_textbook_base_parameters() {
    // Two revolute joints about parallel axes, gravity in the plane, frames at the link tips
    // (a1 = 0.3 m, a2 = 0.2 m): four base parameters, the masses regrouped into the inertias
    // and first moments about the tips: ZZ1 − a1²(m1 + m2), ZZ2 − a2² m2, MX1 + a1(m1 + m2),
    // MX2 + a2 m2.
    let m = generated::model("planar2r").unwrap();
    let b = base_parameters(m, m.configuration("full").unwrap());
    let text: Vec<String> = b.base.iter().map(|p| p.to_string()).collect();
    assert_eq!(
        text,
        [
            "ZZ_l1 − 0.09 m1 − 0.09 m2",
            "ZZ_l2 − 0.04 m2",
            "MX_l1 + 0.3 m1 + 0.3 m2",
            "MX_l2 + 0.2 m2"
        ]
    );
    assert_eq!(b.dependent, ["m1", "m2"]);
}
