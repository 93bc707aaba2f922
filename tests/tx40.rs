//! The Staubli TX40 (real recording, FIGAROH; model read from its URDF) in torque space:
//! IDIM-LS on the base parameters with per-joint rotor inertia, viscous and Coulomb friction,
//! offsets and the motor-6 terms, trained on 0.1–5.5 s and validated on 5.5–7.5 s, against
//! FIGAROH's own OLS identification of the same recording (data/staubli_tx40/reference/).
//!
//! Processing, as FIGAROH's: positions through a 20 Hz zero-phase Butterworth, the rows of a
//! joint slower than 1 % of its peak speed left out (FIGAROH's `dq_lim_def`); parallel
//! decimation ×100 (50 Hz rows: the decimation filter's band, 20 Hz, is the positions').
//!
//! FIGAROH writes the motor-6 terms as cross terms (row 5: fvm6·q̇6, row 6: fvm6·q̇5), lockstep
//! as the motor's own friction on q̇5 + q̇6 acting on both joints; so FIGAROH's fv5 is
//! lockstep's Fv_q5 + fvm6 and its fv6 is Fv_q6 + fvm6 (the coefficient of q̇5 on row 5, of
//! q̇6 on row 6).

use lockstep::identify::idim::{
    base_fit, locked_positions, observation, predict, relative_error, Fit, IdimOptions, MinSpeed,
    Weighting,
};
use lockstep::measurement::Measurement;
use lockstep::plant::Plant;
use std::path::Path;

mod common;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn options(window: (f64, f64)) -> IdimOptions {
    IdimOptions {
        cutoff_hz: 20.0,
        filter_order: 4,
        decimation: 100,
        window: Some(window),
        min_speed: Some(MinSpeed::FractionOfPeak(0.01)),
        differentiator: lockstep::signal::Differentiator::Central,
        trim_moving_edges: false,
    }
}

/// The preparation `lockstep identify idim` chooses from the record itself (no `--cutoff`,
/// `--decimate`), on `window`: measured, the fit band 66.7 Hz (×30, positions at 133 Hz)
/// by cross-validation among 16.7–286 Hz.
fn chosen(window: (f64, f64)) -> IdimOptions {
    let record = Measurement::read(
        &root().join("data/staubli_tx40/tx40_joint_5kHz.csv"),
        &["q1", "q2", "q3", "q4", "q5", "q6"],
    )
    .unwrap();
    let plant = Plant::load(&root().join("model/plants/tx40_figaroh.toml")).unwrap();
    let (opts, said) = lockstep::identify::preparation::Requested::default()
        .resolve(
            options(window),
            std::slice::from_ref(&record),
            &[0, 1, 2, 3, 4, 5],
            Some((&plant, "full")),
        )
        .unwrap();
    eprintln!("{said}");
    opts
}

/// The fit on the training window, the fitted plant and the record.
fn fitted(options: &dyn Fn((f64, f64)) -> IdimOptions) -> (Fit, Plant, Measurement, f64) {
    let record = Measurement::read(
        &root().join("data/staubli_tx40/tx40_joint_5kHz.csv"),
        &["q1", "q2", "q3", "q4", "q5", "q6"],
    )
    .expect("the TX40 record reads");
    let mut plant = Plant::load(&root().join("model/plants/tx40_figaroh.toml")).unwrap();
    let opts = options((0.1, 5.5));
    let records = std::slice::from_ref(&record);
    let obs = observation(&plant, "full", records, &opts).unwrap();
    let locked_at = locked_positions(records);
    let (fit, _) = base_fit(&plant, &obs, "full", &locked_at, &opts, Weighting::Ols).unwrap();
    fit.apply(&mut plant).unwrap();
    // The error in FIGAROH's band (20 Hz, 50 Hz rows), whatever band the fit used.
    let figaroh = observation(&plant, "full", records, &self::options((0.1, 5.5))).unwrap();
    let training = relative_error(&figaroh.y, &predict(&plant, &figaroh).unwrap());
    (fit, plant, record, training)
}

