//! Statistics of a fit: standard errors from the Jacobian (with the held values' share),
//! correlations, exact symmetries and structural ties, fit figures per joint.

use super::*;

/// Correlation above which two parameters are reported as not separately identifiable.
pub const CORRELATION_LIMIT: f64 = 0.95;
/// Relative standard error (σ/|p|) above which a parameter is reported as poorly determined.
pub const RELATIVE_STD_LIMIT: f64 = 0.02;
/// A fit is at the noise floor when every free joint's RMS position error is at most this
/// multiple of the joint's noise σ̂ estimated from the data (the criterion: 1.5 σ).
pub const FLOOR_FACTOR: f64 = 1.5;
/// Δχ² (the objective's difference over s̄², [`Problem::noise_residual_rms`]) within which
/// another start's minimum is as good as the kept one: 3.84, the 95 % quantile of χ² with
/// one degree of freedom (a profile likelihood's 95 % interval).
pub const EQUAL_MINIMUM_CHI2: f64 = 3.84;
/// A parameter whose value at an equally good minimum ([`EQUAL_MINIMUM_CHI2`]) lies more
/// than this many standard errors from the kept one is not determined by the data, whatever
/// its standard error says.
pub const EQUAL_MINIMUM_STD_ERRORS: f64 = 2.0;

/// Another start's minimum as good as the kept one within the noise ([`EQUAL_MINIMUM_CHI2`]):
/// the linearised standard errors describe only the kept minimum's neighbourhood, and a
/// parameter that differs between the two by more than [`EQUAL_MINIMUM_STD_ERRORS`] of them
/// is not identifiable from these data. The isolated step c4 of the Freedom 6S with the plant
/// gains known: the kept fit (0.31497) had joint 2's Stribeck dip collapsed (Fs_q2 = 1.0004
/// Fc_q2 at vs_q2 = 0.46 rad/s) and called Fs_q2 identifiable at ± 5.9e-6 N·m, 38 % below the
/// truth; the Stribeck re-seed's branch ended at 0.31499 with the dip near the truth's.
#[derive(Debug, Clone, Default, Serialize, serde::Deserialize)]
pub struct OtherMinimum {
    /// The start that ended there ([`StartSummary::start`]).
    pub start: usize,
    /// Its objective (cost plus prior term) minus the kept one's (≥ 0).
    pub objective_difference: f64,
    /// `objective_difference` / s̄².
    pub chi2_difference: f64,
    /// Parameters farther than [`EQUAL_MINIMUM_STD_ERRORS`] standard errors from the kept
    /// minimum: (name, value there (SI), distance in standard errors).
    pub moved: Vec<(String, f64, f64)>,
}

/// Fit figures of one free joint over all files.
#[derive(Debug, Clone, Default, Serialize, serde::Deserialize)]
pub struct JointFit {
    /// Joint name.
    pub joint: String,
    /// λ in the cost.
    pub weight: f64,
    /// RMS position error (rad), all samples (MATLAB `compare`'s figure).
    pub rms: f64,
    /// RMS position error (rad) over the samples the cost weighs (w > 0): after the
    /// skipped transient under cost (4.3), every sample under (4.2). The noise floor is
    /// judged on it: (4.3) skips the first samples because the initial state is not known
    /// (on the Freedom 6S's k4 the truth from the measured first samples is at 1.50 σ on
    /// q5 over all samples, 1.00 σ after the skip).
    pub rms_fitted: f64,
    /// Largest |error| (rad).
    pub max_abs: f64,
    /// NRMSE fit % = 100 (1 − ‖y − ŷ‖ / ‖y − ȳ‖) (MATLAB `compare`).
    pub nrmse_fit: f64,
    /// Measurement noise σ̂ of the joint estimated from the files alone (rad,
    /// [`crate::signal::noise_sigma`]): an RMS error near it is the noise floor.
    pub noise: f64,
    #[serde(skip)]
    sse: f64,
    #[serde(skip)]
    sst: f64,
    #[serde(skip)]
    n: usize,
    #[serde(skip)]
    sse_fitted: f64,
    #[serde(skip)]
    n_fitted: usize,
}

