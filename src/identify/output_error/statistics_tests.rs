//! Tests of the standard errors, exact symmetries, held values and structural ties
//! ([`super`]).

use super::*;

/// Another start within Δχ² ≤ 3.84 of the kept minimum takes away the identifiability
/// of what moved by more than 2 standard errors there, and widens its recorded spread;
/// a start beyond 3.84, or a value within 2 standard errors, changes nothing.
#[test]
fn an_equally_good_minimum_elsewhere_takes_away_what_moved() {
    let names: Vec<String> = ["Fs_q2", "Fc_q2", "vs_q2"].map(String::from).to_vec();
    let p = [0.0444, 0.04435, 0.455];
    let mut stats = Statistics {
        std_err: vec![5.85e-6, 3.1e-6, f64::INFINITY],
        identifiable: vec![true, true, false],
        ..Default::default()
    };
    let s_bar2 = 7.8e-5;
    let others = vec![
        // Δχ² = 0.26: Fs_q2 157 σ away, Fc_q2 1.6 σ away.
        (2, 2.06e-5, vec![0.04532, 0.04435 + 5.0e-6, 0.069]),
        // Δχ² = 3.9: a distinguishable minimum.
        (3, 3.9 * s_bar2, vec![0.0715, 0.0443, 0.019]),
    ];
    stats.mark_other_minima(&names, &p, &others, s_bar2);
    assert_eq!(stats.other_minima.len(), 1);
    let o = &stats.other_minima[0];
    assert_eq!(o.start, 2);
    assert!((o.chi2_difference - 2.06e-5 / 7.8e-5).abs() < 1e-12);
    assert_eq!(o.moved.len(), 1);
    assert_eq!(o.moved[0].0, "Fs_q2");
    assert!((o.moved[0].2 - (0.04532 - 0.0444) / 5.85e-6).abs() < 1e-6);
    assert_eq!(stats.identifiable, [false, true, false]);
    assert!((stats.other_minima_spread(0, "Fs_q2") - 9.2e-4).abs() < 1e-12);
    assert_eq!(stats.other_minima_spread(1, "Fc_q2"), 0.0);
    // Without a noise scale nothing is compared.
    let mut again = Statistics {
        std_err: vec![5.85e-6, 3.1e-6, 1.0],
        identifiable: vec![true; 3],
        ..Default::default()
    };
    again.mark_other_minima(&names, &p, &others, 0.0);
    assert!(again.other_minima.is_empty());
    assert_eq!(again.identifiable, [true; 3]);
}

/// The statistics of a linear fit of θ₀, θ₁ (bounds ±10) with Jacobian columns `cols`,
/// the `held` values, and noise σ = `s` on every residual.
fn linear_statistics(theta: &[f64], cols: Vec<Vec<f64>>, held: HeldColumns, s: f64) -> Statistics {
    let m = cols[0].len();
    covariance_statistics(
        &["theta0".to_string(), "theta1".to_string()],
        theta,
        (&[-10.0, -10.0], &[10.0, 10.0]),
        (cols, held),
        &vec![s * s; m],
        vec![Vec::new(); 2],
        Vec::new(),
    )
    .unwrap()
}

