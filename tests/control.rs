//! Control (issue 7): the Kubica mapping and the fuzzy inference (thesis 5.3–5.5), rule
//! tables in FLL and FIS, the derivative filter (4.7), the closed-loop PD against an exact
//! discrete-time recursion, the passivity observer against the spring energy, the chatter
//! metrics on known signals, and the virtual-wall acceptance (PD chatters, the tuned fuzzy
//! table beats it at every approach speed).

use lockstep::control::closedloop::{simulate_pd, DerivativeFilter};
use lockstep::control::fuzzy::{Fam, Partition};
use lockstep::control::wall::{metrics, simulate, Loop, Metrics, PdWall, Run, WallLaw};
use lockstep::control::WallSetup;
use lockstep::plant::{ConsistencyPolicy, Plant};
use std::path::PathBuf;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn wall_file() -> PathBuf {
    root().join("model/control/freedom6s_wall.toml")
}

/// Deterministic points (xorshift) in [lo, hi].
fn points(n: usize, lo: f64, hi: f64, seed: u64) -> Vec<f64> {
    let mut s = seed;
    (0..n)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            lo + (hi - lo) * (s >> 11) as f64 / (1u64 << 53) as f64
        })
        .collect()
}

#[test]
fn kubica_table_is_the_pd_law_at_the_peaks_and_bilinear_inside_each_cell() {
    let setup = WallSetup::load(&wall_file()).unwrap();
    let pd = setup.spec.pd;
    let k = &setup.kubica;
    // At every rule peak the controller equals the (switched) PD law exactly.
    for (i, &q) in k.position.peaks.iter().enumerate() {
        for (j, &v) in k.velocity.peaks.iter().enumerate() {
            assert_eq!(k.rules[i][j], pd.u(q, v));
            assert!((k.output(q, v) - pd.u(q, v)).abs() <= 1e-12 * (1.0 + pd.u(q, v).abs()));
        }
    }
    // Inside each cell: bilinear interpolation of the four corner rules, computed here
    // from the corners' coordinates, and the same as full inference over all 169 rules.
    for fam in [&setup.kubica, &setup.modified] {
        let (p, v) = (&fam.position, &fam.velocity);
        for i in 0..p.len() - 1 {
            for j in 0..v.len() - 1 {
                let (q0, q1, v0, v1) = (p.peaks[i], p.peaks[i + 1], v.peaks[j], v.peaks[j + 1]);
                for (s, t) in [(0.3, 0.7), (0.5, 0.5), (0.9, 0.05)] {
                    let (q, qd) = (q0 + s * (q1 - q0), v0 + t * (v1 - v0));
                    let b = (1.0 - s) * (1.0 - t) * fam.rules[i][j]
                        + (1.0 - s) * t * fam.rules[i][j + 1]
                        + s * (1.0 - t) * fam.rules[i + 1][j]
                        + s * t * fam.rules[i + 1][j + 1];
                    let scale = 1.0 + b.abs();
                    assert!(
                        (fam.output(q, qd) - b).abs() <= 1e-12 * scale,
                        "cell ({i},{j})"
                    );
                    assert!((fam.output_by_inference(q, qd) - b).abs() <= 1e-12 * scale);
                }
            }
        }
    }
    // Kubica's theorem (5.4): an unswitched linear law is reproduced everywhere.
    let (pp, vp) = setup.spec.partitions().unwrap();
    let lin = Fam::kubica(pp, vp, |q, qd| 40.0 * q + 0.25 * qd - 0.1);
    let qs = points(2000, -0.55851, 0.69813, 7);
    let vs = points(2000, -10.0, 10.0, 11);
    for (&q, &v) in qs.iter().zip(&vs) {
        let want = 40.0 * q + 0.25 * v - 0.1;
        assert!((lin.output(q, v) - want).abs() <= 1e-12 * (1.0 + want.abs()));
    }
}

