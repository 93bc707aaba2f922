//! Reports of the control commands: `lockstep closedloop`, `lockstep wall`, `lockstep wall
//! tune` (tables on stdout and in markdown/JSON, figures, rule tables as FLL and FIS).

use crate::control::closedloop::{ClosedLoop, ClosedLoopRun};
use crate::control::fuzzy::Fam;
use crate::control::tune::tune;
use crate::control::wall::{Metrics, Run, WallLaw};
use crate::control::WallSetup;
use crate::files::write_atomic;
use crate::measurement::Measurement;
use crate::report::plot::{figure, Panel, Series, Style};
use anyhow::{bail, Context, Result};
use rayon::prelude::*;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// What `lockstep wall` and `lockstep wall tune` run: the wall file, an optional rule table
/// replacing its modified one, the control rate and the output directory.
#[derive(Debug, Clone)]
pub struct WallRun {
    /// Wall file (plant, loop, PD gains, user, membership functions, rule modifications).
    pub spec: PathBuf,
    /// Rule table (.fll fuzzylite or .fis MATLAB) replacing the file's modified one.
    pub rules: Option<PathBuf>,
    /// Control rate for the hand sweep and tuning (Hz); `None`: the file's first rate.
    pub rate: Option<f64>,
    /// Output directory.
    pub out: PathBuf,
}

/// Metric definitions, printed in every wall report.
pub const METRIC_DEFINITIONS: &str = "\
- peak penetration = max(−q) after first contact (mrad)
- steady penetration = mean(−q) over the last 20 % of the run (mrad)
- losses = exits from the wall (q < 0 → q ≥ 0) after first contact
- restitution = |q̇ at first exit| / |q̇ at first contact| (0 without exit)
- oscillation amplitude = ½ (max q − min q) over the second half of the time after contact (mrad)
- oscillation frequency = crossings of that window's mean / 2 / window length (Hz)
- settling = time after contact from which |q − q_steady| ≤ max(5 % peak, 2 counts) holds (s; — never)
- energy generated = max_n(−E(n)), E(n) = E(n−1) − F(n−1)(q(n) − q(n−1)), F(n−1) the wall torque
  held over the last sample period (hold-aware passivity observer; > 0 means the wall is active) (mJ)
";

/// The metric columns of a table row.
pub fn metric_row(m: &Metrics) -> String {
    format!(
        "{:>7.3} {:>8.3} {:>7.3} {:>6} {:>6.2} {:>8.3} {:>6.1} {:>8} {:>9.3}",
        m.approach_speed,
        1e3 * m.peak_penetration,
        1e3 * m.steady_penetration,
        m.contact_losses,
        m.restitution,
        1e3 * m.oscillation_amplitude,
        m.oscillation_frequency,
        m.settling_time
            .map_or("—".to_string(), |s| format!("{s:.3}")),
        1e3 * m.energy_generated
    )
}

/// The header matching [`metric_row`].
pub const METRIC_HEADER: &str =
    "  v_in    peak    steady losses  rest.   osc.amp  freq  settling  E_gen";
/// Units line under [`METRIC_HEADER`].
pub const METRIC_UNITS: &str =
    " rad/s    mrad     mrad           |v|     mrad     Hz       s      mJ";

fn load_rules(setup: &WallSetup, rules: Option<&Path>) -> Result<Fam> {
    let Some(p) = rules else {
        return Ok(setup.modified.clone());
    };
    let text = std::fs::read_to_string(p)
        .with_context(|| format!("{}: cannot read the rule table", p.display()))?;
    let origin = p.display().to_string();
    match p.extension().and_then(|e| e.to_str()) {
        Some("fll") => Fam::from_fll(&text, &origin),
        Some("fis") => Fam::from_fis(&text, &origin),
        _ => bail!("{origin}: a rule table must be .fll (fuzzylite) or .fis (MATLAB)"),
    }
}

fn write_rule_files(out: &Path, stem: &str, fam: &Fam) -> Result<()> {
    write_atomic(
        &out.join(format!("{stem}.fll")),
        fam.to_fll(stem).as_bytes(),
    )?;
    write_atomic(
        &out.join(format!("{stem}.fis")),
        fam.to_fis(stem).as_bytes(),
    )
}

