//! The exponential integrator ([`Integrator::Etdrk4`]): ETDRK4 (Cox & Matthews 2002) on
//! the velocity block's linear part (the friction damping, frozen per step and taken again
//! where the friction switches regime within the step), with the φ functions by series
//! near zero and by their closed forms elsewhere ([`phi1234`]).

use super::*;

/// φ1(x) … φ4(x) of exponential integrators: φ_k(x) = Σ_j x^j / (j + k)!, i.e.
/// φ1 = (eˣ − 1)/x and φ_{k+1} = (φ_k − 1/k!)/x; by the series (13 terms of φ4, then that
/// recurrence upward) where |x| < 1/2, where the closed forms cancel.
pub fn phi1234(x: f64) -> [f64; 4] {
    if x.abs() < 0.5 {
        // Horner on φ4 = Σ x^j/(j+4)!, then φ_k = 1/k! + x φ_{k+1}.
        let mut p4 = 0.0;
        let mut fact: f64 = (1..=16).map(|k| k as f64).product(); // (12 + 4)!
        for j in (0..=12).rev() {
            p4 = p4 * x + 1.0 / fact;
            fact /= (j + 4) as f64;
        }
        let p3 = 1.0 / 6.0 + x * p4;
        let p2 = 0.5 + x * p3;
        [1.0 + x * p2, p2, p3, p4]
    } else {
        let p1 = x.exp_m1() / x;
        let p2 = (p1 - 1.0) / x;
        let p3 = (p2 - 0.5) / x;
        [p1, p2, p3, (p3 - 1.0 / 6.0) / x]
    }
}

/// Work space of one [`Integrator::Etdrk4`] step, in the coordinates u = (q̃, ṽ, w) (3·NF)
/// where its linear part is diagonal but for each mode's position row
/// ([`PlantModel::etd_lambda`]), and the frozen velocity block that later steps reuse.
#[derive(Debug, Clone, Default)]
pub(super) struct EtdScratch {
    /// u at the step start and the stages a, b, c.
    pub(super) u: [Vec<f64>; 4],
    /// N at those four points.
    pub(super) n: [Vec<f64>; 4],
    /// ṽ = T q̇ and q̇ = T⁻¹ ṽ (NF × NF, column-major).
    pub(super) t: Vec<f64>,
    pub(super) t_inv: Vec<f64>,
    /// (E, Q, E², f1, f2, f3) per component (3·NF).
    pub(super) coef: Vec<[f64; 6]>,
    /// The same of each mode's position row on its velocity (NF).
    pub(super) cross: Vec<[f64; 6]>,
    /// Λ per component.
    pub(super) lambda: Vec<f64>,
    /// g_i = ∂ż_i/∂q̇_i of the deflection coordinates w_i = z_i − g_i q_i (NF).
    pub(super) g: Vec<f64>,
    /// Friction slopes c_i = ∂F_i/∂q̇_i at the current state (NF).
    pub(super) c: Vec<f64>,
    /// The inertia matrix D_FF at the current state (NF·NF, column-major).
    pub(super) mass: Vec<f64>,
    /// The velocity block in force: the slopes and inertia matrix it was decomposed at,
    /// its modal rates μ (uncapped), (D⁻¹)_ii, and the step its coefficients are for
    /// (NaN: none yet).
    pub(super) frozen_c: Vec<f64>,
    pub(super) frozen_mass: Vec<f64>,
    pub(super) mu: Vec<f64>,
    pub(super) d_inv_diag: Vec<f64>,
    pub(super) coef_h: f64,
    /// NF·NF scratch of [`EtdScratch::velocity_block_is_stale`].
    pub(super) work: Vec<f64>,
}

