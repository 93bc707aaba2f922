//! Effects beyond the rigid body: named, composable terms that add to the inverse-dynamics
//! torque of one joint, τ_i = [D q̈ + C q̇ + φ]_i + Σ effects_i.
//!
//! Each effect is listed in a plant file (see [`crate::plant`]) with the joints it acts on;
//! its parameters get names `<symbol>_<joint>` with the model's joint name (`Fv_q0`;
//! [`crate::names`]: the numbered `Fv_0` of earlier versions is still read).
//! Effects that are linear in their parameters contribute regressor columns for
//! inverse-dynamic identification (IDIM-LS); the others (plant gain, Stribeck, LuGre, spring,
//! friction bias, input coupling) act in the simulator (`crate::simulation`).

use crate::names;
use serde::{Deserialize, Serialize};
use std::fmt;

/// The kinds of effect lockstep knows (thesis 3.3–3.4, 4.3.4–4.3.5, Figure 3.5; docs/src/design/digest.md §2).
///
/// The first four are linear in their parameters and give regressor columns for
/// inverse-dynamic identification ([`EffectKind::regressor`]); the others enter the
/// simulator ([`crate::simulation`]) and output-error identification.
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
    /// Plant gain `Kp` (amplifier × gearing): the joint receives `Kp·τ'` for a command `τ'`.
    Gain,
    /// Static friction with the Stribeck effect (thesis 3.3.1):
    /// `g(q̇)·sign(q̇)`, `g(v) = Fc + (Fs − Fc) e^{−(v/vs)²}`.
    Stribeck,
    /// LuGre friction (thesis 3.6–3.8): `σ0 z + σ1 ż + σ2 q̇`, `ż = q̇ − σ0 |q̇| z / g(q̇)`,
    /// with the bristle deflection z as a state (z(0) = 0).
    Lugre,
    /// Cable-drag spring (thesis 3.9): `Ks (q − qeq)`.
    Spring,
    /// Friction position bias (thesis 4.3.5): the joint's friction is multiplied by
    /// `FrictionBias` where `q < qeq` (the spring's qeq when the joint has one).
    FrictionBias,
    /// Tendon input coupling (thesis 4.5–4.6): the command of joint `from` reaches this joint,
    /// `τ'_to = τ_to + G·τ_from`. The thesis's τ'_4 = τ_4 − G54 τ_5, τ'_5 = τ_5 + G45 τ_4 are
    /// two of these: `G_q5_to_q4 = −G54`, `G_q4_to_q5 = G45`.
    InputCoupling,
    /// Armature (rotor) inertia reflected through the gearing, `Ia·q̈` (kg·m² or kg; Ia =
    /// J_rotor·N² for a gear ratio N): it adds Ia to the joint's diagonal entry of the
    /// inertia matrix D(q) (Pinocchio's `armature`, FIGAROH's `Ia`).
    Armature,
    /// Backlash (play) in the transmission between the drive and the position sensor: the
    /// sensed position y follows the drive's q through a gap of width 2·backlash (rad or m),
    /// y ← clamp(y, q − backlash, q + backlash) (the play operator; Tao & Kokotović,
    /// *Adaptive Control of Systems with Actuator and Sensor Nonlinearities*, 1996, §2.1),
    /// y = q at t = 0 (the gap centred). It models a sensor on the load side of a gear whose
    /// load inertia is small beside the drive's reflected inertia (N²·J_rotor), so that the
    /// load rides on the drive's side of the gap; it changes the output, not the dynamics.
    Backlash,
}

impl EffectKind {
    /// Every kind, in catalogue order.
    pub const ALL: [EffectKind; 12] = [
        EffectKind::Viscous,
        EffectKind::Coulomb,
        EffectKind::AsymmetricFriction,
        EffectKind::Offset,
        EffectKind::Gain,
        EffectKind::Stribeck,
        EffectKind::Lugre,
        EffectKind::Spring,
        EffectKind::FrictionBias,
        EffectKind::InputCoupling,
        EffectKind::Armature,
        EffectKind::Backlash,
    ];

