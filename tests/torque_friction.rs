//! LuGre's static curve and the friction position bias in torque space, on a one-joint axis
//! (the EMPS model): the record is written by formula — a smooth motion in closed form and
//! the torque M q̈ + b(q) [(Fc + (Fs − Fc) e^{−(q̇/vs)²}) sign q̇ + σ2 q̇] + offset, b = B below
//! qeq and 1 above (thesis 3.8 and 4.3.5) — with noise on q and τ; no simulator of
//! lockstep's is involved. `identify idim` fits vs, B and qeq by variable projection around
//! the least squares; `diagnose --apply all-significant` names the hidden bias, adds it and
//! refits it.

mod common;
use common::{identify_idim, lockstep, ok};
use std::path::{Path, PathBuf};

const RATE: f64 = 1000.0;
const SECONDS: f64 = 30.0;
const M: f64 = 95.0;
const FC: f64 = 20.0;
const FS: f64 = 30.0;
const VS: f64 = 0.05;
const SIGMA2: f64 = 200.0;
const BIAS: f64 = 1.5;
const QEQ: f64 = 0.1;
const OFFSET: f64 = -3.0;
const TORQUE_NOISE: f64 = 1.0;

/// The record (CSV with its side file) in `dir`.
fn record(dir: &Path) -> PathBuf {
    use std::f64::consts::TAU;
    // (amplitude m, frequency Hz, phase)
    let lines = [(0.3, 0.2, 0.0), (0.15, 0.53, 1.0), (0.05, 1.3, 2.0)];
    let mut seed = 0x9e37_79b9_7f4a_7c15_u64;
    let mut uniform = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut gauss = move || {
        let (a, b) = (uniform().max(1e-300), uniform());
        (-2.0 * a.ln()).sqrt() * (TAU * b).cos()
    };
    let n = (SECONDS * RATE) as usize;
    let mut text = String::from("t,tau0,q0\n");
    for k in 0..n {
        let t = k as f64 / RATE;
        let (mut q, mut v, mut a) = (0.0, 0.0, 0.0);
        for &(amp, f, phi) in &lines {
            let w = TAU * f;
            q += amp * (w * t + phi).sin();
            v += amp * w * (w * t + phi).cos();
            a -= amp * w * w * (w * t + phi).sin();
        }
        let g = FC + (FS - FC) * (-(v / VS).powi(2)).exp();
        let s = if v > 0.0 {
            1.0
        } else if v < 0.0 {
            -1.0
        } else {
            0.0
        };
        let b = if q < QEQ { BIAS } else { 1.0 };
        let tau = M * a + b * (g * s + SIGMA2 * v) + OFFSET;
        text += &format!(
            "{t:e},{:e},{:e}\n",
            tau + TORQUE_NOISE * gauss(),
            q + 1e-6 * gauss()
        );
    }
    let path = dir.join("axis.csv");
    std::fs::write(&path, text).unwrap();
    std::fs::write(dir.join("axis.toml"), "configuration = \"full\"\n").unwrap();
    path
}

