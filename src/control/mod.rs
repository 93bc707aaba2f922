//! Control on the identified plant (thesis 4.5 and Chapter 5; docs/src/design/digest.md §4): the closed-loop
//! PD verification ([`closedloop`]), and the haptic virtual wall, PD versus fuzzy
//! ([`wall`], [`fuzzy`]), with automatic tuning of the fuzzy rules ([`tune`]).
//!
//! Experiments are data: a wall file (`model/control/freedom6s_wall.toml`) gives the plant,
//! the digital loop, the PD gains, the simulated user (hand sweep, approach speeds), the
//! membership functions and the rule modifications of Figure 5.6; a closed-loop file
//! (`model/control/freedom6s_closedloop.toml`) gives the gains of Table 4.8, the filter
//! (4.7) and the command table (4.9).

pub mod closedloop;
pub mod controller;
pub mod fuzzy;
pub mod tune;
pub mod wall;

use crate::plant::{ConsistencyPolicy, Plant};
use crate::simulation::PlantModel;
use anyhow::{bail, Context, Result};
use fuzzy::{Fam, Modification, Partition};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use wall::{Hand, Loop, PdWall, User, WallLaw};

/// Membership functions of one input in a wall file.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct InputSpec {
    /// Labels in increasing order.
    pub labels: Vec<String>,
    /// Peaks (rad or rad/s), strictly increasing.
    pub peaks: Vec<f64>,
}

/// The fuzzy controller of a wall file.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct FuzzySpec {
    /// Position membership functions (Table 5.2; peaks per docs/src/design/digest.md §4).
    pub position: InputSpec,
    /// Velocity membership functions.
    pub velocity: InputSpec,
    /// Rule modifications (Figure 5.6), applied in order to the Kubica table.
    #[serde(default)]
    pub modify: Vec<Modification>,
}

/// Digital loop of a wall file (one run per rate).
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct LoopSpec {
    /// Control rates (Hz).
    pub rates: Vec<f64>,
    /// Samples of delay between measurement and torque.
    pub delay: usize,
    /// Encoder counts per revolution (0 = exact positions).
    pub encoder_counts: f64,
    /// RK4 step (s).
    pub step: f64,
    /// Simulated time per run (s).
    pub duration: f64,
    /// Command torque limit (N·m; 0 = none).
    #[serde(default)]
    pub torque_limit: f64,
}

/// The simulated user of a wall file: hand parameters (grip stiffness and damping are
/// swept) and the intention.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct HandSpec {
    /// End-point radius (m).
    pub radius: f64,
    /// Hand mass (kg).
    pub mass: f64,
    /// Grip stiffnesses to sweep (N/m); the first is nominal.
    pub grip_stiffness: Vec<f64>,
    /// Grip dampings to sweep (N·s/m); the first is nominal.
    pub grip_damping: Vec<f64>,
    /// Arm stiffness (N/m).
    pub arm_stiffness: f64,
    /// Arm damping (N·s/m).
    pub arm_damping: f64,
    /// Start position (rad, > 0).
    pub start: f64,
    /// Intended final position (rad, < 0).
    pub target: f64,
}

/// One approach speed.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Approach {
    /// Name (slow, medium, fast).
    pub name: String,
    /// Intended approach speed (rad/s).
    pub speed: f64,
}

/// Automatic tuning settings (`lockstep wall tune`).
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct TuneSpec {
    /// Starting table: `kubica` (the PD law, 5.3) or `modified` (with Figure 5.6).
    pub from: String,
    /// Peak penetration bound as a multiple of the PD wall's, per approach speed.
    pub penetration_factor: f64,
    /// Position labels whose rules are tuned.
    pub position: Vec<String>,
    /// Velocity labels whose rules are tuned.
    pub velocity: Vec<String>,
    /// Evaluations allowed.
    pub max_evaluations: usize,
}