/// Position-vs-time figure: one panel per approach speed, PD and fuzzy runs.
fn position_figure(stem: &Path, rate: f64, names: &[String], runs: &[(Run, Run)]) -> Result<()> {
    // From 0.1 s before the first contact: the approach would dwarf the contact.
    let thin = |r: &Run, from: f64| {
        let k0 = r.t.partition_point(|&t| t < from);
        let k = ((r.t.len() - k0) / 3000).max(1);
        (
            r.t[k0..].iter().step_by(k).copied().collect::<Vec<_>>(),
            r.q[k0..]
                .iter()
                .step_by(k)
                .map(|q| 1e3 * q)
                .collect::<Vec<_>>(),
        )
    };
    let panels: Vec<Panel> = names
        .iter()
        .zip(runs)
        .map(|(name, (pd, fz))| {
            let from = (pd.metrics.t_contact.min(fz.metrics.t_contact) - 0.1).max(0.0);
            let (t0, q0) = thin(pd, from);
            let (t1, q1) = thin(fz, from);
            let wall = Series {
                name: "wall".into(),
                x: vec![t0[0], *t0.last().unwrap_or(&0.0)],
                y: vec![0.0, 0.0],
                style: Style::Line,
            };
            Panel {
                title: format!(
                    "{name} approach, {rate} Hz: joint 0 (v_in PD {:.2}, fuzzy {:.2} rad/s)",
                    pd.metrics.approach_speed, fz.metrics.approach_speed
                ),
                x_label: "t (s)".into(),
                y_label: "q0 (mrad)".into(),
                series: vec![
                    Series {
                        name: "PD".into(),
                        x: t0,
                        y: q0,
                        style: Style::Line,
                    },
                    Series {
                        name: "fuzzy".into(),
                        x: t1,
                        y: q1,
                        style: Style::Line,
                    },
                    wall,
                ],
            }
        })
        .collect();
    figure(stem, &panels, 1000).map(|_| ())
}

/// Control surfaces as slices u(q) at fixed q̇ (Figures 5.7-5.9).
fn surface_figure(stem: &Path, pd: &WallLaw, fz: &Fam) -> Result<()> {
    let qs: Vec<f64> = (0..=400).map(|k| -0.04 + 0.05 * k as f64 / 400.0).collect();
    let speeds = [-5.0, -2.5, 0.0, 2.5, 5.0];
    let slice = |f: &dyn Fn(f64, f64) -> f64| -> Vec<Series> {
        speeds
            .iter()
            .map(|&v| Series {
                name: format!("q̇ = {v} rad/s"),
                x: qs.iter().map(|q| 1e3 * q).collect(),
                y: qs.iter().map(|&q| f(q, v)).collect(),
                style: Style::Line,
            })
            .collect()
    };
    let fzl = WallLaw::Fuzzy(fz.clone());
    let panels = vec![
        Panel {
            title: "PD wall u = k1 q + k2 q̇ inside (Figure 5.7)".into(),
            x_label: "q (mrad)".into(),
            y_label: "u (N·m)".into(),
            series: slice(&|q, v| pd.u(q, v)),
        },
        Panel {
            title: "fuzzy wall, modified rules (Figure 5.8)".into(),
            x_label: "q (mrad)".into(),
            y_label: "u (N·m)".into(),
            series: slice(&|q, v| fzl.u(q, v)),
        },
        Panel {
            title: "fuzzy − PD (Figure 5.9)".into(),
            x_label: "q (mrad)".into(),
            y_label: "Δu (N·m)".into(),
            series: slice(&|q, v| fzl.u(q, v) - pd.u(q, v)),
        },
    ];
    figure(stem, &panels, 1000).map(|_| ())
}

/// One comparison of PD and fuzzy at a rate: runs per approach speed.
type Comparison = Vec<(Run, Run)>;

fn compare_at(setup: &WallSetup, fz: &WallLaw, rate: f64) -> Result<Comparison> {
    let hand = setup.spec.nominal_hand();
    let pd = setup.runs(&WallLaw::Pd(setup.spec.pd), &hand, rate)?;
    let fz = setup.runs(fz, &hand, rate)?;
    Ok(pd.into_iter().zip(fz).collect())
}

