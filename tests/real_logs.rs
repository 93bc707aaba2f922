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
use common::{lockstep, ok};
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
    let o = lockstep(&[
        "identify",
        "idim",
        "--plant",
        plant.to_str().unwrap(),
        "--data",
        data.to_str().unwrap(),
    ]);
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
    let o = lockstep(&[
        "identify",
        "idim",
        "--plant",
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("model/plants/emps_symmetric.toml")
            .to_str()
            .unwrap(),
        "--data",
        write(d.path(), "gapped", &header, &gapped)
            .to_str()
            .unwrap(),
    ]);
    assert!(!o.status.success());
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.contains("gapped.csv") && e.contains("samples are missing") && e.contains("2.999 s"),
        "{e}"
    );
}