    /// Parameter symbols of the kind (without the joint suffix).
    pub fn symbols(self) -> &'static [&'static str] {
        match self {
            EffectKind::Viscous => &["Fv"],
            EffectKind::Coulomb => &["Fc"],
            EffectKind::AsymmetricFriction => &["Fv_pos", "Fc_pos", "Fv_neg", "Fc_neg"],
            EffectKind::Offset => &["offset"],
            EffectKind::Gain => &["Kp"],
            EffectKind::Stribeck => &["Fc", "Fs", "vs"],
            EffectKind::Lugre => &["sigma0", "sigma1", "sigma2", "Fc", "Fs", "vs"],
            EffectKind::Spring => &["Ks", "qeq"],
            EffectKind::FrictionBias => &["FrictionBias", "qeq"],
            EffectKind::InputCoupling => &["G"],
            EffectKind::Armature => &["Ia"],
            EffectKind::Backlash => &["backlash"],
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
            EffectKind::Gain => "plant gain: amplifier and gearing scale the commanded torque",
            EffectKind::Stribeck => {
                "static friction with stiction: friction falls from Fs to Fc as speed rises (Stribeck)"
            }
            EffectKind::Lugre => {
                "LuGre dynamic friction: bristle deflection gives pre-sliding, stiction, Stribeck and viscous friction"
            }
            EffectKind::Spring => "cable drag: a spring pulling the joint toward an equilibrium position",
            EffectKind::FrictionBias => {
                "friction depends on position: scaled on one side of the equilibrium position"
            }
            EffectKind::InputCoupling => {
                "tendon input coupling: part of another joint's command reaches this joint"
            }
            EffectKind::Armature => {
                "armature: the motor's rotor inertia reflected through the gearing adds to the joint's inertia"
            }
            EffectKind::Backlash => {
                "backlash: play in the transmission; the sensed position lags the drive by up to half the gap and stops while the gap is crossed"
            }
        }
    }

    /// True when τ is linear in the kind's parameters, so that it has regressor columns.
    pub fn is_linear(self) -> bool {
        matches!(
            self,
            EffectKind::Viscous
                | EffectKind::Coulomb
                | EffectKind::AsymmetricFriction
                | EffectKind::Offset
                | EffectKind::Armature
        )
    }

    /// True when the inverse model (torque space) takes the kind: the linear ones, and
    /// those linear in their other parameters once a few are given (fitted by variable
    /// projection: [`crate::identify::idim::separable_fit`]): the spring (given qeq),
    /// Stribeck friction (given vs), LuGre's static curve (given vs; its σ0 and σ1 shape only
    /// the presliding transients, which the inverse model's steady-state curve does not
    /// see), and the friction position bias (given FrictionBias and qeq, it scales the
    /// joint's friction columns).
    pub fn in_torque_space(self) -> bool {
        self.is_linear()
            || matches!(
                self,
                EffectKind::Spring
                    | EffectKind::Stribeck
                    | EffectKind::Lugre
                    | EffectKind::FrictionBias
            )
    }

    /// True for the kinds a friction position bias scales (the simulator's F_i: viscous,
    /// Coulomb, asymmetric, Stribeck and LuGre friction).
    pub fn is_biased_friction(self) -> bool {
        matches!(
            self,
            EffectKind::Viscous
                | EffectKind::Coulomb
                | EffectKind::AsymmetricFriction
                | EffectKind::Stribeck
                | EffectKind::Lugre
        )
    }

    /// The symbols of the kind torque space does not determine (LuGre's σ0, σ1): they keep
    /// the plant's values.
    pub fn undetermined_in_torque_space(self) -> &'static [&'static str] {
        match self {
            EffectKind::Lugre => &["sigma0", "sigma1"],
            _ => &[],
        }
    }

    /// The symbols the torque is linear in, given [`EffectKind::nonlinear_symbols`]: the
    /// inverse model's columns.
    pub fn linear_symbols(self) -> &'static [&'static str] {
        match self {
            EffectKind::Spring => &["Ks"],
            EffectKind::Stribeck => &["Fc", "Fs"],
            EffectKind::Lugre => &["sigma2", "Fc", "Fs"],
            k if k.is_linear() => k.symbols(),
            _ => &[],
        }
    }

    /// The symbols the torque depends on nonlinearly in torque space (the spring's rest
    /// angle, the Stribeck speed).
    pub fn nonlinear_symbols(self) -> &'static [&'static str] {
        match self {
            EffectKind::Spring => &["qeq"],
            EffectKind::Stribeck | EffectKind::Lugre => &["vs"],
            EffectKind::FrictionBias => &["FrictionBias", "qeq"],
            _ => &[],
        }
    }

    /// The inverse model's columns of the kind at position `q`, velocity `qd` and
    /// acceleration `qdd`, its nonlinear values `nonlinear` given (one per
    /// [`EffectKind::nonlinear_symbols`]): the spring's q − qeq; Stribeck's
    /// sign(q̇)(1 − e) and sign(q̇) e with e = exp(−(q̇/vs)²) for Fc and Fs (thesis 3.8, the
    /// simulator's law); the linear kinds' [`EffectKind::regressor`].
    pub fn regressor_at(self, q: f64, qd: f64, qdd: f64, nonlinear: &[f64]) -> Option<Vec<f64>> {
        match self {
            EffectKind::Spring => Some(vec![q - nonlinear[0]]),
            EffectKind::Stribeck => {
                let vs = nonlinear[0];
                let e = crate::simulation::stribeck_decay(qd, vs);
                let s = sign(qd);
                Some(vec![s * (1.0 - e), s * e])
            }
            EffectKind::Lugre => {
                let vs = nonlinear[0];
                let e = crate::simulation::stribeck_decay(qd, vs);
                let s = sign(qd);
                Some(vec![qd, s * (1.0 - e), s * e])
            }
            EffectKind::FrictionBias => Some(Vec::new()),
            _ => self.regressor(qd, qdd),
        }
    }

    /// True when the kind acts between two joints (`from` → `joint`).
    pub fn is_pairwise(self) -> bool {
        self == EffectKind::InputCoupling
    }

    /// True when the kind is a friction law (at most one per joint).
    pub fn is_friction_law(self) -> bool {
        matches!(
            self,
            EffectKind::Coulomb
                | EffectKind::AsymmetricFriction
                | EffectKind::Stribeck
                | EffectKind::Lugre
        )
    }

    /// The regressor entries `∂τ/∂θ` of a linear kind at velocity `qd` and acceleration
    /// `qdd` (one per symbol); `None` for kinds that are not linear in their parameters
    /// ([`EffectKind::is_linear`]).
    pub fn regressor(self, qd: f64, qdd: f64) -> Option<Vec<f64>> {
        let sign = sign(qd);
        let pos = if qd > 0.0 { 1.0 } else { 0.0 };
        let neg = if qd < 0.0 { 1.0 } else { 0.0 };
        match self {
            EffectKind::Viscous => Some(vec![qd]),
            EffectKind::Coulomb => Some(vec![sign]),
            EffectKind::AsymmetricFriction => Some(vec![pos * qd, pos, neg * qd, -neg]),
            EffectKind::Offset => Some(vec![1.0]),
            EffectKind::Armature => Some(vec![qdd]),
            _ => None,
        }
    }
}

