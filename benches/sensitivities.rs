//! The cost of one Jacobian of the simulated outputs (issue 60): by forward sensitivities
//! (the state and S = ∂x/∂θ stepped together, `PlantModel::predict_at_with_sensitivities`)
//! against one plain simulation, on the Appendix D coupled-method plant (I4_33 made positive)
//! under the Table 4.7 inputs, 2 s at 100 Hz, RK4 at 1/12000 s (the step the coupled
//! sequence's data need).
//!
//! For each step k1..k5 of the coupled sequence, θ is what that step adds: the effect values
//! of the joints it frees and the inertial symbols that enter its equations and no earlier
//! step's (k5: 37). `<config>/simulation` is one simulation; `<config>/sensitivities_<P>` is
//! the simulation with its P sensitivities. A forward-difference Jacobian costs P + 1
//! simulations (central: 2P); the target (issue 60) is one k5 Jacobian ≤ 6 simulations.

use criterion::{criterion_group, criterion_main, Criterion};
mod common;

use lockstep::excitation::Excitations;
use lockstep::plant::{ConsistencyPolicy, Plant};
use lockstep::simulation::{Hold, InputSignal, PlantParameter, State};
use std::time::Duration;

/// What step `conf` of the sequence adds after `previous`: parameter names.
fn step_parameters(
    plant: &Plant,
    conf: &generated::Configuration,
    previous: Option<&generated::Configuration>,
) -> Vec<String> {
    let before = |j: usize| previous.is_some_and(|p| p.free.contains(&j));
    let mut names: Vec<String> = plant
        .effects
        .iter()
        .filter(|e| e.acts_with(conf.free) && !(before(e.joint) && e.from.is_none_or(before)))
        .flat_map(|e| e.parameter_names(plant.model.joints))
        .collect();
    names.sort();
    names.dedup();
    for s in plant.model.inertial_symbols {
        let d = plant.sensitivity_parameter(s, conf).unwrap();
        let enters = |c: &generated::Configuration| {
            d.inertial.iter().any(|(k, _)| c.params_present.contains(k))
        };
        if enters(conf) && !previous.is_some_and(enters) {
            names.push(s.to_string());
        }
    }
    names
}

fn bench(c: &mut Criterion) {
    let plant = common::appendix_d_coupled();
    let ex = Excitations::bundled(plant.model).unwrap();
    let test = ex.table("4.7").unwrap().test(None).unwrap();
    let mut g = c.benchmark_group("jacobian");
    g.sample_size(10).measurement_time(Duration::from_secs(5));
    let mut previous: Option<&generated::Configuration> = None;
    for config in ["k1", "k2", "k3", "k4", "k5"] {
        let sim = plant
            .simulator(config, &[0.0; 6], ConsistencyPolicy::Refuse)
            .unwrap()
            .model;
        let conf = sim.conf;
        let (t, u, _) = test.sample(6, conf.free, 2.0, 100.0);
        let tau: Vec<Vec<f64>> = conf.free.iter().map(|&j| u[j].clone()).collect();
        let input = InputSignal {
            t0: 0.0,
            dt: 0.01,
            tau: &tau,
            hold: Hold::Zoh,
        };
        let names = step_parameters(&plant, conf, previous);
        let params: Vec<PlantParameter> = names
            .iter()
            .map(|n| plant.sensitivity_parameter(n, conf).unwrap())
            .collect();
        let h = 1.0 / 12000.0;
        let x0 = || State::at_rest(vec![0.0; conf.free.len()]);
        g.bench_function(format!("{config}/simulation"), |b| {
            b.iter(|| sim.predict_at(x0(), h, &input, None, &t, 100.0).unwrap())
        });
        g.bench_function(format!("{config}/sensitivities_{}", params.len()), |b| {
            b.iter(|| {
                sim.predict_at_with_sensitivities((x0(), None), h, &input, None, &t, 100.0, &params)
                    .unwrap()
            })
        });
        previous = Some(conf);
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
