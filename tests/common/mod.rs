//! Support shared by the integration tests. Each test binary compiles this module and uses
//! part of it.
#![allow(dead_code)]

pub mod independent;

use lockstep::plant::Plant;
use std::path::Path;

/// The Appendix D coupled-method plant with I4_33 made positive (the thesis's value makes
/// link 4 impossible): the truth of the hidden-effect tests.
pub fn appendix_d_coupled() -> Plant {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("model/plants");
    let text = std::fs::read_to_string(dir.join("freedom6s_appendix_d_coupled.toml"))
        .unwrap()
        .replace("I4_33 = -0.00017449", "I4_33 = 0.00017449");
    let spec = toml::from_str(&text).unwrap();
    Plant::from_file(spec, None).unwrap()
}

/// The sensor of the synthetic Freedom 6S files: noise σ = 2e-4 rad and quantisation
/// 1e-4 rad, whose total standard deviation is √(σ² + q²/12) = 2.0207e-4 rad.
pub const SENSOR_NOISE: f64 = 2e-4;
pub const SENSOR_QUANTISATION: f64 = 1e-4;
pub fn sensor_sigma() -> f64 {
    (SENSOR_NOISE.powi(2) + SENSOR_QUANTISATION.powi(2) / 12.0).sqrt()
}

/// Runs the `lockstep` binary built for this test run.
pub fn lockstep(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_lockstep"))
        .args(args)
        .output()
        .unwrap()
}

/// `lockstep identify idim --plant plant --data data` followed by `more` (`--out`, options).
pub fn identify_idim(plant: &Path, data: &Path, more: &[&str]) -> std::process::Output {
    let (plant, data) = (plant.to_str().unwrap(), data.to_str().unwrap());
    let mut args = vec!["identify", "idim", "--plant", plant, "--data", data];
    args.extend_from_slice(more);
    lockstep(&args)
}

/// The standard output of a run that must have succeeded (its output and errors shown if not).
pub fn ok(o: &std::process::Output) -> String {
    assert!(
        o.status.success(),
        "failed: {}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// A run that must have failed with an error that contains every needle.
pub fn fails(o: &std::process::Output, needles: &[&str]) {
    assert!(
        !o.status.success(),
        "succeeded: {}",
        String::from_utf8_lossy(&o.stdout)
    );
    let err = String::from_utf8_lossy(&o.stderr);
    for n in needles {
        assert!(err.contains(n), "'{n}' not in: {err}");
    }
}

/// Positions of a one-joint EMPS-like plant over 3 s from rest under the force 60 sin 2t +
/// 25 sin 9t N, RK4 at 1 ms, one per step: the motion two simulations are compared on.
pub fn emps_multisine_motion(model: &lockstep::simulation::PlantModel) -> Vec<f64> {
    let mut q = Vec::new();
    model
        .simulate(
            lockstep::simulation::State::at_rest(vec![0.0]),
            1e-3,
            3000,
            10.0,
            |t, tau| tau[0] = 60.0 * (2.0 * t).sin() + 25.0 * (9.0 * t).sin(),
            |_, x| q.push(x.q[0]),
        )
        .unwrap();
    q
}
