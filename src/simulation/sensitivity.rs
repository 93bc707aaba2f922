//! Forward sensitivities of a simulation: the state x = (q_F, q̇_F, z_F) and its derivative
//! S = ∂x/∂θ with respect to the plant's values θ stepped together by the same RK4, so that S
//! is the exact derivative of the discrete simulation (internal numerical differentiation,
//! Bock 1981; Hairer, Nørsett & Wanner, *Solving ODEs I*, §II.6), the derivative that
//! finite differences of the simulated outputs approximate, at the cost of one augmented
//! simulation for every parameter at once.
//!
//! Each RK4 stage evaluates f(t, x, θ) and the stage's tangent
//! K = ∂f/∂x S_stage + ∂f/∂θ, with S_stage the tangent of the stage's state. The rigid body's
//! part comes from the generated kernels: from (D + A) q̈ = Q(x, θ) − h(q, q̇) (A the
//! armatures), with τ(q, q̇, q̈) = D q̈ + h the inverse dynamics at fixed q̈ (thesis 3.5),
//!
//! ∂q̈/∂x = (D + A)⁻¹ (∂Q/∂x − ∂τ/∂x) (`dynamics_derivatives`, one CSE body with D),
//! ∂q̈/∂p = −(D + A)⁻¹ Y_F(q, q̇, q̈) for the barycentric parameters (the regressor, τ = Y p),
//!
//! and the effects' derivatives (Q = Kp τ' − b F(q̇, z) − Ks (q − qeq) − offset, LuGre's
//! ż(q̇, z), thesis 3.3–3.9 and 4.3.5) are analytic here. A step split where a friction position
//! bias switches ([`PlantModel::rk4_with_events`]) is differentiated with its switch: the
//! switch fraction θ_s moves with the parameters by the implicit function theorem on the
//! trial step's cubic Hermite interpolant, and the two sub-steps' lengths and start times
//! carry that tangent (∂/∂h and ∂/∂t of an RK4 step, the input's rate included).
//!
//! Outputs at the sample times are the simulator's cubic Hermite (q) and linear (q̇)
//! interpolation of the step ends, so their tangents are the same combinations of S.
//!
//! Not covered (an [`SensitivityError::Unsupported`] names them; use finite differences):
//! user-defined effects, backlash, the ETDRK4 integrator.

use super::*;

/// `$body` with `$n` bound to `$nf` as a constant for 1 to 6 free joints, so that the loops
/// over the joints of the (inlined) functions it calls unroll and drop their bounds checks;
/// any other count as is. A macro, not a closure: a closure is a function of its own, which
/// would not be compiled with the AVX2 copy's target features.
macro_rules! with_nf {
    ($nf:expr, $n:ident => $body:expr) => {
        with_nf!(@arms $nf, $n, $body; 1, 2, 3, 4, 5, 6)
    };
    (@arms $nf:expr, $n:ident, $body:expr; $($k:literal),*) => {
        match $nf {
            $($k => {
                let $n = $k;
                $body
            })*
            $n => $body,
        }
    };
}

/// A value of one effect of a free joint.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EffectValue {
    /// Plant gain Kp.
    Gain,
    /// Viscous friction Fv.
    Viscous,
    /// Coulomb friction Fc.
    Coulomb,
    /// Constant offset.
    Offset,
    /// Static Stribeck Fc.
    StribeckFc,
    /// Static Stribeck Fs.
    StribeckFs,
    /// Static Stribeck vs.
    StribeckVs,
    /// LuGre σ0.
    Sigma0,
    /// LuGre σ1.
    Sigma1,
    /// LuGre σ2.
    Sigma2,
    /// LuGre Fc.
    LuGreFc,
    /// LuGre Fs.
    LuGreFs,
    /// LuGre vs.
    LuGreVs,
    /// Cable-drag spring stiffness Ks.
    SpringStiffness,
    /// Cable-drag spring rest angle qeq.
    SpringRest,
    /// Friction position bias factor.
    BiasFactor,
    /// Friction position bias switch position qeq.
    BiasRest,
    /// Armature inertia Ia.
    Armature,
}

/// A value θ of a [`PlantModel`] a sensitivity is taken with respect to: what it moves in the
/// simulator. One named value can move several things (a joint's `qeq` is both its spring's
/// rest angle and its friction bias's switch, thesis 3.9 and 4.3.5); one that moves nothing
/// here (an effect of a locked joint) has sensitivity 0.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PlantParameter {
    /// A direction in the barycentric parameters p: the nonzero entries of ∂p/∂θ as
    /// (index into p, value); an inertial symbol of the model file moves up to ten.
    pub inertial: Vec<(usize, f64)>,
    /// Values of effects of free joints: (free index, value).
    pub effects: Vec<(usize, EffectValue)>,
    /// Input couplings whose share G it is (indices into [`PlantModel::couplings`]).
    pub couplings: Vec<usize>,
}

/// Why sensitivities could not be integrated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SensitivityError {
    /// The simulation itself diverged.
    #[error(transparent)]
    Divergence(#[from] Divergence),
    /// The plant holds something whose derivative is not implemented.
    #[error("sensitivities are not available for {0} (use finite differences)")]
    Unsupported(String),
}

/// A simulation and its sensitivities at the output times.
#[derive(Debug, Clone, PartialEq)]
pub struct Sensitivities {
    /// The states at the output times, as [`PlantModel::simulate_at`] returns them.
    pub trajectory: Trajectory,
    /// ∂q/∂θ_j at the output times, `q[j][a][k]` (parameter j, free joint a, time k).
    pub q: Vec<Vec<Vec<f64>>>,
    /// ∂q̇/∂θ_j at the output times, `qd[j][a][k]`.
    pub qd: Vec<Vec<Vec<f64>>>,
}

