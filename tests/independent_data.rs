//! The model-versus-measurement loop on data lockstep did not make (issue 53): files from
//! `common::independent` (Dop853 on the continuous excitation, its own noise; the side
//! file declares `hold = "bandlimited"`). The truth plant must sit at the sensor's noise
//! with the hold the file declares, and the diagnosis must say nothing is missing.

mod common;

use common::independent::{self, Spec};
use lockstep::compare::compare_output;
use lockstep::diagnose::apply::{change_text, MAX_APPLIED_STEPS};
use lockstep::diagnose::{
    apply_all_significant, diagnose_output, Finding, LoopEnd, OutputOptions, Turn,
};
use lockstep::effects::EffectKind;
use lockstep::identify::output_error::Record;
use lockstep::identify::refit::RefitOptions;
use lockstep::identify::sequence::read_record;
use lockstep::plant::Plant;
use lockstep::simulation::Hold;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// The independent file of `spec` for the truth plant, read as a record: written once per
/// test run under Cargo's scratch directory for integration tests (each file costs about
/// a second per simulated second), shared by the tests of this binary.
fn record(spec: &Spec) -> Record {
    static MADE: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());
    let truth = common::appendix_d_coupled();
    let dir =
        Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("independent-{}", std::process::id()));
    let path = dir.join(format!(
        "{}_{}_{}_{}s.csv",
        spec.config,
        if spec.noise > 0.0 { "noisy" } else { "exact" },
        spec.seed,
        spec.duration
    ));
    {
        let mut made = MADE.lock().unwrap_or_else(|e| e.into_inner());
        if !made.contains(&path) {
            std::fs::create_dir_all(&dir).unwrap();
            independent::write(&truth, spec, &path);
            made.push(path.clone());
        }
    }
    let m = truth.model;
    read_record(&path, m, m.configuration(spec.config).unwrap(), 0.01)
        .unwrap_or_else(|e| panic!("{e:#}"))
}

fn spec<'a>(config: &'a str, table: &'a str, test: Option<&'a str>) -> Spec<'a> {
    Spec {
        config,
        table,
        test,
        duration: 15.0,
        noise: common::SENSOR_NOISE,
        quantisation: common::SENSOR_QUANTISATION,
        seed: 17,
    }
}

/// The files of the hidden-effect cases: 8 s (each case runs two to four diagnoses and
/// their refits; the truth's files are 15 s).
fn hidden_spec<'a>(config: &'a str, table: &'a str, test: Option<&'a str>) -> Spec<'a> {
    Spec {
        duration: 8.0,
        ..spec(config, table, test)
    }
}

/// The cases of the acceptance: single joints (c3, c2), the base pair with the friction
/// bias (c7), the wrist (k1) and three coupled joints (k3), with the bound on RMS/σ of the
/// truth: for the single joints 1 + 3/√(2n), n = 800 samples of an 8 s file (the RMS of n
/// white samples has relative standard deviation 1/√(2n): 2.5 %; c7's q0 measured 1.059
/// on the 8 s file, 1.05 was the bound for the 15 s files).
const CASES: [(&str, &str, Option<&str>, f64); 5] = [
    ("c3", "4.3", Some("J3"), 1.075),
    ("c2", "4.3", Some("J5"), 1.075),
    ("c7", "4.4", Some("J01-1"), 1.075),
    ("k1", "4.7", None, 1.2),
    ("k3", "4.7", None, 1.2),
];