/// Uncertainty and fit figures at a solution.
#[derive(Debug, Clone, Default, Serialize, serde::Deserialize)]
pub struct Statistics {
    /// Standard error per parameter (its units), the held values' uncertainty included
    /// (`held`).
    pub std_err: Vec<f64>,
    /// Standard error per parameter with every held value taken as exact (the sandwich
    /// covariance of this fit's data alone).
    pub std_err_given_held: Vec<f64>,
    /// Held values whose standard errors (recorded by the step that fitted them) are
    /// propagated into `std_err`: (name, σ).
    pub held: Vec<(String, f64)>,
    /// Held ties ([`Problem::with_held_ties`]) without a recorded standard error, whose
    /// value is known only to lie within their bounds: propagated into `std_err` as a
    /// uniform spread over the bounds, σ = (upper − lower)/√12: (name, σ). A fitted value
    /// that makes up for a held tie (k1 of the Freedom 6S: z7 for I7_13, a tie through
    /// the parallel-axis term m7·x7·z7) is determined only given the tie's arbitrary
    /// value, and its standard error says so.
    pub held_ties: Vec<(String, f64)>,
    /// Per held value of `held` (recorded standard error σ_h, not a tie): ρ_h = σ_h² /
    /// var_h, var_h the variance this fit's data alone would give the value fitted with
    /// the fitted parameters (the same sandwich covariance as `std_err_given_held`, the
    /// held value's column appended), 0 where the data cannot determine it. ρ_h > 1: this
    /// step sees the value better than the step that fitted it (`--release-held`). With
    /// `held_scales`, relative to their scale.
    pub held_information: Vec<(String, f64)>,
    /// Held values that enter the fit without a recorded standard error (and held ties
    /// without bounds): taken as exact.
    pub held_exact: Vec<String>,
    /// Plant-gain scale families ([`crate::plant::Plant::scale_families`]) with members
    /// this fit holds: (family, those members). No step determined the family's scale, so
    /// it counts as unknown in `std_err` (its column projected out): a fitted value that
    /// moves with it (the coupled k2 of the Freedom 6S: Kp_q3 and joint 3's friction,
    /// coupled to the held gains of joints 4 and 5 that k1 left on their symmetry) is
    /// known only relative to it, and its standard error is infinite.
    #[serde(default)]
    pub held_scales: Vec<(String, Vec<String>)>,
    /// Standard error per parameter with the held scale families' scale taken as exact
    /// (as `std_err` otherwise): what the fit determines relative to that scale. Equal to
    /// `std_err` without `held_scales`; empty in reports written before stop 86.
    #[serde(default)]
    pub std_err_given_scale: Vec<f64>,
    /// Per parameter, identifiable relative to the held scale families' scale (as
    /// `identifiable`, from `std_err_given_scale`): what a locking sequence reads to decide
    /// which rigid-body symbols a later step fits again. Empty as `std_err_given_scale`.
    #[serde(default)]
    pub identifiable_given_scale: Vec<bool>,
    /// σ/|p|.
    pub relative_std_err: Vec<f64>,
    /// Correlation matrix (n × n) of this fit's data (the held values exact: whether the
    /// data separate two parameters; the held values' share, common to both, would mask
    /// it); 0 off the diagonal for a parameter the data do not determine (infinite
    /// standard error: its covariance is amplified rounding).
    pub correlation: Vec<Vec<f64>>,
    /// Correlation matrix (n × n) of the estimates with the held values' share: that of
    /// `std_err`'s covariance (`std_err_given_scale`'s with `held_scales`), what a later
    /// step that holds these values propagates ([`crate::plant::Plant::correlations`]); 0
    /// off the diagonal as in `correlation`.
    #[serde(skip)]
    pub correlation_with_held: Vec<Vec<f64>>,
    /// Pairs with |correlation| > [`CORRELATION_LIMIT`].
    pub correlated: Vec<(String, String, f64)>,
    /// At (within 1e-4 of the width of) a bound.
    pub at_bound: Vec<bool>,
    /// The fit is at the noise floor (`above_floor` empty), and σ/|p| ≤
    /// [`RELATIVE_STD_LIMIT`], not at a bound, no correlation above the limit, not
    /// structurally tied to other fitted symbols (`only_with` empty).
    pub identifiable: Vec<bool>,
    /// Per parameter, the other rigid-body symbols (fitted, or held along ties) it trades
    /// with exactly: the configuration's outputs determine only combinations of them (its
    /// base parameters).
    pub only_with: Vec<Vec<String>>,
    /// Free joints whose RMS error over the fitted samples ([`JointFit::rms_fitted`])
    /// exceeds [`FLOOR_FACTOR`] × their noise σ̂, as "q3 RMS
    /// 12.4 σ̂": the residuals are not noise, so the standard errors (which assume they
    /// are) do not bound the error of the values, and no parameter is called identifiable.
    pub above_floor: Vec<String>,
    /// Other starts' minima as good as the kept one ([`OtherMinimum`]); a parameter that
    /// moved between them is not identifiable ([`Statistics::mark_other_minima`]).
    pub other_minima: Vec<OtherMinimum>,
    /// Condition number of the column-scaled JᵀJ.
    pub condition: f64,
    /// The fit's information at its solution ([`Information`]: F = JᵀΣ⁻¹J and JᵀΣ⁻¹r over
    /// the fitted values and the held values with a column): what a later step of a
    /// locking sequence keeps of this step's files ([`EarlierInformation`]). Absent from
    /// reports written before stop 84.
    #[serde(default)]
    pub information: Option<Information>,
    /// Per free joint.
    pub joints: Vec<JointFit>,
}

impl Problem {
    /// Standard errors, correlations and fit figures at physical parameters `p`.
    ///
    /// Covariance of the weighted least-squares estimate with per-joint noise variances
    /// s_a² (estimated from that joint's residuals): cov = (JᵀJ)⁻¹ Jᵀ Σ J (JᵀJ)⁻¹,
    /// Σ = diag(w_k λ_a² s_a²), J = ∂r/∂p by central differences (step 1e-6 of the bound
    /// width).
    ///
    /// # Errors
    /// The simulation at `p` fails.
    pub fn statistics(&self, p: &[f64]) -> Result<Statistics> {
        let trajectories = self
            .trajectories(p)
            .map_err(|e| anyhow::anyhow!("at the fitted values: {}", e))?;
        let r = self.residuals_of(&trajectories);
        let occ = crate::identify::identifiability::occurrence(self.plant.model);
        let mut held = held_in(
            &self.plant,
            &self.names,
            &self.held_ties,
            &occ,
            &[self.conf],
        );
        held.set_columns(self.held_columns(p, &held.column_names(), &r));
        let at = AtTheFit {
            variances: self.residual_variances(&r),
            r: &r,
            held,
            free: self.conf.free,
            only_with: self.structural_companions(p)?,
            joints: self.joint_fits(&trajectories),
        };
        statistics_at(self, p, at, |ties| self.held_columns(p, ties, &r))
    }

    /// ∂r/∂h at fitted values `p` for every held value named in `held`: by sensitivities
    /// where the fit's Jacobian is ([`Problem::value_sensitivities`]), so that held and
    /// fitted columns are the same derivative; else central differences of the plant's
    /// value ([`held_step`]), held values in parallel; `r0` the residuals at `p` (for a
    /// one-sided difference where a side fails, [`difference_column`]).
    pub(crate) fn held_columns(&self, p: &[f64], held: &[String], r0: &[f64]) -> Vec<Vec<f64>> {
        let plant = self.plant_at(p);
        if let Some(cols) = self.value_sensitivities(&plant, held) {
            return cols;
        }
        held.par_iter()
            .map(|name| {
                let h = plant.parameters[name];
                let at = |s: f64| {
                    let mut moved = plant.clone();
                    moved.parameters.insert(name.clone(), h + s);
                    let trajectories = self
                        .records
                        .iter()
                        .map(|r| self.simulate(&moved, r))
                        .collect::<Result<Vec<_>, _>>()?;
                    Ok(self.residuals_of(&trajectories))
                };
                let step = held_step(&plant, name, self.options.fd_step);
                difference_column(&at, r0, step, true)
            })
            .collect()
    }