/// Largest change of the frozen velocity block that [`Integrator::Etdrk4`] leaves to its
/// explicit part before decomposing again, as h ‖ΔΛ_v‖ (estimated by
/// [`EtdScratch::velocity_block_is_stale`]). ETDRK4 is fourth order for any frozen Λ; a
/// Λ off the Jacobian by ΔΛ only moves hΔΛ into the explicit stages, whose RK4 stability
/// limit is 2.78. On the Freedom 6S's 40 s Table 4.7 runs at 1/2000 s the decomposition then
/// runs on 11–15 % of the steps, and the positions move by at most 7e-10 rad (k5) from a
/// decomposition at every step.
pub(super) const REFREEZE: f64 = 0.05;

impl EtdScratch {
    /// Whether the velocity block frozen at (C_f, D_f) is off the current (C, D) by more than
    /// [`REFREEZE`] in h‖ΔΛ‖, to first order in modal coordinates: there the frozen mass
    /// matrix is I and damping −diag(μ), the current ones I + E and −diag(μ) + F with
    /// E = T⁻ᵀ (D − D_f) T⁻¹ and F = T⁻ᵀ (C − C_f) T⁻¹, so ΔΛ ≈ −F − E diag(μ); ‖F‖_F ≤
    /// Σ_i (D_f⁻¹)_ii |c_i − c_f,i| (row i of T⁻¹ has the squared norm (D_f⁻¹)_ii) and
    /// ‖E diag(μ)‖_F is formed (2 NF³ flops). Always true before the first decomposition.
    pub(super) fn velocity_block_is_stale(&mut self, h: f64) -> bool {
        let nf = self.c.len();
        let r_c: f64 = self
            .c
            .iter()
            .zip(&self.frozen_c)
            .zip(&self.d_inv_diag)
            .map(|((c, f), d)| d * (c - f).abs())
            .sum();
        // NaN before the first decomposition (frozen slopes NaN).
        if r_c.is_nan() || h * r_c > REFREEZE {
            return true;
        }
        // work = (D − D_f) T⁻¹, then ‖T⁻ᵀ work diag(μ)‖_F.
        for j in 0..nf {
            for i in 0..nf {
                self.work[j * nf + i] = (0..nf)
                    .map(|k| {
                        (self.mass[k * nf + i] - self.frozen_mass[k * nf + i])
                            * self.t_inv[j * nf + k]
                    })
                    .sum();
            }
        }
        let mut r_d = 0.0;
        for j in 0..nf {
            for i in 0..nf {
                let e_ij: f64 = (0..nf)
                    .map(|k| self.t_inv[i * nf + k] * self.work[j * nf + k])
                    .sum();
                r_d += (e_ij * self.mu[j]).powi(2);
            }
        }
        r_d.is_nan() || h * (r_c + r_d.sqrt()) > REFREEZE
    }

    /// Freeze the velocity block at the current (C, D): D = L Lᵀ, B = −L⁻¹ C L⁻ᵀ = V diag(μ)
    /// Vᵀ, T = Vᵀ Lᵀ, T⁻¹ = L⁻ᵀ V ([`PlantModel::etd_lambda`]); where D is not positive
    /// definite, T = I and μ = 0 for this step only (the frozen slopes are set to NaN, so
    /// the next step decomposes again, as it did before the block was reused).
    pub(super) fn decompose(&mut self, nf: usize) {
        self.frozen_c.copy_from_slice(&self.c);
        self.frozen_mass.copy_from_slice(&self.mass);
        let d = nalgebra::DMatrix::from_column_slice(nf, nf, &self.mass);
        let modal = nalgebra::Cholesky::new(d).and_then(|ch| {
            let l = ch.l();
            let l_inv = l.clone().try_inverse()?;
            let c = nalgebra::DVector::from_column_slice(&self.c);
            let mut b = -(&l_inv * nalgebra::DMatrix::from_diagonal(&c) * l_inv.transpose());
            b = (&b + b.transpose()) * 0.5;
            let eig = b.symmetric_eigen();
            let t = eig.eigenvectors.transpose() * l.transpose();
            let w_back = l_inv.transpose() * &eig.eigenvectors;
            for i in 0..nf {
                self.d_inv_diag[i] = l_inv.column(i).norm_squared();
            }
            Some((eig.eigenvalues, t, w_back))
        });
        match modal {
            Some((mu, t, w_back)) => {
                self.mu.copy_from_slice(mu.as_slice());
                self.t.copy_from_slice(t.as_slice());
                self.t_inv.copy_from_slice(w_back.as_slice());
            }
            None => {
                self.frozen_c.fill(f64::NAN);
                self.d_inv_diag.fill(0.0);
                self.mu.fill(0.0);
                self.t.fill(0.0);
                self.t_inv.fill(0.0);
                for i in 0..nf {
                    self.t[i * nf + i] = 1.0;
                    self.t_inv[i * nf + i] = 1.0;
                }
            }
        }
    }