/// `lockstep wall`: PD vs fuzzy table per rate and approach speed, hand sweep, thesis
/// observation 2, figures and rule files in `args.out`.
///
/// # Errors
/// Bad wall file or rule table (named), simulation failures, unwritable output.
pub fn wall_command(args: &WallRun) -> Result<()> {
    let setup = WallSetup::load(&args.spec)?;
    let fam = load_rules(&setup, args.rules.as_deref())?;
    let fz = WallLaw::Fuzzy(fam.clone());
    let pd = WallLaw::Pd(setup.spec.pd);
    let out = &args.out;
    std::fs::create_dir_all(out).with_context(|| format!("{}: cannot create", out.display()))?;
    let names: Vec<String> = setup.spec.approach.iter().map(|a| a.name.clone()).collect();
    let mut md = format!(
        "# Virtual wall: PD vs fuzzy\n\nWall file `{}`; PD k1 = {} N·m/rad, k2 = {} N·m·s/rad; rules: {}; hand: {} kg at r = {} m, grip {} N/m, {} N·s/m; delay {} sample(s), encoder {} counts/rev.\n\n```\n",
        setup.path.display(),
        setup.spec.pd.k1,
        setup.spec.pd.k2,
        args.rules
            .as_ref()
            .map_or("Kubica + Figure 5.6 modifications".to_string(), |p| p.display().to_string()),
        setup.spec.hand.mass,
        setup.spec.hand.radius,
        setup.spec.hand.grip_stiffness[0],
        setup.spec.hand.grip_damping[0],
        setup.spec.loop_.delay,
        setup.spec.loop_.encoder_counts
    );
    let mut json_runs = Vec::new();
    for &rate in &setup.spec.loop_.rates {
        let runs = compare_at(&setup, &fz, rate)?;
        let mut t = format!(
            "{rate} Hz\n{:<8} {:<6} {METRIC_HEADER}\n{:<8} {:<6} {METRIC_UNITS}\n",
            "approach", "wall", "", ""
        );
        for (name, (p, f)) in names.iter().zip(&runs) {
            for (w, r) in [("PD", p), ("fuzzy", f)] {
                let _ = writeln!(t, "{name:<8} {w:<6} {}", metric_row(&r.metrics));
                json_runs.push(serde_json::json!({
                    "rate": rate, "approach": name, "wall": w, "metrics": r.metrics
                }));
            }
        }
        crate::outln!("{t}");
        md += &t;
        md += "\n";
        position_figure(&out.join(format!("position_{rate}hz")), rate, &names, &runs)?;
        // Thesis observation 2 at this rate.
        let peaks: Vec<(f64, f64)> = runs
            .iter()
            .map(|(p, _)| (p.metrics.approach_speed, p.metrics.peak_penetration))
            .collect();
        let deeper = peaks.windows(2).all(|w| w[1].1 > w[0].1);
        let obs = format!(
            "Thesis observation 2 at {rate} Hz (PD wall: boundary felt deeper at faster approach): {} — peak penetration {}\n",
            if deeper { "holds" } else { "does not hold" },
            peaks
                .iter()
                .map(|(v, p)| format!("{:.2} mrad at {v:.2} rad/s", 1e3 * p))
                .collect::<Vec<_>>()
                .join(", ")
        );
        crate::outln!("{obs}");
        md += &obs;
        md += "\n";
    }
    md += "```\n\n";
    // Hand sweep at the first (or chosen) rate.
    let rate = args.rate.unwrap_or(setup.spec.loop_.rates[0]);
    let mut grid = Vec::new();
    for &k in &setup.spec.hand.grip_stiffness {
        for &b in &setup.spec.hand.grip_damping {
            for a in &setup.spec.approach {
                grid.push((k, b, a.name.clone(), a.speed));
            }
        }
    }
    let sweep: Vec<(Metrics, Metrics)> = grid
        .par_iter()
        .map(|(k, b, _, v)| {
            let hand = setup.spec.hand_with(*k, *b);
            Ok((
                setup.run(&pd, &hand, *v, rate)?.metrics,
                setup.run(&fz, &hand, *v, rate)?.metrics,
            ))
        })
        .collect::<Result<_>>()?;
    let mut s = format!(
        "Hand sweep at {rate} Hz (grip stiffness × damping × approach): PD / fuzzy\n{:>7} {:>6} {:<8} {:>15} {:>15} {:>13}\n",
        "k_g N/m", "b_g", "approach", "osc.amp mrad", "E_gen mJ", "peak mrad"
    );
    let mut better = 0;
    for ((k, b, name, _), (p, f)) in grid.iter().zip(&sweep) {
        let _ = writeln!(
            s,
            "{k:>7} {b:>6} {name:<8} {:>7.3}/{:<7.3} {:>7.3}/{:<7.3} {:>6.2}/{:<6.2}",
            1e3 * p.oscillation_amplitude,
            1e3 * f.oscillation_amplitude,
            1e3 * p.energy_generated,
            1e3 * f.energy_generated,
            1e3 * p.peak_penetration,
            1e3 * f.peak_penetration
        );
        if f.oscillation_amplitude < p.oscillation_amplitude
            && f.energy_generated <= p.energy_generated
        {
            better += 1;
        }
        json_runs.push(serde_json::json!({
            "rate": rate, "approach": name, "grip_stiffness": k, "grip_damping": b,
            "pd": p, "fuzzy": f
        }));
    }
    let _ = writeln!(
        s,
        "fuzzy better on both oscillation and generated energy in {better} of {} cases",
        grid.len()
    );
    crate::out!("\n{s}");
    md += &format!("```\n{s}```\n\n## Metrics\n{METRIC_DEFINITIONS}");
    surface_figure(&out.join("control_surfaces"), &pd, &fam)?;
    write_rule_files(out, "kubica", &setup.kubica)?;
    write_rule_files(out, "rules", &fam)?;
    write_atomic(&out.join("wall.md"), md.as_bytes())?;
    write_atomic(
        &out.join("wall.json"),
        serde_json::to_string_pretty(&json_runs)?.as_bytes(),
    )?;
    crate::outln!(
        "\nwrote {}: wall.md, wall.json, position_<rate>hz.png/.svg, control_surfaces.png/.svg, kubica.fll/.fis, rules.fll/.fis",
        out.display()
    );
    Ok(())
}

