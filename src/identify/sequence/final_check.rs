//! The final plant on every step's files ([`SequenceReport::final_check`]): what MATLAB
//! `compare` of the plant a sequence writes would show on each step's data.

use super::*;
use crate::identify::output_error::FLOOR_FACTOR;

/// One step's files simulated with the plant the sequence wrote
/// ([`final_check`]).
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct FinalCheck {
    /// The step's configuration.
    pub config: String,
    /// Per free joint: name, RMS error over the fitted samples over its noise σ̂ at the
    /// step's own end and with the final plant (the initial positions estimated with
    /// each, as MATLAB `compare`); None where the files give no σ̂ or the simulation
    /// failed.
    pub joints: Vec<(String, Option<f64>, Option<f64>)>,
    /// Why the final plant's figures are missing, when they are (a failed simulation).
    #[serde(default)]
    pub failure: Option<String>,
}

impl FinalCheck {
    /// The worst free joint's RMS / σ̂ with the final plant; infinite where the files could
    /// not be simulated.
    pub fn worst(&self) -> f64 {
        if self.failure.is_some() {
            return f64::INFINITY;
        }
        self.joints.iter().filter_map(|j| j.2).fold(0.0, f64::max)
    }

    /// The worst free joint's RMS / σ̂ at the step's own end.
    pub fn worst_at_end(&self) -> f64 {
        self.joints.iter().filter_map(|j| j.1).fold(0.0, f64::max)
    }

    /// Whether a free joint ends above the noise floor ([`FLOOR_FACTOR`] × σ̂) with the
    /// final plant, or could not be simulated.
    pub fn above_floor(&self) -> bool {
        self.failure.is_some()
            || self
                .joints
                .iter()
                .any(|j| j.2.is_some_and(|r| r > FLOOR_FACTOR))
    }
}

/// Every step of `steps` (the step's report and its problem: configuration and files)
/// simulated with `plant` (the plant the sequence wrote), each file from the initial
/// positions `plant` fits best ([`Problem::with_initial_positions_of`]); per free joint
/// the RMS error over the samples the cost weighs in units of σ̂, beside the step's own.
///
/// Why: each step fits its own files, and later steps move values that earlier steps'
/// data determine only in combination with others (symbols carried because the earlier
/// step did not call them identifiable, the held ties and plant-gain families their least
/// change scales). On the isolated Freedom 6S chain every step ended at the floor, yet the
/// plant written reproduced c2's files at 88 % fit (0.35 rad RMS, 1710 σ̂): c4 refitted
/// I7_22, a member of joint 5's gain family that c2 determined only with Kp_q5 (the
/// sensitivities record, stop 83). The joint fit (`--joint-fit after`) fits every step's
/// files at once, but from a plant that far off it stopped in a local minimum there.
pub fn final_check(plant: &Plant, steps: &[(&StepReport, &Problem)]) -> Vec<FinalCheck> {
    steps
        .iter()
        .map(|(st, problem)| {
            let at_end: Vec<(String, Option<f64>)> = st
                .fit
                .statistics
                .joints
                .iter()
                .map(|j| (j.joint.clone(), j.floor_ratio()))
                .collect();
            let with_final = problem.with_initial_positions_of(plant).and_then(|p| {
                let trajectories = p
                    .records
                    .iter()
                    .map(|r| p.simulate(plant, r))
                    .collect::<Result<Vec<_>, _>>()?;
                Ok(p.joint_fits(&trajectories))
            });
            match with_final {
                Ok(fits) => FinalCheck {
                    config: st.step.config.clone(),
                    joints: at_end
                        .into_iter()
                        .zip(&fits)
                        .map(|((name, end), f)| (name, end, f.floor_ratio()))
                        .collect(),
                    failure: None,
                },
                Err(why) => FinalCheck {
                    config: st.step.config.clone(),
                    joints: at_end.into_iter().map(|(n, e)| (n, e, None)).collect(),
                    failure: Some(why.to_string()),
                },
            }
        })
        .collect()
}

/// A value a step called identifiable that the plant written holds more than two of that
/// step's standard errors away, and that no later step fitted ([`moved_since`]).
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct MovedValue {
    /// Parameter name.
    pub name: String,
    /// The step that called it identifiable.
    pub config: String,
    /// Its value there (SI).
    pub at_step: f64,
    /// Its standard error there (SI).
    pub std_err: f64,
    /// Its value in the plant written (SI).
    pub written: f64,
}

/// The values the steps `steps` (in the plan's order) called identifiable that `plant`
/// (the plant written) holds more than two standard errors from the step's value, where no
/// later step fitted them: moved by the earlier information's following or a refit of the
/// step's files ([`SequenceOptions::earlier_information`]), because a later step moved a
/// held value the step's estimate was conditional on (c2 of the isolated method holds z7
/// and I7_11, which c3 refits; Kp_q5 follows). The step's identifiability verdict takes
/// its held values as known; these show where that was not so.
pub fn moved_since(plant: &Plant, steps: &[StepReport]) -> Vec<MovedValue> {
    let mut out = Vec::new();
    for (k, st) in steps.iter().enumerate() {
        let f = &st.fit;
        for (i, n) in f.names.iter().enumerate() {
            if !f.statistics.identifiable.get(i).copied().unwrap_or(false)
                || steps[k + 1..].iter().any(|l| l.fit.names.contains(n))
            {
                continue;
            }
            let (Some(&written), Some(&std_err)) =
                (plant.parameters.get(n), f.statistics.std_err.get(i))
            else {
                continue;
            };
            if (written - f.fitted[i]).abs() > 2.0 * std_err {
                out.push(MovedValue {
                    name: n.clone(),
                    config: st.step.config.clone(),
                    at_step: f.fitted[i],
                    std_err,
                    written,
                });
            }
        }
    }
    out
}