fn plant(dir: &Path, name: &str, with_bias: bool) -> PathBuf {
    let mut text = String::from(
        "model = \"emps\"\n\n[[effect]]\nkind = \"lugre\"\njoints = [\"q0\"]\n\n\
         [[effect]]\nkind = \"offset\"\njoints = [\"q0\"]\n",
    );
    if with_bias {
        text += "\n[[effect]]\nkind = \"friction_bias\"\njoints = [\"q0\"]\n";
    }
    // The presliding values (σ0, σ1) are the simulator's; a wrong Stribeck speed to start.
    text += "\n[parameters]\nM = 80.0\nsigma0_0 = 1.0e6\nsigma1_0 = 2000.0\nsigma2_0 = 150.0\n\
             Fc_q0 = 15.0\nFs_0 = 15.0\nvs_0 = 0.02\noffset_0 = 0.0\n";
    if with_bias {
        text += "FrictionBias_q0 = 1.0\nqeq_0 = 0.0\n";
    }
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// `NAME value …` of a printed table.
fn value(out: &str, name: &str) -> f64 {
    out.lines()
        .find_map(|l| {
            let w: Vec<&str> = l.split_whitespace().collect();
            (w.len() >= 2 && w[0] == name)
                .then(|| w[1].parse().ok())
                .flatten()
        })
        .unwrap_or_else(|| panic!("{name} not in {out}"))
}

/// `identify idim` of `plant` on `data`, the fit written to `out`: its standard output (its
/// errors shown if it failed).
fn identify(plant: &Path, data: &Path, out: &Path) -> String {
    let o = identify_idim(plant, data, &["--out", out.to_str().unwrap()]);
    let printed = ok(&o);
    eprintln!("{}{printed}", String::from_utf8_lossy(&o.stderr));
    printed
}

fn within(what: &str, x: f64, want: f64, pct: f64) {
    assert!(
        (x - want).abs() <= pct / 100.0 * want.abs(),
        "{what}: {x} against {want} (±{pct} %)"
    );
}

#[test]
fn lugre_static_curve_and_friction_bias_are_fitted_in_torque_space() {
    let d = tempfile::tempdir().unwrap();
    let data = record(d.path());
    let start = plant(d.path(), "start.toml", true);
    let out = identify(&start, &data, &d.path().join("fitted.toml"));
    within("M", value(&out, "M"), M, 1.0);
    within("Fc_q0", value(&out, "Fc_q0"), FC, 2.0);
    within("Fs_q0", value(&out, "Fs_q0"), FS, 2.0);
    within("sigma2_q0", value(&out, "sigma2_q0"), SIGMA2, 2.0);
    within("vs_q0", value(&out, "vs_q0"), VS, 5.0);
    within("FrictionBias_q0", value(&out, "FrictionBias_q0"), BIAS, 2.0);
    // The switch is found to within the grid between samples of the motion.
    assert!(
        (value(&out, "qeq_q0") - QEQ).abs() <= 0.01,
        "qeq_q0 {}",
        value(&out, "qeq_q0")
    );
    // σ0 and σ1 are not torque space's to fit: said, kept.
    assert!(
        out.contains("sigma0_q0") && out.contains("not determined"),
        "{out}"
    );
}

#[test]
fn a_hidden_friction_bias_is_named_added_and_refitted_in_torque_space() {
    let d = tempfile::tempdir().unwrap();
    let data = record(d.path());
    // The right friction law, the bias missing; its values fitted first.
    let start = plant(d.path(), "start.toml", false);
    let fitted = d.path().join("without_bias.toml");
    identify(&start, &data, &fitted);
    let applied = d.path().join("applied.toml");
    let o = lockstep(&[
        "diagnose",
        "--plant",
        fitted.to_str().unwrap(),
        "--data",
        data.to_str().unwrap(),
        "--apply",
        "all-significant",
        "--out",
        applied.to_str().unwrap(),
    ]);
    let out = ok(&o);
    eprintln!("{}{out}", String::from_utf8_lossy(&o.stderr));
    let first = out
        .lines()
        .find(|l| l.starts_with("most likely missing"))
        .unwrap_or_else(|| panic!("{out}"));
    assert!(first.contains("friction_bias"), "{first}");
    let text = std::fs::read_to_string(&applied).unwrap();
    let v = |n: &str| value(&text.replace(" = ", " "), n);
    within("FrictionBias_q0", v("FrictionBias_q0"), BIAS, 2.0);
    assert!((v("qeq_q0") - QEQ).abs() <= 0.01, "qeq_q0 {}", v("qeq_q0"));
}

/// A separable fit's trials rebuild only the effects' columns of an observation prepared
/// once ([`lockstep::identify::idim::Prepared`]): at other values of vs, the bias and its
/// rest angle, with the moving ends and a minimum speed trimming rows, the prepared
/// observation is the one built from scratch, to the bit; a plant with other effects is
/// refused.
#[test]
fn a_prepared_observation_at_other_values_is_the_one_built_afresh() {
    use lockstep::identify::idim::{observation, IdimOptions, MinSpeed, Prepared};
    use lockstep::plant::Plant;
    let d = tempfile::tempdir().unwrap();
    let data = record(d.path());
    let records = vec![lockstep::measurement::Measurement::read(&data, &["q0"]).unwrap()];
    let start = Plant::load(&plant(d.path(), "p.toml", true)).unwrap();
    let opts = IdimOptions {
        cutoff_hz: 30.0,
        decimation: 5,
        min_speed: Some(MinSpeed::FractionOfPeak(0.01)),
        trim_moving_edges: true,
        ..IdimOptions::default()
    };
    let prepared = Prepared::new(&start, "full", &records, &opts).unwrap();
    let mut other = start.clone();
    for (n, v) in [("vs_q0", VS), ("FrictionBias_q0", BIAS), ("qeq_q0", QEQ)] {
        other.parameters.insert(n.into(), v);
    }
    let (a, b) = (
        prepared.at(&other).unwrap(),
        observation(&other, "full", &records, &opts).unwrap(),
    );
    assert_eq!(a.names, b.names);
    assert_eq!(a.y, b.y);
    assert_eq!(a.w, b.w);
    assert_eq!(a.rows.len(), b.rows.len());
    assert!(a.rows.len() < records[0].len() / 5, "rows trimmed");
    // The biased columns differ from the start's (the trial did change them).
    let at_start = prepared.at(&start).unwrap();
    assert_ne!(at_start.w, a.w);
    let without = Plant::load(&plant(d.path(), "q.toml", false)).unwrap();
    let e = prepared.at(&without).unwrap_err().to_string();
    assert!(e.contains("prepared for other effects"), "{e}");
}