/// `lockstep wall tune`: tune the rules, report tuned vs hand-made vs PD, write the tuned
/// table.
///
/// # Errors
/// As [`wall_command`].
pub fn tune_command(args: &WallRun) -> Result<()> {
    let setup = WallSetup::load(&args.spec)?;
    let rate = args.rate.unwrap_or(setup.spec.loop_.rates[0]);
    let out = &args.out;
    std::fs::create_dir_all(out).with_context(|| format!("{}: cannot create", out.display()))?;
    let started = std::time::Instant::now();
    let tuned = tune(&setup, rate, &|n, j| {
        crate::errln!(
            "  tune: {n:>4} evaluations, objective {j:.4}, {:.0} s",
            started.elapsed().as_secs_f64()
        );
    })?;
    let mut s = format!(
        "Tuning at {rate} Hz: objective {:.4} (hand-made) -> {:.4} (tuned), {} simulations, {:.0} s\nfactors per position label (approaching q̇ ≤ 0, leaving q̇ > 0):\n",
        tuned.objective.0,
        tuned.objective.1,
        tuned.evaluations,
        started.elapsed().as_secs_f64()
    );
    for (l, a, b) in &tuned.factors {
        let _ = writeln!(s, "  {l:<4} {a:.3} {b:.3}");
    }
    let _ = writeln!(
        s,
        "\n{:<8} {:<9} {METRIC_HEADER}\n{:<8} {:<9} {METRIC_UNITS}",
        "approach", "wall", "", ""
    );
    let hand = setup.spec.nominal_hand();
    let laws = [
        ("PD", WallLaw::Pd(setup.spec.pd)),
        ("hand-made", WallLaw::Fuzzy(setup.modified.clone())),
        ("tuned", WallLaw::Fuzzy(tuned.fam.clone())),
    ];
    let runs: Vec<Vec<Run>> = laws
        .iter()
        .map(|(_, law)| setup.runs(law, &hand, rate))
        .collect::<Result<_>>()?;
    for (i, a) in setup.spec.approach.iter().enumerate() {
        for ((name, _), r) in laws.iter().zip(&runs) {
            let _ = writeln!(s, "{:<8} {name:<9} {}", a.name, metric_row(&r[i].metrics));
        }
    }
    crate::out!("{s}");
    write_rule_files(out, "tuned", &tuned.fam)?;
    write_atomic(
        &out.join("tune.md"),
        format!("# Wall tuning\n\n```\n{s}```\n\n## Metrics\n{METRIC_DEFINITIONS}").as_bytes(),
    )?;
    crate::outln!("wrote {}: tune.md, tuned.fll, tuned.fis", out.display());
    Ok(())
}

