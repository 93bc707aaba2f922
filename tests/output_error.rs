//! Output-error identification on synthetic data (issue 5): data made by `lockstep excite`
//! and `lockstep simulate` from a known plant, a start away from it, and the fit must reach
//! the noise floor and recover what it calls identifiable; bad input is refused before any
//! optimisation with the file and item named.

use lockstep::identify::equation_error::Cutoff;
use lockstep::identify::output_error::{
    OutputErrorOptions, Problem, Residuals, StageOptimiser, StageRecord, TimeWeighting, WarmUp,
};
use lockstep::identify::sequence::{plan, read_record};
use lockstep::plant::Plant;
use std::path::{Path, PathBuf};
use std::process::Output;

mod common;
use common::{fails, lockstep, ok};

fn plants() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("model/plants")
}

/// The Appendix D coupled-method plant with I4_33 made positive (the truth of the issue).
fn truth(dir: &Path) -> PathBuf {
    let text = std::fs::read_to_string(plants().join("freedom6s_appendix_d_coupled.toml"))
        .unwrap()
        .replace("I4_33 = -0.00017449", "I4_33 = 0.00017449");
    assert!(text.contains("I4_33 = 0.00017449"));
    let p = dir.join("truth.toml");
    std::fs::write(&p, text).unwrap();
    p
}

/// Excite configuration `config` with `table`/`test` for `duration` s and simulate the
/// truth with σ = 2e-4 rad noise and 1e-4 rad quantisation into `dir/<config>_run.csv`.
fn make_data(
    dir: &Path,
    truth: &Path,
    table: &str,
    test: Option<&str>,
    config: &str,
    duration: &str,
) {
    let tau = dir.join(format!("tau_{config}.csv"));
    let mut args = vec![
        "excite",
        "--model",
        "freedom6s",
        "--table",
        table,
        "--config",
        config,
        "--duration",
        duration,
        "-o",
    ];
    let tau_s = tau.to_str().unwrap().to_string();
    args.push(&tau_s);
    if let Some(t) = test {
        args.extend(["--test", t]);
    }
    ok(&lockstep(&args));
    let data = dir.join("data");
    std::fs::create_dir_all(&data).unwrap();
    let out = data.join(format!("{config}_run.csv"));
    ok(&lockstep(&[
        "simulate",
        "--plant",
        truth.to_str().unwrap(),
        "--input",
        tau.to_str().unwrap(),
        "--noise",
        "2e-4",
        "--quantisation",
        "1e-4",
        "--seed",
        "11",
        "--step",
        "1/12000",
        "-o",
        out.to_str().unwrap(),
    ]));
}

/// A start plant: the truth with the step's fitted values moved by ±25 % (alternating) and
/// bounds [v/4, 4v] around the truth (signed parameters: v ± 3|v|).
fn perturbed_start(truth: &Path, names: &[String], out: &Path) {
    let mut p = Plant::load(truth).unwrap();
    for (i, n) in names.iter().enumerate() {
        let v = p.parameters[n];
        let (lo, hi) = if v > 0.0 && !n.starts_with("qeq") {
            (v / 4.0, 4.0 * v)
        } else {
            (v - 3.0 * v.abs() - 0.1, v + 3.0 * v.abs() + 0.1)
        };
        p.bounds.insert(n.clone(), (lo, hi));
        let f = if i % 2 == 0 { 1.25 } else { 0.75 };
        p.parameters.insert(
            n.clone(),
            if n.starts_with("qeq") {
                v + 0.05
            } else {
                v * f
            },
        );
    }
    // Fs ≥ Fc at the start.
    for j in 0..6 {
        let (fc, fs) = (format!("Fc_q{j}"), format!("Fs_q{j}"));
        if let (Some(&c), Some(&s)) = (p.parameters.get(&fc), p.parameters.get(&fs)) {
            if s < c {
                p.parameters.insert(fs, c);
            }
        }
    }
    p.save(out).unwrap();
}

/// Configuration c1 and its record `dir/data/c1_run.csv` (made by [`make_data`]).
fn c1_record(
    dir: &Path,
    truth: &Plant,
) -> (
    &'static generated::Configuration,
    lockstep::identify::output_error::Record,
) {
    let conf = truth.model.configuration("c1").unwrap();
    let rec = read_record(&dir.join("data/c1_run.csv"), truth.model, conf, 0.01).unwrap();
    (conf, rec)
}

/// Run the isolated step c1 on 40 s of Table 4.3's J4 chirp from a ±25 % start; returns
/// the step's fit (report JSON), the truth and the output directory.
fn fit_c1(d: &Path) -> (serde_json::Value, Plant, PathBuf) {
    let truth = truth(d);
    make_data(d, &truth, "4.3", Some("J4"), "c1", "40");
    let plant = Plant::load(&truth).unwrap();
    let steps = plan(&plant, "isolated").unwrap();
    let c1 = &steps[0];
    assert_eq!(c1.config, "c1");
    // Figure 4.2: m7, x7, y7, I7_33 first appear in c1; joint 4's gain, LuGre and spring.
    for n in [
        "m7",
        "x7",
        "y7",
        "I7_33",
        "Kp_q4",
        "sigma0_q4",
        "Fc_q4",
        "Fs_q4",
        "vs_q4",
        "Ks_q4",
        "qeq_q4",
    ] {
        assert!(
            c1.fitted.contains(&n.to_string()),
            "{n} not fitted in c1: {:?}",
            c1.fitted
        );
    }
    let start = d.join("start.toml");
    perturbed_start(&truth, &c1.fitted, &start);
    // The data were simulated at 1/12000 s: fit with the same integrator.
    let report = identify_isolated(d, &start, "c1", &["--step", "1/12000"]);
    (
        report["steps"][0]["fit"].clone(),
        Plant::load(&truth).unwrap(),
        d.join("out"),
    )
}

/// 12 s of Table 4.3's `test` chirp on isolated step `step` (0 = c1) of the truth, and the
/// ±25 % start of [`perturbed_start`] for that step's parameters: the truth and the start.
fn short_isolated_start(d: &Path, test: &str, step: usize) -> (Plant, PathBuf) {
    let truth_file = truth(d);
    let truth = Plant::load(&truth_file).unwrap();
    let config = plan(&truth, "isolated").unwrap()[step].clone();
    make_data(d, &truth_file, "4.3", Some(test), &config.config, "12");
    let start = d.join("start.toml");
    perturbed_start(&truth_file, &config.fitted, &start);
    (truth, start)
}

/// The fit problem of isolated step `step` (0 = c1) on 40 s of Table 4.3's `test` chirp:
/// the problem with the plant at the truth, the fitted parameters' true values, and their
/// values in the ±25 % start of [`perturbed_start`].
fn problem_at_truth(d: &Path, test: &str, step: usize) -> (Problem, Vec<f64>, Vec<f64>) {
    problem_of_step(d, "isolated", "4.3", Some(test), |steps| {
        step.min(steps.len())
    })
}

/// [`problem_at_truth`] for the step `pick` chooses of the `method`'s plan, excited by
/// `table`/`test` for 40 s.
fn problem_of_step(
    d: &Path,
    method: &str,
    table: &str,
    test: Option<&str>,
    pick: impl Fn(&[lockstep::identify::sequence::Step]) -> usize,
) -> (Problem, Vec<f64>, Vec<f64>) {
    let truth_file = truth(d);
    let truth = Plant::load(&truth_file).unwrap();
    let mut steps = plan(&truth, method).unwrap();
    let s = steps.swap_remove(pick(&steps));
    make_data(d, &truth_file, table, test, &s.config, "40");
    let start = d.join("start.toml");
    perturbed_start(&truth_file, &s.fitted, &start);
    // The start's bounds, the truth's values.
    let mut plant = Plant::load(&start).unwrap();
    let off: Vec<f64> = s.fitted.iter().map(|n| plant.parameters[n]).collect();
    let at_truth: Vec<f64> = s.fitted.iter().map(|n| truth.parameters[n]).collect();
    for (n, &v) in s.fitted.iter().zip(&at_truth) {
        plant.parameters.insert(n.clone(), v);
    }
    let conf = truth.model.configuration(&s.config).unwrap();
    let rec = read_record(
        &d.join(format!("data/{}_run.csv", s.config)),
        truth.model,
        conf,
        0.01,
    )
    .unwrap();
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
    (p, at_truth, off)
}

/// Run `lockstep identify sequence --preset isolated` on `start` with the files in `dir/data`, step
/// `config`, options `more`, output to `dir/out`; returns the report (`report.json`).
fn identify_isolated(dir: &Path, start: &Path, config: &str, more: &[&str]) -> serde_json::Value {
    let (data, out) = (dir.join("data"), dir.join("out"));
    let mut args = vec![
        "identify",
        "sequence",
        "--preset",
        "isolated",
        "--plant",
        start.to_str().unwrap(),
        "--data",
        data.to_str().unwrap(),
        "--config",
        config,
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(more);
    ok(&lockstep(&args));
    read_report(&out)
}

/// The report (`report.json`) an identify run wrote to `dir`.
fn read_report(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("report.json")).unwrap()).unwrap()
}

/// `p` set up again on `plant` with `options`: the same configuration, fitted names and
/// files, joints `interest` weighted as the joints of interest.
fn rebuilt(p: &Problem, plant: &Plant, interest: &[usize], options: OutputErrorOptions) -> Problem {
    Problem::new(
        plant,
        p.configuration(),
        p.names.clone(),
        p.records.clone(),
        interest,
        options,
    )
    .unwrap()
}

/// The standard errors a step's plant should record ([`Plant::standard_errors`]): those of
/// the report's fit (`fit`, at the noise floor) for the values it fitted, finite and off
/// their bounds.
fn recorded_standard_errors(fit: &serde_json::Value) -> std::collections::BTreeMap<String, f64> {
    let names: Vec<String> = column(fit, &["names"]);
    let std_err: Vec<Option<f64>> = column(fit, &["statistics", "std_err"]);
    let at_bound: Vec<bool> = column(fit, &["statistics", "at_bound"]);
    names
        .iter()
        .enumerate()
        .filter(|&(i, _)| !at_bound[i])
        .filter_map(|(i, n)| Some((n.clone(), std_err[i].filter(|s| s.is_finite())?)))
        .collect()
}

fn column<T: serde::de::DeserializeOwned>(fit: &serde_json::Value, path: &[&str]) -> T {
    let mut v = fit;
    for p in path {
        v = &v[*p];
    }
    serde_json::from_value(v.clone()).unwrap()
}

/// The issue's criterion on step c1: the noise floor, and every parameter the report calls
/// identifiable within 5 % of the truth. (Before the structural check, m7, x7 and y7 — which
/// c1 determines only as m7·x7 and m7·y7 — could be called identifiable by the linearised
/// statistics alone.) One fit serves every assertion: it takes about a minute and a half.
#[test]
#[ignore = "slow end-to-end identification (minutes); cargo test --release -- --ignored"]
fn isolated_step_c1_reaches_the_noise_floor_and_recovers_everything_it_calls_identifiable() {
    let d = tempfile::tempdir().unwrap();
    let (fit, truth, out_dir) = fit_c1(d.path());
    let names: Vec<String> = column(&fit, &["names"]);
    let fitted: Vec<f64> = column(&fit, &["fitted"]);
    let identifiable: Vec<bool> = column(&fit, &["statistics", "identifiable"]);
    let only_with: Vec<Vec<String>> = column(&fit, &["statistics", "only_with"]);
    // Noise floor: σ = 2e-4 and quantisation 1e-4 (σ_q = 2.9e-5): RMS ≤ 1.5 σ.
    for j in fit["statistics"]["joints"].as_array().unwrap() {
        let rms = j["rms"].as_f64().unwrap();
        assert!(
            rms <= 1.5 * 2e-4,
            "joint {} RMS {rms:.3e} above 1.5 σ",
            j["joint"]
        );
    }
    assert!(fit["cost_after"].as_f64().unwrap() < 1e-6 * fit["cost_before"].as_f64().unwrap());
    let relative: Vec<Option<f64>> = column(&fit, &["statistics", "relative_std_err"]);
    for (i, n) in names.iter().enumerate() {
        println!(
            "{n}: fitted {:.5e}, truth {:.5e} ({:+.2} %), σ/|p| {:.2?}, identifiable {}, only with {:?}",
            fitted[i],
            truth.parameters[n],
            100.0 * (fitted[i] / truth.parameters[n] - 1.0),
            relative[i],
            identifiable[i],
            only_with[i]
        );
    }
    println!("correlated: {}", fit["statistics"]["correlated"]);
    for (i, n) in names.iter().enumerate() {
        let t = truth.parameters[n];
        if identifiable[i] {
            let e = (fitted[i] - t).abs() / t.abs();
            assert!(
                e <= 0.05,
                "{n}: fitted {} vs truth {t} ({:.1} %)",
                fitted[i],
                100.0 * e
            );
        }
    }
    // The Stribeck velocity and the spring's rest position are outside the plant-gain scale
    // family (Kp with every force-like parameter of the joint): called identifiable.
    for n in ["vs_q4", "qeq_q4"] {
        let i = names.iter().position(|x| x == n).unwrap();
        assert!(identifiable[i], "{n} should be identifiable");
    }
    // The plant gain is not separately identifiable from what it multiplies.
    let kp = names.iter().position(|x| x == "Kp_q4").unwrap();
    assert!(!identifiable[kp]);
    // By default (`--rigid-body spanning`) c1 fits 3 of its 4 rigid-body symbols: m7, x7,
    // y7, I7_33 enter its equation through 3 base parameters (m7·x7, m7·y7 and the
    // inertia about joint 4's axis); the fourth is held and listed.
    let report = read_report(&out_dir);
    let held: Vec<String> = column(&report["steps"][0]["step"], &["tied_held"]);
    assert_eq!(held.len(), 1, "held {held:?}");
    assert!(["m7", "x7", "y7", "I7_33"].contains(&held[0].as_str()));
    assert!(!names.contains(&held[0]));
    // The updated plant reads back with the fitted values, and records the rigid-body
    // symbols c1 held or fitted but did not determine, so that a later step run alone
    // fits them again.
    let fitted_plant = Plant::load(&out_dir.join("plant.toml")).unwrap();
    assert_eq!(fitted_plant.parameters[&names[0]], fitted[0]);
    let undetermined: Vec<String> = held
        .iter()
        .cloned()
        .chain(
            names
                .iter()
                .zip(&identifiable)
                .filter(|(n, &ok)| !ok && fitted_plant.model.inertial_symbols.contains(&n.as_str()))
                .map(|(n, _)| n.clone()),
        )
        .collect();
    assert_eq!(fitted_plant.undetermined, undetermined);
    // At the noise floor it also records the standard errors of the values it fitted (for
    // the held values' share in later steps, and `--carried-prior`): finite for the two
    // outside the gain family, none for the tied symbols (infinite standard errors).
    let recorded = recorded_standard_errors(&report["steps"][0]["fit"]);
    for n in ["vs_q4", "qeq_q4"] {
        assert!(recorded.contains_key(n), "{recorded:?}");
    }
    for n in &undetermined {
        assert!(!recorded.contains_key(n), "{n}: {recorded:?}");
    }
    assert_eq!(fitted_plant.standard_errors, recorded);
    // The Appendix D plant records no standard errors: c1 takes every value it holds
    // (link 7's other symbols, the other joints' effects do not enter) as exact, except
    // its held tie, which enters with its bounds' uniform spread.
    let held_uncertain: Vec<(String, f64)> = column(&fit, &["statistics", "held"]);
    let held_ties: Vec<(String, f64)> = column(&fit, &["statistics", "held_ties"]);
    let held_exact: Vec<String> = column(&fit, &["statistics", "held_exact"]);
    assert!(held_uncertain.is_empty(), "{held_uncertain:?}");
    let (lo, hi) = fitted_plant.bounds[&held[0]];
    assert_eq!(held_ties, [(held[0].clone(), (hi - lo) / 12f64.sqrt())]);
    assert!(!held_exact.contains(&held[0]), "{held_exact:?}");
    assert!(
        held_exact.iter().all(|n| !n.ends_with("_0")),
        "{held_exact:?}"
    );
    assert!(std::fs::read_to_string(out_dir.join("report.md"))
        .unwrap()
        .contains("| parameter | initial | fitted | std error"));
}

#[test]
fn fs_at_least_fc_holds_at_every_trial_point() {
    let d = tempfile::tempdir().unwrap();
    let truth = truth(d.path());
    make_data(d.path(), &truth, "4.3", Some("J4"), "c1", "2");
    let mut plant = Plant::load(&truth).unwrap();
    for n in ["Fc_q4", "Fs_q4"] {
        plant.bounds.insert(n.into(), (0.001, 0.1));
    }
    let model = plant.model;
    let conf = model.configuration("c1").unwrap();
    let rec = read_record(&d.path().join("data/c1_run.csv"), model, conf, 0.01).unwrap();
    let opts = OutputErrorOptions {
        weighting: TimeWeighting::HalfFirst,
        ..OutputErrorOptions::thesis()
    };
    let p = Problem::new(
        &plant,
        conf,
        vec!["Fc_q4".into(), "Fs_q4".into()],
        vec![rec],
        &[4],
        opts,
    )
    .unwrap();
    let mut rng = generated::inertia::Xorshift(3);
    for _ in 0..1000 {
        let u = [rng.uniform(0.0, 1.0), rng.uniform(0.0, 1.0)];
        let x = p.to_physical(&u);
        assert!(x[1] >= x[0], "Fs {} < Fc {}", x[1], x[0]);
        assert!((0.001..=0.1).contains(&x[0]) && (0.001..=0.1).contains(&x[1]));
        let back = p.to_physical(&p.to_scaled(&x));
        assert!((back[0] - x[0]).abs() < 1e-15 && (back[1] - x[1]).abs() < 1e-15);
    }
    // Cost (4.2): first half weighted ½ → the residuals of the first half are 1/√2 of the
    // plain error.
    assert_eq!(TimeWeighting::HalfFirst.weight(0, 10), 0.5);
    assert_eq!(TimeWeighting::HalfFirst.weight(5, 10), 1.0);
    assert_eq!(TimeWeighting::SkipTransient(1000).weight(999, 4000), 0.0);
}

#[test]
fn the_coupled_plan_follows_figure_4_2_and_identifies_effects_where_their_joints_are_free() {
    let plant = Plant::load(&plants().join("freedom6s_appendix_d_initial.toml")).unwrap();
    let steps = plan(&plant, "coupled").unwrap();
    let names: Vec<&str> = steps.iter().map(|s| s.config.as_str()).collect();
    assert_eq!(names, ["k1", "k2", "k3", "k4", "k5"]);
    // k1: both wrist joints new (λ = 50 on both), the tendon coupling both ways.
    assert_eq!(steps[0].interest, [4, 5]);
    for n in ["G_q4_to_q5", "G_q5_to_q4", "Kp_q4", "Kp_q5", "m7", "I7_33"] {
        assert!(steps[0].fitted.iter().any(|x| x == n), "{n}");
    }
    assert_eq!(steps[1].interest, [3]);
    assert_eq!(steps[4].interest, [0]);
    assert!(steps[4].fitted.iter().any(|x| x == "FrictionBias_q0"));
    // Every rigid-body symbol is fitted first at most once over the sequence; later only
    // when carried because an earlier step could not separate it.
    let mut all: Vec<&String> = steps
        .iter()
        .flat_map(|s| {
            s.fitted
                .iter()
                .filter(|n| !s.carried.contains(n))
                .chain(&s.held)
        })
        .collect();
    let n = all.len();
    all.sort();
    all.dedup();
    assert_eq!(all.len(), n);
    assert_eq!(steps[0].fitted.len() + steps[0].held.len(), 10 + 2 * 9 + 2);
    let iso = plan(&plant, "isolated").unwrap();
    assert_eq!(iso.len(), 7);
    assert!(iso[6].interest.is_empty(), "c7 frees no new joint");
    // c1 (the wrist alone) sees link 7 only through m7·x7, m7·y7 and the inertia about its
    // axis: m7, x7, y7 are carried into c2 (joint 5 alone does not separate them either)
    // and c3; from c4 on no link-7 symbol is carried.
    assert!(iso[0].carried.is_empty());
    assert_eq!(iso[1].carried, ["m7", "x7", "y7"]);
    for n in ["m7", "x7", "y7"] {
        assert!(
            iso[2].carried.iter().any(|x| x == n),
            "{:?}",
            iso[2].carried
        );
        assert!(
            iso[3].carried.iter().all(|x| x != n),
            "{:?}",
            iso[3].carried
        );
    }
}

