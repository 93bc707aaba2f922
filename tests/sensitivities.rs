//! Forward sensitivities (issue 60): the outputs' derivatives integrated beside the state
//! equal central finite differences of the same discrete simulation — the independent
//! reference: the plain simulator run twice per parameter — on every value of the coupled
//! Freedom 6S plant in k3 (LuGre on four joints, springs, plant gains, the tendon couplings
//! both ways, joint q2's friction position bias with switches inside steps, inertial symbols).

use lockstep::plant::{ConsistencyPolicy, Plant};
use lockstep::simulation::{Hold, InputSignal, PlantModel, State};
use std::path::Path;

/// The coupled-method plant (I4_33 made positive) with q2's qeq (its spring's rest and its
/// friction bias's switch) moved to the middle of q2's range on `tau`, so that the bias
/// switches back and forth, and its k3 simulator.
fn coupled_k3(t: &[f64], tau: &[Vec<f64>], h: f64) -> (Plant, PlantModel) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("model/plants/freedom6s_appendix_d_coupled.toml");
    let mut p = Plant::load(&path).unwrap();
    p.parameters.insert("I4_33".into(), 1.7449e-4);
    let s = p
        .simulator("k3", &[0.0; 6], ConsistencyPolicy::Refuse)
        .unwrap()
        .model;
    let q2 = &outputs(&s, t, tau, h)[..t.len()];
    let (lo, hi) = q2
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &q| (a.min(q), b.max(q)));
    p.parameters.insert("qeq_q2".into(), 0.5 * (lo + hi));
    let s = p
        .simulator("k3", &[0.0; 6], ConsistencyPolicy::Refuse)
        .unwrap()
        .model;
    (p, s)
}

/// Table 4.7's inputs of the free joints `free` for `secs` at 100 Hz: sample times and
/// torques per free joint.
fn inputs(free: &[usize], secs: f64) -> (Vec<f64>, Vec<Vec<f64>>) {
    let model = generated::model("freedom6s").unwrap();
    let ex = lockstep::excitation::Excitations::bundled(model).unwrap();
    let test = ex.table("4.7").unwrap().test(None).unwrap();
    let (t, u, _) = test.sample(6, free, secs, 100.0);
    (t, free.iter().map(|&j| u[j].clone()).collect())
}

/// The torques `tau` sampled at 100 Hz from t = 0, held by `hold`.
fn input(tau: &[Vec<f64>], hold: Hold) -> InputSignal<'_> {
    InputSignal {
        t0: 0.0,
        dt: 0.01,
        tau,
        hold,
    }
}

/// Stacked outputs (q then q̇ of every free joint at every time) of `s` on `tau`.
fn outputs(s: &PlantModel, t: &[f64], tau: &[Vec<f64>], h: f64) -> Vec<f64> {
    try_outputs(s, t, tau, h).unwrap()
}

/// [`outputs`], None where the simulation diverges.
fn try_outputs(s: &PlantModel, t: &[f64], tau: &[Vec<f64>], h: f64) -> Option<Vec<f64>> {
    let input = input(tau, Hold::Linear);
    let tr = s
        .predict_at(State::at_rest(vec![0.0; 4]), h, &input, None, t, 100.0)
        .ok()?;
    Some(tr.q.iter().chain(&tr.qd).flatten().copied().collect())
}