/// sign(v) with sign(0) = 0 (and 0 for NaN): the Coulomb convention of the catalogue.
pub fn sign(v: f64) -> f64 {
    if v > 0.0 {
        1.0
    } else if v < 0.0 {
        -1.0
    } else {
        0.0
    }
}

impl fmt::Display for EffectKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = match self {
            EffectKind::Viscous => "viscous",
            EffectKind::Coulomb => "coulomb",
            EffectKind::AsymmetricFriction => "asymmetric_friction",
            EffectKind::Offset => "offset",
            EffectKind::Gain => "gain",
            EffectKind::Stribeck => "stribeck",
            EffectKind::Lugre => "lugre",
            EffectKind::Spring => "spring",
            EffectKind::FrictionBias => "friction_bias",
            EffectKind::InputCoupling => "input_coupling",
            EffectKind::Armature => "armature",
            EffectKind::Backlash => "backlash",
        };
        f.write_str(s)
    }
}

/// One effect acting on one joint.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Effect {
    /// What it is.
    pub kind: EffectKind,
    /// Joint index in the model (for an input coupling: the joint that receives).
    pub joint: usize,
    /// For an input coupling: the joint whose command is passed on; `None` otherwise.
    pub from: Option<usize>,
}

impl Effect {
    /// An effect of `kind` on `joint` (not an input coupling).
    pub fn on(kind: EffectKind, joint: usize) -> Effect {
        Effect {
            kind,
            joint,
            from: None,
        }
    }

