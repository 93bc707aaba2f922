//! IDIM on a rank-deficient regressor (every serial arm's): `identify` fits the base
//! parameters instead of refusing, keeps the dependent parameters at the plant's values, and
//! writes a plant whose dynamics are the fitted ones.
//!
//! Planar 2R arm (Spong, Hutchinson & Vidyasagar 2006, 7.4.1; frames at the distal ends,
//! a1 = 0.3 m, a2 = 0.2 m) in a vertical plane with viscous friction. The references are
//! independent of the fit: the base parameters worked out by hand from the textbook's
//! equations of motion, the base count of `identifiability::base_parameters` (a different
//! algorithm on random samples), and the truth's own torques.

mod common;
use common::{identify_idim, lockstep, ok};
use lockstep::identify::idim::{observation, predict, IdimOptions};
use lockstep::measurement::Measurement;
use lockstep::plant::Plant;
use std::path::Path;

const TRUTH: &str = r#"model = "planar2r"
description = "test truth"

[[effect]]
kind = "viscous"
joints = ["q0", "q1"]

[parameters]
m1 = 1.2
x1 = -0.12
I1 = 0.02
m2 = 0.8
x2 = -0.08
I2 = 0.01
Fv_0 = 0.05
Fv_1 = 0.03
"#;

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The base parameter `expr` = value from identify's table.
fn base_value(out: &str, expr: &str) -> f64 {
    let line = out
        .lines()
        .find(|l| l.trim_start().starts_with(expr))
        .unwrap_or_else(|| panic!("no base parameter '{expr}' in:\n{out}"));
    let v = line.split('=').nth(1).unwrap().split('±').next().unwrap();
    v.trim().parse().unwrap()
}

#[test]
fn a_rank_deficient_regressor_is_fitted_on_its_base_parameters() {
    let d = tempfile::tempdir().unwrap();
    let truth = d.path().join("truth.toml");
    std::fs::write(&truth, TRUTH).unwrap();
    // A start with the mass of link 1 (not separately identifiable) and I2 off.
    let start = d.path().join("start.toml");
    std::fs::write(
        &start,
        TRUTH
            .replace("m1 = 1.2", "m1 = 1.5")
            .replace("I2 = 0.01", "I2 = 0.013"),
    )
    .unwrap();
    // A 20 s multisine at 1 kHz (a continuous signal sampled: linear hold).
    let mut csv = String::from("t,tau0,tau1\n");
    for k in 0..=20_000 {
        let t = k as f64 * 1e-3;
        let a = 2.0 * (1.3 * t).sin() + 1.5 * (3.7 * t + 0.4).sin() + 0.8 * (7.1 * t).sin();
        let b = 0.6 * (2.1 * t + 1.0).sin() + 0.4 * (5.3 * t).sin() + 0.2 * (11.0 * t).sin();
        csv += &format!("{t},{a},{b}\n");
    }
    let tau = d.path().join("tau.csv");
    std::fs::write(&tau, csv).unwrap();
    let run = d.path().join("run.csv");
    // The textbook links carry only ZZ: not a full rigid body, hence --allow-inconsistent.
    ok(&lockstep(&[
        "simulate",
        "--plant",
        s(&truth),
        "--input",
        s(&tau),
        "--config",
        "full",
        "--hold",
        "linear",
        "--noise",
        "1e-5",
        "--allow-inconsistent",
        "-o",
        s(&run),
    ]));
    let fitted = d.path().join("fitted.toml");
    let out = ok(&identify_idim(
        &start,
        &run,
        &["--out", s(&fitted), "--allow-inconsistent"],
    ));

    // As many base parameters as the independent rank computation finds, plus the two
    // viscous coefficients.
    let model = lockstep::util::model("planar2r").unwrap();
    let full = lockstep::util::configuration(model, "full").unwrap();
    let rank = lockstep::identify::identifiability::base_parameters(model, full).rank;
    assert!(
        out.contains(&format!("{} base parameters fitted", rank + 2)),
        "rank {rank}: {out}"
    );

    // By hand, barycentric about each link's distal frame: MX = m·x, ZZ = I + m·x²;
    // the masses fold in with a1 (link 1 carries both masses) and a2.
    let (m1, x1, i1, m2, x2, i2) = (1.2, -0.12, 0.02, 0.8, -0.08, 0.01);
    let (a1, a2) = (0.3, 0.2);
    let expected = [
        ("MX_l1 + 0.3 m1 + 0.3 m2", m1 * x1 + a1 * (m1 + m2)),
        (
            "ZZ_l1 − 0.09 m1 − 0.09 m2",
            i1 + m1 * x1 * x1 - a1 * a1 * (m1 + m2),
        ),
        ("MX_l2 + 0.2 m2", m2 * x2 + a2 * m2),
        ("ZZ_l2 − 0.04 m2", i2 + m2 * x2 * x2 - a2 * a2 * m2),
    ];
    for (expr, truth_value) in expected {
        let v = base_value(&out, expr);
        assert!(
            ((v - truth_value) / truth_value).abs() < 0.005,
            "{expr}: {v} against {truth_value}"
        );
    }

    // The written plant keeps one form per link, the unidentifiable mass at the start's
    // value, and its torques are the truth's.
    let fit = Plant::load(&fitted).unwrap();
    assert_eq!(fit.parameters["m1"], 1.5);
    assert!(!fit.parameters.contains_key("x1") && !fit.parameters.contains_key("I1"));
    let truth_plant = Plant::load(&truth).unwrap();
    let records = vec![Measurement::read(&run, &["q0", "q1"]).unwrap()];
    let obs = observation(&truth_plant, "full", &records, &IdimOptions::default()).unwrap();
    let (yt, yf) = (
        predict(&truth_plant, &obs).unwrap(),
        predict(&fit, &obs).unwrap(),
    );
    let rel = (&yt - &yf).norm() / yt.norm();
    assert!(
        rel < 2e-3,
        "fitted torques differ from the truth's by {rel}"
    );
}