fn within(what: &str, x: f64, figaroh: f64, pct: f64) {
    let d = 100.0 * (x - figaroh) / figaroh;
    assert!(
        d.abs() <= pct,
        "{what}: lockstep {x:.4}, FIGAROH {figaroh:.4} ({d:+.1} %, allowed ±{pct} %)"
    );
}

#[test]
fn tx40_idim_reaches_figaroh_on_the_real_recording() {
    reaches_figaroh(&options);
}

/// The same acceptance with the preparation chosen from the data (what `identify idim`
/// does without `--cutoff`/`--decimate`), its errors measured in FIGAROH's band.
#[test]
fn tx40_idim_with_the_preparation_chosen_from_the_data() {
    reaches_figaroh(&chosen);
}

fn reaches_figaroh(options: &dyn Fn((f64, f64)) -> IdimOptions) {
    let (fit, plant, record, training) = fitted(options);
    let v = |n: &str| fit.get(n).unwrap_or_else(|| panic!("{n} fitted"));
    // The torque error on the fitted part, and on the held-out 5.5–7.5 s.
    assert!(training <= 5.0, "training error {training:.3} %");
    let val = observation(
        &plant,
        "full",
        std::slice::from_ref(&record),
        &self::options((5.5, 7.5)),
    )
    .unwrap();
    let validation = relative_error(&val.y, &predict(&plant, &val).unwrap());
    eprintln!("TX40: training error {training:.3} %, validation error {validation:.3} %");
    assert!(validation <= 9.0, "validation error {validation:.3} %");
    // Friction against FIGAROH's OLS essential parameters (TX40_ep_5.csv).
    within("fv1", v("Fv_q1"), 8.027789, 5.0);
    within("fs1", v("Fc_q1"), 7.231843, 5.0);
    within("fv2", v("Fv_q2"), 5.520149, 5.0);
    within("fs2", v("Fc_q2"), 8.250505, 5.0);
    within("fv3", v("Fv_q3"), 1.996299, 10.0);
    within("fs3", v("Fc_q3"), 6.287724, 10.0);
    within("fv4", v("Fv_q4"), 1.108709, 10.0);
    within("fv5", v("Fv_q5") + v("fvm6"), 1.845313, 10.0);
    within("fv6", v("Fv_q6") + v("fvm6"), 0.669334, 10.0);
    within("fvm6", v("fvm6"), 0.590868, 10.0);
    // The first base parameter is FIGAROH's first essential one, term for term.
    let b = fit
        .base
        .iter()
        .find(|b| b.parameter.name == "Ia_q1")
        .expect("Ia_q1 carries the inertia about joint 1's axis");
    let terms = b.parameter.to_string();
    for t in [
        "ZZ_link_1",
        "YY_link_2",
        "YY_link_3",
        "0.07 MZ_link_3",
        "0.05185 m_link_6",
    ] {
        assert!(terms.contains(t), "{t} not in {terms}");
    }
    within(
        "Izz1 + Ia1 + Iyy2 + Iyy3 + 0.07 mz3 + 0.05185 (m3 + m4 + m5 + m6)",
        b.value,
        1.274538,
        5.0,
    );
}

