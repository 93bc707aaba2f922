//! What earlier fits' data say about the values a later fit moves: each fit's information
//! (Fisher) matrix and gradient at its solution ([`Information`]), summed over the steps of
//! a locking sequence ([`EarlierInformation`]), and the prior it gives a later step
//! ([`InformationPrior`]) with the values the later step's files do not see following
//! its moves ([`EarlierInformation::following`]).
//!
//! A later step of a locking sequence moves values that earlier steps determined only in
//! combination with others (a carried symbol, [`crate::identify::sequence::Step::carried`]):
//! c2 of the Freedom 6S's isolated method sees I7_22 only over the plant gain Kp_q5, and c4
//! then refits I7_22. Held at c2's value, Kp_q5 no longer matches, and the written plant
//! misses c2's files (stop 83: 1710 σ̂). The joint fit of all the steps' files is what
//! would keep both; each earlier step's cost is here replaced by its second-order
//! expansion at its solution, Cₑ(θ) ≈ Cₑ + 2 gₑᵀδ + δᵀFₑδ (Fₑ = JᵀΣ⁻¹J, gₑ = JᵀΣ⁻¹r,
//! whitened by the step's own residual variances, [`Problem::statistics`]), the sequential
//! (recursive) least-squares estimate of the joint fit. A later step fits its own files
//! plus that quadratic with every value its files see but it holds kept, and every value
//! its files do not see (Kp_q5 in c4) at its conditional minimum: the Schur complement
//! S = H_PP − H_Pr H_rr⁺ H_rP over the fitted values P, and after the fit
//! δ_r = −H_rr⁺ (H_rQ δ_Q + γ_r) for the rest r.

use super::*;
use nalgebra::{DMatrix, DVector};
use std::collections::BTreeMap;

/// Eigenvalues of a scaled information matrix below this fraction of its largest are taken
/// as zero: the data do not determine that direction (the statistics' exact-symmetry cut,
/// squared: singular values of J below 1e-6 of the largest).
const INFORMATION_CUTOFF: f64 = 1e-12;

/// One fit's information at its solution: its fitted values and the held values its files
/// see, F = JᵀΣ⁻¹J and g = JᵀΣ⁻¹r (J = ∂r/∂θ, physical units; Σ the residuals' variances
/// as the statistics estimate them, so F is the Fisher information: the inverse of the
/// covariance given the held values).
#[derive(Debug, Clone, Default, Serialize, serde::Deserialize)]
pub struct Information {
    /// Parameter names (n): the fitted ones, then the held values with a column.
    pub names: Vec<String>,
    /// Their values at the solution (n; SI).
    pub values: Vec<f64>,
    /// F (n × n, row-major; units 1 / (the two parameters' units)).
    pub matrix: Vec<Vec<f64>>,
    /// g (n; units 1 / the parameter's).
    pub gradient: Vec<f64>,
}

impl Information {
    /// Whether its parts agree in size (n names, n values, n × n matrix, n gradient) and
    /// every number is finite.
    pub fn is_well_formed(&self) -> bool {
        let n = self.names.len();
        self.values.len() == n
            && self.gradient.len() == n
            && self.matrix.len() == n
            && self.matrix.iter().all(|row| row.len() == n)
            && self
                .values
                .iter()
                .chain(&self.gradient)
                .chain(self.matrix.iter().flatten())
                .all(|x| x.is_finite())
    }

    /// The information of columns `cols` (∂r/∂θ, one of length m per name) at residuals
    /// `r` (m) with variances `sigma` (m); names with a column that is not finite are left
    /// out.
    pub(crate) fn of(
        names: Vec<String>,
        values: Vec<f64>,
        cols: &[Vec<f64>],
        r: &[f64],
        sigma: &[f64],
    ) -> Information {
        let keep: Vec<usize> = (0..names.len())
            .filter(|&i| cols[i].iter().all(|x| x.is_finite()))
            .collect();
        let weighted: Vec<Vec<f64>> = keep
            .iter()
            .map(|&i| {
                cols[i]
                    .iter()
                    .zip(sigma)
                    .map(|(c, s)| if *s > 0.0 { c / s } else { 0.0 })
                    .collect()
            })
            .collect();
        let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
        let matrix = keep
            .iter()
            .map(|&j| weighted.iter().map(|w| dot(w, &cols[j])).collect())
            .collect();
        let gradient = weighted.iter().map(|w| dot(w, r)).collect();
        Information {
            names: keep.iter().map(|&i| names[i].clone()).collect(),
            values: keep.iter().map(|&i| values[i]).collect(),
            matrix,
            gradient,
        }
    }
}