/// The tangent's rows are P values padded with zero columns to a multiple of `LANES`, and
/// its element-wise arithmetic runs on `Lane`s: whole vector registers, no remainder loop.
const LANES: usize = 4;
type Lane = [f64; LANES];

/// `v` (a multiple of `LANES` long) as lanes.
#[inline(always)]
fn lanes(v: &[f64]) -> &[Lane] {
    v.as_chunks::<LANES>().0
}

/// `v` (a multiple of `LANES` long) as lanes.
#[inline(always)]
fn lanes_mut(v: &mut [f64]) -> &mut [Lane] {
    v.as_chunks_mut::<LANES>().0
}

/// Where element (row r, column j) of a tangent with `n3` rows is stored: lane-column major,
/// each group of `LANES` columns holding all rows in turn, so one lane's rows are contiguous.
#[inline(always)]
fn at(n3: usize, r: usize, j: usize) -> usize {
    (j / LANES) * n3 * LANES + r * LANES + j % LANES
}

/// acc += a x, lane by lane.
#[inline(always)]
fn axpy(acc: &mut Lane, a: f64, x: &Lane) {
    for (o, x) in acc.iter_mut().zip(x) {
        *o += a * x;
    }
}

/// Work space of the tangent computations. The tangents (3NF × P) are stored by [`at`], P
/// padded to a multiple of `LANES`; the padding columns are derivatives with respect to
/// nothing, 0.
struct TangentScratch {
    p: usize,
    /// `[D | ∂τ/∂q | ∂τ/∂q̇]`, NF × 3NF.
    dd: Vec<f64>,
    /// Cholesky factor of D + A, NF × NF (lower, row-major).
    l: Vec<f64>,
    /// G = [∂Q/∂q − ∂τ/∂q | ∂Q/∂q̇ − ∂τ/∂q̇], NF × 2NF: the velocity equation's
    /// right-hand side is G S_(q,q̇) + ∂Q/∂z S_z + ∂Q/∂θ.
    g: Vec<f64>,
    /// The regressor Y_F, NF × NP (when an inertial direction is fitted).
    y: Vec<f64>,
    /// The regressor columns (indices into p) some fitted value's inertial direction uses.
    used: Vec<usize>,
    /// Every fitted value's inertial direction as (index u into `used`, value j, ∂p_m/∂θ_j),
    /// ordered by j.
    inertial: Vec<(usize, usize, f64)>,
    /// The used regressor columns, one NF-vector each (`used.len()` × NF).
    yt: Vec<f64>,
    /// −Y_F ∂p/∂θ by value, one NF-vector each (P × NF).
    ft: Vec<f64>,
    /// ∂Q/∂t per joint where a step's start moves: Kp times the coupled input's rate.
    rate_g: Vec<f64>,
    /// Which free joints have a LuGre state.
    lugre: Vec<bool>,
    /// Armature inertias per free joint (kg·m² or kg).
    armature: Vec<f64>,
    /// Stage tangents K1..K4, 3NF × P each, and the stage state tangent.
    kt: [Vec<f64>; 4],
    sx: Vec<f64>,
    /// Stage time tangents (P).
    st: Vec<f64>,
    /// Input rates dτ/dt at the three stage times (NF each) and the coupled rate.
    rate: [Vec<f64>; 3],
    rate_c: Vec<f64>,
    /// Per joint: ∂Q/∂q, ∂Q/∂q̇, ∂Q/∂z, ∂ż/∂q̇, ∂ż/∂z.
    joint: Vec<[f64; 5]>,
    /// Per joint, the stage's friction terms the values' forcing reads (taken at the first
    /// value of the joint that needs them, once per stage: each holds exponentials).
    forcing: Vec<Option<JointForcing>>,
    /// Tangent copies at the start of a step split at a bias switch.
    start: Vec<f64>,
    /// The tangents of a split step's start time, of its rest and of its sub-step (P each).
    times: Vec<f64>,
    zero: Vec<f64>,
}

/// A free joint's friction terms at a stage, shared by the forcing of its values
/// ([`PlantModel::effect_forcing`]).
#[derive(Debug, Clone, Copy)]
struct JointForcing {
    /// The friction-bias factor on the stage's side (1 without a bias).
    b: f64,
    /// sign(q̇) (0 at rest).
    sign: f64,
    /// The static Stribeck curve's partials (∂g/∂Fc, ∂g/∂Fs, ∂g/∂vs), with a Stribeck law.
    stribeck: Option<[f64; 3]>,
    /// LuGre's g(q̇) and its partials, with a LuGre law.
    lugre: Option<(f64, [f64; 3])>,
}

impl PlantModel {
    /// Whether [`PlantModel::predict_at_with_sensitivities`] covers this plant; the reason
    /// when not.
    pub fn sensitivities_unsupported(&self) -> Option<String> {
        if self.integrator != Integrator::Rk4 {
            return Some(format!("the {} integrator", self.integrator));
        }
        for (i, t) in self.terms.iter().enumerate() {
            if !t.extra.is_empty() {
                return Some(format!("the user-defined effect '{}'", t.extra[0].name));
            }
            if t.backlash != 0.0 {
                return Some(format!("backlash (free joint {i})"));
            }
        }
        None
    }

