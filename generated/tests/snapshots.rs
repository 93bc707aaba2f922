//! The emitted kernels are reviewed like any diff: every model module's source is an insta
//! snapshot (generated/tests/snapshots/). A change in the generator or a model shows here.

#[test]
fn emitted_sources_match_reviewed_snapshots() {
    assert!(!generated::SOURCES.is_empty());
    for (name, source) in generated::SOURCES {
        insta::assert_snapshot!(format!("kernels_{name}"), source);
    }
}

#[test]
fn emps_kernels_are_the_one_dof_mass() {
    // τ = M q̈ for a point mass on a prismatic joint; forward dynamics inverts it.
    let m = generated::model("emps").unwrap();
    let c = m.configuration("full").unwrap();
    let (q, qd, qdd, p) = ([0.3], [0.2], [1.5], [95.0]);
    let mut out = [0.0];
    (c.inverse_dynamics)(&q, &qd, &qdd, &p, &mut out);
    assert_eq!(out[0], 95.0 * 1.5);
    let mut acc = [0.0];
    (c.forward_dynamics)(&q, &qd, &out, &p, &mut acc);
    assert!((acc[0] - 1.5).abs() < 1e-15);
    let mut y = [0.0];
    (c.regressor)(&q, &qd, &qdd, &mut y);
    assert_eq!(y, [1.5]);
}
