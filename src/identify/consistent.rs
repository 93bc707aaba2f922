//! Physically consistent standard parameters from an IDIM fit and a prior (issue 57 item 2).
//!
//! The least squares determine only the base parameters; the standard ones it returns keep
//! the prior where the data say nothing and may describe no real body (a negative inertia
//! about the centroid). This step finds the standard set nearest to both the data and the
//! prior among physical bodies:
//!
//! min over θ  ‖R(θ − θ̂)‖² / σ² + Σ_i ((θ_i − θ_prior,i) / s_i)²
//!
//! where W = QR is the observation's regressor (so the first term is the rise of the torque
//! residual ‖y − Wθ‖² above its least-squares minimum, in units of the fit's residual
//! variance σ²: it holds the identifiable combinations where the data put them), θ_prior are
//! the plant's values before the fit (CAD, a URDF, a paper) with scales
//! s_i = max(|θ_prior,i|, |θ̂_i|, floor of its kind), and every link's pseudo-inertia
//!
//! J = [[Σ, h], [hᵀ, m]],  Σ = ½ tr(I) 𝟙 − I,  h = m c
//!
//! is positive definite (Wensing, Kim & Slotine, "Linear matrix inequalities for physically
//! consistent inertial parameter identification", IEEE RA-L 3(1), 2018: J ≻ 0 is exactly a
//! positive mass with a centroidal inertia that meets the triangle inequality). The
//! constraint is built into the parameters by the log-Cholesky factor of Rucker & Wensing
//! ("Smooth parameterization of rigid-body inertia", IEEE RA-L 7(2), 2022): J = U Uᵀ with
//! U = e^α [[e^d1, s12, s13, t1], [0, e^d2, s23, t2], [0, 0, e^d3, t3], [0, 0, 0, 1]], ten
//! unconstrained numbers per link, so the problem is an unconstrained nonlinear least squares
//! solved by Levenberg–Marquardt. Dissipative and inertial effect parameters (Fc, Fv, Ia and
//! the coupled motor's) are kept non-negative as squares.
//!
//! Why not a semidefinite program: the pseudo-inertia cone is the only constraint and the
//! log-Cholesky map makes it disappear, so the existing dense least-squares machinery
//! solves it in milliseconds for a six-joint arm (one 87-column QR, then 87×87 products),
//! without a conic solver in the dependency tree; the price is a strict inequality (J ≻ 0:
//! a point mass is approached, not reached), which is also what the plant's consistency
//! check asks.

use crate::identify::idim::{Fit, Observation};
use crate::plant::Plant;
use anyhow::{bail, Result};
use nalgebra::{DMatrix, DVector, Matrix3, Matrix4};

/// Settings of [`consistent_parameters`].
#[derive(Debug, Clone, Copy)]
pub struct ConsistentOptions {
    /// Weight of the prior term (1: the prior counts as one standard deviation of 100 % of
    /// each value).
    pub prior_weight: f64,
    /// Levenberg–Marquardt iterations at most.
    pub max_iterations: usize,
}

impl Default for ConsistentOptions {
    fn default() -> Self {
        ConsistentOptions {
            prior_weight: 1.0,
            max_iterations: 200,
        }
    }
}

/// The result of [`consistent_parameters`].
#[derive(Debug, Clone)]
pub struct ConsistentFit {
    /// Column names (the observation's).
    pub names: Vec<String>,
    /// The consistent values (SI), one per name.
    pub theta: Vec<f64>,
    /// Relative torque error 100‖y − Wθ‖/‖y‖ of the least-squares fit (%).
    pub unconstrained_error: f64,
    /// The same of the consistent set (%).
    pub consistent_error: f64,
    /// Each value's prior, for the distance report.
    pub prior: Vec<f64>,
    /// Links made consistent (all ten barycentric parameters in the equations).
    pub links: Vec<String>,
    /// Links left as fitted (not all ten in the equations), with the reason.
    pub skipped: Vec<String>,
    /// Iterations taken.
    pub iterations: usize,
}

impl ConsistentFit {
    /// The value of a name.
    pub fn get(&self, name: &str) -> Option<f64> {
        self.names
            .iter()
            .position(|n| n == name)
            .map(|i| self.theta[i])
    }