#[test]
fn sensitivities_equal_central_differences_of_the_same_simulation_k3() {
    let (t, tau) = inputs(&[2, 3, 4, 5], 3.0);
    let h = 1.0 / 6000.0;
    let (plant, s) = coupled_k3(&t, &tau, h);
    let conf = s.conf;
    // Every effect value acting in k3, and every inertial symbol that enters k3's equations
    // (a barycentric parameter it moves is one k3's regressor holds).
    let mut names: Vec<String> = plant
        .effects
        .iter()
        .filter(|e| e.acts_with(conf.free))
        .flat_map(|e| e.parameter_names(plant.model.joints))
        .collect();
    names.sort();
    names.dedup();
    names.extend(
        plant
            .model
            .inertial_symbols
            .iter()
            .filter(|n| {
                plant
                    .sensitivity_parameter(n, conf)
                    .unwrap()
                    .inertial
                    .iter()
                    .any(|(k, _)| conf.params_present.contains(k))
            })
            .map(|n| n.to_string()),
    );
    let params: Vec<_> = names
        .iter()
        .map(|n| plant.sensitivity_parameter(n, conf).unwrap())
        .collect();
    let input = input(&tau, Hold::Linear);
    let sens = s
        .predict_at_with_sensitivities(
            (State::at_rest(vec![0.0; 4]), None),
            h,
            &input,
            None,
            &t,
            100.0,
            &params,
        )
        .unwrap();
    // The trajectory is the simulator's, bit for bit.
    let base = outputs(&s, &t, &tau, h);
    let traj: Vec<f64> = sens
        .trajectory
        .q
        .iter()
        .chain(&sens.trajectory.qd)
        .flatten()
        .copied()
        .collect();
    assert_eq!(traj, base);
    // q2 crosses its bias switch inside steps: the switch is differentiated.
    let qeq = plant.value("qeq_q2").unwrap();
    let crossings = sens.trajectory.q[0]
        .windows(2)
        .filter(|w| (w[0] < qeq) != (w[1] < qeq))
        .count();
    assert!(crossings >= 2, "q2 crosses qeq {crossings} times");
    // The reference's own error: the discrete simulation has kinks in θ (a stage's velocity
    // through 0 under LuGre's |v|, a Stribeck curve's sign), so a difference quotient that
    // straddles one is off by much more than its truncation, and the rounding a 3 s run
    // amplifies (1e-13 rad) swamps a small step on a value that moves the outputs little; of
    // seven steps δ (1e-1 to 1e-7 of the value), the one that agrees best is the reference (a
    // wrong sensitivity agrees with none).
    let mut worst = (0.0, String::new());
    for (j, name) in names.iter().enumerate() {
        let v = plant.value(name).unwrap();
        let got: Vec<f64> = sens.q[j]
            .iter()
            .chain(&sens.qd[j])
            .flatten()
            .copied()
            .collect();
        let at = |x: f64| {
            let mut p = plant.clone();
            p.parameters.insert(name.clone(), x);
            let m = p
                .simulator("k3", &[0.0; 6], ConsistencyPolicy::Warn)
                .unwrap()
                .model;
            try_outputs(&m, &t, &tau, h)
        };
        let mut best = f64::INFINITY;
        // Steps relative to the value; an inertial value's at least to 1e-4 (a product of
        // inertia of 1e-7 kg·m² beside moments of 1e-4).
        let inertial = plant.model.inertial_symbols.contains(&name.as_str());
        let scale = if inertial {
            v.abs().max(1e-4)
        } else if v != 0.0 {
            v.abs()
        } else {
            1e-3
        };
        for step in [1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7] {
            let delta = step * scale;
            // A large step on an inertial value can leave D(q) indefinite.
            let (Some(up), Some(down)) = (at(v + delta), at(v - delta)) else {
                continue;
            };
            let fd: Vec<f64> = up
                .iter()
                .zip(&down)
                .map(|(a, b)| (a - b) / (2.0 * delta))
                .collect();
            let norm = fd.iter().map(|x| x * x).sum::<f64>().sqrt();
            let diff = got
                .iter()
                .zip(&fd)
                .map(|(a, b)| (a - b).powi(2))
                .sum::<f64>()
                .sqrt();
            best = best.min(if norm > 0.0 { diff / norm } else { diff });
        }
        eprintln!("{name}: {best:.3e}");
        if best > worst.0 {
            worst = (best, name.clone());
        }
    }
    assert!(
        worst.0 < 1e-6,
        "{}: sensitivities differ from central differences by {:.3e} (relative)",
        worst.1,
        worst.0
    );
    eprintln!(
        "{} parameters, worst relative difference {:.3e} ({})",
        names.len(),
        worst.0,
        worst.1
    );
}