    /// The variance of every residual `r` (this problem's, in order) under the noise model
    /// of [`Problem::statistics`]: w_k λ_a² s_a², s_a² the mean square of joint a's
    /// unweighted errors (no correction for the fitted parameters' degrees of freedom).
    pub(crate) fn residual_variances(&self, r: &[f64]) -> Vec<f64> {
        let m = r.len();
        // Per-joint noise variance and the diagonal of Σ.
        let nf = self.lambda.len();
        let mut sigma = vec![0.0; m];
        let mut var = vec![0.0; nf];
        let mut cnt = vec![0usize; nf];
        let mut i = 0;
        let mut owner = vec![0usize; m];
        for ri in 0..self.records.len() {
            for a in 0..nf {
                for &sw in &self.sqrt_w[ri] {
                    if sw > 0.0 {
                        let e = r[i] / (sw * self.lambda[a]);
                        var[a] += e * e;
                        cnt[a] += 1;
                        owner[i] = a;
                        sigma[i] = sw * sw * self.lambda[a] * self.lambda[a];
                        i += 1;
                    }
                }
            }
        }
        for a in 0..nf {
            var[a] /= (cnt[a].max(1)) as f64;
        }
        for k in 0..m {
            sigma[k] *= var[owner[k]];
        }
        sigma
    }

    /// For every fitted parameter, the other rigid-body symbols — fitted or held along
    /// ties ([`Problem::with_held_ties`]) — it trades with exactly at `p`, with the locked
    /// joints where the files hold them ([`fitted_companions`]).
    ///
    /// # Errors
    /// The plant's barycentric parameters cannot be formed.
    fn structural_companions(&self, p: &[f64]) -> Result<Vec<Vec<String>>> {
        let locked_at = self.locked_at();
        fitted_companions(
            &self.plant_at(p),
            &self.names,
            (&self.lower, &self.upper),
            &self.held_ties,
            &[(self.conf, &locked_at)],
        )
    }

    /// Fit figures per free joint of the files' `trajectories` (one per record, as from
    /// [`Problem::trajectories`]) over all samples, unweighted, as MATLAB's `compare`.
    pub fn joint_fits(&self, trajectories: &[Trajectory]) -> Vec<JointFit> {
        let nf = self.lambda.len();
        let mut joint = vec![JointFit::default(); nf];
        for (ri, (rec, traj)) in self.records.iter().zip(trajectories).enumerate() {
            for a in 0..nf {
                let y = &rec.q[a];
                let mean = y.iter().sum::<f64>() / y.len() as f64;
                for k in 0..y.len() {
                    let e = y[k] - traj.q[a][k];
                    if self.sqrt_w[ri].get(k).is_some_and(|&w| w > 0.0) {
                        joint[a].sse_fitted += e * e;
                        joint[a].n_fitted += 1;
                    }
                    joint[a].sse += e * e;
                    joint[a].sst += (y[k] - mean) * (y[k] - mean);
                    joint[a].n += 1;
                    if e.abs() > joint[a].max_abs {
                        joint[a].max_abs = e.abs();
                    }
                }
            }
        }
        for (a, jf) in joint.iter_mut().enumerate() {
            jf.joint = self.plant.model.joints[self.conf.free[a]].to_string();
            jf.weight = self.lambda[a];
            jf.noise = self.noise[a];
            jf.rms = (jf.sse / jf.n.max(1) as f64).sqrt();
            jf.rms_fitted = (jf.sse_fitted / jf.n_fitted.max(1) as f64).sqrt();
            jf.nrmse_fit = crate::util::nrmse_fit_from_sums(jf.sse, jf.sst);
        }
        joint
    }
}

/// Values a fit holds at an earlier step's estimate, whose uncertainty the fitted values
/// inherit: the fit absorbs an error δh of a held value as the change −(JᵀJ)⁻¹ Jᵀ J_h δh of
/// its own estimate (the linearised two-stage estimator; Murphy and Topel 1985).
#[derive(Debug, Clone, Default)]
pub(crate) struct HeldColumns {
    /// Held parameter names.
    pub names: Vec<String>,
    /// Standard error of each (SI), as recorded by the step that fitted it
    /// ([`crate::plant::Plant::standard_errors`]), or for a held tie without one its
    /// bounds' uniform spread (upper − lower)/√12.
    pub std_err: Vec<f64>,
    /// Correlations (k, l, ρ), k < l, of held values that one step fitted together
    /// ([`crate::plant::Plant::correlations`]); every other pair, and every held tie's
    /// spread, is independent. The held share is G D R D Gᵀ with D = diag(`std_err`).
    pub correlation: Vec<(usize, usize, f64)>,
    /// Per held value: a held tie whose `std_err` is its bounds' spread (not recorded).
    pub tie: Vec<bool>,
    /// ∂r/∂h of the fit's residuals per held value (length m each).
    pub cols: Vec<Vec<f64>>,
    /// Per held value, for a held tie ([`GainScaleContext::make_up_held_ties`]): the change
    /// of the fitted values (physical units, per unit of the tie) that makes up for it,
    /// solved over the fitted rigid-body symbols that span it ([`rigid_body_make_up`]).
    /// `None` (and for every value where this is empty): the two-stage estimator's
    /// −(JᵀJ)⁻¹ Jᵀ J_h. Why: JᵀJ is inverted with the plant-gain scale projected out, and
    /// J_h's share along that direction is the finite-difference Jacobian's error, which
    /// −(JᵀJ)⁻¹ Jᵀ J_h spreads over every parameter (k1 of the Freedom 6S at the truth:
    /// qeq_q4 ± 0.0155 rad, 6 %, from the held y7 and I7_13, against 4.6e-6 rad given them).
    pub make_up: Vec<Option<Vec<f64>>>,
    /// Held parameters that enter the fit without a recorded standard error (never fitted,
    /// or not determined where they were): taken as exact.
    pub exact: Vec<String>,
    /// Held members of plant-gain scale families no step determined
    /// ([`crate::plant::Plant::scale_families`]), per family: their common scale is
    /// unknown.
    pub scales: Vec<HeldScale>,
}

/// A plant-gain scale family ([`crate::plant::Plant::scale_families`]) with members a fit
/// holds although they enter it: the step that left the family fixed their scale α only
/// by its least change, so α is a nuisance the fit cannot know (Frisch–Waugh–Lovell: the
/// fitted values' covariance with α free is that of the Jacobian with ∂r/∂α projected
/// out, [`project_out_held_scales`]).
#[derive(Debug, Clone, Default)]
pub(crate) struct HeldScale {
    /// The family's name (the step that last formed it).
    pub family: String,
    /// Its members held here (nonzero, entering the fit).
    pub names: Vec<String>,
    /// Their values h (SI).
    pub values: Vec<f64>,
    /// ∂r/∂α = Σ_h h ∂r/∂h: the residuals' change per unit relative change of the scale
    /// (m; empty until [`HeldColumns::set_columns`]).
    pub col: Vec<f64>,
}

