//! The problems of a fit's warm-up stages, derived from the whole files' [`Problem`]: the
//! growing horizons (the first samples of every file), multiple-shooting segments, the
//! equation error, the prediction-error homotopy and its coarse-step check.

use super::*;

impl Problem {
    /// The same problem on the first samples of every file: the skipped transient plus
    /// `fraction` of the weighted samples.
    pub(super) fn truncated(&self, fraction: f64) -> Problem {
        let mut records = Vec::with_capacity(self.records.len());
        let mut sqrt_w = Vec::with_capacity(self.records.len());
        for (r, w) in self.records.iter().zip(&self.sqrt_w) {
            let first = w.iter().position(|&x| x > 0.0).unwrap_or(0);
            let n = r.t.len();
            let keep =
                (first + ((n - first) as f64 * fraction).ceil() as usize).clamp(first + 2, n);
            let mut rr = r.clone();
            rr.t.truncate(keep);
            for c in rr.tau.iter_mut().chain(rr.q.iter_mut()) {
                c.truncate(keep);
            }
            records.push(rr);
            sqrt_w.push(w[..keep].to_vec());
        }
        self.with_records(records, sqrt_w)
    }

    /// The same problem (parameters, bounds, weights λ, options) on other `records` with
    /// sample weights `sqrt_w` (√w per record and sample); this problem's records are not
    /// copied.
    pub(super) fn with_records(&self, records: Vec<Record>, sqrt_w: Vec<Vec<f64>>) -> Problem {
        Problem {
            plant: self.plant.clone(),
            conf: self.conf,
            names: self.names.clone(),
            lower: self.lower.clone(),
            upper: self.upper.clone(),
            pairs: self.pairs.clone(),
            m: residual_total(&sqrt_w, self.lambda.len()),
            records,
            lambda: self.lambda.clone(),
            sqrt_w,
            noise: self.noise.clone(),
            prior: self.prior.clone(),
            earlier: self.earlier.clone(),
            information_prior: self.information_prior.clone(),
            equation_error: None,
            predictor: self.predictor,
            held_ties: self.held_ties.clone(),
            released: self.released.clone(),
            guarded_links: self.guarded_links.clone(),
            options: self.options.clone(),
        }
    }

    /// The same problem with the rigid-body symbols `names` (not fitted, held at the
    /// plant's values) counted by the structural check of [`Problem::statistics`]: a
    /// fitted symbol that trades exactly with one of them is determined only given the
    /// held value, so it is not called identifiable and its `only_with` names the held
    /// symbol. Set by `--rigid-body spanning` (`super::sequence::RigidBodyFit`).
    pub fn with_held_ties(mut self, names: Vec<String>) -> Problem {
        self.held_ties = names;
        self
    }

    /// The same parameters, bounds and Fs ≥ Fc on the equation error of the whole files
    /// ([`EquationError`], position filter cut-off `cutoff`):
    /// its residuals are torque balances, not position errors, so it has no prior (the
    /// prior's weight is set by the position noise) and serves only as a warm start. The
    /// carried symbols — those an earlier step of the plant's sequence left undetermined
    /// ([`Plant::undetermined`]), with or without the carried prior
    /// ([`OutputErrorOptions::carried_prior`]) — stay at their values there: the torque
    /// balance moved them hundreds of the earlier step's standard errors (k4 of the
    /// Freedom 6S), a start the first predictor stage then began 100 times above its end;
    /// k3 with link 7's m7 and z7 carried from k2 went from 6.36e5 to 5.55e5 there, its
    /// predictor stages ended where RK4 diverged, and the step stopped at 2.48e4 with
    /// link 3 impossible.
    ///
    /// # Errors
    /// A file too short for the filter, or a cut-off outside (0, 1).
    pub fn equation_error_stage(&self, cutoff: Cutoff) -> Result<Problem> {
        let ee = EquationError::new(&self.plant, self.conf, &self.records, cutoff)?;
        let mut problem = self.with_records(self.records.clone(), self.sqrt_w.clone());
        problem.m = ee.len();
        problem.prior = None;
        problem.information_prior = None;
        problem.equation_error = Some(std::sync::Arc::new(ee));
        Ok(problem)
    }

    /// The parameters this stage holds at their start (the optimiser does not vary them):
    /// in the equation-error stage, the carried symbols ([`Problem::equation_error_stage`]);
    /// none elsewhere.
    pub fn frozen(&self) -> Vec<String> {
        self.names
            .iter()
            .filter(|n| self.is_frozen(n))
            .cloned()
            .collect()
    }

