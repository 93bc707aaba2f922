//! Output-error identification cost (issue 5), on synthetic data of the Appendix D
//! coupled-method plant (I4_33 made positive) excited by Table 4.7 for 40 s at 100 Hz.
//!
//! - `cost_evaluation/<config>`: one evaluation of cost (4.3), i.e. one simulation of a
//!   40 s file by RK4 at 1/12000 s (the step these data need: at the thesis's 1/6000 s RK4
//!   is unstable in k2..k5, docs/src/design/digest.md §2); a Jacobian costs one evaluation per fitted
//!   parameter, spread over the cores.
//! - `cost_evaluation_etdrk4/<config>`: the same by ETDRK4 at 1/2000 s (`--integrator
//!   etdrk4 --step 1/2000`), which takes the stiff friction damping exactly: 0.3–0.4 × the
//!   RK4 time, but on these 40 s files not accurate to the noise (k3: 3.0e-3 rad from a
//!   converged RK4, `tests/plant_simulation.rs`), so the fits use RK4.
//! - `tx40/idim` and `tx40/consistent`: IDIM-LS on the base parameters of the real Stäubli
//!   TX40 record (45 000 samples × 6 joints at 5 kHz, `data/staubli_tx40/`, the options of
//!   `tests/tx40.rs`: filter, differentiation, decimation, the random-motion grouping and
//!   the least squares) and the physically consistent set after it (issue 57 targets: < 2 s
//!   and < 5 s on this 2-core machine).
//! - With `LOCKSTEP_BENCH_SEQUENCE=1`, the whole coupled sequence k1..k5 is then run from
//!   the Appendix D initial guess with bounds widened where the truth lies outside the
//!   thesis bounds (`model/plants/freedom6s_appendix_d_initial_widened.toml`) with the
//!   coupled method's default settings (`--equation-error on --predictor 100,30,10,3,1
//!   --horizons none --step 1/12000 --predictor-step 1/2000 --predictor-optimiser trf
//!   --initial-positions estimate --jacobian-refresh 4 --release-held on --tie-reach on`), and the time
//!   per step and per cost evaluation printed (takes hours on 2 cores: k4 alone 3618 s
//!   with a finite-difference Jacobian at every iteration).

mod common;

use criterion::{criterion_group, Criterion};
use lockstep::identify::output_error::{OutputErrorOptions, Problem, Residuals};
use lockstep::identify::sequence::{plan, read_record, run, SequenceOptions};
use lockstep::plant::Plant;
use lockstep::simulation::Integrator;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Data files k1..k5 in `dir/data`.
fn make_data(dir: &Path, truth: &Plant) -> PathBuf {
    let data = dir.join("data");
    std::fs::create_dir_all(&data).unwrap();
    for k in ["k1", "k2", "k3", "k4", "k5"] {
        common::table_4_7_file(truth, dir, &data, k);
    }
    data
}

fn bench(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    let truth = common::appendix_d_coupled();
    let data = make_data(dir.path(), &truth);
    let mut g = c.benchmark_group("cost_evaluation");
    g.sample_size(10).measurement_time(Duration::from_secs(10));
    let steps = plan(&truth, "coupled").unwrap();
    let mut problems = Vec::new();
    for s in &steps {
        let conf = truth.model.configuration(&s.config).unwrap();
        let rec = read_record(
            &data.join(format!("{}_run.csv", s.config)),
            truth.model,
            conf,
            0.01,
        )
        .unwrap();
        let mut plant = truth.clone();
        for n in &s.fitted {
            let v = plant.parameters[n];
            plant
                .bounds
                .insert(n.clone(), (v - v.abs() - 1.0, v + v.abs() + 1.0));
        }
        let p = Problem::new(
            &plant,
            conf,
            s.fitted.clone(),
            vec![rec],
            &s.interest,
            OutputErrorOptions {
                h: 1.0 / 12000.0,
                ..OutputErrorOptions::thesis()
            },
        )
        .unwrap();
        let x: Vec<f64> = s.fitted.iter().map(|n| plant.parameters[n]).collect();
        g.bench_function(&s.config, |b| b.iter(|| p.cost(&x)));
        problems.push((
            s.config.clone(),
            p.with_step(1.0 / 2000.0, Integrator::Etdrk4),
            x,
        ));
    }
    g.finish();
    let mut g = c.benchmark_group("cost_evaluation_etdrk4");
    g.sample_size(10).measurement_time(Duration::from_secs(10));
    for (config, p, x) in &problems {
        g.bench_function(config, |b| b.iter(|| p.cost(x)));
    }
    g.finish();
    if std::env::var_os("LOCKSTEP_BENCH_SEQUENCE").is_some() {
        sequence(dir.path(), &data);
    }
}

