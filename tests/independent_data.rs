//! The model-versus-measurement loop on data lockstep did not make (issue 53): files from
//! `common::independent` (Dop853 on the continuous excitation, its own noise; the side
//! file declares `hold = "bandlimited"`). The truth plant must sit at the sensor's noise
//! with the hold the file declares, and the diagnosis must say nothing is missing.

mod common;

use common::independent::{self, Spec};
use lockstep::compare::compare_output;
use lockstep::diagnose::{diagnose_output, OutputOptions};
use lockstep::identify::output_error::Record;
use lockstep::identify::refit::RefitOptions;
use lockstep::identify::sequence::read_record;
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
        "{}_{}_{}.csv",
        spec.config,
        if spec.noise > 0.0 { "noisy" } else { "exact" },
        spec.seed
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

/// The cases of the acceptance: single joints (c3, c2), the base pair with the friction
/// bias (c7), the wrist (k1) and three coupled joints (k3).
const CASES: [(&str, &str, Option<&str>, f64); 5] = [
    ("c3", "4.3", Some("J3"), 1.05),
    ("c2", "4.3", Some("J5"), 1.05),
    ("c7", "4.4", Some("J01-1"), 1.05),
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
/// the default step checked and refined), sits at the sensor's noise on every joint; the
/// comparison names the hold it used and, with the zero-order hold forced on these data,
/// reports that another hold fits markedly better.
#[test]
fn the_truth_sits_at_the_noise_floor_on_independent_data() {
    let truth = common::appendix_d_coupled();
    let sigma = common::sensor_sigma();
    let mut worst = Vec::new();
    for (config, table, test, bound) in CASES {
        let rec = record(&spec(config, table, test));
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

/// With nothing missing, the diagnosis says so on independent data, with its defaults.
#[test]
fn nothing_is_missing_from_the_truth_on_independent_data() {
    let truth = common::appendix_d_coupled();
    for (config, table, test, _) in CASES {
        let rec = record(&spec(config, table, test));
        let d = diagnose_output(&truth, config, &[rec], &OutputOptions::default()).unwrap();
        let text = lockstep::diagnose::table(&d.findings, 4);
        eprintln!("{config}: {}\n{text}", d.step.summary());
        assert!(!d.findings[0].significant, "{config}:\n{text}");
        assert!(text.contains("nothing significant is missing"), "{text}");
    }
}