fn closedloop_figure(
    stem: &Path,
    run: &ClosedLoopRun,
    names: &[String],
    measured: Option<&Measurement>,
) -> Result<()> {
    let panels: Vec<Panel> = run
        .joints
        .iter()
        .enumerate()
        .map(|(a, &j)| {
            let mut series = vec![
                Series {
                    name: "command".into(),
                    x: run.t.clone(),
                    y: run.q_cmd[a].clone(),
                    style: Style::Line,
                },
                Series {
                    name: "simulated".into(),
                    x: run.t.clone(),
                    y: run.q[a].clone(),
                    style: Style::Line,
                },
            ];
            if let Some(m) = measured {
                series.push(Series {
                    name: "measured".into(),
                    x: m.t.clone(),
                    y: m.q[j].clone(),
                    style: Style::Line,
                });
            }
            Panel {
                title: format!("{} gains: {}", run.gains, names[a]),
                x_label: "t (s)".into(),
                y_label: "q (rad)".into(),
                series,
            }
        })
        .collect();
    figure(stem, &panels, 1100).map(|_| ())
}

/// `lockstep closedloop`.
///
/// # Errors
/// Bad file (named), unknown gain set, measured file with another sampling or joints, a
/// diverging simulation, unwritable output.
pub fn closedloop_command(
    spec: &Path,
    plant: Option<&Path>,
    gains: &[String],
    measured: &[PathBuf],
    duration: Option<f64>,
    out: &Path,
) -> Result<()> {
    let cl = ClosedLoop::load(spec, plant, duration)?;
    let sets: Vec<String> = if gains.is_empty() {
        cl.spec.gains.keys().cloned().collect()
    } else {
        gains.to_vec()
    };
    if !measured.is_empty() && measured.len() != sets.len() {
        bail!(
            "--measured: {} file(s) for {} gain set(s) ({}); give one per set in the same order",
            measured.len(),
            sets.len(),
            sets.join(", ")
        );
    }
    std::fs::create_dir_all(out).with_context(|| format!("{}: cannot create", out.display()))?;
    let mut md = format!("# Closed-loop PD verification\n\nFile `{}`, plant {}, configuration {}, {} Hz, filter (4.7) a = {:?}, b = {:?}\n\n", spec.display(), cl.plant.name(), cl.spec.configuration, cl.spec.rate, cl.spec.filter.a, cl.spec.filter.b);
    for (k, set) in sets.iter().enumerate() {
        let run = cl.run(set)?;
        let names: Vec<String> = run
            .joints
            .iter()
            .map(|&j| cl.plant.model.joints[j].to_string())
            .collect();
        let meas = match measured.get(k) {
            Some(p) => {
                let m = Measurement::read(p, cl.plant.model.joints)?;
                for n in &m.notes {
                    crate::errln!("note: {n}");
                }
                if m.len() < run.t.len() || (m.dt() - 1.0 / cl.spec.rate).abs() > 1e-6 {
                    bail!(
                        "{}: expected at least {} samples at {} Hz (the closed-loop rate)",
                        p.display(),
                        run.t.len(),
                        cl.spec.rate
                    );
                }
                Some(m)
            }
            None => None,
        };
        let mut t = format!(
            "{set} gains\n{:<6} {:>8} {:>8} {:>14} {:>14}\n",
            "joint", "P", "D", "RMS e (mrad)", "fit vs meas %"
        );
        let rms = run.rms_error();
        for (a, n) in names.iter().enumerate() {
            let g = cl.spec.gains[set][n];
            let fit = meas.as_ref().map_or("—".to_string(), |m| {
                format!(
                    "{:.1}",
                    crate::util::nrmse_fit(&m.q[run.joints[a]][..run.t.len()], &run.q[a])
                )
            });
            let _ = writeln!(
                t,
                "{n:<6} {:>8} {:>8} {:>14.3} {fit:>14}",
                g[0],
                g[1],
                1e3 * rms[a]
            );
        }
        crate::outln!("{t}");
        md += &format!("```\n{t}```\n\n");
        closedloop_figure(
            &out.join(format!("closedloop_{set}")),
            &run,
            &names,
            meas.as_ref(),
        )?;
        let mut cols: Vec<(String, &[f64])> = vec![("t".into(), &run.t)];
        for (a, n) in names.iter().enumerate() {
            cols.push((format!("qcmd_{n}"), &run.q_cmd[a]));
            cols.push((format!("q_{n}"), &run.q[a]));
            cols.push((format!("tau_{n}"), &run.tau[a]));
        }
        let (hdr, data): (Vec<String>, Vec<&[f64]>) = cols.into_iter().unzip();
        crate::measurement::write_columns(&out.join(format!("closedloop_{set}.csv")), &hdr, &data)?;
    }
    write_atomic(&out.join("closedloop.md"), md.as_bytes())?;
    crate::outln!(
        "wrote {}: closedloop.md, closedloop_<gains>.png/.svg/.csv",
        out.display()
    );
    Ok(())
}