#[test]
fn bad_input_is_refused_before_any_optimisation_naming_file_and_item() {
    let d = tempfile::tempdir().unwrap();
    let truth = truth(d.path());
    make_data(d.path(), &truth, "4.7", None, "k1", "3");
    let data = d.path().join("data");
    let start = plants().join("freedom6s_appendix_d_initial.toml");
    let out = d.path().join("out");
    let run_with = |plant: &Path, data: &Path, config: &str, more: &[&str]| {
        let mut args = vec![
            "identify",
            "sequence",
            "--preset",
            "coupled",
            "--plant",
            plant.to_str().unwrap(),
            "--data",
            data.to_str().unwrap(),
            "--config",
            config,
            "--cost",
            "4.2",
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(more);
        lockstep(&args)
    };
    let run = |plant: &Path, data: &Path, config: &str| run_with(plant, data, config, &[]);
    // A sensor noise that is not a positive number.
    for bad in ["0", "-2e-4", "two"] {
        fails(
            &run_with(&start, &data, "k1", &[&format!("--noise-sigma={bad}")]),
            &["--noise-sigma", "positive", bad],
        );
    }
    // A step without data.
    fails(
        &run(&start, &data, "k2"),
        &[
            "step 'k2'",
            "no measurement file of configuration 'k2'",
            "k1_run.csv (k1)",
        ],
    );
    // An unknown step.
    fails(
        &run(&start, &data, "c3"),
        &["no step 'c3'", "k1, k2, k3, k4, k5"],
    );
    // A locked joint that moves: a k2 record (q3 free) named as k1, where q3 is locked.
    make_data(d.path(), &truth, "4.7", None, "k2", "3");
    let moved = d.path().join("moved");
    std::fs::create_dir_all(&moved).unwrap();
    std::fs::copy(data.join("k2_run.csv"), moved.join("k1_moved.csv")).unwrap();
    fails(
        &run(&start, &moved, "k1"),
        &[
            "k1_moved.csv",
            "joint 'q3' is locked in configuration 'k1' but moves by",
        ],
    );
    // A free joint without data.
    let cut = d.path().join("cut");
    std::fs::create_dir_all(&cut).unwrap();
    let text = std::fs::read_to_string(data.join("k1_run.csv")).unwrap();
    let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    let keep: Vec<usize> = (0..header.len()).filter(|&i| header[i] != "q_q5").collect();
    let cut_text: String = text
        .lines()
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            keep.iter().map(|&i| f[i]).collect::<Vec<_>>().join(",") + "\n"
        })
        .collect();
    std::fs::write(cut.join("k1_cut.csv"), cut_text).unwrap();
    fails(
        &run(&start, &cut, "k1"),
        &[
            "k1_cut.csv",
            "joint 'q5' is free in configuration 'k1'",
            "'q5'",
        ],
    );
    // A fitted parameter without bounds.
    let mut p = Plant::load(&start).unwrap();
    p.bounds.remove("G_q4_to_q5");
    let nb = d.path().join("no_bounds.toml");
    p.save(&nb).unwrap();
    fails(
        &run(&nb, &data, "k1"),
        &[
            "step 'k1'",
            "'G_q4_to_q5' is fitted in configuration 'k1' but has no bounds",
        ],
    );
    // An initial value outside its bounds: refused when the plant is read.
    let text = std::fs::read_to_string(&start)
        .unwrap()
        .replace("G_q4_to_q5 = 1.0\n", "G_q4_to_q5 = 3.0\n");
    let ob = d.path().join("outside.toml");
    std::fs::write(&ob, text).unwrap();
    fails(&run(&ob, &data, "k1"), &["outside.toml", "G_q4_to_q5"]);
    // Horizons that leave nothing to fit, or that do not grow to the whole files; the
    // coupled method's defaults (no horizons, the equation error and the predictor) with
    // both warm-ups turned off; a predictor step that is not a step.
    let no_warm_up = ["--equation-error", "off", "--predictor", "none"];
    for (more, needles) in [
        (
            &[
                "--horizons",
                "none",
                "--equation-error",
                "off",
                "--predictor",
                "none",
            ][..],
            &["--horizons none:", "--equation-error"][..],
        ),
        (
            &no_warm_up[..],
            &[
                "--horizons none (the coupled method's default)",
                "--predictor",
            ][..],
        ),
        (
            &["--horizons", "0.5,0.2,1"][..],
            &["--horizons", "increasing", "0.5,0.2,1"][..],
        ),
        (
            &["--horizons", "0.1,0.5"][..],
            &["--horizons", "ending with 1"][..],
        ),
        (
            &["--predictor-step", "0"][..],
            &["--predictor-step", "positive step", "got '0'"][..],
        ),
    ] {
        fails(&run_with(&start, &data, "k1", more), needles);
    }
    assert!(!d.path().join("out").exists(), "nothing may be written");
}

/// Multiple shooting (`Problem::segmented`): every file cut into segments simulated from
/// the measured state at their starts. The start velocity (from 100 Hz positions) and the
/// sliding bristles are estimates, so at the truth a segment does not reach the noise
/// floor (≈ 1e-2 rad on joint 3, 50 σ: a warm-up, not the fit), but the truth is still far
/// below a start with the step's parameters 25 % off.
#[test]
fn segments_start_from_the_measured_state_and_separate_the_truth_from_a_far_start() {
    let d = tempfile::tempdir().unwrap();
    let (p, at_truth, off) = problem_at_truth(d.path(), "J3", 2);
    let n = p.records[0].t.len();
    for (seconds, segments) in [(1.0, 40), (4.0, 10)] {
        let s = p.segmented(seconds);
        // One residual per sample of the free joint, each segment's first left out.
        assert_eq!(s.residual_count(), n - segments, "{seconds} s");
        let rms = |x: &[f64]| (s.cost(x) / s.residual_count() as f64).sqrt() / 50.0;
        let (e_truth, e_off) = (rms(&at_truth), rms(&off));
        println!(
            "segments of {seconds} s: RMS at the truth {e_truth:.3e} rad, 25 % off {e_off:.3e} rad"
        );
        assert!(e_truth < 2.0e-2, "{e_truth}");
        assert!(e_off > 10.0 * e_truth, "{e_off} vs {e_truth}");
    }
}

/// Structural identifiability: in c1 the wrist's motion depends on link 7 only through its
/// base parameters (Gautier 1990: the inertia about the axis with m·(x² + y²) folded in,
/// and the first moments m·x, m·y), three numbers for the four symbols m7, x7, y7, I7_33.
/// Along m7 → (1 + ε) m7, x7 → x7 / (1 + ε), y7 → y7 / (1 + ε) no output changes (I7_33
/// moves by only m7 (x7² + y7²) / I7_33 ≈ 6 % of ε there, so it stays determined). The
/// linearised statistics alone cannot see an exact symmetry as exactly singular (a
/// finite-difference Jacobian); the report must name it.
#[test]
fn symbols_that_enter_only_through_base_parameters_are_not_called_identifiable() {
    let d = tempfile::tempdir().unwrap();
    let (p, x, _) = problem_at_truth(d.path(), "J4", 0);
    let names = &p.names;
    let stats = p.statistics(&x).unwrap();
    for (i, n) in names.iter().enumerate() {
        println!(
            "{n}: only with {:?}, identifiable {}",
            stats.only_with[i], stats.identifiable[i]
        );
    }
    let at = |n: &str| names.iter().position(|x| x == n).unwrap();
    for (n, others) in [
        ("m7", ["x7", "y7"]),
        ("x7", ["m7", "y7"]),
        ("y7", ["m7", "x7"]),
    ] {
        assert_eq!(stats.only_with[at(n)], others, "{n}");
        assert!(!stats.identifiable[at(n)], "{n}");
    }
    for n in ["I7_33", "sigma0_q4", "vs_q4", "Ks_q4", "qeq_q4", "Kp_q4"] {
        assert!(stats.only_with[at(n)].is_empty(), "{n}");
    }
    // At the truth the fit is at the noise floor (σ̂ from the data near the true 2e-4) and
    // the Stribeck velocity and the spring's rest are called identifiable.
    assert!(stats.above_floor.is_empty(), "{:?}", stats.above_floor);
    let q4 = &stats.joints[0];
    assert!((q4.noise / 2e-4 - 1.0).abs() < 0.15, "σ̂ {}", q4.noise);
    assert!(stats.identifiable[at("vs_q4")] && stats.identifiable[at("qeq_q4")]);
}

/// Physical consistency is a constraint of every stage: a trial point that leaves a link
/// with a fitted symbol impossible (here m7 < 0 in c1) fails, naming the link, as a
/// diverged simulation does, so the optimiser rejects the step (the equation error's
/// torque balance and a strongly pulled predictor can be evaluated there; k4 of the
/// Freedom 6S had gone there and no later stage could simulate). A link already
/// impossible at the plant's values is not guarded: the fit may move it back.
#[test]
fn a_trial_point_that_makes_a_consistent_link_impossible_is_rejected() {
    let d = tempfile::tempdir().unwrap();
    let (p, x, _) = problem_at_truth(d.path(), "J4", 0);
    let at = |n: &str| p.names.iter().position(|x| x == n).unwrap();
    assert_eq!(p.guarded_links(), ["L7"]);
    assert!(p.residuals(&x).is_ok());
    let mut y = x.clone();
    y[at("m7")] = -0.01;
    let err = p.residuals(&y).unwrap_err();
    assert!(
        matches!(&err, lockstep::identify::output_error::TrialFailure::ImpossibleLink(f) if f.contains("'L7'")),
        "{err}"
    );
    // The same fit from a plant where L7 is impossible already (its mass negative): not
    // guarded, so the point is evaluated (whatever the simulation then says).
    let truth = Plant::load(&truth(d.path())).unwrap();
    let s = plan(&truth, "isolated").unwrap().swap_remove(0);
    let conf = truth.model.configuration(&s.config).unwrap();
    let impossible = p.plant_at(&y);
    let problem_of = |plant: &Plant| {
        Problem::new(
            plant,
            conf,
            s.fitted.clone(),
            vec![q_record(d.path(), &s.config, &truth)],
            &s.interest,
            OutputErrorOptions::thesis(),
        )
    };
    // Its bounds refuse m7 < 0 (named) before anything is guarded; widen them.
    let err = problem_of(&impossible)
        .err()
        .map(|e| format!("{e:#}"))
        .unwrap_or_default();
    assert!(err.contains("m7"), "{err}");
    let mut wide = impossible.clone();
    wide.bounds.insert("m7".into(), (-1.0, 1.0));
    let q = problem_of(&wide).unwrap();
    assert!(q.guarded_links().is_empty(), "{:?}", q.guarded_links());
    if let Err(e) = q.residuals(&y) {
        assert!(
            !matches!(
                e,
                lockstep::identify::output_error::TrialFailure::ImpossibleLink(_)
            ),
            "{e}"
        );
    }
}

/// The measurement file of `config` that [`problem_of_step`] wrote under `d`.
fn q_record(d: &Path, config: &str, truth: &Plant) -> lockstep::identify::output_error::Record {
    let conf = truth.model.configuration(config).unwrap();
    read_record(
        &d.join(format!("data/{config}_run.csv")),
        truth.model,
        conf,
        0.01,
    )
    .unwrap()
}

/// Far from the floor the residuals are not noise and the standard errors mean nothing: at
/// the ±25 % start of c1 no parameter is called identifiable, and the report says which
/// joint is how far above its noise.
#[test]
fn nothing_is_called_identifiable_away_from_the_noise_floor() {
    let d = tempfile::tempdir().unwrap();
    let (p, _, off) = problem_at_truth(d.path(), "J4", 0);
    let stats = p.statistics(&off).unwrap();
    let q4 = &stats.joints[0];
    println!("q4 RMS {:.3e}, σ̂ {:.3e}", q4.rms, q4.noise);
    assert!(q4.rms > 10.0 * q4.noise);
    assert_eq!(stats.above_floor.len(), 1);
    assert!(
        stats.above_floor[0].starts_with("q4 RMS "),
        "{:?}",
        stats.above_floor
    );
    assert!(stats.identifiable.iter().all(|ok| !ok));
}

/// `--segments`: one more start from the plant's values goes through the segment stages and
/// then the whole files, beside the start through the horizons; the report lists both and
/// keeps the lower cost. Short data and few iterations: this checks the plumbing, the
/// recovery is measured elsewhere.
#[test]
fn segments_add_a_start_that_runs_beside_the_horizons_and_the_lower_cost_wins() {
    let d = tempfile::tempdir().unwrap();
    let (_, start) = short_isolated_start(d.path(), "J3", 2);
    let report = identify_isolated(
        d.path(),
        &start,
        "c3",
        &[
            "--step",
            "1/12000",
            "--segments",
            "1,4",
            "--horizons",
            "0.5,1",
            "--max-iter",
            "3",
        ],
    );
    let fit = &report["steps"][0]["fit"];
    let starts = fit["starts"].as_array().unwrap();
    assert_eq!(starts.len(), 2);
    assert_eq!(starts[0]["warm_up"], "horizons");
    assert_eq!(starts[1]["warm_up"], "segments");
    // The report names the start it kept and shows how the other one ended.
    let kept = fit["best_start"].as_u64().unwrap();
    let other = &starts[1 - kept as usize];
    let md = std::fs::read_to_string(d.path().join("out").join("report.md")).unwrap();
    let line = format!("Start {} (not kept): cost ", 1 - kept);
    let shown = md
        .lines()
        .find(|l| l.starts_with(&line))
        .unwrap_or_else(|| panic!("{md}"));
    assert!(
        shown.ends_with(&format!("{}.", other["status"].as_str().unwrap())),
        "{shown}"
    );
    let cost = |s: &serde_json::Value| s["cost"].as_f64().unwrap();
    let best = fit["cost_after"].as_f64().unwrap();
    // The winner's cost is where the least change starts; it may then rise by at most
    // one noise variance (the moves along exact ties and the gain scale).
    let lower = cost(&starts[0]).min(cost(&starts[1]));
    let lc = &fit["least_change"];
    assert_eq!(lc["cost_at_minimum"].as_f64().unwrap(), lower);
    assert!(
        best <= lower + lc["allowed_rise"].as_f64().unwrap(),
        "{best} vs {lower}"
    );
    assert!(best < fit["cost_before"].as_f64().unwrap());
    // Bad lengths are refused by name.
    let (plant, data) = (start.to_str().unwrap(), d.path().join("data"));
    let identify = |more: &[&str]| {
        let mut args = vec![
            "identify",
            "sequence",
            "--preset",
            "isolated",
            "--plant",
            plant,
            "--data",
            data.to_str().unwrap(),
        ];
        args.extend_from_slice(more);
        lockstep(&args)
    };
    fails(&identify(&["--segments", "1,-4"]), &["--segments", "'-4'"]);
    fails(
        &identify(&["--equation-error", "2"]),
        &["--equation-error", "'2'"],
    );
}

/// The gain family of joint 4 in c1 with the prior's offsets δ_i: scaling the plant gain
/// with every force-like parameter of the joint leaves the motion exactly unchanged.
const GAIN_FAMILY_4: [(&str, f64); 9] = [
    ("Kp_q4", 0.30),
    ("sigma0_q4", 0.20),
    ("sigma1_q4", 0.40),
    ("sigma2_q4", 0.25),
    ("Fc_q4", 0.30),
    ("Fs_q4", 0.35),
    ("Ks_q4", 0.20),
    ("m7", 0.30),
    ("I7_33", 0.25),
];

/// c1 on `seconds` of Table 4.3's J4 chirp: the truth, the start (the [`GAIN_FAMILY_4`]
/// at t_i (1 + δ_i), `others` at the truth, every fitted name with the perturbed start's
/// bounds), the fitted names (the family, then `others`) and the record.
fn gain_family_start(
    d: &Path,
    seconds: &str,
    others: &[&str],
) -> (
    Plant,
    Plant,
    Vec<String>,
    &'static generated::Configuration,
    lockstep::identify::output_error::Record,
) {
    let truth_file = truth(d);
    let truth = Plant::load(&truth_file).unwrap();
    make_data(d, &truth_file, "4.3", Some("J4"), "c1", seconds);
    let names: Vec<String> = GAIN_FAMILY_4
        .iter()
        .map(|(n, _)| n.to_string())
        .chain(others.iter().map(|n| n.to_string()))
        .collect();
    let start = d.join("start.toml");
    perturbed_start(&truth_file, &names, &start);
    let mut plant = Plant::load(&start).unwrap();
    for (n, delta) in GAIN_FAMILY_4 {
        plant
            .parameters
            .insert(n.into(), truth.parameters[n] * (1.0 + delta));
    }
    for n in others {
        plant.parameters.insert((*n).into(), truth.parameters[*n]);
    }
    let (conf, rec) = c1_record(d, &truth);
    (truth, plant, names, conf, rec)
}

/// The prior decides where the data are silent, and only there. In c1 with x7 and y7 held,
/// scaling the plant gain with every force-like parameter of joint 4 (LuGre σ0, σ1, σ2, Fc,
/// Fs, the spring Ks, and m7, I7_33) by α leaves the motion exactly unchanged. With the
/// prior's centre c_i = t_i (1 + δ_i) about the truth t, the posterior picks on that line
/// the α minimising Σ ((α t_i − c_i) / (τ c_i))², i.e. α* = Σ ρ_i / Σ ρ_i², ρ_i = t_i / c_i
/// (an analytic reference independent of the fit); the parameters outside the family (vs_q4,
/// qeq_q4) stay where the data put them, and the cost stays at the noise floor.
#[test]
#[ignore = "slow end-to-end identification (minutes); cargo test --release -- --ignored"]
fn the_prior_picks_the_point_of_an_exact_scale_symmetry_its_centre_prefers() {
    let d = tempfile::tempdir().unwrap();
    let others = ["vs_q4", "qeq_q4"];
    let (truth, plant, names, conf, rec) = gain_family_start(d.path(), "20", &others);
    let family = GAIN_FAMILY_4;
    let tau = 0.1;
    let p = Problem::new(
        &plant,
        conf,
        names.clone(),
        vec![rec],
        &[4],
        OutputErrorOptions {
            h: 1.0 / 12000.0,
            prior: Some(tau),
            ..OutputErrorOptions::thesis()
        },
    )
    .unwrap();
    let fit = p.fit(&|_| {}).unwrap();
    let rho: Vec<f64> = family
        .iter()
        .map(|(_, delta)| 1.0 / (1.0 + delta))
        .collect();
    let alpha = rho.iter().sum::<f64>() / rho.iter().map(|r| r * r).sum::<f64>();
    assert!((alpha - 1.2774).abs() < 1e-4, "α* = {alpha}");
    for (i, (n, _)) in family.iter().enumerate() {
        let ratio = fit.fitted[i] / truth.parameters[*n];
        println!("{n}: fitted / truth {ratio:.4} (α* = {alpha:.4})");
        assert!(
            (ratio / alpha - 1.0).abs() < 0.01,
            "{n}: fitted / truth {ratio:.4}, the prior's optimum on the scale line {alpha:.4}"
        );
    }
    for (k, n) in others.iter().enumerate() {
        let (f, t) = (fit.fitted[family.len() + k], truth.parameters[*n]);
        assert!((f - t).abs() < 0.01 * t.abs(), "{n}: {f} vs truth {t}");
    }
    for j in &fit.statistics.joints {
        assert!(j.rms < 1.5 * 2e-4, "{}: RMS {:.3e}", j.joint, j.rms);
    }
    assert!(fit.prior_penalty > 0.0);
}