/// The information of a sequence's completed steps, summed: H = Σₑ Fₑ and the gradient
/// γ = Σₑ (Fₑ (θ − θₑ) + gₑ) at the plant's current values θ, over every value some step
/// fitted or held with a column.
#[derive(Debug, Clone)]
pub struct EarlierInformation {
    /// The values (N).
    names: Vec<String>,
    /// Each value's scale: its bounds' width in the plant, else its magnitude, else 1.
    scale: Vec<f64>,
    /// The plant's current values (N; SI).
    at: Vec<f64>,
    /// H in scaled units (N × N).
    hessian: DMatrix<f64>,
    /// γ in scaled units (N).
    gradient: DVector<f64>,
}

/// The prior an [`EarlierInformation`] gives a fit: Φ(θ) = ‖R (θ − c)‖² over the fitted
/// values, where the earlier steps' data determine a combination of them.
#[derive(Debug, Clone)]
pub struct InformationPrior {
    /// R (k × n over the fit's names, physical units).
    pub rows: Vec<Vec<f64>>,
    /// c (n; SI): the plant's value where no earlier data see the value.
    pub centre: Vec<f64>,
}

impl EarlierInformation {
    /// The sum of `steps`' information at `plant`'s current values; None when there is
    /// none (no step, or reports without it).
    pub fn gather<'a>(
        steps: impl IntoIterator<Item = &'a Information>,
        plant: &Plant,
    ) -> Option<EarlierInformation> {
        // A report edited by hand (`--resume` reads it back) may hold an information of
        // the wrong shape or with values that are not finite: it is left out.
        let steps: Vec<&Information> = steps.into_iter().filter(|s| s.is_well_formed()).collect();
        let mut index: BTreeMap<&str, usize> = BTreeMap::new();
        let mut names: Vec<String> = Vec::new();
        for s in &steps {
            for n in &s.names {
                if plant.parameters.contains_key(n) && !index.contains_key(n.as_str()) {
                    index.insert(n, names.len());
                    names.push(n.clone());
                }
            }
        }
        if names.is_empty() {
            return None;
        }
        let scale: Vec<f64> = names.iter().map(|n| value_scale(plant, n)).collect();
        let at: Vec<f64> = names.iter().map(|n| plant.parameters[n]).collect();
        let nn = names.len();
        let mut hessian = DMatrix::zeros(nn, nn);
        let mut gradient = DVector::zeros(nn);
        for s in &steps {
            let idx: Vec<Option<usize>> = s
                .names
                .iter()
                .map(|n| index.get(n.as_str()).copied())
                .collect();
            for (a, ia) in idx.iter().enumerate() {
                let Some(ia) = *ia else { continue };
                let mut g = s.gradient[a];
                for (b, ib) in idx.iter().enumerate() {
                    let Some(ib) = *ib else { continue };
                    let f = s.matrix[a][b];
                    hessian[(ia, ib)] += f * scale[ia] * scale[ib];
                    g += f * (at[ib] - s.values[b]);
                }
                gradient[ia] += g * scale[ia];
            }
        }
        Some(EarlierInformation {
            names,
            scale,
            at,
            hessian,
            gradient,
        })
    }

    /// Whether an earlier step's data see `name`.
    pub fn knows(&self, name: &str) -> bool {
        self.names.iter().any(|n| n == name)
    }

    /// The prior for a fit of `fitted` (n names), every other known value for which
    /// `enters` holds (it enters the fit's files) held where it is, and the rest at their
    /// conditional minimum; None where no earlier data see any fitted value.
    pub fn prior_for(
        &self,
        fitted: &[String],
        enters: impl Fn(&str) -> bool,
    ) -> Option<InformationPrior> {
        let p: Vec<usize> = (0..self.names.len())
            .filter(|&i| fitted.contains(&self.names[i]))
            .collect();
        if p.is_empty() {
            return None;
        }
        let r = self.following_set(fitted, &enters);
        let (s, b) = self.schur(&p, &r);
        // Φ_P(δ) = δᵀSδ + 2bᵀδ = Σ_k λ_k (v_kᵀδ + v_kᵀb / λ_k)² + const.
        let eig = s.symmetric_eigen();
        let largest = eig.eigenvalues.iter().cloned().fold(0.0, f64::max);
        if largest <= 0.0 || !largest.is_finite() {
            return None;
        }
        let n = fitted.len();
        let position = |i: usize| fitted.iter().position(|f| *f == self.names[i]);
        let mut rows = Vec::new();
        let mut d = DVector::zeros(p.len());
        for (k, &lambda) in eig.eigenvalues.iter().enumerate() {
            if lambda <= INFORMATION_CUTOFF * largest {
                continue;
            }
            let v = eig.eigenvectors.column(k);
            d -= v * (v.dot(&b) / lambda);
            let mut row = vec![0.0; n];
            for (a, &i) in p.iter().enumerate() {
                if let Some(j) = position(i) {
                    row[j] = lambda.sqrt() * v[a] / self.scale[i];
                }
            }
            rows.push(row);
        }
        let mut centre: Vec<f64> = vec![f64::NAN; n];
        for (a, &i) in p.iter().enumerate() {
            if let Some(j) = position(i) {
                centre[j] = self.at[i] + d[a] * self.scale[i];
            }
        }
        Some(InformationPrior { rows, centre })
    }

    /// The moves of the values a fit's files do not see, given the moves `moved` (name,
    /// change in SI) of the values it fitted or that `enters` its files: δ_r = −H_rr⁺
    /// (H_rQ δ_Q + γ_r), the earlier steps' costs at their minimum over the rest. Only
    /// nonzero moves are returned.
    pub fn following(
        &self,
        moved: &[(String, f64)],
        enters: impl Fn(&str) -> bool,
    ) -> Vec<(String, f64)> {
        let fitted: Vec<String> = moved.iter().map(|(n, _)| n.clone()).collect();
        let r = self.following_set(&fitted, &enters);
        if r.is_empty() {
            return Vec::new();
        }
        let q: Vec<usize> = (0..self.names.len()).filter(|i| !r.contains(i)).collect();
        let delta_q = DVector::from_iterator(
            q.len(),
            q.iter().map(|&i| {
                moved
                    .iter()
                    .find(|(n, _)| *n == self.names[i])
                    .map_or(0.0, |(_, d)| d / self.scale[i])
            }),
        );
        let h_rq = self.block(&r, &q);
        let rhs = h_rq * delta_q + self.part(&r);
        let delta_r = -pseudo_inverse(&self.block(&r, &r)) * rhs;
        r.iter()
            .zip(delta_r.iter())
            .filter(|(_, d)| **d != 0.0 && d.is_finite())
            .map(|(&i, d)| (self.names[i].clone(), d * self.scale[i]))
            .collect()
    }

    /// The known values neither in `fitted` nor entering the fit's files.
    fn following_set(&self, fitted: &[String], enters: &impl Fn(&str) -> bool) -> Vec<usize> {
        (0..self.names.len())
            .filter(|&i| !fitted.contains(&self.names[i]) && !enters(&self.names[i]))
            .collect()
    }

    /// S = H_PP − H_Pr H_rr⁺ H_rP and b = γ_P − H_Pr H_rr⁺ γ_r.
    fn schur(&self, p: &[usize], r: &[usize]) -> (DMatrix<f64>, DVector<f64>) {
        let h_pp = self.block(p, p);
        let g_p = self.part(p);
        if r.is_empty() {
            return (h_pp, g_p);
        }
        let h_pr = self.block(p, r);
        let h_rr_inv = pseudo_inverse(&self.block(r, r));
        let s = &h_pp - &h_pr * &h_rr_inv * h_pr.transpose();
        let s = (&s + s.transpose()) * 0.5;
        let b = g_p - &h_pr * h_rr_inv * self.part(r);
        (s, b)
    }

    fn block(&self, rows: &[usize], cols: &[usize]) -> DMatrix<f64> {
        DMatrix::from_fn(rows.len(), cols.len(), |a, b| {
            self.hessian[(rows[a], cols[b])]
        })
    }

    fn part(&self, rows: &[usize]) -> DVector<f64> {
        DVector::from_iterator(rows.len(), rows.iter().map(|&i| self.gradient[i]))
    }
}