    /// The tangent S₀ = ∂x₀/∂θ (3NF × P, row-major) of a start whose LuGre deflections are
    /// those of steady sliding at its velocities, z₀ = g(q̇₀) sign(q̇₀)/σ0
    /// ([`LuGre::sliding_deflection`]; positions and velocities do not move with θ):
    /// ∂z₀/∂σ0 = −z₀/σ0, ∂z₀/∂(Fc, Fs, vs) = ∂g/∂(Fc, Fs, vs) sign(q̇₀)/σ0.
    pub fn sliding_start_tangent(&self, x0: &State, params: &[PlantParameter]) -> Vec<f64> {
        let (nf, np) = (self.nf(), params.len());
        let mut s0 = vec![0.0; 3 * nf * np];
        for (j, param) in params.iter().enumerate() {
            for &(a, value) in &param.effects {
                let (Some(l), v) = (self.terms[a].lugre, x0.qd[a]) else {
                    continue;
                };
                if v == 0.0 || l.sigma0 <= 0.0 {
                    continue;
                }
                let partials = friction::stribeck_partials(l.fc, l.fs, l.vs, v);
                let dg = match value {
                    EffectValue::Sigma0 => {
                        s0[(2 * nf + a) * np + j] += -l.sliding_deflection(v) / l.sigma0;
                        continue;
                    }
                    EffectValue::LuGreFc => partials[0],
                    EffectValue::LuGreFs => partials[1],
                    EffectValue::LuGreVs => partials[2],
                    _ => continue,
                };
                s0[(2 * nf + a) * np + j] += dg * v.signum() / l.sigma0;
            }
        }
        s0
    }

    /// [`PlantModel::predict_at`] with the sensitivities of the outputs to `params`: the
    /// state and S = ∂x/∂θ stepped together (module doc), the outputs' tangents by the same
    /// interpolation as the outputs. The trajectory is the one `predict_at` returns, bit for
    /// bit. `x0` = (the start, its tangent S₀ (3NF × P, row-major) or None where the start
    /// does not move with θ; [`PlantModel::sliding_start_tangent`]).
    ///
    /// # Errors
    /// [`SensitivityError::Divergence`] as [`PlantModel::simulate`];
    /// [`SensitivityError::Unsupported`] for what [`PlantModel::sensitivities_unsupported`]
    /// names.
    #[allow(clippy::too_many_arguments)]
    pub fn predict_at_with_sensitivities(
        &self,
        (x0, s0): (State, Option<&[f64]>),
        h: f64,
        input: &InputSignal,
        observer: Option<(f64, &[Vec<f64>])>,
        times: &[f64],
        max_speed: f64,
        params: &[PlantParameter],
    ) -> Result<Sensitivities, SensitivityError> {
        if let Some(why) = self.sensitivities_unsupported() {
            return Err(SensitivityError::Unsupported(why));
        }
        let nf = self.nf();
        // P values, stored as `np` columns (padded to whole lanes).
        let p_count = params.len();
        let np = p_count.div_ceil(LANES) * LANES;
        let mut out = Sensitivities {
            trajectory: Trajectory {
                t: times.to_vec(),
                q: vec![Vec::with_capacity(times.len()); nf],
                qd: vec![Vec::with_capacity(times.len()); nf],
                z: vec![Vec::with_capacity(times.len()); nf],
            },
            q: vec![vec![Vec::with_capacity(times.len()); nf]; p_count],
            qd: vec![vec![Vec::with_capacity(times.len()); nf]; p_count],
        };
        let Some(&t_start) = times.first() else {
            return Ok(out);
        };
        let t_end = *times.last().unwrap_or(&t_start);
        let steps = ((t_end - t_start) / h - 1e-9).ceil().max(0.0) as usize;
        let mut w = Scratch::new(self);
        let mut used: Vec<usize> = params
            .iter()
            .flat_map(|p| p.inertial.iter().map(|&(m, _)| m))
            .collect();
        used.sort_unstable();
        used.dedup();
        let inertial = params
            .iter()
            .enumerate()
            .flat_map(|(j, p)| {
                let used = &used;
                p.inertial
                    .iter()
                    .map(move |&(m, d)| (used.binary_search(&m).unwrap_or_default(), j, d))
            })
            .collect();
        let mut tw = TangentScratch {
            p: np,
            dd: vec![0.0; 3 * nf * nf],
            l: vec![0.0; nf * nf],
            g: vec![0.0; 2 * nf * nf],
            y: vec![0.0; nf * self.p.len()],
            yt: vec![0.0; used.len() * nf],
            used,
            inertial,
            ft: vec![0.0; np * nf],
            rate_g: vec![0.0; nf],
            lugre: self.terms.iter().map(|t| t.lugre.is_some()).collect(),
            armature: self.terms.iter().map(|t| t.armature).collect(),
            kt: std::array::from_fn(|_| vec![0.0; 3 * nf * np]),
            sx: vec![0.0; 3 * nf * np],
            st: vec![0.0; np],
            rate: std::array::from_fn(|_| vec![0.0; nf]),
            rate_c: vec![0.0; nf],
            joint: vec![[0.0; 5]; nf],
            forcing: vec![None; nf],
            start: vec![0.0; 3 * nf * np],
            times: vec![0.0; 3 * np],
            zero: vec![0.0; np],
        };
        w.stages = StageInputs::cached(input, (t_start, t_end), h, steps);
        let measured = w.observe(observer, input);
        let mut x = x0;
        let mut prev = x.clone();
        let mut s = vec![0.0; 3 * nf * np];
        if let Some(s0) = s0.filter(|_| p_count > 0) {
            for (r, row0) in s0.chunks_exact(p_count).enumerate() {
                for (j, &v) in row0.iter().enumerate() {
                    s[at(3 * nf, r, j)] = v;
                }
            }
        }
        let mut s_prev = s.clone();
        let mut next_out = 0;
        let push = |out: &mut Sensitivities,
                    (a, sa): (&State, &[f64]),
                    (b, sb): (&State, &[f64]),
                    (ta, tb, t): (f64, f64, f64)| {
            let hh = tb - ta;
            let s = step_fraction(ta, tb, t);
            let [h00, h10, h01, h11] = hermite_weights(s);
            let tr = &mut out.trajectory;
            for i in 0..nf {
                tr.q[i].push(h00 * a.q[i] + h10 * hh * a.qd[i] + h01 * b.q[i] + h11 * hh * b.qd[i]);
                tr.qd[i].push(a.qd[i] + s * (b.qd[i] - a.qd[i]));
                tr.z[i].push(a.z[i] + s * (b.z[i] - a.z[i]));
                for j in 0..p_count {
                    let (rq, rv) = (at(3 * nf, i, j), at(3 * nf, nf + i, j));
                    out.q[j][i]
                        .push(h00 * sa[rq] + h10 * hh * sa[rv] + h01 * sb[rq] + h11 * hh * sb[rv]);
                    out.qd[j][i].push(sa[rv] + s * (sb[rv] - sa[rv]));
                }
            }
        };
        while next_out < times.len() && times[next_out] <= t_start + 1e-9 * h {
            push(&mut out, (&x, &s), (&x, &s), (t_start, t_start, t_start));
            next_out += 1;
        }
        for n in 0..steps {
            let (t, t1, hs) = step_span(t_start, t_end, h, n);
            w.step = n;
            prev.copy_from(&x);
            s_prev.copy_from_slice(&s);
            self.rk4_events_tangent(
                (&mut x, &mut s, &s_prev),
                (t, hs),
                (input, measured.as_ref()),
                params,
                &mut w,
                &mut tw,
            );
            self.check_step((&prev, &w.tau[0]), &x, t1, h, max_speed)?;
            while next_out < times.len() && times[next_out] <= t1 + 1e-9 * h {
                push(
                    &mut out,
                    (&prev, &s_prev),
                    (&x, &s),
                    (t, t1, times[next_out]),
                );
                next_out += 1;
            }
        }
        Ok(out)
    }