/// The prior's mechanism, fast (the default test set; the fit itself is the ignored test
/// above): on c1's exact scale symmetry the data cost is the same at every α on the line
/// α × truth, and the prior's term is smallest at the analytic α* = Σ ρ_i / Σ ρ_i² (ρ_i = t_i /
/// c_i, the prior's centre c = the start), larger 2 % either side and at the truth (α = 1).
#[test]
fn the_prior_term_is_least_at_the_analytic_point_of_a_scale_symmetry() {
    let d = tempfile::tempdir().unwrap();
    let (truth, plant, names, conf, rec) = gain_family_start(d.path(), "5", &[]);
    let family = GAIN_FAMILY_4;
    let p = Problem::new(
        &plant,
        conf,
        names.clone(),
        vec![rec],
        &[4],
        OutputErrorOptions {
            h: 1.0 / 12000.0,
            prior: Some(0.1),
            weighting: lockstep::identify::output_error::TimeWeighting::SkipTransient(100),
            ..OutputErrorOptions::thesis()
        },
    )
    .unwrap();
    let rho: Vec<f64> = family
        .iter()
        .map(|(_, delta)| 1.0 / (1.0 + delta))
        .collect();
    let alpha = rho.iter().sum::<f64>() / rho.iter().map(|r| r * r).sum::<f64>();
    let on_line = |a: f64| -> Vec<f64> { names.iter().map(|n| a * truth.parameters[n]).collect() };
    let penalty = |a: f64| p.prior_penalty(&p.to_scaled(&on_line(a)));
    let (at, below, above, truth_point) = (
        penalty(alpha),
        penalty(0.98 * alpha),
        penalty(1.02 * alpha),
        penalty(1.0),
    );
    eprintln!("prior term: α* {at:.4e}, 0.98 α* {below:.4e}, 1.02 α* {above:.4e}, α = 1 {truth_point:.4e}");
    assert!(at > 0.0 && at < below && at < above && at < truth_point);
    // The data cannot tell the points of the line apart: the same cost to rounding.
    let (c_star, c_one) = (p.cost(&on_line(alpha)), p.cost(&on_line(1.0)));
    assert!((c_star / c_one - 1.0).abs() < 1e-6, "{c_star} vs {c_one}");
}

/// The least change's plant-gain scale move: in c1 (x7, y7 held) the fit cannot tell the
/// truth from the whole gain family of joint 4 scaled by 0.6 (the motion is the same to
/// rounding), so the least change must scale it by α = 1 / 0.6 — the point of the symmetry
/// where the gain Kp_q4 and the rigid-body symbols m7, I7_33 are all at the plant's values
/// (here the truth) — and the rest of the family must follow to the truth, the cost
/// unchanged; the parameters outside the family stay.
/// Again with I7_33 held as a tie (as `--rigid-body spanning` holds k1's I7_13) and × 0.6
/// in the plant: no point of the symmetry has every value at the plant's, so the move must
/// end nearer them (gains and rigid-body symbols, held tie included, in units of their
/// bounds' widths) than the return of everything to the truth, which scales the held tie;
/// and the cost must stay.
#[test]
fn the_least_change_returns_a_scaled_gain_family_to_the_initial_plant_gain() {
    let d = tempfile::tempdir().unwrap();
    let truth_file = truth(d.path());
    let truth = Plant::load(&truth_file).unwrap();
    make_data(d.path(), &truth_file, "4.3", Some("J4"), "c1", "20");
    let family = [
        "Kp_q4",
        "sigma0_q4",
        "sigma1_q4",
        "sigma2_q4",
        "Fc_q4",
        "Fs_q4",
        "Ks_q4",
        "m7",
        "I7_33",
    ];
    let all: Vec<String> = family
        .iter()
        .chain(&["vs_q4", "qeq_q4"])
        .map(|n| n.to_string())
        .collect();
    let start = d.path().join("start.toml");
    perturbed_start(&truth_file, &all, &start);
    let (conf, rec) = c1_record(d.path(), &truth);
    // The start's bounds (a factor 4 either side), the truth's values as p₀.
    let mut at_truth_plant = Plant::load(&start).unwrap();
    for n in &all {
        at_truth_plant
            .parameters
            .insert(n.clone(), truth.parameters[n]);
    }
    let options = OutputErrorOptions {
        h: 1.0 / 12000.0,
        ..OutputErrorOptions::thesis()
    };
    let c_truth = Problem::new(
        &at_truth_plant,
        conf,
        all.clone(),
        vec![rec.clone()],
        &[4],
        options.clone(),
    )
    .unwrap()
    .cost(&all.iter().map(|n| truth.parameters[n]).collect::<Vec<_>>());
    for held in [None, Some("I7_33")] {
        let names: Vec<String> = all
            .iter()
            .filter(|n| Some(n.as_str()) != held)
            .cloned()
            .collect();
        // The held tie × 0.6 with the fitted family.
        let mut plant = at_truth_plant.clone();
        if let Some(h) = held {
            plant.parameters.insert(h.into(), 0.6 * truth.parameters[h]);
        }
        let p = Problem::new(
            &plant,
            conf,
            names.clone(),
            vec![rec.clone()],
            &[4],
            options.clone(),
        )
        .unwrap()
        .with_held_ties(held.iter().map(|h| h.to_string()).collect());
        let at_truth: Vec<f64> = names.iter().map(|n| truth.parameters[n]).collect();
        let scaled: Vec<f64> = names
            .iter()
            .zip(&at_truth)
            .map(|(n, v)| {
                if family.contains(&n.as_str()) {
                    0.6 * v
                } else {
                    *v
                }
            })
            .collect();
        let c_scaled = p.cost(&scaled);
        println!("held {held:?}: cost at the truth {c_truth:.6e}, the family × 0.6 {c_scaled:.6e}");
        assert!(
            (c_scaled - c_truth).abs() < 1e-6 * c_truth,
            "{c_scaled} vs {c_truth}"
        );
        let lc = p.least_change(&scaled, c_scaled).unwrap();
        let alpha = lc.gain_scale.expect("the gain-scale move was dropped");
        assert!(
            (lc.cost - c_truth).abs() < 1e-6 * c_truth,
            "{} vs {c_truth}",
            lc.cost
        );
        if let Some(h) = held {
            // Distance from the plant's values over the gain and the rigid-body symbols.
            let width = |n: &str| {
                let (lo, hi) = plant.bounds[n];
                hi - lo
            };
            let counted = ["Kp_q4", "m7", "I7_33"];
            let distance = |value: &dyn Fn(&str) -> f64| -> f64 {
                counted
                    .iter()
                    .map(|n| ((value(n) - plant.parameters[*n]) / width(n)).powi(2))
                    .sum()
            };
            let moved = |n: &str| -> f64 {
                match names.iter().position(|x| x == n) {
                    Some(i) => lc.fitted[i],
                    None => lc
                        .held
                        .iter()
                        .find(|(x, _)| x == n)
                        .map_or(plant.parameters[n], |(_, v)| *v),
                }
            };
            let (d_move, d_truth) = (distance(&moved), distance(&|n| truth.parameters[n]));
            println!(
                "held {h}: α = {alpha:.6}, distance² {d_move:.4e} against {d_truth:.4e} at the truth; held {:?}",
                lc.held
            );
            assert!(d_move < d_truth, "{d_move} vs {d_truth}");
            assert!((alpha * 0.6 - 1.0).abs() < 0.2, "α = {alpha}");
            continue;
        }
        assert!((alpha - 1.0 / 0.6).abs() < 1e-9, "α = {alpha}");
        for (i, n) in names.iter().enumerate() {
            let (f, t) = (lc.fitted[i], at_truth[i]);
            assert!((f - t).abs() <= 1e-9 * t.abs(), "{n}: {f} vs truth {t}");
        }
        assert_eq!(lc.held.len(), held.iter().len(), "{:?}", lc.held);
        for (n, v) in &lc.held {
            let t = truth.parameters[n];
            assert!(
                (v - t).abs() <= 1e-9 * t.abs(),
                "held {n}: {v} vs truth {t}"
            );
        }
        assert!(
            (lc.cost - c_truth).abs() < 1e-6 * c_truth,
            "{} vs {c_truth}",
            lc.cost
        );
        assert!(
            (lc.gains_after.unwrap() - 1.0).abs() < 1e-9,
            "{:?}",
            lc.gains_after
        );
    }
}

/// The equation error (the warm start of `--equation-error`): at the true parameters the
/// torque balance holds up to the filtering and the noise; the ±25 % start of c4 (joint 2,
/// the parallelogram base with gravity, Table 4.3's J2 chirp) breaks it many times over;
/// and it is unchanged (to rounding) along the plant gain's scale family — Kp_q2 with every force
/// of joint 2 and every mass and inertia — as the simulated positions are, so the warm
/// start does not pick a scale the output error cannot see.
/// rmpfit freezes a parameter only when it equals its limit; one within rounding of it (a
/// value read back from a plant file) shortened every step to about 1e-16 of the bound
/// distance, and the fit "converged" where it started (k3 of the Freedom 6S: no stage
/// moved from the fitted plant, whose I6_13 was 4e-23 above its lower bound). Here Ks_q4's
/// upper bound is below its truth, so its optimum is on the bound, and it starts 4 ulps
/// under it; Kp_q4 starts 20 % high: the fit must bring Kp_q4 back and leave Ks_q4 on the bound.
#[test]
fn a_parameter_within_rounding_of_its_bound_does_not_freeze_the_fit() {
    let d = tempfile::tempdir().unwrap();
    let truth_file = truth(d.path());
    let truth = Plant::load(&truth_file).unwrap();
    make_data(d.path(), &truth_file, "4.3", Some("J4"), "c1", "20");
    let (conf, rec) = c1_record(d.path(), &truth);
    let (kp, ks) = (truth.parameters["Kp_q4"], truth.parameters["Ks_q4"]);
    let ks_upper = 0.9 * ks;
    let mut plant = truth.clone();
    plant.bounds.insert("Kp_q4".into(), (0.5 * kp, 2.0 * kp));
    plant.bounds.insert("Ks_q4".into(), (0.1 * ks, ks_upper));
    plant.parameters.insert("Kp_q4".into(), 1.2 * kp);
    plant
        .parameters
        .insert("Ks_q4".into(), ks_upper * (1.0 - 4.0 * f64::EPSILON));
    let options = OutputErrorOptions {
        h: 1.0 / 12000.0,
        horizons: vec![1.0],
        ..OutputErrorOptions::thesis()
    };
    let names = vec!["Kp_q4".to_string(), "Ks_q4".to_string()];
    let fit = Problem::new(&plant, conf, names, vec![rec], &[4], options)
        .unwrap()
        .fit(&|_| {})
        .unwrap();
    println!(
        "cost {:.4e} -> {:.4e}; Kp_q4 {:.6} (truth {kp:.6}), Ks_q4 {:.6e} (bound {ks_upper:.6e}); {}",
        fit.cost_before, fit.cost_after, fit.fitted[0], fit.fitted[1], fit.starts[0].status
    );
    assert!(
        fit.cost_after < 0.1 * fit.cost_before,
        "{} -> {}",
        fit.cost_before,
        fit.cost_after
    );
    assert!(
        (fit.fitted[0] / kp - 1.0).abs() < 0.05,
        "Kp_q4 {}",
        fit.fitted[0]
    );
    assert!(
        (fit.fitted[1] / ks_upper - 1.0).abs() < 1e-12,
        "Ks_q4 {}",
        fit.fitted[1]
    );
}

/// The truth with joint 4's Stribeck velocity a tenth of Appendix D's (vs_q4 = 0.05 rad/s;
/// k3's vs_q2 is 0.019 rad/s: a dip seen only at the reversals), 20 s of Table 4.3's J4
/// chirp on c1 simulated from it into `dir`: the truth, c1 and the file's record.
fn slow_dip_c1(
    dir: &Path,
) -> (
    Plant,
    &'static generated::Configuration,
    lockstep::identify::output_error::Record,
) {
    let truth_file = truth(dir);
    let text = std::fs::read_to_string(&truth_file).unwrap();
    assert!(text.contains("vs_q4 = 0.19765"));
    std::fs::write(&truth_file, text.replace("vs_q4 = 0.19765", "vs_q4 = 0.05")).unwrap();
    let truth = Plant::load(&truth_file).unwrap();
    make_data(dir, &truth_file, "4.3", Some("J4"), "c1", "20");
    let (conf, rec) = c1_record(dir, &truth);
    (truth, conf, rec)
}

/// A collapsed Stribeck dip (Fs = Fc) leaves the cost flat in vs, so no gradient brings
/// the dip back, and once the other parameters have adapted to its absence the collapsed
/// point is a local minimum. With joint 4's Stribeck velocity at 0.05 rad/s, its gain
/// and friction fitted with the dip held collapsed (Fs_q4 = Fc_q4, vs_q4 on its upper bound),
/// then Fs_q4 and vs_q4 freed, the start alone ends at Fs_q4 = 1.024 Fc_q4, vs_q4 = 0.26 rad/s,
/// 4 % above the truth's cost. The Stribeck branch must win: at most 2 % above the
/// truth's cost, the dip at least half the truth's, vs_q4 within 10 %, the rest within 1 %
/// (and whatever the statistics call identifiable within 5 %).
#[test]
#[ignore = "slow end-to-end identification (minutes); cargo test --release -- --ignored"]
fn a_collapsed_stribeck_dip_is_re_seeded_and_recovered() {
    let d = tempfile::tempdir().unwrap();
    let (truth, conf, rec) = slow_dip_c1(d.path());
    let adapted: Vec<String> = [
        "Kp_q4",
        "sigma0_q4",
        "sigma1_q4",
        "sigma2_q4",
        "Fc_q4",
        "Ks_q4",
    ]
    .map(String::from)
    .to_vec();
    let names: Vec<String> = adapted
        .iter()
        .cloned()
        .chain(["Fs_q4".to_string(), "vs_q4".to_string()])
        .collect();
    let at_truth: Vec<f64> = names.iter().map(|n| truth.parameters[n]).collect();
    let mut plant = truth.clone();
    for (n, v) in names.iter().zip(&at_truth) {
        plant.bounds.insert(n.clone(), (v / 4.0, 4.0 * v));
    }
    // Appendix D's bounds on vs_q4.
    plant.bounds.insert("vs_q4".into(), (0.003953, 9.8825));
    plant
        .parameters
        .insert("Fs_q4".into(), truth.parameters["Fc_q4"]);
    plant.parameters.insert("vs_q4".into(), 9.8825);
    let options = OutputErrorOptions {
        h: 1.0 / 12000.0,
        horizons: Vec::new(),
        predictor: vec![3.0, 1.0],
        ..OutputErrorOptions::thesis()
    };
    let collapsed = Problem::new(
        &plant,
        conf,
        adapted.clone(),
        vec![rec.clone()],
        &[4],
        options.clone(),
    )
    .unwrap()
    .fit(&|_| {})
    .unwrap();
    println!(
        "collapsed: {:.5e} {:?}",
        collapsed.cost_after, collapsed.fitted
    );
    for (n, v) in adapted.iter().zip(&collapsed.fitted) {
        plant.parameters.insert(n.clone(), *v);
    }
    let problem = Problem::new(&plant, conf, names.clone(), vec![rec], &[4], options).unwrap();
    let c_truth = problem.cost(&at_truth);
    let fit = problem.fit(&|_| {}).unwrap();
    for s in &fit.starts {
        println!(
            "{:?}: {:.5e} -> {:.5e}: {}",
            s.warm_up, s.start_cost, s.cost, s.status
        );
    }
    println!(
        "cost at the truth {c_truth:.5e}, fitted {:.5e}: {:?} (truth {at_truth:?})",
        fit.cost_after, fit.fitted
    );
    let branch = fit
        .starts
        .iter()
        .find(|s| s.warm_up == WarmUp::StribeckBranch)
        .expect("no Stribeck branch");
    assert_eq!(fit.best_start, branch.start, "the branch did not win");
    assert!(
        fit.cost_after < 1.02 * c_truth,
        "{} vs {c_truth}",
        fit.cost_after
    );
    let dip = |fs: f64, fc: f64| fs / fc - 1.0;
    let (fitted_dip, true_dip) = (
        dip(fit.fitted[6], fit.fitted[4]),
        dip(at_truth[6], at_truth[4]),
    );
    assert!(
        fitted_dip > 0.5 * true_dip,
        "dip {fitted_dip} vs {true_dip}"
    );
    for (i, n) in names.iter().enumerate() {
        let e = fit.fitted[i] / at_truth[i] - 1.0;
        let limit = if i < adapted.len() {
            0.01
        } else if n == "vs_q4" {
            0.1
        } else {
            f64::INFINITY
        };
        let limit = if fit.statistics.identifiable[i] {
            limit.min(0.05)
        } else {
            limit
        };
        assert!(
            e.abs() < limit,
            "{n}: {} vs {} ({:+.1} %)",
            fit.fitted[i],
            at_truth[i],
            100.0 * e
        );
    }
}

/// A dip lost the other way: vs on its upper bound leaves g(v) ≈ Fs at every velocity the
/// files reach, so Fs carries the level the files saw (the truth's Fc) and Fc is barely
/// seen (the rerun's k3: vs_q2 = 9.48 rad/s on its bound, Fs_q2 = the truth's Fc_q2, Fc_q2 40 %
/// low). A re-seed that keeps Fc as the level puts the dip under the truth's Coulomb
/// friction. Joint 4 of c1 with the truth's vs_q4 at 0.05 rad/s, at Fc_q4 = 0.9 × the truth's
/// Fc_q4, Fs_q4 = the truth's Fc_q4, vs_q4 on its upper bound (Appendix D's): the seed must
/// take Fc_q4 = Fs_q4's level, vs_q4 at one of the grid's two points around the truth's
/// (0.028 or 0.074 rad/s), and cost at most half the best seed with Fc_q4 kept.
#[test]
fn a_stribeck_dip_lost_with_vs_on_its_upper_bound_is_re_seeded_at_the_level_seen() {
    let d = tempfile::tempdir().unwrap();
    let (truth, conf, rec) = slow_dip_c1(d.path());
    let names: Vec<String> = ["Fc_q4", "Fs_q4", "vs_q4"].map(String::from).to_vec();
    let fc_truth = truth.parameters["Fc_q4"];
    let (vs_lower, vs_upper) = (0.003953, 9.8825);
    let mut plant = truth.clone();
    for n in &names {
        let v = truth.parameters[n];
        plant.bounds.insert(n.clone(), (v / 4.0, 4.0 * v));
    }
    plant.bounds.insert("vs_q4".into(), (vs_lower, vs_upper));
    let lost = [0.9 * fc_truth, fc_truth, vs_upper];
    let options = OutputErrorOptions {
        h: 1.0 / 12000.0,
        ..OutputErrorOptions::thesis()
    };
    let problem = Problem::new(&plant, conf, names, vec![rec], &[4], options).unwrap();
    let (seed, note, _) = problem
        .stribeck_reseed(&problem.to_scaled(&lost))
        .expect("vs on its bound: a re-seed");
    let seed = problem.to_physical(&seed);
    let seed_cost = problem.cost(&seed);
    // The seeds the grid on Fc alone offers: Fc kept, Fs = Fc (1 + r).
    let fc_kept = (0..9)
        .flat_map(|g| {
            let vs = vs_lower * (vs_upper / vs_lower).powf(g as f64 / 8.0);
            [0.25, 0.5, 1.0].map(|r| problem.cost(&[lost[0], lost[0] * (1.0 + r), vs]))
        })
        .fold(f64::INFINITY, f64::min);
    println!("{note}: {seed:?}, cost {seed_cost:.5e}; best with Fc kept {fc_kept:.5e}");
    assert_eq!(seed[0], fc_truth, "Fc_q4 of the seed");
    assert!(seed[1] > 1.2 * seed[0], "Fs_q4 of the seed {}", seed[1]);
    assert!(
        (0.02..0.08).contains(&seed[2]),
        "vs_q4 of the seed {}",
        seed[2]
    );
    assert!(seed_cost < 0.5 * fc_kept, "{seed_cost} vs {fc_kept}");
}