/// The two-stage standard errors against a Monte Carlo of the two-stage estimator
/// itself: y = A θ + b h + e (m = 200, e ~ N(0, s²)), h estimated before with error
/// N(0, σ_h²) and held, θ̂ = (AᵀA)⁻¹ Aᵀ (y − b ĥ); over 4000 draws the spread of θ̂
/// matches `std_err` within 5 % (sampling error of a spread ≈ 1.1 %) and, with ĥ
/// exact, `std_err_given_held`; the held value's share is large here (θ₀'s error × 35,
/// θ₁'s × 1.7), so taking it as exact would fail the first check.
#[test]
fn held_values_uncertainty_matches_a_monte_carlo_of_the_two_stage_estimate() {
    let m = 200;
    let (s, sigma_h) = (0.01, 0.05);
    let t: Vec<f64> = (0..m).map(|k| k as f64 / m as f64).collect();
    let a: Vec<[f64; 2]> = t.iter().map(|&x| [1.0, (6.0 * x).sin()]).collect();
    let b: Vec<f64> = t.iter().map(|&x| x + 0.3 * (6.0 * x).sin()).collect();
    let (theta, h) = ([0.7, -1.2], 0.4);
    // Normal equations of the 2-parameter fit.
    let ata = {
        let mut n = [[0.0; 2]; 2];
        for row in &a {
            for i in 0..2 {
                for j in 0..2 {
                    n[i][j] += row[i] * row[j];
                }
            }
        }
        n
    };
    let det = ata[0][0] * ata[1][1] - ata[0][1] * ata[1][0];
    let solve = |rhs: [f64; 2]| {
        [
            (ata[1][1] * rhs[0] - ata[0][1] * rhs[1]) / det,
            (ata[0][0] * rhs[1] - ata[1][0] * rhs[0]) / det,
        ]
    };
    let mut rng = generated::inertia::Xorshift(42);
    let draws = 4000;
    let spread = |held_exact: bool, rng: &mut generated::inertia::Xorshift| {
        let mut sum = [0.0; 2];
        let mut sq = [0.0; 2];
        for _ in 0..draws {
            let h_hat = if held_exact {
                h
            } else {
                h + sigma_h * crate::synthetic::gaussian(rng)
            };
            let mut rhs = [0.0; 2];
            for k in 0..m {
                let y = a[k][0] * theta[0]
                    + a[k][1] * theta[1]
                    + b[k] * h
                    + s * crate::synthetic::gaussian(rng);
                for i in 0..2 {
                    rhs[i] += a[k][i] * (y - b[k] * h_hat);
                }
            }
            let est = solve(rhs);
            for i in 0..2 {
                sum[i] += est[i];
                sq[i] += est[i] * est[i];
            }
        }
        [0, 1].map(|i| {
            let mean = sum[i] / draws as f64;
            (sq[i] / draws as f64 - mean * mean).sqrt()
        })
    };
    let with_held = spread(false, &mut rng);
    let given_held = spread(true, &mut rng);
    // Residual r = y − ŷ: ∂r/∂θ = −A, ∂r/∂h = −b.
    let cols: Vec<Vec<f64>> = (0..2)
        .map(|i| a.iter().map(|row| -row[i]).collect())
        .collect();
    let held = HeldColumns {
        names: vec!["h".into()],
        std_err: vec![sigma_h],
        tie: vec![false],
        cols: vec![b.iter().map(|x| -x).collect()],
        make_up: Vec::new(),
        exact: vec!["c".into()],
        correlation: Vec::new(),
        scales: Vec::new(),
    };
    let stats = linear_statistics(&theta, cols, held, s);
    for i in 0..2 {
        let rel = |x: f64, reference: f64| (x / reference - 1.0).abs();
        assert!(
            rel(stats.std_err[i], with_held[i]) < 0.05,
            "θ{i}: {} vs Monte Carlo {}",
            stats.std_err[i],
            with_held[i]
        );
        assert!(
            rel(stats.std_err_given_held[i], given_held[i]) < 0.05,
            "θ{i} given ĥ: {} vs Monte Carlo {}",
            stats.std_err_given_held[i],
            given_held[i]
        );
    }
    assert!(
        with_held[0] > 10.0 * given_held[0] && with_held[1] > 1.5 * given_held[1],
        "{with_held:?} {given_held:?}"
    );
    assert_eq!(stats.held, [("h".to_string(), sigma_h)]);
    assert_eq!(stats.held_exact, ["c"]);
}

