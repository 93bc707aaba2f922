//! Trustworthy under misuse: one regression test per class of defect a careful user and an
//! adversary found (issue "Trustworthy under misuse"). Each reproduces the original probe
//! through the CLI and asserts that it is now refused with one clear line, or handled, and
//! that no user file was destroyed and no partial output left.

use lockstep::measurement::Measurement;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

mod common;
use common::{lockstep, ok};

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_lockstep"))
}

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn plant(name: &str) -> String {
    root()
        .join("model/plants")
        .join(name)
        .to_string_lossy()
        .into_owned()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Failed with exit 1 and one line on stderr holding every needle; no panic.
fn refused(o: &Output, needles: &[&str]) {
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    for n in needles {
        assert!(err.contains(n), "'{n}' not in: {err}");
    }
}

/// Refused by the argument parser (exit 2) with `needle` in the message.
fn usage_error(o: &Output, needle: &str) {
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains(needle), "'{needle}' not in: {err}");
}

/// The directory's entries, sorted (to show that nothing was left behind).
fn entries(d: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(d)
        .map(|r| {
            r.map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

/// A 4 s chirp on q3 (configuration c3) in `d/tau.csv` with its side file.
fn torque_file(d: &Path) -> PathBuf {
    let tau = d.join("tau.csv");
    ok(&lockstep(&[
        "excite",
        "--model",
        "freedom6s",
        "--table",
        "4.3",
        "--test",
        "J3",
        "--config",
        "c3",
        "--duration",
        "4",
        "-o",
        s(&tau),
    ]));
    tau
}

/// Run to completion within `limit` (a hang is a failure, not a slow test).
fn within(mut c: Command, limit: Duration) -> Output {
    let mut child = c
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    loop {
        if child.try_wait().unwrap().is_some() {
            return child.wait_with_output().unwrap();
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            panic!("still running after {limit:?}: a hang");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Class 1: `-o` through a symbolic link writes the link's target and keeps the link; a
/// FIFO, a device and a directory are refused before anything is computed.
#[test]
fn an_output_symlink_is_followed_and_a_fifo_device_or_directory_is_refused() {
    let d = tempfile::tempdir().unwrap();
    let tau = torque_file(d.path());
    let p = plant("freedom6s_appendix_d_isolated.toml");
    let real = d.path().join("real.csv");
    std::fs::write(&real, "old").unwrap();
    let link = d.path().join("link.csv");
    std::os::unix::fs::symlink("real.csv", &link).unwrap();
    ok(&lockstep(&[
        "simulate",
        "--plant",
        &p,
        "--input",
        s(&tau),
        "-o",
        s(&link),
    ]));
    assert!(std::fs::symlink_metadata(&link)
        .unwrap()
        .file_type()
        .is_symlink());
    assert!(std::fs::read_to_string(&real).unwrap().starts_with("t,"));

    let fifo = d.path().join("fifo.csv");
    assert!(Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap()
        .success());
    let o = lockstep(&[
        "simulate",
        "--plant",
        &p,
        "--input",
        s(&tau),
        "-o",
        s(&fifo),
    ]);
    refused(&o, &["fifo.csv is a FIFO", "regular files"]);
    assert!(std::fs::symlink_metadata(&fifo)
        .unwrap()
        .file_type()
        .is_fifo_like());

    let o = lockstep(&[
        "simulate",
        "--plant",
        &p,
        "--input",
        s(&tau),
        "-o",
        "/dev/null",
    ]);
    refused(&o, &["/dev/null is a device"]);
    let o = lockstep(&[
        "effect",
        "add",
        "viscous",
        "--plant",
        &p,
        "--joint",
        "q3",
        "--out",
        s(d.path()),
    ]);
    refused(&o, &["is a directory"]);
    assert!(!entries(d.path()).iter().any(|e| e.contains(".tmp")));
}

trait FifoLike {
    fn is_fifo_like(&self) -> bool;
}

impl FifoLike for std::fs::FileType {
    fn is_fifo_like(&self) -> bool {
        use std::os::unix::fs::FileTypeExt;
        self.is_fifo()
    }
}

/// Class 2: the side file `<stem>.toml` never replaces the plant (an input), the
/// measurement itself, or a TOML file that is not a side file.
#[test]
fn a_side_file_never_overwrites_an_input_the_output_or_another_toml() {
    let d = tempfile::tempdir().unwrap();
    let tau = torque_file(d.path());
    let run1 = d.path().join("run1.toml");
    std::fs::copy(plant("freedom6s_appendix_d_isolated.toml"), &run1).unwrap();
    let before = std::fs::read(&run1).unwrap();
    let o = lockstep(&[
        "simulate",
        "--plant",
        s(&run1),
        "--input",
        s(&tau),
        "-o",
        s(&d.path().join("run1.csv")),
    ]);
    refused(&o, &["would overwrite the input", "run1.toml"]);
    assert_eq!(std::fs::read(&run1).unwrap(), before, "the plant is intact");
    assert!(!d.path().join("run1.csv").exists());

    let o = lockstep(&[
        "simulate",
        "--plant",
        s(&run1),
        "--input",
        s(&tau),
        "-o",
        s(&d.path().join("meas.toml")),
    ]);
    refused(&o, &["cannot be written as .toml"]);

    let notes = d.path().join("notes.toml");
    std::fs::write(&notes, "title = \"my notes\"\n").unwrap();
    let o = lockstep(&[
        "excite",
        "--model",
        "freedom6s",
        "--table",
        "4.3",
        "--test",
        "J3",
        "--config",
        "c3",
        "-o",
        s(&d.path().join("notes.csv")),
    ]);
    refused(
        &o,
        &["notes.toml exists and is not a measurement's side file"],
    );
    assert_eq!(
        std::fs::read_to_string(&notes).unwrap(),
        "title = \"my notes\"\n"
    );
}

/// Class 3: a reader that closes the pipe early (`| head -1`) ends the command quietly
/// (exit 0, no panic) and the files it promised are still written.
#[test]
fn a_closed_pipe_ends_quietly_and_the_files_are_still_written() {
    for _ in 0..200 {
        let mut child = bin()
            .arg("models")
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let mut line = String::new();
        BufReader::new(child.stdout.take().unwrap())
            .read_line(&mut line)
            .unwrap();
        // The reader is gone: stdout closed after one line.
        let o = child.wait_with_output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success() && !err.contains("panicked"), "{err}");
    }
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("params");
    let mut child = bin()
        .args(["params", "--model", "freedom6s", "--out", s(&out)])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let o = child.wait_with_output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(entries(&out), ["parameters.json", "parameters.md"]);
}

/// Classes 4 and 5: a 1e308 cell and extreme or NaN cut-offs end at once with a message
/// naming the cell or the option (they hung the SVD or panicked).
#[test]
fn a_1e308_cell_and_extreme_cutoffs_end_with_a_message() {
    let d = tempfile::tempdir().unwrap();
    let train = root().join("data/emps/emps_train.csv");
    let text = std::fs::read_to_string(&train).unwrap();
    let spiked: Vec<String> = text
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if i == 5000 {
                let mut c: Vec<&str> = l.split(',').collect();
                c[3] = "1e308";
                c.join(",")
            } else {
                l.to_string()
            }
        })
        .collect();
    let data = d.path().join("spike.csv");
    std::fs::write(&data, spiked.join("\n")).unwrap();
    std::fs::copy(
        root().join("data/emps/emps_train.toml"),
        d.path().join("spike.toml"),
    )
    .unwrap();
    let emps = plant("emps_symmetric.toml");
    let limit = Duration::from_secs(60);
    for cmd in ["identify idim", "diagnose", "compare"] {
        let mut c = bin();
        c.args(cmd.split(' '));
        c.args(["--plant", &emps, "--data", s(&data)]);
        if cmd == "compare" {
            c.args(["--out", s(&d.path().join("cmp"))]);
        }
        refused(&within(c, limit), &["row 5001", "'q_m'", "1e308"]);
    }
    for cutoff in ["1e-6", "0.01"] {
        let mut c = bin();
        c.args([
            "identify",
            "idim",
            "--plant",
            &emps,
            "--data",
            s(&train),
            "--cutoff",
            cutoff,
        ]);
        refused(&within(c, limit), &["below one cycle per record"]);
    }
    let o = lockstep(&[
        "identify",
        "idim",
        "--plant",
        &emps,
        "--data",
        s(&train),
        "--cutoff",
        "nan",
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        o.status.code() == Some(2) && err.contains("--cutoff"),
        "{err}"
    );
}

/// Class 5: a truncated or corrupt MAT file (lockstep's own output cut short) is an error
/// naming the file, never a panic.
#[test]
fn truncated_mat_files_are_refused_without_a_panic() {
    let d = tempfile::tempdir().unwrap();
    let full = d.path().join("full.mat");
    let t: Vec<f64> = (0..2000).map(|k| k as f64 * 1e-3).collect();
    let q: Vec<f64> = t.iter().map(|x| x.sin()).collect();
    let names: Vec<String> = ["t", "tau0", "q0"].iter().map(|s| s.to_string()).collect();
    lockstep::measurement::write_columns(&full, &names, &[&t, &q, &q]).unwrap();
    let bytes = std::fs::read(&full).unwrap();
    let cut = d.path().join("cut.mat");
    for k in 1..40 {
        std::fs::write(&cut, &bytes[..bytes.len() * k / 40]).unwrap();
        let e = Measurement::read(&cut, &["q0"]).unwrap_err().to_string();
        assert!(e.contains("cut.mat") && !e.contains('\u{1b}'), "{e}");
    }
    let o = lockstep(&[
        "compare",
        "--plant",
        &plant("emps_symmetric.toml"),
        "--data",
        s(&cut),
        "--out",
        s(&d.path().join("c")),
    ]);
    refused(&o, &["cut.mat", "MAT"]);
}

/// Class 6: settings that would write non-finite or wrong data are refused before a file
/// is written: infinite noise, a quantisation step the float format cannot divide by, a
/// step longer than the sample period, an excitation frequency of 1/0 or a NaN amplitude.
#[test]
fn simulate_and_excite_refuse_what_would_write_garbage() {
    let d = tempfile::tempdir().unwrap();
    let tau = torque_file(d.path());
    let p = plant("freedom6s_appendix_d_isolated.toml");
    let out = d.path().join("out");
    std::fs::create_dir(&out).unwrap();
    let o_csv = out.join("m.csv");
    for (args, needle) in [
        (vec!["--noise", "inf"], "--noise"),
        (vec!["--noise=-1"], "--noise"),
        (vec!["--noise", "1e308"], "overflow the float format"),
        (
            vec!["--quantisation", "1e-320"],
            "overflow the float format",
        ),
        (
            vec!["--step", "10"],
            "longer than the input's sample period",
        ),
    ] {
        let mut a = vec![
            "simulate",
            "--plant",
            &p,
            "--input",
            s(&tau),
            "-o",
            s(&o_csv),
        ];
        a.extend(args);
        let o = lockstep(&a);
        if needle.starts_with("--") {
            usage_error(&o, needle);
        } else {
            refused(&o, &[needle]);
        }
    }
    let ex = std::fs::read_to_string(root().join("model/excitation/freedom6s.toml")).unwrap();
    let first_omega = ex.find("omega = [").unwrap();
    for (bad, needle) in [
        ("omega = [\"1/0\", ", "'1/0' is inf"),
        ("amplitude = [nan, ", "NaN"),
    ] {
        let mut t = ex.clone();
        let at = if bad.starts_with("omega") {
            first_omega
        } else {
            ex.find("amplitude = [").unwrap()
        };
        let close = t[at..].find(',').unwrap() + at + 2;
        t.replace_range(at..close, bad);
        let f = d.path().join("ex.toml");
        std::fs::write(&f, t).unwrap();
        let o = lockstep(&[
            "excite",
            "--model",
            "freedom6s",
            "--excitation",
            s(&f),
            "--table",
            "4.3",
            "--test",
            "J3",
            "--config",
            "c3",
            "-o",
            s(&o_csv),
        ]);
        refused(&o, &[needle]);
    }
    assert!(entries(&out).is_empty(), "{:?}", entries(&out));
}

/// Class 7: IDIM does not write a plant that is not a body (here a negative mass fitted to
/// a record whose force opposes the acceleration) unless asked to.
#[test]
fn identify_refuses_to_write_a_plant_that_is_not_a_body() {
    let d = tempfile::tempdir().unwrap();
    let mut csv = String::from("t,tau0,q0\n");
    for k in 0..6000 {
        let t = k as f64 * 1e-3;
        let q = 0.05 * (2.0 * t).sin() + 0.02 * (7.0 * t).sin();
        let qdd = -0.2 * (2.0 * t).sin() - 0.98 * (7.0 * t).sin();
        let qd = 0.1 * (2.0 * t).cos() + 0.14 * (7.0 * t).cos();
        let tau = -2.0 * qdd + 10.0 * qd + 3.0 * qd.signum() + 0.5;
        csv += &format!("{t},{tau},{q}\n");
    }
    let data = d.path().join("neg.csv");
    std::fs::write(&data, csv).unwrap();
    let out = d.path().join("fitted.toml");
    let emps = plant("emps_symmetric.toml");
    let o = lockstep(&[
        "identify",
        "idim",
        "--plant",
        &emps,
        "--data",
        s(&data),
        "--cutoff",
        "20",
        "--out",
        s(&out),
    ]);
    refused(
        &o,
        &[
            "not written",
            "mass",
            "not positive",
            "--allow-inconsistent",
        ],
    );
    assert!(!out.exists());
    let o = lockstep(&[
        "identify",
        "idim",
        "--plant",
        &emps,
        "--data",
        s(&data),
        "--cutoff",
        "20",
        "--out",
        s(&out),
        "--allow-inconsistent",
    ]);
    ok(&o);
    assert!(String::from_utf8_lossy(&o.stderr).contains("warning:"));
    let m = lockstep::plant::Plant::load(&out).unwrap().parameters["M"];
    assert!((m + 2.0).abs() < 0.1, "M = {m}");
}

/// Class 9: output-error identification checks its output directory before the first fit.
#[test]
fn an_unusable_output_directory_is_refused_before_the_first_fit() {
    let d = tempfile::tempdir().unwrap();
    let file = d.path().join("taken");
    std::fs::write(&file, "x").unwrap();
    let started = Instant::now();
    let o = lockstep(&[
        "identify",
        "sequence",
        "--preset",
        "isolated",
        "--plant",
        &plant("freedom6s_appendix_d_initial_widened.toml"),
        "--data",
        s(d.path()),
        "--out",
        s(&file),
    ]);
    refused(&o, &["taken is a file: expected an output directory"]);
    assert!(started.elapsed() < Duration::from_secs(30));
}

/// Class 10: a command that fails part way leaves none of its outputs (closed loop with a
/// gain set that misses a joint after a good set; a wall rate of 0 is refused at once).
#[test]
fn a_command_that_fails_part_way_leaves_no_output() {
    let d = tempfile::tempdir().unwrap();
    let control = d.path().join("control");
    std::fs::create_dir_all(&control).unwrap();
    std::fs::create_dir_all(d.path().join("plants")).unwrap();
    std::fs::copy(
        plant("freedom6s_appendix_d_coupled.toml"),
        d.path().join("plants/freedom6s_appendix_d_coupled.toml"),
    )
    .unwrap();
    let spec = std::fs::read_to_string(root().join("model/control/freedom6s_closedloop.toml"))
        .unwrap()
        .replace("q5 = [0.08, 0.003]\n", "");
    let f = control.join("cl.toml");
    std::fs::write(&f, spec).unwrap();
    let out = d.path().join("cl");
    let o = lockstep(&[
        "closedloop",
        "--spec",
        s(&f),
        "--gains",
        "small",
        "--gains",
        "big",
        "--duration",
        "0.5",
        "--out",
        s(&out),
    ]);
    refused(&o, &["q5"]);
    assert!(entries(&out).is_empty(), "{:?}", entries(&out));

    let wall = d.path().join("wall");
    let o = lockstep(&["wall", "--rate", "0", "--out", s(&wall)]);
    assert_eq!(o.status.code(), Some(2), "a usage error");
    assert!(String::from_utf8_lossy(&o.stderr).contains("expected a positive number"));
    assert!(!wall.exists());
}

/// Class 11: two runs writing the same output leave a measurement and a side file from the
/// same run.
#[test]
fn two_runs_on_one_output_leave_a_consistent_pair() {
    let d = tempfile::tempdir().unwrap();
    let tau = torque_file(d.path());
    let p = plant("freedom6s_appendix_d_isolated.toml");
    let out = d.path().join("m.csv");
    // The reference of each seed, written alone.
    let reference = |seed: &str| {
        let r = d.path().join(format!("ref{seed}.csv"));
        ok(&lockstep(&[
            "simulate",
            "--plant",
            &p,
            "--input",
            s(&tau),
            "--noise",
            "1e-3",
            "--seed",
            seed,
            "-o",
            s(&r),
        ]));
        std::fs::read(&r).unwrap()
    };
    let refs = [reference("1"), reference("2")];
    for _ in 0..20 {
        let children: Vec<_> = ["1", "2"]
            .iter()
            .map(|seed| {
                bin()
                    .args([
                        "simulate",
                        "--plant",
                        &p,
                        "--input",
                        s(&tau),
                        "--noise",
                        "1e-3",
                        "--seed",
                        seed,
                        "-o",
                        s(&out),
                    ])
                    .stdout(Stdio::null())
                    .stderr(Stdio::null())
                    .spawn()
                    .unwrap()
            })
            .collect();
        for mut c in children {
            assert!(c.wait().unwrap().success());
        }
        let side = std::fs::read_to_string(d.path().join("m.toml")).unwrap();
        let seed = if side.contains("seed 1;") { 0 } else { 1 };
        assert!(side.contains(&format!("seed {};", seed + 1)), "{side}");
        assert!(
            std::fs::read(&out).unwrap() == refs[seed],
            "the CSV is from the other run"
        );
    }
    assert!(!entries(d.path()).iter().any(|e| e.contains(".tmp")));
}

/// Class 12: a step run alone adds to the report in --out (k1's, here c1's, is kept), and
/// --resume skips the completed steps.
#[test]
fn a_step_run_alone_adds_to_the_report_and_resume_skips_completed_steps() {
    let d = tempfile::tempdir().unwrap();
    let data = d.path().join("data");
    std::fs::create_dir(&data).unwrap();
    let truth = plant("freedom6s_appendix_d_isolated.toml");
    for (config, test) in [("c1", "J4"), ("c2", "J5")] {
        let tau = d.path().join(format!("tau_{config}.csv"));
        ok(&lockstep(&[
            "excite",
            "--model",
            "freedom6s",
            "--table",
            "4.3",
            "--test",
            test,
            "--config",
            config,
            "--duration",
            "1",
            "-o",
            s(&tau),
        ]));
        ok(&lockstep(&[
            "simulate",
            "--plant",
            &truth,
            "--input",
            s(&tau),
            "--noise",
            "2e-4",
            "-o",
            s(&data.join(format!("{config}_run.csv"))),
        ]));
    }
    let start = plant("freedom6s_appendix_d_initial_widened.toml");
    let out = d.path().join("out");
    let steps = || -> Vec<String> {
        let r: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap())
                .unwrap();
        r["steps"]
            .as_array()
            .unwrap()
            .iter()
            .map(|s| s["step"]["config"].as_str().unwrap().to_string())
            .collect()
    };
    let run = |plant: &str, more: &[&str]| {
        let mut a = vec![
            "identify",
            "sequence",
            "--preset",
            "isolated",
            "--plant",
            plant,
            "--data",
            s(&data),
            "--out",
            s(&out),
        ];
        a.extend_from_slice(more);
        lockstep(&a)
    };
    ok(&run(&start, &["--config", "c1"]));
    assert_eq!(steps(), ["c1"]);
    // Resuming checks every remaining step's files before any fit: c3 has none, so
    // nothing runs and c1's report stays.
    let o = run(&start, &["--resume"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.starts_with("resuming from"), "{err}");
    assert!(
        err.contains("error: step 'c3'") && err.contains("no measurement file"),
        "{err}"
    );
    assert_eq!(steps(), ["c1"]);
    // Resuming up to c2 runs c2 only (c1 is done) and adds it to the report.
    let o = run(&start, &["--resume", "--config", "c2"]);
    ok(&o);
    assert!(String::from_utf8_lossy(&o.stdout).contains("c2 "));
    assert_eq!(steps(), ["c1", "c2"]);
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(md.contains("c1") && md.contains("c2"));
    // c1 again, alone: replaced in place, c2 kept.
    ok(&run(s(&out.join("plant.toml")), &["--config", "c1"]));
    assert_eq!(steps(), ["c1", "c2"]);
    let o = run(&start, &["--resume", "--config", "c2"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        o.status.code() == Some(1) && err.contains("already completed"),
        "{err}"
    );
}

/// Class 13: a duration that would not fit in memory and 200,000 nested parentheses are
/// errors, not an abort or a stack overflow.
#[test]
fn huge_durations_and_deep_nesting_are_refused() {
    let d = tempfile::tempdir().unwrap();
    let o = lockstep(&[
        "excite",
        "--model",
        "freedom6s",
        "--table",
        "4.3",
        "--test",
        "J3",
        "--config",
        "c3",
        "--duration",
        "1e9",
        "-o",
        s(&d.path().join("x.csv")),
    ]);
    refused(&o, &["--duration", "GiB of memory"]);
    let deep = format!("{}1/6000{}", "(".repeat(30_000), ")".repeat(30_000));
    let o = lockstep(&[
        "simulate",
        "--plant",
        &plant("emps_symmetric.toml"),
        "--input",
        "x.csv",
        "--step",
        &deep,
        "-o",
        s(&d.path().join("y.csv")),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("nested deeper than 64"));
    assert!(entries(d.path()).is_empty());
}

/// Class 14: `--data DIR` works in torque space as it does in output space.
#[test]
fn a_data_directory_works_in_torque_space() {
    let d = tempfile::tempdir().unwrap();
    let data = d.path().join("emps");
    std::fs::create_dir(&data).unwrap();
    for f in ["emps_train.csv", "emps_train.toml"] {
        std::fs::copy(root().join("data/emps").join(f), data.join(f)).unwrap();
    }
    // IDIM works in torque space only.
    let out = ok(&lockstep(&[
        "identify",
        "idim",
        "--plant",
        &plant("emps_symmetric.toml"),
        "--data",
        s(&data),
    ]));
    assert!(
        out.contains("1 record(s)") && out.contains("Fc_q0"),
        "{out}"
    );
    let empty = d.path().join("none");
    std::fs::create_dir(&empty).unwrap();
    let o = lockstep(&[
        "compare",
        "--plant",
        &plant("emps_symmetric.toml"),
        "--data",
        s(&empty),
        "--out",
        s(&d.path().join("c2")),
    ]);
    refused(&o, &["holds no .csv or .mat file"]);
}

/// Class 15 and the confusing messages: `[bounds]` of three numbers, an empty CSV and a
/// duplicated column are named.
#[test]
fn bad_bounds_an_empty_csv_and_a_duplicate_column_are_named() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("p.toml");
    std::fs::write(
        &p,
        "model = \"emps\"\n[parameters]\nM = 2.0\n[bounds]\nM = [1, 3, 5]\n",
    )
    .unwrap();
    refused(
        &lockstep(&["check", "--plant", s(&p)]),
        &["line 4", "'M'", "two numbers", "found 3"],
    );
    let empty = d.path().join("empty.csv");
    std::fs::write(&empty, "").unwrap();
    let e = Measurement::read(&empty, &["q0"]).unwrap_err().to_string();
    assert!(e.contains("empty.csv: the file is empty"), "{e}");
    let dup = d.path().join("dup.csv");
    std::fs::write(&dup, "t,tau0,q0,q0\n0,1,2,3\n").unwrap();
    let e = Measurement::read(&dup, &["q0"]).unwrap_err().to_string();
    assert!(e.contains("'q0' twice (columns 3 and 4)"), "{e}");
}

/// Class 10: Ctrl-C during a large write (5e4 s at 100 Hz, 5 million rows, about 1 GB of
/// memory at most) removes the temporary file and leaves no output.
#[test]
fn ctrl_c_during_a_large_write_leaves_nothing_behind() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("long.csv");
    let mut child = bin()
        .args([
            "excite",
            "--model",
            "freedom6s",
            "--table",
            "4.3",
            "--test",
            "J3",
            "--config",
            "c3",
            "--duration",
            "5e4",
            "-o",
            s(&out),
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // Wait for the temporary file of the write to appear, then interrupt.
    let start = Instant::now();
    while !entries(d.path()).iter().any(|e| e.contains(".tmp")) {
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "no write started"
        );
        assert!(
            child.try_wait().unwrap().is_none(),
            "finished before it could be interrupted"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    std::thread::sleep(Duration::from_millis(100));
    let pid = child.id().to_string();
    assert!(Command::new("kill")
        .args(["-INT", &pid])
        .status()
        .unwrap()
        .success());
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(130));
    assert!(entries(d.path()).is_empty(), "{:?}", entries(d.path()));
}
