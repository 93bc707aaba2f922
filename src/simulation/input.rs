//! Input reconstruction between samples ([`Hold`]): zero-order, linear, cubic and
//! band-limited (Kaiser-windowed sinc) holds of a sampled torque, as [`InputSignal`].

/// How a sampled torque is reconstructed between its sample times: how the input was
/// applied to the device the record comes from.
///
/// - `Zoh`: a digital controller held each command until the next (a DAC); the simulator
///   follows the steps exactly (the last RK stage of a step that ends on a sample takes
///   the left limit, [`InputSignal::before`]).
/// - `Linear`: straight lines between samples (second order: error h²/8·|u″|).
/// - `Cubic`: the Catmull–Rom (Keys a = −½) cubic through the four nearest samples: C¹,
///   exact for quadratics, error O(h³) (Keys, IEEE Trans. ASSP 29(6), 1981).
/// - `Bandlimited`: the Whittaker–Shannon reconstruction of a signal band-limited below
///   the Nyquist frequency, truncated to [`BANDLIMITED_TAPS`] samples each side with a
///   Kaiser window (β = [`KAISER_BETA`]) and normalised to reproduce constants: within
///   1e-5 of a sinusoid's amplitude up to 0.3 of the sampling rate (Lanczos's window, the
///   usual choice in image resampling, leaves 4e-4 at any frequency: its passband droops).
///
/// Outside the record the first or last sample holds (the reconstruction takes the record
/// as extended by its end values).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Hold {
    /// τ(t) = τ_k on [t_k, t_{k+1}) (what a digital controller with a DAC does).
    #[default]
    Zoh,
    /// Linear interpolation between samples.
    Linear,
    /// Catmull–Rom cubic through the four nearest samples.
    Cubic,
    /// Lanczos-windowed sinc reconstruction of a band-limited signal.
    Bandlimited,
}

/// Samples each side of the band-limited reconstruction ([`Hold::Bandlimited`]).
pub const BANDLIMITED_TAPS: usize = 12;

/// The Kaiser window's β of the band-limited reconstruction.
pub const KAISER_BETA: f64 = 10.0;

/// Kernel table points per sample period (the kernel is read by linear interpolation
/// between them: 5e-8 of a weight at most).
const KERNEL_RESOLUTION: usize = 4096;

impl Hold {
    /// Every hold, in the order of the CLI's list.
    pub const ALL: [Hold; 4] = [Hold::Zoh, Hold::Linear, Hold::Cubic, Hold::Bandlimited];

    /// Whether the reconstruction is continuous in time (no step at a sample).
    pub fn is_continuous(self) -> bool {
        self != Hold::Zoh
    }
}

impl std::str::FromStr for Hold {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "zoh" => Ok(Hold::Zoh),
            "linear" => Ok(Hold::Linear),
            "cubic" => Ok(Hold::Cubic),
            "bandlimited" => Ok(Hold::Bandlimited),
            _ => Err(format!(
                "expected `zoh`, `linear`, `cubic` or `bandlimited`, got `{s}`"
            )),
        }
    }
}

impl std::fmt::Display for Hold {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Hold::Zoh => "zoh",
            Hold::Linear => "linear",
            Hold::Cubic => "cubic",
            Hold::Bandlimited => "bandlimited",
        })
    }
}

/// Commanded torques sampled at evenly spaced times, held by [`Hold`]: the input of
/// [`crate::simulation::PlantModel::simulate_at`]. Before the first sample the first value
/// holds, after the last the last.
#[derive(Debug, Clone, Copy)]
pub struct InputSignal<'a> {
    /// First sample time (s).
    pub t0: f64,
    /// Sampling period (s), > 0.
    pub dt: f64,
    /// Torque per free joint, `tau[a][k]` (N·m); all of the same length ≥ 1.
    pub tau: &'a [Vec<f64>],
    /// Interpolation between samples.
    pub hold: Hold,
}

/// The band-limited reconstruction's kernel K(x) = sinc(x) I0(β √(1 − (x/a)²)) / I0(β)
/// (K(x) = 0 for |x| ≥ a), tabulated by phase, computed once: row p = 0 ..= resolution holds
/// the weights K(p / [`KERNEL_RESOLUTION`] − i), i = 1 − a ..= a, of the 2a samples around a
/// time the fraction p / resolution of a period past a sample. A time between two rows
/// reads both rows' 2a contiguous weights (linear interpolation in the phase), where a
/// table by x would read each weight a table's length apart.
fn bandlimited_kernel() -> &'static [[f64; 2 * BANDLIMITED_TAPS]] {
    static K: std::sync::OnceLock<Vec<[f64; 2 * BANDLIMITED_TAPS]>> = std::sync::OnceLock::new();
    K.get_or_init(|| {
        let i0 = crate::signal::bessel_i0;
        let a = BANDLIMITED_TAPS as f64;
        let kernel = |x: f64| {
            let x = x.abs();
            if x >= a {
                return 0.0;
            }
            let px = std::f64::consts::PI * x;
            let sinc = if x == 0.0 { 1.0 } else { px.sin() / px };
            sinc * i0(KAISER_BETA * (1.0 - (x / a).powi(2)).max(0.0).sqrt()) / i0(KAISER_BETA)
        };
        (0..=KERNEL_RESOLUTION)
            .map(|p| {
                let f = p as f64 / KERNEL_RESOLUTION as f64;
                std::array::from_fn(|j| kernel(f - (j as f64 + 1.0 - a)))
            })
            .collect()
    })
}