impl HeldColumns {
    /// The held values whose columns a fit computes, each once: those with a standard
    /// error or a tie's spread (`names`), then the held scale families' other members.
    pub(crate) fn column_names(&self) -> Vec<String> {
        let mut names = self.names.clone();
        for s in &self.scales {
            for n in &s.names {
                if !names.contains(n) {
                    names.push(n.clone());
                }
            }
        }
        names
    }

    /// Takes the columns ∂r/∂h of [`HeldColumns::column_names`], in that order: the held
    /// values' into `cols`, each scale family's members' summed into its ∂r/∂α.
    pub(crate) fn set_columns(&mut self, cols: Vec<Vec<f64>>) {
        let names = self.column_names();
        for s in &mut self.scales {
            let mut col: Vec<f64> = Vec::new();
            for (h, n) in s.values.iter().zip(&s.names) {
                let Some(c) = names.iter().position(|m| m == n).and_then(|k| cols.get(k)) else {
                    continue;
                };
                if col.is_empty() {
                    col = vec![0.0; c.len()];
                }
                for (a, b) in col.iter_mut().zip(c) {
                    *a += h * b;
                }
            }
            s.col = col;
        }
        self.cols = cols.into_iter().take(self.names.len()).collect();
    }
}

/// Removes the held scale families' directions ∂r/∂α ([`HeldScale`]) from the fitted
/// columns `cols` and the held values' columns (orthogonally in the residuals, as the
/// least squares sees them): the covariance of the fitted values with every family's scale
/// free (Frisch–Waugh–Lovell). Where the fit's own plant-gain scale is an exact symmetry
/// together with them, that direction is then one the data do not see, and its members'
/// standard errors are infinite: they are known only relative to the family's scale.
/// A column the families' scale spans alone is zeroed (undetermined). `false` (nothing
/// changed) when a family's column is not finite (a simulation fails where the scale
/// moves): the share is then unknown.
pub(crate) fn project_out_held_scales(cols: &mut [Vec<f64>], held: &mut HeldColumns) -> bool {
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
    if held
        .scales
        .iter()
        .any(|s| !s.col.iter().all(|x| x.is_finite()))
    {
        return false;
    }
    // An orthonormal basis of the families' columns (modified Gram–Schmidt, twice).
    let mut basis: Vec<Vec<f64>> = Vec::new();
    for s in &held.scales {
        let full = dot(&s.col, &s.col).sqrt();
        let mut u = s.col.clone();
        for _ in 0..2 {
            for b in &basis {
                let d = dot(&u, b);
                u.iter_mut().zip(b).for_each(|(x, y)| *x -= d * y);
            }
        }
        let norm = dot(&u, &u).sqrt();
        if norm > 1e-12 * full && norm > 0.0 {
            u.iter_mut().for_each(|x| *x /= norm);
            basis.push(u);
        }
    }
    for c in cols.iter_mut().chain(held.cols.iter_mut()) {
        let before = dot(c, c).sqrt();
        for b in &basis {
            if c.len() == b.len() {
                let d = dot(c, b);
                c.iter_mut().zip(b).for_each(|(x, y)| *x -= d * y);
            }
        }
        // A column the families' scale spans (to the Jacobian's accuracy: below the
        // singular-value cut-off of the covariance, on the columns' scale) is one the data
        // do not see with the scale free; normalised, its residue would pass for a
        // direction of its own.
        if dot(c, c).sqrt() < EXACT_SYMMETRY.sqrt() * before {
            c.fill(0.0);
        }
    }
    true
}

/// Singular value of the scaled JᵀJ, relative to the largest, below which a direction is
/// taken as not seen by the data (an exact symmetry, resolved by a finite-difference
/// Jacobian only to its own accuracy).
pub(crate) const EXACT_SYMMETRY: f64 = 1e-9;

/// Which parameters the directions not seen by the data move: `v_t` the right singular
/// vectors of the scaled JᵀJ (rows, unit norm in the columns' unit-norm coordinates),
/// `singular` its singular values, `cutoff` the largest singular value taken as not seen;
/// `scale(i)` the column's norm times the parameter's size (`None` for a column that is
/// zero: such a parameter is undetermined on its own, and moves nothing else), so that
/// `v[i] / scale(i)` is the relative change of parameter `i` along the direction. A
/// parameter is moved when its component is above rounding (1e-12) and its relative
/// change is at least 1e-3 of the largest along that direction: the plant gain's scale
/// family moves all its members by the same fraction, however different their columns'
/// norms. Conservative: magnitude alone does not tell a real part from the Jacobian's own
/// error, so the plant-gain direction is built without the latter
/// ([`gain_scale_direction`]: on k1 of the Freedom 6S it moves z7, which makes up for the
/// held tie I7_13, and no longer vs_q4, which a least squares over every column had moved
/// by more than 1e-3 of the largest change). A direction that lives in zero
/// columns (k1: Fs_q5 with vs_q5 → 0) leaves the others at rounding (≤ 2.4e-15), which
/// must not count: divided by a tiny parameter's scale, rounding had looked like the
/// largest change and made seven parameters "undetermined".
fn moved_by_null_directions(
    v_t: &DMatrix<f64>,
    singular: &nalgebra::DVector<f64>,
    cutoff: f64,
    scale: impl Fn(usize) -> Option<f64>,
) -> Vec<bool> {
    let n = v_t.ncols();
    let mut moved = vec![false; n];
    for (k, &sv) in singular.iter().enumerate() {
        if sv > cutoff {
            continue;
        }
        let relative_change: Vec<f64> = (0..n)
            .map(|i| match scale(i) {
                Some(s) if v_t[(k, i)].abs() > 1e-12 => (v_t[(k, i)] / s).abs(),
                _ => 0.0,
            })
            .collect();
        let largest = relative_change.iter().cloned().fold(0.0, f64::max);
        for (i, &r) in relative_change.iter().enumerate() {
            if largest > 0.0 && r >= 1e-3 * largest {
                moved[i] = true;
            }
        }
    }
    moved
}

