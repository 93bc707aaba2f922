//! Which inertial parameters a configuration's equations contain, where a locking sequence
//! identifies each one first (thesis Figure 4.2), and the base (identifiable) parameters of a
//! configuration (Gautier 1990: the independent columns of the stacked regressor and the
//! linear combinations that the dependent ones fold into).
//!
//! Both are computed numerically from the generated regressor at random states, so they
//! hold for the equations as emitted, whatever their symbolic form.

use generated::inertia::Xorshift as Rng;
use generated::{Configuration, Model};
use nalgebra::DMatrix;
use rmpfit::{MPConfig, MPFitter, MPPar, MPResult};
use serde::Serialize;

/// The regressor of `conf` stacked over `samples` random states, `(samples·NF) × NP`.
fn stacked_regressor(
    model: &Model,
    conf: &Configuration,
    samples: usize,
    rng: &mut Rng,
    locked_at: &[Vec<f64>],
) -> DMatrix<f64> {
    let nf = conf.free.len();
    let np = model.params.len();
    let mut w = DMatrix::zeros(samples * nf, np);
    let mut y = vec![0.0; nf * np];
    for s in 0..samples {
        let mut q: Vec<f64> = (0..model.joints.len())
            .map(|_| rng.uniform(-3.0, 3.0))
            .collect();
        // The locked joints where the data hold them, cycling through the records.
        if let Some(at) = locked_at.get(s % locked_at.len().max(1)) {
            for (j, qj) in q.iter_mut().enumerate() {
                if !conf.free.contains(&j) {
                    *qj = at[j];
                }
            }
        }
        let qd: Vec<f64> = (0..nf).map(|_| rng.uniform(-2.0, 2.0)).collect();
        let qdd: Vec<f64> = (0..nf).map(|_| rng.uniform(-5.0, 5.0)).collect();
        (conf.regressor)(&q, &qd, &qdd, &mut y);
        for a in 0..nf {
            for j in 0..np {
                w[(s * nf + a, j)] = y[a * np + j];
            }
        }
    }
    w
}

/// Occurrence of inertial quantities in configurations.
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct Occurrence {
    /// Model name.
    pub model: String,
    /// What the rows name: "inertial symbols" (the model file's m, centroid, centroidal
    /// inertia, as in the thesis) or "barycentric parameters".
    pub quantity: String,
    /// Row names.
    pub names: Vec<String>,
    /// Configuration names (columns).
    pub configurations: Vec<String>,
    /// `appears[i][c]`: quantity i appears in configuration c's equations.
    pub appears: Vec<Vec<bool>>,
    /// Per locking sequence: name, and for each step the quantities that appear there first.
    pub sequences: Vec<SequenceOccurrence>,
}

impl Occurrence {
    /// Whether quantity `name` appears in configuration `config`'s equations (false for a
    /// name or configuration the table does not have).
    pub fn appears_in(&self, name: &str, config: &str) -> bool {
        let row = self.names.iter().position(|n| n == name);
        let column = self.configurations.iter().position(|c| c == config);
        matches!((row, column), (Some(r), Some(c)) if self.appears[r][c])
    }
}

/// First appearances along one locking sequence.
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct SequenceOccurrence {
    /// Sequence name.
    pub name: String,
    /// Steps: configuration name and the quantities first identified there.
    pub steps: Vec<(String, Vec<String>)>,
    /// Quantities that appear in no step of the sequence.
    pub nowhere: Vec<String>,
}

impl SequenceOccurrence {
    /// Number of quantities first identified at each step.
    pub fn counts(&self) -> Vec<usize> {
        self.steps.iter().map(|(_, v)| v.len()).collect()
    }
}

