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
/// [`PlantModel::simulate_at`]. Before the first sample the first value holds, after the
/// last the last.
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