    /// [`PlantModel::rk4_with_events`] with the tangent `s` (3NF × P) stepped beside the
    /// state: the same arithmetic on the state, and a split step's switch differentiated.
    /// `s_start` is `s` on entry (the caller's copy; it is not copied again here).
    /// A step that does not switch (nearly all) costs one tangent step; the start-time and
    /// length tangents and the input's rates are formed only after a switch.
    fn rk4_events_tangent(
        &self,
        (x, s, s_start): (&mut State, &mut [f64], &[f64]),
        (t, h): (f64, f64),
        (input, measured): (&InputSignal, Option<&InputSignal>),
        params: &[PlantParameter],
        w: &mut Scratch,
        tw: &mut TangentScratch,
    ) {
        let np = tw.p;
        // The stage inputs, and with `rates` their time derivatives (one-sided as the
        // samples are taken: `at` is right-continuous, `before` left-continuous).
        let load = |t0: f64, hs: f64, rates: bool, w: &mut Scratch, tw: &mut TangentScratch| {
            w.load(input, measured, t0, hs);
            if rates {
                let d = 1e-7 * input.dt.max(1e-12);
                for (s, &ts) in w.time.iter().enumerate() {
                    let other = &mut tw.rate_c;
                    if s < 2 {
                        input.at(ts + d, other);
                        for (r, (o, a)) in tw.rate[s].iter_mut().zip(other.iter().zip(&w.tau[s])) {
                            *r = (o - a) / d;
                        }
                    } else {
                        input.before(ts - d, other);
                        for (r, (o, a)) in tw.rate[s].iter_mut().zip(other.iter().zip(&w.tau[s])) {
                            *r = (a - o) / d;
                        }
                    }
                }
            }
        };
        if !self.lock_sides(x, w) {
            load(t, h, false, w, tw);
            self.rk4_tangent((x, s), h, None, params, w, tw);
            return;
        }
        let (mut t0, mut rest) = (t, h);
        // The tangents of the start time and of the rest of the step: 0 until a switch.
        let mut split = false;
        let mut times = std::mem::take(&mut tw.times);
        let mut start = std::mem::take(&mut w.start);
        let mut done = false;
        for _ in 0..8 {
            start.copy_from(x);
            // The tangent at the start: `s_start` until the first switch, then copied.
            if split {
                tw.start.copy_from_slice(s);
            }
            load(t0, rest, split, w, tw);
            let moving = split.then_some((&times[..np], &times[np..2 * np]));
            self.rk4_tangent((x, s), rest, moving, params, w, tw);
            let Some((first, first_joint)) = self.crossings(&start, x, rest, w) else {
                done = true;
                break;
            };
            if !split {
                times.iter_mut().for_each(|v| *v = 0.0);
                tw.start.copy_from_slice(s_start);
                split = true;
            }
            let (dt0, rest_tangents) = times.split_at_mut(np);
            let (drest, dhs) = rest_tangents.split_at_mut(np);
            // The switch fraction's tangent: H(θ) = qeq on the trial step's Hermite
            // interpolant of the joint's position, H(θ) = h00 q0 + h10 m0 + h01 q1 + h11 m1
            // with m = rest·q̇ at either end.
            let i = first_joint;
            let nf = self.nf();
            let th = first;
            let [h00, h10, h01, h11] = hermite_weights(th);
            let [d00, d10, d01, d11] = hermite_slopes(th);
            let slope =
                d00 * start.q[i] + d10 * rest * start.qd[i] + d01 * x.q[i] + d11 * rest * x.qd[i];
            for j in 0..np {
                let (rq, rv) = (at(3 * nf, i, j), at(3 * nf, nf + i, j));
                let moves_qeq = params
                    .get(j)
                    .is_some_and(|p| p.effects.contains(&(i, EffectValue::BiasRest)));
                let dqeq = if moves_qeq { 1.0 } else { 0.0 };
                let dh_interp = h00 * tw.start[rq]
                    + h10 * (drest[j] * start.qd[i] + rest * tw.start[rv])
                    + h01 * s[rq]
                    + h11 * (drest[j] * x.qd[i] + rest * s[rv]);
                let dtheta = if slope != 0.0 {
                    (dqeq - dh_interp) / slope
                } else {
                    0.0
                };
                dhs[j] = dtheta * rest + th * drest[j];
            }
            x.copy_from(&start);
            s.copy_from_slice(&tw.start);
            let hs = first * rest;
            if hs > 1e-12 * h {
                load(t0, hs, true, w, tw);
                self.rk4_tangent((x, s), hs, Some((dt0, dhs)), params, w, tw);
            }
            w.switch_sides(first);
            t0 += hs;
            rest -= hs;
            for j in 0..np {
                dt0[j] += dhs[j];
                drest[j] -= dhs[j];
            }
            if rest <= 1e-12 * h {
                done = true;
                break;
            }
        }
        w.start = start;
        if !done {
            // At most 8 switches per step, then the rest as is (as the simulator).
            load(t0, rest, true, w, tw);
            let (dt0, rest_tangents) = times.split_at(np);
            self.rk4_tangent(
                (x, s),
                rest,
                Some((dt0, &rest_tangents[..np])),
                params,
                w,
                tw,
            );
        }
        tw.times = times;
    }