#[test]
fn figure_5_6_modifications_land_on_the_cells_of_the_figure() {
    let s = WallSetup::load(&wall_file()).unwrap();
    let (k, m) = (&s.kubica, &s.modified);
    let at = |f: &Fam, p: &str, v: &str| {
        f.rules[f.position.index(p).unwrap()][f.velocity.index(v).unwrap()]
    };
    let n5 = at(k, "N2", "N3"); // the figure's rule N^5
    let n2 = at(k, "N2", "Z0");
    assert_eq!(at(m, "N6", "N3"), 2.0 * n5);
    assert_eq!(at(m, "N5", "P1"), 2.0 * n5);
    assert_eq!(at(m, "N4", "Z0"), 1.6 * n5);
    assert_eq!(at(m, "Z0", "P2"), 1.6 * n5);
    assert_eq!(at(m, "N3", "N3"), n2);
    assert_eq!(at(m, "N2", "N1"), n2);
    assert_eq!(at(m, "N1", "P1"), n2);
    assert_eq!(at(m, "N3", "P1"), at(k, "N2", "P1"));
    assert_eq!(at(m, "Z0", "P4"), at(k, "N2", "P3"));
    // Unmodified cells keep the Kubica value: N7 column, the rows beyond ±P4, outside the wall.
    assert_eq!(at(m, "N7", "Z0"), at(k, "N7", "Z0"));
    assert_eq!(at(m, "N5", "P5"), at(k, "N5", "P5"));
    assert_eq!(at(m, "P2", "N6"), 0.0);
    // Exactly the 44 bracketed rules of Figure 5.6 differ (7 per column N6..N3 and Z0, 3 in
    // N2, 6 in N1).
    let changed = (0..13)
        .flat_map(|i| (0..13).map(move |j| (i, j)))
        .filter(|&(i, j)| k.rules[i][j] != m.rules[i][j])
        .count();
    assert_eq!(changed, 44, "cells changed");
}

#[test]
fn rule_tables_round_trip_through_fll_and_fis() {
    let s = WallSetup::load(&wall_file()).unwrap();
    let fam = &s.modified;
    let back = Fam::from_fll(&fam.to_fll("wall"), "mem.fll").unwrap();
    let fis = Fam::from_fis(&fam.to_fis("wall"), "mem.fis").unwrap();
    for f in [&back, &fis] {
        assert_eq!(f.position.labels, fam.position.labels);
        for i in 0..13 {
            assert!((f.position.peaks[i] - fam.position.peaks[i]).abs() < 1e-15);
            assert!((f.velocity.peaks[i] - fam.velocity.peaks[i]).abs() < 1e-12);
            for j in 0..13 {
                assert_eq!(f.rules[i][j], fam.rules[i][j]);
            }
        }
    }
    // The bundled tuned table reads in both formats and they agree.
    let fll = Fam::from_fll(
        &std::fs::read_to_string(root().join("model/control/freedom6s_wall_tuned.fll")).unwrap(),
        "tuned.fll",
    )
    .unwrap();
    let fis = Fam::from_fis(
        &std::fs::read_to_string(root().join("model/control/freedom6s_wall_tuned.fis")).unwrap(),
        "tuned.fis",
    )
    .unwrap();
    assert_eq!(fll.rules, fis.rules);
}

#[test]
fn malformed_rule_tables_are_refused_with_the_line_or_term() {
    let s = WallSetup::load(&wall_file()).unwrap();
    let fll = s.modified.to_fll("wall");
    // A triangle whose foot is not the neighbour's peak: not a partition of unity.
    let bad = fll.replacen(
        "term: N7 Triangle -5.5851e-1 -3.8067e-1 -2.0284e-1",
        "term: N7 Triangle -5.5851e-1 -3.8067e-1 -1e-1",
        1,
    );
    assert_ne!(bad, fll, "the test's edit must apply");
    let e = Fam::from_fll(&bad, "bad.fll").unwrap_err().to_string();
    assert!(
        e.contains("term 'N7'") && e.contains("partition of unity"),
        "{e}"
    );
    // A missing rule.
    let missing: String = fll
        .lines()
        .filter(|l| !l.contains("if q is N8 and dq is N6"))
        .map(|l| format!("{l}\n"))
        .collect();
    let e = Fam::from_fll(&missing, "m.fll").unwrap_err().to_string();
    assert!(e.contains("no rule for (q is N8, dq is N6)"), "{e}");
    // A shape other than a triangle, with its line.
    let gauss = fll.replacen("Triangle", "Gaussian", 1);
    let e = Fam::from_fll(&gauss, "g.fll").unwrap_err().to_string();
    assert!(e.starts_with("g.fll:7:"), "{e}");
    // FIS with a Mamdani type.
    let fis = s
        .modified
        .to_fis("wall")
        .replace("Type='sugeno'", "Type='mamdani'");
    let e = Fam::from_fis(&fis, "w.fis").unwrap_err().to_string();
    assert!(e.contains("w.fis:3:") && e.contains("Sugeno"), "{e}");
}

