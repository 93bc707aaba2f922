//! The plant-gain scale families a sequence carries into a step that couples joints whose
//! families earlier steps left apart.

use super::*;
use crate::identify::output_error::scales_with_the_gain;
use std::collections::BTreeSet;

/// Per joint (model index), the last of `steps` (completed, in the plan's order) that fitted
/// the joint's plant gain `Kp_j`, where that fit left it on an exact symmetry (an infinite
/// standard error: the gain scaled with every force of the joint moves nothing the step's
/// data show): the step's configuration and the fitted values of the joint that scale with
/// the gain ([`scales_with_the_gain`]: `Kp_j`, the friction levels, the spring). A later
/// step that determines the gain removes the joint.
pub fn undetermined_gain_families<'a>(
    model: &Model,
    steps: impl IntoIterator<Item = &'a StepReport>,
) -> BTreeMap<usize, (String, Vec<String>)> {
    gain_families_of(
        model,
        steps.into_iter().map(|st| GainFit {
            config: &st.step.config,
            free: &st.step.free,
            names: &st.fit.names,
            // Whether the step's own data fixed the gain, relative to any held scale.
            std_err: st.fit.statistics.std_errs_given_scale(),
        }),
    )
}

/// What [`undetermined_gain_families`] reads of a completed step.
pub struct GainFit<'a> {
    /// The step's configuration.
    pub config: &'a str,
    /// Its free joints (model indices).
    pub free: &'a [usize],
    /// The values it fitted.
    pub names: &'a [String],
    /// Their standard errors (infinite: not determined).
    pub std_err: &'a [f64],
}

/// [`undetermined_gain_families`] of the steps `fits`, in the plan's order.
pub fn gain_families_of<'a>(
    model: &Model,
    fits: impl IntoIterator<Item = GainFit<'a>>,
) -> BTreeMap<usize, (String, Vec<String>)> {
    let mut families = BTreeMap::new();
    for fit in fits {
        for &j in fit.free {
            let gain = crate::names::parameter("Kp", model.joints[j]);
            let Some(i) = fit.names.iter().position(|n| *n == gain) else {
                continue;
            };
            if fit.std_err.get(i).is_some_and(|s| s.is_finite()) {
                families.remove(&j);
                continue;
            }
            let members: Vec<String> = fit
                .names
                .iter()
                .filter(|n| {
                    scales_with_the_gain(model, n)
                        && crate::names::split_parameter(model.joints, n)
                            .is_some_and(|(_, k)| k == j)
                })
                .cloned()
                .collect();
            families.insert(j, (fit.config.to_string(), members));
        }
    }
    families
}