    /// One RK4 step of `h` ([`PlantModel::rk4_in_place`]'s arithmetic on `x`) with the
    /// tangent `s` (3NF × P): K_i the stage tangents, and where the step's start time and
    /// length move with θ (`dt0`, `dh`, P each; a step split at a switch) their terms.
    ///
    /// The tangent's arithmetic is element-wise loops over the P parameters (most of a
    /// sensitivity run's time): on an x86-64 CPU with AVX2 they run four wide instead of
    /// SSE2's two, chosen at run time. Each element is the same sequence of operations
    /// either way (no reduction is reordered), so the results are identical on every CPU.
    fn rk4_tangent(
        &self,
        (x, s): (&mut State, &mut [f64]),
        h: f64,
        moving: Option<(&[f64], &[f64])>,
        params: &[PlantParameter],
        w: &mut Scratch,
        tw: &mut TangentScratch,
    ) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: `rk4_tangent_avx2` only requires AVX2, which the CPU was just found
            // to have.
            unsafe { self.rk4_tangent_avx2((x, s), h, moving, params, w, tw) };
            return;
        }
        self.rk4_tangent_body((x, s), h, moving, params, w, tw);
    }

    /// [`PlantModel::rk4_tangent`] compiled for AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn rk4_tangent_avx2(
        &self,
        (x, s): (&mut State, &mut [f64]),
        h: f64,
        moving: Option<(&[f64], &[f64])>,
        params: &[PlantParameter],
        w: &mut Scratch,
        tw: &mut TangentScratch,
    ) {
        self.rk4_tangent_body((x, s), h, moving, params, w, tw);
    }

    /// [`PlantModel::rk4_tangent`]'s body, inlined into each of its compilations.
    #[inline(always)]
    fn rk4_tangent_body(
        &self,
        (x, s): (&mut State, &mut [f64]),
        h: f64,
        moving: Option<(&[f64], &[f64])>,
        params: &[PlantParameter],
        w: &mut Scratch,
        tw: &mut TangentScratch,
    ) {
        let np = tw.p;
        let n3 = 3 * self.nf();
        let mut k = std::mem::take(&mut w.k);
        let mut stage = std::mem::take(&mut w.stage);
        let tau = std::mem::take(&mut w.tau);
        let mut kt = std::mem::take(&mut tw.kt);
        let mut sx = std::mem::take(&mut tw.sx);
        let mut st = std::mem::take(&mut tw.st);
        let zero = std::mem::take(&mut tw.zero);
        let (dt0, dh) = moving.unwrap_or((&zero, &zero));
        let moving = moving.is_some();
        let time = w.time;
        // The stages: state x + c_i h k_{i−1} at time index T_i, as RK4 takes them.
        const C: [f64; 4] = [0.0, 0.5, 0.5, 1.0];
        const T: [usize; 4] = [0, 1, 1, 2];
        for i in 0..4 {
            let (done, todo) = kt.split_at_mut(i);
            let (k_done, k_todo) = k.split_at_mut(i);
            // The first stage's tangent is s itself (no copy) unless the step's start moves.
            let at = if i == 0 {
                if moving {
                    stage_tangent(&mut sx, &mut st, (s, 0.0, 0.0, None), moving, (dt0, dh));
                }
                &*x
            } else {
                x.axpy_into(C[i] * h, &k_done[i - 1], &mut stage);
                let previous = Some((&done[i - 1][..], &k_done[i - 1]));
                let stage_at = (&*s, C[i] * h, C[i], previous);
                stage_tangent(&mut sx, &mut st, stage_at, moving, (dt0, dh));
                &stage
            };
            let sx = if i == 0 && !moving { &*s } else { &sx };
            self.stage_with_tangent(
                (time[T[i]], at, &tau[T[i]]),
                T[i],
                (sx, &st, moving),
                params,
                w,
                tw,
                &mut k_todo[0],
                &mut todo[0],
            );
        }
        let [kt0, kt1, kt2, kt3] = &kt;
        let c = h / 6.0;
        super::rk4_combine(s, c, [kt0, kt1, kt2, kt3]);
        if moving {
            let sum = |f: fn(&State) -> &Vec<f64>| -> Vec<f64> {
                (0..self.nf())
                    .map(|i| f(&k[0])[i] + 2.0 * f(&k[1])[i] + 2.0 * f(&k[2])[i] + f(&k[3])[i])
                    .collect()
            };
            let ksum: Vec<f64> = sum(|k| &k.q)
                .into_iter()
                .chain(sum(|k| &k.qd))
                .chain(sum(|k| &k.z))
                .collect();
            for r in 0..n3 {
                for j in 0..np {
                    s[at(n3, r, j)] += dh[j] / 6.0 * ksum[r];
                }
            }
        }
        x.add_rk4(c, &k);
        w.k = k;
        w.stage = stage;
        w.tau = tau;
        tw.kt = kt;
        tw.sx = sx;
        tw.st = st;
        tw.zero = zero;
    }

    /// f at one stage into `k` ([`PlantModel::derivative_into`] and the output injection,
    /// as RK4 evaluates it) and its tangent K = ∂f/∂x sx + ∂f/∂t st + ∂f/∂θ into `kt`
    /// (3NF × P); `stage` indexes the stage inputs (0: t, 1: t + h/2, 2: t + h).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn stage_with_tangent(
        &self,
        (t, x, tau): (f64, &State, &[f64]),
        stage: usize,
        (sx, st, moving): (&[f64], &[f64], bool),
        params: &[PlantParameter],
        w: &mut Scratch,
        tw: &mut TangentScratch,
        k: &mut State,
        kt: &mut [f64],
    ) {
        let nf = self.nf();
        // The rigid body's q̈ (the derivative kernels, the regressor and the armatures read
        // it); the output injection is added to k at the end.
        self.derivative_into((t, x, tau), &[], w, k);
        // ∂Q/∂x and ż's derivatives per joint (diagonal: each joint's effects read its own
        // state), with the bias side locked as the step runs.
        for i in 0..nf {
            let term = &self.terms[i];
            let (v, z) = (x.qd[i], x.z[i]);
            let below = w.sides.get(i).copied().flatten();
            let b = self.bias_factor(i, x.q[i], below);
            let mut df_dv = term.viscous;
            if let Some(sb) = &term.stribeck {
                if v != 0.0 {
                    df_dv += friction::stribeck_slope(sb.fc, sb.fs, sb.vs, v) * v.signum();
                }
            }
            let (mut df_dz, mut dzd_dv, mut dzd_dz) = (0.0, 0.0, 0.0);
            if let Some(l) = &term.lugre {
                let (dfv, dzv, dzz) = l.slopes(v, z);
                df_dv += dfv;
                dzd_dv = dzv;
                dzd_dz = dzz;
                df_dz = l.sigma0 + l.sigma1 * dzz;
            }
            let dq_dq = -term.spring.map_or(0.0, |(ks, _)| ks);
            tw.joint[i] = [dq_dq, -b * df_dv, -b * df_dz, dzd_dv, dzd_dz];
        }
        // [D | ∂τ/∂q | ∂τ/∂q̇] at q̈, the Cholesky factor of D + A, and G.
        (self.conf.dynamics_derivatives_trig)(&w.q_full, &w.sc, &x.qd, &k.qd, &self.p, &mut tw.dd);
        with_nf!(nf, nf => factor(nf, tw));
        let inertial = !tw.inertial.is_empty();
        if inertial {
            (self.conf.regressor_trig)(&w.q_full, &w.sc, &x.qd, &k.qd, &mut tw.y);
        }
        if moving {
            self.coupled_command(&tw.rate[stage], &mut tw.rate_c);
        }
        let n3 = 3 * nf;
        // ∂Q/∂θ and ∂ż/∂θ into the K_v and K_z rows: the rigid body's −Y_F ∂p/∂θ, then the
        // couplings and effects.
        let np = tw.p;
        with_nf!(nf, nf => inertial_forcing(nf, np, &self.p, tw, kt));
        tw.forcing.fill(None);
        for (j, param) in params.iter().enumerate() {
            for &c in &param.couplings {
                let c = self.couplings[c];
                kt[at(n3, nf + c.to, j)] += self.terms[c.to].gain * tau[c.from];
            }
            for &(i, value) in &param.effects {
                let f = *tw.forcing[i].get_or_insert_with(|| self.joint_forcing(i, x, w));
                let (dq, dz) = self.effect_forcing(i, value, x, k, w, &f);
                kt[at(n3, nf + i, j)] += dq;
                kt[at(n3, 2 * nf + i, j)] += dz;
            }
        }
        if moving {
            for (a, r) in tw.rate_g.iter_mut().enumerate() {
                *r = self.terms[a].gain * tw.rate_c[a];
            }
        }
        let pass = LanePass {
            g: &tw.g,
            l: &tw.l,
            joint: &tw.joint,
            lugre: &tw.lugre,
            injection: w.injection,
            rate: moving.then_some(&tw.rate_g[..]),
        };
        with_nf!(nf, nf => pass.run(nf, kt, sx, st));
        w.inject(x, stage, k);
    }

    /// Free joint `i`'s [`JointForcing`] at state `x`.
    fn joint_forcing(&self, i: usize, x: &State, w: &Scratch) -> JointForcing {
        let term = &self.terms[i];
        let v = x.qd[i];
        let below = w.sides.get(i).copied().flatten();
        JointForcing {
            b: self.bias_factor(i, x.q[i], below),
            sign: crate::effects::sign(v),
            stribeck: term
                .stribeck
                .as_ref()
                .map(|s| friction::stribeck_partials(s.fc, s.fs, s.vs, v)),
            lugre: term
                .lugre
                .as_ref()
                .map(|l| (l.g(v), friction::stribeck_partials(l.fc, l.fs, l.vs, v))),
        }
    }

    /// ∂Q_i/∂θ (the right-hand side of the velocity equation; the armature's −q̈_i) and
    /// ∂ż_i/∂θ for value `value` of free joint `i`'s effects at state `x` (derivative `k`).
    #[inline(always)]
    fn effect_forcing(
        &self,
        i: usize,
        value: EffectValue,
        x: &State,
        k: &State,
        w: &Scratch,
        f: &JointForcing,
    ) -> (f64, f64) {
        use EffectValue as E;
        let term = &self.terms[i];
        let (q, v, z) = (x.q[i], x.qd[i], x.z[i]);
        let below = w.sides.get(i).copied().flatten();
        let (b, sign) = (f.b, f.sign);
        match value {
            E::Gain => (w.tau_c[i], 0.0),
            E::Viscous => (-b * v, 0.0),
            E::Coulomb => (-b * sign, 0.0),
            E::Offset => (-1.0, 0.0),
            E::StribeckFc | E::StribeckFs | E::StribeckVs => match f.stribeck {
                Some(g) => {
                    let n = [E::StribeckFc, E::StribeckFs, E::StribeckVs]
                        .iter()
                        .position(|&e| e == value)
                        .unwrap_or(0);
                    (-b * g[n] * sign, 0.0)
                }
                None => (0.0, 0.0),
            },
            E::Sigma0 | E::Sigma1 | E::Sigma2 | E::LuGreFc | E::LuGreFs | E::LuGreVs => {
                let (Some(l), Some((g, dg))) = (&term.lugre, f.lugre) else {
                    return (0.0, 0.0);
                };
                let zd = v - l.sigma0 * v.abs() * z / g;
                // ż = v − σ0 |v| z / g(v): ∂ż/∂σ0 = −|v| z / g, ∂ż/∂g = σ0 |v| z / g².
                let (dzd, df_extra) = match value {
                    E::Sigma0 => (-v.abs() * z / g, z),
                    E::Sigma1 => (0.0, zd),
                    E::Sigma2 => (0.0, v),
                    _ => {
                        let n = match value {
                            E::LuGreFc => 0,
                            E::LuGreFs => 1,
                            _ => 2,
                        };
                        (l.sigma0 * v.abs() * z / (g * g) * dg[n], 0.0)
                    }
                };
                // F = σ0 z + σ1 ż + σ2 v.
                (-b * (df_extra + l.sigma1 * dzd), dzd)
            }
            E::SpringStiffness => (-term.spring.map_or(0.0, |(_, qeq)| q - qeq), 0.0),
            E::SpringRest => (term.spring.map_or(0.0, |(ks, _)| ks), 0.0),
            E::BiasFactor => {
                if term.bias.is_some_and(|(_, qeq)| below.unwrap_or(q < qeq)) {
                    let (f, _) = self.friction_on_side(i, q, v, z, Some(false));
                    (-f, 0.0)
                } else {
                    (0.0, 0.0)
                }
            }
            // Through the switch only ([`PlantModel::rk4_events_tangent`]).
            E::BiasRest => (0.0, 0.0),
            E::Armature => (-k.qd[i], 0.0),
        }
    }
}