/// Which quantities appear in which configuration (∂τ_F/∂u ≠ 0 at random states), for the
/// model file's inertial symbols when it has them, else for the barycentric parameters.
pub fn occurrence(model: &Model) -> Occurrence {
    let mut rng = Rng(0x5eed_0cc0_7265_6e63);
    let np = model.params.len();
    let ni = model.inertial_symbols.len();
    let by_symbol = ni > 0;
    // ∂p/∂u at a random u (p is a polynomial of degree ≤ 3 in u; a central difference is
    // nonzero exactly where the derivative is).
    let dp_du: Vec<Vec<f64>> = if by_symbol {
        let u0: Vec<f64> = (0..ni).map(|_| rng.uniform(0.5, 1.5)).collect();
        let mut pp = vec![0.0; np];
        let mut pm = vec![0.0; np];
        (0..ni)
            .map(|i| {
                let h = 1e-4;
                let mut u = u0.clone();
                u[i] += h;
                (model.barycentric_from_symbols)(&u, &mut pp);
                u[i] -= 2.0 * h;
                (model.barycentric_from_symbols)(&u, &mut pm);
                (0..np).map(|j| (pp[j] - pm[j]) / (2.0 * h)).collect()
            })
            .collect()
    } else {
        (0..np)
            .map(|i| (0..np).map(|j| if i == j { 1.0 } else { 0.0 }).collect())
            .collect()
    };
    let names: Vec<String> = if by_symbol {
        model
            .inertial_symbols
            .iter()
            .map(|s| s.to_string())
            .collect()
    } else {
        model.params.iter().map(|s| s.to_string()).collect()
    };
    let nq = names.len();
    let mut appears = vec![vec![false; model.configurations.len()]; nq];
    for (c, conf) in model.configurations.iter().enumerate() {
        let w = stacked_regressor(model, conf, 4, &mut rng, &[]);
        let scale = w.amax().max(1e-300);
        for (i, row) in appears.iter_mut().enumerate() {
            // Column of W times ∂p/∂u_i.
            let mut norm = 0.0f64;
            for r in 0..w.nrows() {
                let v: f64 = (0..np).map(|j| w[(r, j)] * dp_du[i][j]).sum();
                norm = norm.max(v.abs());
            }
            row[c] = norm > 1e-9 * scale;
        }
    }
    let configurations: Vec<String> = model
        .configurations
        .iter()
        .map(|c| c.name.to_string())
        .collect();
    let sequences = model
        .sequences
        .iter()
        .map(|(name, steps)| {
            let mut seen = vec![false; nq];
            let steps = steps
                .iter()
                .map(|s| {
                    let c = configurations
                        .iter()
                        .position(|n| n == s)
                        .unwrap_or(usize::MAX);
                    let mut first = Vec::new();
                    for i in 0..nq {
                        if c != usize::MAX && appears[i][c] && !seen[i] {
                            seen[i] = true;
                            first.push(names[i].clone());
                        }
                    }
                    (s.to_string(), first)
                })
                .collect();
            let nowhere = (0..nq)
                .filter(|&i| !seen[i])
                .map(|i| names[i].clone())
                .collect();
            SequenceOccurrence {
                name: name.to_string(),
                steps,
                nowhere,
            }
        })
        .collect();
    Occurrence {
        model: model.name.to_string(),
        quantity: if by_symbol {
            "inertial symbols".into()
        } else {
            "barycentric parameters".into()
        },
        names,
        configurations,
        appears,
        sequences,
    }
}

/// One base parameter: an independent barycentric parameter plus the dependent ones that
/// fold into it.
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct BaseParameter {
    /// The independent parameter.
    pub name: String,
    /// `(coefficient, dependent parameter)` terms added to it.
    pub terms: Vec<(f64, String)>,
}

impl std::fmt::Display for BaseParameter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.name)?;
        for (c, n) in &self.terms {
            let sign = if *c < 0.0 { '−' } else { '+' };
            if (c.abs() - 1.0).abs() < 1e-9 {
                write!(f, " {sign} {n}")?;
            } else {
                write!(f, " {sign} {} {n}", fmt_coeff(c.abs()))?;
            }
        }
        Ok(())
    }
}

