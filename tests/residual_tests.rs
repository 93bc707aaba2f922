//! The residual tests of `compare` (MATLAB `resid`) on signals whose answers are known:
//! white noise, an AR(1) sequence (ρ(k) = φᵏ), a residual that is a delayed copy of the
//! input, and a sine of known frequency and amplitude.

use generated::inertia::Xorshift;
use lockstep::compare::{amplitude_spectrum, residual_tests};

fn gaussian(rng: &mut Xorshift, n: usize) -> Vec<f64> {
    (0..n)
        .map(|_| {
            let (u1, u2) = (rng.uniform(1e-12, 1.0), rng.uniform(0.0, 1.0));
            (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
        })
        .collect()
}

#[test]
fn white_noise_passes_the_whiteness_test() {
    let mut rng = Xorshift(7);
    let e = gaussian(&mut rng, 5000);
    let t = residual_tests(&e, &[], 0.01, 25);
    assert_eq!(t.autocorrelation.len(), 26);
    assert!((t.autocorrelation[0] - 1.0).abs() < 1e-12);
    assert!((t.autocorrelation_bound - 2.58 / 5000f64.sqrt()).abs() < 1e-12);
    assert!(t.lags_outside <= 1, "{} lags outside", t.lags_outside);
    assert!(
        t.verdict().starts_with("the residual is white"),
        "{}",
        t.verdict()
    );
}

#[test]
fn ar1_autocorrelation_is_phi_to_the_lag() {
    let mut rng = Xorshift(11);
    let w = gaussian(&mut rng, 20000);
    let phi = 0.8;
    let mut e = vec![0.0; w.len()];
    for k in 1..w.len() {
        e[k] = phi * e[k - 1] + w[k];
    }
    let t = residual_tests(&e, &[], 0.01, 25);
    for k in 1..=5 {
        let expect = phi.powi(k as i32);
        assert!(
            (t.autocorrelation[k] - expect).abs() < 0.03,
            "lag {k}: {} vs {expect}",
            t.autocorrelation[k]
        );
    }
    assert!(t.verdict().contains("not white"));
}

#[test]
fn a_delayed_input_shows_at_its_lag() {
    let mut rng = Xorshift(3);
    let n = 5000;
    let u = gaussian(&mut rng, n);
    let noise = gaussian(&mut rng, n);
    let e: Vec<f64> = (0..n)
        .map(|k| 0.5 * if k >= 3 { u[k - 3] } else { 0.0 } + noise[k])
        .collect();
    let t = residual_tests(&e, &[("tau0".into(), u.clone())], 0.01, 25);
    let (name, c, bound) = &t.cross_correlation[0];
    assert_eq!(name, "tau0");
    assert_eq!(c.len(), 51);
    let (imax, cmax) = c
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
        .unwrap();
    assert_eq!(imax as isize - 25, 3, "peak at lag {}", imax as isize - 25);
    // ρ = 0.5 / √(0.25 + 1) for unit-variance u and noise.
    assert!((cmax - 0.5 / 1.25f64.sqrt()).abs() < 0.03, "{cmax}");
    assert!(*cmax > *bound && *bound < 0.06);
    assert_eq!(t.correlated_inputs, vec!["tau0".to_string()]);
    // Unrelated noise does not correlate.
    let v = gaussian(&mut rng, n);
    let t = residual_tests(&noise, &[("tau1".into(), v)], 0.01, 25);
    assert!(
        t.correlated_inputs.is_empty(),
        "{:?}",
        t.cross_correlation[0].1
    );
}

#[test]
fn spectrum_peak_at_the_sine_frequency_with_its_amplitude() {
    let dt = 0.01;
    let x: Vec<f64> = (0..4000)
        .map(|k| 0.3 * (2.0 * std::f64::consts::PI * 1.5 * k as f64 * dt).sin() + 0.1)
        .collect();
    let (f, a) = amplitude_spectrum(&x, dt);
    assert!((f[1] - 0.025).abs() < 1e-12);
    assert!((f.last().unwrap() - 50.0).abs() < 1e-9);
    let (i, amax) = a
        .iter()
        .enumerate()
        .max_by(|p, q| p.1.total_cmp(q.1))
        .unwrap();
    assert!((f[i] - 1.5).abs() < 1e-9, "peak at {} Hz", f[i]);
    assert!((amax - 0.3).abs() < 0.003, "amplitude {amax}");
    // The mean is removed: nothing at 0 Hz.
    assert!(a[0] < 1e-3);
}