#[test]
fn the_equation_error_holds_at_the_truth_and_keeps_the_gain_scale_symmetry() {
    use lockstep::identify::equation_error::{EquationError, DEFAULT_CUTOFF};
    let d = tempfile::tempdir().unwrap();
    let (p, at_truth, off) = problem_at_truth(d.path(), "J2", 3);
    assert_eq!(p.configuration().name, "c4");
    let truth = p.plant_at(&at_truth);
    let r = &p.records[0];
    let ee = EquationError::new(
        &truth,
        p.configuration(),
        &p.records,
        Cutoff::Fixed(DEFAULT_CUTOFF),
    )
    .unwrap();
    assert_eq!(ee.len(), r.t.len() - 20);
    let rms = |x: &[f64]| (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt();
    let at = ee.residuals(&truth).unwrap();
    let away = ee.residuals(&p.plant_at(&off)).unwrap();
    println!(
        "equation error RMS (× command RMS): truth {:.4}, 25 % off {:.4}",
        rms(&at),
        rms(&away)
    );
    assert!(rms(&at) < 0.05, "{}", rms(&at));
    assert!(
        rms(&away) > 4.0 * rms(&at),
        "{} vs {}",
        rms(&away),
        rms(&at)
    );
    // The scale family.
    let alpha = 1.37;
    let mut scaled = truth.clone();
    let mut moved = 0;
    for (n, v) in scaled.parameters.iter_mut() {
        let force = [
            "Kp_q2",
            "sigma0_q2",
            "sigma1_q2",
            "sigma2_q2",
            "Fc_q2",
            "Fs_q2",
            "Ks_q2",
        ];
        let inertial = truth.model.inertial_symbols.contains(&n.as_str())
            && (n.starts_with('m') || n.starts_with('I'));
        if inertial || force.contains(&n.as_str()) {
            *v *= alpha;
            moved += 1;
        }
    }
    assert!(moved > 10, "{moved}");
    let along = ee.residuals(&scaled).unwrap();
    let worst = at
        .iter()
        .zip(&along)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(worst < 1e-9 * rms(&at).max(1e-12) * 1e3, "{worst}");
    // The estimate alone, from the ±25 % start: the optimiser brings the equation error
    // from 30 times the truth's level to within 1.5 times it (measured: 162 → 5.96, the
    // truth 4.84). The torque balance's own error (filtered, differentiated noise) is what
    // limits it, so the output error improves far less (2.8e4 → 1.8e4; the truth 0.30):
    // a warm start, not a fit.
    let start = Problem::new(
        &p.plant_at(&off),
        p.configuration(),
        p.names.clone(),
        p.records.clone(),
        &[2],
        p.options().clone(),
    )
    .unwrap();
    let (est, status) = start
        .fit_equation_error(Cutoff::Fixed(DEFAULT_CUTOFF))
        .unwrap();
    let stage = start
        .equation_error_stage(Cutoff::Fixed(DEFAULT_CUTOFF))
        .unwrap();
    let (e_truth, e_off, e_est) = (stage.cost(&at_truth), stage.cost(&off), stage.cost(&est));
    let (o_off, o_est) = (p.cost(&off), p.cost(&est));
    println!("{status}: equation error {e_off:.4e} → {e_est:.4e} (truth {e_truth:.4e}); output error {o_off:.4e} → {o_est:.4e}");
    assert!(e_off > 20.0 * e_truth);
    assert!(e_est < 1.5 * e_truth);
    assert!(o_est < o_off);
}

/// The prediction-error homotopy on c4 (joint 2: LuGre, spring, friction position bias) from
/// the ±25 % start: the equation error's estimate leaves the whole files far from the noise
/// floor (the output error from there stops in a local minimum: 2.3e3 on the Appendix D
/// guess), and the predictor's stages at ω = 3 and 1 rad/s — the simulation pulled toward
/// the measured positions, a low-passed equation error that is smooth in the parameters —
/// bring the fit of the whole files to the noise floor: position RMS ≤ 1.5 σ. Measured (RK4
/// at 1/2000 s, 89 s): output error 3.74e3 at the equation error's estimate; ω = 3:
/// 3.10 → 0.287 (output error 0.583); ω = 1: → 0.292 (0.336); whole files 0.295.
#[test]
#[ignore = "slow end-to-end identification (minutes); cargo test --release -- --ignored"]
fn the_prediction_error_homotopy_takes_c4_from_the_equation_error_to_the_noise_floor() {
    use lockstep::identify::equation_error::{Cutoff, DEFAULT_CUTOFF};
    let d = tempfile::tempdir().unwrap();
    let (p, _, off) = problem_at_truth(d.path(), "J2", 3);
    let options = OutputErrorOptions {
        h: 1.0 / 2000.0,
        horizons: vec![1.0],
        ..p.options().clone()
    };
    let on = |plant: &Plant| rebuilt(&p, plant, &[2], options.clone());
    let start = on(&p.plant_at(&off));
    let (est, _) = start
        .fit_equation_error(Cutoff::Fixed(DEFAULT_CUTOFF))
        .unwrap();
    let at_equation_error = start.cost(&est);
    let mut plant = start.plant_at(&est);
    let mut trail =
        format!("output error at the equation error's estimate {at_equation_error:.4e}");
    for omega in [3.0, 1.0, 0.0] {
        let q = on(&plant).predictor(omega);
        let fit = q.fit(&|_| {}).unwrap();
        plant = q.plant_at(&fit.fitted);
        trail += &format!(
            "; ω = {omega}: {:.4e} → {:.4e}, output error {:.4e}",
            fit.cost_before,
            fit.cost_after,
            start.cost(&fit.fitted)
        );
    }
    println!("{trail}");
    let fitted: Vec<f64> = p.names.iter().map(|n| plant.parameters[n]).collect();
    let joint = &start.joint_fits(&start.trajectories(&fitted).unwrap())[0];
    assert!(
        joint.rms <= 1.5 * 2e-4,
        "position RMS {:.3e} rad; {trail}",
        joint.rms
    );
    assert!(at_equation_error > 100.0 * start.cost(&fitted), "{trail}");
}

/// The coarse predictor step is used only where it is checked to predict what the user's
/// step does ([`Problem::predictor_step_disagreement`]): on k3 of the coupled method (Table
/// 4.7, 40 s, at the truth, against RK4 at 1/12000 s) the difference of the predicted
/// positions, per joint in units of its noise σ̂ (the largest over the joints), grows with
/// the step and, at a coarse step, as the output injection's pull weakens. Measured (at
/// ω = 100, 30, 10, 3, 1 rad/s): ETDRK4 at 1/2000 s 0.003, 0.006, 0.044, 0.035, 0.090 (every
/// stage may use it); at 1/500 s 0.15, 0.79, 1.5, 2.8 and 84 — only the 100 rad/s stage
/// keeps it. Without a predictor step, or at ω = 0, there is nothing to check.
#[test]
fn the_coarse_predictor_step_is_checked_against_the_users_step_stage_by_stage() {
    use lockstep::identify::output_error::COARSE_PREDICTOR_AGREEMENT;
    use lockstep::simulation::Integrator;
    let d = tempfile::tempdir().unwrap();
    let (p, at_truth, _) = problem_of_step(d.path(), "coupled", "4.7", None, |steps| {
        steps.iter().position(|s| s.config == "k3").unwrap()
    });
    assert_eq!(
        p.predictor_step_disagreement(100.0, &at_truth).unwrap(),
        None
    );
    let omegas = [100.0, 30.0, 10.0, 3.0, 1.0];
    let ratios = |h: f64| -> Vec<f64> {
        let checked = rebuilt(
            &p,
            &p.plant_at(&at_truth),
            &[2],
            OutputErrorOptions {
                predictor_step: Some((h, Integrator::Etdrk4)),
                ..p.options().clone()
            },
        );
        assert_eq!(
            checked.predictor_step_disagreement(0.0, &at_truth).unwrap(),
            None
        );
        omegas
            .iter()
            .map(|&w| {
                checked
                    .predictor_step_disagreement(w, &at_truth)
                    .unwrap()
                    .unwrap()
            })
            .collect()
    };
    let (fine, middle, coarse) = (
        ratios(1.0 / 2000.0),
        ratios(1.0 / 1000.0),
        ratios(1.0 / 500.0),
    );
    let trail = format!(
        "largest RMS difference / σ̂ at ω = {omegas:?} rad/s: 1/2000 s {fine:.4?}, \
         1/1000 s {middle:.4?}, 1/500 s {coarse:.4?}"
    );
    println!("{trail}");
    assert!(
        fine.iter()
            .all(|&r| r > 0.0 && r < 0.5 * COARSE_PREDICTOR_AGREEMENT),
        "{trail}"
    );
    assert!(coarse[0] <= COARSE_PREDICTOR_AGREEMENT, "{trail}");
    assert!(
        coarse[1..].iter().all(|&r| r > COARSE_PREDICTOR_AGREEMENT),
        "{trail}"
    );
    assert!(coarse[4] > 100.0 * COARSE_PREDICTOR_AGREEMENT, "{trail}");
    assert!(coarse.windows(2).all(|w| w[0] < w[1]), "{trail}");
    assert!(fine.iter().zip(&coarse).all(|(f, c)| f < c), "{trail}");
}

/// `--carried-prior`: a carried symbol with a standard error σ recorded in the plant is held
/// by a Gaussian prior whose term is what that much data would add, s̄² (Δp / σ)² (s̄ the
/// noise's RMS residual), and no other parameter gets one; without the option, none. The
/// equation-error warm start holds every carried symbol, with the option or without.
#[test]
fn the_carried_prior_weighs_a_carried_symbol_by_its_earlier_standard_error() {
    let d = tempfile::tempdir().unwrap();
    let (p, at_truth, _) = problem_at_truth(d.path(), "J4", 0);
    let mut plant = p.plant_at(&at_truth);
    let k = p
        .names
        .iter()
        .position(|n| plant.model.inertial_symbols.contains(&n.as_str()))
        .unwrap();
    let name = p.names[k].clone();
    let sigma = 0.01 * (p.upper[k] - p.lower[k]);
    plant.undetermined = vec![name.clone()];
    plant.standard_errors.insert(name.clone(), sigma);
    let on = |carried_prior: bool| {
        let options = OutputErrorOptions {
            carried_prior,
            ..p.options().clone()
        };
        rebuilt(&p, &plant, &[4], options)
    };
    let (with, without) = (on(true), on(false));
    let s_bar = with.noise_residual_rms();
    // One free joint, every weighted sample weighted 1: s̄ = λ σ̂.
    assert_eq!(with.lambda.len(), 1);
    let expected = with.lambda[0] * with.noise[0];
    assert!(
        (s_bar / expected - 1.0).abs() < 1e-12,
        "s̄ = {s_bar}, λ σ̂ = {expected}"
    );
    let moved = |i: usize, by: f64| {
        let mut x = at_truth.clone();
        x[i] += by;
        with.to_scaled(&x)
    };
    let term = with.prior_penalty(&moved(k, 2.0 * sigma));
    assert!(
        (term / (4.0 * s_bar * s_bar) - 1.0).abs() < 1e-9,
        "{name}: {term}"
    );
    assert_eq!(without.prior_penalty(&moved(k, 2.0 * sigma)), 0.0);
    let other = (k + 1) % p.names.len();
    let span = p.upper[other] - p.lower[other];
    assert_eq!(with.prior_penalty(&moved(other, 0.01 * span)), 0.0);
    // The equation-error warm start (no prior: torque residuals) holds the carried symbol
    // at its value instead of letting it drift, with the prior or without; only there.
    let ee = |p: &Problem| p.equation_error_stage(Cutoff::Fixed(0.5)).unwrap().frozen();
    assert_eq!(ee(&with), std::slice::from_ref(&name));
    assert_eq!(ee(&without), [name]);
    assert!(with.frozen().is_empty() && without.frozen().is_empty());
    // A symbol no earlier step left undetermined moves there.
    plant.undetermined.clear();
    assert!(ee(&rebuilt(&p, &plant, &[4], p.options().clone())).is_empty());
}

/// A held value's recorded standard error enters the fitted values' standard errors by
/// the model's own exact symmetry: on c1 at the truth with the Coulomb level Fc_q4 held with
/// σ = 1 % of its value, a relative change ε of Fc_q4 is absorbed exactly by scaling the
/// plant gain and every other force and inertia of joint 4 by 1 + ε (positions
/// unchanged), so the held share √(σ_p² − σ_p,given held²) of each determined member p of
/// that family is 1 % of |p|; the members outside it (vs_q4, qeq_q4) get none. With Fc_q4
/// held the family is no longer an exact symmetry, so its members are determined given
/// Fc_q4.
#[test]
fn a_held_values_standard_error_is_propagated_along_the_plant_gain_scale() {
    let d = tempfile::tempdir().unwrap();
    let (p, at_truth, _) = problem_at_truth(d.path(), "J4", 0);
    let mut plant = p.plant_at(&at_truth);
    let fc = plant.parameters["Fc_q4"];
    let relative = 0.01;
    plant.standard_errors.insert("Fc_q4".into(), relative * fc);
    let names: Vec<String> = p.names.iter().filter(|n| *n != "Fc_q4").cloned().collect();
    let values: Vec<f64> = names.iter().map(|n| plant.parameters[n]).collect();
    let statistics_on = |plant: &Plant| {
        Problem::new(
            plant,
            p.configuration(),
            names.clone(),
            p.records.clone(),
            &[4],
            p.options().clone(),
        )
        .unwrap()
        .statistics(&values)
        .unwrap()
    };
    let stats = statistics_on(&plant);
    assert_eq!(stats.held, [("Fc_q4".to_string(), relative * fc)]);
    let share = |i: usize| {
        let (se, given) = (stats.std_err[i], stats.std_err_given_held[i]);
        (se * se - given * given).max(0.0).sqrt()
    };
    let mut checked = Vec::new();
    for n in ["Kp_q4", "sigma0_q4", "sigma2_q4", "Fs_q4", "Ks_q4"] {
        let i = names.iter().position(|x| x == n).unwrap();
        assert!(
            stats.std_err_given_held[i].is_finite(),
            "{n} undetermined given Fc_q4"
        );
        let expected = relative * values[i].abs();
        println!(
            "{n}: σ given held {:.3e}, held share {:.4e}, expected {expected:.4e}",
            stats.std_err_given_held[i],
            share(i)
        );
        assert!(
            (share(i) / expected - 1.0).abs() < 0.01,
            "{n}: held share {:.4e} vs {expected:.4e}",
            share(i)
        );
        checked.push(n);
    }
    for n in ["vs_q4", "qeq_q4"] {
        let i = names.iter().position(|x| x == n).unwrap();
        println!(
            "{n}: σ {:.4e}, given held {:.4e}",
            stats.std_err[i], stats.std_err_given_held[i]
        );
        assert!(
            share(i) < 0.05 * stats.std_err_given_held[i],
            "{n}: held share {:.3e}, σ given held {:.3e}",
            share(i),
            stats.std_err_given_held[i]
        );
    }
    // Without the record, Fc_q4 is held as exact and the standard errors are those given it.
    plant.standard_errors.clear();
    let exact = statistics_on(&plant);
    assert!(exact.held.is_empty() && exact.held_exact.contains(&"Fc_q4".to_string()));
    assert_eq!(exact.std_err, exact.std_err_given_held);
}

/// c6 (joint 0 alone) sees the rigid body through one base parameter, its inertia
/// D_00 at the files' locked pose: the spanning symbol I1_33 plus the held ties' terms.
/// With two held ties short of the truth (I2_33 × 0.75, m1 × 0.8), D_00 needs I1_33
/// past its upper bound (the truth + 30 %): the first fit ends there, above the noise
/// floor. The reach across held ties fits again with I1_33's bound moved out by what the
/// held ties can carry, spreads D_00 back over every symbol's own bounds and fits on
/// them: the noise floor, D_00 within 0.2 % of the truth's, every value within its own
/// bounds, and the held ties that moved in the plant written. With `--tie-reach off` the
/// step ends above the floor (measured: q0 at 1.92 σ̂).
#[test]
fn a_spanning_symbol_on_its_bound_reaches_its_base_parameter_through_the_held_ties() {
    use lockstep::plant::ConsistencyPolicy;
    let d = tempfile::tempdir().unwrap();
    let truth_file = truth(d.path());
    let truth = Plant::load(&truth_file).unwrap();
    make_data(d.path(), &truth_file, "4.3", Some("J0"), "c6", "12");
    let start = truth_within_bounds(d.path(), &truth_file, &[("I2_33", 0.75), ("m1", 0.8)]);
    let mut plant = Plant::load(&start).unwrap();
    // The plant gain known (as the isolated method needs for c6): held at the truth's.
    let kp = truth.parameters["Kp_q0"];
    plant.bounds.insert("Kp_q0".into(), (kp, kp));
    plant.save(&start).unwrap();
    let args = ["--step", "1/2000", "--horizons", "1"];
    // Without the reach (`--tie-reach off`) the step ends above the floor.
    let off = identify_isolated(
        d.path(),
        &start,
        "c6",
        &[&args[..], &["--tie-reach", "off"]].concat(),
    );
    assert!(off["steps"][0]["tie_reach"].is_null());
    let above: Vec<String> = column(&off["steps"][0]["fit"], &["statistics", "above_floor"]);
    assert!(
        above.len() == 1 && above[0].starts_with("q0 RMS"),
        "{above:?}"
    );
    let report = identify_isolated(d.path(), &start, "c6", &args);
    let step = &report["steps"][0];
    let reach = &step["tie_reach"];
    println!("{reach:#}");
    // The premise: the first fit ended on I1_33's upper bound above the floor.
    let representatives = reach["representatives"].as_array().unwrap();
    assert_eq!(representatives.len(), 1, "{representatives:?}");
    assert_eq!(representatives[0][0], "I1_33");
    let upper = plant.bounds["I1_33"].1;
    assert_eq!(representatives[0][1].as_f64().unwrap(), upper);
    let cost_before = reach["cost_before"].as_f64().unwrap();
    let cost_after = reach["cost_after"].as_f64().unwrap();
    assert!(reach["kept"].as_bool().unwrap());
    assert!(
        cost_after < 0.5 * cost_before,
        "{cost_before} → {cost_after}"
    );
    let fit = &step["fit"];
    for j in fit["statistics"]["joints"].as_array().unwrap() {
        let (rms, noise) = (j["rms"].as_f64().unwrap(), j["noise"].as_f64().unwrap());
        assert!(
            rms <= 1.1 * noise,
            "joint {} at {:.2} σ̂",
            j["joint"],
            rms / noise
        );
    }
    let out = d.path().join("out");
    let written = Plant::load(&out.join("plant.toml")).unwrap();
    let moved: Vec<(String, f64, f64)> = serde_json::from_value(reach["moved"].clone()).unwrap();
    assert!(!moved.is_empty());
    for (n, before, after) in &moved {
        assert_eq!(plant.parameters[n], *before, "{n}");
        assert_eq!(written.parameters[n], *after, "{n}");
    }
    for (n, &(lo, hi)) in &plant.bounds {
        let v = written.parameters[n];
        assert!(lo <= v && v <= hi, "{n} = {v} outside [{lo}, {hi}]");
    }
    // D_00 at the files' locked pose: the truth's.
    let conf = truth.model.configuration("c6").unwrap();
    let rec = read_record(&d.path().join("data/c6_run.csv"), truth.model, conf, 0.01).unwrap();
    let d00 = |p: &Plant| {
        p.simulator("c6", &rec.q_all, ConsistencyPolicy::Warn)
            .unwrap()
            .model
            .inertia_matrix(&[rec.q_all[0]])[(0, 0)]
    };
    let (fitted, true_d00, held_d00) = (d00(&written), d00(&truth), d00(&plant));
    println!("D_00: start {held_d00:.6e}, fitted {fitted:.6e}, truth {true_d00:.6e}");
    assert!(
        (held_d00 / true_d00 - 1.0).abs() > 0.02,
        "premise: the start's D_00 is short"
    );
    assert!(
        (fitted / true_d00 - 1.0).abs() < 2e-3,
        "D_00 {fitted} against {true_d00}"
    );
}

/// Isolated step c5 (joint 1 alone, the other joints locked) sees 42 rigid-body symbols
/// only through 3 base parameters where its file holds the locked joints (the inertia
/// about joint 1's axis and two gravity terms). With `--rigid-body spanning` it fits the 3
/// symbols that span them within their bounds and holds the rest, which the report lists
/// and the written plant keeps undetermined for later steps. From the ±25 % start with the
/// equation error and the predictor's homotopy (`--horizons none`: the start itself is
/// not fitted through the horizons), 20 s of Table 4.3's J1 chirp reach the noise
/// floor (measured: 4.79e5 → 0.147, RMS 1.98e-4 rad) and every parameter called
/// identifiable is within 5 % of the truth (on these 20 s the report calls none
/// identifiable, so that check is empty here). Not robust yet: on 40 s from the same
/// kind of start the fit ended at 2.96 σ̂; from c4's fitted plant on 40 s it reached 0.98 σ̂,
/// where all 52 parameters with their exact ties stalled at 3.02 σ̂.
#[test]
#[ignore = "slow end-to-end identification (minutes); cargo test --release -- --ignored"]
fn c5_fits_the_symbols_that_span_its_base_parameters_and_reaches_the_noise_floor() {
    let d = tempfile::tempdir().unwrap();
    let truth_file = truth(d.path());
    make_data(d.path(), &truth_file, "4.3", Some("J1"), "c5", "20");
    let truth = Plant::load(&truth_file).unwrap();
    let steps = plan(&truth, "isolated").unwrap();
    let c5 = steps.iter().find(|s| s.config == "c5").unwrap();
    let rigid: Vec<&String> = c5
        .fitted
        .iter()
        .filter(|n| truth.model.inertial_symbols.contains(&n.as_str()))
        .collect();
    assert!(rigid.len() > 30, "c5 identifies {rigid:?}");
    let start = d.path().join("start.toml");
    perturbed_start(&truth_file, &c5.fitted, &start);
    let report = identify_isolated(
        d.path(),
        &start,
        "c5",
        &[
            "--step",
            "1/2000",
            "--equation-error",
            "on",
            "--predictor",
            "3,1",
            "--horizons",
            "none",
            "--rigid-body",
            "spanning",
        ],
    );
    let out = d.path().join("out");
    let step = &report["steps"][0];
    let held: Vec<String> = serde_json::from_value(step["step"]["tied_held"].clone()).unwrap();
    let names: Vec<String> = column(&step["fit"], &["names"]);
    let fitted_rigid: Vec<&String> = names
        .iter()
        .filter(|n| truth.model.inertial_symbols.contains(&n.as_str()))
        .collect();
    assert_eq!(fitted_rigid.len(), 3, "fitted {names:?}");
    assert_eq!(held.len() + 3, rigid.len(), "held {held:?}");
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(md.contains("Held along exact ties"), "{md}");
    let written = Plant::load(&out.join("plant.toml")).unwrap();
    for n in &held {
        assert!(
            written.undetermined.contains(n),
            "{n} not left undetermined"
        );
    }
    let fit = &step["fit"];
    let starts: Vec<serde_json::Value> = column(fit, &["starts"]);
    assert_eq!(starts.len(), 1, "{starts:?}");
    assert_eq!(starts[0]["warm_up"], "equation_error", "{starts:?}");
    let joints: Vec<serde_json::Value> = column(fit, &["statistics", "joints"]);
    let rms = joints[0]["rms"].as_f64().unwrap();
    let summary = format!(
        "cost {} → {}, RMS {rms:.3e} rad, {} s",
        fit["cost_before"], fit["cost_after"], fit["wall_s"]
    );
    println!("{summary}");
    assert!(rms <= 1.5 * 2e-4, "{summary}");
    let values: Vec<f64> = column(fit, &["fitted"]);
    let identifiable: Vec<bool> = column(fit, &["statistics", "identifiable"]);
    for ((n, v), ok) in names.iter().zip(&values).zip(&identifiable) {
        if *ok {
            let t = truth.parameters[n];
            assert!(
                (v - t).abs() <= 0.05 * t.abs(),
                "{n}: fitted {v}, truth {t}; {summary}"
            );
        }
    }
}

/// The step report names links a fit leaves physically impossible, and which
/// configurations contain them: the isolated c6 fit drove I1_33 to −7.97 × the truth (the
/// joint-0 gain scale), the data of c6 fitted, and the 6-joint plant no longer simulated.
#[test]
fn a_step_that_leaves_a_link_impossible_says_which_and_where_it_matters() {
    use lockstep::identify::sequence::impossible_links;
    let dir = tempfile::tempdir().unwrap();
    let mut p = Plant::load(&truth(dir.path())).unwrap();
    let fitted = |names: &[&str]| names.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    // At the truth (I4_33 made positive) no link is impossible.
    assert!(impossible_links(&p, &fitted(&["I1_33", "Kp_q0"]))
        .unwrap()
        .is_empty());
    p.parameters.insert("I1_33".into(), -7.97 * 0.00144);
    let lines = impossible_links(&p, &fitted(&["I1_33", "Kp_q0", "sigma0_q0"])).unwrap();
    assert_eq!(lines.len(), 1, "{lines:?}");
    let l = &lines[0];
    eprintln!("{l}");
    for needle in ["link 'L1'", "fitted here: I1_33;", "c6", "c7", "k5"] {
        assert!(l.contains(needle), "'{needle}' not in: {l}");
    }
    // Configurations without joint 0 free do not contain link 1's inertia about its axis.
    assert!(!l.contains("c1,") && !l.contains("k1"), "{l}");
    // A step that did not fit the link does not report it.
    assert!(impossible_links(&p, &fitted(&["Kp_q0", "m2"]))
        .unwrap()
        .is_empty());
}

/// The premise of `--initial-positions estimate`: the first measured sample carries the
/// sensor noise, and the coupled k4 trajectory (Table 4.7, 40 s; the wrist whips round at
/// tens of rad/s) carries a start that far off to later samples, so even the *true*
/// parameters are above 1.3 σ̂ from it over the whole file — but not over the samples
/// cost (4.3) weighs, after its skipped transient, where the floor is judged
/// (`JointFit::rms_fitted`: below 1.15 σ̂ there). With each file's initial positions
/// estimated (`Problem::estimate_initial_positions`, Gauss–Newton on q(0)) the truth is at
/// the noise on every joint, and the estimate is nearer the true start (the simulation
/// starts every free joint at 0) than the first sample on the joints whose motion depends
/// on it.
#[test]
fn the_true_parameters_reach_the_noise_floor_of_k4_only_from_estimated_initial_positions() {
    let d = tempfile::tempdir().unwrap();
    let (p, at_truth, _) = problem_of_step(d.path(), "coupled", "4.7", None, |steps| {
        steps.iter().position(|s| s.config == "k4").unwrap()
    });
    let plant = p.plant_at(&at_truth);
    let rms_over_noise = |q: &Problem| -> Vec<f64> {
        q.joint_fits(&q.trajectories(&at_truth).unwrap())
            .iter()
            .map(|j| j.rms / j.noise)
            .collect()
    };
    let measured = rms_over_noise(&p);
    // Over the samples the cost (4.3) weighs, after its skipped transient, the first
    // samples' start is no obstacle: the floor is judged there.
    let fitted_samples: Vec<f64> = p
        .joint_fits(&p.trajectories(&at_truth).unwrap())
        .iter()
        .map(|j| j.rms_fitted / j.noise)
        .collect();
    let mut estimated = p.with_initial_positions_of(&plant).unwrap();
    // A second Gauss–Newton step, as the fit's second round takes.
    estimated = estimated.with_initial_positions_of(&plant).unwrap();
    let from_estimate = rms_over_noise(&estimated);
    eprintln!(
        "RMS / σ̂ from the first sample {measured:.3?}, from the estimate {from_estimate:.3?}"
    );
    let worst = |v: &[f64]| v.iter().copied().fold(0.0, f64::max);
    assert!(worst(&measured) > 1.3, "{measured:?}");
    eprintln!("RMS / σ̂ over the fitted samples from the first sample {fitted_samples:.3?}");
    assert!(worst(&fitted_samples) < 1.15, "{fitted_samples:?}");
    assert!(worst(&from_estimate) < 1.1, "{from_estimate:?}");
    let free = &p.configuration().free;
    let error =
        |q: &Problem| -> Vec<f64> { free.iter().map(|&j| q.records[0].q_all[j].abs()).collect() };
    let (first, est) = (error(&p), error(&estimated));
    eprintln!("|q(0) − 0|: first sample {first:?}, estimate {est:?}");
    let rms = |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt();
    assert!(rms(&est) < 0.5 * rms(&first), "{est:?} against {first:?}");
}

/// `--initial-positions estimate` in a fit: the whole files' stage runs on estimated
/// initial positions, re-estimated until they settle, and the result's cost, RMS figures
/// and report are on those starts. On k4 from the truth (two of its parameters fitted, one
/// iteration, the whole files only) the result's cost is below the same parameters' from
/// the first samples, the worst joint goes from above 1.3 σ̂ to below 1.1 σ̂, and every
/// joint's estimate − first sample is listed. (On k1 the
/// estimate is not taken: it does not lower the cost there, which skips the first 10 s.)
#[test]
#[ignore = "slow end-to-end identification (minutes); cargo test --release -- --ignored"]
fn the_fit_estimates_initial_positions_and_reports_them() {
    let d = tempfile::tempdir().unwrap();
    let (p, at_truth, _) = problem_of_step(d.path(), "coupled", "4.7", None, |steps| {
        steps.iter().position(|s| s.config == "k4").unwrap()
    });
    let plant = p.plant_at(&at_truth);
    let options = |estimate_initial_positions| OutputErrorOptions {
        horizons: vec![1.0],
        max_iter: 1,
        estimate_initial_positions,
        ..p.options().clone()
    };
    let problem = |estimate| {
        let names = vec!["Kp_q1".to_string(), "Fc_q1".to_string()];
        Problem::new(
            &plant,
            p.configuration(),
            names,
            p.records.clone(),
            &[1],
            options(estimate),
        )
        .unwrap()
    };
    let with = problem(true).fit(&|_| {}).unwrap();
    let offsets = with.initial_positions.as_ref().unwrap();
    eprintln!(
        "estimate − first sample: {offsets:?}; {}",
        with.starts[0].status
    );
    assert_eq!((offsets.len(), offsets[0].len()), (1, 5));
    assert!(offsets[0].iter().all(|d| d.abs() < 1e-3), "{offsets:?}");
    assert!(offsets[0].iter().any(|d| d.abs() > 5e-5), "{offsets:?}");
    let first = problem(false);
    let from_first_samples = first.cost(&with.fitted);
    assert!(
        with.cost_after < from_first_samples,
        "{} against {from_first_samples}",
        with.cost_after
    );
    // The cost is joint 1's (λ = 50); the starts matter on the wrist.
    let worst = |joints: &[lockstep::identify::output_error::JointFit]| {
        joints.iter().map(|j| j.rms / j.noise).fold(0.0, f64::max)
    };
    let before = worst(&first.joint_fits(&first.trajectories(&with.fitted).unwrap()));
    let after = worst(&with.statistics.joints);
    assert!(
        before > 1.3 && after < 1.1,
        "RMS / σ̂ {before} from the first samples, {after} estimated"
    );
    assert!(
        with.starts[0].status.contains("initial positions settled"),
        "{}",
        with.starts[0].status
    );
    assert!(problem(false)
        .fit(&|_| {})
        .unwrap()
        .initial_positions
        .is_none());
}

/// The truth's values with the initial plant's bounds (Appendix D's guesses, widened to
/// hold the truth as the benchmark does), `moved` parameters scaled by their factors;
/// written to `dir/start.toml`.
fn truth_within_bounds(dir: &Path, truth: &Path, moved: &[(&str, f64)]) -> PathBuf {
    let mut plant = Plant::load(truth).unwrap();
    let initial = Plant::load(&plants().join("freedom6s_appendix_d_initial.toml")).unwrap();
    for (n, &(lo, hi)) in &initial.bounds {
        let v = plant.parameters.get(n).copied().unwrap_or(0.5 * (lo + hi));
        let widen = 0.3 * v.abs();
        plant
            .bounds
            .insert(n.clone(), (lo.min(v - widen), hi.max(v + widen)));
    }
    for (n, f) in moved {
        *plant.parameters.get_mut(*n).unwrap() *= f;
    }
    let out = dir.join("start.toml");
    plant.save(&out).unwrap();
    out
}

/// The joint fit (`--joint-fit`, [`JointProblem`]) refits values of several steps on all
/// their files at once. Here joint 4's Coulomb level, which k1 identifies, is held 2 %
/// off while k2 fits joint 3's (the sequence's situation when an earlier step got a value
/// wrong): k2's fit cannot make up for it and ends above the noise floor on joint 4. The
/// joint fit of the three on k1's and k2's files (30 s of Table 4.7 each) reaches the floor
/// on every joint of both, recovers every value within 1 % and each within 4 of its
/// standard errors, and a parameter simulates only the configurations it enters (joint 3's
/// friction not k1, where joint 3 is locked).
#[test]
#[ignore = "slow end-to-end identification (minutes); cargo test --release -- --ignored"]
fn the_joint_fit_recovers_a_value_an_earlier_step_held_wrong() {
    use lockstep::identify::identifiability::occurrence;
    use lockstep::identify::joint::JointProblem;
    let d = tempfile::tempdir().unwrap();
    let truth_file = truth(d.path());
    let truth = Plant::load(&truth_file).unwrap();
    for k in ["k1", "k2"] {
        make_data(d.path(), &truth_file, "4.7", None, k, "30");
    }
    let names: Vec<String> = ["Fc_q4", "Fc_q3", "sigma2_q3"].map(String::from).to_vec();
    let start_file = truth_within_bounds(d.path(), &truth_file, &[("Fc_q4", 1.02)]);
    let start = Plant::load(&start_file).unwrap();
    let options = OutputErrorOptions {
        h: 1.0 / 12000.0,
        horizons: vec![1.0],
        estimate_initial_positions: true,
        ..OutputErrorOptions::thesis()
    };
    let files = |k: &str| {
        let conf = truth.model.configuration(k).unwrap();
        let file = d.path().join(format!("data/{k}_run.csv"));
        (
            conf,
            vec![read_record(&file, truth.model, conf, 0.01).unwrap()],
        )
    };
    let worst = |joints: &[lockstep::identify::output_error::JointFit]| {
        joints.iter().map(|j| j.rms / j.noise).fold(0.0, f64::max)
    };
    // k2's step with Fc_q4 held wrong.
    let (k2, k2_records) = files("k2");
    let step = Problem::new(
        &start,
        k2,
        names[1..].to_vec(),
        k2_records,
        &[3],
        options.clone(),
    )
    .unwrap()
    .fit(&|_| {})
    .unwrap();
    eprintln!(
        "k2 with Fc_q4 held 2 % off: {:?}, worst RMS {:.2} σ̂",
        step.fitted,
        worst(&step.statistics.joints)
    );
    assert!(worst(&step.statistics.joints) > 1.5);
    let joint = JointProblem::new(
        &start,
        names.clone(),
        Vec::new(),
        vec![files("k1"), files("k2")],
        &options,
        &occurrence(truth.model),
    )
    .unwrap();
    assert_eq!(joint.entering("k1"), ["Fc_q4"]);
    assert_eq!(joint.entering("k2"), names);
    let fit = joint.fit(&|_| {}).unwrap();
    let stats = &fit.statistics;
    eprintln!(
        "joint: cost {:.4e} → {:.4e}; {}",
        fit.cost_before, fit.cost_after, fit.starts[0].status
    );
    let labels: Vec<&str> = stats.joints.iter().map(|j| j.joint.as_str()).collect();
    assert_eq!(labels, ["k1 q4", "k1 q5", "k2 q3", "k2 q4", "k2 q5"]);
    assert!(stats.above_floor.is_empty(), "{:?}", stats.above_floor);
    for (i, n) in names.iter().enumerate() {
        let (v, t, se) = (fit.fitted[i], truth.parameters[n], stats.std_err[i]);
        eprintln!("{n}: {v:.6e} (truth {t:.6e}) ± {se:.2e}");
        assert!((v / t - 1.0).abs() < 0.01, "{n} = {v}, truth {t}");
        assert!((v - t).abs() < 4.0 * se, "{n} = {v} ± {se}, truth {t}");
    }
    eprintln!("correlated: {:?}", stats.correlated);
    assert!(stats.identifiable[0], "{:?}", stats.correlated);
}

/// The joint refit after a step ([`lockstep::identify::sequence::joint_refit`]): k1 has
/// moved joint 4's Coulomb level, which c1 fitted too, 2 % off the value c1's files want, so
/// c1's files (10 s of Table 4.3's J4 chirp) end above the floor and c1 has nothing of its
/// own to refit. c1's and k1's files (10 s of Table 4.7) fitted at once must bring both
/// back to the floor and Fc_q4 within 0.3 % of the truth; a value that the files of a step
/// outside the group see (Fc_q5: c2's J5 chirp) stays where it is; each step's information
/// is formed again where the values now are.
#[test]
fn the_joint_refit_brings_an_earlier_steps_files_back_with_the_later_steps() {
    use lockstep::identify::identifiability::occurrence;
    use lockstep::identify::sequence::{final_check, joint_refit, Step, StepReport};
    let d = tempfile::tempdir().unwrap();
    let truth_file = truth(d.path());
    let truth = Plant::load(&truth_file).unwrap();
    make_data(d.path(), &truth_file, "4.3", Some("J4"), "c1", "10");
    make_data(d.path(), &truth_file, "4.3", Some("J5"), "c2", "10");
    make_data(d.path(), &truth_file, "4.7", None, "k1", "10");
    let at_truth = Plant::load(&truth_within_bounds(d.path(), &truth_file, &[])).unwrap();
    let options = OutputErrorOptions {
        h: 1.0 / 12000.0,
        horizons: vec![1.0],
        estimate_initial_positions: true,
        ..OutputErrorOptions::isolated()
    };
    let step = |config: &str, free: Vec<usize>, names: &[&str]| {
        let conf = truth.model.configuration(config).unwrap();
        let file = d.path().join(format!("data/{config}_run.csv"));
        let names: Vec<String> = names.iter().map(|n| n.to_string()).collect();
        let problem = Problem::new(
            &at_truth,
            conf,
            names.clone(),
            vec![read_record(&file, truth.model, conf, 0.01).unwrap()],
            &free,
            options.clone(),
        )
        .unwrap();
        let fit = problem.fit(&|_| {}).unwrap();
        let report = StepReport::of(
            Step {
                config: config.into(),
                free,
                interest: Vec::new(),
                fitted: names,
                carried: Vec::new(),
                held: Vec::new(),
                tied_held: Vec::new(),
            },
            fit,
        );
        (report, (config.to_string(), problem))
    };
    let (c1, c1_files) = step("c1", vec![4], &["Fc_q4", "sigma2_q4"]);
    let (c2, c2_files) = step("c2", vec![5], &["Fc_q5"]);
    let (k1, k1_files) = step("k1", vec![4, 5], &["Fc_q4", "sigma2_q4", "Fc_q5"]);
    for st in [&c1, &c2, &k1] {
        assert!(
            st.fit.statistics.above_floor.is_empty(),
            "{}",
            st.step.config
        );
    }
    // The plant after k1, with Fc_q4 2 % off.
    let mut current = at_truth.clone();
    *current.parameters.get_mut("Fc_q4").unwrap() *= 1.02;
    let worst = |plant: &Plant, st: &StepReport, files: &(String, Problem)| {
        final_check(plant, &[(st, &files.1)])[0].worst()
    };
    let off = worst(&current, &c1, &c1_files);
    eprintln!("c1's files after k1: {off:.2} σ̂");
    assert!(off > 1.5, "{off}");
    let reports = [c1.clone(), c2.clone(), k1.clone()];
    let refit = joint_refit(
        &mut current,
        (&k1, &k1_files.1),
        &["c1".to_string()],
        &[&c1_files, &c2_files],
        &reports,
        &occurrence(truth.model),
        &|_, _| {},
    )
    .expect("a joint refit");
    eprintln!("{refit:?}");
    assert_eq!(refit.configs, ["c1", "k1"]);
    assert_eq!(refit.names, ["Fc_q4", "sigma2_q4"]);
    assert!(refit.kept());
    assert_eq!(current.parameters["Fc_q5"], at_truth.parameters["Fc_q5"]);
    let fc = current.parameters["Fc_q4"] / truth.parameters["Fc_q4"] - 1.0;
    assert!(fc.abs() < 3e-3, "Fc_q4 {fc:+.2e} off the truth");
    for (st, files) in [(&c1, &c1_files), (&k1, &k1_files)] {
        let now = worst(&current, st, files);
        eprintln!("{}: {now:.2} σ̂", st.step.config);
        assert!(now < 1.1, "{}: {now}", st.step.config);
    }
    let informed: Vec<&str> = refit.information.iter().map(|(c, _)| c.as_str()).collect();
    assert_eq!(informed, ["c1", "k1"]);
}

/// k2 of the Freedom 6S (free q3, q4, q5; 30 s of Table 4.7 made from the truth in `dir`)
/// from the truth with `moved` values scaled, fitted on the whole files at 1/12000 s with
/// the initial positions estimated: the truth, the start, the options, and the file's
/// record (read afresh by each call).
struct K2Case {
    truth: Plant,
    start: Plant,
    options: OutputErrorOptions,
    file: PathBuf,
}

impl K2Case {
    fn new(dir: &Path, moved: &[(&str, f64)]) -> K2Case {
        let truth_file = truth(dir);
        make_data(dir, &truth_file, "4.7", None, "k2", "30");
        let start_file = truth_within_bounds(dir, &truth_file, moved);
        K2Case {
            truth: Plant::load(&truth_file).unwrap(),
            start: Plant::load(&start_file).unwrap(),
            options: OutputErrorOptions {
                h: 1.0 / 12000.0,
                horizons: vec![1.0],
                estimate_initial_positions: true,
                ..OutputErrorOptions::thesis()
            },
            file: dir.join("data/k2_run.csv"),
        }
    }

    fn k2(&self) -> &'static generated::Configuration {
        self.truth.model.configuration("k2").unwrap()
    }

    fn record(&self) -> Vec<lockstep::identify::output_error::Record> {
        vec![read_record(&self.file, self.truth.model, self.k2(), 0.01).unwrap()]
    }
}