/// A fit's Jacobian (`Residuals::jacobian_columns`) by sensitivities against central
/// differences of the same fit's residuals, in the solver's scaled coordinates: k1 of the
/// coupled plant (both tendon couplings, LuGre with an Fs ≥ Fc pair, springs, gains, two
/// inertial symbols of the last link), one 4 s file that starts moving (LuGre's deflections in steady sliding
/// at the initial velocities, so the start moves with σ0, Fc, Fs, vs), with the cost's
/// weights (the first 100 samples skipped) and the joint of interest's λ = 50; the whole
/// files and a prediction-error stage (output injection at ω = 30 rad/s).
#[test]
fn a_fits_jacobian_by_sensitivities_equals_central_differences_of_its_residuals_k1() {
    use lockstep::identify::output_error::{
        JacobianMethod, OutputErrorOptions, Problem, Record, Residuals, TimeWeighting,
    };
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("model/plants/freedom6s_appendix_d_coupled.toml");
    let mut plant = Plant::load(&path).unwrap();
    plant.parameters.insert("I4_33".into(), 1.7449e-4);
    let conf = plant.model.configuration("k1").unwrap();
    let (t, tau) = inputs(&[4, 5], 4.0);
    let sim = plant
        .simulator("k1", &[0.0; 6], ConsistencyPolicy::Refuse)
        .unwrap()
        .model;
    let input = input(&tau, Hold::Zoh);
    let q = sim
        .predict_at(
            State::at_rest(vec![0.0; 2]),
            1.0 / 12000.0,
            &input,
            None,
            &t,
            100.0,
        )
        .unwrap()
        .q;
    let record = Record {
        file: "k1_run.csv".into(),
        t: t.clone(),
        dt: 0.01,
        tau: tau.clone(),
        q,
        q_all: vec![0.0; 6],
        qd0: Some(vec![0.3, -0.2]),
        hold: Hold::Zoh,
    };
    let names: Vec<String> = [
        "Kp_q4",
        "sigma0_q4",
        "sigma1_q4",
        "sigma2_q4",
        "Fc_q4",
        "Fs_q4",
        "vs_q4",
        "Ks_q4",
        "qeq_q4",
        "Kp_q5",
        "sigma0_q5",
        "Fc_q5",
        "Ks_q5",
        "G_q4_to_q5",
        "G_q5_to_q4",
        "m7",
        "z7",
        "I7_33",
    ]
    .map(String::from)
    .to_vec();
    // Bounds ±50 % about the values (Fs ≥ Fc kept by the scaled coordinates).
    for n in &names {
        let v = plant.parameters[n];
        plant
            .bounds
            .insert(n.clone(), (v - 0.5 * v.abs(), v + 0.5 * v.abs()));
    }
    let problem = |jacobian: JacobianMethod| {
        Problem::new(
            &plant,
            conf,
            names.clone(),
            vec![record.clone()],
            &[0],
            OutputErrorOptions {
                h: 1.0 / 12000.0,
                jacobian,
                weighting: TimeWeighting::SkipTransient(100),
                ..OutputErrorOptions::thesis()
            },
        )
        .unwrap()
    };
    let (by_sensitivities, by_differences) = (
        problem(JacobianMethod::Sensitivities),
        problem(JacobianMethod::Differences),
    );
    let p: Vec<f64> = names.iter().map(|n| plant.parameters[n]).collect();
    let x = by_sensitivities.to_scaled(&p);
    // The whole files, and a prediction-error stage (the output injection at ω = 30 rad/s).
    for (by_sensitivities, by_differences) in [
        (by_sensitivities.clone(), by_differences.clone()),
        (
            by_sensitivities.predictor(30.0),
            by_differences.predictor(30.0),
        ),
    ] {
        let r0 = by_sensitivities.residuals(&p).unwrap();
        let got = central_columns(&by_sensitivities, &x, &r0, 1e-6);
        let references: Vec<Vec<Vec<f64>>> = [1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7]
            .iter()
            .map(|&h| central_columns(&by_differences, &x, &r0, h))
            .collect();
        assert_columns_agree(&names, &got, &references, "the fit's");
    }
}

