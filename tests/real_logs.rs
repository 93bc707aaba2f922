//! Real logs as they come (issue 57): jittered time stamps, exact repeats and stale rows are
//! taken, said, and do not change the fit; a gap of missing samples is refused naming it.
//!
//! The reference is the EMPS benchmark's own record (real measurements, 1 kHz, evenly
//! sampled) fitted by IDIM-LS. Its jittered copy is what a non-real-time logger writes: the
//! same signals sampled at times off the 1 ms grid by up to ±30 % of the period (the values
//! at those times by linear interpolation of the record), so the fit of the resampled copy
//! must agree with the original's to within the interpolation's smoothing of the
//! measurement noise.

mod common;
use common::{identify_idim, lockstep, ok};
use std::path::{Path, PathBuf};

fn emps() -> (Vec<String>, Vec<Vec<f64>>) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/emps");
    let text = std::fs::read_to_string(dir.join("emps_train.csv")).unwrap();
    let mut lines = text.lines();
    let header: Vec<String> = lines.next().unwrap().split(',').map(String::from).collect();
    let rows = lines
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    (header, rows)
}

/// `rows` written as `name` in `dir` with EMPS's side file beside it.
fn write(dir: &Path, name: &str, header: &[String], rows: &[Vec<f64>]) -> PathBuf {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/emps/emps_train.toml");
    let path = dir.join(format!("{name}.csv"));
    std::fs::copy(src, path.with_extension("toml")).unwrap();
    let mut s = header.join(",") + "\n";
    for r in rows {
        s += &r
            .iter()
            .map(|x| format!("{x:e}"))
            .collect::<Vec<_>>()
            .join(",");
        s.push('\n');
    }
    std::fs::write(&path, s).unwrap();
    path
}

/// `identify idim` of the symmetric EMPS plant on `data`: the fitted values by name, and
/// what the run printed on standard error.
fn fit(data: &Path) -> (Vec<(String, f64, f64)>, String) {
    let plant = Path::new(env!("CARGO_MANIFEST_DIR")).join("model/plants/emps_symmetric.toml");
    let o = identify_idim(&plant, data, &[]);
    let out = ok(&o);
    let values = out
        .lines()
        .filter_map(|l| {
            let w: Vec<&str> = l.split_whitespace().collect();
            match w.as_slice() {
                [name, v, se, _] => Some((name.to_string(), v.parse().ok()?, se.parse().ok()?)),
                _ => None,
            }
        })
        .collect();
    (values, String::from_utf8_lossy(&o.stderr).into_owned())
}