/// Measured (2026-11-28): 14 steps, 4.743 % against the full model's 4.858 %, 157 s — the
/// friction bias on q5 the loop now applies in torque space costs a grid of refits at every
/// later step (each grid point rebuilds the 45 000-sample observation).
#[test]
fn the_loop_on_the_tx40_names_the_friction_and_the_coupled_motor() {
    // A plant without friction (rigid body from the URDF, rotor inertias, offsets): the
    // torque-space loop adds what is significant and lowers the error, step by step, to
    // within 0.3 percentage points of the full model's (rigid body, Ia, Fv, Fc, offsets and
    // the motor-6 terms: tx40_idim_reaches_figaroh_on_the_real_recording).
    let record = Measurement::read(
        &root().join("data/staubli_tx40/tx40_joint_5kHz.csv"),
        &["q1", "q2", "q3", "q4", "q5", "q6"],
    )
    .unwrap();
    let d = tempfile::tempdir().unwrap();
    let file = d.path().join("tx40_nofriction.toml");
    // Rotor inertias and offsets from zero: the loop's first step refits them.
    let zeros: String = (0..6)
        .map(|j| format!("Ia_q{0} = 0.0\noffset_q{0} = 0.0\n", j + 1))
        .collect();
    std::fs::write(
        &file,
        format!("model = \"tx40\"\n[[effect]]\nkind = \"armature\"\njoints = [\"q1\", \"q2\", \"q3\", \"q4\", \"q5\", \"q6\"]\n[[effect]]\nkind = \"offset\"\njoints = [\"q1\", \"q2\", \"q3\", \"q4\", \"q5\", \"q6\"]\n[parameters]\n{zeros}"),
    )
    .unwrap();
    let plant = Plant::load(&file).unwrap();
    let opts = options((0.1, 5.5));
    let done = lockstep::diagnose::torque::apply_all_significant(
        &plant,
        "full",
        std::slice::from_ref(&record),
        (&opts, &[]),
        lockstep::diagnose::apply::max_applied_steps(6),
        &|_| {},
    )
    .unwrap();
    let added: Vec<String> = done
        .steps
        .iter()
        .filter_map(|(f, _)| f.as_ref().map(|f| format!("{} on {}", f.name, f.joint)))
        .collect();
    // Viscous and Coulomb friction on every joint, and motor 6's friction on q5 + q6 —
    // which is q6's viscous friction: with it, q6's own is the 0.05 N·m·s/rad the full
    // model finds (FIGAROH likewise: its fv6 is mostly fvm6), not worth a step.
    for j in 1..=6 {
        for kind in ["viscous", "coulomb"] {
            // q6's own friction: the coupled motor's (on q5 + q6) carries most of it.
            if j == 6 {
                continue;
            }
            assert!(
                added.contains(&format!("{kind} on q{j}")),
                "{kind} on q{j} not in {added:?}"
            );
        }
    }
    assert!(
        added.iter().any(|a| a.contains("coupled_motor_q5_q6")),
        "the coupled motor not in {added:?}"
    );
    // The first step is the largest friction term: viscous friction of the base joint.
    assert_eq!(added[0], "viscous on q1", "{added:?}");
    let obs = observation(&done.plant, "full", std::slice::from_ref(&record), &opts).unwrap();
    let after = relative_error(&obs.y, &predict(&done.plant, &obs).unwrap());
    let (_, _, _, full) = fitted(&options);
    eprintln!("TX40 loop: {added:?}; error {after:.3} % (full model {full:.3} %)");
    assert!(
        after <= full + 0.3,
        "loop {after:.3} %, full model {full:.3} %"
    );
}

#[test]
fn the_consistent_tx40_set_is_physical_and_keeps_the_fit() {
    // The least squares' standard values describe no body (negative inertias about the
    // centroid on links 2, 3, 4, 6); the consistent set does, for a small rise of the error.
    let record = Measurement::read(
        &root().join("data/staubli_tx40/tx40_joint_5kHz.csv"),
        &["q1", "q2", "q3", "q4", "q5", "q6"],
    )
    .unwrap();
    let prior = Plant::load(&root().join("model/plants/tx40_figaroh.toml")).unwrap();
    let opts = options((0.1, 5.5));
    let obs = observation(&prior, "full", std::slice::from_ref(&record), &opts).unwrap();
    let (fit, mut unconstrained, _, training) = fitted(&options);
    let conf = prior.model.configuration("full").unwrap();
    assert!(
        !lockstep::identify::idim::implausible(&unconstrained, conf)
            .unwrap()
            .is_empty(),
        "the least squares alone were expected to leave an unphysical link"
    );
    let c = lockstep::identify::consistent::consistent_parameters(
        &obs,
        &prior,
        &fit,
        &Default::default(),
    )
    .unwrap();
    assert!((c.unconstrained_error - training).abs() < 1e-9);
    c.apply(&mut unconstrained).unwrap();
    let reasons = lockstep::identify::idim::implausible(&unconstrained, conf).unwrap();
    assert!(reasons.is_empty(), "{reasons:?}");
    eprintln!(
        "TX40 consistent set: {:.3} % (least squares {:.3} %), {} iterations",
        c.consistent_error, c.unconstrained_error, c.iterations
    );
    assert!(c.consistent_error <= c.unconstrained_error + 0.3);
    // The friction the data determine stays where the least squares put it.
    within(
        "fv1 (consistent)",
        c.get("Fv_q1").unwrap(),
        fit.get("Fv_q1").unwrap(),
        2.0,
    );
    within(
        "fs2 (consistent)",
        c.get("Fc_q2").unwrap(),
        fit.get("Fc_q2").unwrap(),
        2.0,
    );
}

