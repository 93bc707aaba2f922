//! Output-space diagnosis cost (issue 53's performance target: a k1 file of 40 s, two
//! joints, every screened candidate confirmed by a fit, in under 60 s on 2 cores).
//!
//! The data: the Appendix D coupled-method plant (I4_33 made positive) excited by Table 4.7
//! on k1 for 40 s at 100 Hz, simulated at 1/12000 s with σ = 2e-4 rad and quantisation
//! 1e-4 rad. Two diagnoses are timed once each (each takes minutes; criterion's ten
//! samples would take most of an hour):
//! - `truth`: the plant that made the data (nothing missing; the step check refines the
//!   default 1/6000 s to 1/12000 s on the wrist);
//! - `coupling missing`: the same plant without the 5 → 4 tendon coupling;
//! - `coupling missing, bounds`: the same with bounds (±50 %) on every effect value of k1's
//!   joints, so that each confirming fit refits those values beside the candidate (issue
//!   53: the case the target is for).
//!
//! `cargo bench --bench diagnosis` prints the wall time, the simulations run and the
//! verdict of each (`-- unbounded`: the first two only; `-- bounds`: the third only).
//!
//! Then the torque-space detector (issue 54's target: 40 s × 6 joints in under 10 s): the
//! k5 file (all six joints free, 40 s at 100 Hz, Table 4.7) through the inverse model of
//! the rigid body with viscous and Coulomb friction only (the truth's LuGre, gains,
//! springs, biases and coupling left for the diagnosis to find), filtered at 20 Hz and not
//! decimated: the observation, then the diagnosis with its catalogue, built-ins, structure
//! search and whiteness tests, each timed (`cargo bench --bench diagnosis -- torque` runs
//! this part alone).
//!
//! Then the output-space detector on six joints (`cargo bench --bench diagnosis -- k5`;
//! more than half an hour on 2 cores, docs/src/record/independent-data.md): the k5 file
//! made by the truth with a cogging 0.005 sin(6 q3) N·m it lacks,
//! diagnosed from the truth: the catalogue, the structure search on every joint above its
//! noise or not white, the built-ins and the coupled-motor pairs, timed with its
//! simulations.

mod common;

use lockstep::diagnose::{diagnose_output, OutputOptions};
use lockstep::effects::{Effect, EffectKind};
use lockstep::identify::idim::{observation, IdimOptions};
use lockstep::identify::sequence::read_record;
use lockstep::measurement::Measurement;
use std::time::Instant;

/// The target wall time of one k1 diagnosis (s).
const TARGET_S: f64 = 60.0;

/// The target wall time of the torque-space detector on 40 s × 6 joints (s).
const TORQUE_TARGET_S: f64 = 10.0;

fn main() {
    // `cargo test --benches` runs bench targets with `--bench` absent: nothing to time.
    if !std::env::args().any(|a| a == "--bench") {
        return;
    }
    let truth = common::appendix_d_coupled();
    let dir = tempfile::tempdir().unwrap();
    // `cargo bench --bench diagnosis -- k5`: the output-space detector on six joints only.
    if std::env::args().any(|a| a == "k5") {
        output_space_six_joints(&truth, dir.path());
        return;
    }
    // `cargo bench --bench diagnosis -- torque`: the torque-space detector only.
    if !std::env::args().any(|a| a == "torque") {
        output_space(&truth, dir.path());
    }
    if !std::env::args().any(|a| a == "bounds") {
        torque_space(&truth, dir.path());
    }
}

/// The output-space diagnosis of the truth on k5 data with a cogging it lacks.
fn output_space_six_joints(truth: &lockstep::plant::Plant, dir: &std::path::Path) {
    let mut maker = truth.clone();
    maker
        .add_expression("cogging", vec![3], "A*sin(6*q3)", &["A".into()])
        .unwrap();
    maker.parameters.insert("A".into(), 0.005);
    let file = common::table_4_7_file(&maker, dir, dir, "k5");
    let conf = truth.model.configuration("k5").unwrap();
    let record = read_record(&file, truth.model, conf, 0.01).unwrap();
    let started = Instant::now();
    let d = diagnose_output(
        truth,
        "k5",
        std::slice::from_ref(&record),
        &OutputOptions::default(),
    )
    .unwrap();
    let wall = started.elapsed().as_secs_f64();
    println!(
        "diagnose k5 40 s × 6 joints, cogging on q3 missing: {wall:.1} s, {} simulations, {} structure findings; {}\n{}",
        d.simulations,
        d.findings.iter().filter(|f| f.structure).count(),
        d.verdict(),
        d.table(5)
    );
}