/// The joint fit of several configurations (`identify sequence --joint-fit`,
/// `JointProblem`) takes each configuration's rows by sensitivities: its Jacobian against
/// central differences of its own residuals, in the solver's scaled coordinates. k1 and
/// k2 of the coupled plant, 3 s each (k2 starts moving), values that enter both (q4's
/// LuGre with an Fs ≥ Fc pair, its gain, the 4 → 5 coupling, a last-link mass) and one
/// that enters k2 only (q3's spring), bounds ±50 %.
#[test]
fn the_joint_fits_jacobian_by_sensitivities_equals_central_differences_k1_k2() {
    use lockstep::identify::identifiability::occurrence;
    use lockstep::identify::joint::JointProblem;
    use lockstep::identify::output_error::{
        JacobianMethod, OutputErrorOptions, Record, Residuals, TimeWeighting,
    };
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("model/plants/freedom6s_appendix_d_coupled.toml");
    let mut plant = Plant::load(&path).unwrap();
    plant.parameters.insert("I4_33".into(), 1.7449e-4);
    let record = |config: &str, free: &[usize], qd0: Option<Vec<f64>>| {
        let (t, tau) = inputs(free, 3.0);
        let sim = plant
            .simulator(config, &[0.0; 6], ConsistencyPolicy::Refuse)
            .unwrap()
            .model;
        let q = sim
            .predict_at(
                State::at_rest(vec![0.0; free.len()]),
                1.0 / 12000.0,
                &input(&tau, Hold::Zoh),
                None,
                &t,
                100.0,
            )
            .unwrap()
            .q;
        let conf = plant.model.configuration(config).unwrap();
        (
            conf,
            vec![Record {
                file: format!("{config}_run.csv").into(),
                t,
                dt: 0.01,
                tau,
                q,
                q_all: vec![0.0; 6],
                qd0,
                hold: Hold::Zoh,
            }],
        )
    };
    let files = vec![
        record("k1", &[4, 5], None),
        record("k2", &[3, 4, 5], Some(vec![0.2, 0.3, -0.2])),
    ];
    let names: Vec<String> = [
        "Kp_q4",
        "sigma0_q4",
        "Fc_q4",
        "Fs_q4",
        "vs_q4",
        "G_q4_to_q5",
        "m7",
        "Ks_q3",
    ]
    .map(String::from)
    .to_vec();
    for n in &names {
        let v = plant.parameters[n];
        plant
            .bounds
            .insert(n.clone(), (v - 0.5 * v.abs(), v + 0.5 * v.abs()));
    }
    let occ = occurrence(plant.model);
    let problem = |jacobian: JacobianMethod| {
        JointProblem::new(
            &plant,
            names.clone(),
            Vec::new(),
            files.clone(),
            &OutputErrorOptions {
                h: 1.0 / 12000.0,
                jacobian,
                weighting: TimeWeighting::SkipTransient(50),
                ..OutputErrorOptions::thesis()
            },
            &occ,
        )
        .unwrap()
    };
    let (by_sensitivities, by_differences) = (
        problem(JacobianMethod::Sensitivities),
        problem(JacobianMethod::Differences),
    );
    assert_eq!(
        by_sensitivities.entering("k1").len(),
        7,
        "Ks_q3 enters k2 only"
    );
    assert_eq!(by_sensitivities.jacobian_simulations(names.len()), 1);
    assert_eq!(
        by_differences.jacobian_simulations(names.len()),
        names.len()
    );
    let p: Vec<f64> = names.iter().map(|n| plant.parameters[n]).collect();
    let x = by_sensitivities.to_scaled(&p);
    let r0 = by_sensitivities.residuals(&p).unwrap();
    let got = central_columns(&by_sensitivities, &x, &r0, 1e-6);
    let references: Vec<Vec<Vec<f64>>> = [1e-3, 1e-4, 1e-5, 1e-6, 1e-7]
        .iter()
        .map(|&h| central_columns(&by_differences, &x, &r0, h))
        .collect();
    assert_columns_agree(&names, &got, &references, "the joint fit's");
}

/// `pr`'s Jacobian columns at scaled point `x` (residuals `r0` there) with every
/// coordinate stepped by `h` (toward the interior where the step would pass 1), central
/// where the method takes differences.
fn central_columns<R: lockstep::identify::output_error::Residuals>(
    pr: &R,
    x: &[f64],
    r0: &[f64],
    h: f64,
) -> Vec<Vec<f64>> {
    let steps: Vec<f64> = x
        .iter()
        .map(|&u| if u + h > 1.0 { -h } else { h })
        .collect();
    let p_of = |y: &[f64]| pr.to_physical(y);
    pr.jacobian_columns(&lockstep::identify::output_error::Stencil {
        x,
        r0,
        steps: &steps,
        p_of: &p_of,
        central: true,
    })
}

/// Every column of `got` (one per name) within 1e-6 relative of the closest of the
/// `references` (central differences at several steps), each reference column nonzero;
/// `what` names the Jacobian in the message.
fn assert_columns_agree(
    names: &[String],
    got: &[Vec<f64>],
    references: &[Vec<Vec<f64>>],
    what: &str,
) {
    for (i, name) in names.iter().enumerate() {
        let best = references
            .iter()
            .map(|fd| {
                let norm = fd[i].iter().map(|v| v * v).sum::<f64>().sqrt();
                assert!(norm > 0.0, "{name} does not move the residuals");
                let diff = got[i]
                    .iter()
                    .zip(&fd[i])
                    .map(|(a, b)| (a - b).powi(2))
                    .sum::<f64>()
                    .sqrt();
                diff / norm
            })
            .fold(f64::INFINITY, f64::min);
        eprintln!("{name}: {best:.3e}");
        assert!(
            best < 1e-6,
            "{name}: {what} sensitivity column differs from central differences by {best:.3e}"
        );
    }
}