impl InputSignal<'_> {
    /// Torques at time `t` into `out` (NF): the value held from the sample at or before
    /// `t` (a time that is a sample time up to rounding belongs to that sample).
    pub fn at(&self, t: f64, out: &mut [f64]) {
        self.sample(t, false, out);
    }

    /// Torques just before time `t` into `out` (NF): the left limit, which under a
    /// zero-order hold at a sample time is the previous sample's value. The last stage of
    /// an integration step that ends on a sample time takes this one: the step integrates
    /// over [t_k − h, t_k], where the previous sample holds; taking the new sample there
    /// instead costs the integrator its order (an O(h) error per torque jump). The
    /// continuous holds have no jump: their left limit is their value.
    pub fn before(&self, t: f64, out: &mut [f64]) {
        self.sample(t, true, out);
    }

    /// The three stage inputs of an RK4 step of `hs` from `t0` into `out` (NF each): at
    /// t0, at t0 + hs/2 and just before t0 + hs ([`InputSignal::before`]). The simulator
    /// and [`StageInputs`] both form them here, so a stored step holds the same numbers.
    pub(crate) fn stage_inputs(&self, t0: f64, hs: f64, [a, b, c]: [&mut [f64]; 3]) {
        self.at(t0, a);
        self.at(t0 + hs / 2.0, b);
        self.before(t0 + hs, c);
    }

    fn sample(&self, t: f64, left: bool, out: &mut [f64]) {
        let n = self.tau.first().map_or(0, Vec::len);
        if n == 0 {
            out.fill(0.0);
            return;
        }
        let s = ((t - self.t0) / self.dt).max(0.0);
        match self.hold {
            Hold::Zoh | Hold::Linear => {
                // s ≥ 0: truncation is the floor, and the ceiling one more where it cut.
                let k = if left && s > 1e-9 {
                    let c = s - 1e-9;
                    let i = c as usize;
                    (if (i as f64) < c { i + 1 } else { i }).saturating_sub(1)
                } else {
                    (s + 1e-9) as usize
                }
                .min(n - 1);
                if self.hold == Hold::Zoh {
                    for (o, col) in out.iter_mut().zip(self.tau) {
                        *o = col[k];
                    }
                } else {
                    let f = (s - k as f64).clamp(0.0, 1.0);
                    let k1 = (k + 1).min(n - 1);
                    for (o, col) in out.iter_mut().zip(self.tau) {
                        *o = col[k] + f * (col[k1] - col[k]);
                    }
                }
            }
            Hold::Cubic | Hold::Bandlimited => {
                // s ≥ 0: truncation is the floor.
                let k = ((s + 1e-9) as usize) as f64;
                let f = (s - k).max(0.0);
                let k = k as usize;
                if k >= n - 1 || f < 1e-9 {
                    for (o, col) in out.iter_mut().zip(self.tau) {
                        *o = col[k.min(n - 1)];
                    }
                    return;
                }
                let at =
                    |col: &[f64], i: isize| col[(k as isize + i).clamp(0, n as isize - 1) as usize];
                if self.hold == Hold::Cubic {
                    // Catmull–Rom: p0 + f/2 (p1 − p₋₁) + f² (p₋₁ − 5/2 p0 + 2 p1 − p2/2)
                    // + f³ (−p₋₁/2 + 3/2 p0 − 3/2 p1 + p2/2).
                    for (o, col) in out.iter_mut().zip(self.tau) {
                        let (pm, p0, p1, p2) = (at(col, -1), at(col, 0), at(col, 1), at(col, 2));
                        *o = p0
                            + f * (0.5 * (p1 - pm)
                                + f * ((pm - 2.5 * p0 + 2.0 * p1 - 0.5 * p2)
                                    + f * (-0.5 * pm + 1.5 * p0 - 1.5 * p1 + 0.5 * p2)));
                    }
                } else {
                    // w_i = K(f − i), i = 1 − a … a, normalised to sum 1; K read between
                    // the two phases of the table around f.
                    let a = BANDLIMITED_TAPS as isize;
                    let u = f * KERNEL_RESOLUTION as f64;
                    // 0 ≤ u < resolution: truncation is the floor.
                    let p = (u as usize).min(KERNEL_RESOLUTION - 1);
                    let phi = u - p as f64;
                    let table = bandlimited_kernel();
                    let (lo, hi) = (&table[p], &table[p + 1]);
                    let mut w = [0.0; 2 * BANDLIMITED_TAPS];
                    let mut sum = 0.0;
                    for ((wj, l), h) in w.iter_mut().zip(lo).zip(hi) {
                        *wj = l + phi * (h - l);
                        sum += *wj;
                    }
                    // The taps k + 1 − a ..= k + a, clamped to the record at its ends.
                    let first = k as isize + 1 - a;
                    let inside = first >= 0 && k + BANDLIMITED_TAPS < n;
                    for (o, col) in out.iter_mut().zip(self.tau) {
                        let mut v = 0.0;
                        if inside {
                            let taps = &col[first as usize..first as usize + 2 * BANDLIMITED_TAPS];
                            for (wj, x) in w.iter().zip(taps) {
                                v += wj * x;
                            }
                        } else {
                            for (j, wj) in w.iter().enumerate() {
                                v += wj * at(col, j as isize + 1 - a);
                            }
                        }
                        *o = v / sum;
                    }
                }
            }
        }
    }
}