/// Noise-free, the two simulators agree where the input is reconstructed as the
/// continuous signal it was: on the wrist (k1, whose motion amplifies any difference over
/// 15 s) lockstep's RK4 at 1/12000 s with the band-limited or cubic hold is within σ/4
/// (RMS) of Dop853 on the continuous formula (measured: 2.1e-5 rad, σ/10); with the
/// zero-order hold (the input delayed by half a sample) it is 5e-2 rad off.
#[test]
fn the_simulator_reproduces_an_independent_integrator_on_a_continuous_input() {
    let truth = common::appendix_d_coupled();
    let rec = record(&Spec {
        noise: 0.0,
        quantisation: 0.0,
        ..spec("k1", "4.7", None)
    });
    let deviation = |hold, h| {
        let c = compare_output(
            &truth,
            "k1",
            std::slice::from_ref(&rec),
            &RefitOptions {
                h,
                hold: Some(hold),
                estimate_initial: false,
                ..RefitOptions::default()
            },
        )
        .unwrap();
        let max = c
            .comparisons
            .iter()
            .map(|x| x.max_error.0.abs())
            .fold(0.0, f64::max);
        let rms = c.comparisons.iter().map(|x| x.rmse).fold(0.0, f64::max);
        eprintln!("k1 noise-free, {hold} at {h:e} s ({}): largest |q - q_independent| {max:.3e}, RMS {rms:.3e}", c.step.summary());
        rms
    };
    let band = deviation(Hold::Bandlimited, 1.0 / 12000.0);
    let cubic = deviation(Hold::Cubic, 1.0 / 12000.0);
    let zoh = deviation(Hold::Zoh, 1.0 / 12000.0);
    assert!(cubic < common::sensor_sigma() / 4.0, "cubic {cubic}");
    assert!(band < common::sensor_sigma() / 4.0, "bandlimited {band}");
    assert!(zoh > 100.0 * band, "zoh {zoh} vs bandlimited {band}");
}

/// The truth plant, compared as a user would (default options: the file's declared hold,
/// the default step checked and refined) on the 8 s files of the hidden-effect cases, sits at the sensor's noise on every joint; the
/// comparison names the hold it used and, with the zero-order hold forced on these data,
/// reports that another hold fits markedly better.
#[test]
fn the_truth_sits_at_the_noise_floor_on_independent_data() {
    let truth = common::appendix_d_coupled();
    let sigma = common::sensor_sigma();
    let mut worst = Vec::new();
    for (config, table, test, bound) in CASES {
        let rec = record(&hidden_spec(config, table, test));
        assert_eq!(rec.hold, Hold::Bandlimited);
        let c = compare_output(
            &truth,
            config,
            std::slice::from_ref(&rec),
            &RefitOptions::default(),
        )
        .unwrap();
        assert_eq!(c.holds, vec![Hold::Bandlimited]);
        eprintln!("{config}: {}", c.step.summary());
        for j in &c.comparisons {
            let ratio = j.rmse / sigma;
            eprintln!("{config} {}: RMS {:.4e} = {ratio:.3} σ", j.joint, j.rmse);
            assert!(
                ratio <= bound,
                "{config} {}: {ratio:.3} σ > {bound}",
                j.joint
            );
            worst.push(ratio);
        }
        if config == "c3" {
            let forced = compare_output(
                &truth,
                config,
                std::slice::from_ref(&rec),
                &RefitOptions {
                    hold: Some(Hold::Zoh),
                    ..RefitOptions::default()
                },
            )
            .unwrap();
            let better = forced.better_hold().map(|b| b.0);
            assert!(
                matches!(better, Some(Hold::Cubic | Hold::Bandlimited | Hold::Linear)),
                "{:?}",
                forced.hold_errors
            );
        }
    }
    eprintln!("worst {:.3} σ", worst.iter().fold(0.0f64, |a, &b| a.max(b)));
}

/// With nothing missing, the diagnosis says so on independent data (the 8 s files), with
/// its defaults: no significant finding, every joint's residual white enough and within
/// its noise, so no structure search and no built-in outside the catalogue (issue 54: no
/// false alarm on c3, c2, c7, k1, k3).
#[test]
fn nothing_is_missing_from_the_truth_on_independent_data() {
    let truth = common::appendix_d_coupled();
    for (config, table, test, _) in CASES {
        let rec = record(&hidden_spec(config, table, test));
        let d = diagnose_output(&truth, config, &[rec], &OutputOptions::default()).unwrap();
        let text = d.table(4);
        eprintln!("{config}: {}\n{text}", d.step.summary());
        assert!(!d.findings[0].significant, "{config}:\n{text}");
        assert!(
            d.above_noise.is_empty() && d.not_white.is_empty(),
            "{config}: {:?} {:?}",
            d.above_noise,
            d.not_white
        );
        assert!(
            !d.findings.iter().any(|f| f.expression.is_some()),
            "{config}:\n{text}"
        );
        assert!(text.contains("nothing significant is missing"), "{text}");
    }
}

