//! The crates.io rmpfit 2.0.3 (CMPFIT) against lockstep's patched copy (vendor/PATCHES.md)
//! on random bounded least-squares problems: 8 residuals, 4 values, two columns nearly
//! collinear, each value started on a bound, 1e-7 of its range inside one, or mid-range,
//! with lockstep's stopping rules (relative step 2e-6, cost change 1e-6).
//!
//! Linear problems (the default) are compared with the exact optimum over the box, found by
//! enumerating the 3⁴ active sets. `--nonconvex` adds 0.3 sin(x₀x₁) + 0.1 x₂² to every
//! residual; there only the two fits are compared.
//!
//! `cargo run --release --manifest-path vendor/rmpfit-differential/Cargo.toml [-- --nonconvex] [--problems N]`

/// One fitter per crate: the same residuals.
macro_rules! fitter {
    ($krate:ident) => {
        mod $krate {
            use $krate::{MPConfig, MPFitter, MPPar, MPResult};
            struct Problem<'a> {
                a: &'a [[f64; 4]],
                b: &'a [f64],
                nonconvex: bool,
                pars: Vec<MPPar>,
                config: MPConfig,
            }
            impl MPFitter for Problem<'_> {
                fn eval(&mut self, x: &[f64], d: &mut [f64]) -> MPResult<()> {
                    for (i, row) in self.a.iter().enumerate() {
                        let linear: f64 = row.iter().zip(x).map(|(r, x)| r * x).sum();
                        let bend = if self.nonconvex {
                            0.3 * (x[0] * x[1]).sin() + 0.1 * x[2] * x[2]
                        } else {
                            0.0
                        };
                        d[i] = linear + bend - self.b[i];
                    }
                    Ok(())
                }
                fn number_of_points(&self) -> usize {
                    self.b.len()
                }
                fn parameters(&self) -> &[MPPar] {
                    &self.pars
                }
                fn config(&self) -> &MPConfig {
                    &self.config
                }
            }
            /// The fit's cost (sum of squared residuals) and cost evaluations.
            pub fn fit(
                a: &[[f64; 4]],
                b: &[f64],
                nonconvex: bool,
                lo: &[f64],
                hi: &[f64],
                x0: &[f64],
            ) -> (f64, usize) {
                let pars = lo
                    .iter()
                    .zip(hi)
                    .map(|(l, h)| MPPar {
                        limited_low: true,
                        limited_up: true,
                        limit_low: *l,
                        limit_up: *h,
                        ..MPPar::new()
                    })
                    .collect();
                let config = MPConfig {
                    xtol: 2e-6,
                    ftol: 1e-6,
                    ..MPConfig::new()
                };
                let mut problem = Problem {
                    a,
                    b,
                    nonconvex,
                    pars,
                    config,
                };
                let mut x = x0.to_vec();
                match problem.mpfit(&mut x) {
                    Ok(status) => (status.best_norm, status.n_fev),
                    Err(_) => (f64::NAN, 0),
                }
            }
        }
    };
}
fitter!(release);
fitter!(patched);

fn cost(a: &[[f64; 4]], b: &[f64], x: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(row, b)| {
            let d = row.iter().zip(x).map(|(r, x)| r * x).sum::<f64>() - b;
            d * d
        })
        .sum()
}