/// What the statistics of a fit read at its solution besides the Jacobian.
pub(crate) struct AtTheFit<'a> {
    /// Residuals (m) at the solution.
    pub(crate) r: &'a [f64],
    /// Per-residual noise variance (m), as estimated from the residuals (scaled here by
    /// m / (m − n) for the n fitted parameters).
    pub(crate) variances: Vec<f64>,
    /// The held values' columns ∂r/∂h ([`held_in`]).
    pub(crate) held: HeldColumns,
    /// Every free joint of the fit's configurations.
    pub(crate) free: &'a [usize],
    /// Per fitted parameter, the symbols it trades with exactly ([`fitted_companions`]).
    pub(crate) only_with: Vec<Vec<String>>,
    /// Per free joint, the fit figures.
    pub(crate) joints: Vec<JointFit>,
}

/// Standard errors, correlations and fit figures of `problem` at physical parameters `p`
/// (n): J = ∂r/∂p by central differences ([`ParameterSpace::difference_steps`]), the held
/// ties made up and the plant-gain scale symmetry projected out ([`GainScaleContext`];
/// `tie_columns` gives ∂r/∂h of named held values), then [`covariance_statistics`].
///
/// # Errors
/// The covariance cannot be formed.
pub(crate) fn statistics_at(
    problem: &dyn Residuals,
    p: &[f64],
    at: AtTheFit,
    tie_columns: impl Fn(&[String]) -> Vec<Vec<f64>>,
) -> Result<Statistics> {
    let space = problem.space();
    let dof = at.r.len() as f64 / (at.r.len() - p.len()) as f64;
    let sigma: Vec<f64> = at.variances.iter().map(|v| v * dof).collect();
    // Central differences here (O(h²)): in a sensitive trajectory a one-sided difference
    // blurs exact symmetries of the model into seemingly determined directions.
    let steps = space.difference_steps(p);
    let mut cols = problem.jacobian_columns(&Stencil {
        x: p,
        r0: at.r,
        steps: &steps,
        p_of: &|x: &[f64]| x.to_vec(),
        central: true,
    });
    let scale = GainScaleContext {
        plant: space.plant,
        names: space.names,
        bounds: (space.lower, space.upper),
        free: at.free,
        held_ties: space.held_ties,
    };
    // A column the data do not see — its change over the parameter's bounds below
    // EXACT_SYMMETRY of the best-seen column's — is zero: whatever it holds is rounding
    // (an exact sensitivity: k1 of the Freedom 6S, Fs_q5 with vs_q5 → 0, 2e-16 of the
    // largest) or a difference quotient's noise (1e-12), and normalised to unit length it
    // would pass for a direction of its own and swamp the relative changes that tell
    // which parameters a null direction moves ([`moved_by_null_directions`]).
    let seen: Vec<f64> = cols
        .iter()
        .zip(space.lower.iter().zip(space.upper))
        .map(|(c, (lo, hi))| c.iter().map(|x| x * x).sum::<f64>().sqrt() * (hi - lo))
        .collect();
    let best = seen
        .iter()
        .cloned()
        .filter(|s| s.is_finite())
        .fold(0.0, f64::max);
    for (c, s) in cols.iter_mut().zip(&seen) {
        if *s < EXACT_SYMMETRY * best {
            c.fill(0.0);
        }
    }
    let mut held = at.held;
    let information = {
        // The held values' columns where they were simulated (one per held value).
        let held_names: &[String] = if held.cols.len() == held.names.len() {
            &held.names
        } else {
            &[]
        };
        let mut names = space.names.to_vec();
        names.extend(held_names.iter().cloned());
        let mut values = p.to_vec();
        values.extend(held_names.iter().map(|n| space.plant.parameters[n]));
        let all: Vec<Vec<f64>> = cols
            .iter()
            .chain(held.cols.iter().take(held_names.len()))
            .cloned()
            .collect();
        Information::of(names, values, &all, at.r, &sigma)
    };
    scale.make_up_held_ties(&cols, &mut held);
    // With held scale families, first the figures given their scale (what the fit
    // determines relative to it), then with it unknown.
    let given_scale = if held.scales.is_empty() {
        None
    } else {
        let mut given = cols.clone();
        scale.project_out_of(&mut given, p, &held, false, &tie_columns);
        Some(covariance_statistics(
            space.names,
            p,
            (space.lower, space.upper),
            (given, held.clone()),
            &sigma,
            at.only_with.clone(),
            at.joints.clone(),
        )?)
    };
    let held_scales: Vec<(String, Vec<String>)> = held
        .scales
        .iter()
        .map(|s| (s.family.clone(), s.names.clone()))
        .collect();
    let scales_known = project_out_held_scales(&mut cols, &mut held);
    scale.project_out_of(&mut cols, p, &held, true, &tie_columns);
    let mut statistics = covariance_statistics(
        space.names,
        p,
        (space.lower, space.upper),
        (cols, held),
        &sigma,
        at.only_with,
        at.joints,
    )?;
    if !scales_known {
        statistics.std_err.fill(f64::INFINITY);
        statistics.relative_std_err.fill(f64::INFINITY);
        statistics.identifiable.fill(false);
    }
    // What the sequence records and decides on is relative to the held families' scale
    // (the scale itself is their family's): the standard errors and their correlations,
    // and how well this fit sees each held value.
    match given_scale {
        Some(given) => {
            statistics.std_err_given_scale = given.std_err;
            statistics.identifiable_given_scale = given.identifiable;
            statistics.correlation_with_held = given.correlation_with_held;
            statistics.held_information = given.held_information;
        }
        None => {
            statistics.std_err_given_scale = statistics.std_err.clone();
            statistics.identifiable_given_scale = statistics.identifiable.clone();
        }
    }
    statistics.held_scales = held_scales;
    statistics.information = Some(information);
    Ok(statistics)
}