/// `lockstep compare --controller C`: the plant simulated in closed loop under the
/// controller of C on each record's reference ([`crate::control::controller`]); per record
/// and free joint, the force or torque and the velocity compared with the measured ones
/// (the table, one residual CSV and one figure each under `out`). Returns the
/// comparisons, `[force, velocity]` per record and joint.
///
/// # Errors
/// The controller file (its field named); a data file (a missing reference or disturbance
/// column named with the columns present; a period that is not the controller's); a
/// divergence; I/O (path named).
pub fn closed_loop_compare_command(
    plant: &crate::plant::Plant,
    controller: &Path,
    data: &[std::path::PathBuf],
    out: &Path,
) -> Result<Vec<[crate::compare::Comparison; 2]>> {
    use crate::control::controller::compare_closed_loop;
    // Every file read and checked before anything is written.
    let (c, records) = closed_loop_records(plant, controller, data)?;
    let compared = records
        .iter()
        .map(|r| compare_closed_loop(plant, &c, r).map(|(v, _)| v))
        .collect::<Result<Vec<_>>>()?;
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let disturbed = records
        .iter()
        .any(|r| r.disturbance.iter().flatten().any(|d| *d != 0.0));
    let disturbance = if !disturbed {
        String::new()
    } else if c.disturbance_hold.is_continuous() {
        format!(
            "; the records' disturbance fed as a continuous signal ({} between samples)",
            c.disturbance_hold
        )
    } else {
        "; the records' disturbance held between samples (zoh)".to_string()
    };
    crate::outln!(
        "closed-loop space: {} under {} ({}), configuration {}; measured velocity: central difference of the position filtered at {} Hz (4th-order, zero-phase); the first {} samples left out{disturbance}",
        plant.name(),
        controller.display(),
        if c.description.is_empty() { "no description" } else { &c.description },
        c.configuration,
        c.compare.velocity_cutoff_hz,
        c.compare.skip
    );
    crate::outln!(
        "{:<24} {:<5} {:<9} {:>8} {:>9} {:>11} {:>11} {:>9}",
        "record",
        "joint",
        "signal",
        "fit %",
        "error %",
        "RMSE",
        "max |e|",
        "at t (s)"
    );
    let mut all = Vec::new();
    for per_record in compared {
        for pair in per_record {
            for (signal, cmp) in ["force", "velocity"].iter().zip(&pair) {
                let stem = cmp
                    .file
                    .file_stem()
                    .map(|s| s.to_string_lossy().into_owned())
                    .unwrap_or_default();
                let base = out.join(format!("{stem}_{}_{signal}", cmp.joint));
                crate::compare::write_residual_csv(&base.with_extension("csv"), cmp, None)?;
                crate::compare::plot(
                    &base,
                    cmp,
                    &format!("{stem}, closed loop, {signal}"),
                    None,
                    None,
                )?;
                crate::outln!(
                    "{:<24} {:<5} {:<9} {:>8.2} {:>9.3} {:>11.4e} {:>11.4e} {:>9.3}",
                    stem,
                    cmp.joint,
                    signal,
                    cmp.nrmse_fit,
                    cmp.relative_error,
                    cmp.rmse,
                    cmp.max_error.0.abs(),
                    cmp.max_error.1
                );
                crate::outln!("    {}", cmp.tests.verdict());
            }
            all.push(pair);
        }
    }
    crate::outln!("residual CSVs and plots (PNG, SVG) in {}", out.display());
    Ok(all)
}

