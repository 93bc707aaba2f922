//! Automatic tuning of the fuzzy wall's rules (beyond the thesis, its 6.2.2): the rules of
//! the tuned block (the wall file's `[tune]` labels) are scaled by one factor per position
//! label for approaching velocities (q̇ ≤ 0) and one for leaving velocities (q̇ > 0), and a
//! compass search (step halving; bounds [0.25, 3] approaching, so the wall keeps pushing, and
//! [0, 3] leaving) minimises the chatter of the simulated user
//! at every approach speed,
//!
//! J = Σ_speeds [ A / A_PD + E_gen / (E_gen,PD + 1e-6 J) + 0.1·losses ]
//!     + 100 · Σ_speeds max(0, peak / (f·peak_PD) − 1),
//!
//! with A the oscillation amplitude, E_gen the energy generated, losses the contact losses,
//! peak the peak penetration and f the allowed penetration factor.

use super::fuzzy::Fam;
use super::wall::{Metrics, WallLaw};
use super::WallSetup;
use anyhow::Result;

/// The outcome of a tuning.
#[derive(Debug, Clone)]
pub struct Tuned {
    /// The tuned table.
    pub fam: Fam,
    /// Factors per tuned position label: (label, approaching, leaving).
    pub factors: Vec<(String, f64, f64)>,
    /// Objective of the starting (hand-made) table and of the tuned one.
    pub objective: (f64, f64),
    /// Simulations run.
    pub evaluations: usize,
}

/// Metrics per approach speed of `law` at `rate` with the nominal hand.
///
/// # Errors
/// Simulation failures.
fn metrics(setup: &WallSetup, law: &WallLaw, rate: f64) -> Result<Vec<Metrics>> {
    Ok(setup
        .runs(law, &setup.spec.nominal_hand(), rate)?
        .into_iter()
        .map(|r| r.metrics)
        .collect())
}

/// PD reference metrics per approach speed at `rate` with the nominal hand.
///
/// # Errors
/// Simulation failures.
pub fn reference(setup: &WallSetup, rate: f64) -> Result<Vec<Metrics>> {
    metrics(setup, &WallLaw::Pd(setup.spec.pd), rate)
}

/// The objective J of a table (module docs).
///
/// # Errors
/// Simulation failures.
pub fn objective(setup: &WallSetup, fam: &Fam, pd: &[Metrics], rate: f64) -> Result<f64> {
    let f = setup.spec.tune.penetration_factor;
    let ms = metrics(setup, &WallLaw::Fuzzy(fam.clone()), rate)?;
    Ok(ms
        .iter()
        .zip(pd)
        .map(|(m, p)| {
            m.oscillation_amplitude / p.oscillation_amplitude.max(1e-9)
                + m.energy_generated / (p.energy_generated + 1e-6)
                + 0.1 * m.contact_losses as f64
                + 100.0 * (m.peak_penetration / (f * p.peak_penetration) - 1.0).max(0.0)
        })
        .sum())
}

/// Tune the wall file's Kubica or modified table (`[tune] from`) at `rate` (module docs).
///
/// # Errors
/// Unknown labels in `[tune]`, simulation failures.
pub fn tune(setup: &WallSetup, rate: f64, progress: &dyn Fn(usize, f64)) -> Result<Tuned> {
    let spec = &setup.spec.tune;
    let base = match spec.from.as_str() {
        "kubica" => &setup.kubica,
        "modified" => &setup.modified,
        other => anyhow::bail!(
            "{}: tune.from: expected 'kubica' or 'modified', got '{other}'",
            setup.path.display()
        ),
    };
    let cols: Vec<usize> = spec
        .position
        .iter()
        .map(|l| base.position.index(l))
        .collect::<Result<_>>()?;
    let rows: Vec<usize> = spec
        .velocity
        .iter()
        .map(|l| base.velocity.index(l))
        .collect::<Result<_>>()?;
    let build = |x: &[f64]| {
        let mut fam = base.clone();
        for (c, &i) in cols.iter().enumerate() {
            for &j in &rows {
                let k = if base.velocity.peaks[j] <= 0.0 { 0 } else { 1 };
                fam.rules[i][j] = base.rules[i][j] * x[2 * c + k];
            }
        }
        fam
    };
    let pd = reference(setup, rate)?;
    let mut x = vec![1.0; 2 * cols.len()];
    let mut best = objective(setup, &build(&x), &pd, rate)?;
    let start = best;
    let mut evals = 1;
    let mut step = 0.5;
    progress(evals, best);
    while step >= 0.02 && evals < spec.max_evaluations {
        let mut improved = false;
        for d in 0..x.len() {
            for s in [step, -step] {
                if evals >= spec.max_evaluations {
                    break;
                }
                let mut y = x.clone();
                // Approaching factors keep a quarter of the rule at least: a wall must push.
                let lo = if d % 2 == 0 { 0.25 } else { 0.0 };
                y[d] = (y[d] + s).clamp(lo, 3.0);
                if y[d] == x[d] {
                    continue;
                }
                let j = objective(setup, &build(&y), &pd, rate)?;
                evals += 1;
                if j < best {
                    best = j;
                    x = y;
                    improved = true;
                    progress(evals, best);
                    break;
                }
            }
        }
        if !improved {
            step /= 2.0;
        }
    }
    Ok(Tuned {
        fam: build(&x),
        factors: cols
            .iter()
            .enumerate()
            .map(|(c, &i)| (base.position.labels[i].clone(), x[2 * c], x[2 * c + 1]))
            .collect(),
        objective: (start, best),
        evaluations: evals * setup.spec.approach.len(),
    })
}