fn sequence(dir: &Path, data: &Path) {
    let start = Plant::load(
        &Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("model/plants/freedom6s_appendix_d_initial_widened.toml"),
    )
    .unwrap();
    let opts = SequenceOptions::preset("coupled", dir.join("out"));
    let report = run(&start, &[data.to_path_buf()], &opts, &|_, _| {}).unwrap();
    println!(
        "step   params  wall s   evaluations  s per evaluation  cost after  RMS per joint (rad)"
    );
    let mut total = 0.0;
    for s in &report.steps {
        let f = &s.fit;
        total += f.wall_s;
        println!(
            "{:<6} {:>6} {:>7.1} {:>13} {:>17.3} {:>11.4e}  {}",
            s.step.config,
            f.names.len(),
            f.wall_s,
            f.evaluations,
            f.wall_s / f.evaluations.max(1) as f64,
            f.cost_after,
            f.statistics
                .joints
                .iter()
                .map(|j| format!("{} {:.2e}", j.joint, j.rms))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    println!("whole coupled sequence: {total:.1} s");
}

/// The TX40 record: IDIM-LS with base parameters, then the consistent set.
fn real_arm(c: &mut Criterion) {
    use lockstep::identify::consistent::consistent_parameters;
    use lockstep::identify::idim::{
        base_fit, locked_positions, observation, IdimOptions, MinSpeed, Weighting,
    };
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let plant = Plant::load(&root.join("model/plants/tx40_figaroh.toml")).unwrap();
    let record = lockstep::measurement::Measurement::read(
        &root.join("data/staubli_tx40/tx40_joint_5kHz.csv"),
        plant.model.joints,
    )
    .unwrap();
    let opts = IdimOptions {
        cutoff_hz: 20.0,
        filter_order: 4,
        decimation: 100,
        window: Some((0.1, 5.5)),
        min_speed: Some(MinSpeed::FractionOfPeak(0.01)),
        differentiator: lockstep::signal::Differentiator::Central,
        trim_moving_edges: false,
    };
    let records = std::slice::from_ref(&record);
    let locked_at = locked_positions(records);
    let idim = || {
        let obs = observation(&plant, "full", records, &opts).unwrap();
        let (fit, _) = base_fit(&plant, &obs, "full", &locked_at, &opts, Weighting::Ols).unwrap();
        (obs, fit)
    };
    let mut g = c.benchmark_group("tx40");
    g.sample_size(10).measurement_time(Duration::from_secs(20));
    g.bench_function("idim", |b| b.iter(idim));
    let (obs, fit) = idim();
    g.bench_function("consistent", |b| {
        b.iter(|| consistent_parameters(&obs, &plant, &fit, &Default::default()).unwrap())
    });
    // A friction position bias on q5 (its rest angle profiled on a grid, the bias factor by
    // Levenberg–Marquardt, the linear values by least squares at each trial): the torque
    // space's slowest refit, each trial rebuilding only the effects' columns.
    let mut biased = plant.clone();
    biased
        .add_effect(lockstep::effects::Effect::on(
            lockstep::effects::EffectKind::FrictionBias,
            4,
        ))
        .unwrap();
    biased.parameters.insert("FrictionBias_q5".into(), 1.0);
    biased.parameters.insert("qeq_q5".into(), 0.0);
    let random =
        lockstep::identify::idim::random_motion_observation(&biased, "full", &locked_at, &opts)
            .unwrap();
    let linear = |p: &Plant, obs: &lockstep::identify::idim::Observation| {
        lockstep::identify::idim::base_fit_with(p, obs, "full", &locked_at, Weighting::Ols, &random)
            .map(|(fit, _)| fit)
    };
    g.bench_function("friction bias refit", |b| {
        b.iter(|| {
            lockstep::identify::idim::separable_fit(&biased, "full", records, &opts, &linear)
                .unwrap()
        })
    });
    g.finish();
}

criterion_group!(benches, real_arm, bench);

fn main() {
    benches();
    Criterion::default().configure_from_args().final_summary();
}