/// Standard errors, correlations and identifiability of parameters `names` at physical
/// values `p` within `(lower, upper)`, from the Jacobian `cols` (∂r/∂p, one column per
/// parameter) with the `held` values' columns, and the variance `sigma` of every residual
/// (degrees of freedom included): cov = (JᵀJ)⁻¹ Jᵀ Σ J (JᵀJ)⁻¹ on unit-norm columns, plus
/// the `held` values' share
/// G Σ_h Gᵀ, G = −(JᵀJ)⁻¹ Jᵀ J_h ([`HeldColumns`]). `only_with` (the structural ties)
/// and `joints` (the fit per joint, for the noise floor) go into the verdict and the
/// result as they are.
///
/// A held value whose column is not finite (its simulation fails where it moves) has an
/// unknown share: every `std_err` is then infinite (nothing is called identifiable), while
/// `std_err_given_held` stays this fit's own.
///
/// # Errors
/// The fitted values' Jacobian, weighted by `sigma`, is not finite.
pub(crate) fn covariance_statistics(
    names: &[String],
    p: &[f64],
    (lower, upper): (&[f64], &[f64]),
    (cols, held): (Vec<Vec<f64>>, HeldColumns),
    sigma: &[f64],
    only_with: Vec<Vec<String>>,
    joints: Vec<JointFit>,
) -> Result<Statistics> {
    let n = names.len();
    // Columns scaled to unit norm; a zero column (the parameter changes no output)
    // stays zero and gets an infinite standard error.
    let norms: Vec<f64> = cols
        .iter()
        .map(|c| c.iter().map(|x| x * x).sum::<f64>().sqrt())
        .collect();
    let cols: Vec<Vec<f64>> = cols
        .iter()
        .zip(&norms)
        .map(|(c, &nrm)| {
            if nrm > 0.0 && nrm.is_finite() {
                c.iter().map(|x| x / nrm).collect()
            } else {
                vec![0.0; c.len()]
            }
        })
        .collect();
    let (a, b) = sandwich_parts(&cols, n, sigma);
    if !(a.iter().all(|x| x.is_finite()) && b.iter().all(|x| x.is_finite())) {
        bail!("the Jacobian at the fitted values is not finite");
    }
    let svd = crate::util::svd(a.clone()).ok_or_else(|| {
        anyhow::anyhow!(
            "the Jacobian at the fitted values: the singular value decomposition did not converge"
        )
    })?;
    let smax = svd.singular_values.max();
    let condition = smax / svd.singular_values.min().max(1e-300);
    // Directions the data do not see (below EXACT_SYMMETRY of the largest singular value)
    // are not determined: truncated, and the parameters along them reported with infinite
    // error. An exact symmetry of the model shows there at the finite-difference Jacobian's
    // accuracy, not at rounding (k1 of the Freedom 6S: the plant-gain scale family at
    // 3.5e-11, the next direction the data see at 2.3e-6). Anything above is inverted, so
    // a near-symmetry shows as large errors and correlations.
    let cutoff = smax * EXACT_SYMMETRY;
    let ainv = svd
        .clone()
        .pseudo_inverse(cutoff)
        .unwrap_or_else(|_| DMatrix::from_element(n, n, f64::NAN));
    let undetermined = match &svd.v_t {
        Some(v_t) => moved_by_null_directions(v_t, &svd.singular_values, cutoff, |i| {
            (norms[i] > 0.0).then(|| norms[i] * p[i].abs().max(1e-3 * (upper[i] - lower[i])))
        }),
        None => vec![false; n],
    };
    // A zero column is undetermined on its own (its covariance is rounding).
    let undetermined: Vec<bool> = (0..n).map(|i| undetermined[i] || norms[i] <= 0.0).collect();
    // Symmetric to rounding: the pseudo-inverse's 1/sv near the cut-off makes the two
    // halves differ.
    let given_held = &ainv * b * &ainv;
    let given_held = (&given_held + given_held.transpose()) * 0.5;
    // The held values' share G Σ_h Gᵀ: column k of G (scaled parameters per unit of held
    // value k) is −A⁺ J̃ᵀ J_h,k; Σ_h = D R D.
    let mut cov_scaled = given_held.clone();
    let mut g_columns = Vec::with_capacity(held.cols.len());
    // A held value whose column is not finite (a simulation fails where it moves): its
    // share is unknown, and so is every total standard error.
    let mut unknown_share = false;
    for (k, (col, se)) in held.cols.iter().zip(&held.std_err).enumerate() {
        let g = match held.make_up.get(k).and_then(|d| d.as_ref()) {
            // Scaled parameter i is p_i times its column's norm.
            Some(d) => {
                nalgebra::DVector::from_iterator(n, d.iter().zip(&norms).map(|(d, nrm)| d * nrm))
            }
            None => {
                let t = nalgebra::DVector::from_iterator(
                    n,
                    cols.iter()
                        .map(|c| c.iter().zip(col).map(|(a, b)| a * b).sum::<f64>()),
                );
                -(&ainv * t)
            }
        };
        let g = g * *se;
        if !g.iter().all(|x| x.is_finite()) {
            unknown_share = true;
            g_columns.push(nalgebra::DVector::zeros(n));
            continue;
        }
        cov_scaled += &g * g.transpose();
        g_columns.push(g);
    }
    for &(k, l, r) in &held.correlation {
        if let (Some(gk), Some(gl)) = (g_columns.get(k), g_columns.get(l)) {
            // Both orders of the pair: ρ (g_k σ_k)(g_l σ_l)ᵀ + its transpose.
            let cross = gk * gl.transpose() * r;
            cov_scaled += &cross + cross.transpose();
        }
    }
    let standard_error = |cov: &DMatrix<f64>, i: usize| {
        if norms[i] > 0.0 && !undetermined[i] && cov[(i, i)].is_finite() {
            cov[(i, i)].max(0.0).sqrt() / norms[i]
        } else {
            f64::INFINITY
        }
    };
    let std_err: Vec<f64> = (0..n)
        .map(|i| {
            if unknown_share {
                f64::INFINITY
            } else {
                standard_error(&cov_scaled, i)
            }
        })
        .collect();
    let std_err_given_held: Vec<f64> = (0..n).map(|i| standard_error(&given_held, i)).collect();
    let held_information = held_information(&cols, &held, sigma);
    let mut correlation = vec![vec![0.0; n]; n];
    // An undetermined parameter's covariance is rounding amplified by the pseudo-inverse
    // (k1 of the Freedom 6S: Fs_q5 with vs_q5 → 0 showed "correlation −1" with the
    // well-determined qeq_q5 one way and none the other): it has no correlation.
    let correlation_of = |cov: &DMatrix<f64>, i: usize, j: usize| {
        let d = (cov[(i, i)] * cov[(j, j)]).sqrt();
        if i == j {
            1.0
        } else if undetermined[i] || undetermined[j] {
            0.0
        } else if d > 0.0 && d.is_finite() {
            (cov[(i, j)] / d).clamp(-1.0, 1.0)
        } else {
            0.0
        }
    };
    let correlation_with_held: Vec<Vec<f64>> = (0..n)
        .map(|i| (0..n).map(|j| correlation_of(&cov_scaled, i, j)).collect())
        .collect();
    let mut correlated = Vec::new();
    for i in 0..n {
        for j in 0..n {
            correlation[i][j] = correlation_of(&given_held, i, j);
            if j > i && correlation[i][j].abs() > CORRELATION_LIMIT {
                correlated.push((names[i].clone(), names[j].clone(), correlation[i][j]));
            }
        }
    }
    let at_bound: Vec<bool> = (0..n)
        .map(|i| {
            let w = upper[i] - lower[i];
            (p[i] - lower[i]).abs() < 1e-4 * w || (upper[i] - p[i]).abs() < 1e-4 * w
        })
        .collect();
    let relative: Vec<f64> = (0..n)
        .map(|i| std_err[i] / p[i].abs().max(1e-300))
        .collect();
    let above_floor: Vec<String> = joints
        .iter()
        .filter_map(|j| {
            j.floor_ratio()
                .filter(|&r| r > FLOOR_FACTOR)
                .map(|r| format!("{} RMS {r:.3} σ̂", j.joint))
        })
        .collect();
    let identifiable: Vec<bool> = (0..n)
        .map(|i| {
            above_floor.is_empty()
                && relative[i].is_finite()
                && relative[i] <= RELATIVE_STD_LIMIT
                && !at_bound[i]
                && only_with[i].is_empty()
                && (0..n).all(|j| j == i || correlation[i][j].abs() <= CORRELATION_LIMIT)
        })
        .collect();
    Ok(Statistics {
        std_err,
        std_err_given_held,
        held: held_share(&held, false),
        held_ties: held_share(&held, true),
        held_information,
        held_exact: held.exact,
        held_scales: Vec::new(),
        std_err_given_scale: Vec::new(),
        identifiable_given_scale: Vec::new(),
        relative_std_err: relative,
        correlation,
        correlation_with_held,
        correlated,
        at_bound,
        identifiable,
        only_with,
        above_floor,
        other_minima: Vec::new(),
        condition,
        joints,
        information: None,
    })
}

