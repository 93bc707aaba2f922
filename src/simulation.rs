//! Fixed-step RK4 simulation of one configuration of a plant: the generated rigid-body
//! kernels plus the joint effects of thesis 3.3–3.5 and Figure 3.5 (DESIGN.md §2).
//!
//! Per free joint i the rigid body receives
//! Q_i = Kp_i·τ'_i − F_i(q̇_i, z_i) − Ks_i (q_i − qeq_i) − offset_i, where τ' is the commanded
//! torque after the tendon input coupling (4.5–4.6): τ'_a = τ_a − G_ba τ_b, τ'_b = τ_b + G_ab τ_a,
//! and F_i is viscous + Coulomb + LuGre friction (3.6–3.8). The state is
//! (q_F, q̇_F, z_F) with z the LuGre bristle deflection (z(0) = 0).
//!
//! Units: rad, rad/s, N·m (m, m/s, N for prismatic joints), s.

use generated::Configuration;

/// LuGre friction (thesis 3.6–3.8): F = σ0 z + σ1 ż + σ2 v, ż = v − σ0 |v| z / g(v),
/// g(v) = Fc + (Fs − Fc) e^{−(v/vs)²}.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LuGre {
    /// Bristle stiffness σ0 (N·m/rad).
    pub sigma0: f64,
    /// Bristle damping σ1 (N·m·s/rad).
    pub sigma1: f64,
    /// Viscous coefficient σ2 (N·m·s/rad).
    pub sigma2: f64,
    /// Coulomb level Fc (N·m).
    pub fc: f64,
    /// Static (stiction) level Fs ≥ Fc (N·m).
    pub fs: f64,
    /// Stribeck velocity vs (rad/s).
    pub vs: f64,
}

impl LuGre {
    /// The Stribeck curve g(v) (N·m).
    pub fn g(&self, v: f64) -> f64 {
        self.fc + (self.fs - self.fc) * (-(v / self.vs).powi(2)).exp()
    }

    /// Friction force and bristle rate `(F, ż)` at velocity `v` and deflection `z`.
    pub fn force(&self, v: f64, z: f64) -> (f64, f64) {
        let zd = v - self.sigma0 * v.abs() * z / self.g(v);
        (self.sigma0 * z + self.sigma1 * zd + self.sigma2 * v, zd)
    }

    /// Steady-state friction at constant velocity: g(v) sign(v) + σ2 v.
    pub fn steady_state(&self, v: f64) -> f64 {
        if v == 0.0 {
            0.0
        } else {
            self.g(v) * v.signum() + self.sigma2 * v
        }
    }
}

/// The effects on one free joint.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointTerms {
    /// Plant gain Kp (commanded to applied torque).
    pub gain: f64,
    /// Viscous friction Fv (N·m·s/rad).
    pub viscous: f64,
    /// Coulomb friction Fc·sign(q̇) (N·m).
    pub coulomb: f64,
    /// Constant offset (N·m), subtracted from the applied torque.
    pub offset: f64,
    /// LuGre friction.
    pub lugre: Option<LuGre>,
    /// Cable-drag spring (Ks (N·m/rad), qeq (rad)) (thesis 3.9).
    pub spring: Option<(f64, f64)>,
}

impl Default for JointTerms {
    fn default() -> Self {
        JointTerms {
            gain: 1.0,
            viscous: 0.0,
            coulomb: 0.0,
            offset: 0.0,
            lugre: None,
            spring: None,
        }
    }
}

/// Tendon input coupling between free joints `a` and `b` (indices into the free joints):
/// τ'_a = τ_a − g_ba τ_b, τ'_b = τ_b + g_ab τ_a (thesis 4.5–4.6 with a = 4, b = 5).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Coupling {
    /// Free index of the first joint (joint 4 in the thesis).
    pub a: usize,
    /// Free index of the second joint (joint 5).
    pub b: usize,
    /// G45: share of τ_a added to joint b.
    pub g_ab: f64,
    /// G54: share of τ_b taken from joint a.
    pub g_ba: f64,
}

/// A configuration of a plant ready to simulate.
#[derive(Debug, Clone)]
pub struct PlantModel {
    /// The generated kernels of the configuration.
    pub conf: &'static Configuration,
    /// Barycentric parameters (NP).
    pub p: Vec<f64>,
    /// Joint positions (NJ); locked joints keep these values.
    pub q_locked: Vec<f64>,
    /// Effects per free joint (NF).
    pub terms: Vec<JointTerms>,
    /// Optional tendon coupling.
    pub coupling: Option<Coupling>,
}

/// Simulation state: positions and velocities of the free joints and LuGre deflections.
#[derive(Debug, Clone, PartialEq)]
pub struct State {
    /// q_F (rad or m).
    pub q: Vec<f64>,
    /// q̇_F (rad/s or m/s).
    pub qd: Vec<f64>,
    /// z_F (rad); zero where a joint has no LuGre term.
    pub z: Vec<f64>,
}

impl State {
    /// At rest at `q` with z = 0.
    pub fn at_rest(q: Vec<f64>) -> State {
        let n = q.len();
        State {
            q,
            qd: vec![0.0; n],
            z: vec![0.0; n],
        }
    }

