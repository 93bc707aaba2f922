//! IDIM-LS on the bundled EMPS records against the benchmark's published figures
//! (Janot, Gautier, Brunot 2019; data/emps/README.md).

use lockstep::identify::idim::{least_squares, observation, predict, relative_error, IdimOptions};
use lockstep::measurement::Measurement;
use lockstep::plant::Plant;
use std::path::Path;

fn record(name: &str) -> Measurement {
    Measurement::read(
        &Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("data/emps")
            .join(name),
        &["q0"],
    )
    .unwrap()
}

fn plant(name: &str) -> Plant {
    Plant::load(
        &Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("model/plants")
            .join(name),
    )
    .unwrap()
}

fn within(x: f64, want: f64, rel_pct: f64) {
    assert!(
        ((x - want) / want).abs() * 100.0 <= rel_pct,
        "{x} is not within {rel_pct} % of {want}"
    );
}

#[test]
fn symmetric_model_reproduces_published_parameters_and_errors() {
    let train = record("emps_train.csv");
    let p = plant("emps_symmetric.toml");
    let obs = observation(&p, "full", &[train], &IdimOptions::default()).unwrap();
    let fit = least_squares(&obs).unwrap();
    eprintln!(
        "{:?} {:?} err {} cond {}",
        fit.names, fit.theta, fit.relative_error, fit.condition
    );
    within(fit.get("M").unwrap(), 95.1089, 0.5);
    within(fit.get("Fv_q0").unwrap(), 203.5034, 2.0);
    within(fit.get("Fc_q0").unwrap(), 20.3935, 2.0);
    within(fit.get("offset_q0").unwrap(), -3.1648, 5.0);
    assert!(
        (fit.relative_error - 4.0834).abs() <= 0.15,
        "training error {}",
        fit.relative_error
    );
    // Same parameters on the pulses record.
    let mut fitted = p.clone();
    fit.apply(&mut fitted).unwrap();
    let pulses = record("emps_test_pulses.csv");
    let obs2 = observation(&fitted, "full", &[pulses], &IdimOptions::default()).unwrap();
    let yhat = predict(&fitted, &obs2).unwrap();
    let e = relative_error(&obs2.y, &yhat);
    eprintln!("pulses {e}");
    assert!((e - 5.9824).abs() <= 0.3, "pulses error {e}");
}

#[test]
fn asymmetric_and_viscous_models() {
    let train = record("emps_train.csv");
    let fit = least_squares(
        &observation(
            &plant("emps_asymmetric.toml"),
            "full",
            std::slice::from_ref(&train),
            &IdimOptions::default(),
        )
        .unwrap(),
    )
    .unwrap();
    eprintln!("{:?} {:?} err {}", fit.names, fit.theta, fit.relative_error);
    assert!(
        (fit.relative_error - 3.1117).abs() <= 0.15,
        "asymmetric error {}",
        fit.relative_error
    );
    let fit = least_squares(
        &observation(
            &plant("emps_viscous.toml"),
            "full",
            &[train],
            &IdimOptions::default(),
        )
        .unwrap(),
    )
    .unwrap();
    eprintln!("viscous err {}", fit.relative_error);
    assert!(
        fit.relative_error >= 15.0,
        "mass + viscous error {}",
        fit.relative_error
    );
}