/// Bad input on the real record, each one clear line, exit ≠ 0, nothing written: too few
/// rows for the base parameters (a 0.2 s window), a joint that does not move (q6 held at
/// its first sample: structurally separable, unexcited by these data), and a prior that is
/// itself impossible (a negative mass) under `--consistent`.
#[test]
fn bad_input_on_the_tx40_is_one_line_and_writes_nothing() {
    let d = tempfile::tempdir().unwrap();
    let data = root().join("data/staubli_tx40/tx40_joint_5kHz.csv");
    let plant = root().join("model/plants/tx40_figaroh.toml");
    let out = d.path().join("fit.toml");
    let run = |plant: &Path, data: &Path, extra: &[&str]| {
        let mut more = vec![
            "--min-speed",
            "1%",
            "--weighting",
            "ols",
            "--allow-inconsistent",
            "--out",
            out.to_str().unwrap(),
        ];
        more.extend_from_slice(extra);
        let o = common::identify_idim(plant, data, &more);
        assert!(!o.status.success());
        let err = String::from_utf8_lossy(&o.stderr).into_owned();
        let errors: Vec<&str> = err.lines().filter(|l| l.starts_with("error")).collect();
        assert_eq!(errors.len(), 1, "{err}");
        assert!(!out.exists(), "{err}");
        errors[0].to_string()
    };
    let e = run(
        &plant,
        &data,
        &["--window", "0.1:0.3", "--cutoff", "20", "--decimate", "100"],
    );
    assert!(
        e.contains("observation rows")
            && e.contains("for 61 parameters")
            && e.contains("more data needed"),
        "{e}"
    );
    // q6 (column q_q6) held still.
    let text = std::fs::read_to_string(&data).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    let col = header.split(',').position(|c| c == "q_q6").unwrap();
    let first: Vec<&str> = text.lines().nth(1).unwrap().split(',').collect();
    let mut still = String::from(header) + "\n";
    for l in lines {
        let mut v: Vec<&str> = l.split(',').collect();
        v[col] = first[col];
        still += &v.join(",");
        still.push('\n');
    }
    let still_csv = d.path().join("still.csv");
    std::fs::write(&still_csv, still).unwrap();
    std::fs::copy(
        root().join("data/staubli_tx40/tx40_joint_5kHz.toml"),
        d.path().join("still.toml"),
    )
    .unwrap();
    let e = run(&plant, &still_csv, &[]);
    assert!(
        e.contains("joint 'q6' does not move")
            && e.contains("too little excitation")
            && e.contains("Fv_q6"),
        "{e}"
    );
    // A negative mass in the prior.
    let bad = d.path().join("bad_prior.toml");
    std::fs::write(
        &bad,
        std::fs::read_to_string(&plant)
            .unwrap()
            .replace("[parameters]", "[parameters]\nm_link_3 = -1.0"),
    )
    .unwrap();
    let e = run(&bad, &data, &["--consistent"]);
    assert!(
        e.contains("the prior is itself impossible") && e.contains("link 'link_3' has mass -1 kg"),
        "{e}"
    );
}