/// Two held values estimated together by an earlier step, their errors correlated
/// (ρ = −0.95, as a value and what it trades with), entering this fit through nearly
/// the same column (it sees h₁ + h₂, which the earlier step knew well): a Monte Carlo of
/// the two-stage estimator with (ĥ₁, ĥ₂) drawn jointly matches `std_err` within 5 %
/// with the recorded correlation, while taking them as independent overstates θ₀'s
/// standard error more than twofold (k5 of the Freedom 6S held such pairs from k1..k4).
#[test]
fn correlated_held_values_propagate_their_joint_uncertainty() {
    let m = 200;
    let (s, sigma, rho) = (0.01, [0.05, 0.04], -0.95);
    let t: Vec<f64> = (0..m).map(|k| k as f64 / m as f64).collect();
    let a = DMatrix::from_fn(m, 2, |k, i| if i == 0 { 1.0 } else { (6.0 * t[k]).sin() });
    let b = DMatrix::from_fn(m, 2, |k, l| 1.0 + 0.1 * l as f64 * t[k]);
    let (theta, h) = ([0.7, -1.2], [0.4, 0.1]);
    let pinv = (a.transpose() * &a).try_inverse().unwrap() * a.transpose();
    let mut rng = generated::inertia::Xorshift(7);
    let draws = 4000;
    let (mut sum, mut sq) = ([0.0; 2], [0.0; 2]);
    for _ in 0..draws {
        let (z1, z2) = (
            crate::synthetic::gaussian(&mut rng),
            crate::synthetic::gaussian(&mut rng),
        );
        let h_hat = [
            h[0] + sigma[0] * z1,
            h[1] + sigma[1] * (rho * z1 + (1.0 - rho * rho).sqrt() * z2),
        ];
        let y = nalgebra::DVector::from_fn(m, |k, _| {
            a[(k, 0)] * theta[0]
                + a[(k, 1)] * theta[1]
                + b[(k, 0)] * (h[0] - h_hat[0])
                + b[(k, 1)] * (h[1] - h_hat[1])
                + s * crate::synthetic::gaussian(&mut rng)
        });
        let est = &pinv * y;
        for i in 0..2 {
            sum[i] += est[i];
            sq[i] += est[i] * est[i];
        }
    }
    let monte_carlo = [0, 1].map(|i| {
        let mean = sum[i] / draws as f64;
        (sq[i] / draws as f64 - mean * mean).sqrt()
    });
    let stats_with = |correlation: Vec<(usize, usize, f64)>| {
        let cols: Vec<Vec<f64>> = (0..2)
            .map(|i| a.column(i).iter().map(|x| -x).collect())
            .collect();
        let held = HeldColumns {
            names: vec!["h1".into(), "h2".into()],
            std_err: sigma.to_vec(),
            correlation,
            tie: vec![false; 2],
            cols: (0..2)
                .map(|l| b.column(l).iter().map(|x| -x).collect())
                .collect(),
            ..Default::default()
        };
        linear_statistics(&theta, cols, held, s)
    };
    let correlated = stats_with(vec![(0, 1, rho)]);
    let independent = stats_with(Vec::new());
    for i in 0..2 {
        let rel = correlated.std_err[i] / monte_carlo[i] - 1.0;
        assert!(
            rel.abs() < 0.05,
            "θ{i}: {} vs Monte Carlo {}",
            correlated.std_err[i],
            monte_carlo[i]
        );
    }
    assert!(
        independent.std_err[0] > 2.0 * monte_carlo[0],
        "independent {} vs Monte Carlo {}",
        independent.std_err[0],
        monte_carlo[0]
    );
    // What a later step would record: the total correlation, symmetric, within [−1, 1].
    let r = &correlated.correlation_with_held;
    assert_eq!(r[0][0], 1.0);
    assert_eq!(r[0][1], r[1][0]);
    assert!(r[0][1].abs() < 1.0);
}

