//! Generation time of whole models (criterion, 10 samples): the Freedom 6S (both locking
//! sequences and the full model), the Puma 560, the Panda, and the TX40 and the Panda read
//! from their URDFs (reading the URDF included). Symbolica runs restricted (one
//! thread): criterion runs the samples one after another in this one process.

use criterion::{criterion_group, criterion_main, Criterion};
use std::path::Path;
use std::time::Duration;

fn generation(c: &mut Criterion) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../model");
    let mut g = c.benchmark_group("generate");
    g.sample_size(10).measurement_time(Duration::from_secs(30));
    for name in ["freedom6s", "puma560", "panda"] {
        let model = codegen::load(&dir.join(format!("{name}.toml"))).expect("model loads");
        g.bench_function(name, |b| {
            b.iter(|| codegen::generate::generate(&model, None).expect("generates"))
        });
    }
    for name in ["tx40", "panda_urdf"] {
        let file = dir.join(format!("{name}.toml"));
        g.bench_function(name, |b| {
            b.iter(|| {
                let model = codegen::load(&file).expect("model loads");
                codegen::generate::generate(&model, None).expect("generates")
            })
        });
    }
    g.finish();
}

criterion_group!(benches, generation);
criterion_main!(benches);
