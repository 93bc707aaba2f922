//! Support shared by the benchmarks. Each bench target compiles this module and uses part
//! of it.
#![allow(dead_code)]

use lockstep::excitation::Excitations;
use lockstep::plant::Plant;
use lockstep::synthetic::{excite, simulate_file, SimulateOptions};
use std::path::{Path, PathBuf};

/// The Appendix D coupled-method plant with I4_33 made positive (the thesis's value makes
/// link 4 impossible): the truth the benchmarks' data come from.
pub fn appendix_d_coupled() -> Plant {
    let mut p = Plant::load(
        &Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("model/plants/freedom6s_appendix_d_coupled.toml"),
    )
    .unwrap();
    p.parameters.insert("I4_33".into(), 1.7449e-4);
    p
}

/// A synthetic file of configuration `config`: `truth` excited by Table 4.7 for 40 s at
/// 100 Hz, simulated at 1/12000 s with σ = 2e-4 rad and quantisation 1e-4 rad (seed 7);
/// the torques are written to `dir/tau_<config>.csv` and the file to `data/<config>_run.csv`.
pub fn table_4_7_file(truth: &Plant, dir: &Path, data: &Path, config: &str) -> PathBuf {
    let ex = Excitations::bundled(truth.model).unwrap();
    let e = excite(truth.model, &ex, "4.7", None, config, 40.0, 100.0).unwrap();
    let tau = dir.join(format!("tau_{config}.csv"));
    e.write(&tau).unwrap();
    let sim = simulate_file(
        truth,
        &tau,
        &SimulateOptions {
            h: 1.0 / 12000.0,
            noise: 2e-4,
            quantisation: 1e-4,
            seed: 7,
            ..SimulateOptions::default()
        },
    )
    .unwrap();
    let file = data.join(format!("{config}_run.csv"));
    sim.write(&file).unwrap();
    file
}