#[test]
fn a_jittered_log_is_resampled_and_fits_as_the_even_one() {
    let d = tempfile::tempdir().unwrap();
    let (header, rows) = emps();
    let (reference, said) = fit(&write(d.path(), "even", &header, &rows));
    assert!(reference.len() >= 4, "{reference:?}");
    assert!(!said.contains("note:"), "{said}");
    // ±30 % of the period, deterministic, first and last sample on the grid.
    let h = rows[1][0] - rows[0][0];
    let mut seed = 0x9e37_79b9_7f4a_7c15_u64;
    let n = rows.len();
    let jittered: Vec<Vec<f64>> = (0..n)
        .map(|k| {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            let r = (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0;
            let t = rows[k][0]
                + if k == 0 || k == n - 1 {
                    0.0
                } else {
                    0.3 * h * r
                };
            // The record's signals at t, by linear interpolation.
            let i = ((t - rows[0][0]) / h).floor().clamp(0.0, (n - 2) as f64) as usize;
            let w = (t - rows[i][0]) / h;
            let mut row: Vec<f64> = (0..header.len())
                .map(|c| rows[i][c] + w * (rows[i + 1][c] - rows[i][c]))
                .collect();
            row[0] = t;
            row
        })
        .collect();
    let (values, said) = fit(&write(d.path(), "jittered", &header, &jittered));
    assert!(
        said.contains("uneven sampling") && said.contains("resampled"),
        "{said}"
    );
    for ((name, v, se), (_, v0, _)) in values.iter().zip(&reference) {
        // Measured: every value within 0.17 standard errors and 0.09 % of the even log's.
        assert!(
            (v - v0).abs() <= se.max(1e-3 * v0.abs()),
            "{name}: {v} against {v0} (σ {se})"
        );
    }
}

#[test]
fn repeats_and_stale_rows_are_said_and_a_gap_is_refused() {
    let d = tempfile::tempdir().unwrap();
    let (header, rows) = emps();
    let (reference, _) = fit(&write(d.path(), "even", &header, &rows));
    // Row 2001 (line 2002) written twice; lines 5002–5004 repeat line 5001's values.
    let mut logged = rows.clone();
    logged.insert(2001, rows[2000].clone());
    for k in 5001..5004 {
        let t = logged[k][0];
        logged[k] = logged[5000].clone();
        logged[k][0] = t;
    }
    let (values, said) = fit(&write(d.path(), "logged", &header, &logged));
    assert!(
        said.contains("1 exact repeat(s)") && said.contains("row 2003"),
        "{said}"
    );
    assert!(
        said.contains("3 stale row(s)") && said.contains("rows 5003–5005"),
        "{said}"
    );
    // Interpolated over, the stale rows leave the fit as it was (kept as logged, they moved
    // the mass by 4.4 standard errors).
    for ((name, v, se), (_, v0, _)) in values.iter().zip(&reference) {
        assert!((v - v0).abs() <= *se, "{name}: {v} against {v0} (σ {se})");
    }
    // Ten samples missing: refused, naming where.
    let mut gapped = rows.clone();
    gapped.drain(3000..3010);
    let o = identify_idim(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("model/plants/emps_symmetric.toml"),
        &write(d.path(), "gapped", &header, &gapped),
        &[],
    );
    assert!(!o.status.success());
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.contains("gapped.csv") && e.contains("samples are missing") && e.contains("2.999 s"),
        "{e}"
    );
}

/// A one-joint oscillator m ÿ + c ẏ + k (y − y_eq) = u sampled at 610.35 Hz (the Silverbox
/// benchmark's rate), its resonance at 60 Hz (ζ = 0.05), driven by a random-phase multisine
/// of 1–200 Hz. The response is the exact periodic steady state, Σ |H(jω)| A sin(ωt + φ +
/// ∠H(jω)) with H = 1/(k − mω² + jcω): no simulator is involved. Noise σ = 1e-4 on y and 1 %
/// of u's RMS on u. The speed reaches several hundred units/s.
const OSC_RATE: f64 = 610.35;
const OSC_M: f64 = 1.0;
const OSC_F0: f64 = 60.0;
const OSC_ZETA: f64 = 0.05;
const OSC_YEQ: f64 = 0.05;

fn oscillator(dir: &Path) -> PathBuf {
    use std::f64::consts::PI;
    let wn = 2.0 * PI * OSC_F0;
    let (k, c) = (OSC_M * wn * wn, 2.0 * OSC_ZETA * wn * OSC_M);
    let n = (8.0 * OSC_RATE) as usize;
    let mut seed = 0x2545_f491_4f6c_dd1d_u64;
    let mut uniform = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64
    };
    // Lines every 0.5 Hz from 1 to 200 Hz, amplitude 4000 N each: y's RMS about 1 unit,
    // speeds to several hundred units/s.
    let lines: Vec<(f64, f64)> = (2..=400)
        .map(|i| (2.0 * PI * 0.5 * i as f64, 2.0 * PI * uniform()))
        .collect();
    let mut gauss = move || {
        let (a, b) = (uniform().max(1e-300), uniform());
        (-2.0 * a.ln()).sqrt() * (2.0 * PI * b).cos()
    };
    let (mut u, mut y) = (vec![0.0; n], vec![0.0; n]);
    for s in 0..n {
        let t = s as f64 / OSC_RATE;
        for &(w, phi) in &lines {
            let (re, im) = (k - OSC_M * w * w, c * w);
            let (gain, lag) = (1.0 / re.hypot(im), im.atan2(re));
            u[s] += 4000.0 * (w * t + phi).sin();
            y[s] += 4000.0 * gain * (w * t + phi - lag).sin();
        }
        y[s] += OSC_YEQ;
    }
    let u_rms = (u.iter().map(|x| x * x).sum::<f64>() / n as f64).sqrt();
    let path = dir.join("oscillator.csv");
    let mut text = String::from("t,tau0,q0\n");
    for s in 0..n {
        text += &format!(
            "{:e},{:e},{:e}\n",
            s as f64 / OSC_RATE,
            u[s] + 0.01 * u_rms * gauss(),
            y[s] + 1e-4 * gauss()
        );
    }
    std::fs::write(&path, text).unwrap();
    std::fs::write(
        dir.join("oscillator.toml"),
        "description = \"one-joint oscillator, exact steady state\"\nconfiguration = \"full\"\nhold = \"bandlimited\"\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("oscillator_plant.toml"),
        "model = \"emps\"\n\n[[effect]]\nkind = \"viscous\"\njoints = [\"q0\"]\n\n\
         [[effect]]\nkind = \"spring\"\njoints = [\"q0\"]\n\n[parameters]\nM = 0.5\nFv_0 = 1.0\n\
         Ks_q0 = 1.0e5\nqeq_0 = 0.0\n",
    )
    .unwrap();
    path
}

