//! `lockstep excite` → `lockstep simulate` → a measurement file that reads back, and the
//! errors of both commands: one line naming the option, file or item, no output left.

use lockstep::measurement::{Measurement, Table};
use std::path::{Path, PathBuf};
use std::process::Output;

mod common;
use common::lockstep;

fn coupled_plant() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("model/plants/freedom6s_appendix_d_coupled.toml")
}

fn fails(o: &Output, needles: &[&str]) {
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    for n in needles {
        assert!(err.contains(n), "'{n}' not in: {err}");
    }
}

#[test]
fn excite_then_simulate_makes_noisy_quantised_data_of_the_configuration() {
    let d = tempfile::tempdir().unwrap();
    let tau = d.path().join("k1_tau.csv");
    let o = lockstep(&[
        "excite",
        "--model",
        "freedom6s",
        "--table",
        "4.7",
        "--config",
        "k1",
        "--duration",
        "10",
        "-o",
        tau.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // A note: on stderr (stdout carries results only).
    assert!(String::from_utf8_lossy(&o.stderr).contains("note: q0, q1, q2, q3 locked"));
    let t = Table::read(&tau).unwrap();
    assert_eq!(t.side.configuration.as_deref(), Some("k1"));
    let tau5 = t.need("tau_q5").unwrap();
    assert_eq!(tau5.len(), 1001);
    assert_eq!(tau5[0], 0.0055); // Table 4.7: A5(0) cos(0)
    assert!(t.need("tau_q0").unwrap().iter().all(|&x| x == 0.0));
    for (ext, noise) in [("csv", "2e-4"), ("mat", "0")] {
        let out = d.path().join(format!("k1.{ext}"));
        let o = lockstep(&[
            "simulate",
            "--plant",
            coupled_plant().to_str().unwrap(),
            "--input",
            tau.to_str().unwrap(),
            "--locked",
            "q1=0.1",
            "--noise",
            noise,
            "--quantisation",
            "1e-4",
            "--seed",
            "7",
            "-o",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        // Warnings go to stderr (stdout carries results only).
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(
            stderr.contains("warning:") && stderr.contains("link 'L7'"),
            "{stderr}"
        );
        let m = Measurement::read(&out, &["q0", "q1", "q2", "q3", "q4", "q5"]).unwrap();
        assert_eq!(m.len(), 1001);
        // Positions on the 1e-4 grid; locked joint 1 at 0.1 within the noise.
        for q in &m.q {
            assert!(q
                .iter()
                .all(|x| ((x / 1e-4) - (x / 1e-4).round()).abs() < 1e-6));
        }
        let spread = m.q[1].iter().map(|x| (x - 0.1).abs()).fold(0.0, f64::max);
        assert!(spread < 1e-3, "{spread}");
        // Joints 4 and 5 move; the side file records configuration and locked positions.
        assert!(m.q[4].iter().any(|x| x.abs() > 0.1));
        let side = Table::read(&out).unwrap().side;
        assert_eq!(side.configuration.as_deref(), Some("k1"));
        assert_eq!(side.locked["q1"], 0.1);
    }
}

#[test]
fn excite_and_simulate_errors_name_the_item() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("x.csv");
    // `lockstep excite` on the Freedom 6S with these table/test/config arguments, into `out`.
    let excite = |extra: &[&str]| {
        let mut a = vec![
            "excite",
            "--model",
            "freedom6s",
            "-o",
            out.to_str().unwrap(),
        ];
        a.extend_from_slice(extra);
        lockstep(&a)
    };
    let o = excite(&["--table", "9.9", "--config", "k1"]);
    fails(&o, &["no table '9.9'", "4.3, 4.4, 4.5, 4.7, 4.9"]);
    let o = excite(&["--table", "4.4", "--config", "c1"]);
    fails(&o, &["--test", "J4-1"]);
    let o = excite(&["--table", "4.4", "--test", "J0-1", "--config", "c1"]);
    fails(&o, &["drives q0", "none of them free", "free: q4"]);
    assert!(!out.exists());

    // A torque file without the column of a free joint.
    let tau = d.path().join("tau.csv");
    let mut text = String::from("t,tau4\n");
    for k in 0..20 {
        text.push_str(&format!("{},{}\n", k as f64 * 0.01, 0.001));
    }
    std::fs::write(&tau, text).unwrap();
    let plant = coupled_plant();
    let sim = |extra: &[&str]| {
        let mut a = vec![
            "simulate",
            "--plant",
            plant.to_str().unwrap(),
            "--input",
            tau.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ];
        a.extend_from_slice(extra);
        lockstep(&a)
    };
    fails(&sim(&[]), &["tau.csv", "no configuration", "--config"]);
    fails(
        &sim(&["--config", "k1"]),
        &["tau.csv", "missing column 'tau_q5' (or 'tau5'", "t, tau4"],
    );
    fails(
        &sim(&["--config", "c1", "--initial", "q0=0.2"]),
        &["--initial", "'q0' is locked"],
    );
    fails(
        &sim(&["--config", "c1", "--locked", "q9=0.2"]),
        &["--locked", "unknown joint 'q9'"],
    );
    fails(&sim(&["--config", "c1", "--step", "0"]), &["--step"]);
    fails(
        &sim(&["--config", "k3"]),
        &["link 'L4'", "not positive definite", "--allow-inconsistent"],
    );
    assert!(!out.exists());
    assert!(std::fs::read_dir(d.path()).unwrap().all(|e| !e
        .unwrap()
        .file_name()
        .to_string_lossy()
        .starts_with('.')));
}

/// `lockstep check --against`: the values of a reference plant a fit from `--plant` cannot
/// reach (Appendix D's coupled m2 outside the thesis bounds), none from the widened start;
/// a reference of another model is refused in one line before anything is printed.
#[test]
fn check_against_lists_the_reference_values_outside_the_bounds() {
    let plants = Path::new(env!("CARGO_MANIFEST_DIR")).join("model/plants");
    let coupled = coupled_plant();
    let run = |start: &str, against: &Path| {
        lockstep(&[
            "check",
            "--plant",
            plants.join(start).to_str().unwrap(),
            "--against",
            against.to_str().unwrap(),
        ])
    };
    let o = run("freedom6s_appendix_d_initial.toml", &coupled);
    assert!(o.status.success());
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("9 value(s) of "), "{out}");
    assert!(
        out.contains("  m2 = 3.75590e-1 outside [9.86000e-2, 2.95800e-1]"),
        "{out}"
    );
    let o = run("freedom6s_appendix_d_initial_widened.toml", &coupled);
    assert!(o.status.success());
    assert!(String::from_utf8_lossy(&o.stdout).contains("lies within the bounds"));
    let o = run(
        "freedom6s_appendix_d_initial.toml",
        &plants.join("emps_viscous.toml"),
    );
    fails(&o, &["emps_viscous.toml", "model 'emps'", "'freedom6s'"]);
    assert!(o.stdout.is_empty());
}

/// A diverging simulation advises a smaller step only where a quarter of it was tried and
/// ran: an EMPS cart on a stiff spring (ω = 1000 rad/s) at a step RK4 cannot hold
/// (h ω = 10 > 2.8) runs at a quarter of it (2.5); the same cart pushed by a constant
/// 50 kN (terminal speed 245 m/s) runs past the speed bound whatever the step, and the
/// message says the step is not the cause.
#[test]
fn a_smaller_step_is_advised_only_where_it_was_tried_and_helped() {
    let d = tempfile::tempdir().unwrap();
    // The cart with the benchmark's mass and viscous friction (IDIM's values, rounded).
    let cart = "model = \"emps\"\ndescription = \"cart\"\n\n[[effect]]\nkind = \"viscous\"\njoints = [\"q0\"]\n";
    let emps = d.path().join("cart.toml");
    std::fs::write(
        &emps,
        format!("{cart}\n[parameters]\nM = 95.1\nFv_0 = 203.5\n"),
    )
    .unwrap();
    let stiff = d.path().join("stiff.toml");
    std::fs::write(
        &stiff,
        format!("{cart}\n[[effect]]\nkind = \"spring\"\njoints = [\"q0\"]\n\n[parameters]\nM = 95.1\nFv_0 = 203.5\nKs_0 = 9.5e7\nqeq_0 = 0.0\n"),
    )
    .unwrap();
    let input = |name: &str, force: f64| {
        let p = d.path().join(name);
        let mut s = String::from("t,tau0\n");
        for k in 0..=2000 {
            s += &format!("{},{force}\n", k as f64 * 1e-2);
        }
        std::fs::write(&p, s).unwrap();
        std::fs::write(p.with_extension("toml"), "configuration = \"full\"\n").unwrap();
        p
    };
    let simulate = |plant: &Path, input: &Path, step: &str| {
        lockstep(&[
            "simulate",
            "--plant",
            plant.to_str().unwrap(),
            "--input",
            input.to_str().unwrap(),
            "--step",
            step,
            "--initial",
            "q0=0.01",
            "-o",
            d.path().join("out.csv").to_str().unwrap(),
        ])
    };
    fails(
        &simulate(&stiff, &input("still.csv", 0.0), "1e-2"),
        &["diverged", "runs at a quarter of the step", "--step 2.5e-3"],
    );
    fails(
        &simulate(&emps, &input("pushed.csv", 5e4), "1e-3"),
        &["diverged", "the step is not the cause"],
    );
    assert!(!d.path().join("out.csv").exists());
}
