//! Bad measurement and plant files: one clear line naming the file, row and column; exit
//! code ≠ 0 from the CLI; no partial output file.

use lockstep::measurement::Measurement;
use std::path::{Path, PathBuf};
use std::process::Command;

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn csv_rows(n: usize, f: impl Fn(usize) -> String) -> String {
    let mut s = String::from("t,tau0,q0\n");
    for k in 0..n {
        s.push_str(&f(k));
        s.push('\n');
    }
    s
}

fn good_row(k: usize) -> String {
    format!(
        "{},{},{}",
        k as f64 * 0.001,
        (k as f64).sin(),
        k as f64 * 1e-4
    )
}

/// A good record of `n` rows with row `k` (0-based data row) replaced by `bad`.
fn csv_with_bad_row(n: usize, k: usize, bad: &str) -> String {
    csv_rows(n, |i| if i == k { bad.to_string() } else { good_row(i) })
}

/// `lockstep identify` on `data` with the bundled symmetric EMPS plant, writing to `out`.
fn run_identify(data: &Path, out: &Path) -> std::process::Output {
    let plant = Path::new(env!("CARGO_MANIFEST_DIR")).join("model/plants/emps_symmetric.toml");
    Command::new(env!("CARGO_BIN_EXE_lockstep"))
        .args(["identify", "idim", "--plant"])
        .arg(&plant)
        .arg("--data")
        .arg(data)
        .arg("--out")
        .arg(out)
        .output()
        .unwrap()
}

fn read_err(path: &Path) -> String {
    Measurement::read(path, &["q0"]).unwrap_err().to_string()
}

#[test]
fn missing_file() {
    let e = read_err(Path::new("no/such/file.csv"));
    assert!(
        e.contains("no/such/file.csv") && e.contains("cannot read"),
        "{e}"
    );
}

#[test]
fn missing_column_lists_the_header() {
    let d = tempfile::tempdir().unwrap();
    let p = write(
        d.path(),
        "a.csv",
        &csv_rows(20, good_row).replace("tau0", "force"),
    );
    let e = read_err(&p);
    assert!(
        e.contains("a.csv")
            && e.contains("missing column 'tau_q0' (or 'tau0', numbered from 0")
            && e.contains("t, force, q0"),
        "{e}"
    );
}

#[test]
fn non_numeric_and_nan_cells_name_row_and_column() {
    let d = tempfile::tempdir().unwrap();
    let p = write(d.path(), "b.csv", &csv_with_bad_row(20, 5, "0.005,abc,0"));
    let e = read_err(&p);
    assert!(
        e.contains("b.csv: row 7, column 'tau0': 'abc' is not a number"),
        "{e}"
    );
    let p = write(d.path(), "c.csv", &csv_with_bad_row(20, 3, "0.003,1,NaN"));
    let e = read_err(&p);
    assert!(
        e.contains("row 5, column 'q0'") && e.contains("not a finite number"),
        "{e}"
    );
}

/// Time must increase; uneven steps (a real logger's jitter) are resampled onto the median
/// period and said, a gap of missing samples refused (`measurement::sampling`).
#[test]
fn time_must_increase_and_uneven_steps_are_resampled() {
    let d = tempfile::tempdir().unwrap();
    let p = write(d.path(), "d.csv", &csv_with_bad_row(20, 8, "0.001,0,0"));
    let e = read_err(&p);
    assert!(
        e.contains("d.csv") && e.contains("row 10") && e.contains("must increase"),
        "{e}"
    );
    let p = write(
        d.path(),
        "e.csv",
        &csv_rows(20, |k| {
            format!(
                "{},0,0",
                if k < 10 {
                    k as f64 * 0.001
                } else {
                    k as f64 * 0.0011
                }
            )
        }),
    );
    let m = Measurement::read(&p, &["q0"]).unwrap();
    assert!((m.dt() - 0.0011).abs() < 1e-12, "{}", m.dt());
    assert!(
        m.notes
            .iter()
            .any(|n| n.contains("uneven sampling") && n.contains("resampled")),
        "{:?}",
        m.notes
    );
    let p = write(
        d.path(),
        "g.csv",
        &csv_rows(20, |k| {
            format!("{},0,0", if k < 10 { k } else { k + 5 } as f64 * 0.001)
        }),
    );
    let e = read_err(&p);
    assert!(
        e.contains("g.csv") && e.contains("samples are missing"),
        "{e}"
    );
}

#[test]
fn too_few_samples() {
    let d = tempfile::tempdir().unwrap();
    let p = write(d.path(), "f.csv", &csv_rows(4, good_row));
    assert!(read_err(&p).contains("too few samples: 4 rows"));
}