/// The release of held values (`--release-held`, `StepRefit::release_held`): joint 4's Coulomb
/// level, which k1 fits, is held 2 % off with a recorded standard error of 1 % while k2
/// fits joint 3's friction (30 s of Table 4.7); k2's fit ends above the noise floor. Its
/// statistics say how much better k2's data see Fc_q4 than its recorded error: ρ =
/// σ_rec² / var, checked against the variance a fit with Fc_q4 among its parameters reports
/// for it. ρ > 1, so the release refits Fc_q4 with k2's parameters under a prior of 1 %
/// about the held value: the fit reaches the floor, Fc_q4 returns within 0.5 % of the truth
/// (a move of about −2 of its prior's σ), and the plant-level result keeps the step's
/// history (cost before, the first fit's evaluations counted).
#[test]
#[ignore = "acceptance of an opt-in option (minutes); cargo test --release -- --ignored"]
fn a_held_value_the_step_sees_better_is_released_and_the_floor_reached() {
    use lockstep::identify::sequence::StepRefit;
    let d = tempfile::tempdir().unwrap();
    let case = K2Case::new(d.path(), &[("Fc_q4", 1.02)]);
    let (truth, mut start, options, k2) =
        (&case.truth, case.start.clone(), &case.options, case.k2());
    let fc4 = truth.parameters["Fc_q4"];
    start.standard_errors.insert("Fc_q4".into(), 0.01 * fc4);
    let record = || case.record();
    let names: Vec<String> = ["Fc_q3", "sigma2_q3"].map(String::from).to_vec();
    let problem = Problem::new(&start, k2, names.clone(), record(), &[3], options.clone()).unwrap();
    // σ̂ from the data (robust 5th differences) is near the sensor's 2.02e-4 rad; a known
    // sensor σ (`--noise-sigma`) replaces it on every free joint.
    for s in &problem.noise {
        assert!((s / 2.02e-4 - 1.0).abs() < 0.25, "σ̂ {s}");
    }
    let known = OutputErrorOptions {
        noise_sigma: Some(2.02e-4),
        ..options.clone()
    };
    let sensor = Problem::new(&start, k2, names.clone(), record(), &[3], known).unwrap();
    assert_eq!(sensor.noise, vec![2.02e-4; 3]);
    let fit = problem.fit(&|_| {}).unwrap();
    let worst = |f: &lockstep::identify::output_error::FitResult| {
        f.statistics
            .joints
            .iter()
            .map(|j| j.rms / j.noise)
            .fold(0.0, f64::max)
    };
    eprintln!("k2 with Fc_q4 held 2 % off: worst RMS {:.2} σ̂", worst(&fit));
    assert!(!fit.statistics.above_floor.is_empty());
    let rho = fit
        .statistics
        .held_information
        .iter()
        .find(|(n, _)| n == "Fc_q4")
        .map(|x| x.1)
        .expect("Fc_q4 is held with a standard error");
    // The variance of Fc_q4 fitted with the others, at the same point.
    let mut at = start.clone();
    at.set_values(&fit.names, &fit.fitted);
    let mut with = names.clone();
    with.push("Fc_q4".into());
    let augmented = Problem::new(&at, k2, with.clone(), record(), &[3], options.clone()).unwrap();
    let p: Vec<f64> = with.iter().map(|n| at.parameters[n]).collect();
    let stats = augmented.statistics(&p).unwrap();
    let reference = (0.01 * fc4 / stats.std_err_given_held[2]).powi(2);
    eprintln!("ρ(Fc_q4) = {rho:.4}, from the augmented fit's standard error {reference:.4}");
    assert!(rho > 1.0);
    assert!((rho / reference - 1.0).abs() < 0.05, "{rho} vs {reference}");
    let (released, summary) = StepRefit {
        problem: &problem,
        interest: &[3],
        held_ties: &[],
        progress: &|_| {},
    }
    .release_held(&start, fit.clone())
    .unwrap();
    let summary = summary.expect("Fc_q4 is released");
    eprintln!("{summary:?}");
    assert!(summary.kept);
    assert_eq!(summary.values.len(), 1);
    let (name, _, se, before, after) = summary.values[0].clone();
    assert_eq!(name, "Fc_q4");
    assert!(
        (after / fc4 - 1.0).abs() < 0.005,
        "Fc_q4 {after}, truth {fc4}"
    );
    assert!(
        ((after - before) / se + 2.0).abs() < 0.6,
        "{}",
        (after - before) / se
    );
    assert!(
        released.statistics.above_floor.is_empty(),
        "{:?}",
        released.statistics.above_floor
    );
    assert_eq!(released.names, with);
    assert_eq!(released.cost_before, fit.cost_before);
    assert!(released.evaluations > fit.evaluations);
    assert!(released.cost_after + released.prior_penalty < fit.cost_after);
    for n in &names {
        let i = released.names.iter().position(|x| x == n).unwrap();
        let t = truth.parameters[n];
        assert!(
            (released.fitted[i] / t - 1.0).abs() < 0.01,
            "{n} {} truth {t}",
            released.fitted[i]
        );
    }
}