/// The two k1 diagnoses in output space.
fn output_space(truth: &lockstep::plant::Plant, dir: &std::path::Path) {
    let file = common::table_4_7_file(truth, dir, dir, "k1");
    let conf = truth.model.configuration("k1").unwrap();
    let record = read_record(&file, truth.model, conf, 0.01).unwrap();
    let mut missing = truth.clone();
    missing
        .effects
        .retain(|e| !(e.kind == EffectKind::InputCoupling && e.joint == 4));
    let mut bounded = missing.clone();
    let conf_free = conf.free;
    let values: Vec<String> = bounded
        .effects
        .iter()
        .filter(|e| e.acts_with(conf_free))
        .flat_map(|e| e.parameter_names(truth.model.joints))
        .collect();
    for n in values {
        let v = bounded.parameters[&n];
        bounded
            .bounds
            .insert(n, (v - 0.5 * v.abs(), v + 0.5 * v.abs()));
    }
    // `cargo bench --bench diagnosis -- values`: the bounded case's first refit of the
    // values alone, with each Jacobian method, stage by stage.
    if std::env::args().any(|a| a == "jacobian") {
        let records = std::slice::from_ref(&record);
        let values =
            lockstep::diagnose::apply::configuration_values(&bounded, "k1", records).unwrap();
        let p: Vec<f64> = values.iter().map(|n| bounded.parameters[n]).collect();
        jacobian_check(&bounded, &record, &values, &p, "start");
        return;
    }
    if std::env::args().any(|a| a == "values") {
        values_refit(&bounded, &record);
        return;
    }
    // `cargo bench --bench diagnosis -- bounds`: the bounded case alone; `-- unbounded`:
    // the other two alone (the bounded one takes more than 20 minutes).
    let only_bounds = std::env::args().any(|a| a == "bounds");
    let unbounded = std::env::args().any(|a| a == "unbounded");
    for (name, plant) in [
        ("truth", truth),
        ("coupling missing", &missing),
        ("coupling missing, bounds", &bounded),
    ] {
        let bounds = name.ends_with("bounds");
        if (only_bounds && !bounds) || (unbounded && bounds) {
            continue;
        }
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

/// The bounded diagnosis's first refit of the values (the null its candidates are judged
/// against), by finite differences and by sensitivities: wall time, stages, final figures.
fn values_refit(plant: &lockstep::plant::Plant, record: &lockstep::identify::output_error::Record) {
    use lockstep::identify::output_error::JacobianMethod;
    use lockstep::identify::refit::refit;
    let records = std::slice::from_ref(record);
    let values = lockstep::diagnose::apply::configuration_values(plant, "k1", records).unwrap();
    let defaults = OutputOptions::default();
    for jacobian in [JacobianMethod::Sensitivities, JacobianMethod::Differences] {
        let options = lockstep::identify::refit::RefitOptions {
            max_iter: defaults.values_max_iter,
            warm_ups: false,
            jacobian,
            ..defaults.fit.clone()
        };
        let started = Instant::now();
        let r = refit(plant, plant, "k1", records, &values, &options).unwrap();
        let wall = started.elapsed().as_secs_f64();
        println!(
            "values refit ({} values), {jacobian:?}: {wall:.1} s, cost {:.6e} → {:.6e}, {} evaluations, {} Jacobians",
            values.len(),
            r.fit.cost_before,
            r.fit.cost_after,
            r.fit.evaluations,
            r.fit.jacobians
        );
        for s in &r.fit.starts[r.fit.best_start].stages {
            println!(
                "  {:<28} {:>4} it {:>3} failed  whole files {:>12}  {}",
                s.stage,
                s.iterations,
                s.failures,
                s.whole_files_cost
                    .map_or("-".into(), |c| format!("{c:.6e}")),
                s.outcome
            );
        }
        for j in &r.fit.statistics.joints {
            println!("  {}: {:.1} σ̂", j.joint, j.rms / j.noise);
        }
        for (n, (a, b)) in r
            .fit
            .names
            .iter()
            .zip(r.fit.initial.iter().zip(&r.fit.fitted))
        {
            println!("  {n:<10} {a:>12.5e} → {b:>12.5e}");
        }
        jacobian_check(plant, record, &values, &r.fit.initial, "start");
        jacobian_check(plant, record, &values, &r.fit.fitted, "end");
    }
}

/// The Jacobian of the values refit's whole-file residuals at physical `p` by
/// sensitivities against the fits' forward differences and central differences of
/// several steps: per column, the relative difference.
fn jacobian_check(
    plant: &lockstep::plant::Plant,
    record: &lockstep::identify::output_error::Record,
    names: &[String],
    p: &[f64],
    label: &str,
) {
    use lockstep::identify::output_error::{JacobianMethod, Problem, Residuals, Stencil};
    let conf = plant.model.configuration("k1").unwrap();
    let problem = |jacobian| {
        let o = lockstep::identify::refit::RefitOptions {
            jacobian,
            h: 1.0 / 12000.0,
            ..OutputOptions::default().fit
        };
        Problem::new(
            plant,
            conf,
            names.to_vec(),
            vec![record.clone()],
            &[],
            o.output_error(vec![1.0]),
        )
        .unwrap()
    };
    let (s, d) = (
        problem(JacobianMethod::Sensitivities),
        problem(JacobianMethod::Differences),
    );
    let x = s.to_scaled(p);
    let r0 = s.residuals(p).unwrap();
    let columns = |pr: &Problem, h: f64, central: bool| {
        let steps: Vec<f64> = x
            .iter()
            .map(|&u| if u + h > 1.0 { -h } else { h })
            .collect();
        let p_of = |y: &[f64]| pr.to_physical(y);
        pr.jacobian_columns(&Stencil {
            x: &x,
            r0: &r0,
            steps: &steps,
            p_of: &p_of,
            central,
        })
    };
    let got = columns(&s, 1e-6, false);
    let norm = |c: &[f64]| c.iter().map(|v| v * v).sum::<f64>().sqrt();
    let rel = |a: &[f64], b: &[f64]| {
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - y).powi(2))
            .sum::<f64>()
            .sqrt()
            / norm(b).max(1e-300)
    };
    let forward = columns(&d, 1e-6, false);
    let central: Vec<_> = [1e-3, 1e-5, 1e-7]
        .iter()
        .map(|&h| columns(&d, h, true))
        .collect();
    println!("  Jacobian at the {label} (cost {:.6e}): column, ‖J‖, vs forward 1e-6, vs central 1e-3, 1e-5, 1e-7", r0.iter().map(|v| v * v).sum::<f64>());
    for (i, n) in names.iter().enumerate() {
        println!(
            "    {n:<10} {:>10.3e} {:>10.3e} {:>10.3e} {:>10.3e} {:>10.3e}",
            norm(&got[i]),
            rel(&got[i], &forward[i]),
            rel(&got[i], &central[0][i]),
            rel(&got[i], &central[1][i]),
            rel(&got[i], &central[2][i]),
        );
    }
}