/// Where step `n` of a fixed-step run from `t_start` to `t_end` by `h` lies: its start
/// time, its end time and its length (the last step ends on `t_end`). [`PlantModel::predict_at`], its
/// sensitivities and [`StageInputs`] share this arithmetic, so the stage times they form
/// are the same numbers.
///
/// [`PlantModel::predict_at`]: super::PlantModel::predict_at
pub(crate) fn step_span(t_start: f64, t_end: f64, h: f64, n: usize) -> (f64, f64, f64) {
    let t = t_start + n as f64 * h;
    let t1 = (t_start + (n + 1) as f64 * h).min(t_end.max(t));
    (t, t1, t1 - t)
}

/// Stage inputs of the steps of a fixed-step run, formed once and shared by every run on
/// the same samples, hold, times and step: `values[n]` holds the torques at t_n, t_n + h_n/2
/// and just before t_n + h_n ([`InputSignal::at`], [`InputSignal::before`]; NF each), the
/// numbers [`super::Scratch::load`] would compute.
///
/// A cubic or band-limited reconstruction (24 taps) costs as much as a stage of a small
/// configuration, and an identification or a diagnosis simulates the same record
/// hundreds of times (one run per Jacobian column, per candidate); reading the stage
/// inputs back costs nothing next to it. Zero-order and linear holds are not stored
/// (one or two reads per torque).
#[derive(Debug)]
pub(crate) struct StageInputs {
    t_start: f64,
    t_end: f64,
    h: f64,
    nf: usize,
    /// Step n's three stage inputs, NF each: 3·NF per step.
    values: Vec<f64>,
}

/// What a [`StageInputs`] is for: the samples (by content), the hold, the run's times and
/// step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct StageKey {
    samples: u64,
    len: usize,
    nf: usize,
    hold: Hold,
    t0: u64,
    dt: u64,
    t_start: u64,
    t_end: u64,
    h: u64,
    steps: usize,
}

impl StageKey {
    fn bytes(&self) -> usize {
        3 * self.steps * self.nf * std::mem::size_of::<f64>()
    }
}

/// Most bytes one run's stage inputs may take to be stored.
const STAGE_INPUTS_MAX_BYTES: usize = 96 << 20;

/// Most bytes all stored stage inputs take (the least recently used are dropped).
const STAGE_CACHE_BYTES: usize = 384 << 20;

type StageEntry = (
    StageKey,
    std::sync::Arc<std::sync::OnceLock<std::sync::Arc<StageInputs>>>,
);

/// The stored stage inputs, most recently used first.
static STAGE_CACHE: std::sync::Mutex<Vec<StageEntry>> = std::sync::Mutex::new(Vec::new());