/// A stage of [`stage_tangent`]: the step's tangent s, the stage's c·h and c, and the
/// previous stage's tangent and derivative (None at the first stage).
type StageAt<'a> = (&'a [f64], f64, f64, Option<(&'a [f64], &'a State)>);

/// An RK4 stage's tangent sx = s + c·K_prev (+ (dh·c')·k_prev where the step's length
/// moves with θ: `moving`), and its time tangent st = dt0 + c'·dh (P each row).
#[inline(always)]
fn stage_tangent(
    sx: &mut [f64],
    st: &mut [f64],
    (s, c, cd, kp): StageAt<'_>,
    moving: bool,
    (dt0, dh): (&[f64], &[f64]),
) {
    let np = st.len();
    let n3 = sx.len() / np.max(1);
    match kp {
        None => sx.copy_from_slice(s),
        Some((kt_prev, k_prev)) => {
            for ((o, a), b) in sx.iter_mut().zip(s.iter()).zip(kt_prev) {
                *o = a + c * b;
            }
            if moving {
                let kv = k_prev.q.iter().chain(&k_prev.qd).chain(&k_prev.z);
                for (r, kr) in kv.enumerate() {
                    for j in 0..np {
                        sx[at(n3, r, j)] += cd * dh[j] * kr;
                    }
                }
            }
        }
    }
    if moving {
        for j in 0..np {
            st[j] = dt0[j] + cd * dh[j];
        }
    }
}