/// The torque-space detector on six joints.
fn torque_space(truth: &lockstep::plant::Plant, dir: &std::path::Path) {
    let file = common::table_4_7_file(truth, dir, dir, "k5");
    let m = Measurement::read(&file, truth.model.joints).unwrap();
    let mut linear = truth.clone();
    linear.effects.clear();
    for j in 0..truth.model.joints.len() {
        for kind in [EffectKind::Viscous, EffectKind::Coulomb] {
            linear.add_effect(Effect::on(kind, j)).unwrap();
            let name = Effect::on(kind, j).parameter_names(truth.model.joints)[0].clone();
            linear.parameters.entry(name).or_insert(0.0);
        }
    }
    let options = IdimOptions {
        cutoff_hz: 20.0,
        filter_order: 4,
        decimation: 1,
        window: None,
        min_speed: None,
        differentiator: lockstep::signal::Differentiator::Central,
        trim_moving_edges: false,
    };
    let started = Instant::now();
    let obs = observation(&linear, "k5", std::slice::from_ref(&m), &options).unwrap();
    let prepared = started.elapsed().as_secs_f64();
    let started = Instant::now();
    let d = lockstep::diagnose::torque::diagnosis(&linear, &obs).unwrap();
    let wall = started.elapsed().as_secs_f64();
    println!(
        "torque-space detector, k5 40 s × 6 joints ({} rows): observation {prepared:.2} s, diagnosis {wall:.2} s (target < {TORQUE_TARGET_S} s); {} findings, not white: {}; {}",
        obs.rows.len(),
        d.findings.len(),
        d.not_white.len(),
        lockstep::diagnose::verdict(&d.findings, &d.not_white)
    );
}