/// What a fit of k1 holds, on the Freedom 6S's Appendix D start: a held tie without a
/// recorded standard error is propagated with its bounds' uniform spread (I7_13:
/// ±120 % of the guess, σ = width/√12) and reported apart; a recorded standard error
/// wins over a tie's spread (I7_12) and is reported as recorded (x7); a value neither
/// recorded nor a tie is exact (the joint-4 plant gain); a symbol that does not enter
/// k1 (m2) is not held at all.
#[test]
fn a_held_tie_is_propagated_with_its_bounds_spread_and_a_recorded_error_wins() {
    let mut plant = Plant::load(
        &std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("model/plants/freedom6s_appendix_d_initial_widened.toml"),
    )
    .unwrap();
    plant.standard_errors.insert("x7".into(), 1e-4);
    plant.standard_errors.insert("I7_12".into(), 2e-7);
    let conf = plant.model.configuration("k1").unwrap();
    let occ = crate::identify::identifiability::occurrence(plant.model);
    let ties = ["I7_13".to_string(), "I7_12".to_string()];
    let held = held_in(&plant, &["m7".to_string()], &ties, &occ, &[conf]);
    let (lo, hi) = plant.bounds["I7_13"];
    let share = |k: usize| (held.names[k].clone(), held.std_err[k]);
    let at = |n: &str| held.names.iter().position(|x| x == n).unwrap();
    assert_eq!(
        share(at("I7_13")),
        ("I7_13".into(), (hi - lo) / 12f64.sqrt())
    );
    assert!(held.tie[at("I7_13")] && !held.tie[at("I7_12")] && !held.tie[at("x7")]);
    assert_eq!(share(at("I7_12")).1, 2e-7);
    assert_eq!(
        held_share(&held, true),
        [("I7_13".to_string(), (hi - lo) / 12f64.sqrt())]
    );
    assert!(held_share(&held, false).contains(&("x7".to_string(), 1e-4)));
    assert!(held.exact.contains(&"Kp_q4".to_string()));
    assert!(!held.names.contains(&"m7".to_string()) && !held.exact.contains(&"m7".to_string()));
    assert!(!held.names.contains(&"m2".to_string()) && !held.exact.contains(&"m2".to_string()));
}

/// A model seen only through the ratios θ₁/θ₀ and θ₂/θ₀ (the plant-gain scale family in
/// miniature: θ₀, θ₁, θ₂ × α change nothing), one more parameter θ₃, and a column that
/// is zero (θ₄: a Stribeck velocity → 0). The family's direction, resolved only to a
/// finite-difference Jacobian's accuracy (θ₁'s column 1e-6 off), is not seen: θ₀..θ₂
/// get infinite standard errors (a rounding-level cut-off had inverted it: errors 1e5
/// of the values, finite); θ₄ too, and its rounding-level covariance correlates with
/// nothing; θ₃ is determined, its standard error that of the problem with the
/// symmetry removed by holding θ₀ (a quantity the family does not move has the same
/// error in every gauge).
/// [`Statistics::held_information`] beside an exact symmetry of the fitted parameters
/// (two columns identical to the finite-difference accuracy, as k4's ties through held
/// symbols): a held value whose
/// column is independent has ρ = σ_h² / var, var the ordinary least-squares variance of
/// the problem with the duplicate dropped and the held value fitted, s² [(XᵀX)⁻¹]_hh; a
/// held value whose column the fitted ones span has ρ = 0 (this step cannot tell it).
/// A first version called every held value of the Freedom 6S's k4 undetermined because
/// the fitted parameters' own symmetry was counted against it.
#[test]
fn held_information_is_the_variance_ratio_beside_an_exact_symmetry() {
    let m = 400;
    let s = 2e-3;
    let t: Vec<f64> = (0..m).map(|k| k as f64 / m as f64).collect();
    let a: Vec<f64> = t.iter().map(|&x| (5.0 * x).sin()).collect();
    let b: Vec<f64> = t.iter().map(|&x| x * x - 0.3).collect();
    let c: Vec<f64> = t.iter().map(|&x| (11.0 * x).cos() + 0.2 * x).collect();
    let spanned: Vec<f64> = a.iter().zip(&b).map(|(x, y)| 2.0 * x - y).collect();
    // The duplicate as a finite-difference Jacobian has it: 1e-5 of the column off, in
    // the held value's shape, so the unseen direction of the fitted parameters has a
    // component 1e-5 along the held value.
    let a_fd: Vec<f64> = a.iter().zip(&c).map(|(x, y)| x + 1e-5 * y).collect();
    let names: Vec<String> = ["p0", "p1", "p2"].map(String::from).to_vec();
    let held = HeldColumns {
        names: vec!["h_free".into(), "h_spanned".into()],
        std_err: vec![0.05, 0.05],
        tie: vec![false, false],
        cols: vec![c.clone(), spanned],
        make_up: vec![None, None],
        exact: Vec::new(),
        correlation: Vec::new(),
        scales: Vec::new(),
    };
    let stats = covariance_statistics(
        &names,
        &[1.0, 1.0, 1.0],
        (&[0.0; 3], &[2.0; 3]),
        (vec![a.clone(), a_fd, b.clone()], held),
        &vec![s * s; m],
        vec![Vec::new(); 3],
        Vec::new(),
    )
    .unwrap();
    let x = DMatrix::from_fn(m, 3, |k, j| [&a, &b, &c][j][k]);
    let var = s * s * (x.transpose() * &x).try_inverse().unwrap()[(2, 2)];
    let expected = 0.05f64.powi(2) / var;
    let info = &stats.held_information;
    assert_eq!(info.len(), 2);
    assert_eq!(info[0].0, "h_free");
    assert!(expected > 1.0, "{expected}");
    assert!(
        (info[0].1 / expected - 1.0).abs() < 1e-4,
        "{} vs {expected}",
        info[0].1
    );
    assert_eq!(info[1], ("h_spanned".to_string(), 0.0));
}