/// The pseudo-inverse of a symmetric positive semi-definite `h`, eigenvalues below
/// [`INFORMATION_CUTOFF`] of the largest dropped.
fn pseudo_inverse(h: &DMatrix<f64>) -> DMatrix<f64> {
    let n = h.nrows();
    let eig = h.clone().symmetric_eigen();
    let largest = eig.eigenvalues.iter().cloned().fold(0.0, f64::max);
    let mut out = DMatrix::zeros(n, n);
    if largest <= 0.0 || !largest.is_finite() {
        return out;
    }
    for (k, &lambda) in eig.eigenvalues.iter().enumerate() {
        if lambda > INFORMATION_CUTOFF * largest {
            let v = eig.eigenvectors.column(k);
            out += v * v.transpose() / lambda;
        }
    }
    out
}

/// The scale of value `name` in `plant`: its bounds' width, else its magnitude, else 1.
fn value_scale(plant: &Plant, name: &str) -> f64 {
    match plant.bounds.get(name) {
        Some(&(lo, hi)) if hi > lo => hi - lo,
        _ => {
            let v = plant.parameters.get(name).map_or(0.0, |v| v.abs());
            if v > 0.0 {
                v
            } else {
                1.0
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A linear step: residuals r = y − A θ_S over the values `seen` (σ = 1), fitted by
    /// the least change from the current values under `prior` (rows over `seen`); returns
    /// the fitted values and the step's information at them.
    fn linear_step(
        values: &mut BTreeMap<String, f64>,
        seen: &[&str],
        a: &DMatrix<f64>,
        y: &DVector<f64>,
        prior: Option<&InformationPrior>,
    ) -> Information {
        let theta0 = DVector::from_iterator(seen.len(), seen.iter().map(|n| values[*n]));
        // Normal equations in δ = θ − θ0: (AᵀA + RᵀR) δ = Aᵀ(y − Aθ0) + RᵀR (c − θ0).
        let mut lhs = a.transpose() * a;
        let mut rhs = a.transpose() * (y - a * &theta0);
        if let Some(p) = prior {
            let r = DMatrix::from_fn(p.rows.len(), seen.len(), |k, j| p.rows[k][j]);
            let c = DVector::from_iterator(
                seen.len(),
                p.centre
                    .iter()
                    .zip(theta0.iter())
                    .map(|(c, t)| if c.is_nan() { *t } else { *c }),
            );
            lhs += r.transpose() * &r;
            rhs += r.transpose() * &r * (c - &theta0);
        }
        let delta = pseudo_inverse(&lhs) * rhs;
        let theta = theta0 + delta;
        for (n, t) in seen.iter().zip(theta.iter()) {
            values.insert(n.to_string(), *t);
        }
        let residual = y - a * &theta;
        let cols: Vec<Vec<f64>> = (0..seen.len())
            .map(|j| a.column(j).iter().map(|x| -x).collect())
            .collect();
        Information::of(
            seen.iter().map(|s| s.to_string()).collect(),
            theta.iter().copied().collect(),
            &cols,
            residual.as_slice(),
            &vec![1.0; y.len()],
        )
    }

    /// An information of the wrong shape or with a value that is not finite (a report
    /// edited by hand) is left out of the sum, not indexed out of bounds.
    #[test]
    fn a_malformed_information_is_left_out() {
        let mut plant = Plant::new("planar2r", vec![]).unwrap();
        plant.parameters.insert("a".into(), 1.0);
        let good = Information {
            names: vec!["a".into()],
            values: vec![1.0],
            matrix: vec![vec![4.0]],
            gradient: vec![0.0],
        };
        let short = Information {
            matrix: vec![],
            ..good.clone()
        };
        let nan = Information {
            gradient: vec![f64::NAN],
            ..good.clone()
        };
        assert!(good.is_well_formed() && !short.is_well_formed() && !nan.is_well_formed());
        assert!(EarlierInformation::gather([&short, &nan], &plant).is_none());
        let e = EarlierInformation::gather([&good, &short], &plant).unwrap();
        assert!(e.knows("a"));
    }

    /// For a linear model the sequence under the earlier information ends where the joint
    /// least-squares fit of all the steps' data does (recursive = batch least squares),
    /// although its first step sees only a − b: the second step refits a, and b follows it.
    /// Without the information the first step's tie breaks: its data are missed.
    #[test]
    fn a_linear_sequence_under_the_earlier_information_ends_at_the_joint_fit() {
        let names = ["a", "b", "c", "d"];
        let truth = [2.0, 0.5, -1.0, 3.0];
        let mut plant = Plant::new("planar2r", vec![]).unwrap();
        // A deterministic "noise": the joint fit is not the truth, so the test compares
        // with the joint fit, not with the truth.
        let noise = |k: usize| ((k as f64) * 1.7).sin() * 0.05;
        let t = |k: usize| k as f64 * 0.1;
        // Step 1 sees a − b and c; step 2 sees a and d; step 3 sees c and d.
        // Per step: the values its data see, and its regressor row at sample k.
        type Row<'a> = Box<dyn Fn(usize) -> Vec<f64> + 'a>;
        let steps: [(&[&str], Row); 3] = [
            (
                &["a", "b", "c"],
                Box::new(|k| vec![t(k).cos(), -t(k).cos(), 1.0]),
            ),
            (&["a", "d"], Box::new(|k| vec![1.0 + t(k), t(k).sin()])),
            (&["c", "d"], Box::new(|k| vec![t(k) * t(k), 1.0])),
        ];
        let m = 40;
        let data: Vec<(DMatrix<f64>, DVector<f64>)> = steps
            .iter()
            .enumerate()
            .map(|(e, (seen, row))| {
                let a = DMatrix::from_fn(m, seen.len(), |k, j| row(k)[j]);
                let y = DVector::from_fn(m, |k, _| {
                    row(k)
                        .iter()
                        .zip(seen.iter())
                        .map(|(x, n)| x * truth[names.iter().position(|s| s == n).unwrap()])
                        .sum::<f64>()
                        + noise(k + 100 * e)
                });
                (a, y)
            })
            .collect();
        // The joint least-squares fit of all three steps' data.
        let mut big = DMatrix::zeros(3 * m, 4);
        let mut y_all = DVector::zeros(3 * m);
        for (e, ((seen, _), (a, y))) in steps.iter().zip(&data).enumerate() {
            for k in 0..m {
                y_all[e * m + k] = y[k];
                for (j, n) in seen.iter().enumerate() {
                    big[(e * m + k, names.iter().position(|s| s == n).unwrap())] = a[(k, j)];
                }
            }
        }
        let joint = (big.transpose() * &big).try_inverse().unwrap() * big.transpose() * y_all;
        // The sequence from 1 everywhere, with and without the earlier information.
        for with_information in [true, false] {
            let mut values: BTreeMap<String, f64> =
                names.iter().map(|n| (n.to_string(), 1.0)).collect();
            let mut infos: Vec<Information> = Vec::new();
            for ((seen, _), (a, y)) in steps.iter().zip(&data) {
                for (n, v) in &values {
                    plant.parameters.insert(n.clone(), *v);
                }
                let earlier =
                    EarlierInformation::gather(infos.iter(), &plant).filter(|_| with_information);
                let fitted: Vec<String> = seen.iter().map(|s| s.to_string()).collect();
                let prior = earlier
                    .as_ref()
                    .and_then(|e| e.prior_for(&fitted, |n| seen.contains(&n)));
                let before = values.clone();
                infos.push(linear_step(&mut values, seen, a, y, prior.as_ref()));
                if let Some(e) = &earlier {
                    let moved: Vec<(String, f64)> = fitted
                        .iter()
                        .map(|n| (n.clone(), values[n] - before[n]))
                        .collect();
                    for (n, d) in e.following(&moved, |n| seen.contains(&n)) {
                        *values.get_mut(&n).unwrap() += d;
                    }
                }
            }
            let worst = names
                .iter()
                .enumerate()
                .map(|(i, n)| (values[*n] - joint[i]).abs())
                .fold(0.0, f64::max);
            if with_information {
                assert!(
                    worst < 1e-9,
                    "sequence {values:?} against the joint fit {joint}"
                );
            } else {
                // b stays where step 1's tie left it while step 2 moves a: step 1's a − b
                // is lost.
                assert!(
                    worst > 0.1,
                    "without the information: {values:?}, joint {joint}"
                );
            }
        }
    }
}