/// A coefficient with at most 6 decimals and no trailing zeros.
fn fmt_coeff(c: f64) -> String {
    let s = format!("{c:.6}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}

/// Base parameters of one configuration.
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct BaseParameters {
    /// Configuration name.
    pub configuration: String,
    /// Number of barycentric parameters that appear.
    pub appearing: usize,
    /// Rank of the stacked regressor (the number of base parameters).
    pub rank: usize,
    /// The base parameters.
    pub base: Vec<BaseParameter>,
    /// Parameters that appear only through the base parameters above.
    pub dependent: Vec<String>,
}

/// Base parameters of `conf` by the numeric method: stack the regressor at random states,
/// take the columns inertia first, then first moments, then masses, keep a column when it is independent of
/// the kept ones (relative residual above 1e-8), and express each dropped column as a
/// combination of the kept ones (least squares; exact for a structural dependence).
pub fn base_parameters(model: &Model, conf: &Configuration) -> BaseParameters {
    base_parameters_at(model, conf, &[])
}

/// [`base_parameters`] of data that hold the locked joints of `conf` at the positions
/// `locked_at` (full joint vectors, rad, one per measurement file; the free joints' entries
/// are ignored; empty: the locked joints anywhere): fewer combinations, since a locked
/// joint's angle is then a constant of the equations (c5 of the Freedom 6S, joint 1 alone:
/// 22 base parameters with the other joints anywhere, 3 with them where a file holds them —
/// the inertia about joint 1's axis and the two gravity terms of its angle).
pub fn base_parameters_at(
    model: &Model,
    conf: &Configuration,
    locked_at: &[Vec<f64>],
) -> BaseParameters {
    let mut rng = Rng(0xba5e_ba5e_0000_0001);
    let np = model.params.len();
    let samples = (2 * np / conf.free.len().max(1)).max(10);
    let w = stacked_regressor(model, conf, samples, &mut rng, locked_at);
    let scale = w.amax().max(1e-300);
    let mut kept: Vec<usize> = Vec::new();
    let mut dependent: Vec<usize> = Vec::new();
    let mut basis: Vec<nalgebra::DVector<f64>> = Vec::new();
    let mut appearing = 0;
    // Column order (Khalil & Gautier's grouping): inertia entries first, then first moments,
    // then masses, each from the base to the tip; dependent columns fold into earlier ones,
    // so masses and first moments regroup into inertias (e.g. ZZ1 + a1² M2).
    let group = |j: usize| match model.param_kind[j] {
        0 => 2,
        1..=3 => 1,
        _ => 0,
    };
    let mut order: Vec<usize> = (0..np).collect();
    order.sort_by_key(|&j| (group(j), model.param_link[j], model.param_kind[j]));
    for j in order {
        let col = w.column(j).into_owned();
        let norm = col.norm();
        if norm <= 1e-10 * scale {
            continue;
        }
        appearing += 1;
        // Modified Gram–Schmidt, twice for stability.
        let mut r = col.clone();
        for _ in 0..2 {
            for b in &basis {
                let d = b.dot(&r);
                r -= b * d;
            }
        }
        let rn = r.norm();
        if rn > 1e-8 * norm {
            basis.push(r / rn);
            kept.push(j);
        } else {
            dependent.push(j);
        }
    }
    let w1 = DMatrix::from_columns(&kept.iter().map(|&j| w.column(j)).collect::<Vec<_>>());
    let mut terms: Vec<Vec<(f64, String)>> = vec![Vec::new(); kept.len()];
    if !kept.is_empty() {
        let svd = crate::util::svd(w1.clone());
        for &d in &dependent {
            let beta = svd
                .as_ref()
                .ok_or("no decomposition")
                .and_then(|s| s.solve(&w.column(d).into_owned(), 1e-12))
                .unwrap_or_else(|_| nalgebra::DVector::zeros(kept.len()));
            for (i, &b) in beta.iter().enumerate() {
                if b.abs() > 1e-9 {
                    terms[i].push((b, model.params[d].to_string()));
                }
            }
        }
    }
    BaseParameters {
        configuration: conf.name.to_string(),
        appearing,
        rank: kept.len(),
        base: kept
            .iter()
            .zip(terms)
            .map(|(&j, t)| BaseParameter {
                name: model.params[j].to_string(),
                terms: t,
            })
            .collect(),
        dependent: dependent
            .iter()
            .map(|&j| model.params[j].to_string())
            .collect(),
    }
}

/// The base parameters β of a configuration as functions of a plant's values:
/// β_k = p_kept + Σ c p_dependent over the barycentric parameters p ([`base_parameters`]).
struct BaseMap<'a> {
    /// Per base parameter, its name (the kept barycentric parameter).
    names: Vec<String>,
    /// Per base parameter, (index into the model's barycentric parameters, coefficient).
    combos: Vec<Vec<(usize, f64)>>,
    conf: &'a Configuration,
}

impl<'a> BaseMap<'a> {
    /// The base parameters of data with the locked joints at `locked_at`
    /// ([`base_parameters_at`]).
    fn at(model: &Model, conf: &'a Configuration, locked_at: &[Vec<f64>]) -> BaseMap<'a> {
        let bases = base_parameters_at(model, conf, locked_at);
        let index = |name: &str| model.params.iter().position(|x| *x == name);
        let combos = bases
            .base
            .iter()
            .map(|b| {
                let mut t: Vec<(usize, f64)> =
                    index(&b.name).map(|j| (j, 1.0)).into_iter().collect();
                t.extend(
                    b.terms
                        .iter()
                        .filter_map(|(c, d)| index(d).map(|j| (j, *c))),
                );
                t
            })
            .collect();
        BaseMap {
            names: bases.base.into_iter().map(|b| b.name).collect(),
            combos,
            conf,
        }
    }

    fn len(&self) -> usize {
        self.combos.len()
    }

    /// β at the plant's values.
    fn values(&self, plant: &crate::plant::Plant) -> anyhow::Result<Vec<f64>> {
        let bary = plant.barycentric(Some(self.conf))?;
        Ok(self
            .combos
            .iter()
            .map(|t| t.iter().map(|&(j, c)| c * bary[j]).sum())
            .collect())
    }
}

/// Indices of the rigid-body (inertial) symbols among `names`.
fn rigid_body_indices(model: &Model, names: &[String]) -> Vec<usize> {
    (0..names.len())
        .filter(|&i| model.inertial_symbols.contains(&names[i].as_str()))
        .collect()
}

/// Least change along the structural ties: the values of `names` after moving the fitted
/// rigid-body symbols among them from their values in `plant` toward `initial` while the
/// base parameters β of `conf` stay as they are in `plant` — the same torques and the same
/// simulated positions in this configuration, so the same cost (up to rounding).
///
/// Of all symbol values a configuration cannot tell apart (it sees them only through β),
/// the one nearest the initial values (in units of the bound widths `upper − lower`,
/// the spread the user gave each value) is the honest report, and the right start for
/// the next configuration of a locking sequence, which sees other combinations: left where
/// an optimiser drifted along an exact tie, the symbols bias it. Solved as
/// min ‖z − z₀‖² over z = s / width within the bounds, subject to β(z) = β(plant), by a
/// penalty K² ‖Δβ / |β|‖² with K = 1e2, 1e4, 1e6, 1e8 in turn, each a bounded
/// Levenberg–Marquardt fit (β is cheap: no simulation) warm-started from the last.
/// Only exact ties move: a direction the data determine weakly (a flat, curved valley of
/// the output-error cost) changes β and is left alone here.
/// Other names keep their values.
///
/// # Errors
/// The plant's barycentric parameters cannot be formed (a value missing).
pub fn least_change_along_ties(
    plant: &crate::plant::Plant,
    conf: &Configuration,
    names: &[String],
    initial: &[f64],
    lower: &[f64],
    upper: &[f64],
) -> anyhow::Result<Vec<f64>> {
    least_change_along_ties_at(plant, conf, &[], names, initial, lower, upper)
}

/// [`least_change_along_ties`] with the base parameters of data whose locked joints sit at
/// `locked_at` ([`base_parameters_at`]; empty: anywhere), which tie more symbols than the
/// base parameters anywhere do. A start value outside its bounds is clamped into them
/// first, and the penalty then moves the others to keep β: how [`tie_reach`]'s widened
/// fit is brought back inside every symbol's own bounds.
///
/// # Errors
/// The plant's barycentric parameters cannot be formed (a value missing).
pub fn least_change_along_ties_at(
    plant: &crate::plant::Plant,
    conf: &Configuration,
    locked_at: &[Vec<f64>],
    names: &[String],
    initial: &[f64],
    lower: &[f64],
    upper: &[f64],
) -> anyhow::Result<Vec<f64>> {
    if rigid_body_indices(plant.model, names).is_empty() {
        return names.iter().map(|n| plant.value(n)).collect();
    }
    let base = BaseMap::at(plant.model, conf, locked_at);
    let beta = base.values(plant)?;
    let (_, values) = tie_projection(plant, &base, &beta, names, initial, lower, upper, None)?;
    Ok(values)
}

/// The least change along the plant-gain scale and the ties together: the scale α and the
/// values of `names` that keep the base parameters β of `conf` (locked joints at
/// `locked_at`, [`base_parameters_at`]) at α × their values in `plant` — the same
/// simulated positions when every force of the configuration is scaled by α with them
/// (Kp τ = D q̈ + … all × α) — nearest the `initial` values: min over α and the rigid-body
/// symbols s among `names` of ‖(s − s₀) / width‖² + Σ_g ((α Kp_g − Kp₀_g) / width_g)²
/// over the plant gains g = `gains` (indices into `names`, values in `plant`), with α
/// within `alpha_range`, every symbol within its bounds, and widths `upper − lower`.
/// Solved as [`least_change_along_ties`] with ln α one more unknown. Returns α and the
/// values of `names` (the rigid-body symbols moved; the rest, the gains included, as in
/// `plant`: the caller scales what scales with α). Where no values within the bounds keep
/// α β the penalty ends at the nearest it found: the caller checks β
/// ([`base_parameter_values_at`]).
///
/// The rigid-body symbols a step holds along ties belong among `names` with their plant
/// values as `initial`: left out, they would have to be scaled with the family (changing
/// values the next step sees) or make the fitted symbols carry α β alone (c4 of the Freedom
/// 6S from the Appendix D guess: its single fitted inertia I7_22 cannot, and the plant's
/// Kp_q2 = 1 is 4.6 × off, so returning the gains alone would halve every held link mass).
///
/// # Errors
/// The plant's barycentric parameters cannot be formed (a value missing); `alpha_range`
/// not a positive interval.
#[allow(clippy::too_many_arguments)]
pub fn least_change_along_scale(
    plant: &crate::plant::Plant,
    conf: &Configuration,
    locked_at: &[Vec<f64>],
    names: &[String],
    gains: &[usize],
    initial: &[f64],
    lower: &[f64],
    upper: &[f64],
    alpha_range: (f64, f64),
) -> anyhow::Result<(f64, Vec<f64>)> {
    let (lo, hi) = alpha_range;
    anyhow::ensure!(
        lo > 0.0 && lo <= hi && hi.is_finite(),
        "the range of the plant-gain scale α must be a positive interval, not [{lo}, {hi}]"
    );
    let base = BaseMap::at(plant.model, conf, locked_at);
    let beta = base.values(plant)?;
    let scale = Scale {
        gains,
        ln_alpha: (lo.ln(), hi.ln()),
    };
    tie_projection(
        plant,
        &base,
        &beta,
        names,
        initial,
        lower,
        upper,
        Some(&scale),
    )
}

/// The plant-gain scale as an unknown of [`tie_projection`].
struct Scale<'a> {
    /// Indices (into the names) of the plant gains, whose change counts.
    gains: &'a [usize],
    /// Bounds of ln α.
    ln_alpha: (f64, f64),
}

/// min ‖z − z₀‖² (+ the gains' terms of `scale`) over z = s / width within the bounds,
/// subject to β(z) = α β_fit (α = 1 without `scale`), by a penalty K ‖scaled β
/// violation‖² raised in steps (each fit warm-starts the next) with bounded
/// Levenberg–Marquardt; [`least_change_along_ties_at`], [`least_change_along_scale`].
#[allow(clippy::too_many_arguments)]
fn tie_projection(
    plant: &crate::plant::Plant,
    base: &BaseMap<'_>,
    beta_fit: &[f64],
    names: &[String],
    initial: &[f64],
    lower: &[f64],
    upper: &[f64],
    scale: Option<&Scale<'_>>,
) -> anyhow::Result<(f64, Vec<f64>)> {
    let mut values: Vec<f64> = names
        .iter()
        .map(|n| plant.value(n))
        .collect::<anyhow::Result<_>>()?;
    let rigid = rigid_body_indices(plant.model, names);
    let largest = beta_fit.iter().fold(0.0f64, |a, b| a.max(b.abs()));
    if scale.is_none() && (rigid.is_empty() || largest == 0.0) {
        return Ok((1.0, values));
    }
    let width: Vec<f64> = rigid.iter().map(|&i| upper[i] - lower[i]).collect();
    let nr = rigid.len();
    let beta_at = |at: &mut crate::plant::Plant, z: &[f64]| -> anyhow::Result<Vec<f64>> {
        for (c, &i) in rigid.iter().enumerate() {
            at.parameters.insert(names[i].clone(), z[c] * width[c]);
        }
        base.values(at)
    };
    let row_scale: Vec<f64> = beta_fit
        .iter()
        .map(|b| {
            if largest > 0.0 {
                1.0 / b.abs().max(1e-9 * largest)
            } else {
                1.0
            }
        })
        .collect();
    // The rigid-body entries of a vector over `names`, in units of their bound widths.
    let to_z =
        |x: &[f64]| -> Vec<f64> { rigid.iter().zip(&width).map(|(&i, w)| x[i] / w).collect() };
    let (z0, zlo, zhi) = (to_z(initial), to_z(lower), to_z(upper));
    let mut z: Vec<f64> = to_z(&values)
        .iter()
        .enumerate()
        .map(|(c, &x)| x.clamp(zlo[c], zhi[c]))
        .collect();
    // The last unknown is ln α where the scale is one.
    let gains: &[usize] = scale.map_or(&[], |s| s.gains);
    if let Some(s) = scale {
        z.push(0.0f64.clamp(s.ln_alpha.0, s.ln_alpha.1));
    }
    let ln_alpha = |zt: &[f64]| if scale.is_some() { zt[nr] } else { 0.0 };
    let at = std::cell::RefCell::new(plant.clone());
    for k in [1e2, 1e4, 1e6, 1e8] {
        let residuals = |zt: &[f64]| -> Vec<f64> {
            let alpha = ln_alpha(zt).exp();
            let mut out: Vec<f64> = match beta_at(&mut at.borrow_mut(), &zt[..nr]) {
                Ok(beta) => (0..beta.len())
                    .map(|r| k * (beta[r] - alpha * beta_fit[r]) * row_scale[r])
                    .collect(),
                Err(_) => vec![f64::NAN; base.len()],
            };
            out.extend((0..nr).map(|c| zt[c] - z0[c]));
            out.extend(
                gains
                    .iter()
                    .map(|&g| (alpha * values[g] - initial[g]) / (upper[g] - lower[g])),
            );
            out
        };
        let mut pars: Vec<MPPar> = (0..nr)
            .map(|c| MPPar {
                limited_low: true,
                limited_up: true,
                limit_low: zlo[c],
                limit_up: zhi[c],
                step: 1e-7 * z[c].abs().max(1e-3),
                ..MPPar::new()
            })
            .collect();
        if let Some(s) = scale {
            pars.push(MPPar {
                limited_low: true,
                limited_up: true,
                limit_low: s.ln_alpha.0,
                limit_up: s.ln_alpha.1,
                step: 1e-7,
                ..MPPar::new()
            });
        }
        let mut fitter = TieProjection {
            residuals: &residuals,
            m: base.len() + nr + gains.len(),
            config: MPConfig {
                xtol: 1e-14,
                ftol: 1e-14,
                gtol: 1e-14,
                max_iter: 500,
                ..MPConfig::new()
            },
            pars,
        };
        let mut zt = z.clone();
        if fitter.mpfit(&mut zt).is_ok() && zt.iter().all(|x| x.is_finite()) {
            z = zt;
        }
    }
    for (c, &i) in rigid.iter().enumerate() {
        // z × width can round past a bound that z reached exactly; the plant file must read
        // back.
        values[i] = (z[c] * width[c]).clamp(lower[i], upper[i]);
    }
    Ok((ln_alpha(&z).exp(), values))
}

/// How far the held rigid-body symbols `held` can carry, within their bounds, the base
/// parameters β that the fitted symbol `representative` moves in configuration `conf`
/// with its locked joints at `locked_at` ([`base_parameters_at`]): in the
/// representative's units (kg, kg·m, kg·m²), the largest over the β rows k it moves of
/// Σ_h |∂β_k/∂h| (upper_h − lower_h) / |∂β_k/∂representative|. A fit whose spanning
/// symbol ([`spanning_symbols`]) ends on a bound while the data want its β further, with
/// the held ties at values an earlier step could not determine, can reach that β by
/// moving them instead (c6 of the Freedom 6S, joint 0 alone: its single inertia
/// β = I1_33 + the held links' terms; with I1_33 on its upper bound the fit ended at
/// 26 σ̂, with I1_33 free to the tie's reach at 0.98 σ̂). Linear in each symbol's step
/// (β is at most quadratic in each symbol): a box for a search, not a guarantee.
/// 0 when `held` is empty or the representative moves no β.
///
/// # Errors
/// The plant's barycentric parameters cannot be formed (a value missing); a held symbol
/// without bounds (named).
pub fn tie_reach(
    plant: &crate::plant::Plant,
    conf: &Configuration,
    locked_at: &[Vec<f64>],
    representative: &str,
    held: &[String],
) -> anyhow::Result<f64> {
    if held.is_empty() {
        return Ok(0.0);
    }
    let names: Vec<String> = std::iter::once(representative.to_string())
        .chain(held.iter().cloned())
        .collect();
    let width = names
        .iter()
        .map(|n| {
            plant
                .bounds
                .get(n)
                .map(|&(lo, hi)| hi - lo)
                .ok_or_else(|| anyhow::anyhow!("'{n}' has no bounds"))
        })
        .collect::<anyhow::Result<Vec<f64>>>()?;
    let columns: Vec<usize> = (0..names.len()).collect();
    let (_, g) = base_jacobian(plant, &[(conf, locked_at)], &names, &columns, &|_, _| 1.0)?;
    let largest = (0..g.nrows()).fold(0.0f64, |a, k| a.max(g[(k, 0)].abs()));
    if largest == 0.0 {
        return Ok(0.0);
    }
    Ok((0..g.nrows())
        .filter(|&k| g[(k, 0)].abs() > 1e-9 * largest)
        .map(|k| {
            (1..names.len())
                .map(|c| g[(k, c)].abs() * width[c])
                .sum::<f64>()
                / g[(k, 0)].abs()
        })
        .fold(0.0, f64::max))
}

/// G = ∂β/∂s: the base parameters β of every configuration of `places` (rows, unscaled;
/// each configuration with its locked joints at its positions, [`BaseMap::at`]; the
/// configurations' rows stacked in order) by the rigid-body symbols `names[rigid[c]]`
/// (columns, each times `scale(i, s_i)`: the change of the symbol the column stands for),
/// by central differences of step 1e-6 × that scale — exact, β is at most quadratic in each
/// symbol. Returns β at the plant's values and G.
fn base_jacobian(
    plant: &crate::plant::Plant,
    places: &[(&Configuration, &[Vec<f64>])],
    names: &[String],
    rigid: &[usize],
    scale: &dyn Fn(usize, f64) -> f64,
) -> anyhow::Result<(Vec<f64>, DMatrix<f64>)> {
    let maps: Vec<BaseMap> = places
        .iter()
        .map(|(conf, locked_at)| BaseMap::at(plant.model, conf, locked_at))
        .collect();
    let values = |at: &crate::plant::Plant| -> anyhow::Result<Vec<f64>> {
        let mut out = Vec::new();
        for map in &maps {
            out.extend(map.values(at)?);
        }
        Ok(out)
    };
    let beta = |name: &str, v: f64| -> anyhow::Result<Vec<f64>> {
        let mut at = plant.clone();
        at.parameters.insert(name.to_string(), v);
        values(&at)
    };
    let rows: usize = maps.iter().map(BaseMap::len).sum();
    let mut g = DMatrix::zeros(rows, rigid.len());
    for (c, &i) in rigid.iter().enumerate() {
        let v = plant.value(&names[i])?;
        let scale = scale(i, v);
        let h = 1e-6 * scale;
        let (bp, bm) = (beta(&names[i], v + h)?, beta(&names[i], v - h)?);
        for k in 0..rows {
            g[(k, c)] = (bp[k] - bm[k]) / (2.0 * h) * scale;
        }
    }
    Ok((values(plant)?, g))
}

/// Of the rigid-body symbols among `names`, a set that spans the base parameters β of
/// configuration `conf` with its locked joints at `locked_at` ([`base_parameters_at`];
/// empty: anywhere) at the plant's values: indices into `names`, as many as β has
/// entries the symbols move (fewer if some β is out of their reach). Fitting these and
/// holding the others moves every β the data see, with none of the exact ties
/// ([`structural_companions`]) whose null directions a finite-difference Jacobian fills
/// with noise and a Levenberg–Marquardt step then wanders along.
///
/// Chosen greedily by column pivoting (Businger–Golub) on G = ∂β/∂s (`base_jacobian`),
/// each column times its symbol's bound width `width(i)` and each row in units of its |β|
/// (floored at 1e-9 of the largest, so that a small product of inertia weighs like a large
/// mass): the symbol that can move β furthest within its bounds first, then the one that
/// moves it furthest in a direction the chosen ones do not, until what is left is below
/// 1e-6 of the first.
///
/// # Errors
/// The plant's barycentric parameters cannot be formed (a value missing).
pub fn spanning_symbols(
    plant: &crate::plant::Plant,
    conf: &Configuration,
    names: &[String],
    width: &dyn Fn(usize) -> f64,
    locked_at: &[Vec<f64>],
) -> anyhow::Result<Vec<usize>> {
    spanning_symbols_across(plant, &[(conf, locked_at)], names, width)
}

/// [`spanning_symbols`] of several configurations together (`places`: each with its locked
/// joints' positions): a set of the rigid-body symbols among `names` that spans the base
/// parameters of all of them (the joint fit of a locking sequence,
/// [`super::joint::JointProblem`]).
///
/// # Errors
/// The plant's barycentric parameters cannot be formed (a value missing).
pub fn spanning_symbols_across(
    plant: &crate::plant::Plant,
    places: &[(&Configuration, &[Vec<f64>])],
    names: &[String],
    width: &dyn Fn(usize) -> f64,
) -> anyhow::Result<Vec<usize>> {
    let rigid = rigid_body_indices(plant.model, names);
    if rigid.is_empty() {
        return Ok(Vec::new());
    }
    // Columns per bound width: how far each symbol can move β within its bounds.
    let (beta, mut g) = base_jacobian(plant, places, names, &rigid, &|i, _| width(i))?;
    let largest = beta.iter().fold(0.0f64, |a, b| a.max(b.abs()));
    for (k, b) in beta.iter().enumerate() {
        let scale = 1.0 / b.abs().max(1e-9 * largest).max(1e-300);
        g.row_mut(k).scale_mut(scale);
    }
    let mut chosen: Vec<usize> = Vec::new();
    let mut first = None;
    while chosen.len() < g.nrows() {
        let Some((c, norm)) = (0..g.ncols())
            .filter(|c| !chosen.contains(c))
            .map(|c| (c, g.column(c).norm()))
            .max_by(|a, b| a.1.total_cmp(&b.1))
        else {
            break;
        };
        let first = *first.get_or_insert(norm);
        if norm.is_nan() || norm <= 1e-6 * first {
            break;
        }
        chosen.push(c);
        // Remove the chosen direction from every column (modified Gram–Schmidt).
        let q = g.column(c) / norm;
        for d in 0..g.ncols() {
            let along = q.dot(&g.column(d));
            g.column_mut(d).axpy(-along, &q, 1.0);
        }
    }
    let mut out: Vec<usize> = chosen.iter().map(|&c| rigid[c]).collect();
    out.sort_unstable();
    Ok(out)
}

/// For each of `names` (parameters of `plant`), the other rigid-body symbols among `names`
/// it trades with exactly in configuration `conf` (empty: none; always empty for a name
/// that is not an inertial symbol).
///
/// The configuration's dynamics depend on the rigid body only through its base parameters
/// β ([`base_parameters`], Gautier 1990); a direction v of the symbols s (mass, centroid,
/// inertia about the centroid) with ∂β/∂s · v = 0 changes no torque and no simulated
/// position, however well linearised statistics from a finite-difference Jacobian seem to
/// determine it. G = ∂β/∂s by central differences (exact: β is at most quadratic in each
/// symbol), columns in relative terms (scaled by |s|, or by `width(i)` for a zero value);
/// null directions are the eigenvectors of GᵀG below 1e-12 of its largest eigenvalue, and
/// the symbols with a component above 0.05 in one are listed with each other.
///
/// # Errors
/// The plant's barycentric parameters cannot be formed (a value missing).
pub fn structural_companions(
    plant: &crate::plant::Plant,
    conf: &Configuration,
    names: &[String],
    width: &dyn Fn(usize) -> f64,
) -> anyhow::Result<Vec<Vec<String>>> {
    structural_companions_across(plant, &[(conf, &[])], names, width)
}

/// [`structural_companions`] in several configurations together (`places`: each with its
/// locked joints' positions, empty: anywhere): the ties no configuration's base parameters
/// break (the null directions of the stacked ∂β/∂s).
///
/// # Errors
/// The plant's barycentric parameters cannot be formed (a value missing).
pub fn structural_companions_across(
    plant: &crate::plant::Plant,
    places: &[(&Configuration, &[Vec<f64>])],
    names: &[String],
    width: &dyn Fn(usize) -> f64,
) -> anyhow::Result<Vec<Vec<String>>> {
    let n = names.len();
    let mut out = vec![Vec::new(); n];
    let model = plant.model;
    let rigid = rigid_body_indices(model, names);
    if rigid.is_empty() {
        return Ok(out);
    }
    // Columns in relative terms: per |s|, or per bound width for a value near zero.
    let relative = |i: usize, v: f64| {
        if v.abs() > 1e-9 * width(i) {
            v.abs()
        } else {
            width(i)
        }
    };
    let g = base_jacobian(plant, places, names, &rigid, &relative)?.1;
    let eig = (g.transpose() * &g).symmetric_eigen();
    let largest = eig.eigenvalues.amax();
    for (k, &ev) in eig.eigenvalues.iter().enumerate() {
        if ev > 1e-12 * largest {
            continue;
        }
        let v = eig.eigenvectors.column(k);
        let members: Vec<usize> = (0..rigid.len()).filter(|&c| v[c].abs() > 0.05).collect();
        for &c in &members {
            for &d in &members {
                let other = &names[rigid[d]];
                if d != c && !out[rigid[c]].contains(other) {
                    out[rigid[c]].push(other.clone());
                }
            }
        }
    }
    Ok(out)
}

/// The occurrence table and base parameters as Markdown.
pub fn markdown(occ: &Occurrence, bases: &[BaseParameters]) -> String {
    let mut s = format!("# Parameters of model `{}`\n\n", occ.model);
    s.push_str(&format!(
        "## Occurrence of the {} per configuration\n\n`x`: appears in the configuration's equations (∂τ_F/∂u ≠ 0 at random states).\n\n| | {} |\n|---|{}\n",
        occ.quantity,
        occ.configurations.join(" | "),
        "---|".repeat(occ.configurations.len())
    ));
    for (i, n) in occ.names.iter().enumerate() {
        let cells: Vec<&str> = occ.appears[i]
            .iter()
            .map(|&a| if a { "x" } else { "" })
            .collect();
        s.push_str(&format!("| {n} | {} |\n", cells.join(" | ")));
    }
    for seq in &occ.sequences {
        s.push_str(&format!(
            "\n## Sequence `{}`: where each of the {} is identified first\n\n| step | count | first identified |\n|---|---|---|\n",
            seq.name, occ.quantity
        ));
        for (c, first) in &seq.steps {
            s.push_str(&format!(
                "| {c} | {} | {} |\n",
                first.len(),
                first.join(", ")
            ));
        }
        s.push_str(&format!(
            "| nowhere | {} | {} |\n",
            seq.nowhere.len(),
            seq.nowhere.join(", ")
        ));
    }
    s.push_str("\n## Base parameters per configuration (barycentric form)\n");
    for b in bases {
        s.push_str(&format!(
            "\n### `{}`: {} appear, {} identifiable\n\n",
            b.configuration, b.appearing, b.rank
        ));
        for p in &b.base {
            s.push_str(&format!("- {p}\n"));
        }
        if !b.dependent.is_empty() {
            s.push_str(&format!(
                "\nNot separately identifiable (folded into the above): {}.\n",
                b.dependent.join(", ")
            ));
        }
    }
    s
}

/// rmpfit adapter of [`least_change_along_ties`].
struct TieProjection<'a> {
    residuals: &'a dyn Fn(&[f64]) -> Vec<f64>,
    m: usize,
    config: MPConfig,
    pars: Vec<MPPar>,
}