#[test]
fn an_exact_symmetry_at_the_jacobians_accuracy_and_a_zero_column_leave_the_rest_determined() {
    let m = 300;
    let s = 1e-3;
    let theta = [2.0, 0.5, 3e-6, 0.8, 0.02];
    let t: Vec<f64> = (0..m).map(|k| k as f64 / m as f64).collect();
    let u: Vec<f64> = t.iter().map(|&x| (7.0 * x).sin()).collect();
    let w: Vec<f64> = t.iter().map(|&x| (3.0 * x).cos() * 1e5).collect();
    let z: Vec<f64> = t.iter().map(|&x| (7.0 * x).sin() + x * x).collect();
    // y = (θ₁/θ₀) u + (θ₂/θ₀) w + θ₃ z.
    let c0: Vec<f64> = (0..m)
        .map(|k| -(theta[1] * u[k] + theta[2] * w[k]) / (theta[0] * theta[0]))
        .collect();
    let c1: Vec<f64> = u.iter().map(|x| x / theta[0]).collect();
    let c2: Vec<f64> = w.iter().map(|x| x / theta[0]).collect();
    // A finite-difference error: 1e-6 of the column, of another shape.
    let c1_fd: Vec<f64> = c1
        .iter()
        .zip(&t)
        .map(|(x, tk)| x + 1e-6 * (13.0 * tk).sin())
        .collect();
    let cols = vec![c0.clone(), c1_fd, c2.clone(), z.clone(), vec![0.0; m]];
    let names: Vec<String> = (0..5).map(|i| format!("theta{i}")).collect();
    let lower = [0.1, 0.01, 1e-7, -10.0, 1e-4];
    let upper = [10.0, 5.0, 2e-4, 10.0, 1.0];
    let stats = covariance_statistics(
        &names,
        &theta,
        (&lower, &upper),
        (cols, HeldColumns::default()),
        &vec![s * s; m],
        vec![Vec::new(); 5],
        Vec::new(),
    )
    .unwrap();
    for i in [0, 1, 2, 4] {
        assert!(stats.std_err[i].is_infinite(), "θ{i}: {}", stats.std_err[i]);
    }
    assert!(stats.correlation[3]
        .iter()
        .enumerate()
        .all(|(j, c)| j == 3 || c.abs() < 0.95));
    // θ₀ held: least squares on (c1, c2, z), the variance s² (CᵀC)⁻¹ at θ₃.
    let reduced = [&c1, &c2, &z];
    let ctc = nalgebra::Matrix3::from_fn(|i, j| {
        reduced[i]
            .iter()
            .zip(reduced[j])
            .map(|(a, b)| a * b)
            .sum::<f64>()
    });
    let expected = s * ctc.try_inverse().unwrap()[(2, 2)].sqrt();
    assert!(
        (stats.std_err[3] / expected - 1.0).abs() < 1e-3,
        "θ₃: {} vs {expected}",
        stats.std_err[3]
    );
}