#[test]
fn derivative_filter_has_its_transfer_function_and_the_thesis_cutoff() {
    let f = DerivativeFilter::THESIS;
    let period = 0.01;
    // Steady-state response to a sinusoid from the difference equation vs |H(e^{jωT})|.
    for hz in [0.5, 5.0, 15.0, 30.0] {
        let n = 4000;
        let u: Vec<f64> = (0..n)
            .map(|k| (std::f64::consts::TAU * hz * k as f64 * period).sin())
            .collect();
        let y = f.filter(&u);
        // Amplitude over a whole number of periods (4 s): √(2 · mean y²).
        let amp = (2.0 * y[n - 400..].iter().map(|v| v * v).sum::<f64>() / 400.0).sqrt();
        let (mag, _) = f.response(hz, period);
        assert!(
            (amp - mag).abs() < 2e-3 * mag.max(0.1),
            "{hz} Hz: {amp} vs {mag}"
        );
    }
    // DC gain (b1 + b2) / (a1 + a2 + a3) = 0.4564 / 0.4565.
    assert!((f.response(0.0, period).0 - 0.4564 / 0.4565).abs() < 1e-12);
    // The thesis calls it a 15 Hz filter: the gain there is about -3 dB (within 1 dB).
    let db = 20.0 * f.response(15.0, period).0.log10();
    assert!((db + 3.0).abs() < 1.0, "{db} dB at 15 Hz");
}

#[test]
fn closed_loop_pd_on_a_mass_matches_the_exact_zero_order_hold_recursion() {
    // EMPS: one prismatic joint, mass M, no effects: q̈ = u / M.
    let mut plant = Plant::new("emps", vec![]).unwrap();
    plant.parameters.insert("M".into(), 2.0);
    let sim = plant
        .simulator("full", &[0.0], ConsistencyPolicy::Refuse)
        .unwrap()
        .model;
    let (p, d, rate) = (200.0, 30.0, 100.0);
    let period = 1.0 / rate;
    let n = 500;
    let cmd: Vec<f64> = (0..n)
        .map(|k| 0.05 * (1.3 * k as f64 * period).sin())
        .collect();
    let f = DerivativeFilter::THESIS;
    let (q, tau) = simulate_pd(
        &sim,
        &["q0".into()],
        &[[p, d]],
        &f,
        std::slice::from_ref(&cmd),
        rate,
        1e-3,
    )
    .unwrap();
    // Exact discretisation of a double integrator under a held force, with the same PD.
    let (mut x, mut v, mut e_prev) = (0.0f64, 0.0f64, 0.0f64);
    let mut fs = lockstep::control::closedloop::FilterState::default();
    for k in 0..n {
        assert!((q[0][k] - x).abs() < 1e-12, "k = {k}: {} vs {x}", q[0][k]);
        let e = cmd[k] - x;
        let de = if k == 0 { 0.0 } else { (e - e_prev) / period };
        e_prev = e;
        let u = p * e + d * fs.step(&f, de);
        assert!((tau[0][k] - u).abs() < 1e-9);
        x += period * v + 0.5 * period * period * u / 2.0;
        v += period * u / 2.0;
    }
    // And it tracks: the last second's RMS error is below 5 % of the command amplitude.
    let rms = (q[0][n - 100..]
        .iter()
        .zip(&cmd[n - 100..])
        .map(|(a, b)| (a - b).powi(2))
        .sum::<f64>()
        / 100.0)
        .sqrt();
    assert!(rms < 0.05 * 0.05, "rms {rms}");
}

#[test]
fn passivity_observer_equals_the_spring_energy_of_a_fast_stiff_wall() {
    // A pure spring wall (k2 = 0) sampled at 20 kHz without delay or quantisation is close
    // to the continuous spring: the observer's E at the end equals ½ Kp k1 q² (energy stored
    // in the wall), and no energy is generated.
    let s = WallSetup::load(&wall_file()).unwrap();
    let pd = WallLaw::Pd(PdWall { k1: 20.0, k2: 0.0 });
    let hand = s.spec.nominal_hand();
    let user = s.spec.user(0.6);
    let lp = Loop {
        rate: 20_000.0,
        delay: 0,
        encoder_counts: 0.0,
        step: 5e-5,
        duration: 1.5,
        torque_limit: 0.0,
    };
    let run = simulate(&s.plant, s.joint, &pd, &hand, &user, &lp).unwrap();
    let kp = s.plant.terms[s.joint].gain;
    let q_end = *run.q.last().unwrap();
    assert!(q_end < 0.0, "the user holds the joint inside ({q_end})");
    let stored = 0.5 * kp * 20.0 * q_end * q_end;
    let m = run.metrics;
    assert!(
        (m.energy_final - stored).abs() < 0.02 * stored,
        "E = {} J, ½ Kp k1 q² = {stored} J",
        m.energy_final
    );
    assert!(m.energy_generated < 1e-3 * stored, "{}", m.energy_generated);
}