impl StageInputs {
    /// The stage inputs of the `steps` steps of `h` from `t_start` to `t_end` under
    /// `input`, formed on first use and stored (None for a zero-order or linear hold, no
    /// samples, or a run too long to store: the caller samples as it goes).
    pub(crate) fn cached(
        input: &InputSignal,
        (t_start, t_end): (f64, f64),
        h: f64,
        steps: usize,
    ) -> Option<std::sync::Arc<StageInputs>> {
        use std::hash::{Hash, Hasher};
        if !matches!(input.hold, Hold::Cubic | Hold::Bandlimited) || steps == 0 {
            return None;
        }
        let len = input.tau.first().map_or(0, Vec::len);
        if len == 0 || input.tau.iter().any(|c| c.len() != len) {
            return None;
        }
        let mut hasher = std::collections::hash_map::DefaultHasher::new();
        for col in input.tau {
            for v in col {
                v.to_bits().hash(&mut hasher);
            }
        }
        let key = StageKey {
            samples: hasher.finish(),
            len,
            nf: input.tau.len(),
            hold: input.hold,
            t0: input.t0.to_bits(),
            dt: input.dt.to_bits(),
            t_start: t_start.to_bits(),
            t_end: t_end.to_bits(),
            h: h.to_bits(),
            steps,
        };
        if key.bytes() > STAGE_INPUTS_MAX_BYTES {
            return None;
        }
        let slot = {
            // A poisoned lock only means another run panicked while holding it; the list
            // itself is always whole.
            let mut cache = STAGE_CACHE.lock().unwrap_or_else(|e| e.into_inner());
            let slot = match cache.iter().position(|(k, _)| *k == key) {
                Some(i) => cache.remove(i).1,
                None => Default::default(),
            };
            cache.insert(0, (key, std::sync::Arc::clone(&slot)));
            let mut total = 0;
            cache.retain(|(k, _)| {
                total += k.bytes();
                total <= STAGE_CACHE_BYTES
            });
            slot
        };
        let stages = slot.get_or_init(|| {
            let nf = input.tau.len();
            let mut values = vec![0.0; 3 * nf * steps];
            for (n, v) in values.chunks_exact_mut(3 * nf).enumerate() {
                let (t, _, hs) = step_span(t_start, t_end, h, n);
                let (a, rest) = v.split_at_mut(nf);
                let (b, c) = rest.split_at_mut(nf);
                input.stage_inputs(t, hs, [a, b, c]);
            }
            std::sync::Arc::new(StageInputs {
                t_start,
                t_end,
                h,
                nf,
                values,
            })
        });
        Some(std::sync::Arc::clone(stages))
    }

    /// Step `n`'s three stage inputs (3·NF) if a step from `t0` of `hs` is that step
    /// (the same numbers), else None (a step split at a friction-bias switch).
    pub(crate) fn step(&self, n: usize, t0: f64, hs: f64) -> Option<&[f64]> {
        let v = self.values.get(3 * self.nf * n..3 * self.nf * (n + 1))?;
        let (t, _, h) = step_span(self.t_start, self.t_end, self.h, n);
        (t == t0 && h == hs).then_some(v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The stored stage inputs are the numbers sampling gives at every step's stage times
    /// (the last, shorter step included), a split step is not served from them, a second
    /// run shares them, and other samples get their own.
    #[test]
    fn stored_stage_inputs_equal_sampling_and_follow_the_samples() {
        let tau: Vec<Vec<f64>> = (0..2)
            .map(|a| {
                (0..50)
                    .map(|k| ((k * (a + 3)) as f64 * 0.37).sin())
                    .collect()
            })
            .collect();
        let input = InputSignal {
            t0: 0.001,
            dt: 0.01,
            tau: &tau,
            hold: Hold::Bandlimited,
        };
        let (t_start, t_end, h) = (0.003, 0.4137, 1.0 / 1200.0);
        let steps = ((t_end - t_start) / h - 1e-9_f64).ceil() as usize;
        let stages = StageInputs::cached(&input, (t_start, t_end), h, steps).unwrap();
        let mut direct = [0.0; 6];
        for n in 0..steps {
            let (t, _, hs) = step_span(t_start, t_end, h, n);
            let (a, rest) = direct.split_at_mut(2);
            let (b, c) = rest.split_at_mut(2);
            input.at(t, a);
            input.at(t + hs / 2.0, b);
            input.before(t + hs, c);
            assert_eq!(stages.step(n, t, hs), Some(&direct[..]), "step {n}");
            assert_eq!(stages.step(n, t, hs / 2.0), None);
        }
        let (t, _, hs) = step_span(t_start, t_end, h, steps - 1);
        assert!(hs < 0.99 * h, "the last step is shorter: {hs}");
        assert!(stages.step(steps, t, hs).is_none());
        let again = StageInputs::cached(&input, (t_start, t_end), h, steps).unwrap();
        assert!(std::sync::Arc::ptr_eq(&stages, &again));
        let mut other = tau.clone();
        other[1][20] += 1e-9;
        let input = InputSignal {
            tau: &other,
            ..input
        };
        let changed = StageInputs::cached(&input, (t_start, t_end), h, steps).unwrap();
        assert!(!std::sync::Arc::ptr_eq(&stages, &changed));
        let zoh = InputSignal {
            hold: Hold::Zoh,
            ..input
        };
        assert!(StageInputs::cached(&zoh, (t_start, t_end), h, steps).is_none());
    }
}