/// The floor ratio is RMS over the weighed samples / σ̂, and undefined (None) where
/// the files give no σ̂: such a joint is not called above the floor, whatever its RMS.
#[test]
fn the_floor_ratio_is_undefined_without_a_noise_estimate() {
    let noisy = JointFit {
        joint: "q3".into(),
        rms: 4.0e-4,
        rms_fitted: 3.1e-4,
        noise: 2.0e-4,
        ..Default::default()
    };
    assert!((noisy.floor_ratio().unwrap() - 1.55).abs() < 1e-12);
    assert!((noisy.rms_ratio().unwrap() - 2.0).abs() < 1e-12);
    let noiseless = JointFit {
        noise: 0.0,
        ..noisy.clone()
    };
    assert_eq!(noiseless.floor_ratio(), None);
    assert_eq!(noiseless.rms_ratio(), None);
}

/// A held value whose Jacobian column is not finite (a simulation that fails where it
/// moves) leaves its share of the covariance unknown: the statistics are still returned
/// (before, the whole sequence stopped with "the Jacobian of the held values … is not
/// finite"), every standard error with the held values is infinite and nothing is called
/// identifiable, and the standard errors given the held values are the fit's own — the
/// same as with the held value taken as exact.
#[test]
fn a_held_value_with_a_non_finite_column_makes_the_total_standard_errors_infinite() {
    let m = 50;
    let t: Vec<f64> = (0..m).map(|k| k as f64 / m as f64).collect();
    let cols: Vec<Vec<f64>> = vec![
        t.iter().map(|_| -1.0).collect(),
        t.iter().map(|&x| -(6.0 * x).sin()).collect(),
    ];
    let held = |col: Vec<f64>| HeldColumns {
        names: vec!["h".into()],
        std_err: vec![0.05],
        tie: vec![false],
        cols: vec![col],
        make_up: Vec::new(),
        exact: Vec::new(),
        correlation: Vec::new(),
        scales: Vec::new(),
    };
    let mut broken: Vec<f64> = t.iter().map(|&x| -x).collect();
    broken[7] = f64::NAN;
    let theta = [0.7, -1.2];
    let s = linear_statistics(&theta, cols.clone(), held(broken), 0.01);
    let exact = linear_statistics(&theta, cols, held(vec![0.0; m]), 0.01);
    assert!(s.std_err.iter().all(|x| x.is_infinite()), "{:?}", s.std_err);
    assert!(s.identifiable.iter().all(|&i| !i));
    for (a, b) in s.std_err_given_held.iter().zip(&exact.std_err_given_held) {
        assert!((a - b).abs() <= 1e-12 * b, "{a} against {b}");
    }
    // The fit's own: σ √((AᵀA)⁻¹)ᵢᵢ, finite and small.
    assert!(s
        .std_err_given_held
        .iter()
        .all(|x| x.is_finite() && *x < 0.01));
}