    /// The ETDRK4 coefficients (E, Q, E², f1, f2, f3) of step `h` for the components
    /// `range` of Λ, and of each mode's position row on its velocity where `range` holds
    /// velocity components ([`PlantModel::etdrk4_in_place`]).
    pub(super) fn coefficients(&mut self, range: std::ops::Range<usize>, h: f64) {
        let nf = self.g.len();
        for m in range {
            let l = self.lambda[m];
            let p = phi1234(l * h);
            let ph = phi1234(l * h / 2.0);
            self.coef[m] = [
                (l * h / 2.0).exp(),
                h / 2.0 * ph[0],
                (l * h).exp(),
                h * (p[0] - 3.0 * p[1] + 4.0 * p[2]),
                h * (p[1] - 2.0 * p[2]),
                h * (4.0 * p[2] - p[1]),
            ];
            if (nf..2 * nf).contains(&m) {
                self.cross[m - nf] = [
                    h / 2.0 * ph[0],
                    h * h / 4.0 * ph[1],
                    h * p[0],
                    h * h * (p[1] - 3.0 * p[2] + 4.0 * p[3]),
                    h * h * (p[2] - 2.0 * p[3]),
                    h * h * (4.0 * p[3] - p[2]),
                ];
            }
        }
    }
}

impl PlantModel {
    /// [`PlantModel::etdrk4_in_place`], redone in substeps where a joint's friction damping
    /// changes within the step by more than the step can follow. The LuGre law switches
    /// regime within a fraction of a millisecond: sliding into the Stribeck region its
    /// slope ∂F/∂q̇ is negative, once the velocity stops or reverses with the bristles still
    /// deflected it is σ1 (1 + σ0 |z|/g) + σ2 (2σ1 + σ2 from saturation, −5e4 s⁻¹ on the
    /// Freedom 6S's joint 4). A step whose linear part was frozen in one regime meets the
    /// other explicitly and overshoots. So after each step the slopes c_i = ∂F_i/∂q̇_i are
    /// taken again at its end; where r = h max_i (D⁻¹)_ii |c_i(end) − c_i(start)| > 1/2 the
    /// step is redone in n = ⌈2r⌉ substeps (≤ 64), each freezing its own linear part; the
    /// stage inputs of a substep are the quadratic through the step's three (exact for a
    /// zero-order hold and a linear interpolation within a step). Such switches are rare
    /// (a few per second per joint), so are the redos.
    pub(super) fn etdrk4_with_switches(&self, x: &mut State, h: f64, w: &mut Scratch) {
        let (mut x0, mut tau0, mut y0) = std::mem::take(&mut w.redo);
        x0.copy_from(x);
        self.etdrk4_in_place(x, h, w);
        let r = (0..self.nf())
            .map(|i| {
                let (c_end, ..) = self.friction_slopes(i, x, w.sides[i], (w.time[0], &w.tau[0]));
                let mut jump = (c_end - w.etd.frozen_c[i]).abs();
                let (v0, v1) = (x0.qd[i], x.qd[i]);
                if let Some(l) = &self.terms[i].lugre {
                    // The step may have passed q̇ = 0, where ∂F/∂q̇ jumps by 2σ1σ0|z|/g.
                    if (v1 - v0).abs() >= v0.abs().min(v1.abs()) {
                        let bias = self.terms[i].bias.map_or(1.0, |(f, _)| f.max(1.0));
                        jump = jump.max(2.0 * l.sigma1 * l.sigma0 * x0.z[i].abs() / l.g(v0) * bias);
                    }
                }
                w.etd.d_inv_diag[i] * jump
            })
            .fold(0.0, f64::max)
            * h;
        if r.is_finite() && r > 0.5 {
            let n = (2.0 * r).ceil().min(64.0) as usize;
            x.copy_from(&x0);
            let time0 = w.time;
            for j in 0..3 {
                tau0[j].copy_from_slice(&w.tau[j]);
                y0[j].copy_from_slice(&w.y[j]);
            }
            // The quadratic through (0, a), (1/2, b), (1, c) at s.
            let quad = |v: &[Vec<f64>; 3], i: usize, s: f64| {
                v[0][i] * (2.0 * s - 1.0) * (s - 1.0)
                    + v[1][i] * 4.0 * s * (1.0 - s)
                    + v[2][i] * s * (2.0 * s - 1.0)
            };
            for sub in 0..n {
                for (j, ds) in [0.0, 0.5, 1.0].into_iter().enumerate() {
                    let s = (sub as f64 + ds) / n as f64;
                    w.time[j] = time0[0] + s * h;
                    for i in 0..self.nf() {
                        w.tau[j][i] = quad(&tau0, i, s);
                        w.y[j][i] = quad(&y0, i, s);
                    }
                }
                self.etdrk4_in_place(x, h / n as f64, w);
            }
            w.time = time0;
            for j in 0..3 {
                w.tau[j].copy_from_slice(&tau0[j]);
                w.y[j].copy_from_slice(&y0[j]);
            }
        }
        w.redo = (x0, tau0, y0);
    }

