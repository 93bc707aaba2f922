//! `lockstep demo`: the main job on the bundled EMPS measurements (data/emps).
//!
//! 1. Fit the model that lacks Coulomb friction and the offset (mass + viscous) by IDIM-LS and
//!    show its error and where it fails: the residual against velocity has a step at q̇ = 0.
//! 2. Add the effects the residual points to (Coulomb friction, offset), refit, and show the
//!    error fall; validate on the pulses record with the same parameters.
//! 3. Refine with direction-dependent friction.
//! 4. Simulate the model of step 2 in closed loop under the benchmark's controller on both
//!    records' references (`model/control/emps_controller.toml`) and compare force and
//!    velocity with the benchmark's published closed-loop figures.
//!
//! Everything is written under the output directory, which is named at the end.

use crate::compare::{compare_observation, compare_torque, plot, write_residual_csv, Comparison};
use crate::effects::{Effect, EffectKind};
use crate::identify::idim::{least_squares, observation, Fit, IdimOptions};
use crate::measurement::Measurement;
use crate::plant::Plant;
use crate::report::fit_table;
use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The repository's bundled data directory.
pub fn bundled_data_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("data")
        .join("emps")
}

/// The repository's plant directory.
pub fn bundled_plant_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("model")
        .join("plants")
}

/// Figures of one demo step.
#[derive(Debug, Clone)]
pub struct Step {
    /// Plant description.
    pub label: String,
    /// The fit on the training record.
    pub fit: Fit,
    /// Comparison on the training record.
    pub train: Comparison,
    /// Comparison on the validation (pulses) record.
    pub validation: Comparison,
}

/// What the demo found.
#[derive(Debug, Clone)]
pub struct DemoResult {
    /// The three steps.
    pub steps: Vec<Step>,
    /// Output directory.
    pub out: PathBuf,
    /// The printed report.
    pub text: String,
}

fn fit_and_compare(
    plant: &mut Plant,
    label: &str,
    train: &Measurement,
    pulses: &Measurement,
    out: &Path,
    tag: &str,
) -> Result<Step> {
    let opts = IdimOptions::default();
    // One observation of the training record serves the fit and the comparison.
    let obs = observation(plant, "full", std::slice::from_ref(train), &opts)?;
    let fit = least_squares(&obs)?;
    fit.apply(plant)?;
    plant.description = format!("{label} (IDIM-LS on emps_train.csv)");
    plant.save(&out.join(format!("{tag}.toml")))?;
    let t = compare_observation(plant, &obs, &train.file)?.remove(0);
    let v = compare_torque(plant, "full", std::slice::from_ref(pulses), &opts)?.remove(0);
    write_residual_csv(&out.join(format!("{tag}_train_residual.csv")), &t, None)?;
    write_residual_csv(&out.join(format!("{tag}_pulses_residual.csv")), &v, None)?;
    plot(
        &out.join(format!("{tag}_train")),
        &t,
        &format!("{label}, training record"),
        None,
        None,
    )?;
    plot(
        &out.join(format!("{tag}_pulses")),
        &v,
        &format!("{label}, pulses record"),
        None,
        None,
    )?;
    Ok(Step {
        label: label.into(),
        fit,
        train: t,
        validation: v,
    })
}