/// The controller of `controller` checked against `plant`, and the closed-loop signals of
/// every file of `data` (files or directories), all read before anything runs.
///
/// # Errors
/// As [`crate::control::controller::Controller::load`] and
/// [`crate::control::controller::ClosedLoopRecord::from_table`].
pub fn closed_loop_records(
    plant: &crate::plant::Plant,
    controller: &Path,
    data: &[PathBuf],
) -> Result<(
    crate::control::controller::Controller,
    Vec<crate::control::controller::ClosedLoopRecord>,
)> {
    use crate::control::controller::{ClosedLoopRecord, Controller};
    let c = Controller::load(controller, plant)?;
    let records = crate::measurement::expand_data_paths(data)?
        .iter()
        .map(|f| {
            let table = crate::measurement::Table::read(f)?;
            for n in &table.notes {
                crate::errln!("note: {n}");
            }
            ClosedLoopRecord::from_table(&table, plant, &c)
        })
        .collect::<Result<Vec<_>>>()?;
    Ok((c, records))
}

/// Print DIDIM's iterations as they end.
fn print_iteration(i: usize, it: &crate::identify::didim::DidimIteration) {
    let values: Vec<String> = it
        .values
        .iter()
        .map(|(n, v)| format!("{n} = {v:.6}"))
        .collect();
    crate::outln!(
        "  {:>2}  force {:>8.4} %  velocity {:>8.4} %  {}",
        i,
        it.force_error,
        it.velocity_error,
        values.join(", ")
    );
}

/// `lockstep identify didim` and `refit --controller`: DIDIM ([`crate::identify::didim`])
/// from the plant's values on the records under the controller, of `params` (all the
/// inverse model's parameters when empty); the iterations, the fit's table and, with
/// `out`, the plant written with the values (with `change`, the step in its history: the
/// closed-loop force RMS per joint before and after, `space = "closed loop"`).
///
/// # Errors
/// As [`closed_loop_records`] and [`crate::identify::didim::didim`]; no convergence within
/// the iterations (the last change named; nothing written); I/O (path named).
pub fn didim_command(
    plant: &crate::plant::Plant,
    controller: &Path,
    data: &[PathBuf],
    (params, change): (&[String], Option<&str>),
    out: Option<&Path>,
) -> Result<crate::identify::didim::DidimResult> {
    use crate::identify::didim::{didim, DidimOptions};
    let (c, records) = closed_loop_records(plant, controller, data)?;
    let options = DidimOptions {
        params: params.to_vec(),
        ..DidimOptions::default()
    };
    crate::outln!(
        "DIDIM, plant {}, controller {}, configuration {}, {} record(s): iteration, closed-loop errors, values",
        plant.name(),
        controller.display(),
        c.configuration,
        records.len()
    );
    let r = didim(plant, &c, &records, &options, &print_iteration)?;
    if !r.converged {
        bail!(
            "DIDIM did not converge in {} iterations (force error {:.4} % → {:.4} %): nothing written",
            r.iterations.len() - 1,
            r.iterations[r.iterations.len().saturating_sub(2)].force_error,
            r.iterations.last().map_or(f64::NAN, |x| x.force_error)
        );
    }
    crate::out!("{}", crate::report::fit_table(&r.fit));
    if let Some(out) = out {
        let mut written = r.plant.clone();
        if let Some(change) = change {
            // The closed-loop force RMS per joint before and after, over every record.
            let force_rms =
                |p: &crate::plant::Plant| -> Result<std::collections::BTreeMap<String, f64>> {
                    let mut sums: std::collections::BTreeMap<String, (f64, usize)> =
                        std::collections::BTreeMap::new();
                    for rec in &records {
                        let (cmp, _) = crate::control::controller::compare_closed_loop(p, &c, rec)?;
                        for [force, _] in &cmp {
                            let e = sums.entry(force.joint.clone()).or_default();
                            e.0 += force.rmse * force.rmse * force.y.len() as f64;
                            e.1 += force.y.len();
                        }
                    }
                    Ok(sums
                        .into_iter()
                        .map(|(j, (s, n))| (j, (s / n.max(1) as f64).sqrt()))
                        .collect())
                };
            written.history.push(crate::plant::HistoryEntry {
                change: change.to_string(),
                configuration: c.configuration.clone(),
                files: records
                    .iter()
                    .map(|r| r.file.display().to_string())
                    .collect(),
                fitted: r
                    .fit
                    .names
                    .iter()
                    .cloned()
                    .zip(r.fit.theta.iter().copied())
                    .collect(),
                rms_before: force_rms(plant)?,
                rms_after: force_rms(&r.plant)?,
                space: Some("closed loop".into()),
            });
        }
        written.save(out)?;
        crate::outln!("wrote {}", out.display());
    }
    Ok(r)
}