    /// Slope ∂F_i/∂q̇_i of all friction of free joint `i` (bias factor included, Coulomb's
    /// jump left out) and of its user-defined terms (at time `t` and the commands `tau`),
    /// and ∂ż_i/∂q̇_i, ∂ż_i/∂z_i of its LuGre term (0 without one), at `x`.
    pub(super) fn friction_slopes(
        &self,
        i: usize,
        x: &State,
        below: Option<bool>,
        (time, tau): (f64, &[f64]),
    ) -> (f64, f64, f64) {
        let t = &self.terms[i];
        let (v, z) = (x.qd[i], x.z[i]);
        let mut df = t.viscous;
        if let Some(s) = &t.stribeck {
            df += stribeck_slope(s.fc, s.fs, s.vs, v) * crate::effects::sign(v);
        }
        let (mut dzv, mut dzz) = (0.0, 0.0);
        if let Some(l) = &t.lugre {
            let (dfl, a, b) = l.slopes(v, z);
            df += dfl;
            (dzv, dzz) = (a, b);
        }
        let extra: f64 = t
            .extra
            .iter()
            .map(|e| e.slope(time, &x.q, &x.qd, &x.z, tau))
            .sum();
        (df * self.bias_factor(i, x.q[i], below) + extra, dzv, dzz)
    }

    /// The friction bias factor of free joint `i` at position `q` (thesis 4.3.5):
    /// FrictionBias on the side below qeq, else 1; `below = Some(b)` fixes the side
    /// ([`PlantModel::friction_on_side`]).
    pub(super) fn bias_factor(&self, i: usize, q: f64, below: Option<bool>) -> f64 {
        match self.terms[i].bias {
            Some((factor, qeq)) if below.unwrap_or(q < qeq) => factor,
            _ => 1.0,
        }
    }