    /// Whether this stage holds parameter `name` at its start ([`Problem::frozen`]).
    pub(super) fn is_frozen(&self, name: &str) -> bool {
        self.equation_error.is_some() && self.plant.undetermined.iter().any(|n| n == name)
    }

    /// For the equation-error stage, the position filter's cut-off per free joint
    /// (" (filter cut-offs q3 0.7, q5 0.6 of the Nyquist frequency)"); empty otherwise.
    pub(super) fn equation_error_note(&self) -> String {
        let Some(ee) = &self.equation_error else {
            return String::new();
        };
        let each: Vec<String> = self
            .conf
            .free
            .iter()
            .zip(ee.cutoffs())
            .map(|(&j, c)| format!("{} {c}", self.plant.model.joints[j]))
            .collect();
        format!(
            " (filter cut-offs {} of the Nyquist frequency)",
            each.join(", ")
        )
    }

    /// The same problem as multiple shooting: every file cut into segments of `seconds`
    /// (at least 4 samples; a shorter rest joins the last segment), each simulated from the
    /// measured state at its start: positions as measured, velocities by the 7-point cubic
    /// Savitzky–Golay derivative of the measured positions, LuGre bristles in steady
    /// sliding; the first segment keeps the file's own start. Every sample has weight 1
    /// except each segment's first (its initial condition); joint weights λ are kept.
    ///
    /// A long output-error horizon of a sensitive trajectory (a light wrist joint swinging
    /// through several turns) has local minima far from the truth; short segments have
    /// fewer, and together they still use every sample for the cost of one simulation per
    /// file. The start states are estimates — the velocity's noise is ≈ 0.5 σ/Δt, but a
    /// joint with fast content between samples is worse (joint 4 of the Freedom 6S under
    /// Table 4.7: errors up to 4 rad/s), and the bristle deflection is not measured — so at
    /// the true parameters the segments do not reach the noise floor (joint 3 alone,
    /// Table 4.3: 1.1e-2 rad RMS with 1 s segments, 6.9e-3 rad with 4 s): the segment fit is
    /// a warm start for the fit of the whole files, never the result.
    pub fn segmented(&self, seconds: f64) -> Problem {
        let mut records = Vec::new();
        let mut sqrt_w = Vec::new();
        for r in &self.records {
            let n = r.t.len();
            let len = ((seconds / r.dt).round() as usize).max(4);
            let mut starts: Vec<usize> = (0..n).step_by(len).collect();
            if starts.len() > 1 && n - starts[starts.len() - 1] < 4 {
                starts.pop();
            }
            for (i, &k0) in starts.iter().enumerate() {
                let k1 = starts.get(i + 1).copied().unwrap_or(n);
                let mut seg = Record {
                    file: r.file.clone(),
                    t: r.t[k0..k1].to_vec(),
                    dt: r.dt,
                    tau: r.tau.iter().map(|c| c[k0..k1].to_vec()).collect(),
                    q: r.q.iter().map(|c| c[k0..k1].to_vec()).collect(),
                    q_all: r.q_all.clone(),
                    qd0: r.qd0.clone(),
                    hold: r.hold,
                };
                if k0 > 0 {
                    for (a, &j) in self.conf.free.iter().enumerate() {
                        seg.q_all[j] = r.q[a][k0];
                    }
                    seg.qd0 = Some(
                        r.q.iter()
                            .map(|c| savitzky_golay_velocity(c, k0, r.dt))
                            .collect(),
                    );
                }
                let mut w = vec![1.0; k1 - k0];
                w[0] = 0.0;
                records.push(seg);
                sqrt_w.push(w);
            }
        }
        self.with_records(records, sqrt_w)
    }

    /// The same problem on the predictor's errors: every file simulated with the state pulled
    /// toward its measured positions by a critically damped output injection of bandwidth
    /// `omega` (rad/s, [`crate::simulation::PlantModel::predict_at`]). Below ω the residual is a
    /// low-passed equation error, so drift and the long memory of friction (where a joint
    /// sticks decides every later position) no longer make the cost rugged; `omega` → 0 is
    /// the output error. A sequence of decreasing ω is a homotopy from the one to the other.
    /// For ω > 0 the step and integrator are [`OutputErrorOptions::predictor_step`]'s when
    /// set.
    pub fn predictor(&self, omega: f64) -> Problem {
        let mut p = self.clone();
        p.predictor = (omega > 0.0).then_some(omega);
        if let (true, Some((h, integrator))) = (omega > 0.0, self.options.predictor_step) {
            p.options.h = h;
            p.options.integrator = integrator;
        }
        p
    }