/// A virtual-wall experiment file.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct WallSpec {
    /// Plant file, relative to the wall file.
    pub plant: PathBuf,
    /// Parameter values replacing the plant file's.
    #[serde(default)]
    pub plant_overrides: BTreeMap<String, f64>,
    /// Configuration with the wall joint free.
    pub configuration: String,
    /// The wall joint.
    pub joint: String,
    /// Positions of the locked joints (rad; default 0).
    #[serde(default)]
    pub locked: BTreeMap<String, f64>,
    /// Digital loop.
    #[serde(rename = "loop")]
    pub loop_: LoopSpec,
    /// PD wall gains (5.3).
    pub pd: PdWall,
    /// Simulated user.
    pub hand: HandSpec,
    /// Approach speeds.
    pub approach: Vec<Approach>,
    /// Fuzzy controller.
    pub fuzzy: FuzzySpec,
    /// Tuning.
    pub tune: TuneSpec,
}

/// A wall file loaded: the simulator of the wall joint and the controllers.
#[derive(Debug, Clone)]
pub struct WallSetup {
    /// The file.
    pub spec: WallSpec,
    /// Where it was read.
    pub path: PathBuf,
    /// Simulator of the configuration.
    pub plant: PlantModel,
    /// Free index of the wall joint.
    pub joint: usize,
    /// Kubica table of the PD law (5.3), unmodified.
    pub kubica: Fam,
    /// Kubica table with the file's modifications (Figure 5.6).
    pub modified: Fam,
}

impl WallSpec {
    /// Read a wall file.
    ///
    /// # Errors
    /// Unreadable file; TOML error with line and column; unknown or missing field.
    pub fn load(path: &Path) -> Result<WallSpec> {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("{}: cannot read the wall file", path.display()))?;
        toml::from_str(&text)
            .map_err(|e| crate::util::toml_error(&path.display().to_string(), &text, &e))
    }

    /// The partitions of the fuzzy section.
    ///
    /// # Errors
    /// Invalid partitions, named by input and label.
    pub fn partitions(&self) -> Result<(Partition, Partition)> {
        Ok((
            Partition::new(
                "q",
                self.fuzzy.position.labels.clone(),
                self.fuzzy.position.peaks.clone(),
            )?,
            Partition::new(
                "dq",
                self.fuzzy.velocity.labels.clone(),
                self.fuzzy.velocity.peaks.clone(),
            )?,
        ))
    }

    /// The digital loop at `rate`.
    pub fn loop_at(&self, rate: f64) -> Loop {
        Loop {
            rate,
            delay: self.loop_.delay,
            encoder_counts: self.loop_.encoder_counts,
            step: self.loop_.step,
            duration: self.loop_.duration,
            torque_limit: self.loop_.torque_limit,
        }
    }

    /// The nominal hand (first grip stiffness and damping).
    pub fn nominal_hand(&self) -> Hand {
        self.hand_with(self.hand.grip_stiffness[0], self.hand.grip_damping[0])
    }

    /// The hand with a given grip.
    pub fn hand_with(&self, grip_stiffness: f64, grip_damping: f64) -> Hand {
        Hand {
            radius: self.hand.radius,
            mass: self.hand.mass,
            grip_stiffness,
            grip_damping,
            arm_stiffness: self.hand.arm_stiffness,
            arm_damping: self.hand.arm_damping,
        }
    }

    /// The user approaching at `speed`.
    pub fn user(&self, speed: f64) -> User {
        User {
            start: self.hand.start,
            target: self.hand.target,
            speed,
        }
    }
}