/// The family members ([`undetermined_gain_families`]) a step that frees `free` fits again,
/// beside its own `fitted`: every member of its free joints' families, where those families
/// were left by two or more different steps; none otherwise.
///
/// Why: each step that fits a joint's gain with every force of that joint alone leaves one
/// exact symmetry per joint (the isolated method: c1..c6 one joint each), and its least
/// change sets that joint's scale at a point of its own. A step that frees two such joints
/// together sees their coupling (the inertia matrix is symmetric, D₀₁ = D₁₀, and the links'
/// symbols are shared by both rows), which fixes their relative scale — but only if their
/// families may move. On the Freedom 6S, c7 (joints 0 and 1, the families of c6 and c5)
/// ended at 1.64 and 1.29 σ̂ with them held, and at 1.07 and 0.98 σ̂ with both carried;
/// Kp_q0 / Kp_q1 came within 0.06 %, 0.4 % and 5.6 % of the truth's ratio on three data
/// sets (the sensitivities record, stop 83). But carried without the earlier steps'
/// information, c7's moves left the written plant off c5's and c6's files and, through
/// the held ties its least change scaled, c2's and c4's; [`run`] carries them only under
/// [`SequenceOptions::earlier_information`].
/// Joints freed together in one step (the coupled method's k1: q4 and q5) already have
/// their relative scale, and no family is carried for them. The families are read from the
/// run's report: a step run alone (`--config`) into a directory without the earlier
/// steps' report carries none.
pub fn gain_families_carried_into(
    families: &BTreeMap<usize, (String, Vec<String>)>,
    free: &[usize],
    fitted: &[String],
) -> Vec<String> {
    let of_free: Vec<&(String, Vec<String>)> =
        free.iter().filter_map(|j| families.get(j)).collect();
    let steps: BTreeSet<&String> = of_free.iter().map(|(s, _)| s).collect();
    if steps.len() < 2 {
        return Vec::new();
    }
    of_free
        .iter()
        .flat_map(|(_, members)| members.iter())
        .filter(|n| !fitted.contains(n))
        .cloned()
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(v: &[&str]) -> Vec<String> {
        v.iter().map(|s| s.to_string()).collect()
    }

    /// The isolated method's c5 and c6 (joint 1, joint 0, each gain on its own exact
    /// symmetry) leave two families that c7 (joints 0 and 1) carries, each with the values
    /// its step fitted that scale with the gain (not qeq or vs, not the rigid body's
    /// positions). The coupled method's k1 (joints 4 and 5 together) leaves two families of
    /// one step, which k2 (joints 3, 4, 5) does not carry. A step that determines a gain
    /// removes its family.
    #[test]
    fn families_left_apart_are_carried_where_their_joints_are_freed_together() {
        let model = generated::model("freedom6s").unwrap();
        let inf = f64::INFINITY;
        let c5 = names(&["m3", "z3", "Kp_q1", "Fc_q1", "Ks_q1", "qeq_q1", "vs_q1"]);
        let c6 = names(&["I1_33", "Kp_q0", "sigma0_q0", "Fs_q0", "qeq_q0"]);
        let (c5_se, c6_se) = (
            [inf, inf, inf, inf, inf, 1e-5, 1e-3],
            [inf, inf, inf, inf, 1e-6],
        );
        let isolated = || {
            [
                GainFit {
                    config: "c5",
                    free: &[1],
                    names: &c5,
                    std_err: &c5_se,
                },
                GainFit {
                    config: "c6",
                    free: &[0],
                    names: &c6,
                    std_err: &c6_se,
                },
            ]
        };
        let families = gain_families_of(model, isolated());
        assert_eq!(
            families[&1],
            ("c5".to_string(), names(&["Kp_q1", "Fc_q1", "Ks_q1"]))
        );
        assert_eq!(
            families[&0],
            ("c6".to_string(), names(&["Kp_q0", "sigma0_q0", "Fs_q0"]))
        );
        let c7 = gain_families_carried_into(&families, &[0, 1], &names(&["I1_33", "Fc_q1"]));
        assert_eq!(
            c7,
            names(&["Kp_q0", "sigma0_q0", "Fs_q0", "Kp_q1", "Ks_q1"])
        );
        // One joint of the two: nothing to couple.
        assert!(gain_families_carried_into(&families, &[1], &[]).is_empty());
        // A later step that determines joint 1's gain removes its family.
        let k = names(&["Kp_q1"]);
        let determined = gain_families_of(
            model,
            isolated().into_iter().chain([GainFit {
                config: "k4",
                free: &[1],
                names: &k,
                std_err: &[0.01],
            }]),
        );
        assert!(!determined.contains_key(&1) && determined.contains_key(&0));
        assert!(gain_families_carried_into(&determined, &[0, 1], &[]).is_empty());
        // The coupled k1: two families of one step.
        let k1 = names(&["Kp_q4", "Fc_q4", "Kp_q5", "Fc_q5"]);
        let coupled = gain_families_of(
            model,
            [GainFit {
                config: "k1",
                free: &[4, 5],
                names: &k1,
                std_err: &[inf; 4],
            }],
        );
        assert_eq!(coupled.len(), 2);
        assert!(gain_families_carried_into(&coupled, &[3, 4, 5], &[]).is_empty());
    }
}