    /// The predictor's stage at `omega` (rad/s) for a start at scaled parameters `u`, with a
    /// note for the report. With [`OutputErrorOptions::predictor_step`] set, the coarse step
    /// serves the stage only where it is checked to: at `u` the coarse and the user's step
    /// must predict the same positions within [`COARSE_PREDICTOR_AGREEMENT`] × σ̂ on every
    /// free joint (root mean square over the weighted samples, σ̂ the joint's noise). The output
    /// injection's damping of an early error weakens as ω falls: on the 40 s k3 file of the
    /// Freedom 6S, ETDRK4 at 1/2000 s is within 0.09 σ̂ at every ω down to 1 rad/s, at
    /// 1/1000 s 0.32 σ̂ at 3 and 1.5 σ̂ at 1 rad/s, at 1/500 s 0.15 σ̂ at 100 rad/s but
    /// 0.79 at 30 and 84 at 1 rad/s, where a fit would hand the whole files a point the
    /// accurate simulation does not share. A stage that fails the check runs on the user's
    /// step.
    pub(super) fn checked_predictor(&self, omega: f64, u: &[f64]) -> (Problem, String) {
        let Some((h, integrator)) = self.options.predictor_step.filter(|_| omega > 0.0) else {
            return (self.predictor(omega), String::new());
        };
        let coarse = format!("{} at {h:.4e} s", integrator.to_string().to_uppercase());
        match self.coarse_step_disagreement(omega, &self.to_physical(u)) {
            Ok(d) if d <= COARSE_PREDICTOR_AGREEMENT => (
                self.predictor(omega),
                format!(" ({coarse}: within {d:.1e} σ̂ of the user's step)"),
            ),
            Ok(d) => (
                self.predictor_on_user_step(omega),
                format!(" (on the user's step: {coarse} off by {d:.1e} σ̂)"),
            ),
            Err(why) => (
                self.predictor_on_user_step(omega),
                format!(" (on the user's step: {coarse} not checked: {})", why),
            ),
        }
    }

    /// [`Problem::predictor`] on the user's step whatever
    /// [`OutputErrorOptions::predictor_step`] says.
    pub(super) fn predictor_on_user_step(&self, omega: f64) -> Problem {
        let mut p = self.clone();
        p.options.predictor_step = None;
        p.predictor(omega)
    }

    /// How far the positions predicted at bandwidth `omega` (rad/s) on
    /// [`OutputErrorOptions::predictor_step`] lie from those on the user's step
    /// ([`OutputErrorOptions::h`], [`OutputErrorOptions::integrator`]) at physical parameters
    /// `p`: per free joint the root mean square of the difference over the weighted samples
    /// of every file, over that joint's noise σ̂; the largest over the joints (dimensionless;
    /// 1 = as far as the noise). Per joint, as the noise floor is judged, so a wrist joint's
    /// difference is not discounted by the joint of interest's weight. `Ok(None)` without a
    /// predictor step or at `omega` = 0. Errors: either simulation fails.
    pub fn predictor_step_disagreement(
        &self,
        omega: f64,
        p: &[f64],
    ) -> Result<Option<f64>, TrialFailure> {
        if self.options.predictor_step.is_none() || omega <= 0.0 {
            return Ok(None);
        }
        self.coarse_step_disagreement(omega, p).map(Some)
    }

    /// [`Problem::predictor_step_disagreement`] where a predictor step is set and ω > 0.
    pub(super) fn coarse_step_disagreement(
        &self,
        omega: f64,
        p: &[f64],
    ) -> Result<f64, TrialFailure> {
        let coarse = self.predictor(omega).trajectories(p)?;
        let fine = self.predictor_on_user_step(omega).trajectories(p)?;
        let mut worst: f64 = 0.0;
        for (a, sigma) in self.noise.iter().enumerate() {
            let (mut squares, mut n) = (0.0, 0usize);
            for ((c, f), w) in coarse.iter().zip(&fine).zip(&self.sqrt_w) {
                for (k, _) in w.iter().enumerate().filter(|(_, &x)| x > 0.0) {
                    squares += (c.q[a][k] - f.q[a][k]).powi(2);
                    n += 1;
                }
            }
            worst = worst.max((squares / n.max(1) as f64).sqrt() / sigma);
        }
        Ok(worst)
    }
}