/// The plant of an experiment file at `file`: `plant` relative to the file's directory, with
/// `overrides` replacing its parameter values.
///
/// # Errors
/// As [`Plant::load`] (with the experiment file named); an override the plant does not have.
pub(crate) fn experiment_plant(
    file: &Path,
    plant: &Path,
    overrides: &BTreeMap<String, f64>,
) -> Result<Plant> {
    let origin = file.display().to_string();
    let path = file.parent().unwrap_or(Path::new(".")).join(plant);
    let mut p = Plant::load(&path).with_context(|| format!("{origin}: plant"))?;
    for (k, v) in overrides {
        if !p.parameters.contains_key(k) {
            bail!("{origin}: plant_overrides: the plant has no parameter '{k}'");
        }
        p.parameters.insert(k.clone(), *v);
    }
    Ok(p)
}

impl WallSetup {
    /// Load a wall file and build plant and controllers.
    ///
    /// # Errors
    /// Everything [`WallSpec::load`], [`Plant::load`] and [`Plant::simulator`] report; an
    /// unknown override, wall joint not free, empty sweep or speed list, bad partitions or
    /// rule modifications; each with the wall file named.
    pub fn load(path: &Path) -> Result<WallSetup> {
        let spec = WallSpec::load(path)?;
        let origin = path.display().to_string();
        let plant = experiment_plant(path, &spec.plant, &spec.plant_overrides)?;
        let model = plant.model;
        let mut q_locked = vec![0.0; model.joints.len()];
        for (k, v) in &spec.locked {
            let j = model
                .joints
                .iter()
                .position(|n| n == k)
                .with_context(|| format!("{origin}: locked: model has no joint '{k}'"))?;
            q_locked[j] = *v;
        }
        let sim = plant
            .simulator(&spec.configuration, &q_locked, ConsistencyPolicy::Refuse)
            .with_context(|| origin.clone())?
            .model;
        let jm = model
            .joints
            .iter()
            .position(|n| *n == spec.joint)
            .with_context(|| format!("{origin}: joint: model has no joint '{}'", spec.joint))?;
        let joint = sim
            .conf
            .free
            .iter()
            .position(|&k| k == jm)
            .with_context(|| {
                format!(
                    "{origin}: joint '{}' is not free in configuration '{}'",
                    spec.joint, spec.configuration
                )
            })?;
        if spec.hand.grip_stiffness.is_empty() || spec.hand.grip_damping.is_empty() {
            bail!("{origin}: hand: grip_stiffness and grip_damping need at least one value each");
        }
        if spec.approach.is_empty() || spec.loop_.rates.is_empty() {
            bail!("{origin}: at least one [[approach]] and one loop rate are needed");
        }
        if let Some(r) = spec
            .loop_
            .rates
            .iter()
            .find(|r| !(**r > 0.0 && r.is_finite()))
        {
            bail!("{origin}: loop rates: expected positive rates in Hz, got {r}");
        }
        let (pp, vp) = spec
            .partitions()
            .with_context(|| format!("{origin}: fuzzy"))?;
        let pd = spec.pd;
        let kubica = Fam::kubica(pp, vp, |q, qd| pd.u(q, qd));
        let mut modified = kubica.clone();
        modified
            .modify(&spec.fuzzy.modify)
            .with_context(|| format!("{origin}: fuzzy.modify"))?;
        Ok(WallSetup {
            spec,
            path: path.to_path_buf(),
            plant: sim,
            joint,
            kubica,
            modified,
        })
    }

    /// Simulate one run.
    ///
    /// # Errors
    /// As [`wall::simulate`].
    pub fn run(&self, law: &WallLaw, hand: &Hand, speed: f64, rate: f64) -> Result<wall::Run> {
        wall::simulate(
            &self.plant,
            self.joint,
            law,
            hand,
            &self.spec.user(speed),
            &self.spec.loop_at(rate),
        )
    }

    /// One run per approach speed of the file (in its order), in parallel.
    ///
    /// # Errors
    /// As [`wall::simulate`].
    pub fn runs(&self, law: &WallLaw, hand: &Hand, rate: f64) -> Result<Vec<wall::Run>> {
        self.spec
            .approach
            .par_iter()
            .map(|a| self.run(law, hand, a.speed, rate))
            .collect()
    }
}
