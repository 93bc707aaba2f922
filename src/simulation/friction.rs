//! Friction laws of the joints: LuGre (thesis 3.6–3.8) and the static Stribeck curve.

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
        stribeck_curve(self.fc, self.fs, self.vs, v)
    }

    /// Friction force and bristle rate `(F, ż)` at velocity `v` and deflection `z`.
    pub fn force(&self, v: f64, z: f64) -> (f64, f64) {
        let zd = v - self.sigma0 * v.abs() * z / self.g(v);
        (self.sigma0 * z + self.sigma1 * zd + self.sigma2 * v, zd)
    }

    /// Slopes at velocity `v` and deflection `z`: (∂F/∂v (N·m·s/rad), ∂ż/∂v (s), ∂ż/∂z (1/s)), from
    /// ∂ż/∂v = 1 − σ0 z (sign(v)/g − |v| g′/g²), ∂F/∂v = σ1 ∂ż/∂v + σ2 and
    /// ∂ż/∂z = −σ0 |v| / g (the kink of |v| at v = 0 taken as sticking, ∂ż/∂v = 1).
    pub fn slopes(&self, v: f64, z: f64) -> (f64, f64, f64) {
        let g = self.g(v);
        let dg = stribeck_slope(self.fc, self.fs, self.vs, v);
        let dzd_dv = 1.0 - self.sigma0 * z * (crate::effects::sign(v) / g - v.abs() * dg / (g * g));
        (
            self.sigma1 * dzd_dv + self.sigma2,
            dzd_dv,
            -self.sigma0 * v.abs() / g,
        )
    }

    /// Bristle deflection of steady sliding at velocity `v` (ż = 0): z = g(v) sign(v) / σ0
    /// (rad; 0 at rest).
    pub fn sliding_deflection(&self, v: f64) -> f64 {
        if v == 0.0 || self.sigma0 <= 0.0 {
            0.0
        } else {
            self.g(v) * v.signum() / self.sigma0
        }
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

/// The Stribeck decay e^{−(v/vs)²}, 0 without calling `exp` where it underflows anyway:
/// libm's underflow path is slow, and a hump of vs → 0 (Appendix D's vs_5 = 8e-9 rad/s)
/// sends every sample there (13 % of a k1 fit's time).
pub fn stribeck_decay(v: f64, vs: f64) -> f64 {
    let x = (v / vs).powi(2);
    // e^−746 rounds to 0 (the least subnormal is e^−744.4).
    if x > 746.0 {
        0.0
    } else {
        (-x).exp()
    }
}

/// The Stribeck curve g(v) = Fc + (Fs − Fc) e^{−(v/vs)²} (thesis 3.8), shared by LuGre and
/// the static model.
pub(super) fn stribeck_curve(fc: f64, fs: f64, vs: f64, v: f64) -> f64 {
    fc + (fs - fc) * stribeck_decay(v, vs)
}

/// g′(v) of [`stribeck_curve`]: −2 v / vs² (Fs − Fc) e^{−(v/vs)²}.
pub(super) fn stribeck_slope(fc: f64, fs: f64, vs: f64, v: f64) -> f64 {
    -2.0 * v / (vs * vs) * (fs - fc) * stribeck_decay(v, vs)
}

/// The partials of [`stribeck_curve`] at velocity `v`: (∂g/∂Fc, ∂g/∂Fs, ∂g/∂vs) =
/// (1 − e, e, (Fs − Fc) e 2v²/vs³), e = e^{−(v/vs)²} (the sensitivities' forcing).
pub(super) fn stribeck_partials(fc: f64, fs: f64, vs: f64, v: f64) -> [f64; 3] {
    let e = stribeck_decay(v, vs);
    [1.0 - e, e, (fs - fc) * e * 2.0 * v * v / (vs * vs * vs)]
}

/// Static friction with the Stribeck effect (thesis 3.3.1):
/// F = (Fc + (Fs − Fc) e^{−(v/vs)²}) sign(v), sign(0) = 0.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stribeck {
    /// Coulomb level Fc (N·m).
    pub fc: f64,
    /// Static level Fs (N·m).
    pub fs: f64,
    /// Stribeck velocity vs (rad/s).
    pub vs: f64,
}

impl Stribeck {
    /// Friction at velocity `v` (N·m).
    pub fn force(&self, v: f64) -> f64 {
        if v == 0.0 {
            0.0
        } else {
            stribeck_curve(self.fc, self.fs, self.vs, v) * v.signum()
        }
    }
}