/// A held plant-gain scale family whose scale no step determined ([`HeldScale`]) is a
/// nuisance of the fit: the standard errors with it free are those of the least squares
/// that fits its scale α beside the parameters (X = [A, ∂r/∂α], the held value with a
/// recorded standard error propagated through the same X; an independent 3 × 3 inverse),
/// and a fitted value that moves exactly as the scale does is undetermined. Given the
/// scale (the figures before the nuisance is projected out), the fit's own.
#[test]
fn a_held_scale_family_counts_as_an_unknown_scale() {
    let m = 300;
    let s = 1e-3;
    let t: Vec<f64> = (0..m).map(|k| k as f64 / m as f64).collect();
    let a: Vec<f64> = t.iter().map(|&x| (5.0 * x).sin()).collect();
    let b: Vec<f64> = t.iter().map(|&x| (3.0 * x).cos() + 0.3 * x).collect();
    let c: Vec<f64> = t
        .iter()
        .map(|&x| x * x - 0.3 + 0.2 * (9.0 * x).sin())
        .collect();
    let d: Vec<f64> = t.iter().map(|&x| (x - 0.5).abs()).collect();
    let (h, sigma_g) = (2.0, 0.05);
    let neg = |v: &[f64]| -> Vec<f64> { v.iter().map(|x| -x).collect() };
    // Residual r = y − (θ₀ a + θ₁ b + h c + g d): ∂r/∂θ = −a, −b; the family member h's
    // column −c (∂r/∂α = h·(−c)); the held value g (σ_g recorded) −d.
    let held = || {
        let mut held = HeldColumns {
            names: vec!["g".into()],
            std_err: vec![sigma_g],
            tie: vec![false],
            scales: vec![HeldScale {
                family: "k1".into(),
                names: vec!["h".into()],
                values: vec![h],
                col: Vec::new(),
            }],
            ..Default::default()
        };
        assert_eq!(held.column_names(), ["g", "h"]);
        held.set_columns(vec![neg(&d), neg(&c)]);
        held
    };
    assert_eq!(
        held().scales[0].col,
        neg(&c).iter().map(|x| h * x).collect::<Vec<_>>()
    );
    let theta = [0.7, -1.2];
    let mut cols = vec![neg(&a), neg(&b)];
    let given = linear_statistics(&theta, cols.clone(), held(), s);
    let mut free_scale = held();
    assert!(project_out_held_scales(&mut cols, &mut free_scale));
    let stats = linear_statistics(&theta, cols, free_scale, s);
    // The reference: θ̂ = (XᵀX)⁻¹ Xᵀ (y − d ĝ), X = [a, b, c].
    let x = DMatrix::from_fn(m, 3, |k, j| [&a, &b, &c][j][k]);
    let xtx_inv = (x.transpose() * &x).try_inverse().unwrap();
    let share = -(&xtx_inv * x.transpose() * nalgebra::DVector::from_column_slice(&d)) * sigma_g;
    // Given the scale: the same with X = [a, b].
    let x_given = DMatrix::from_fn(m, 2, |k, j| [&a, &b][j][k]);
    let given_inv = (x_given.transpose() * &x_given).try_inverse().unwrap();
    let given_share =
        -(&given_inv * x_given.transpose() * nalgebra::DVector::from_column_slice(&d)) * sigma_g;
    for i in 0..2 {
        let expected = (s * s * xtx_inv[(i, i)] + share[i] * share[i]).sqrt();
        assert!(
            (stats.std_err[i] / expected - 1.0).abs() < 1e-6,
            "θ{i}: {} vs {expected}",
            stats.std_err[i]
        );
        let expected = (s * s * given_inv[(i, i)] + given_share[i] * given_share[i]).sqrt();
        assert!(
            (given.std_err[i] / expected - 1.0).abs() < 1e-6,
            "θ{i} given the scale: {} vs {expected}",
            given.std_err[i]
        );
        assert!(given.std_err[i] != stats.std_err[i]);
    }
    // θ₀ moving as the scale does (its column ∂r/∂α's): undetermined with the scale free,
    // θ₁ then the least squares of [b, c].
    let mut cols = vec![neg(&c), neg(&b)];
    let mut free_scale = held();
    let given = linear_statistics(&theta, cols.clone(), held(), s);
    assert!(given.std_err[0].is_finite(), "{}", given.std_err[0]);
    assert!(project_out_held_scales(&mut cols, &mut free_scale));
    let stats = linear_statistics(&theta, cols, free_scale, s);
    assert!(stats.std_err[0].is_infinite() && !stats.identifiable[0]);
    let x = DMatrix::from_fn(m, 2, |k, j| [&b, &c][j][k]);
    let xtx_inv = (x.transpose() * &x).try_inverse().unwrap();
    let share = -(&xtx_inv * x.transpose() * nalgebra::DVector::from_column_slice(&d)) * sigma_g;
    let expected = (s * s * xtx_inv[(0, 0)] + share[0] * share[0]).sqrt();
    assert!(
        (stats.std_err[1] / expected - 1.0).abs() < 1e-6,
        "θ₁: {} vs {expected}",
        stats.std_err[1]
    );
    // A family column that is not finite: nothing is projected, the share is unknown.
    let mut broken = held();
    broken.scales[0].col[3] = f64::NAN;
    let mut cols = vec![neg(&a), neg(&b)];
    assert!(!project_out_held_scales(&mut cols, &mut broken));
    assert_eq!(cols[0], neg(&a));
}
