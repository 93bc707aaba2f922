//! Per-call cost of the generated kernels (criterion). The Puma 560 figures are compared
//! with Pinocchio (bench/pinocchio_puma560.py) in the README.

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use generated::{freedom6s, panda, puma560};

fn puma(c: &mut Criterion) {
    use puma560::full;
    let p = puma560::barycentric_from_symbols(&[]);
    let q = [0.1, -0.4, 0.7, 0.3, -0.2, 0.5];
    let qd = [0.5, -1.0, 0.8, 1.2, -0.7, 0.9];
    let qdd = [0.3, 0.2, -0.4, 1.0, 0.5, -0.6];
    let tau = full::inverse_dynamics(&q, &qd, &qdd, &p);
    let mut g = c.benchmark_group("puma560");
    g.bench_function("mass_matrix", |b| {
        b.iter(|| full::mass_matrix(black_box(&q), black_box(&p)))
    });
    g.bench_function("coriolis", |b| {
        b.iter(|| full::coriolis(black_box(&q), black_box(&qd), black_box(&p)))
    });
    g.bench_function("christoffel_matrix", |b| {
        b.iter(|| full::christoffel_matrix(black_box(&q), black_box(&qd), black_box(&p)))
    });
    g.bench_function("gravity", |b| {
        b.iter(|| full::gravity(black_box(&q), black_box(&p)))
    });
    g.bench_function("inverse_dynamics", |b| {
        b.iter(|| {
            full::inverse_dynamics(
                black_box(&q),
                black_box(&qd),
                black_box(&qdd),
                black_box(&p),
            )
        })
    });
    g.bench_function("forward_dynamics", |b| {
        b.iter(|| {
            full::forward_dynamics(
                black_box(&q),
                black_box(&qd),
                black_box(&tau),
                black_box(&p),
            )
        })
    });
    g.bench_function("regressor", |b| {
        b.iter(|| full::regressor(black_box(&q), black_box(&qd), black_box(&qdd)))
    });
    g.finish();
}

fn freedom(c: &mut Criterion) {
    use freedom6s::k5;
    // A physically consistent parameter vector (the Freedom 6S file has symbols, no values).
    let mut rng = generated::inertia::Xorshift(42);
    let links: Vec<[f64; 10]> = (0..freedom6s::LINKS.len())
        .map(|_| generated::inertia::CentroidalInertia::random(&mut rng).to_barycentric())
        .collect();
    let p: [f64; freedom6s::NP] =
        std::array::from_fn(|j| links[freedom6s::PARAM_LINK[j]][freedom6s::PARAM_KIND[j]]);
    let q = [0.1, -0.4, 0.7, 0.3, -0.2, 0.5];
    let qd = [0.5, -1.0, 0.8, 1.2, -0.7, 0.9];
    let qdd = [0.3, 0.2, -0.4, 1.0, 0.5, -0.6];
    let mut g = c.benchmark_group("freedom6s_k5");
    g.bench_function("mass_matrix", |b| {
        b.iter(|| k5::mass_matrix(black_box(&q), black_box(&p)))
    });
    g.bench_function("inverse_dynamics", |b| {
        b.iter(|| {
            k5::inverse_dynamics(
                black_box(&q),
                black_box(&qd),
                black_box(&qdd),
                black_box(&p),
            )
        })
    });
    g.bench_function("forward_dynamics", |b| {
        b.iter(|| {
            k5::forward_dynamics(
                black_box(&q),
                black_box(&qd),
                black_box(&qdd),
                black_box(&p),
            )
        })
    });
    g.finish();
}

fn franka(c: &mut Criterion) {
    use panda::full;
    let p = panda::barycentric_from_symbols(&[]);
    let q = [0.1, -0.4, 0.7, -1.3, -0.2, 1.5, 0.4];
    let qd = [0.5, -1.0, 0.8, 1.2, -0.7, 0.9, 0.2];
    let qdd = [0.3, 0.2, -0.4, 1.0, 0.5, -0.6, 0.1];
    let mut g = c.benchmark_group("panda");
    g.bench_function("mass_matrix", |b| {
        b.iter(|| full::mass_matrix(black_box(&q), black_box(&p)))
    });
    g.bench_function("inverse_dynamics", |b| {
        b.iter(|| {
            full::inverse_dynamics(
                black_box(&q),
                black_box(&qd),
                black_box(&qdd),
                black_box(&p),
            )
        })
    });
    g.bench_function("forward_dynamics", |b| {
        b.iter(|| {
            full::forward_dynamics(
                black_box(&q),
                black_box(&qd),
                black_box(&qdd),
                black_box(&p),
            )
        })
    });
    g.finish();
}

criterion_group!(benches, puma, freedom, franka);
criterion_main!(benches);