/// From `tw.dd` = [D | ∂τ/∂q | ∂τ/∂q̇] and `tw.joint`: the Cholesky factor L of D + A (the
/// armatures) into `tw.l`, and G = [∂Q/∂q − ∂τ/∂q | ∂Q/∂q̇ − ∂τ/∂q̇] into `tw.g` (∂Q/∂x is
/// diagonal: each joint's effects read its own state).
#[inline(always)]
fn factor(nf: usize, tw: &mut TangentScratch) {
    let (n2, n3) = (2 * nf, 3 * nf);
    let (dd, l) = (&tw.dd[..nf * n3], &mut tw.l[..nf * nf]);
    for a in 0..nf {
        for c in 0..=a {
            let mut v = dd[a * n3 + c] + if a == c { tw.armature[a] } else { 0.0 };
            for m in 0..c {
                v -= l[a * nf + m] * l[c * nf + m];
            }
            l[a * nf + c] = if a == c { v.sqrt() } else { v / l[c * nf + c] };
        }
    }
    for a in 0..nf {
        let ja = tw.joint[a];
        let g = &mut tw.g[a * n2..(a + 1) * n2];
        for (g, d) in g.iter_mut().zip(&dd[a * n3 + nf..(a + 1) * n3]) {
            *g = -d;
        }
        g[a] += ja[0];
        g[nf + a] += ja[1];
    }
}