    /// Set the values on `plant` (links converted to barycentric form where fitted).
    ///
    /// # Errors
    /// As [`Plant::set_barycentric_values`].
    pub fn apply(&self, plant: &mut Plant) -> Result<()> {
        plant.set_barycentric_values(&self.names, &self.theta)
    }
}

/// Parameters kept non-negative (as squares): the prefixes of dissipative and inertial sizes.
const NON_NEGATIVE: [&str; 6] = ["Fc_", "Fv_", "Ia_", "Fvm_", "Fm_", "Jm_"];

/// Pseudo-inertia of barycentric values `b` = (m, mx, my, mz, XX, XY, XZ, YY, YZ, ZZ), the
/// inertia about the frame origin as tensor entries.
pub fn pseudo_inertia(b: &[f64; 10]) -> Matrix4<f64> {
    let i = Matrix3::new(b[4], b[5], b[6], b[5], b[7], b[8], b[6], b[8], b[9]);
    let sigma = Matrix3::identity() * (0.5 * i.trace()) - i;
    let mut j = Matrix4::zeros();
    j.fixed_view_mut::<3, 3>(0, 0).copy_from(&sigma);
    for k in 0..3 {
        j[(k, 3)] = b[1 + k];
        j[(3, k)] = b[1 + k];
    }
    j[(3, 3)] = b[0];
    j
}

/// Barycentric values of a pseudo-inertia (the inverse of [`pseudo_inertia`]).
fn barycentric_of(j: &Matrix4<f64>) -> [f64; 10] {
    let sigma = j.fixed_view::<3, 3>(0, 0).into_owned();
    let i = Matrix3::identity() * sigma.trace() - sigma;
    [
        j[(3, 3)],
        j[(0, 3)],
        j[(1, 3)],
        j[(2, 3)],
        i[(0, 0)],
        i[(0, 1)],
        i[(0, 2)],
        i[(1, 1)],
        i[(1, 2)],
        i[(2, 2)],
    ]
}

/// The log-Cholesky parameters (α, d1, d2, d3, s12, s13, s23, t1, t2, t3) of U Uᵀ.
fn pseudo_of_log_cholesky(x: &[f64]) -> Matrix4<f64> {
    let (a, d1, d2, d3, s12, s13, s23, t1, t2, t3) =
        (x[0], x[1], x[2], x[3], x[4], x[5], x[6], x[7], x[8], x[9]);
    let u = Matrix4::new(
        d1.exp(),
        s12,
        s13,
        t1,
        0.0,
        d2.exp(),
        s23,
        t2,
        0.0,
        0.0,
        d3.exp(),
        t3,
        0.0,
        0.0,
        0.0,
        1.0,
    ) * a.exp();
    u * u.transpose()
}

/// The log-Cholesky parameters of a positive definite J (J = U Uᵀ, U upper triangular).
fn log_cholesky_of(j: &Matrix4<f64>) -> Option<[f64; 10]> {
    // U Uᵀ with U upper triangular is the Cholesky factor of J with its index order reversed.
    let p = Matrix4::new(
        0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0,
    );
    let l = (p * j * p).cholesky()?.l();
    let u = p * l * p;
    let ea = u[(3, 3)];
    if ea <= 0.0 {
        return None;
    }
    Some([
        ea.ln(),
        (u[(0, 0)] / ea).ln(),
        (u[(1, 1)] / ea).ln(),
        (u[(2, 2)] / ea).ln(),
        u[(0, 1)] / ea,
        u[(0, 2)] / ea,
        u[(1, 2)] / ea,
        u[(0, 3)] / ea,
        u[(1, 3)] / ea,
        u[(2, 3)] / ea,
    ])
}

/// How each column is parametrised.
enum Block {
    /// A link's ten barycentric columns (indices in the kind order m, mx, …, ZZ) and the
    /// margin ε added to Σ's diagonal (J = U Uᵀ + diag(ε, ε, ε, 0)): the centroidal
    /// inertia's principal moments stay ≥ 2ε, clear of the consistency check's tolerance.
    Link([usize; 10], f64),
    /// A non-negative value θ = x².
    Square(usize),
    /// A free value.
    Free(usize),
}

