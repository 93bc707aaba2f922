//! Simulator throughput (issue 4): the Freedom 6S with the Appendix D coupled-method plant
//! (I4_33 made positive; plant gain, LuGre, cable-drag spring on every joint, friction bias
//! on the base joints, tendon coupling 4↔5) on the Table 4.7 inputs at 100 Hz, RK4 at the
//! thesis's 1/6000 s, output at 100 Hz.
//!
//! - `simulate/k5_60s`: 60 s of all six joints = 360,000 RK4 steps (target < 2 s; the thesis
//!   needed 15 min per minute of data).
//! - `steps/<config>`: 1 s (6,000 steps) per configuration, for steps per second against the
//!   number of free joints (c1: 1, k1: 2, k2: 3, k3: 4, k4: 5, k5: 6).
//! - `effects/k5_10s_{built_in,expression}_springs`: 10 s of k5 with the six cable-drag
//!   springs built in, and written by hand as user-defined effects `Ks*(qj - qe)`
//!   (`crate::expression`; target: an expression effect costs ≤ 3× the built-in, issue 54).
//! - `closed_loop/emps_train_24.8s`: the EMPS benchmark's published model under its
//!   controller on the training record's reference, 24,841 samples at 1 kHz, ten RK4 steps
//!   each (target < 0.5 s, issue 59).

use criterion::{criterion_group, criterion_main, Criterion};
mod common;

use lockstep::excitation::Excitations;
use lockstep::plant::ConsistencyPolicy;
use lockstep::simulation::{Hold, InputSignal, PlantModel, State};
use std::time::Duration;

fn setup(config: &str, seconds: f64) -> (PlantModel, Vec<Vec<f64>>, Vec<f64>) {
    setup_plant(&common::appendix_d_coupled(), config, seconds)
}

fn run(sim: &PlantModel, tau: &[Vec<f64>], t: &[f64]) -> f64 {
    let input = InputSignal {
        t0: 0.0,
        dt: 0.01,
        tau,
        hold: Hold::Zoh,
    };
    let tr = sim
        .simulate_at(
            State::at_rest(vec![0.0; sim.nf()]),
            1.0 / 6000.0,
            &input,
            t,
            100.0,
        )
        .unwrap();
    tr.q[0][t.len() - 1]
}

/// The simulator of `plant` in `config`, the Table 4.7 inputs of its free joints for
/// `seconds` at 100 Hz, and their times.
fn setup_plant(
    plant: &lockstep::plant::Plant,
    config: &str,
    seconds: f64,
) -> (PlantModel, Vec<Vec<f64>>, Vec<f64>) {
    let sim = plant
        .simulator(config, &[0.0; 6], ConsistencyPolicy::Refuse)
        .unwrap()
        .model;
    let ex = Excitations::bundled(plant.model).unwrap();
    let test = ex.table("4.7").unwrap().test(None).unwrap();
    let (t, u, _) = test.sample(6, sim.conf.free, seconds, 100.0);
    let tau = sim.conf.free.iter().map(|&j| u[j].clone()).collect();
    (sim, tau, t)
}

/// The plant with its six built-in springs replaced by `Ks*(qj - qe)` expressions.
fn springs_by_hand(plant: &lockstep::plant::Plant) -> lockstep::plant::Plant {
    let mut p = plant.clone();
    p.effects
        .retain(|e| e.kind != lockstep::effects::EffectKind::Spring);
    for j in 0..6 {
        let (ks, qe) = (format!("Ks{j}"), format!("qe{j}"));
        p.add_expression(
            &format!("spring_{j}"),
            vec![j],
            &format!("{ks}*(q{j} - {qe})"),
            &[ks.clone(), qe.clone()],
        )
        .unwrap();
        let (v, q) = (
            plant.parameters[&format!("Ks_q{j}")],
            plant.parameters[&format!("qeq_q{j}")],
        );
        p.parameters.insert(ks, v);
        p.parameters.insert(qe, q);
    }
    p
}

fn bench(c: &mut Criterion) {
    {
        use lockstep::control::controller::{simulate_closed_loop, ClosedLoopRecord, Controller};
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
        let plant =
            lockstep::plant::Plant::load(&root.join("model/plants/emps_published.toml")).unwrap();
        let controller =
            Controller::load(&root.join("model/control/emps_controller.toml"), &plant).unwrap();
        let table =
            lockstep::measurement::Table::read(&root.join("data/emps/emps_train.csv")).unwrap();
        let record = ClosedLoopRecord::from_table(&table, &plant, &controller).unwrap();
        let mut g = c.benchmark_group("closed_loop");
        g.sample_size(10).measurement_time(Duration::from_secs(5));
        g.bench_function("emps_train_24.8s", |b| {
            b.iter(|| simulate_closed_loop(&plant, &controller, &record).unwrap())
        });
        g.finish();
    }
    {
        let plant = common::appendix_d_coupled();
        let by_hand = springs_by_hand(&plant);
        let mut g = c.benchmark_group("effects");
        g.sample_size(10).measurement_time(Duration::from_secs(10));
        let (sim, tau, t) = setup_plant(&plant, "k5", 10.0);
        g.bench_function("k5_10s_built_in_springs", |b| {
            b.iter(|| run(&sim, &tau, &t))
        });
        let (sim, tau, t) = setup_plant(&by_hand, "k5", 10.0);
        g.bench_function("k5_10s_expression_springs", |b| {
            b.iter(|| run(&sim, &tau, &t))
        });
        g.finish();
    }
    let (sim, tau, t) = setup("k5", 60.0);
    let mut g = c.benchmark_group("simulate");
    g.sample_size(10).measurement_time(Duration::from_secs(20));
    g.bench_function("k5_60s", |b| b.iter(|| run(&sim, &tau, &t)));
    g.finish();
    let mut g = c.benchmark_group("steps");
    g.sample_size(10).measurement_time(Duration::from_secs(3));
    for config in ["c1", "k1", "k2", "k3", "k4", "k5"] {
        let (sim, tau, t) = setup(config, 1.0);
        g.bench_function(config, |b| b.iter(|| run(&sim, &tau, &t)));
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