/// The rigid body's forcing −Y_F ∂p/∂θ (NF × P) into the K_v rows of `kt`, which it sets
/// (the K_z rows are zeroed): the used regressor columns gathered once (`yt`, one NF-vector
/// each), each fitted value's inertial direction summed into its NF-vector (`ft`,
/// contiguous per value), then stored by [`at`].
#[inline(always)]
fn inertial_forcing(nf: usize, np: usize, p: &[f64], tw: &mut TangentScratch, kt: &mut [f64]) {
    let (n3, npb) = (3 * nf, p.len());
    if n3 == 0 {
        return;
    }
    for (u, &m) in tw.used.iter().enumerate() {
        for (a, o) in tw.yt[u * nf..(u + 1) * nf].iter_mut().enumerate() {
            *o = tw.y[a * npb + m];
        }
    }
    tw.ft.fill(0.0);
    for &(u, j, d) in &tw.inertial {
        let (src, dst) = (
            &tw.yt[u * nf..(u + 1) * nf],
            &mut tw.ft[j * nf..(j + 1) * nf],
        );
        for (o, y) in dst.iter_mut().zip(src) {
            *o -= y * d;
        }
    }
    for (c, block) in kt.chunks_exact_mut(n3 * LANES).enumerate() {
        let (_, rest) = block.split_at_mut(nf * LANES);
        let (v, z) = rest.split_at_mut(nf * LANES);
        for lane in 0..LANES {
            let f = &tw.ft[(c * LANES + lane) * nf..(c * LANES + lane + 1) * nf];
            for (a, &fa) in f.iter().enumerate() {
                v[a * LANES + lane] = fa;
            }
        }
        z.fill(0.0);
    }
    debug_assert_eq!(kt.len(), n3 * np);
}

/// A stage's tangent lane by lane, each lane's rows contiguous ([`at`]): K_v from
/// (D + A) K_v = ∂Q/∂θ + G S_(q,q̇) + ∂Q/∂z S_z (+ ∂Q/∂t st where the step's start moves) by
/// the Cholesky factor L, K_z = ∂ż/∂θ + ∂ż/∂q̇ S_q̇ + ∂ż/∂z S_z, K_q = S_q̇, and the output
/// injection's −L1 S_q, −L2 S_q. `kt` holds ∂Q/∂θ and ∂ż/∂θ in its K_v and K_z rows on entry.
struct LanePass<'a> {
    /// G, NF × 2NF.
    g: &'a [f64],
    /// L, NF × NF (lower).
    l: &'a [f64],
    /// Per joint: ∂Q/∂q, ∂Q/∂q̇, ∂Q/∂z, ∂ż/∂q̇, ∂ż/∂z.
    joint: &'a [[f64; 5]],
    /// Which joints have a LuGre state.
    lugre: &'a [bool],
    injection: Option<(f64, f64)>,
    /// ∂Q/∂t per joint, where the step's start time moves.
    rate: Option<&'a [f64]>,
}

impl LanePass<'_> {
    #[inline(always)]
    fn run(&self, nf: usize, kt: &mut [f64], sx: &[f64], st: &[f64]) {
        let (n2, n3) = (2 * nf, 3 * nf);
        if n3 == 0 {
            return;
        }
        let (g, l) = (&self.g[..nf * n2], &self.l[..nf * nf]);
        let blocks = lanes_mut(kt)
            .chunks_exact_mut(n3)
            .zip(lanes(sx).chunks_exact(n3));
        for ((block, sxb), stc) in blocks.zip(lanes(st)) {
            let (kq, kvz) = block.split_at_mut(nf);
            let (kv, kz) = kvz.split_at_mut(nf);
            let (sqv, sz) = sxb.split_at(n2);
            let (sq, sv) = sqv.split_at(nf);
            for a in 0..nf {
                let mut r = kv[a];
                axpy(&mut r, self.joint[a][2], &sz[a]);
                // Two chains (positions, velocities): half the dependent adds.
                let mut rv = [0.0; LANES];
                let ga = &g[a * n2..(a + 1) * n2];
                let (gq, gv) = ga.split_at(nf);
                for b in 0..nf {
                    axpy(&mut r, gq[b], &sq[b]);
                    axpy(&mut rv, gv[b], &sv[b]);
                }
                axpy(&mut r, 1.0, &rv);
                if let Some(rate) = self.rate {
                    axpy(&mut r, rate[a], stc);
                }
                for m in 0..a {
                    axpy(&mut r, -l[a * nf + m], &kv[m]);
                }
                let d = l[a * nf + a];
                kv[a] = r.map(|v| v / d);
            }
            for a in (0..nf).rev() {
                let mut r = kv[a];
                for m in a + 1..nf {
                    axpy(&mut r, -l[m * nf + a], &kv[m]);
                }
                let d = l[a * nf + a];
                kv[a] = r.map(|v| v / d);
            }
            for a in 0..nf {
                if self.lugre[a] {
                    let ja = self.joint[a];
                    axpy(&mut kz[a], ja[3], &sv[a]);
                    axpy(&mut kz[a], ja[4], &sz[a]);
                }
                kq[a] = sv[a];
                if let Some((l1, l2)) = self.injection {
                    axpy(&mut kq[a], -l1, &sq[a]);
                    axpy(&mut kv[a], -l2, &sq[a]);
                }
            }
        }
    }
}