#[test]
fn chatter_metrics_of_a_known_signal() {
    // Approach at 1 rad/s to contact at t = 0.1 s, then q = −5 mrad + 8 mrad·sin(2π 4 t'):
    // the joint leaves the wall once per period after contact.
    let h = 1e-4;
    let n = 30_001;
    let t: Vec<f64> = (0..n).map(|k| k as f64 * h).collect();
    let q: Vec<f64> = t
        .iter()
        .map(|&t| {
            if t < 0.1 {
                0.1 - t
            } else {
                -0.005 * (1.0 - (-(t - 0.1) * 200.0).exp())
                    - 0.008 * (std::f64::consts::TAU * 4.0 * (t - 0.1)).sin()
            }
        })
        .collect();
    let qd: Vec<f64> = (0..n)
        .map(|k| if k == 0 { -1.0 } else { (q[k] - q[k - 1]) / h })
        .collect();
    let run = Run {
        t,
        q,
        qd,
        t_control: vec![],
        tau: vec![],
        energy: vec![0.0, -0.25, 0.1],
        metrics: Default::default(),
    };
    let m = metrics(&run, 0.1, 0.0);
    assert!(m.contact);
    assert!((m.t_contact - 0.1).abs() < 2e-4);
    assert!(
        (m.oscillation_amplitude - 0.008).abs() < 1e-4,
        "{}",
        m.oscillation_amplitude
    );
    assert!(
        (m.oscillation_frequency - 4.0).abs() < 0.3,
        "{}",
        m.oscillation_frequency
    );
    // 2.9 s of contact at 4 Hz: one exit per period.
    assert!(
        (11..=12).contains(&m.contact_losses),
        "{}",
        m.contact_losses
    );
    assert!(
        (m.peak_penetration - 0.013).abs() < 2e-4,
        "{}",
        m.peak_penetration
    );
    assert_eq!(m.settling_time, None);
    assert_eq!(m.energy_generated, 0.25);
}

fn compare(s: &WallSetup, fz: &Fam, rate: f64) -> Vec<(String, Metrics, Metrics)> {
    let hand = s.spec.nominal_hand();
    s.spec
        .approach
        .iter()
        .map(|a| {
            (
                a.name.clone(),
                s.run(&WallLaw::Pd(s.spec.pd), &hand, a.speed, rate)
                    .unwrap()
                    .metrics,
                s.run(&WallLaw::Fuzzy(fz.clone()), &hand, a.speed, rate)
                    .unwrap()
                    .metrics,
            )
        })
        .collect()
}

#[test]
fn a_chattering_pd_wall_is_beaten_by_the_tuned_fuzzy_wall_at_every_approach_speed() {
    let s = WallSetup::load(&wall_file()).unwrap();
    let tuned = Fam::from_fll(
        &std::fs::read_to_string(root().join("model/control/freedom6s_wall_tuned.fll")).unwrap(),
        "tuned.fll",
    )
    .unwrap();
    let rows = compare(&s, &tuned, 100.0);
    let mut speeds = Vec::new();
    for (name, pd, fz) in &rows {
        // The PD wall chatters: it leaves the wall repeatedly and generates energy.
        assert!(
            pd.contact_losses > 1 && pd.energy_generated > 0.0,
            "{name}: PD {pd:?}"
        );
        assert!(
            fz.oscillation_amplitude < 0.5 * pd.oscillation_amplitude,
            "{name}: amplitude {} vs PD {}",
            fz.oscillation_amplitude,
            pd.oscillation_amplitude
        );
        assert!(
            fz.energy_generated < 0.5 * pd.energy_generated,
            "{name}: energy {} vs PD {}",
            fz.energy_generated,
            pd.energy_generated
        );
        assert!(
            fz.peak_penetration <= 1.5 * pd.peak_penetration,
            "{name}: peak {} vs PD {}",
            fz.peak_penetration,
            pd.peak_penetration
        );
        speeds.push(pd.approach_speed);
    }
    // The three approaches are the thesis's slow (< 1), medium (1–2) and fast (> 2 rad/s).
    assert!(
        speeds[0] < 1.0 && (1.0..2.0).contains(&speeds[1]) && speeds[2] > 2.0,
        "{speeds:?}"
    );
    // Thesis observation 2: with the PD wall the boundary is felt deeper at faster approach.
    assert!(rows[0].1.peak_penetration < rows[1].1.peak_penetration);
    assert!(rows[1].1.peak_penetration < rows[2].1.peak_penetration);
}