#[test]
fn malformed_side_file_is_named() {
    let d = tempfile::tempdir().unwrap();
    let p = write(d.path(), "g.csv", &csv_rows(20, good_row));
    write(d.path(), "g.toml", "[columns]\nt = 3\n");
    let e = read_err(&p);
    assert!(e.contains("g.toml"), "{e}");
}

#[test]
fn plant_file_errors_name_file_and_item() {
    let d = tempfile::tempdir().unwrap();
    let p = write(
        d.path(),
        "p.toml",
        "model = \"emps\"\n[[effect]]\nkind = \"viscous\"\njoints = [\"q7\"]\n",
    );
    let e = lockstep::plant::Plant::load(&p).unwrap_err().to_string();
    assert!(
        e.contains("p.toml") && e.contains("unknown joint 'q7'"),
        "{e}"
    );
    let p = write(
        d.path(),
        "p2.toml",
        "model = \"emps\"\n[[effect]]\nkind = \"stiction\"\njoints = [\"q0\"]\n",
    );
    let e = lockstep::plant::Plant::load(&p).unwrap_err().to_string();
    assert!(
        e.contains("p2.toml") && e.contains("line 3") && e.contains("stiction"),
        "{e}"
    );
    let p = write(d.path(), "p3.toml", "model = \"robot9\"\n");
    let e = lockstep::plant::Plant::load(&p).unwrap_err().to_string();
    assert!(
        e.contains("unknown model 'robot9'") && e.contains("emps"),
        "{e}"
    );
    let p = write(
        d.path(),
        "p4.toml",
        "model = \"emps\"\n[parameters]\nFc_0 = 3.0\n",
    );
    let e = lockstep::plant::Plant::load(&p).unwrap_err().to_string();
    // A numbered name (earlier versions) of an effect the plant lacks: named as written.
    assert!(e.contains("'Fc_0' belongs to nothing"), "{e}");
    let p = write(
        d.path(),
        "p5.toml",
        "model = \"emps\"\nundetermined = [\"Fc_q0\"]\n",
    );
    let e = lockstep::plant::Plant::load(&p).unwrap_err().to_string();
    assert!(
        e.contains("p5.toml") && e.contains("'undetermined': 'Fc_q0' is not a rigid-body symbol"),
        "{e}"
    );
    // Standard errors are kept only for the plant's parameters, and must be positive.
    for (file, text, needle) in [
        (
            "p6.toml",
            "model = \"emps\"\n[parameters]\nM = 95.0\n[standard_errors]\nMM = 0.1\n",
            "[standard_errors] 'MM': not a parameter of this plant",
        ),
        (
            "p7.toml",
            "model = \"emps\"\n[parameters]\nM = 95.0\n[standard_errors]\nM = -0.1\n",
            "[standard_errors] 'M': expected a positive finite standard error, found -0.1",
        ),
        // Correlations only between values with standard errors, each pair once, in [−1, 1].
        (
            "p8.toml",
            "model = \"emps\"\n[[effect]]\nkind = \"viscous\"\njoints = [\"q0\"]\n[parameters]\nM = 95.0\nFv_0 = 20.0\n[standard_errors]\nM = 0.1\n[correlations.Fv_q0]\nM = 0.5\n",
            "[correlations.Fv_q0] 'M': 'Fv_q0' has no entry in [standard_errors]",
        ),
        (
            "p9.toml",
            "model = \"emps\"\n[[effect]]\nkind = \"viscous\"\njoints = [\"q0\"]\n[parameters]\nM = 95.0\nFv_0 = 20.0\n[standard_errors]\nM = 0.1\nFv_0 = 0.2\n[correlations.Fv_q0]\nM = -1.2\n",
            "[correlations.Fv_q0] 'M': expected a correlation in [-1, 1], found -1.2",
        ),
    ] {
        let p = write(d.path(), file, text);
        let e = lockstep::plant::Plant::load(&p).unwrap_err().to_string();
        assert!(e.contains(file) && e.contains(needle), "{e}");
    }
}

#[test]
fn cli_fails_with_one_line_and_leaves_no_output() {
    let d = tempfile::tempdir().unwrap();
    let data = write(d.path(), "h.csv", &csv_with_bad_row(20, 11, "0.011,1,x"));
    let out = d.path().join("fitted.toml");
    let o = run_identify(&data, &out);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(
        err.contains("h.csv: row 13, column 'q0': 'x' is not a number"),
        "{err}"
    );
    assert!(!out.exists());
    // Too short for the filters: a clear error, still no output.
    let data = write(d.path(), "i.csv", &csv_rows(50, good_row));
    let o = run_identify(&data, &out);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("i.csv: too few samples (50)"), "{err}");
    assert!(!out.exists());
    assert_eq!(
        std::fs::read_dir(d.path())
            .unwrap()
            .filter(|e| e
                .as_ref()
                .unwrap()
                .file_name()
                .to_string_lossy()
                .starts_with('.'))
            .count(),
        0
    );
}