/// The optimum of the linear problem over the box: every active set (each value free, on
/// its lower bound or on its upper one), the free values by the normal equations, the
/// lowest feasible cost.
fn optimum(a: &[[f64; 4]], b: &[f64], lo: &[f64], hi: &[f64]) -> f64 {
    let mut best = f64::INFINITY;
    for code in 0..81usize {
        let mut c = code;
        let mut held = [None; 4];
        for (j, h) in held.iter_mut().enumerate() {
            *h = match c % 3 {
                0 => None,
                1 => Some(lo[j]),
                _ => Some(hi[j]),
            };
            c /= 3;
        }
        let free: Vec<usize> = (0..4).filter(|&j| held[j].is_none()).collect();
        let k = free.len();
        let mut n = vec![vec![0.0; k + 1]; k];
        for (row, bi) in a.iter().zip(b) {
            let r = bi
                - (0..4)
                    .filter_map(|j| held[j].map(|v| row[j] * v))
                    .sum::<f64>();
            for p in 0..k {
                for q in 0..k {
                    n[p][q] += row[free[p]] * row[free[q]];
                }
                n[p][k] += row[free[p]] * r;
            }
        }
        for p in 0..k {
            let pivot_row = n[p].clone();
            for (q, row) in n.iter_mut().enumerate() {
                if q != p {
                    let f = row[p] / pivot_row[p];
                    for (v, w) in row.iter_mut().zip(&pivot_row) {
                        *v -= f * w;
                    }
                }
            }
        }
        let mut x: Vec<f64> = held.iter().map(|h| h.unwrap_or(0.0)).collect();
        for p in 0..k {
            x[free[p]] = n[p][k] / n[p][p];
        }
        if (0..4).all(|j| x[j] >= lo[j] - 1e-12 && x[j] <= hi[j] + 1e-12) {
            best = best.min(cost(a, b, &x));
        }
    }
    best
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let nonconvex = args.iter().any(|a| a == "--nonconvex");
    let problems: usize = match args.iter().position(|a| a == "--problems") {
        Some(i) => match args.get(i + 1).and_then(|n| n.parse().ok()) {
            Some(n) => n,
            None => {
                eprintln!("--problems: expected a count, e.g. --problems 5000");
                std::process::exit(2);
            }
        },
        None => 5000,
    };
    let mut state: u64 = 12345;
    let mut uniform = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    let (mut lower, mut higher) = (0, 0);
    let (mut release_missed, mut patched_missed) = (0, 0);
    let (mut release_worst, mut patched_worst) = (1.0f64, 1.0f64);
    let (mut release_evaluations, mut patched_evaluations) = (0, 0);
    for case in 0..problems {
        let a: Vec<[f64; 4]> = (0..8)
            .map(|_| {
                let mut row = [uniform(), uniform(), uniform(), uniform()];
                row[1] = row[0] * (1.0 + 0.05 * row[1]);
                row
            })
            .collect();
        let b: Vec<f64> = (0..8).map(|_| 3.0 * uniform()).collect();
        let lo: Vec<f64> = (0..4).map(|_| -1.0 + 0.5 * uniform()).collect();
        let hi: Vec<f64> = lo.iter().map(|l| l + 0.5 + uniform().abs()).collect();
        let x0: Vec<f64> = (0..4)
            .map(|j| match (case + j) % 3 {
                0 => lo[j],
                1 => hi[j] - 1e-7 * (hi[j] - lo[j]),
                _ => 0.5 * (lo[j] + hi[j]),
            })
            .collect();
        let (release_cost, release_fev) = release::fit(&a, &b, nonconvex, &lo, &hi, &x0);
        let (patched_cost, patched_fev) = patched::fit(&a, &b, nonconvex, &lo, &hi, &x0);
        release_evaluations += release_fev;
        patched_evaluations += patched_fev;
        if patched_cost < release_cost * (1.0 - 1e-3) {
            lower += 1;
        }
        if patched_cost > release_cost * (1.0 + 1e-3) {
            higher += 1;
        }
        if !nonconvex {
            let best = optimum(&a, &b, &lo, &hi);
            if release_cost > best * (1.0 + 1e-4) {
                release_missed += 1;
            }
            if patched_cost > best * (1.0 + 1e-4) {
                patched_missed += 1;
            }
            release_worst = release_worst.max(release_cost / best);
            patched_worst = patched_worst.max(patched_cost / best);
        }
    }
    let kind = if nonconvex { "nonconvex" } else { "linear" };
    println!("{problems} {kind} problems");
    if !nonconvex {
        println!(
            "off the optimum by more than 1e-4: release {release_missed} (worst {release_worst:.4} ×), patched {patched_missed} (worst {patched_worst:.8} ×)"
        );
    }
    println!("patched lower than the release by more than 1e-3: {lower}; higher: {higher}");
    println!("cost evaluations: release {release_evaluations}, patched {patched_evaluations}");
}