/// Refuse a prior that no body can have on a link the set includes: a negative mass, or an
/// inertia about the centroid with a negative principal moment (a zero one, a point or a
/// line as URDFs give for tool links, is the cone's edge and is accepted). The consistent
/// set is the one nearest to the prior; from an impossible prior that distance measures
/// nothing.
fn refuse_impossible_prior(
    plant: &Plant,
    names: &[String],
    values: &std::collections::BTreeMap<String, f64>,
) -> Result<()> {
    let m = plant.model;
    for (l, link) in m.links.iter().enumerate() {
        let params: Vec<usize> = (0..m.params.len())
            .filter(|&j| m.param_link[j] == l)
            .collect();
        if !params
            .iter()
            .any(|&j| names.iter().any(|n| n == m.params[j]))
        {
            continue;
        }
        let mut b = [0.0; 10];
        for &j in &params {
            b[m.param_kind[j]] = values.get(m.params[j]).copied().unwrap_or(0.0);
        }
        let origin = if plant.file.is_some() {
            plant.name()
        } else {
            "the prior".into()
        };
        if b[0] < 0.0 {
            bail!(
                "{origin}: the prior is itself impossible, so no nearest physical set can be \
                 measured from it: link '{link}' has mass {} kg (correct it in the plant's \
                 [parameters] or the model's [defaults], or leave out --consistent)",
                b[0]
            );
        }
        let Some(ci) = generated::inertia::CentroidalInertia::from_barycentric(&b) else {
            continue;
        };
        let moments = ci.principal_moments();
        let scale = moments.iter().fold(0.0f64, |a, x| a.max(x.abs()));
        if let Some(neg) = moments.iter().find(|&&x| x < -1e-9 * scale.max(1e-12)) {
            bail!(
                "{origin}: the prior is itself impossible, so no nearest physical set can be \
                 measured from it: link '{link}' has a principal moment of inertia {neg:.4e} \
                 kg·m² about its centroid (correct it in the plant's [parameters] or the \
                 model's [defaults], or leave out --consistent)"
            );
        }
    }
    Ok(())
}