/// The independent file of `spec` for `truth` (tagged `tag` in its name), read as a record.
fn record_of(truth: &lockstep::plant::Plant, tag: &str, spec: &Spec) -> Record {
    let dir =
        Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("independent-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(format!("{tag}_{}_{}.csv", spec.config, spec.seed));
    independent::write(truth, spec, &path);
    let m = truth.model;
    read_record(&path, m, m.configuration(spec.config).unwrap(), 0.01)
        .unwrap_or_else(|e| panic!("{e:#}"))
}

/// How close a hidden value must come back.
#[derive(Clone, Copy)]
enum Within {
    /// Relative error at most this.
    Relative(f64),
    /// The record cannot determine the value (a Stribeck level and velocity trade off
    /// exactly on some records): the refit must say "not determined" and the truth must
    /// lie within two of its standard errors.
    Undetermined,
}

/// A hidden-effect case: `start` is `truth` without one effect (or with it changed).
/// The first diagnosis must name `expect` (kind, joint, from) first, or list it as
/// indistinguishable from the first; `--apply all-significant` (joint refits) must end
/// with nothing significant missing, every joint within `bound` σ, and the hidden values
/// as `hidden` says.
fn hidden_case(
    truth: &Plant,
    start: &Plant,
    tag: &str,
    s: Spec,
    expect: ((EffectKind, &str, Option<&str>), bool),
    hidden: &[(&str, Within)],
    bound: f64,
) {
    hidden_case_on(truth, start, tag, &[s], expect, hidden, bound)
}

/// [`hidden_case`] on several records of one configuration (`specs`, the first naming it).
fn hidden_case_on(
    truth: &Plant,
    start: &Plant,
    tag: &str,
    specs: &[Spec],
    (expect, first_only): ((EffectKind, &str, Option<&str>), bool),
    hidden: &[(&str, Within)],
    bound: f64,
) {
    let s = specs[0];
    let owned: Vec<Record> = specs.iter().map(|x| record_of(truth, tag, x)).collect();
    let records = owned.as_slice();
    let done = apply_all_significant(
        start,
        s.config,
        records,
        &OutputOptions::default(),
        MAX_APPLIED_STEPS,
        &|turn| {
            let Turn::Applied(step) = turn else { return };
            eprintln!(
                "{tag} {}: {} ({:.1} %), values {:?}, alike {:?}\n{}",
                s.config,
                change_text(&step.finding),
                100.0 * step.finding.explained,
                step.finding.values,
                step.finding.alike,
                lockstep::report::diagnosis::refit_table(&step.refit)
            )
        },
    )
    .unwrap();
    eprintln!(
        "{tag} {}: {}\n{}",
        s.config,
        done.end,
        lockstep::diagnose::table(&done.last.findings, 4)
    );
    let first = &done.steps.first().expect("a step applied").finding;
    let named = |f: &Finding| {
        f.kind == Some(expect.0) && f.joint == expect.1 && f.from.as_deref() == expect.2
    };
    let wanted = match expect.2 {
        Some(from) => format!("{} from {from} on {}", expect.0, expect.1),
        None => format!("{} on {}", expect.0, expect.1),
    };
    eprintln!(
        "{tag} {}, first diagnosis:\n{}",
        s.config,
        lockstep::diagnose::table(&done.first.findings, 6)
    );
    if first_only {
        assert!(
            named(first) || first.alike.iter().any(|a| a.starts_with(&wanted)),
            "{tag}: first finding {} on {} ({:?}), expected {wanted}",
            first.name,
            first.joint,
            first.from
        );
    } else {
        // Two effects missing at once: the one expected is significant in the first
        // diagnosis, and the joint refits sort out the rest.
        assert!(
            done.first
                .findings
                .iter()
                .any(|f| named(f) && f.significant),
            "{tag}: {wanted} not significant in the first diagnosis"
        );
    }
    assert_eq!(done.end, LoopEnd::NothingMissing, "{tag}");
    // The loop ends with the truth's effects, no more (a stand-in taken up on the way is
    // removed once a joint refit takes it back to no effect).
    let kinds = |p: &Plant| {
        let mut v: Vec<String> = p
            .effects
            .iter()
            .map(|e| format!("{:?} {} {:?}", e.kind, e.joint, e.from))
            .collect();
        v.sort();
        v
    };
    for r in &done.removed {
        eprintln!("{tag}: {r}");
    }
    assert_eq!(
        kinds(&done.plant),
        kinds(truth),
        "{tag}: the effects at the end"
    );
    for (name, tol) in hidden {
        let (fitted, true_value) = (done.plant.parameters[*name], truth.parameters[*name]);
        let err = (fitted / true_value - 1.0).abs();
        // What the last fit of the value says of it: standard error, determined or not.
        let (se, determined) = done
            .steps
            .iter()
            .rev()
            .find_map(|s| {
                let f = &s.refit.fit;
                let i = f.names.iter().position(|n| n == name)?;
                Some((f.statistics.std_err[i], f.statistics.identifiable[i]))
            })
            .expect("the hidden value was fitted");
        eprintln!(
            "{tag}: {name} = {fitted:.6e} ± {se:.2e} ({}), truth {true_value:.6e} ({:.2} %, {:.2} standard errors)",
            if determined { "determined" } else { "not determined" },
            100.0 * err,
            (fitted - true_value).abs() / se
        );
        match tol {
            Within::Relative(tol) => {
                assert!(err <= *tol, "{tag}: {name} = {fitted}, truth {true_value}")
            }
            Within::Undetermined => assert!(
                !determined && (fitted - true_value).abs() <= 2.0 * se,
                "{tag}: {name} = {fitted} ± {se}, truth {true_value}"
            ),
        }
    }
    let c = compare_output(&done.plant, s.config, records, &RefitOptions::default()).unwrap();
    for j in &c.comparisons {
        let ratio = j.rmse / common::sensor_sigma();
        eprintln!("{tag} {}: {} RMS {ratio:.3} σ", s.config, j.joint);
        assert!(ratio <= bound, "{tag} {}: {ratio:.3} σ > {bound}", j.joint);
    }
}

/// A cable-drag spring missing on q3 (c3).
#[test]
fn hidden_spring_on_independent_data_c3() {
    let truth = common::appendix_d_coupled();
    let mut start = truth.clone();
    start
        .effects
        .retain(|e| !(e.kind == EffectKind::Spring && e.joint == 3));
    hidden_case(
        &truth,
        &start,
        "spring",
        hidden_spec("c3", "4.3", Some("J3")),
        ((EffectKind::Spring, "q3", None), true),
        &[
            ("Ks_q3", Within::Relative(0.02)),
            ("qeq_q3", Within::Relative(0.05)),
        ],
        1.1,
    );
}

/// The friction position bias missing on q0 and q1 (c7): two steps.
#[test]
fn hidden_friction_bias_on_independent_data_c7() {
    let truth = common::appendix_d_coupled();
    let mut start = truth.clone();
    start
        .effects
        .retain(|e| !(e.kind == EffectKind::FrictionBias && e.joint <= 1));
    hidden_case(
        &truth,
        &start,
        "bias",
        hidden_spec("c7", "4.4", Some("J01-1")),
        ((EffectKind::FrictionBias, "q0", None), true),
        &[
            ("FrictionBias_q0", Within::Relative(0.02)),
            ("FrictionBias_q1", Within::Relative(0.02)),
        ],
        1.1,
    );
}

/// A plant gain 30 % above the starting plant's on q2 (c4).
#[test]
fn hidden_gain_error_on_independent_data_c4() {
    let mut truth = common::appendix_d_coupled();
    let kp = truth.parameters["Kp_q2"];
    truth.parameters.insert("Kp_q2".into(), 1.3 * kp);
    let start = common::appendix_d_coupled();
    hidden_case(
        &truth,
        &start,
        "gain",
        hidden_spec("c4", "4.3", Some("J2")),
        ((EffectKind::Gain, "q2", None), true),
        &[("Kp_q2", Within::Relative(0.02))],
        1.1,
    );
}

/// Both directions of the tendon coupling missing on the wrist (k1): two effects missing
/// at once, so no single candidate explains the residual and the first fitted may be a
/// stand-in (measured: a friction bias on q4, 51 % against 45 % for the 4 → 5 coupling);
/// the couplings must be significant from the start, and the joint refits must end with
/// both at the truth and the stand-in removed.
#[test]
#[ignore = "slow end-to-end diagnosis (minutes); cargo test --release -- --ignored"]
fn hidden_tendon_coupling_on_independent_data_k1() {
    let truth = common::appendix_d_coupled();
    let mut start = truth.clone();
    start
        .effects
        .retain(|e| e.kind != EffectKind::InputCoupling);
    hidden_case(
        &truth,
        &start,
        "coupling",
        hidden_spec("k1", "4.7", None),
        ((EffectKind::InputCoupling, "q5", Some("q4")), false),
        &[
            ("G_q4_to_q5", Within::Relative(0.02)),
            ("G_q5_to_q4", Within::Relative(0.02)),
        ],
        1.1,
    );
}

/// The tendon coupling 5 → 4 present with its sign flipped (k1): not a missing effect but
/// a wrong one, which the catalogue offers as the existing coupling's gain off (either
/// sign). A 4 s file: one step, the sign is plain on it.
#[test]
fn a_coupling_with_its_sign_flipped_is_found_and_refitted_k1() {
    let truth = common::appendix_d_coupled();
    let mut start = truth.clone();
    let g = truth.parameters["G_q5_to_q4"];
    start.parameters.insert("G_q5_to_q4".into(), -g);
    hidden_case(
        &truth,
        &start,
        "sign",
        Spec {
            duration: 4.0,
            ..hidden_spec("k1", "4.7", None)
        },
        ((EffectKind::InputCoupling, "q4", Some("q5")), true),
        &[("G_q5_to_q4", Within::Relative(0.02))],
        1.1,
    );
}

/// The spring on q3 present with its rest angle 0.37 rad off (c3): the catalogue offers
/// the existing equilibrium position as a candidate. It is exactly a torque offset of
/// −Ks·Δqeq (equal ΔBIC, reported as indistinguishable), and the change of a value the plant
/// already has goes first. A 4 s file.
#[test]
fn a_spring_rest_angle_off_is_found_and_refitted_c3() {
    let truth = common::appendix_d_coupled();
    let mut start = truth.clone();
    start.parameters.insert("qeq_q3".into(), 0.0);
    hidden_case(
        &truth,
        &start,
        "rest-angle",
        Spec {
            duration: 4.0,
            ..hidden_spec("c3", "4.3", Some("J3"))
        },
        ((EffectKind::Spring, "q3", None), true),
        &[("qeq_q3", Within::Relative(0.05))],
        1.1,
    );
}

/// The truth with a strong Stribeck hump in q5's LuGre friction (Fs = 5 Fc, vs = 0.1
/// rad/s), and the start without it (Fs = Fc).
fn stribeck_truth_and_start() -> (Plant, Plant) {
    let mut truth = common::appendix_d_coupled();
    truth.parameters.insert("Fs_q5".into(), 0.1);
    truth.parameters.insert("vs_q5".into(), 0.1);
    let mut start = truth.clone();
    start.parameters.insert("Fs_q5".into(), 0.02);
    (truth, start)
}

/// A strong Stribeck hump in q5's LuGre friction that the starting plant lacks (c2).
#[test]
fn hidden_stribeck_on_independent_data_c2() {
    let (truth, start) = stribeck_truth_and_start();
    hidden_case(
        &truth,
        &start,
        "stribeck",
        hidden_spec("c2", "4.3", Some("J5")),
        ((EffectKind::Stribeck, "q5", None), true),
        &[
            ("Fs_q5", Within::Undetermined),
            ("vs_q5", Within::Undetermined),
        ],
        1.1,
    );
}

/// LuGre friction on q5 modelled as static (Stribeck with the same Fc, Fs, vs, and its σ2
/// as viscous friction): the bristles' deflection before sliding, Fc/σ0 ≈ 0.09 rad at
/// every reversal, is what the static law lacks. The diagnosis offers LuGre in the law's
/// place, names it first and `--apply` takes q5 to the noise with σ0 back (c2).
#[test]
fn lugre_presliding_replaces_a_static_law_c2() {
    let truth = common::appendix_d_coupled();
    let mut start = truth.clone();
    start
        .effects
        .retain(|e| !(e.kind == EffectKind::Lugre && e.joint == 5));
    start
        .add_effect(lockstep::effects::Effect::on(EffectKind::Stribeck, 5))
        .unwrap();
    start
        .add_effect(lockstep::effects::Effect::on(EffectKind::Viscous, 5))
        .unwrap();
    let sigma2 = truth.parameters["sigma2_q5"];
    start.parameters.insert("Fv_q5".into(), sigma2);
    start.bounds.insert("Fv_q5".into(), (0.0, 10.0 * sigma2));
    for s in ["sigma0_q5", "sigma1_q5", "sigma2_q5"] {
        start.parameters.remove(s);
        start.bounds.remove(s);
    }
    hidden_case(
        &truth,
        &start,
        "lugre",
        hidden_spec("c2", "4.3", Some("J5")),
        ((EffectKind::Lugre, "q5", None), true),
        &[("sigma0_q5", Within::Relative(0.05))],
        1.1,
    );
}

/// The same hump where a record dwells near vs: with a slow sine (Table 4.4's J5-1, 0.5
/// rad/s: the joint sticks and breaks away each half period, its speed passing slowly
/// through vs) beside the chirp, Fs and vs no longer trade off and come back determined.
#[test]
fn hidden_stribeck_determined_where_a_record_dwells_near_vs_c2() {
    let (truth, start) = stribeck_truth_and_start();
    let chirp = hidden_spec("c2", "4.3", Some("J5"));
    let slow = Spec {
        seed: chirp.seed + 1,
        ..hidden_spec("c2", "4.4", Some("J5-1"))
    };
    hidden_case_on(
        &truth,
        &start,
        "stribeck-dwell",
        &[chirp, slow],
        ((EffectKind::Stribeck, "q5", None), true),
        &[
            ("Fs_q5", Within::Relative(0.02)),
            ("vs_q5", Within::Relative(0.05)),
        ],
        1.1,
    );
}

/// The starting plant a user really has: `plant` with every rigid-body value (the model's
/// inertial symbols) and every friction value of the joints `joints` 10 % off, up or down
/// by a seeded coin, and bounds to refit them in: the thesis's rule for the inertial
/// symbols (mass ±50 %, centroid ±30 %, inertia ±120 %), ±50 % for the friction values.
fn ten_percent_off(plant: &Plant, joints: &[usize], seed: u64) -> Plant {
    let mut p = plant.clone();
    let mut state = seed;
    let mut coin = move || {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        if (state >> 63) == 1 {
            1.1
        } else {
            0.9
        }
    };
    for s in p.model.inertial_symbols {
        if let Some(v) = p.parameters.get_mut(*s) {
            *v *= coin();
        }
    }
    p.apply_thesis_bounds();
    let friction: Vec<String> = p
        .effects
        .iter()
        .filter(|e| joints.contains(&e.joint) && e.kind.is_friction_law())
        .flat_map(|e| e.parameter_names(p.model.joints))
        .collect();
    for name in friction {
        let v = p.parameters[&name] * coin();
        p.parameters.insert(name.clone(), v);
        p.bounds.insert(name, (0.5 * v, 1.5 * v));
    }
    p
}

/// A hidden-effect case from a start 10 % off: `truth` less `hidden` (kind and joint: the
/// effects of that kind on those joints removed), every rigid-body value and every
/// friction value of `joints` 10 % off (seeded). The first diagnosis (after its refit of
/// the configuration's values) must name the hidden effect first, or list it as
/// indistinguishable from the first; `--apply all-significant` must end with nothing
/// significant missing, the hidden effects in the plant and every joint within 1.2 σ.
fn from_ten_percent_off(tag: &str, s: Spec, hidden: (EffectKind, &[usize]), joints: &[usize]) {
    let truth = common::appendix_d_coupled();
    let mut start = truth.clone();
    start
        .effects
        .retain(|e| !(e.kind == hidden.0 && hidden.1.contains(&e.joint)));
    let start = ten_percent_off(&start, joints, 11);
    let rec = record_of(&truth, tag, &s);
    let records = std::slice::from_ref(&rec);
    let done = apply_all_significant(
        &start,
        s.config,
        records,
        &OutputOptions::default(),
        MAX_APPLIED_STEPS,
        &|turn| {
            let Turn::Applied(step) = turn else { return };
            eprintln!(
                "{tag}: {}\n{}",
                change_text(&step.finding),
                lockstep::report::diagnosis::refit_table(&step.refit)
            )
        },
    )
    .unwrap();
    eprintln!("{tag}, first diagnosis:\n{}", done.first.table(6));
    eprintln!("{tag}, end: {}\n{}", done.end, done.last.table(4));
    let c = compare_output(&done.plant, s.config, records, &RefitOptions::default()).unwrap();
    let worst = c
        .comparisons
        .iter()
        .map(|j| j.rmse / common::sensor_sigma())
        .fold(0.0, f64::max);
    eprintln!("{tag}: worst joint {worst:.3} σ");
    // The hidden effect first: of its kind on one of its joints (either direction of a
    // coupling), or listed as indistinguishable from the first.
    let first = &done.first.findings[0];
    let names: Vec<&str> = hidden.1.iter().map(|&j| truth.model.joints[j]).collect();
    let kind = hidden.0.to_string();
    let named = first.kind == Some(hidden.0) && names.contains(&first.joint.as_str());
    let alike = first
        .alike
        .iter()
        .any(|a| a.starts_with(&kind) && names.iter().any(|n| a.ends_with(&format!(" on {n}"))));
    assert!(
        named || alike,
        "{tag}: first finding {} on {} ({:?}), expected {kind} on one of {names:?}",
        first.name,
        first.joint,
        first.alike
    );
    assert_eq!(done.end, LoopEnd::NothingMissing, "{tag}");
    assert!(worst <= 1.2, "{tag}: {worst:.3} σ");
    // The effect named first is in the plant at the end (on the other joints the refitted
    // values may have taken its share: the acceptance asks for the first and the floor).
    let first_joint = truth
        .model
        .joints
        .iter()
        .position(|&n| n == first.joint)
        .unwrap();
    // An effect of the kind acting on joint j (an input coupling: one into j, which
    // `Plant::has_effect` does not count).
    let has = |j: usize| {
        done.plant
            .effects
            .iter()
            .any(|e| e.kind == hidden.0 && e.joint == j)
    };
    assert!(
        has(first_joint) || !named,
        "{tag}: no {} on {}",
        hidden.0,
        first.joint
    );
    for &j in hidden.1 {
        eprintln!(
            "{tag}: {} on {}: {}",
            hidden.0,
            truth.model.joints[j],
            has(j)
        );
    }
}

/// From a start 10 % off (every rigid-body value and q3's friction), the spring missing on
/// q3 (c3). Measured: the spring first (100 %, ΔBIC −9576 against the refitted values),
/// one step, 0.99 σ.
#[test]
#[ignore = "slow end-to-end diagnosis (minutes); cargo test --release -- --ignored"]
fn from_a_start_ten_percent_off_the_spring_is_found_c3() {
    from_ten_percent_off(
        "spring-off",
        hidden_spec("c3", "4.3", Some("J3")),
        (EffectKind::Spring, &[3]),
        &[3],
    );
}

/// From a start 10 % off (every rigid-body value and q0's and q1's friction), the friction
/// position bias missing on q0 and q1 (c7). Measured (20 min): the bias on q0 first (97 %,
/// ΔBIC −5613), then a small coupling q1 → q0; nothing missing at 1.07 σ. The bias on q1 is
/// not found again: with the 22 values refitted, q1 is at 1.1 σ after the first step.
#[test]
#[ignore = "slow end-to-end diagnosis (minutes); cargo test --release -- --ignored"]
fn from_a_start_ten_percent_off_the_bias_is_found_c7() {
    from_ten_percent_off(
        "bias-off",
        hidden_spec("c7", "4.4", Some("J01-1")),
        (EffectKind::FrictionBias, &[0, 1]),
        &[0, 1],
    );
}

/// From a start 10 % off (every rigid-body value and q4's and q5's friction), the tendon
/// couplings missing in both directions (k1). Measured (41 min, sharing the machine with a
/// build): the coupling q4 → q5 first (77.7 %, ΔBIC −2394), then q5 → q4; nothing missing at
/// 1.002 σ (G_q5_to_q4 −0.20345, truth −0.20362).
#[test]
#[ignore = "slow end-to-end diagnosis (minutes); cargo test --release -- --ignored"]
fn from_a_start_ten_percent_off_the_coupling_is_found_k1() {
    from_ten_percent_off(
        "coupling-off",
        hidden_spec("k1", "4.7", None),
        (EffectKind::InputCoupling, &[4, 5]),
        &[4, 5],
    );
}

/// The truth's model with every rigid-body value and q3's friction 10 % off (c3, nothing
/// missing): judged as it is, the plant looks incomplete (something significant); with
/// the configuration's values refitted first (the default, the plant giving bounds), the
/// diagnosis says nothing significant is missing and the refitted plant sits at the noise.
#[test]
fn values_merely_off_are_refitted_not_called_a_missing_effect_c3() {
    let truth = common::appendix_d_coupled();
    let start = ten_percent_off(&truth, &[3], 11);
    let s = hidden_spec("c3", "4.3", Some("J3"));
    let rec = record_of(&truth, "values-off", &s);
    let records = std::slice::from_ref(&rec);
    let as_is = diagnose_output(
        &start,
        "c3",
        records,
        &OutputOptions {
            refit_values: false,
            ..OutputOptions::default()
        },
    )
    .unwrap();
    eprintln!("as it is:\n{}", as_is.table(4));
    assert!(as_is.values_refit.is_none());
    assert!(as_is.findings[0].significant, "{}", as_is.verdict());
    let d = diagnose_output(&start, "c3", records, &OutputOptions::default()).unwrap();
    eprintln!("values refitted first:\n{}", d.table(4));
    let r = d.values_refit.as_ref().expect("the plant gives bounds");
    eprintln!(
        "{}\n{:?}",
        lockstep::report::diagnosis::refit_table(r),
        r.fit.starts.iter().map(|s| &s.status).collect::<Vec<_>>()
    );
    assert!(!d.findings[0].significant, "{}", d.verdict());
    assert!(
        d.verdict().starts_with("nothing significant is missing"),
        "{}",
        d.verdict()
    );
    assert!(d.above_noise.is_empty(), "{:?}", d.above_noise);
    for ((joint, before), (_, after)) in r.before.iter().zip(&r.after) {
        let ratio = after / common::sensor_sigma();
        eprintln!("{joint}: {before:.3e} → {after:.3e} ({ratio:.3} σ)");
        assert!(ratio <= 1.1, "{joint}: {ratio:.3} σ");
    }
    assert!(std::ptr::eq(d.judged(&start), &r.plant));
}

/// The warm-ups of the values' refit (`RefitOptions::warm_ups`): the base pair (c7) with
/// every rigid-body value and both joints' LuGre values 10 % off, nothing missing. The
/// configuration determines 22 values; from the growing horizons alone the refit stops in a
/// local minimum (measured: q0 0.037, q1 0.099 rad, 170 and 490 σ); the start through the
/// equation error and the prediction-error homotopy reaches q0 7.0e-4, q1 2.1e-4 rad.
#[test]
#[ignore = "slow refits (minutes); cargo test --release -- --ignored"]
fn the_warm_ups_take_the_values_refit_out_of_a_local_minimum_c7() {
    let truth = common::appendix_d_coupled();
    let s = hidden_spec("c7", "4.4", Some("J01-1"));
    let rec = record_of(&truth, "bias-off", &s);
    let records = std::slice::from_ref(&rec);
    let start = ten_percent_off(&truth, &[0, 1], 11);
    let names = lockstep::diagnose::apply::configuration_values(&start, "c7", records).unwrap();
    assert_eq!(names.len(), 22, "{names:?}");
    let worst = |warm_ups: bool| {
        let r = lockstep::identify::refit::refit(
            &start,
            &start,
            "c7",
            records,
            &names,
            &RefitOptions {
                max_iter: OutputOptions::default().values_max_iter,
                warm_ups,
                ..RefitOptions::default()
            },
        )
        .unwrap();
        eprintln!("warm-ups {warm_ups}: {:?} → {:?}", r.before, r.after);
        r.after
            .iter()
            .map(|(_, e)| e / common::sensor_sigma())
            .fold(0.0, f64::max)
    };
    let horizons = worst(false);
    let warm = worst(true);
    assert!(warm < 5.0, "through the warm-ups: {warm:.2} σ");
    assert!(
        warm < 0.1 * horizons,
        "through the warm-ups {warm:.2} σ, the horizons alone {horizons:.1} σ"
    );
}