/// The joint fit's case: k1 and k2 files of `seconds` of Table 4.7 from the truth under `d`,
/// the start (the truth within bounds); returns the truth and the start.
fn joint_fit_case(d: &Path, seconds: &str) -> (Plant, PathBuf) {
    let truth_file = truth(d);
    let truth = Plant::load(&truth_file).unwrap();
    for k in ["k1", "k2"] {
        make_data(d, &truth_file, "4.7", None, k, seconds);
    }
    (truth, truth_within_bounds(d, &truth_file, &[]))
}

/// `lockstep identify sequence --preset coupled --config k2 --joint-fit only` from `start` on
/// `data` into `out`, with `extra` options.
fn joint_fit_only(start: &Path, data: &Path, out: &Path, extra: &[&str]) -> Output {
    let args = [
        "identify",
        "sequence",
        "--preset",
        "coupled",
        "--config",
        "k2",
        "--joint-fit",
        "only",
        "--plant",
        start.to_str().unwrap(),
        "--data",
        data.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    lockstep(&[&args[..], extra].concat())
}

/// A run of [`joint_fit_only`] on k2's file alone (under `d`) is refused before any fit,
/// naming the step without files.
fn joint_fit_refused_without_k1(d: &Path, start: &Path, out: &Path) {
    let only_k2 = d.join("only_k2");
    std::fs::create_dir_all(&only_k2).unwrap();
    std::fs::copy(d.join("data/k2_run.csv"), only_k2.join("k2_run.csv")).unwrap();
    fails(
        &joint_fit_only(start, &only_k2, out, &[]),
        &["joint fit: step 'k1' has no measurement file"],
    );
}

/// What every joint fit up to k2 must show in `out`: no step run alone, every parameter
/// k1 and k2 fit either fitted or held as a tie (and then left undetermined in the plant),
/// every joint at the noise floor, the plant written with the fitted values, report.md's
/// section. Returns the joint fit's JSON.
fn check_joint_fit(out: &Path, truth: &Plant) -> serde_json::Value {
    let report = read_report(out);
    assert_eq!(report["steps"].as_array().unwrap().len(), 0);
    let fit = report["joint"]["fit"].clone();
    let names: Vec<String> = column(&fit, &["names"]);
    let steps = plan(truth, "coupled").unwrap();
    let tied: Vec<String> = column(&report["joint"], &["step", "tied_held"]);
    for n in steps[0].fitted.iter().chain(&steps[1].fitted) {
        assert!(
            names.contains(n) || tied.contains(n),
            "{n} neither fitted nor held"
        );
    }
    let above: Vec<String> = column(&fit, &["statistics", "above_floor"]);
    assert!(above.is_empty(), "{above:?}");
    let fitted: Vec<f64> = column(&fit, &["fitted"]);
    let written = Plant::load(&out.join("plant.toml")).unwrap();
    for (n, v) in names.iter().zip(&fitted) {
        assert_eq!(written.parameters[n], *v, "{n}");
    }
    for n in &tied {
        assert!(written.undetermined.contains(n), "{n}");
    }
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(md.contains("## Joint fit of every step's files: free q3, q4, q5"));
    // Each round of the joint fit is a record; the last kept one's cost is the fit's.
    let stages = fit["starts"][0]["stages"].as_array().unwrap();
    assert!(!stages.is_empty());
    assert_eq!(stages[0]["stage"], "joint fit 1");
    // The coupled preset's whole-files optimiser.
    assert_eq!(stages[0]["optimiser"], "TrustRegionReflective");
    let after = fit["cost_after"].as_f64().unwrap();
    assert!(
        stages
            .iter()
            .any(|s| s["whole_files_cost"].as_f64() == Some(after)),
        "no round ends at the fit's cost {after}: {stages:?}"
    );
    fit
}

/// `lockstep identify sequence --preset coupled --config k2 --joint-fit only`: the joint fit of the
/// steps up to k2 on their files (30 s of Table 4.7 each), from the truth (the joint fit
/// is meant for the values the steps fitted; from 2 % off in a Coulomb level it can end in
/// a local minimum, see `JointProblem::fit`). No step runs alone; the joint fit fits every
/// parameter k1 and k2 fit (those k2's plan lists, with the symbols that span the two
/// configurations' base parameters), stays at the noise floor on every joint of both, and
/// calls at least three values identifiable, each within 1 % of the truth and 4 of its
/// standard errors (measured with the Levenberg–Marquardt: qeq_q4, qeq_q5, G_q4_to_q5,
/// G_q5_to_q4, vs_q3, the largest 3.4 σ, qeq_q5; with the trust-region-reflective method, the
/// coupled preset's since stop 92, vs_q4 too). The plant written holds the fitted values and lists the symbols left
/// undetermined; report.md has the joint fit's section. Without k1's file the run is
/// refused before any fit, naming the step.
#[test]
#[ignore = "slow end-to-end identification (minutes); cargo test --release -- --ignored"]
fn the_joint_fit_alone_refines_the_steps_up_to_config_on_their_files() {
    let d = tempfile::tempdir().unwrap();
    let (truth, start) = joint_fit_case(d.path(), "30");
    let out = d.path().join("out");
    joint_fit_refused_without_k1(d.path(), &start, &out);
    ok(&joint_fit_only(&start, &d.path().join("data"), &out, &[]));
    let fit = &check_joint_fit(&out, &truth);
    let names: Vec<String> = column(fit, &["names"]);
    let fitted: Vec<f64> = column(fit, &["fitted"]);
    let std_err: Vec<Option<f64>> = column(fit, &["statistics", "std_err"]);
    let identifiable: Vec<bool> = column(fit, &["statistics", "identifiable"]);
    let called: Vec<&String> = names
        .iter()
        .zip(&identifiable)
        .filter_map(|(n, &y)| y.then_some(n))
        .collect();
    eprintln!("identifiable: {called:?}");
    assert!(called.len() >= 3, "{called:?}");
    for (i, n) in names.iter().enumerate() {
        if identifiable[i] {
            let (v, t, se) = (fitted[i], truth.parameters[n], std_err[i].unwrap());
            assert!((v / t - 1.0).abs() < 0.01, "{n} = {v}, truth {t}");
            assert!((v - t).abs() < 4.0 * se, "{n} = {v} ± {se}, truth {t}");
        }
    }
}

/// The joint fit's mechanism, fast (the default test set; the ignored test above runs it on
/// 30 s files from the warm-ups): `--joint-fit only` on 4 s of k1 and k2 from the truth,
/// the whole files at once. No step runs alone; every parameter k1 and k2 fit is fitted or
/// held as a tie; every joint ends at the noise floor; the plant written holds the fitted
/// values; report.md has the joint fit's section; each round is a stage record. Without
/// k1's file the run is refused before any fit, naming the step.
#[test]
fn the_joint_fit_fits_every_steps_parameters_on_every_steps_files() {
    let d = tempfile::tempdir().unwrap();
    let (truth, start) = joint_fit_case(d.path(), "4");
    let out = d.path().join("out");
    joint_fit_refused_without_k1(d.path(), &start, &out);
    ok(&joint_fit_only(
        &start,
        &d.path().join("data"),
        &out,
        &[
            "--equation-error",
            "off",
            "--predictor",
            "none",
            "--horizons",
            "1",
            "--skip",
            "100",
        ],
    ));
    check_joint_fit(&out, &truth);
}

/// A start from which the whole files cannot be simulated is warmed up all the same: the
/// equation error simulates nothing, and the predictor's stages start from its result. c1
/// on 12 s of Table 4.3's J4 chirp from a ±50 % start (alternating, as the ±25 % start of
/// the other tests): q4 runs past 100 rad/s by t = 0.23 s (the start used to end the fit:
/// "no start could be fitted"); through the equation error and ω = 100, 1 rad/s it reaches
/// the noise floor (measured: 1.02 σ̂, 22 s) with what it calls identifiable within 5 %.
/// Every stage by the Levenberg–Marquardt (`--predictor-optimiser lm`; the predictor's
/// default is the trust-region-reflective method, the next test).
#[test]
fn a_start_the_whole_files_diverge_from_is_warmed_up_to_the_noise_floor() {
    let starts = fit_the_diverging_start(&["--predictor-optimiser", "lm"]);
    let stages: Vec<StageRecord> = column(&starts[0], &["stages"]);
    assert!(
        stages
            .iter()
            .any(|r| r.stage.starts_with("predictor ω = 100 rad/s")),
        "{stages:?}"
    );
    // Every stage that ran, ran on the Levenberg–Marquardt.
    assert!(
        stages
            .iter()
            .filter_map(|r| r.optimiser)
            .all(|o| o == StageOptimiser::LevenbergMarquardt),
        "{stages:?}"
    );
    // Each stage that ran records what it spent: at least one evaluation per iteration and
    // one Jacobian per iteration that moved (the Levenberg–Marquardt's), and its time.
    for r in stages.iter().filter(|r| r.optimiser.is_some()) {
        assert!(
            r.evaluations >= r.iterations.max(1) && r.jacobians >= 1 && r.wall_s > 0.0,
            "{r:?}"
        );
    }
}

/// The same through the trust-region-reflective method for the predictor's stages and
/// the whole files' (`--predictor-optimiser trf --whole-files-optimiser trf`): the same
/// floor, what it calls identifiable within 5 %, and the report names the method of each
/// stage.
#[test]
fn the_trust_region_reflective_method_warms_a_diverging_start_up_to_the_noise_floor() {
    let starts = fit_the_diverging_start(&[
        "--predictor-optimiser",
        "trf",
        "--whole-files-optimiser",
        "trf",
    ]);
    let stages: Vec<StageRecord> = column(&starts[0], &["stages"]);
    let optimiser_of = |prefix: &str| {
        stages
            .iter()
            .find(|r| r.stage.starts_with(prefix))
            .and_then(|r| r.optimiser)
    };
    let trf = Some(StageOptimiser::TrustRegionReflective);
    assert_eq!(optimiser_of("predictor ω = 100 rad/s"), trf, "{stages:?}");
    assert_eq!(optimiser_of("horizon 100 %"), trf, "{stages:?}");
    // The report's text names the method of each stage too.
    let status = starts[0]["status"].as_str().unwrap();
    assert!(
        status.contains("horizon 100 %: trust-region-reflective: "),
        "{status}"
    );
}

/// c1 of the Freedom 6S from the ±50 % start of
/// [`a_start_the_whole_files_diverge_from_is_warmed_up_to_the_noise_floor`] with `extra`
/// options: asserts the premise (the whole files diverge from the start), every joint
/// within 1.1 σ̂ and every value called identifiable within 5 % of the truth; returns the
/// starts' summaries.
fn fit_the_diverging_start(extra: &[&str]) -> Vec<serde_json::Value> {
    let d = tempfile::tempdir().unwrap();
    let (truth, start) = short_isolated_start(d.path(), "J4", 0);
    let mut plant = Plant::load(&start).unwrap();
    let c1 = plan(&truth, "isolated").unwrap()[0].clone();
    for (i, n) in c1.fitted.iter().enumerate() {
        if !n.starts_with("qeq") {
            let f = if i % 2 == 0 { 1.5 } else { 0.5 };
            plant.parameters.insert(n.clone(), f * truth.parameters[n]);
        }
    }
    let fc = plant.parameters["Fc_q4"];
    let fs = plant.parameters.get_mut("Fs_q4").unwrap();
    *fs = fs.max(fc);
    plant.save(&start).unwrap();
    // The bound of the run this premise was written for (the default now follows the
    // records' speeds and lets this start run on, far off, instead of diverging).
    let mut args = vec![
        "--set",
        "max_speed=100",
        "--step",
        "1/12000",
        "--horizons",
        "none",
        "--equation-error",
        "on",
        "--predictor",
        "100,1",
        "--predictor-step",
        "1/2000",
    ];
    args.extend_from_slice(extra);
    let report = identify_isolated(d.path(), &start, "c1", &args);
    let fit = &report["steps"][0]["fit"];
    let starts: Vec<serde_json::Value> = column(fit, &["starts"]);
    println!("{starts:#?}");
    // The premise: the whole files diverge from the start.
    assert!(fit["cost_before"].is_null(), "{}", fit["cost_before"]);
    let status = starts[0]["status"].as_str().unwrap();
    assert!(
        status.starts_with("the start cannot be simulated (") && status.contains("diverged"),
        "{status}"
    );
    for j in fit["statistics"]["joints"].as_array().unwrap() {
        let (rms, noise) = (j["rms"].as_f64().unwrap(), j["noise"].as_f64().unwrap());
        assert!(
            rms <= 1.1 * noise,
            "joint {} at {:.2} σ̂",
            j["joint"],
            rms / noise
        );
    }
    let names: Vec<String> = column(fit, &["names"]);
    let fitted: Vec<f64> = column(fit, &["fitted"]);
    let identifiable: Vec<bool> = column(fit, &["statistics", "identifiable"]);
    assert!(
        identifiable.iter().any(|&b| b),
        "nothing called identifiable"
    );
    for (i, n) in names.iter().enumerate().filter(|&(i, _)| identifiable[i]) {
        let t = truth.parameters[n];
        assert!(
            (fitted[i] - t).abs() <= 0.05 * t.abs(),
            "{n}: fitted {} against the truth's {t}",
            fitted[i]
        );
    }
    starts
}

/// A fit whose bounds exclude the truth ends away from the noise floor with the value at
/// its bound, and the report says exactly which values ended at a bound and what that may
/// mean (joint 4's cable-drag spring Ks_q4 bounded to 10–20 % of its true value; c1, 12 s,
/// 15 iterations). Joint 4's Stribeck dip and plant gain are held at the truth's (bounds
/// lower = upper). With the dip fitted, the Stribeck re-seed's branch (Fc = Fs tried) ends
/// lower (7.2e7 against 4.0e8) with σ1_4, σ2_4 and vs_q4 on their bounds and Ks_q4 inside;
/// with the gain fitted, the plant-gain scale lets Kp_q4 run to its bound instead (3.6e8,
/// Ks_q4 at 17 %): either would test something else than the bound the truth is outside of.
#[test]
fn a_fit_away_from_the_floor_names_the_values_at_their_bounds() {
    let d = tempfile::tempdir().unwrap();
    let (truth, start) = short_isolated_start(d.path(), "J4", 0);
    let mut plant = Plant::load(&start).unwrap();
    let ks = truth.parameters["Ks_q4"];
    plant.bounds.insert("Ks_q4".into(), (0.1 * ks, 0.2 * ks));
    plant.parameters.insert("Ks_q4".into(), 0.15 * ks);
    // The Stribeck dip and the gain held at the truth's (bounds lower = upper): no re-seed
    // branch and no gain scale (either ends with other values on their bounds, Ks_q4 inside).
    for n in ["Fs_q4", "vs_q4", "Kp_q4"] {
        let v = truth.parameters[n];
        plant.bounds.insert(n.into(), (v, v));
        plant.parameters.insert(n.into(), v);
    }
    plant.save(&start).unwrap();
    let report = identify_isolated(
        d.path(),
        &start,
        "c1",
        &["--step", "1/12000", "--horizons", "1", "--max-iter", "15"],
    );
    let fit = &report["steps"][0]["fit"];
    let names: Vec<String> = column(fit, &["names"]);
    let fitted: Vec<f64> = column(fit, &["fitted"]);
    let at_bound: Vec<bool> = column(fit, &["statistics", "at_bound"]);
    let k = names.iter().position(|n| n == "Ks_q4").unwrap();
    assert!(at_bound[k], "Ks_q4 = {} not at its bound", fitted[k]);
    assert!((fitted[k] - 0.2 * ks).abs() <= 1e-9 * ks, "{}", fitted[k]);
    let bounded: Vec<&String> = names
        .iter()
        .zip(&at_bound)
        .filter(|(_, &b)| b)
        .map(|(n, _)| n)
        .collect();
    assert!(!bounded.is_empty(), "no value at a bound: {fitted:?}");
    assert!(!fit["statistics"]["above_floor"]
        .as_array()
        .unwrap()
        .is_empty());
    let md = std::fs::read_to_string(d.path().join("out").join("report.md")).unwrap();
    let line = md
        .lines()
        .find(|l| l.contains("ended at a bound:"))
        .expect("no line on the values at their bounds");
    println!("{line}");
    assert!(line.contains("widen them"), "{line}");
    let listed: Vec<&str> = line
        .split_once("ended at a bound: ")
        .and_then(|(_, rest)| rest.split_once(". "))
        .unwrap()
        .0
        .split(", ")
        .collect();
    assert_eq!(listed, bounded, "{line}");
}

/// In k1 (joints 4 and 5 free, every parameter that scales with the plant gains fitted or
/// held along a tie) the gain's scale family — Kp_q4, Kp_q5 with every force of both joints
/// and link 7's mass and inertias — is an exact symmetry of position data, so the
/// statistics must call every member undetermined, also where a member's column is only
/// difference noise, as Fs_q5's is at the truth's vs_q5 = 8.0e-9 rad/s (a k1 fit of the
/// seed-7 data called Kp_q4 and Kp_q5 "identifiable" to 4 and 9 ppm: such a column had
/// lifted the family's direction above the exact-symmetry cut-off). The parameters outside
/// the family keep finite standard errors. With Kp_q5 held at a known value (a datasheet
/// gain) nothing scales any more: the forces get finite standard errors. The direction
/// includes what makes up for the held ties, over the fitted rigid-body symbols only, and
/// so does each held tie's share in the standard errors (a value uniform within its
/// bounds): z7 (for I7_13) gets the tie's uncertainty, vs_q4, qeq_q4 and G_q4_to_q5 keep theirs
/// (solved over every column, the least squares leaked the finite-difference error along
/// the projected direction into them: qeq_q4 ± 0.0155 rad, 6 %).
#[test]
fn the_plant_gain_scale_family_is_undetermined_and_a_held_gain_determines_it() {
    let d = tempfile::tempdir().unwrap();
    let truth_file = truth(d.path());
    let truth = Plant::load(&truth_file).unwrap();
    let step = plan(&truth, "coupled").unwrap()[0].clone();
    assert_eq!(step.config, "k1");
    let (p, at_truth, _) = problem_of_step(d.path(), "coupled", "4.7", None, |_| 0);
    let mut plant = p.plant_at(&at_truth);
    let model = truth.model;
    // Where that k1 fit ended joint 5's Stribeck dip: Fs_q5 and vs_q5 on their upper bounds
    // (3.14385 N·m, 4.0112e-7 rad/s), a dip no sample sees.
    plant.bounds.insert("Fs_q5".into(), (1.2575e-3, 3.14385));
    plant.bounds.insert("vs_q5".into(), (1.6045e-10, 4.0112e-7));
    let dip_lost = [("Fs_q5", 3.14385), ("vs_q5", 4.0112e-7)];
    // As `--rigid-body spanning` fits k1 on these files: y7 and I7_13 held along ties.
    let ties = vec!["y7".to_string(), "I7_13".to_string()];
    let problem = |held: &[&str], at: &[(&str, f64)]| {
        let names: Vec<String> = step
            .fitted
            .iter()
            .filter(|n| !ties.contains(n) && !held.contains(&n.as_str()))
            .cloned()
            .collect();
        let rec = read_record(
            &d.path().join("data/k1_run.csv"),
            model,
            p.configuration(),
            0.01,
        );
        let q = Problem::new(
            &plant,
            p.configuration(),
            names.clone(),
            vec![rec.unwrap()],
            &[4, 5],
            p.options().clone(),
        )
        .unwrap()
        .with_held_ties(ties.clone());
        let values: Vec<f64> = names
            .iter()
            .map(|n| {
                at.iter()
                    .find(|(m, _)| m == n)
                    .map_or(truth.parameters[n], |a| a.1)
            })
            .collect();
        let stats = q.statistics(&values).unwrap();
        (names, values, stats)
    };

    let in_family = |n: &str| {
        lockstep::identify::output_error::scales_with_the_gain(model, n)
            && truth.parameters[n] != 0.0
    };
    for n in [
        "Kp_q4",
        "Kp_q5",
        "sigma0_q4",
        "Fc_q5",
        "Fs_q5",
        "Ks_q5",
        "m7",
        "I7_33",
    ] {
        assert!(step.fitted.iter().any(|f| f == n) && in_family(n), "{n}");
    }
    for at in [&[][..], &dip_lost[..]] {
        let (names, values, stats) = problem(&[], at);
        for (i, n) in names.iter().enumerate() {
            let se = stats.std_err[i];
            println!("{at:?}: {n}: {:.6e} ± {se:.3e}", values[i]);
            if in_family(n) {
                assert!(se.is_infinite(), "{n} ± {se} on the gain scale at {at:?}");
                assert!(!stats.identifiable[i], "{n} called identifiable");
            }
        }
        for n in ["qeq_q4", "qeq_q5", "G_q4_to_q5", "vs_q4"] {
            let i = names.iter().position(|m| m == n).unwrap();
            let se = stats.std_err[i];
            assert!(
                se.is_finite() && se > 0.0 && se < 1e-2 * values[i].abs(),
                "{n} ± {se}"
            );
        }
        // z7 is no member, but it makes up for the held I7_13 (the parallel-axis term
        // m7·x7·z7): as uncertain as the tie's spread makes it (at the truth ± 26 m for
        // z7 = −0.145 m; where the fit ended, moved by the family's direction: infinite),
        // never "identifiable" (before the held ties' share: 0.54 % off at 21.6 standard
        // errors, and called identifiable).
        let z7 = names.iter().position(|m| m == "z7").unwrap();
        assert!(
            stats.std_err[z7] > values[z7].abs() && !stats.identifiable[z7],
            "z7 ± {}",
            stats.std_err[z7]
        );
        // The held ties enter the standard errors with their bounds' spread.
        let tied: Vec<&str> = stats.held_ties.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(tied, ["I7_13", "y7"]);
        for (n, se) in &stats.held_ties {
            let (lo, hi) = plant.bounds[n];
            assert_eq!(*se, (hi - lo) / 12f64.sqrt(), "{n}");
        }
    }

    // Kp_q5 held at its value (a datasheet gain): nothing scales any more.
    let (names, values, stats) = problem(&["Kp_q5"], &[]);
    for n in ["Kp_q4", "sigma0_q4", "Fc_q5", "Ks_q5", "Ks_q4"] {
        let i = names.iter().position(|m| m == n).unwrap();
        let (se, v) = (stats.std_err[i], values[i]);
        println!("Kp_q5 held: {n}: {v:.6e} ± {se:.3e}");
        assert!(
            se.is_finite() && se < 0.05 * v.abs(),
            "{n}: {v} ± {se} with Kp_q5 held"
        );
    }
}

/// k2 of the coupled method (joints 3..5, 30 s of Table 4.7) holds what k1 fitted. k1 left
/// its gain family (Kp_q4, Kp_q5, both joints' friction levels and springs, link 7's mass
/// and inertias) on the exact plant-gain symmetry, at a scale its least change chose. Recorded as a scale family in
/// the plant (`[scale_families] k1`), that scale counts as unknown in k2's statistics:
/// joint 3's gain and friction levels, which k2 fixes only relative to it, get infinite
/// standard errors and are not called identifiable; their standard errors relative to the
/// scale are the figures k2 gave before (without the family the same computation: finite,
/// below 1 % of each value; on the seed-7 run k2 called Kp_q3 identifiable 0.046 % off at
/// 8.4 such standard errors, the error of k1's scale). vs_q3, which does not scale, keeps a finite standard
/// error, no smaller than relative to the scale.
#[test]
fn a_held_gain_family_without_a_determined_scale_leaves_the_coupled_values_relative() {
    let d = tempfile::tempdir().unwrap();
    let case = K2Case::new(d.path(), &[]);
    let (truth, k2) = (&case.truth, case.k2());
    let step = plan(truth, "coupled").unwrap()[1].clone();
    assert_eq!(step.config, "k2");
    let names: Vec<String> = step.fitted.clone();
    let at_truth: Vec<f64> = names.iter().map(|n| truth.parameters[n]).collect();
    let model = truth.model;
    // What k1 fitted that scales with the gain (nonzero), k2 does not fit again.
    let k1 = plan(truth, "coupled").unwrap()[0].clone();
    let family: Vec<String> = k1
        .fitted
        .iter()
        .filter(|n| {
            lockstep::identify::output_error::scales_with_the_gain(model, n)
                && case.start.parameters.get(*n).is_some_and(|v| *v != 0.0)
                && !names.contains(n)
        })
        .cloned()
        .collect();
    for n in ["Kp_q4", "Kp_q5", "Fc_q4", "Fs_q5", "Ks_q4", "m7", "I7_33"] {
        assert!(family.iter().any(|m| m == n), "{n} not in {family:?}");
    }
    let statistics = |plant: &Plant| {
        Problem::new(
            plant,
            k2,
            names.clone(),
            case.record(),
            &[3],
            case.options.clone(),
        )
        .unwrap()
        .statistics(&at_truth)
        .unwrap()
    };
    let before = statistics(&case.start);
    let mut start = case.start.clone();
    start.scale_families.insert("k1".into(), family.clone());
    let stats = statistics(&start);
    let at = |n: &str| names.iter().position(|m| m == n).unwrap();
    assert!(before.held_scales.is_empty());
    assert_eq!(stats.held_scales.len(), 1);
    assert_eq!(stats.held_scales[0].0, "k1");
    assert_eq!(stats.held_scales[0].1.len(), family.len());
    for n in ["Kp_q3", "Fc_q3", "Fs_q3", "sigma2_q3"] {
        let i = at(n);
        let (old, se, given) = (
            before.std_err[i],
            stats.std_err[i],
            stats.std_err_given_scale[i],
        );
        println!("{n}: before ± {old:.3e}; now ± {se:.3e}, relative to k1's scale ± {given:.3e}");
        assert!(
            old.is_finite() && old < 0.01 * at_truth[i].abs(),
            "{n} ± {old} without the family"
        );
        assert!(se.is_infinite() && !stats.identifiable[i], "{n} ± {se}");
        assert!(
            (given / old - 1.0).abs() < 1e-9,
            "{n}: relative to the scale ± {given}, before ± {old}"
        );
        assert_eq!(stats.identifiable_given_scale[i], before.identifiable[i]);
        assert!(lockstep::identify::output_error::scales_with_the_gain(
            model, n
        ));
    }
    // k3 holds k2's family with the standard errors k2 recorded relative to its scale:
    // each member's share enters beside the scale, which stays unknown.
    let mut relative = start.clone();
    for n in &family {
        let v = relative.parameters[n];
        relative.standard_errors.insert(n.clone(), 1e-3 * v.abs());
    }
    let with_shares = statistics(&relative);
    for n in ["Kp_q3", "Fc_q3", "Fs_q3", "sigma2_q3"] {
        let i = at(n);
        let (se, given) = (with_shares.std_err[i], with_shares.std_err_given_scale[i]);
        println!("{n} with the members' shares: ± {se:.3e}, relative to the scale ± {given:.3e}");
        assert!(
            se.is_infinite() && !with_shares.identifiable[i],
            "{n} ± {se}"
        );
        assert!(
            given > stats.std_err_given_scale[i],
            "{n}: ± {given} relative"
        );
    }
    assert_eq!(with_shares.held.len(), family.len());
    let i = at("vs_q3");
    let (se, given) = (stats.std_err[i], stats.std_err_given_scale[i]);
    println!("vs_q3 ± {se:.3e}, relative to k1's scale ± {given:.3e}");
    assert!(
        se.is_finite() && se < 0.01 * at_truth[i] && (se / given - 1.0).abs() < 1e-3,
        "vs_q3 ± {se}, relative to the scale ± {given}"
    );
}

/// The balanced refit (`--balance on`, `StepRefit::balance`): k2 (q3 of interest, weighted
/// 50; 30 s of Table 4.7) with k1's Coulomb level Fc_q4 held 0.01 % off (the wrist sees it:
/// 0.5 % off puts q4 at 149 σ̂), fitting joint 3's friction and link 7's centroid (x7, y7),
/// which move every free joint. Measured: the thesis-weighted fit ends with q3, q4, q5 at
/// 1.57, 5.32, 2.76 σ̂ (cost 0.477); refitted with every joint weighted 1 at 1.12, 2.70,
/// 1.37 σ̂, and the thesis-weighted cost there is lower too (0.242): the weighted fit had
/// stopped short, its q4 share 1/2500 of q3's. The refit is kept; its reported costs are
/// checked against each cost evaluated afresh, and a step whose free joints are all of
/// interest gets none.
#[test]
#[ignore = "acceptance of an opt-in option (minutes); cargo test --release -- --ignored"]
fn the_balanced_refit_spreads_a_held_values_misfit_over_the_joints() {
    use lockstep::identify::sequence::StepRefit;
    let d = tempfile::tempdir().unwrap();
    let case = K2Case::new(d.path(), &[("Fc_q4", 1.0001)]);
    let (start, options, k2) = (&case.start, &case.options, case.k2());
    let record = || case.record();
    let names: Vec<String> = ["x7", "y7", "Fc_q3", "sigma2_q3"]
        .map(String::from)
        .to_vec();
    let problem = Problem::new(start, k2, names.clone(), record(), &[3], options.clone()).unwrap();
    let fit = problem.fit(&|_| {}).unwrap();
    let refit = StepRefit {
        problem: &problem,
        interest: &[3],
        held_ties: &[],
        progress: &|_| {},
    };
    let (balanced, summary) = refit.balance(start, fit.clone(), &[]).unwrap();
    let b = summary.expect("q3 is weighted apart from q4 and q5");
    eprintln!("{b:?}");
    let (before, after) = b.worst();
    assert!(before > 3.0, "the held value's misfit: worst {before:.2} σ̂");
    assert!(after < 0.7 * before, "worst {before:.2} → {after:.2} σ̂");
    assert!(b.kept);
    for (j, x, y) in &b.joints {
        let (x, y) = (x.expect("σ̂ of noisy data"), y.expect("σ̂ of noisy data"));
        assert!(y < x, "{j}: {x:.2} → {y:.2} σ̂");
    }
    // The step's result: the balanced values and statistics (every joint weighted 1), its
    // history (cost before), its cost the thesis-weighted one at the balanced values.
    assert!(balanced.statistics.joints.iter().all(|j| j.weight == 1.0));
    assert_eq!(balanced.cost_before, fit.cost_before);
    assert!(balanced.evaluations > fit.evaluations);
    assert_eq!(b.cost_weighted.0, fit.cost_after);
    assert_eq!(balanced.cost_after, b.cost_weighted.1);
    // Each reported cost afresh: a new problem at the values, on the initial positions that
    // fit settled on; the fits' own costs are repeated the same way.
    let cost = |weight: f64, of: &lockstep::identify::output_error::FitResult| {
        let mut at = start.clone();
        at.set_values(&names, &of.fitted);
        let o = OutputErrorOptions {
            interest_weight: weight,
            ..options.clone()
        };
        Problem::new(&at, k2, names.clone(), record(), &[3], o)
            .unwrap()
            .with_initial_offsets(of.initial_positions.as_ref().unwrap())
            .cost(&of.fitted)
    };
    let close = |a: f64, b: f64| (a / b - 1.0).abs() < 1e-9;
    assert!(close(cost(50.0, &fit), fit.cost_after));
    assert!(close(cost(1.0, &balanced), b.cost_balanced.1));
    assert!(close(cost(50.0, &balanced), b.cost_weighted.1));
    assert!(close(cost(1.0, &fit), b.cost_balanced.0));
    // With λ ≥ 1 on q3 the weighted cost bounds the balanced one at the same values.
    assert!(b.cost_balanced.0 < b.cost_weighted.0);
    assert!(b.cost_balanced.1 < b.cost_weighted.1);
    // Every free joint of interest: nothing to balance.
    let all = StepRefit {
        problem: &problem,
        interest: &[3, 4, 5],
        held_ties: &[],
        progress: &|_| {},
    };
    let (same, none) = all.balance(start, fit.clone(), &[]).unwrap();
    assert!(none.is_none());
    assert_eq!(same.fitted, fit.fitted);
}

/// c1 on 20 s of Table 4.3's J4 chirp in `d`: the truth, a ±25 % start's file
/// ([`perturbed_start`]) and joint 4's effect values it fits.
fn c1_j4_case(d: &Path) -> (Plant, PathBuf, Vec<String>) {
    let truth_file = truth(d);
    let truth = Plant::load(&truth_file).unwrap();
    make_data(d, &truth_file, "4.3", Some("J4"), "c1", "20");
    let names: Vec<String> = [
        "Kp_q4",
        "sigma0_q4",
        "sigma1_q4",
        "Fc_q4",
        "Fs_q4",
        "vs_q4",
        "Ks_q4",
        "qeq_q4",
    ]
    .map(String::from)
    .to_vec();
    let start_file = d.join("start.toml");
    perturbed_start(&truth_file, &names, &start_file);
    (truth, start_file, names)
}

/// [`c1_j4_case`] with the start's values at the truth (its bounds kept): the truth, that
/// start, the fitted names and their true values.
fn c1_j4_at_truth(d: &Path) -> (Plant, Plant, Vec<String>, Vec<f64>) {
    let (truth, start_file, names) = c1_j4_case(d);
    let mut start = Plant::load(&start_file).unwrap();
    let at_truth: Vec<f64> = names.iter().map(|n| truth.parameters[n]).collect();
    start.set_values(&names, &at_truth);
    (truth, start, names, at_truth)
}

/// The warm-up start of a sequence step (`--warm-up-start`, `StepRefit::warm_up_start`): c1
/// on 20 s of Table 4.3's J4 chirp from a ±25 % start, its first fit cut short (3
/// iterations through the whole file alone) so that it ends above the noise floor; the
/// second start runs through the equation error and the predictor under the same limits.
/// The record must hold the first fit's joints above the floor and both costs; the fit
/// returned must be the one with the lower cost, with the work of both. A fit at the floor,
/// and options with warm-ups of their own, get no second start.
#[test]
fn the_warm_up_start_runs_where_the_horizons_end_above_the_floor_and_keeps_the_lower_cost() {
    use lockstep::identify::sequence::StepRefit;
    let d = tempfile::tempdir().unwrap();
    let (truth, start_file, names) = c1_j4_case(d.path());
    let start = Plant::load(&start_file).unwrap();
    let (conf, rec) = c1_record(d.path(), &truth);
    let options = OutputErrorOptions {
        h: 1.0 / 12000.0,
        horizons: vec![1.0],
        max_iter: 3,
        ..OutputErrorOptions::isolated()
    };
    let problem = Problem::new(
        &start,
        conf,
        names.clone(),
        vec![rec.clone()],
        &[4],
        options,
    )
    .unwrap();
    let fit = problem.fit(&|_| {}).unwrap();
    assert!(
        !fit.statistics.above_floor.is_empty(),
        "3 iterations from ±25 % should end above the floor: {:?}",
        fit.statistics.joints
    );
    let refit = StepRefit {
        problem: &problem,
        interest: &[4],
        held_ties: &[],
        progress: &|_| {},
    };
    let (kept, record) = refit.warm_up_start(&start, fit.clone()).unwrap();
    let w = record.expect("above the floor: a second start");
    eprintln!("{:?} {:?}", w.cost, w.above_floor);
    assert_eq!(w.above_floor, fit.statistics.above_floor);
    assert_eq!(w.cost.0, fit.cost_after);
    assert_eq!(kept.cost_after, w.cost.0.min(w.cost.1));
    assert_eq!(w.kept, w.cost.1 < w.cost.0);
    // Measured: the whole file from ±25 % ends at 2.8e7 (q4 at 1.3e4 σ̂), the warm-ups
    // under the same 3 iterations per stage at 0.150.
    assert!(w.kept, "{:?}", w.cost);
    assert_eq!(kept.evaluations, fit.evaluations + w.work.evaluations);
    assert!(
        w.work.status.contains("equation error"),
        "{}",
        w.work.status
    );
    // At the floor (the truth's values): none.
    let at_truth: Vec<f64> = names.iter().map(|n| truth.parameters[n]).collect();
    let mut truth_start = start.clone();
    truth_start.set_values(&names, &at_truth);
    let at_floor = Problem::new(
        &truth_start,
        conf,
        names.clone(),
        vec![rec.clone()],
        &[4],
        problem.options().clone(),
    )
    .unwrap();
    let floor_fit = at_floor.fit(&|_| {}).unwrap();
    assert!(floor_fit.statistics.above_floor.is_empty());
    let (same, none) = StepRefit {
        problem: &at_floor,
        ..refit
    }
    .warm_up_start(&truth_start, floor_fit.clone())
    .unwrap();
    assert!(none.is_none());
    assert_eq!(same.fitted, floor_fit.fitted);
    // Options with warm-ups of their own: none.
    let own = Problem::new(
        &start,
        conf,
        names.clone(),
        vec![rec],
        &[4],
        OutputErrorOptions {
            predictor: vec![3.0, 1.0],
            ..problem.options().clone()
        },
    )
    .unwrap();
    let (_, none) = StepRefit {
        problem: &own,
        ..refit
    }
    .warm_up_start(&start, fit)
    .unwrap();
    assert!(none.is_none());
}

/// `identify sequence` end to end with the warm-up start (`--warm-up-start`, on by default):
/// c1 on 12 s of Table 4.3's J4 chirp from a ±25 % start, the whole file alone for 3
/// iterations (it ends far above the floor, as in
/// `the_warm_up_start_runs_where_the_horizons_end_above_the_floor_and_keeps_the_lower_cost`).
/// The report must record the second start with both costs and keep the lower, and say so
/// in its Markdown, then the initial-positions refit from the kept minimum; with
/// `--warm-up-start off --initial-positions measured` neither. (By sensitivities, the isolated
/// default, the statistics at the horizons' end failed here — "the Jacobian of the held
/// values at the fitted values is not finite" — until non-finite sensitivities fell back
/// to finite differences.)
#[test]
fn the_sequence_reports_its_warm_up_start_and_off_switches_it_off() {
    let d = tempfile::tempdir().unwrap();
    let (_, start) = short_isolated_start(d.path(), "J4", 0);
    let args = ["--horizons", "1", "--max-iter", "3"];
    let report = identify_isolated(d.path(), &start, "c1", &args);
    let step = &report["steps"][0];
    let w = &step["warm_up_start"];
    let (horizons, warm) = (
        w["cost"][0].as_f64().expect("a warm-up start was recorded"),
        w["cost"][1].as_f64().unwrap(),
    );
    eprintln!("horizons {horizons:.4e}, warm-ups {warm:.4e}");
    assert!(!w["above_floor"].as_array().unwrap().is_empty());
    assert!(warm < horizons, "{warm} vs {horizons}");
    assert_eq!(w["kept"], true);
    // Then the initial-positions refit (the isolated default) from the kept minimum.
    let r = &step["initial_positions_refit"];
    let (from, to) = (
        r["cost"][0].as_f64().unwrap(),
        r["cost"][1].as_f64().unwrap(),
    );
    assert!((from - warm).abs() <= 1e-12 * warm, "{from} vs {warm}");
    let after = step["fit"]["cost_after"].as_f64().unwrap();
    let kept = if r["kept"] == true { to } else { from };
    assert!((after - kept).abs() <= 1e-12 * kept, "{after} vs {kept}");
    let md = std::fs::read_to_string(d.path().join("out").join("report.md")).unwrap();
    assert!(
        md.contains("Warm-up start (`--warm-up-start on`") && md.contains("the warm-ups' kept"),
        "{md}"
    );
    assert!(
        md.contains("Initial-positions refit (`--initial-positions refit`"),
        "{md}"
    );
    let off = identify_isolated(
        d.path(),
        &start,
        "c1",
        &[
            &args[..],
            &["--warm-up-start", "off", "--initial-positions", "measured"],
        ]
        .concat(),
    );
    let step = &off["steps"][0];
    assert!(step["warm_up_start"].is_null());
    assert!(step["initial_positions_refit"].is_null());
    assert_eq!(step["fit"]["cost_after"].as_f64().unwrap(), horizons);
}

/// The initial-positions refit of a sequence step (`--initial-positions refit`, the
/// isolated default; `StepRefit::refit_initial_positions`): c1 on 20 s of Table 4.3's J4
/// chirp, fitted from the true values on a start that is not the file's: the record's
/// q4(0) moved by +5 σ (1e-3 rad). The fit absorbs such a start into its values (it stays
/// at the noise floor, but some values move beyond 2.5 of their standard errors). The
/// simulated truth starts q4 at 0, so the reference for the estimate is 0: the refit of
/// the kept minimum must bring the start there (within 0.5 σ), lower the cost, return every
/// value within 2 standard errors of the truth, and record its largest move (the
/// estimate − start, in σ̂). Options that estimate the starts in every start already, and
/// a fit above the noise floor (its residual is the model's error, which the starts would
/// absorb), get no refit.
#[test]
fn the_initial_positions_refit_estimates_a_start_the_first_sample_missed() {
    use lockstep::identify::sequence::StepRefit;
    let d = tempfile::tempdir().unwrap();
    let (truth, start, names, at_truth) = c1_j4_at_truth(d.path());
    let (conf, mut rec) = c1_record(d.path(), &truth);
    let displaced = 1e-3;
    rec.q_all[4] += displaced;
    let problem = Problem::new(
        &start,
        conf,
        names.clone(),
        vec![rec.clone()],
        &[4],
        OutputErrorOptions {
            h: 1.0 / 12000.0,
            horizons: vec![1.0],
            ..OutputErrorOptions::isolated()
        },
    )
    .unwrap();
    let fit = problem.fit(&|_| {}).unwrap();
    let ratio = |f: &lockstep::identify::output_error::FitResult| {
        f.statistics.joints[0].rms_fitted / f.statistics.joints[0].noise
    };
    let refit = StepRefit {
        problem: &problem,
        interest: &[4],
        held_ties: &[],
        progress: &|_| {},
    };
    let (kept, record) = refit.refit_initial_positions(&start, fit.clone()).unwrap();
    let r = record.expect("measured starts: a refit");
    let offset = kept.initial_positions.as_ref().expect("estimated starts")[0][0];
    eprintln!(
        "measured start: cost {:.5e}, RMS/σ̂ {:.3}; refit: cost {:.5e}, RMS/σ̂ {:.3}, estimate − start {offset:.3e} rad, largest move {:.2} σ̂; {}",
        fit.cost_after,
        ratio(&fit),
        kept.cost_after,
        ratio(&kept),
        r.largest_move,
        r.work.status
    );
    let z = |f: &lockstep::identify::output_error::FitResult| -> Vec<f64> {
        (0..names.len())
            .map(|i| (f.fitted[i] - at_truth[i]) / f.statistics.std_err[i])
            .collect()
    };
    let (z_measured, z_refit) = (z(&fit), z(&kept));
    eprintln!("z = (fitted − truth) / standard error: measured start {z_measured:.2?}, refit {z_refit:.2?}");
    let worst = |z: &[f64]| z.iter().map(|x| x.abs()).fold(0.0, f64::max);
    assert!(
        worst(&z_measured) > 2.5,
        "the displaced start biases: {z_measured:?}"
    );
    assert!(worst(&z_refit) < 2.0, "the estimated start: {z_refit:?}");
    assert_eq!(r.cost.0, fit.cost_after + fit.prior_penalty);
    assert!(r.kept && r.cost.1 < r.cost.0, "{:?}", r.cost);
    assert_eq!(kept.cost_after, r.cost.1);
    assert!(ratio(&kept) <= 1.1, "the estimated start: {}", ratio(&kept));
    // The true start is 0: the estimate lands there, not at the displaced record's.
    let estimated_start = rec.q_all[4] + offset;
    assert!(
        estimated_start.abs() < 1e-4,
        "estimated q4(0) = {estimated_start:.3e} rad, record's {:.3e}",
        rec.q_all[4]
    );
    let noise = kept.statistics.joints[0].noise;
    assert!(
        (r.largest_move - offset.abs() / noise).abs() < 1e-9,
        "{} against {}",
        r.largest_move,
        offset.abs() / noise
    );
    assert_eq!(kept.evaluations, fit.evaluations + r.work.evaluations);
    // The step's history is the first fit's.
    assert_eq!(kept.initial, fit.initial);
    assert_eq!(kept.cost_before, fit.cost_before);
    // Options that estimate the starts already: no refit.
    let estimating = Problem::new(
        &start,
        conf,
        names,
        vec![rec],
        &[4],
        OutputErrorOptions {
            estimate_initial_positions: true,
            ..problem.options().clone()
        },
    )
    .unwrap();
    let (same, none) = StepRefit {
        problem: &estimating,
        ..refit
    }
    .refit_initial_positions(&start, fit.clone())
    .unwrap();
    assert!(none.is_none());
    assert_eq!(same.fitted, fit.fitted);
    // A fit above the noise floor: no refit.
    let mut above = fit.clone();
    above.statistics.above_floor.push("q4 RMS 2.000 σ̂".into());
    let (same, none) = refit.refit_initial_positions(&start, above).unwrap();
    assert!(none.is_none());
    assert_eq!(same.fitted, fit.fitted);
}

/// The written plant on every step's files (`SequenceReport::final_check`): c1 on 20 s of
/// Table 4.3's J4 chirp, fitted from the truth. With the fitted plant the check repeats the
/// step's own figure (the starts estimated in both: within 5 %, at the floor); with the
/// plant gain alone moved by 20 % — what a later step does to an earlier one when it moves
/// a member of that step's gain family without the rest — the joint is far above the floor,
/// and the check says so.
#[test]
fn the_final_check_repeats_a_steps_figure_and_sees_a_later_move_of_its_values() {
    use lockstep::identify::sequence::{final_check, Step, StepReport};
    let d = tempfile::tempdir().unwrap();
    let (truth, start, names, _) = c1_j4_at_truth(d.path());
    let (conf, rec) = c1_record(d.path(), &truth);
    let problem = Problem::new(
        &start,
        conf,
        names.clone(),
        vec![rec],
        &[4],
        OutputErrorOptions {
            h: 1.0 / 12000.0,
            horizons: vec![1.0],
            estimate_initial_positions: true,
            ..OutputErrorOptions::isolated()
        },
    )
    .unwrap();
    let fit = problem.fit(&|_| {}).unwrap();
    let mut fitted = start.clone();
    fit.apply(&mut fitted);
    let report = StepReport::of(
        Step {
            config: "c1".into(),
            free: vec![4],
            interest: vec![4],
            fitted: names.clone(),
            carried: Vec::new(),
            held: Vec::new(),
            tied_held: Vec::new(),
        },
        fit,
    );
    let same = &final_check(&fitted, &[(&report, &problem)])[0];
    let (end, written) = (same.joints[0].1.unwrap(), same.joints[0].2.unwrap());
    eprintln!("c1 q4 RMS / σ̂: step {end:.3}, written plant {written:.3}");
    assert!(
        end < 1.1 && (written - end).abs() < 0.05 * end,
        "{end} {written}"
    );
    assert!(!same.above_floor());
    let mut moved = fitted.clone();
    let kp = moved.parameters["Kp_q4"];
    moved.parameters.insert("Kp_q4".into(), 1.2 * kp);
    let broken = &final_check(&moved, &[(&report, &problem)])[0];
    let written = broken.joints[0].2.unwrap();
    eprintln!("with Kp_q4 × 1.2: {written:.1} σ̂");
    assert!(written > 10.0, "{written}");
    assert!(broken.above_floor());
}

/// c2 then c3 of the isolated method, each run alone (`--config`, options `more`) from the
/// Appendix D initial guess on 20 s of Table 4.3's J5 and J3 chirps made from the truth in
/// `dir`: the report after c3.
fn c2_then_c3(dir: &Path, more: &[&str]) -> serde_json::Value {
    let truth_file = truth(dir);
    make_data(dir, &truth_file, "4.3", Some("J5"), "c2", "20");
    make_data(dir, &truth_file, "4.3", Some("J3"), "c3", "20");
    let initial = plants().join("freedom6s_appendix_d_initial.toml");
    let c2 = identify_isolated(dir, &initial, "c2", more);
    assert_eq!(c2["steps"][0]["step"]["config"], "c2");
    let plant = dir.join("c2_plant.toml");
    std::fs::copy(dir.join("out/plant.toml"), &plant).unwrap();
    identify_isolated(dir, &plant, "c3", more)
}

/// The earlier steps' information (`--earlier-information`, the isolated default): c2 then
/// c3 of the isolated method, each run alone (`--config`) from the Appendix D initial
/// guess on 20 s of Table 4.3's J5 and J3 chirps made from the truth. c3 refits z7, I7_11
/// and m7, which c2 holds and sees through its inertia and gravity: under c2's information
/// c2's gain family (Kp_q5 and joint 5's friction) follows c3's moves, and where the
/// second-order term still leaves c2's files off, they are refitted on them. The written
/// plant must reproduce both steps' files at the floor, and the report must show c2's files
/// off after c3 before that refit (else c3 did not disturb c2 and the test shows nothing).
#[test]
#[ignore = "slow end-to-end identification (minutes); cargo test --release -- --ignored"]
fn a_later_step_keeps_the_earlier_steps_files_under_their_information() {
    let d = tempfile::tempdir().unwrap();
    let report = c2_then_c3(d.path(), &[]);
    let c3 = &report["steps"][1];
    assert_eq!(c3["step"]["config"], "c3");
    assert_eq!(c3["earlier_information"], true);
    let moved: Vec<&str> = c3["following"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f[0].as_str().unwrap())
        .collect();
    eprintln!("followed c3: {moved:?}");
    assert!(moved.contains(&"Kp_q5"), "{moved:?}");
    let refits = c3["earlier_refits"].as_array().unwrap();
    for r in refits {
        eprintln!("after c3: {}'s files {} σ̂", r["config"], r["rms"]);
    }
    let off = refits
        .iter()
        .find(|r| r["config"] == "c2")
        .expect("c2's files rose after c3");
    assert!(off["rms"][1].as_f64().unwrap() > 1.5, "{off}");
    let checks = report["final_check"].as_array().unwrap();
    eprintln!("final check: {}", report["final_check"]);
    let configs: Vec<&str> = checks
        .iter()
        .map(|c| c["config"].as_str().unwrap())
        .collect();
    assert_eq!(configs, ["c2", "c3"]);
    for c in checks {
        let written = c["joints"][0][2].as_f64().unwrap();
        assert!(written <= 1.1, "{c}");
    }
}

/// The earlier steps' files checked after the last step without the earlier information
/// (`--earlier-information off`, the coupled default; `--earlier-refit on`): the same c2
/// then c3 as above, c3 run alone. c3 refits z7, I7_11 and m7, which c2 sees through its
/// inertia and gravity, with nothing to keep c2's combination, so c2's files must be off
/// after c3 (else the test shows nothing) and c2's own values that c3's files do not see
/// refitted on them, bringing both steps' files to the floor in the written plant.
#[test]
#[ignore = "slow end-to-end identification (minutes); cargo test --release -- --ignored"]
fn without_the_earlier_information_the_last_step_refits_the_earlier_files_it_left_off() {
    let d = tempfile::tempdir().unwrap();
    let report = c2_then_c3(d.path(), &["--earlier-information", "off"]);
    let c3 = &report["steps"][1];
    assert_eq!(c3["step"]["config"], "c3");
    assert_eq!(c3["earlier_information"], false);
    let refits = c3["earlier_refits"].as_array().unwrap();
    for r in refits {
        eprintln!(
            "after c3: {}'s files {} σ̂, refitted {}",
            r["config"], r["rms"], r["names"]
        );
    }
    let c2 = refits
        .iter()
        .find(|r| r["config"] == "c2")
        .expect("c2's files rose after c3");
    assert!(c2["rms"][1].as_f64().unwrap() > 1.5, "{c2}");
    assert!(!c2["names"].as_array().unwrap().is_empty(), "{c2}");
    eprintln!("final check: {}", report["final_check"]);
    for c in report["final_check"].as_array().unwrap() {
        let written = c["joints"][0][2].as_f64().unwrap();
        assert!(written <= 1.1, "{c}");
    }
}

/// The residual's whiteness (`Problem::whiteness`, the Ljung–Box test of MATLAB `resid`),
/// what the sequence's whiteness start reads at the floor: c1 on 20 s of Table 4.3's J4
/// chirp made from the truth (RK4 at the simulator's step, the fit's), with the initial
/// position estimated. At the truth the residual is the sensor's noise, white; with Kp_q4
/// 1e-5 off — an RMS still within 1.5 σ̂, as a wrong minimum near the floor is — it is not.
#[test]
fn the_residual_at_the_truth_is_white_and_a_small_error_is_not() {
    let d = tempfile::tempdir().unwrap();
    let (truth, start, names, at_truth) = c1_j4_at_truth(d.path());
    let (conf, rec) = c1_record(d.path(), &truth);
    let problem = Problem::new(
        &start,
        conf,
        names.clone(),
        vec![rec],
        &[4],
        OutputErrorOptions {
            h: 1.0 / 12000.0,
            ..OutputErrorOptions::isolated()
        },
    )
    .unwrap();
    let at = problem.with_initial_positions_of(&start).unwrap();
    let white = at.whiteness(&at_truth).unwrap();
    eprintln!("at the truth: {}", white[0].1.text());
    assert_eq!(white[0].0, "q4");
    assert!(white[0].1.white(), "{}", white[0].1.text());
    let k = names.iter().position(|n| n == "Kp_q4").unwrap();
    let mut off = at_truth.clone();
    off[k] *= 1.0 + 1e-5;
    let mut moved = start.clone();
    moved.set_values(&names, &off);
    let at = problem.with_initial_positions_of(&moved).unwrap();
    let coloured = at.whiteness(&off).unwrap();
    let rms = at.joint_fits(
        &at.records
            .iter()
            .map(|r| at.simulate(&moved, r).unwrap())
            .collect::<Vec<_>>(),
    )[0]
    .floor_ratio()
    .unwrap();
    eprintln!(
        "Kp_q4 × (1 + 1e-5): {}, RMS {rms:.2} σ̂",
        coloured[0].1.text()
    );
    assert!(rms < 1.5, "{rms}");
    assert!(!coloured[0].1.white(), "{}", coloured[0].1.text());
}