/// IDIM-WLS against the formula it implements, on an observation built by hand: two joints,
/// 600 rows each; a column acting on joint 0's rows only, one on joint 1's only, and one on
/// both. Joint 0's torque (RMS ≈ 2) carries noise σ = 0.5, joint 1's (RMS ≈ 0.05) σ = 0.002.
/// The weighting estimates each joint's σ within 10 % (from each joint's own subsystem);
/// `auto` weights (torque scales 40× apart) and `ols` does not; WLS's standard deviations
/// are the generalised least squares' with the true σ, (Wᵀ Σ⁻¹ W)⁻¹, to 15 %; the shared
/// parameter's is under a fifth of the ordinary fit's (the precise joint counts by its
/// noise, not its size); both estimates lie within three standard deviations of the truth.
#[test]
fn idim_wls_weights_each_joint_by_its_own_noise() {
    use lockstep::identify::idim::{
        least_squares, weighted_least_squares_base, Observation, RowInfo, Weighting,
    };
    use nalgebra::{DMatrix, DVector};
    let n = 600;
    let mut state = 0x1234_5678_u64;
    let mut uniform = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    };
    let mut gauss = || {
        let (u1, u2) = (uniform(), uniform());
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    };
    let theta = [2.0, 3.0, 0.5];
    let sigma = [0.5, 0.002];
    let mut w = DMatrix::zeros(2 * n, 3);
    let mut y = DVector::zeros(2 * n);
    let mut rows = Vec::new();
    for (j, &noise) in sigma.iter().enumerate() {
        for k in 0..n {
            let i = j * n + k;
            let x = (0.01 * k as f64 * (1.0 + j as f64)).sin();
            if j == 0 {
                w[(i, 0)] = x;
                w[(i, 2)] = (0.037 * k as f64).cos();
            } else {
                w[(i, 1)] = 0.01 * x;
                w[(i, 2)] = 0.05 * (0.023 * k as f64).cos();
            }
            let clean: f64 = (0..3).map(|c| w[(i, c)] * theta[c]).sum();
            y[i] = clean + noise * gauss();
            rows.push(RowInfo {
                record: 0,
                t: k as f64,
                joint: j,
                q: 0.0,
                qd: 0.0,
                qdd: 0.0,
            });
        }
    }
    let obs = Observation {
        names: vec!["a".into(), "b".into(), "c".into()],
        y,
        w,
        rows,
    };
    let model = lockstep::util::model("emps").unwrap();
    let conf = lockstep::util::configuration(model, "full").unwrap();
    let fit = |weighting| {
        weighted_least_squares_base(&obs, model, conf, &[], &|_| None, weighting, None).unwrap()
    };
    let (ols, none) = fit(Weighting::Ols);
    assert!(none.is_empty());
    let plain = least_squares(&obs).unwrap();
    assert_eq!(ols.theta, plain.theta);
    let (auto, sigmas) = fit(Weighting::Auto);
    let (wls, _) = fit(Weighting::Wls);
    assert_eq!(auto.theta, wls.theta);
    eprintln!(
        "σ estimated {sigmas:?}; c: OLS {:.5} ± {:.2e}, WLS {:.5} ± {:.2e}",
        ols.theta[2], ols.std[2], wls.theta[2], wls.std[2]
    );
    for (j, s) in &sigmas {
        assert!((s / sigma[*j] - 1.0).abs() < 0.1, "joint {j}: σ {s}");
    }
    // The generalised least squares' covariance with the true σ, (Wᵀ Σ⁻¹ W)⁻¹.
    let mut info = DMatrix::<f64>::zeros(3, 3);
    for i in 0..2 * n {
        let s2 = sigma[i / n] * sigma[i / n];
        let r = obs.w.row(i);
        info += r.transpose() * r / s2;
    }
    let gls = info.try_inverse().unwrap();
    for c in 0..3 {
        let expected = gls[(c, c)].sqrt();
        assert!(
            (wls.std[c] / expected - 1.0).abs() < 0.15,
            "{c}: WLS std {} against the GLS {expected}",
            wls.std[c]
        );
    }
    assert!(wls.std[2] < 0.2 * ols.std[2]);
    for f in [&ols, &wls] {
        for (c, truth) in theta.iter().enumerate() {
            assert!(
                (f.theta[c] - truth).abs() < 3.0 * f.std[c],
                "{c}: {} ± {}",
                f.theta[c],
                f.std[c]
            );
        }
    }
}