    /// The linear part Λ of [`Integrator::Etdrk4`] at `x`, in coordinates where it is
    /// diagonal, into `w.etd`: on the velocities Λ_v = −D⁻¹ C with C = diag(∂F_i/∂q̇_i) (bias
    /// included; a growing mode's μ capped at [`GROWTH_MAX`]/h) and D = D_FF(q) = L Lᵀ (Cholesky); Λ_v = L⁻ᵀ B Lᵀ with B = −L⁻¹ C L⁻ᵀ symmetric, so
    /// with B = V diag(μ) Vᵀ the modal velocities ṽ = T q̇, T = Vᵀ Lᵀ, decouple (ṽ̇ = μ ṽ + …)
    /// and q̇ = T⁻¹ ṽ, T⁻¹ = L⁻ᵀ V. The whole damping matrix is taken, not its diagonal: joint
    /// 4's damping reaches the other joints' accelerations through D⁻¹'s off-diagonal terms
    /// as strongly as its own, and leaving that explicit costs the order. On z_i: ∂ż_i/∂z_i.
    /// On q: 0. The deflections are taken as w_i = z_i − g_i q_i with g_i = ∂ż_i/∂q̇_i: ż_i
    /// follows a fast velocity transient with the gain g_i (1 while the joint sticks), w_i
    /// does not. Where D_FF(q) is not positive definite (parameters not physical) Λ_v = 0 and
    /// the velocities step as in RK4. The velocity block (T, T⁻¹, μ and its coefficients) is
    /// kept from an earlier step while it stays within [`REFREEZE`] of the current one
    /// ([`EtdScratch::velocity_block_is_stale`]); the deflections' rates are taken afresh
    /// every step.
    pub(super) fn etd_lambda(&self, x: &State, h: f64, w: &mut Scratch) {
        let nf = self.nf();
        w.put_free(self, &x.q);
        let e = &mut w.etd;
        self.mass_matrix_into(&w.q_full, (w.time[0], x, &w.tau[0]), &mut e.mass);
        for i in 0..nf {
            let (df, dzv, dzz) = self.friction_slopes(i, x, w.sides[i], (w.time[0], &w.tau[0]));
            e.c[i] = df;
            e.g[i] = dzv;
            e.lambda[2 * nf + i] = dzz.min(0.0);
        }
        let decomposed = e.velocity_block_is_stale(h);
        if decomposed {
            e.decompose(nf);
        }
        if decomposed || e.coef_h != h {
            for i in 0..nf {
                e.lambda[nf + i] = e.mu[i].min(GROWTH_MAX / h);
            }
            e.coefficients(0..2 * nf, h);
            e.coef_h = h;
        }
        e.coefficients(2 * nf..3 * nf, h);
    }