impl MPFitter for TieProjection<'_> {
    fn eval(&mut self, params: &[f64], deviates: &mut [f64]) -> MPResult<()> {
        deviates.copy_from_slice(&(self.residuals)(params));
        Ok(())
    }

    fn number_of_points(&self) -> usize {
        self.m
    }

    fn config(&self) -> &MPConfig {
        &self.config
    }

    fn parameters(&self) -> &[MPPar] {
        &self.pars
    }
}

/// The values of the base parameters β of `conf` at `plant`'s values (Gautier 1990), named
/// by their kept barycentric parameter ([`base_parameters`]).
///
/// # Errors
/// The plant's barycentric parameters cannot be formed (a value missing).
pub fn base_parameter_values(
    plant: &crate::plant::Plant,
    conf: &Configuration,
) -> anyhow::Result<Vec<(String, f64)>> {
    base_parameter_values_at(plant, conf, &[])
}

/// [`base_parameter_values`] of data with the locked joints at `locked_at` (rad, every
/// joint's position per file; [`base_parameters_at`]).
///
/// # Errors
/// The plant's barycentric parameters cannot be formed (a value missing).
pub fn base_parameter_values_at(
    plant: &crate::plant::Plant,
    conf: &Configuration,
    locked_at: &[Vec<f64>],
) -> anyhow::Result<Vec<(String, f64)>> {
    let base = BaseMap::at(plant.model, conf, locked_at);
    let values = base.values(plant)?;
    Ok(base.names.into_iter().zip(values).collect())
}