    /// An input coupling from joint `from` to joint `to`.
    pub fn coupling(from: usize, to: usize) -> Effect {
        Effect {
            kind: EffectKind::InputCoupling,
            joint: to,
            from: Some(from),
        }
    }

    /// Whether the effect acts in a configuration with free joints `free` (model indices):
    /// its joint is free, and for an input coupling the joint it passes the command from
    /// too (a locked joint has no command, [`crate::plant::Plant::simulator`]).
    pub fn acts_with(&self, free: &[usize]) -> bool {
        free.contains(&self.joint) && self.from.is_none_or(|f| free.contains(&f))
    }

    /// Parameter names with the model's joint names `joints` ([`crate::names`]): viscous
    /// friction on joint `q1` has `["Fv_q1"]`; an input coupling from `q6` to `q5` has
    /// `["G_q6_to_q5"]`.
    pub fn parameter_names(&self, joints: &[&str]) -> Vec<String> {
        self.kind
            .symbols()
            .iter()
            .map(|s| self.parameter_name(s, joints))
            .collect()
    }

    /// The name of this effect's parameter `symbol` (one of [`EffectKind::symbols`]; an
    /// input coupling's one, `G`, is named by both joints).
    pub fn parameter_name(&self, symbol: &str, joints: &[&str]) -> String {
        let name = |k: usize| joints.get(k).copied().unwrap_or("?");
        match self.from {
            Some(from) => names::coupling_gain(name(from), name(self.joint)),
            None => names::parameter(symbol, name(self.joint)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const JOINTS: [&str; 6] = ["q1", "q2", "q3", "q4", "q5", "q6"];

    #[test]
    fn regressor_rows_match_the_friction_laws() {
        assert_eq!(EffectKind::Coulomb.regressor(-0.2, 0.0), Some(vec![-1.0]));
        assert_eq!(EffectKind::Coulomb.regressor(0.0, 0.0), Some(vec![0.0]));
        assert_eq!(EffectKind::Viscous.regressor(0.5, 0.0), Some(vec![0.5]));
        assert_eq!(EffectKind::Lugre.regressor(0.5, 0.0), None);
        assert_eq!(EffectKind::Armature.regressor(0.5, -2.0), Some(vec![-2.0]));
        // τ = Fv_pos q̇ + Fc_pos for q̇ > 0, Fv_neg q̇ − Fc_neg for q̇ < 0.
        let th = [2.0, 3.0, 5.0, 7.0];
        let tau = |qd: f64| -> f64 {
            EffectKind::AsymmetricFriction
                .regressor(qd, 0.0)
                .unwrap()
                .iter()
                .zip(th)
                .map(|(a, b)| a * b)
                .sum()
        };
        assert_eq!(tau(0.5), 2.0 * 0.5 + 3.0);
        assert_eq!(tau(-0.5), 5.0 * -0.5 - 7.0);
        assert_eq!(
            Effect::on(EffectKind::AsymmetricFriction, 3).parameter_names(&JOINTS),
            vec!["Fv_pos_q4", "Fc_pos_q4", "Fv_neg_q4", "Fc_neg_q4"]
        );
        assert_eq!(
            Effect::coupling(5, 4).parameter_names(&JOINTS),
            vec!["G_q6_to_q5"]
        );
    }
}