impl JointFit {
    /// RMS position error over the samples the cost weighs in units of the joint's noise σ̂
    /// (`rms_fitted / noise`): 1 at the noise floor, above [`FLOOR_FACTOR`] above it. None
    /// when the files give no noise estimate (σ̂ = 0: noise-free or quantised-only data),
    /// where the floor cannot be judged; every report and test of the floor uses this one
    /// ratio.
    pub fn floor_ratio(&self) -> Option<f64> {
        (self.noise > 0.0).then(|| self.rms_fitted / self.noise)
    }

    /// `rms / noise` over all samples (MATLAB `compare`'s RMS), None as
    /// [`JointFit::floor_ratio`].
    pub fn rms_ratio(&self) -> Option<f64> {
        (self.noise > 0.0).then(|| self.rms / self.noise)
    }
}

impl Statistics {
    /// Compare the kept minimum `p` (physical values of `names`) with other starts' minima
    /// `others`: (start, objective difference ≥ 0 to the kept one, physical values). Those
    /// within Δχ² = [`EQUAL_MINIMUM_CHI2`] (difference / `s_bar2`, s̄² from
    /// [`Problem::noise_residual_rms`]) are kept in `other_minima` with the parameters that
    /// lie more than [`EQUAL_MINIMUM_STD_ERRORS`] standard errors (`std_err`, relative to
    /// any held scale family's scale: [`Statistics::std_err_given_scale`]) away there, and
    /// those parameters are no longer called identifiable.
    pub fn mark_other_minima(
        &mut self,
        names: &[String],
        p: &[f64],
        others: &[(usize, f64, Vec<f64>)],
        s_bar2: f64,
    ) {
        if !(s_bar2 > 0.0 && s_bar2.is_finite()) {
            return;
        }
        for (start, difference, q) in others {
            let chi2 = difference.max(0.0) / s_bar2;
            if !difference.is_finite() || chi2 > EQUAL_MINIMUM_CHI2 {
                continue;
            }
            let mut moved = Vec::new();
            for i in 0..names.len() {
                // In standard errors relative to any held scale family's scale (a value
                // known only relative to it has an infinite one, and moves along it too).
                let distance = (q[i] - p[i]).abs() / self.std_err_given_scale(i);
                if distance > EQUAL_MINIMUM_STD_ERRORS {
                    self.identifiable[i] = false;
                    if let Some(x) = self.identifiable_given_scale.get_mut(i) {
                        *x = false;
                    }
                    moved.push((names[i].clone(), q[i], distance));
                }
            }
            self.other_minima.push(OtherMinimum {
                start: *start,
                objective_difference: difference.max(0.0),
                chi2_difference: chi2,
                moved,
            });
        }
    }

    /// Whether parameter `i` is identifiable relative to the held scale families' scale
    /// (`identifiable_given_scale`; `identifiable` in a report without it).
    pub fn identifiable_given_scale(&self, i: usize) -> bool {
        self.identifiable_given_scale
            .get(i)
            .or(self.identifiable.get(i))
            .copied()
            .unwrap_or(false)
    }

    /// The standard error of parameter `i` relative to the held scale families' scale
    /// ([`Statistics::std_errs_given_scale`]).
    pub fn std_err_given_scale(&self, i: usize) -> f64 {
        self.std_errs_given_scale()
            .get(i)
            .copied()
            .unwrap_or(f64::INFINITY)
    }

    /// Every parameter's standard error relative to the held scale families' scale
    /// (`std_err_given_scale`; `std_err` in a report without it).
    pub fn std_errs_given_scale(&self) -> &[f64] {
        if self.std_err_given_scale.is_empty() {
            &self.std_err
        } else {
            &self.std_err_given_scale
        }
    }

    /// The largest distance (SI) of parameter `i`, named `name`, between the kept minimum
    /// and the equally good minima of [`Statistics::other_minima`] (the distance in
    /// standard errors those record, times [`Statistics::std_err_given_scale`]); 0 without
    /// them.
    pub fn other_minima_spread(&self, i: usize, name: &str) -> f64 {
        self.other_minima
            .iter()
            .flat_map(|o| &o.moved)
            .filter(|(n, _, _)| n == name)
            .map(|(_, _, d)| d * self.std_err_given_scale(i))
            .fold(0.0, f64::max)
    }
}

