//! The Jacobian of a configuration's output error by forward sensitivities
//! ([`JacobianMethod::Sensitivities`], [`JacobianMethod::Auto`]): every file simulated once with S = ∂x/∂θ stepped
//! beside the state ([`crate::simulation::PlantModel::predict_at_with_sensitivities`]), the
//! residuals' columns −√w_k λ_a ∂q̂_a,k/∂θ, and the chain rule to the solver's coordinates.

use super::*;
use crate::simulation::PlantParameter;

impl Problem {
    /// Whether this problem's Jacobian is taken by sensitivities: the method asks for them
    /// ([`JacobianMethod::Auto`]: for [`SENSITIVITIES_FROM`] values or more), the residuals
    /// are simulated by RK4, and every fitted value has derivatives
    /// ([`Plant::sensitivity_parameter`]).
    pub(crate) fn sensitivities_apply(&self) -> bool {
        let asked = match self.options.jacobian {
            JacobianMethod::Auto => self.names.len() >= SENSITIVITIES_FROM,
            JacobianMethod::Sensitivities => true,
            JacobianMethod::Differences => false,
        };
        asked
            && self.equation_error.is_none()
            && self.options.integrator == Integrator::Rk4
            && self
                .names
                .iter()
                .all(|name| self.plant.sensitivity_parameter(name, self.conf).is_ok())
    }

    /// ∂r/∂θ for the values `names` of `plant` (any values it holds: fitted or held; one
    /// column of length m each), every file simulated once with its sensitivities; None
    /// where they are not available or the fit's Jacobian is not taken by them
    /// ([`Problem::sensitivities_apply`]), so that held and fitted columns are the same
    /// derivative.
    pub(crate) fn value_sensitivities(
        &self,
        plant: &Plant,
        names: &[String],
    ) -> Option<Vec<Vec<f64>>> {
        if !self.sensitivities_apply() {
            return None;
        }
        let params: Vec<PlantParameter> = names
            .iter()
            .map(|name| plant.sensitivity_parameter(name, self.conf).ok())
            .collect::<Option<_>>()?;
        let per_file: Vec<Vec<Vec<f64>>> = self
            .records
            .par_iter()
            .enumerate()
            .map(|(ri, r)| self.record_sensitivities(plant, ri, r, &params))
            .collect::<Option<_>>()?;
        let mut dr_dp = vec![vec![0.0; self.m]; names.len()];
        let mut at = 0;
        for cols in &per_file {
            let len = cols.first().map_or(0, Vec::len);
            for (k, col) in cols.iter().enumerate() {
                dr_dp[k][at..at + len].copy_from_slice(col);
            }
            at += len;
        }
        Some(dr_dp)
    }

    /// ∂r/∂x at `stencil`'s point by sensitivities, or None where they are not available
    /// (the Jacobian method is differences, the equation error's stage, the ETDRK4
    /// integrator, a fitted value or an effect without derivatives, a file that does not
    /// simulate): the caller then takes finite differences.
    ///
    /// The solver's coordinates x map to the physical values by `stencil.p_of`, affine in
    /// each coordinate except where Fs meets Fc ([`scaled_to_physical`]): ∂p/∂x is taken by
    /// differences of that map with the stencil's steps (no simulation; exact on the
    /// affine pieces).
    pub(crate) fn sensitivity_columns(&self, stencil: &Stencil) -> Option<Vec<Vec<f64>>> {
        let p = (stencil.p_of)(stencil.x);
        let dr_dp = self.value_sensitivities(&self.plant_at(&p), &self.names)?;
        let dp_dx = physical_derivatives(stencil, &p);
        Some(chain(&dp_dx, &dr_dp, Some, self.m))
    }

    /// ∂r/∂θ of file `ri` (one column per parameter, the file's residuals in
    /// [`Problem::record_residuals`]'s order), or None where the file cannot be simulated
    /// with sensitivities.
    fn record_sensitivities(
        &self,
        plant: &Plant,
        ri: usize,
        r: &Record,
        params: &[PlantParameter],
    ) -> Option<Vec<Vec<f64>>> {
        let sim = plant
            .simulator(self.conf.name, &r.q_all, ConsistencyPolicy::Warn)
            .ok()?
            .model;
        let mut sim = sim;
        sim.integrator = self.options.integrator;
        let (x0, input, max_speed) = self.start_of(&sim, r);
        let s0 = r
            .qd0
            .as_ref()
            .map(|_| sim.sliding_start_tangent(&x0, params));
        let s = sim
            .predict_at_with_sensitivities(
                (x0, s0.as_deref()),
                self.options.h,
                &input,
                self.predictor.map(|omega| (omega, r.q.as_slice())),
                &r.t,
                max_speed,
                params,
            )
            .ok()?;
        Some(
            s.q.iter()
                .map(|dq| {
                    let mut col = Vec::new();
                    for (a, lam) in self.lambda.iter().enumerate() {
                        for (k, &sw) in self.sqrt_w[ri].iter().enumerate() {
                            if sw > 0.0 {
                                col.push(-sw * lam * dq[a][k]);
                            }
                        }
                    }
                    col
                })
                .collect(),
        )
    }
}

/// ∂p/∂x of the solver's coordinates at `stencil`'s point (physical parameters `p` there),
/// row i = ∂p/∂x_i: differences of the map `stencil.p_of` with the stencil's steps (no
/// simulation; exact where the map is affine in x_i, everywhere except where Fs meets Fc).
pub(crate) fn physical_derivatives(stencil: &Stencil, p: &[f64]) -> Vec<Vec<f64>> {
    (0..stencil.x.len())
        .map(|i| {
            let mut xi = stencil.x.to_vec();
            xi[i] += stencil.steps[i];
            let pi = (stencil.p_of)(&xi);
            pi.iter()
                .zip(p)
                .map(|(a, b)| (a - b) / stencil.steps[i])
                .collect()
        })
        .collect()
}

/// The chain rule ∂r/∂x_i = Σ_k ∂p_k/∂x_i ∂r/∂p_k: `dp_dx` (n rows of the physical
/// parameters' derivatives), `dr_dp` (one column of length `m` per parameter the
/// residuals read), `column_of(k)` the column of physical parameter k (None: the residuals
/// do not read it). n columns of length m.
pub(crate) fn chain(
    dp_dx: &[Vec<f64>],
    dr_dp: &[Vec<f64>],
    column_of: impl Fn(usize) -> Option<usize>,
    m: usize,
) -> Vec<Vec<f64>> {
    dp_dx
        .iter()
        .map(|row| {
            let mut col = vec![0.0; m];
            for (k, d) in row.iter().enumerate() {
                if let (true, Some(c)) = (*d != 0.0, column_of(k)) {
                    for (o, g) in col.iter_mut().zip(&dr_dp[c]) {
                        *o += d * g;
                    }
                }
            }
            col
        })
        .collect()
}
