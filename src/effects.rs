//! Effects beyond the rigid body: named, composable terms that add to the inverse-dynamics
//! torque of one joint, τ_i = [D q̈ + C q̇ + φ]_i + Σ effects_i.
//!
//! Each effect is listed in a plant file (see [`crate::plant`]) with the joints it acts on;
//! its parameters get names `<symbol>_<joint index>` (thesis Appendix D style, e.g. `Fv_0`).
//! The effects here are linear in their parameters, so each contributes regressor columns
//! for inverse-dynamic identification (IDIM-LS).

use serde::{Deserialize, Serialize};
use std::fmt;

/// The kinds of effect lockstep knows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EffectKind {
    /// Viscous friction `Fv·q̇` (N·m·s/rad or N·s/m).
    Viscous,
    /// Coulomb friction `Fc·sign(q̇)` (N·m or N), `sign(0) = 0`.
    Coulomb,
    /// Direction-dependent Coulomb and viscous friction:
    /// `[q̇ > 0](Fv_pos·q̇ + Fc_pos) + [q̇ < 0](Fv_neg·q̇ − Fc_neg)`.
    AsymmetricFriction,
    /// A constant torque or force offset (N·m or N), e.g. an amplifier or sensor bias.
    Offset,
}

impl EffectKind {
    /// Every kind, in catalogue order.
    pub const ALL: [EffectKind; 4] = [
        EffectKind::Viscous,
        EffectKind::Coulomb,
        EffectKind::AsymmetricFriction,
        EffectKind::Offset,
    ];

    /// Parameter symbols of the kind (without the joint suffix).
    pub fn symbols(self) -> &'static [&'static str] {
        match self {
            EffectKind::Viscous => &["Fv"],
            EffectKind::Coulomb => &["Fc"],
            EffectKind::AsymmetricFriction => &["Fv_pos", "Fc_pos", "Fv_neg", "Fc_neg"],
            EffectKind::Offset => &["offset"],
        }
    }

    /// One line on the physics.
    pub fn meaning(self) -> &'static str {
        match self {
            EffectKind::Viscous => "viscous friction, proportional to velocity",
            EffectKind::Coulomb => "Coulomb (dry) friction, constant magnitude opposing motion",
            EffectKind::AsymmetricFriction => {
                "Coulomb + viscous friction with different coefficients in each direction"
            }
            EffectKind::Offset => "constant torque offset (amplifier or sensor bias)",
        }
    }

    /// The regressor entries `∂τ/∂θ` of this kind at velocity `qd` (one per symbol).
    pub fn regressor(self, qd: f64) -> Vec<f64> {
        let sign = if qd > 0.0 {
            1.0
        } else if qd < 0.0 {
            -1.0
        } else {
            0.0
        };
        let pos = if qd > 0.0 { 1.0 } else { 0.0 };
        let neg = if qd < 0.0 { 1.0 } else { 0.0 };
        match self {
            EffectKind::Viscous => vec![qd],
            EffectKind::Coulomb => vec![sign],
            EffectKind::AsymmetricFriction => vec![pos * qd, pos, neg * qd, -neg],
            EffectKind::Offset => vec![1.0],
        }
    }
}

impl fmt::Display for EffectKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = match self {
            EffectKind::Viscous => "viscous",
            EffectKind::Coulomb => "coulomb",
            EffectKind::AsymmetricFriction => "asymmetric_friction",
            EffectKind::Offset => "offset",
        };
        f.write_str(s)
    }
}

/// One effect acting on one joint.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Effect {
    /// What it is.
    pub kind: EffectKind,
    /// Joint index in the model.
    pub joint: usize,
}

impl Effect {
    /// Parameter names, e.g. `["Fv_0"]`.
    pub fn parameter_names(&self) -> Vec<String> {
        self.kind
            .symbols()
            .iter()
            .map(|s| format!("{s}_{}", self.joint))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn regressor_rows_match_the_friction_laws() {
        assert_eq!(EffectKind::Coulomb.regressor(-0.2), vec![-1.0]);
        assert_eq!(EffectKind::Coulomb.regressor(0.0), vec![0.0]);
        assert_eq!(EffectKind::Viscous.regressor(0.5), vec![0.5]);
        // τ = Fv_pos q̇ + Fc_pos for q̇ > 0, Fv_neg q̇ − Fc_neg for q̇ < 0.
        let th = [2.0, 3.0, 5.0, 7.0];
        let tau = |qd: f64| -> f64 {
            EffectKind::AsymmetricFriction
                .regressor(qd)
                .iter()
                .zip(th)
                .map(|(a, b)| a * b)
                .sum()
        };
        assert_eq!(tau(0.5), 2.0 * 0.5 + 3.0);
        assert_eq!(tau(-0.5), 5.0 * -0.5 - 7.0);
        assert_eq!(
            Effect {
                kind: EffectKind::AsymmetricFriction,
                joint: 3
            }
            .parameter_names(),
            vec!["Fv_pos_3", "Fc_pos_3", "Fv_neg_3", "Fc_neg_3"]
        );
    }
}
