//! Measurement files made without lockstep's simulator: the data a hidden-effect test must
//! also pass on, so that a capability is not shown by data the code under test made.
//!
//! What it shares with `lockstep simulate` is only the plant's equations
//! ([`lockstep::simulation::PlantModel::derivative`]: rigid body, friction, springs,
//! couplings). Everything else is its own:
//! - the integrator: `ode_solvers`' Dop853 (Dormand–Prince 8(5,3), dense output of order
//!   7) instead of lockstep's RK4, at [`STEP`]: the steps are fixed (tolerances left wide,
//!   the step capped), because an error-controlled run at rtol 1e-10 resolves the LuGre
//!   bristles' presliding oscillation (ω ≈ 3e4 rad/s on the wrist) to 1e-10 and took 1.2
//!   million steps per simulated second; 8th order at ωh ≈ 1.3 leaves it far below the
//!   sensor, and the test that compares the two simulators bounds the difference;
//! - the input: the excitation's continuous formula (`Signal::value`) evaluated at every
//!   stage of every step, not a sampled torque held between samples; the file gets the
//!   samples at 100 Hz, with a side file that declares `hold = "bandlimited"`;
//! - the noise: its own generator (SplitMix64, Box–Muller), not lockstep's Xorshift.

use lockstep::excitation::{Excitations, Test};
use lockstep::plant::{ConsistencyPolicy, Plant};
use lockstep::simulation::{PlantModel, State, Stepper};
use ode_solvers::{DVector, Dop853, System};
use std::cell::RefCell;
use std::fmt::Write as _;
use std::path::Path;

/// A torque the plant's equations do not have, written here by hand (a hidden effect that
/// lockstep's own code must not make): the torque it takes from each free joint (NF) at a
/// state.
pub type Hidden<'a> = &'a (dyn Fn(&State) -> Vec<f64> + Sync);

/// The plant's state equation driven by the continuous excitation.
struct Driven<'a> {
    test: &'a Test,
    /// Model joint index of each free joint.
    free: &'a [usize],
    /// A hidden torque, taken from the joints.
    hidden: Option<Hidden<'a>>,
    /// The plant's derivative evaluated with one work space (the equations only: the
    /// stepper's RK4 is not used), and the state, derivative and torques it reads.
    work: RefCell<(Stepper<'a>, State, State, Vec<f64>)>,
}

impl<'a> Driven<'a> {
    fn new(
        model: &'a PlantModel,
        test: &'a Test,
        free: &'a [usize],
        hidden: Option<Hidden<'a>>,
    ) -> Self {
        let zero = || State::at_rest(vec![0.0; free.len()]);
        Driven {
            test,
            free,
            hidden,
            work: RefCell::new((model.stepper(), zero(), zero(), vec![0.0; free.len()])),
        }
    }

    fn tau(&self, t: f64) -> Vec<f64> {
        let mut tau = vec![0.0; self.free.len()];
        self.tau_into(t, &mut tau);
        tau
    }

    fn tau_into(&self, t: f64, tau: &mut [f64]) {
        for (o, &j) in tau.iter_mut().zip(self.free) {
            *o = self
                .test
                .signals
                .iter()
                .filter(|s| s.joint == j)
                .map(|s| s.value(t))
                .sum();
        }
    }
}

impl System<f64, DVector<f64>> for Driven<'_> {
    fn system(&self, t: f64, y: &DVector<f64>, dy: &mut DVector<f64>) {
        let nf = self.free.len();
        let mut work = self.work.borrow_mut();
        let (stepper, x, d, tau) = &mut *work;
        for a in 0..nf {
            x.q[a] = y[a];
            x.qd[a] = y[nf + a];
            x.z[a] = y[2 * nf + a];
        }
        self.tau_into(t, tau);
        match self.hidden {
            Some(h) => {
                let taken: Vec<f64> = h(x).iter().map(|u| -u).collect();
                stepper.derivative_into(t, x, tau, &taken, d);
            }
            None => stepper.derivative_into(t, x, tau, &[], d),
        }
        for a in 0..nf {
            dy[a] = d.q[a];
            dy[nf + a] = d.qd[a];
            dy[2 * nf + a] = d.z[a];
        }
    }
}

/// The fixed step of the Dop853 run (s): 240 steps per 100 Hz sample.
pub const STEP: f64 = 1.0 / 24000.0;

/// Dop853 at the fixed step `step` over `(from, to)` (tolerances left wide so that the
/// step is never refined), dense output every `dx`: the independent integrator's setting.
pub fn fixed_step_dop853<F: System<f64, DVector<f64>>>(
    system: F,
    (from, to): (f64, f64),
    dx: f64,
    y0: DVector<f64>,
    step: f64,
) -> Dop853<f64, DVector<f64>, F> {
    Dop853::from_param(
        system,
        from,
        to,
        dx,
        y0,
        1e3,
        1e3,
        0.9,
        0.0,
        0.333,
        6.0,
        step,
        step,
        50_000_000,
        u32::MAX,
        ode_solvers::OutputType::Dense,
    )
}

/// Dense-output points per file sample on which a backlash is played (4 kHz).
pub const BACKLASH_OVERSAMPLING: usize = 40;

/// Gaussian deviates from SplitMix64 by Box–Muller.
pub struct Noise(pub u64);

