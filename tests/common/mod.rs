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
