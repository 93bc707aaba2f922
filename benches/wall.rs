//! Virtual wall (issue 7): one simulated second of wall contact at 1 kHz with the fuzzy
//! controller (the bundled tuned table), RK4 at 0.1 ms with the simulated hand, and the
//! controller alone. Target: well under a millisecond per 1 ms control step.

use criterion::{criterion_group, criterion_main, Criterion};
use lockstep::control::fuzzy::Fam;
use lockstep::control::wall::{simulate, Loop, User, WallLaw};
use lockstep::control::WallSetup;
use std::path::Path;
use std::time::Duration;

fn bench(c: &mut Criterion) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let setup = WallSetup::load(&root.join("model/control/freedom6s_wall.toml")).unwrap();
    let fam = Fam::from_fll(
        &std::fs::read_to_string(root.join("model/control/freedom6s_wall_tuned.fll")).unwrap(),
        "tuned.fll",
    )
    .unwrap();
    let law = WallLaw::Fuzzy(fam.clone());
    let hand = setup.spec.nominal_hand();
    // Start just outside the wall so the whole second is contact.
    let user = User {
        start: 0.002,
        target: -0.03,
        speed: 0.6,
    };
    let lp = Loop {
        rate: 1000.0,
        duration: 1.0,
        ..setup.spec.loop_at(1000.0)
    };
    let mut g = c.benchmark_group("wall");
    g.measurement_time(Duration::from_secs(10)).sample_size(20);
    g.bench_function("fuzzy_1s_contact_1khz (1000 control steps)", |b| {
        b.iter(|| simulate(&setup.plant, setup.joint, &law, &hand, &user, &lp).unwrap())
    });
    g.bench_function("fuzzy_output (one inference)", |b| {
        let mut q = -0.0123;
        b.iter(|| {
            q = -q * 0.999;
            fam.output(std::hint::black_box(q), 1.8)
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