/// Run the demo, writing under `out`.
///
/// # Errors
/// Missing bundled files, or an output file that cannot be written.
pub fn run(data_dir: &Path, out: &Path) -> Result<DemoResult> {
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let bar = ProgressBar::new(6);
    bar.set_style(
        ProgressStyle::with_template("{spinner} [{bar:30}] {pos}/{len} {msg}")
            .expect("valid template")
            .progress_chars("=> "),
    );
    bar.set_message("reading the EMPS records");
    let joints = crate::util::model("emps")?.joints;
    let train = Measurement::read(&data_dir.join("emps_train.csv"), joints)?;
    let pulses = Measurement::read(&data_dir.join("emps_test_pulses.csv"), joints)?;
    bar.inc(1);
    let mut text = String::new();
    writeln!(text, "EMPS (Janot, Gautier, Brunot 2019): one prismatic axis, {} samples at {:.0} Hz per record.", train.len(), 1.0 / train.dt())?;
    writeln!(text, "IDIM-LS: Butterworth 4th order at 100 Hz (zero phase), central differences, parallel decimation x10.\n")?;

    // Step 1: mass + viscous friction only.
    bar.set_message("fitting mass + viscous friction");
    let mut plant = Plant::load(&bundled_plant_dir().join("emps_viscous.toml"))?;
    let s1 = fit_and_compare(
        &mut plant,
        "mass + viscous",
        &train,
        &pulses,
        out,
        "1_viscous",
    )?;
    bar.inc(1);
    writeln!(text, "1. Model: tau = M qdd + Fv qd")?;
    text.push_str(&indent(&fit_table(&s1.fit)));
    let (a, b) = s1.train.sign_step;
    writeln!(
        text,
        "   Where it fails: the residual against velocity has a step of {:.1} N at qd = 0 (a = {a:.2} N in a*sign(qd) + b + c*qd)\n   and a mean of b = {b:.2} N. A step at zero velocity is Coulomb friction; a constant is an offset.\n   Largest residual {:.1} N at t = {:.2} s, qd = {:.4} m/s (see 1_viscous_train.png, bottom panel).\n",
        2.0 * a,
        s1.train.max_error.0,
        s1.train.max_error.1,
        s1.train.max_error.2
    )?;

    // Step 2: add the effects the residual points to.
    bar.set_message("adding Coulomb friction and offset, refitting");
    plant.add_effect(Effect::on(EffectKind::Coulomb, 0))?;
    plant.add_effect(Effect::on(EffectKind::Offset, 0))?;
    let s2 = fit_and_compare(
        &mut plant,
        "mass + viscous + Coulomb + offset",
        &train,
        &pulses,
        out,
        "2_coulomb_offset",
    )?;
    bar.inc(1);
    writeln!(
        text,
        "2. Added: coulomb, offset  ->  tau = M qdd + Fv qd + Fc sign(qd) + offset"
    )?;
    text.push_str(&indent(&fit_table(&s2.fit)));
    writeln!(text, "   Benchmark reference: M 95.1089, Fv 203.5034, Fc 20.3935, offset -3.1648, error 4.0834 %.\n")?;

    // Step 3: direction-dependent friction.
    bar.set_message("asymmetric friction");
    let mut plant3 = Plant::load(&bundled_plant_dir().join("emps_asymmetric.toml"))?;
    let s3 = fit_and_compare(
        &mut plant3,
        "mass + asymmetric friction",
        &train,
        &pulses,
        out,
        "3_asymmetric",
    )?;
    bar.inc(1);
    writeln!(
        text,
        "3. Direction-dependent friction (no offset): Fv/Fc differ for qd > 0 and qd < 0"
    )?;
    text.push_str(&indent(&fit_table(&s3.fit)));
    writeln!(text, "   Benchmark reference: M 95.1540, Fv+ 166.7061, Fc+ 20.1440, Fv- 240.4236, Fc- 20.6277, error 3.1117 %.\n")?;

    // Step 4: the model of step 2 in closed loop, as the device ran.
    bar.set_message("closed loop under the benchmark's controller");
    let closed = closed_loop(&plant, data_dir)?;
    bar.inc(1);
    writeln!(
        text,
        "4. The model of step 2 in closed loop under the benchmark's controller (model/control/emps_controller.toml:\n   u = kv (kp (qref - q) - dq), one sample of delay, +/-10 V, force = gtau u), on each record's reference:"
    )?;
    writeln!(
        text,
        "   {:<18} {:>10} {:>12}   benchmark's published model",
        "record", "force", "velocity"
    )?;
    for (name, force, velocity, published) in &closed {
        writeln!(
            text,
            "   {name:<18} {force:>9.3}% {velocity:>11.3}%   {published}"
        )?;
    }
    writeln!(text)?;

    bar.set_message("summary");
    let steps = vec![s1, s2, s3];
    writeln!(
        text,
        "Relative force error 100*||y - yhat||/||y|| (parameters fitted on the training record):"
    )?;
    writeln!(
        text,
        "   {:<36} {:>10} {:>16}",
        "model", "training", "pulses (valid.)"
    )?;
    for s in &steps {
        writeln!(
            text,
            "   {:<36} {:>9.2}% {:>15.2}%",
            s.label, s.train.relative_error, s.validation.relative_error
        )?;
    }
    crate::files::write_atomic(&out.join("summary.txt"), text.as_bytes())?;
    bar.inc(1);
    bar.finish_and_clear();
    Ok(DemoResult {
        steps,
        out: out.to_path_buf(),
        text,
    })
}

/// The closed-loop force and velocity errors (%) of `plant` on both records under the
/// benchmark's controller, with the published figures.
fn closed_loop(plant: &Plant, data_dir: &Path) -> Result<Vec<(String, f64, f64, &'static str)>> {
    use crate::control::controller::{compare_closed_loop, ClosedLoopRecord, Controller};
    let controller = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("model")
        .join("control")
        .join("emps_controller.toml");
    let c = Controller::load(&controller, plant)?;
    [
        ("emps_train", "force 5.848 %, velocity 0.229 %"),
        ("emps_test_pulses", "force 8.941 %, velocity 0.479 %"),
    ]
    .into_iter()
    .map(|(name, published)| {
        let table = crate::measurement::Table::read(&data_dir.join(format!("{name}.csv")))?;
        let record = ClosedLoopRecord::from_table(&table, plant, &c)?;
        let (cmp, _) = compare_closed_loop(plant, &c, &record)?;
        Ok((
            name.to_string(),
            cmp[0][0].relative_error,
            cmp[0][1].relative_error,
            published,
        ))
    })
    .collect()
}

fn indent(s: &str) -> String {
    s.lines().map(|l| format!("   {l}\n")).collect()
}
