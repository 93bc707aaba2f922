//! Output-space diagnosis cost (issue 53's performance target: a k1 file of 40 s, two
//! joints, every screened candidate confirmed by a fit, in under 60 s on 2 cores).
//!
//! The data: the Appendix D coupled-method plant (I4_33 made positive) excited by Table 4.7
//! on k1 for 40 s at 100 Hz, simulated at 1/12000 s with σ = 2e-4 rad and quantisation
//! 1e-4 rad. Two diagnoses are timed once each (each takes minutes; criterion's ten
//! samples would take most of an hour):
//! - `truth`: the plant that made the data (nothing missing; the step check refines the
//!   default 1/6000 s to 1/12000 s on the wrist);
//! - `coupling missing`: the same plant without the 5 → 4 tendon coupling.
//!
//! `cargo bench --bench diagnosis` prints the wall time, the simulations run and the
//! verdict of each.

mod common;

use lockstep::diagnose::{diagnose_output, OutputOptions};
use lockstep::effects::EffectKind;
use lockstep::identify::sequence::read_record;
use std::time::Instant;

/// The target wall time of one k1 diagnosis (s).
const TARGET_S: f64 = 60.0;

fn main() {
    // `cargo test --benches` runs bench targets with `--bench` absent: nothing to time.
    if !std::env::args().any(|a| a == "--bench") {
        return;
    }
    let truth = common::appendix_d_coupled();
    let dir = tempfile::tempdir().unwrap();
    let file = common::table_4_7_file(&truth, dir.path(), dir.path(), "k1");
    let conf = truth.model.configuration("k1").unwrap();
    let record = read_record(&file, truth.model, conf, 0.01).unwrap();
    let mut missing = truth.clone();
    missing
        .effects
        .retain(|e| !(e.kind == EffectKind::InputCoupling && e.joint == 4));
    for (name, plant) in [("truth", &truth), ("coupling missing", &missing)] {
        let started = Instant::now();
        let d = diagnose_output(
            plant,
            "k1",
            std::slice::from_ref(&record),
            &OutputOptions::default(),
        )
        .unwrap();
        let wall = started.elapsed().as_secs_f64();
        let confirmed = d.findings.iter().filter(|f| f.confirmed).count();
        println!(
            "diagnose k1 40 s, {name}: {wall:.1} s (target < {TARGET_S} s), {} simulations, {confirmed} candidates confirmed; {}",
            d.simulations,
            d.verdict()
        );
    }
}