    fn axpy(&self, h: f64, d: &State) -> State {
        let f = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x + h * y).collect();
        State {
            q: f(&self.q, &d.q),
            qd: f(&self.qd, &d.qd),
            z: f(&self.z, &d.z),
        }
    }
}

/// The simulation left the valid region.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("simulation diverged at t = {t:.6} s: joint {joint} has {what} (step {h} s; try a smaller step)")]
pub struct Divergence {
    /// Time of the first invalid state (s).
    pub t: f64,
    /// Free-joint index.
    pub joint: usize,
    /// What was found.
    pub what: String,
    /// The step used (s).
    pub h: f64,
}

impl PlantModel {
    /// Friction force of free joint `i` and its bristle rate.
    fn friction(&self, i: usize, v: f64, z: f64) -> (f64, f64) {
        let t = &self.terms[i];
        let mut f = t.viscous * v + t.coulomb * if v == 0.0 { 0.0 } else { v.signum() };
        let mut zd = 0.0;
        if let Some(l) = &t.lugre {
            let (fl, d) = l.force(v, z);
            f += fl;
            zd = d;
        }
        (f, zd)
    }

    /// Generalised forces on the rigid body for commanded torques `tau` (NF).
    pub fn applied(&self, x: &State, tau: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let nf = self.terms.len();
        let mut tc = tau.to_vec();
        if let Some(c) = &self.coupling {
            tc[c.a] = tau[c.a] - c.g_ba * tau[c.b];
            tc[c.b] = tau[c.b] + c.g_ab * tau[c.a];
        }
        let mut q_applied = vec![0.0; nf];
        let mut zd = vec![0.0; nf];
        for i in 0..nf {
            let t = &self.terms[i];
            let (f, d) = self.friction(i, x.qd[i], x.z[i]);
            zd[i] = d;
            let spring = t.spring.map_or(0.0, |(ks, qeq)| ks * (x.q[i] - qeq));
            q_applied[i] = t.gain * tc[i] - f - spring - t.offset;
        }
        (q_applied, zd)
    }

    /// dx/dt at state `x` under commanded torques `tau`.
    pub fn derivative(&self, x: &State, tau: &[f64]) -> State {
        let mut q = self.q_locked.clone();
        for (a, &k) in self.conf.free.iter().enumerate() {
            q[k] = x.q[a];
        }
        let (applied, zd) = self.applied(x, tau);
        let mut qdd = vec![0.0; self.terms.len()];
        (self.conf.forward_dynamics)(&q, &x.qd, &applied, &self.p, &mut qdd);
        State {
            q: x.qd.clone(),
            qd: qdd,
            z: zd,
        }
    }

    /// One classical RK4 step of length `h` with the torques held over the step.
    pub fn rk4_step(&self, x: &State, tau: &[f64], h: f64) -> State {
        let k1 = self.derivative(x, tau);
        let k2 = self.derivative(&x.axpy(h / 2.0, &k1), tau);
        let k3 = self.derivative(&x.axpy(h / 2.0, &k2), tau);
        let k4 = self.derivative(&x.axpy(h, &k3), tau);
        let comb = |a: &[f64], b: &[f64], c: &[f64], d: &[f64], y: &[f64]| -> Vec<f64> {
            (0..y.len())
                .map(|i| y[i] + h / 6.0 * (a[i] + 2.0 * b[i] + 2.0 * c[i] + d[i]))
                .collect()
        };
        State {
            q: comb(&k1.q, &k2.q, &k3.q, &k4.q, &x.q),
            qd: comb(&k1.qd, &k2.qd, &k3.qd, &k4.qd, &x.qd),
            z: comb(&k1.z, &k2.z, &k3.z, &k4.z, &x.z),
        }
    }

    /// Simulate `steps` RK4 steps of `h` from `x0`; `input(t, tau)` writes the commanded
    /// torques (NF) held over the step starting at t (zero-order hold). Calls `observe(t, x)`
    /// after every step.
    ///
    /// # Errors
    /// [`Divergence`] at the first non-finite state or velocity beyond `max_speed`, naming
    /// the time and joint.
    pub fn simulate(
        &self,
        x0: State,
        h: f64,
        steps: usize,
        max_speed: f64,
        mut input: impl FnMut(f64, &mut [f64]),
        mut observe: impl FnMut(f64, &State),
    ) -> Result<State, Divergence> {
        let nf = self.terms.len();
        let mut tau = vec![0.0; nf];
        let mut x = x0;
        for n in 0..steps {
            let t = n as f64 * h;
            input(t, &mut tau);
            x = self.rk4_step(&x, &tau, h);
            let t1 = t + h;
            for i in 0..nf {
                let bad = if !(x.q[i].is_finite() && x.qd[i].is_finite() && x.z[i].is_finite()) {
                    Some("a non-finite state".to_string())
                } else if x.qd[i].abs() > max_speed {
                    Some(format!("speed {:.4e} beyond {max_speed:.4e}", x.qd[i]))
                } else {
                    None
                };
                if let Some(what) = bad {
                    return Err(Divergence {
                        t: t1,
                        joint: i,
                        what,
                        h,
                    });
                }
            }
            observe(t1, &x);
        }
        Ok(x)
    }
}