/// `lockstep diagnose --controller C`: the diagnosis in closed-loop space
/// ([`crate::identify::didim::diagnose_closed_loop`]), the user's `candidates` ranked
/// beside the catalogue, the first `top` findings printed; with `apply` = Some(K) (1-based) and
/// `out`, finding K added at its estimate and the plant refitted by DIDIM, then diagnosed
/// again, and with `all` repeated until nothing significant is missing (at most
/// [`crate::diagnose::apply::MAX_APPLIED_STEPS`] steps); the plant written to `out`.
///
/// # Errors
/// As [`closed_loop_records`], the diagnosis and DIDIM; finding K absent or not a plant
/// edit (named); I/O (path named).
pub fn closed_loop_diagnose_command(
    plant: &crate::plant::Plant,
    controller: &Path,
    data: &[PathBuf],
    (top, candidates): (usize, &[crate::diagnose::candidates::UserCandidate]),
    apply: Option<(usize, bool)>,
    out: Option<&Path>,
) -> Result<()> {
    use crate::identify::didim::{diagnose_closed_loop, didim, DidimOptions};
    let (c, records) = closed_loop_records(plant, controller, data)?;
    let options = DidimOptions::default();
    let mut current = plant.clone();
    let steps = match apply {
        Some((_, true)) => crate::diagnose::apply::max_applied_steps(plant.model.joints.len()),
        Some((_, false)) => 1,
        None => 0,
    };
    for step in 0..=steps {
        let (d, left_out) =
            diagnose_closed_loop(&current, &c, &records, &options.idim, candidates)?;
        for line in left_out
            .iter()
            .filter(|l| step == 0 || !l.contains("has this effect already"))
        {
            crate::outln!("{line}");
        }
        crate::outln!(
            "plant {}, closed-loop space (controller {}, configuration {}; the inverse model on the simulated closed loop, the measured forces or torques):",
            current.name(),
            controller.display(),
            c.configuration
        );
        crate::out!(
            "{}",
            crate::diagnose::table_with(&d.findings, top, &d.not_white)
        );
        let Some((k, all)) = apply else {
            return Ok(());
        };
        let pick = if all { 1 } else { k };
        let Some(f) = d.findings.get(pick.saturating_sub(1)) else {
            bail!(
                "--apply {pick}: the diagnosis has {} findings",
                d.findings.len()
            );
        };
        if step == steps || (all && !f.significant) {
            break;
        }
        // The loop stops at a finding it cannot take (about the input or the values, or an
        // effect the inverse model cannot fit); one finding asked for by number fails.
        let edited = match f.apply(&current) {
            Ok(p) => p,
            Err(e) if all => {
                crate::outln!("stopped: {e:#}");
                break;
            }
            Err(e) => return Err(e),
        };
        crate::outln!("adding {} on {}, refitting by DIDIM:", f.name, f.joint);
        let r = match didim(&edited, &c, &records, &options, &print_iteration) {
            Ok(r) => r,
            Err(e) if all => {
                crate::outln!(
                    "stopped: {} on {} cannot be refitted: {e:#}",
                    f.name,
                    f.joint
                );
                break;
            }
            Err(e) => return Err(e),
        };
        if !r.converged {
            bail!(
                "DIDIM did not converge after adding {} on {}: nothing written",
                f.name,
                f.joint
            );
        }
        current = r.plant;
        if !all {
            break;
        }
    }
    if let Some(out) = out {
        current.save(out)?;
        crate::outln!("wrote {}", out.display());
    }
    Ok(())
}