impl Noise {
    /// A uniform deviate in (0, 1).
    pub fn uniform(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        ((z >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }

    /// A standard normal deviate.
    pub fn gaussian(&mut self) -> f64 {
        let (u1, u2) = (self.uniform(), self.uniform());
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }
}

/// What to make: the excitation table and test, its length, the sensor.
#[derive(Debug, Clone, Copy)]
pub struct Spec<'a> {
    pub config: &'a str,
    pub table: &'a str,
    pub test: Option<&'a str>,
    pub duration: f64,
    /// Position noise σ (rad) and quantisation step (rad).
    pub noise: f64,
    pub quantisation: f64,
    pub seed: u64,
}

/// Simulate `plant` in `spec.config` (locked joints at 0, free joints from rest at 0) on
/// the continuous excitation, sample at 100 Hz and write `path` (CSV: `t`, `tau{j}`,
/// `q{j}` of every joint) and its side file (configuration, `hold = "bandlimited"`).
pub fn write(plant: &Plant, spec: &Spec, path: &Path) {
    write_with(plant, spec, path, None)
}

/// [`write`] with a hidden torque taken from the free joints ([`Hidden`]).
pub fn write_with(plant: &Plant, spec: &Spec, path: &Path, hidden: Option<Hidden>) {
    write_sensed(plant, spec, path, hidden, &[])
}

/// [`write_with`] with backlash between each free joint's drive and its sensor: `backlash`
/// (NF, or empty for none) half-plays (rad or m), the play operator written here by hand,
/// y ← min(max(y, q − b), q + b) from y = q at t = 0, run on the dense output at
/// [`BACKLASH_OVERSAMPLING`] times the file's rate so that the reversals between samples
/// are not missed.
pub fn write_sensed(
    plant: &Plant,
    spec: &Spec,
    path: &Path,
    hidden: Option<Hidden>,
    backlash: &[f64],
) {
    const RATE: f64 = 100.0;
    let m = plant.model;
    let nj = m.joints.len();
    let conf = m.configuration(spec.config).expect("configuration");
    let free: Vec<usize> = conf.free.to_vec();
    let nf = free.len();
    let model = plant
        .simulator(spec.config, &vec![0.0; nj], ConsistencyPolicy::Warn)
        .expect("plant")
        .model;
    let tables = Excitations::bundled(m).expect("bundled excitation");
    let test = tables
        .table(spec.table)
        .expect("table")
        .test(spec.test)
        .expect("test")
        .clone();
    let system = Driven::new(&model, &test, &free, hidden);
    let y0 = DVector::zeros(3 * nf);
    let played = backlash.iter().any(|&b| b > 0.0);
    let fine = if played { BACKLASH_OVERSAMPLING } else { 1 };
    let mut solver = fixed_step_dop853(
        system,
        // Past the end: ode_solvers' dense output at x_end itself is not trustworthy (a
        // 15 s k1 run gave −8e7 rad there, the sample before it 4.7 rad).
        (0.0, spec.duration + 2.0 / RATE),
        1.0 / (RATE * fine as f64),
        y0,
        STEP,
    );
    let stats = solver.integrate().expect("Dop853 integration");
    if std::env::var_os("LOCKSTEP_INDEPENDENT_STATS").is_some() {
        eprintln!("Dop853 {}: {stats:?}", spec.config);
    }
    let (ts, ys) = (solver.x_out(), solver.y_out());
    let n = (spec.duration * RATE).round() as usize + 1;
    assert!(
        ts.len() > (n - 1) * fine,
        "dense output has {} of {n} samples",
        ts.len()
    );
    // The positions the sensors read: the drive's, or behind the play.
    let sensed: Vec<Vec<f64>> = (0..nf)
        .map(|a| {
            let b = backlash.get(a).copied().unwrap_or(0.0);
            let mut y = ys[0][a];
            (0..(n - 1) * fine + 1)
                .filter_map(|k| {
                    let q = ys[k][a];
                    if b > 0.0 {
                        y = y.max(q - b).min(q + b);
                    } else {
                        y = q;
                    }
                    (k % fine == 0).then_some(y)
                })
                .collect()
        })
        .collect();
    let mut noise = Noise(spec.seed);
    let mut measure = |x: f64| {
        let y = x + spec.noise * noise.gaussian();
        if spec.quantisation > 0.0 {
            (y / spec.quantisation).round() * spec.quantisation
        } else {
            y
        }
    };
    let mut csv = String::from("t");
    for j in 0..nj {
        write!(csv, ",tau{j}").unwrap();
    }
    for j in 0..nj {
        write!(csv, ",q{j}").unwrap();
    }
    csv.push('\n');
    let driven = Driven::new(&model, &test, &free, None);
    for k in 0..n {
        let t = k as f64 / RATE;
        assert!(
            (ts[k * fine] - t).abs() < 1e-9,
            "output time {} for sample {k}",
            ts[k * fine]
        );
        let tau = driven.tau(t);
        let mut row = format!("{t:e}");
        for j in 0..nj {
            let v = free.iter().position(|&f| f == j).map_or(0.0, |a| tau[a]);
            write!(row, ",{v:e}").unwrap();
        }
        for j in 0..nj {
            let v = free
                .iter()
                .position(|&f| f == j)
                .map_or(0.0, |a| sensed[a][k]);
            write!(row, ",{:e}", measure(v)).unwrap();
        }
        csv.push_str(&row);
        csv.push('\n');
    }
    std::fs::write(path, csv).unwrap();
    std::fs::write(
        path.with_extension("toml"),
        format!(
            "description = \"independent: Dop853 at a fixed {STEP:e} s on the continuous excitation of table {}, test {}\"\nconfiguration = \"{}\"\nhold = \"bandlimited\"\n",
            spec.table,
            spec.test.unwrap_or("(the first)"),
            spec.config
        ),
    )
    .unwrap();
}