/// The physically consistent standard set nearest to the fit `fit` of `obs` and to the
/// prior `plant` (its values before the fit). See the module documentation.
///
/// # Errors
/// The observation has no rows or its regressor is not finite; a prior value is missing; a
/// prior that is itself impossible (a negative mass or principal moment on a link the set
/// includes).
pub fn consistent_parameters(
    obs: &Observation,
    prior_plant: &Plant,
    fit: &Fit,
    opts: &ConsistentOptions,
) -> Result<ConsistentFit> {
    let m = prior_plant.model;
    let p = obs.names.len();
    // The columns, then each link's barycentric parameters that enter no equation of this
    // configuration (the first links of an arm): free in the body, held only by the prior.
    let mut names = obs.names.clone();
    for (l, _) in m.links.iter().enumerate() {
        let of_link: Vec<usize> = (0..m.params.len())
            .filter(|&j| m.param_link[j] == l)
            .collect();
        let present = of_link
            .iter()
            .filter(|&&j| names.iter().any(|n| n == m.params[j]))
            .count();
        if present > 0 && of_link.len() == 10 {
            for &j in &of_link {
                if !names.iter().any(|n| n == m.params[j]) {
                    names.push(m.params[j].to_string());
                }
            }
        }
    }
    let names = &names;
    let pe = names.len();
    let (rows, _) = obs.w.shape();
    if rows <= p {
        bail!("{rows} rows for {p} parameters: too few for the consistent set");
    }
    let theta_hat = DVector::from_column_slice(&fit.theta);
    let values = prior_plant.values_with_barycentric()?;
    refuse_impossible_prior(prior_plant, names, &values)?;
    let prior: Vec<f64> = names
        .iter()
        .map(|n| values.get(n).copied().unwrap_or(0.0))
        .collect();
    // The fit's values, and the prior for the values no column holds.
    let fitted: Vec<f64> = (0..pe)
        .map(|i| if i < p { fit.theta[i] } else { prior[i] })
        .collect();
    let resid = &obs.y - &obs.w * &theta_hat;
    let sigma = (resid.norm_squared() / (rows - p) as f64)
        .sqrt()
        .max(1e-300);
    let r = obs.w.clone().qr().r();
    // Scale of each value for the prior term: its prior, its estimate, or its kind's floor.
    let floor = |n: &str| -> f64 {
        let kind = m
            .params
            .iter()
            .position(|x| *x == n)
            .map(|j| m.param_kind[j]);
        match kind {
            Some(0) => 1e-2,
            Some(1..=3) => 1e-3,
            Some(_) => 1e-4,
            None => 1e-3,
        }
    };
    let scale: Vec<f64> = (0..pe)
        .map(|i| prior[i].abs().max(fitted[i].abs()).max(floor(&names[i])))
        .collect();
    // Blocks.
    let mut blocks = Vec::new();
    let mut links = Vec::new();
    let mut skipped = Vec::new();
    let mut in_link = vec![false; pe];
    for (l, lname) in m.links.iter().enumerate() {
        let mut idx = [usize::MAX; 10];
        for j in (0..m.params.len()).filter(|&j| m.param_link[j] == l) {
            if let Some(c) = names.iter().position(|n| n == m.params[j]) {
                idx[m.param_kind[j]] = c;
            }
        }
        let present = idx.iter().filter(|&&c| c != usize::MAX).count();
        if present == 10 {
            for &c in &idx {
                in_link[c] = true;
            }
            let bv: [f64; 10] = std::array::from_fn(|k| prior[idx[k]]);
            let sigma = pseudo_inertia(&bv).fixed_view::<3, 3>(0, 0).trace();
            blocks.push(Block::Link(idx, (1e-4 * sigma.abs() / 3.0).max(1e-9)));
            links.push(lname.to_string());
        } else if present > 0 {
            skipped.push(format!(
                "link {lname}: {present} of its ten barycentric parameters are in the equations (left as fitted)"
            ));
        }
    }
    for (i, n) in names.iter().enumerate() {
        if in_link[i] {
            continue;
        }
        if NON_NEGATIVE.iter().any(|pre| n.starts_with(pre)) {
            blocks.push(Block::Square(i));
        } else {
            blocks.push(Block::Free(i));
        }
    }
    // Starting point: the prior's bodies (made positive definite where they are not) and the
    // fit's other values.
    let mut x0: Vec<f64> = Vec::new();
    for b in &blocks {
        match b {
            Block::Link(idx, eps_margin) => {
                let bv: [f64; 10] = std::array::from_fn(|k| prior[idx[k]]);
                let mut j = pseudo_inertia(&bv);
                for k in 0..3 {
                    j[(k, k)] -= eps_margin;
                }
                let mass = j[(3, 3)].abs().max(1e-3);
                // A small sphere's second moment keeps a point mass or a rod positive definite.
                let mut eps = 1e-6 * mass;
                let x = loop {
                    if let Some(x) = log_cholesky_of(&j) {
                        break x;
                    }
                    j[(3, 3)] = j[(3, 3)].max(mass);
                    for k in 0..3 {
                        j[(k, k)] += eps;
                    }
                    eps *= 10.0;
                    if eps > 1e3 * mass {
                        j = Matrix4::identity() * mass;
                    }
                };
                x0.extend_from_slice(&x);
            }
            Block::Square(i) => x0.push(fitted[*i].max(0.0).sqrt().max(1e-6)),
            Block::Free(i) => x0.push(fitted[*i]),
        }
    }
    let theta_of = |x: &[f64]| -> DVector<f64> {
        let mut th = DVector::zeros(pe);
        let mut at = 0;
        for b in &blocks {
            match b {
                Block::Link(idx, eps_margin) => {
                    let mut j = pseudo_of_log_cholesky(&x[at..at + 10]);
                    for k in 0..3 {
                        j[(k, k)] += eps_margin;
                    }
                    let bv = barycentric_of(&j);
                    for k in 0..10 {
                        th[idx[k]] = bv[k];
                    }
                    at += 10;
                }
                Block::Square(i) => {
                    th[*i] = x[at] * x[at];
                    at += 1;
                }
                Block::Free(i) => {
                    th[*i] = x[at];
                    at += 1;
                }
            }
        }
        th
    };
    let weight = opts.prior_weight.max(0.0).sqrt();
    let residuals = |x: &[f64]| -> DVector<f64> {
        let th = theta_of(x);
        let data = &r * (th.rows(0, p) - &theta_hat) / sigma;
        let mut out = DVector::zeros(p + pe);
        out.rows_mut(0, p).copy_from(&data);
        for i in 0..pe {
            out[p + i] = weight * (th[i] - prior[i]) / scale[i];
        }
        out
    };
    // Levenberg–Marquardt (Marquardt's diagonal scaling, forward-difference Jacobian).
    let n = x0.len();
    let mut x = DVector::from_vec(x0);
    let mut res = residuals(x.as_slice());
    let mut cost = res.norm_squared();
    let mut lambda = 1e-3;
    let mut iterations = 0;
    for it in 0..opts.max_iterations {
        iterations = it + 1;
        let mut jac = DMatrix::zeros(p + pe, n);
        for k in 0..n {
            let h = 1e-7 * x[k].abs().max(1.0);
            let mut xp = x.clone();
            xp[k] += h;
            let rp = residuals(xp.as_slice());
            jac.set_column(k, &((rp - &res) / h));
        }
        let jtj = jac.transpose() * &jac;
        let g = jac.transpose() * &res;
        let mut improved = false;
        for _ in 0..30 {
            let mut a = jtj.clone();
            for k in 0..n {
                a[(k, k)] += lambda * jtj[(k, k)].max(1e-12);
            }
            let Some(step) = a.cholesky().map(|c| c.solve(&(-&g))) else {
                lambda *= 10.0;
                continue;
            };
            let xn = &x + &step;
            let rn = residuals(xn.as_slice());
            let cn = rn.norm_squared();
            if cn.is_finite() && cn < cost {
                let relative = (cost - cn) / cost.max(1e-300);
                x = xn;
                res = rn;
                cost = cn;
                lambda = (lambda / 3.0).max(1e-12);
                improved = relative > 1e-9;
                break;
            }
            lambda *= 4.0;
        }
        if !improved {
            break;
        }
    }
    let th = theta_of(x.as_slice());
    let error = |t: &DVector<f64>| 100.0 * (&obs.y - &obs.w * t.rows(0, p)).norm() / obs.y.norm();
    Ok(ConsistentFit {
        names: names.clone(),
        theta: th.iter().copied().collect(),
        unconstrained_error: 100.0 * (&obs.y - &obs.w * &theta_hat).norm() / obs.y.norm(),
        consistent_error: error(&th),
        prior,
        links,
        skipped,
        iterations,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_log_cholesky_map_and_its_inverse_agree() {
        // A rod-like body off its frame origin: m 2 kg, c = (0.1, −0.2, 0.3) m, centroidal
        // inertia diag(0.01, 0.02, 0.025) turned; J from it, its factor, and back.
        let (m, c) = (2.0, [0.1, -0.2, 0.3]);
        let ic = [
            [0.01, 0.001, 0.0],
            [0.001, 0.02, -0.002],
            [0.0, -0.002, 0.025],
        ];
        let shift = |a: usize, b: usize| {
            let d = c[0] * c[0] + c[1] * c[1] + c[2] * c[2];
            ic[a][b] + m * (if a == b { d } else { 0.0 } - c[a] * c[b])
        };
        let b = [
            m,
            m * c[0],
            m * c[1],
            m * c[2],
            shift(0, 0),
            shift(0, 1),
            shift(0, 2),
            shift(1, 1),
            shift(1, 2),
            shift(2, 2),
        ];
        let j = pseudo_inertia(&b);
        // Σ about the centroid plus m c cᵀ: its (0, 0) entry is ∫x² dm = ½(Iyy + Izz − Ixx)_c + m c0².
        let sxx = 0.5 * (0.02 + 0.025 - 0.01) + m * c[0] * c[0];
        assert!((j[(0, 0)] - sxx).abs() < 1e-15, "{}", j[(0, 0)]);
        let x = log_cholesky_of(&j).unwrap();
        let back = barycentric_of(&pseudo_of_log_cholesky(&x));
        for k in 0..10 {
            assert!(
                (back[k] - b[k]).abs() < 1e-13,
                "{k}: {} vs {}",
                back[k],
                b[k]
            );
        }
        // A body against the triangle inequality has no factor.
        let mut bad = b;
        bad[4] += 1.0; // Ixx far above Iyy + Izz
        assert!(log_cholesky_of(&pseudo_inertia(&bad)).is_none());
    }
}