/// Σ_k x_k y_k and Σ_k x_k y_k σ_k: one element of JᵀJ and of JᵀΣJ.
fn products(x: &[f64], y: &[f64], sigma: &[f64]) -> (f64, f64) {
    x.iter()
        .zip(y)
        .zip(sigma)
        .fold((0.0, 0.0), |(s, t), ((a, b), v)| (s + a * b, t + a * b * v))
}

/// JᵀJ and JᵀΣJ of the columns `cols` (Σ = diag(`sigma`)), in the top-left corner of
/// `size` × `size` matrices (the rest zero, for columns appended later).
fn sandwich_parts(cols: &[Vec<f64>], size: usize, sigma: &[f64]) -> (DMatrix<f64>, DMatrix<f64>) {
    let n = cols.len();
    let mut a = DMatrix::zeros(size, size);
    let mut b = DMatrix::zeros(size, size);
    for i in 0..n {
        for j in i..n {
            let (s, t) = products(&cols[i], &cols[j], sigma);
            a[(i, j)] = s;
            a[(j, i)] = s;
            b[(i, j)] = t;
            b[(j, i)] = t;
        }
    }
    (a, b)
}

/// [`Statistics::held_information`]: per held value with a recorded standard error σ_h (not
/// a tie), σ_h² / var_h, var_h the variance the same sandwich covariance as the fit's own
/// (unit-norm columns `cols`, residual variances `sigma`) gives the value fitted with the
/// others: the fitted columns with the held one appended. 0 where appending it adds a
/// direction the data do not see (then this step cannot determine it at all); directions
/// the fitted parameters alone leave unseen are truncated as in the covariance.
fn held_information(cols: &[Vec<f64>], held: &HeldColumns, sigma: &[f64]) -> Vec<(String, f64)> {
    let n = cols.len();
    let (a, b) = sandwich_parts(cols, n + 1, sigma);
    // Directions the fitted parameters' data do not see (an exact symmetry among them, such
    // as k4's ties through held symbols): the held value is undetermined only if appending
    // it adds one.
    let unseen_directions = |a: &DMatrix<f64>| {
        let Some(sv) = crate::util::singular_values(a) else {
            return usize::MAX;
        };
        let cutoff = sv.max() * EXACT_SYMMETRY;
        sv.iter().filter(|&&x| x <= cutoff).count()
    };
    let fitted_unseen = unseen_directions(&a.view((0, 0), (n, n)).into_owned());
    held.names
        .iter()
        .enumerate()
        .filter(|&(k, _)| !held.tie.get(k).copied().unwrap_or(false))
        .filter_map(|(k, name)| {
            let col = held.cols.get(k)?;
            let norm = col.iter().map(|x| x * x).sum::<f64>().sqrt();
            if !(norm > 0.0 && norm.is_finite()) {
                return Some((name.clone(), 0.0));
            }
            let h: Vec<f64> = col.iter().map(|x| x / norm).collect();
            let (mut a, mut b) = (a.clone(), b.clone());
            for i in 0..=n {
                let (s, t) = products(if i < n { &cols[i] } else { &h }, &h, sigma);
                a[(i, n)] = s;
                a[(n, i)] = s;
                b[(i, n)] = t;
                b[(n, i)] = t;
            }
            // The held value moves along a direction the data do not see: not determined.
            if unseen_directions(&a) > fitted_unseen {
                return Some((name.clone(), 0.0));
            }
            let svd = crate::util::svd(a)?;
            let cutoff = svd.singular_values.max() * EXACT_SYMMETRY;
            let ainv = svd.pseudo_inverse(cutoff).ok()?;
            let var = (&ainv * b * &ainv)[(n, n)] / (norm * norm);
            let se = held.std_err[k];
            Some((name.clone(), if var > 0.0 { se * se / var } else { 0.0 }))
        })
        .collect()
}

/// One finite-difference column ∂r/∂x_i of residuals `at(s)` (at x_i + s): central
/// where `central` and both sides simulate, else forward from `r0` (the residuals at x),
/// retried with the opposite step; zero where neither side simulates.
pub(crate) fn difference_column(
    at: &dyn Fn(f64) -> Result<Vec<f64>, TrialFailure>,
    r0: &[f64],
    step: f64,
    central: bool,
) -> Vec<f64> {
    if central {
        if let (Ok(rp), Ok(rm)) = (at(step), at(-step)) {
            return rp
                .iter()
                .zip(&rm)
                .map(|(a, b)| (a - b) / (2.0 * step))
                .collect();
        }
    }
    for s in [step, -step] {
        if let Ok(ri) = at(s) {
            return ri.iter().zip(r0).map(|(a, b)| (a - b) / s).collect();
        }
    }
    vec![0.0; r0.len()]
}

/// For every fitted parameter of `names` (bounds `(lower, upper)`), the other rigid-body
/// symbols — fitted, or `held` along ties ([`Problem::with_held_ties`]) — it trades with
/// exactly in every configuration of `places` with its locked joints where its files hold
/// them ([`structural_companions_across`](crate::identify::identifiability::structural_companions_across)):
/// the ties the data can see, which are more than those of a configuration anywhere (the
/// spanning symbols, [`crate::identify::identifiability::spanning_symbols`], are chosen there too).
/// Scales: a fitted symbol's bound width; a held one's bound width, else its magnitude, else 1.
///
/// # Errors
/// The plant's barycentric parameters cannot be formed.
pub(crate) fn fitted_companions(
    plant: &Plant,
    names: &[String],
    (lower, upper): (&[f64], &[f64]),
    held: &[String],
    places: &[(&Configuration, &[Vec<f64>])],
) -> Result<Vec<Vec<String>>> {
    let n = names.len();
    let all: Vec<String> = names.iter().chain(held).cloned().collect();
    let width = |i: usize| {
        if i < n {
            return upper[i] - lower[i];
        }
        held_scale(plant, &all[i])
    };
    let mut out = crate::identify::identifiability::structural_companions_across(
        plant, places, &all, &width,
    )?;
    out.truncate(n);
    Ok(out)
}

#[cfg(test)]
#[path = "statistics_tests.rs"]
mod tests;