#[test]
fn tuning_lowers_the_chatter_objective() {
    let mut s = WallSetup::load(&wall_file()).unwrap();
    s.spec.tune.max_evaluations = 30;
    s.spec.loop_.duration = 1.5;
    let pd = lockstep::control::tune::reference(&s, 100.0).unwrap();
    let start = lockstep::control::tune::objective(&s, &s.kubica, &pd, 100.0).unwrap();
    let t = lockstep::control::tune::tune(&s, 100.0, &|_, _| {}).unwrap();
    assert_eq!(t.objective.0, start);
    // 30 evaluations take it from 7.9 to 1.9.
    assert!(t.objective.1 < 0.5 * start, "{:?}", t.objective);
}

#[test]
fn bad_wall_files_name_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(wall_file()).unwrap();
    let write = |name: &str, t: &str| -> PathBuf {
        let p = dir.path().join(name);
        std::fs::write(&p, t).unwrap();
        p
    };
    let plant = root().join("model/plants/freedom6s_appendix_d_coupled.toml");
    let fixed = text.replace(
        "plant = \"../plants/freedom6s_appendix_d_coupled.toml\"",
        &format!("plant = {:?}", plant.display().to_string()),
    );
    let p = write("typo.toml", &fixed.replace("k1 = 40.0", "kk1 = 40.0"));
    let e = format!("{:#}", WallSetup::load(&p).unwrap_err());
    assert!(e.contains("typo.toml") && e.contains("kk1"), "{e}");
    let p = write(
        "joint.toml",
        &fixed.replace("joint = \"q0\"", "joint = \"q3\""),
    );
    let e = format!("{:#}", WallSetup::load(&p).unwrap_err());
    assert!(
        e.contains("joint 'q3' is not free in configuration 'c6'"),
        "{e}"
    );
    let p = write(
        "label.toml",
        &fixed.replacen("like = [\"N2\", \"N3\"]", "like = [\"N9\", \"N3\"]", 1),
    );
    let e = format!("{:#}", WallSetup::load(&p).unwrap_err());
    assert!(e.contains("no membership function 'N9'"), "{e}");
    let p = write(
        "peaks.toml",
        &fixed.replace("-0.025, -0.02,", "-0.02, -0.025,"),
    );
    let e = format!("{:#}", WallSetup::load(&p).unwrap_err());
    assert!(e.contains("peaks must increase strictly"), "{e}");
    // The partition itself refuses a mismatch.
    assert!(Partition::new("q", vec!["a".into()], vec![0.0, 1.0]).is_err());
}

#[test]
fn fuzzylite_evaluates_the_written_fll_table_as_lockstep_does() {
    // Reference: fuzzylite 8.0.6 (pyfuzzylite) on the rules.fll that `lockstep wall` writes,
    // printed by bench/fuzzylite_wall.py; its lock-range clamps inputs beyond the universes.
    let s = WallSetup::load(&wall_file()).unwrap();
    let text = std::fs::read_to_string(root().join("tests/data/fuzzylite_wall_rules.txt")).unwrap();
    let mut n = 0;
    for line in text.lines().filter(|l| !l.starts_with('#')) {
        let v: Vec<f64> = line
            .split_whitespace()
            .map(|x| x.parse().unwrap())
            .collect();
        let ours = s.modified.output(v[0], v[1]);
        assert!(
            (ours - v[2]).abs() <= 1e-12 * (1.0 + v[2].abs()),
            "q = {}, dq = {}: lockstep {ours}, fuzzylite {}",
            v[0],
            v[1],
            v[2]
        );
        n += 1;
    }
    assert_eq!(n, 305);
}