    /// ETDRK4 (Cox & Matthews 2002, (26)–(29)) on `x` with the stage torques in `w.tau`, in
    /// the coordinates u = (q̃, ṽ, w), q̃ = T q, ṽ = T q̇, w = z − g q, of
    /// [`PlantModel::etd_lambda`]:
    ///
    ///   a = E u + Q N(u),  b = E u + Q N(a),  c = E a + Q (2 N(b) − N(u)),
    ///   u⁺ = E² u + f1 N(u) + 2 f2 (N(a) + N(b)) + f3 N(c),
    ///
    /// with E = e^{Ah/2}, Q = (h/2) φ1(Ah/2), f1 = h (φ1 − 3φ2 + 4φ3), f2 = h (φ2 − 2φ3),
    /// f3 = h (4φ3 − φ2) of Ah, and N(u) = f(u) − A u. The linear part A is, per mode j, the
    /// block (q̃̇_j, ṽ̇_j) = (ṽ_j, μ_j ṽ_j) and λ_j on w_j: positions are integrated along the
    /// exact velocity flow, so a fast velocity transient leaves no position error either.
    /// Of the block, φ_k(hA) = [[1/k!, h φ_{k+1}(hμ)], [0, φ_k(hμ)]] (the divided difference
    /// of φ_k over the eigenvalues 0 and hμ). N's position rows are only the predictor's
    /// output injection. With A's μ = λ = 0 the step is classical RK4.
    pub(super) fn etdrk4_in_place(&self, x: &mut State, h: f64, w: &mut Scratch) {
        let nf = self.nf();
        self.etd_lambda(x, h, w);
        let mut e = std::mem::take(&mut w.etd);
        let mut k = std::mem::take(&mut w.k);
        let mut y = std::mem::take(&mut w.stage);
        let tau = std::mem::take(&mut w.tau);
        let time = w.time;
        // out = M v for an NF × NF column-major M.
        let mat_vec = |m: &[f64], v: &[f64], out: &mut [f64]| {
            for (i, o) in out.iter_mut().enumerate() {
                *o = (0..v.len()).map(|j| m[j * v.len() + i] * v[j]).sum();
            }
        };
        let EtdScratch {
            u,
            n,
            t,
            t_inv,
            coef,
            cross,
            lambda,
            g,
            ..
        } = &mut e;
        mat_vec(t, &x.q, &mut u[0][..nf]);
        mat_vec(t, &x.qd, &mut u[0][nf..2 * nf]);
        for i in 0..nf {
            u[0][2 * nf + i] = x.z[i] - g[i] * x.q[i];
        }
        // N at stage s of the coordinates u[j] (torques tau[s]) into n[j].
        let mut eval = |j: usize, s: usize, u: &[Vec<f64>; 4], n: &mut [Vec<f64>; 4]| {
            mat_vec(t_inv, &u[j][..nf], &mut y.q);
            mat_vec(t_inv, &u[j][nf..2 * nf], &mut y.qd);
            for i in 0..nf {
                y.z[i] = u[j][2 * nf + i] + g[i] * y.q[i];
            }
            self.derivative_into((time[s], &y, &tau[s]), &[], w, &mut k[0]);
            w.inject(&y, s, &mut k[0]);
            for i in 0..nf {
                n[j][2 * nf + i] = k[0].z[i] - g[i] * k[0].q[i];
                k[0].q[i] -= y.qd[i];
            }
            mat_vec(t, &k[0].q, &mut n[j][..nf]);
            mat_vec(t, &k[0].qd, &mut n[j][nf..2 * nf]);
            for m in nf..3 * nf {
                n[j][m] -= lambda[m] * u[j][m];
            }
        };
        // u[to] = E u[from] + Q n, with n = N(·) or 2 N(b) − N(u).
        let stage = |u: &mut [Vec<f64>; 4], to: usize, from: usize, n: &dyn Fn(usize) -> f64| {
            for m in 0..3 * nf {
                let [ee, q, ..] = coef[m];
                u[to][m] = ee * u[from][m] + q * n(m);
                if m < nf {
                    let [eqv, qqv, ..] = cross[m];
                    u[to][m] += eqv * u[from][nf + m] + qqv * n(nf + m);
                }
            }
        };
        eval(0, 0, u, n);
        stage(u, 1, 0, &|m| n[0][m]);
        eval(1, 1, u, n);
        stage(u, 2, 0, &|m| n[1][m]);
        eval(2, 1, u, n);
        stage(u, 3, 1, &|m| 2.0 * n[2][m] - n[0][m]);
        eval(3, 2, u, n);
        // u⁺ into u[1] (stage a is spent).
        let (u0, rest) = u.split_at_mut(1);
        let (u0, u_next) = (&u0[0], &mut rest[0]);
        let combine = |m: usize, [_, _, e2, f1, f2, f3]: [f64; 6]| {
            e2 * u0[m] + f1 * n[0][m] + 2.0 * f2 * (n[1][m] + n[2][m]) + f3 * n[3][m]
        };
        for m in 0..3 * nf {
            u_next[m] = combine(m, coef[m]);
            if m < nf {
                u_next[m] += combine(nf + m, cross[m]);
            }
        }
        mat_vec(t_inv, &u_next[..nf], &mut x.q);
        mat_vec(t_inv, &u_next[nf..2 * nf], &mut x.qd);
        for i in 0..nf {
            x.z[i] = u_next[2 * nf + i] + g[i] * x.q[i];
        }
        w.etd = e;
        w.k = k;
        w.stage = y;
        w.tau = tau;
    }
}