#[test]
fn a_610_hz_oscillator_keeps_its_resonance_and_a_fast_record_is_simulated() {
    use std::f64::consts::PI;
    let d = tempfile::tempdir().unwrap();
    let data = oscillator(d.path());
    let plant = d.path().join("oscillator_plant.toml");
    let fitted = d.path().join("fitted.toml");
    let o = identify_idim(&plant, &data, &["--out", fitted.to_str().unwrap()]);
    let out = ok(&o);
    let said = String::from_utf8_lossy(&o.stderr);
    eprintln!("{said}{out}");
    let line = out
        .lines()
        .find(|l| l.starts_with("preparation:"))
        .unwrap_or_else(|| panic!("{out}"));
    // The fit band reaches past the resonance: nothing filtered or decimated away.
    let band: f64 = line
        .split("fit band ")
        .nth(1)
        .and_then(|r| r.split(' ').next())
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("{line}"));
    assert!(band > 2.0 * OSC_F0, "{line}");
    assert!(line.contains("band-limited"), "{line}");
    let value = |name: &str| -> f64 {
        out.lines()
            .find_map(|l| {
                let w: Vec<&str> = l.split_whitespace().collect();
                (w.len() >= 2 && w[0] == name).then(|| w[1].parse().unwrap())
            })
            .unwrap_or_else(|| panic!("{name} not in {out}"))
    };
    let wn = 2.0 * PI * OSC_F0;
    // Measured: M +0.007 %, Fv_q0 +0.05 %, Ks_q0 −0.008 %, qeq_q0 −0.08 %.
    for (name, truth, tol) in [
        ("M", OSC_M, 0.005),
        ("Fv_q0", 2.0 * OSC_ZETA * wn * OSC_M, 0.01),
        ("Ks_q0", OSC_M * wn * wn, 0.005),
        ("qeq_q0", OSC_YEQ, 0.005),
    ] {
        let v = value(name);
        assert!(
            (v / truth - 1.0).abs() <= tol,
            "{name} = {v}, truth {truth}"
        );
    }
    // The fitted plant simulated on the record (output space): its speeds beyond 100
    // units/s are the record's own, not a divergence.
    let o = lockstep(&[
        "compare",
        "--plant",
        fitted.to_str().unwrap(),
        "--data",
        data.to_str().unwrap(),
        "--space",
        "output",
        "--skip",
        "300",
        "--out",
        d.path().join("cmp").to_str().unwrap(),
    ]);
    let out = ok(&o);
    let fit: f64 = out
        .lines()
        .find_map(|l| {
            let w: Vec<&str> = l.split_whitespace().collect();
            (w.len() > 3 && w[0] == "oscillator" && w[1] == "q0").then(|| w[2].parse().unwrap())
        })
        .unwrap_or_else(|| panic!("{out}"));
    // Measured: 98.2 % (speeds to 761 units/s; the bound was a fixed 100 until now).
    assert!(fit > 95.0, "{out}");
}
