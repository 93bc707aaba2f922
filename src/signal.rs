//! Signal processing for the inverse-dynamic identification model (IDIM): digital IIR
//! low-pass design (Butterworth, Chebyshev type I), zero-phase filtering that reproduces
//! MATLAB's `filtfilt`, MATLAB's `decimate` and central differences.
//!
//! These are the data-preparation steps of IDIM-LS as used by the EMPS benchmark (Janot,
//! Gautier, Brunot 2019): position low-passed forward and backward by a 4th-order
//! Butterworth, velocities and accelerations by central differences, then parallel
//! decimation of the observation vector and of every regressor column.
//!
//! Filters are kept as cascades of second-order sections (direct form II transposed), which
//! is numerically safe at the low normalised cut-offs decimation needs (0.08 of Nyquist for
//! an 8th-order Chebyshev).

use std::f64::consts::PI;

/// A complex number (only what filter design needs).
#[derive(Debug, Clone, Copy, PartialEq)]
struct C64 {
    re: f64,
    im: f64,
}

impl C64 {
    fn new(re: f64, im: f64) -> Self {
        C64 { re, im }
    }
    fn add(self, o: C64) -> C64 {
        C64::new(self.re + o.re, self.im + o.im)
    }
    fn sub(self, o: C64) -> C64 {
        C64::new(self.re - o.re, self.im - o.im)
    }
    fn mul(self, o: C64) -> C64 {
        C64::new(
            self.re * o.re - self.im * o.im,
            self.re * o.im + self.im * o.re,
        )
    }
    fn div(self, o: C64) -> C64 {
        let d = o.re * o.re + o.im * o.im;
        C64::new(
            (self.re * o.re + self.im * o.im) / d,
            (self.im * o.re - self.re * o.im) / d,
        )
    }
    fn scale(self, k: f64) -> C64 {
        C64::new(self.re * k, self.im * k)
    }
}

/// One second-order section `(b0 + b1 z⁻¹ + b2 z⁻²) / (1 + a1 z⁻¹ + a2 z⁻²)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Biquad {
    /// Numerator `[b0, b1, b2]`.
    pub b: [f64; 3],
    /// Denominator `[a1, a2]` (a0 = 1).
    pub a: [f64; 2],
}

impl Biquad {
    /// One sample `u` through the section (transposed direct form II) with state `z`;
    /// returns the output.
    #[inline(always)]
    fn step(&self, u: f64, z: &mut [f64; 2]) -> f64 {
        let y = self.b[0] * u + z[0];
        z[0] = self.b[1] * u - self.a[0] * y + z[1];
        z[1] = self.b[2] * u - self.a[1] * y;
        y
    }
}

/// [`Sos::run`] for `N` sections: the sections and their states in local arrays.
fn cascade<const N: usize>(sections: &[Biquad], x: &mut [f64], zi: &[[f64; 2]], x0: f64) {
    let s: [Biquad; N] = std::array::from_fn(|i| sections[i]);
    let mut z: [[f64; 2]; N] = std::array::from_fn(|i| [zi[i][0] * x0, zi[i][1] * x0]);
    for v in x.iter_mut() {
        let mut u = *v;
        for i in 0..N {
            u = s[i].step(u, &mut z[i]);
        }
        *v = u;
    }
}

/// A digital IIR filter as a cascade of second-order sections.
#[derive(Debug, Clone, PartialEq)]
pub struct Sos {
    /// Sections, applied in order.
    pub sections: Vec<Biquad>,
    /// Filter order (number of poles).
    pub order: usize,
}

/// Analog low-pass prototype poles (cut-off 1 rad/s) and gain → digital SOS by the bilinear
/// transform with pre-warping, as `scipy.signal.butter`/`cheby1` and MATLAB do.
fn lowpass_from_prototype(poles: &[C64], gain: f64, wn: f64) -> Sos {
    let n = poles.len();
    // Pre-warp (sampling frequency 2, so that wn is relative to Nyquist).
    let fs2 = 4.0; // 2·fs with fs = 2
    let warped = fs2 * (PI * wn / 2.0).tan();
    let p: Vec<C64> = poles.iter().map(|p| p.scale(warped)).collect();
    let k = gain * warped.powi(n as i32);
    // Bilinear transform: z = (fs2 + p) / (fs2 - p); zeros at z = -1.
    let pd: Vec<C64> = p
        .iter()
        .map(|&p| C64::new(fs2, 0.0).add(p).div(C64::new(fs2, 0.0).sub(p)))
        .collect();
    let mut denom = C64::new(1.0, 0.0);
    for &pp in &p {
        denom = denom.mul(C64::new(fs2, 0.0).sub(pp));
    }
    let mut kd = k / denom.re;
    // Pair conjugate poles into sections; a real pole (odd order) gets a first-order section.
    let mut sections = Vec::new();
    let mut used = vec![false; n];
    for i in 0..n {
        if used[i] {
            continue;
        }
        used[i] = true;
        let pi = pd[i];
        if pi.im.abs() < 1e-14 {
            sections.push(Biquad {
                b: [1.0, 1.0, 0.0],
                a: [-pi.re, 0.0],
            });
            continue;
        }
        // Find its conjugate.
        let j = (0..n)
            .filter(|&j| !used[j])
            .min_by(|&x, &y| {
                let dx = (pd[x].re - pi.re).abs() + (pd[x].im + pi.im).abs();
                let dy = (pd[y].re - pi.re).abs() + (pd[y].im + pi.im).abs();
                dx.total_cmp(&dy)
            })
            .expect("complex poles come in conjugate pairs");
        used[j] = true;
        sections.push(Biquad {
            b: [1.0, 2.0, 1.0],
            a: [-2.0 * pi.re, pi.re * pi.re + pi.im * pi.im],
        });
    }
    // Put the overall gain on the first section.
    if let Some(s) = sections.first_mut() {
        for b in &mut s.b {
            *b *= kd;
        }
        kd = 1.0;
    }
    debug_assert_eq!(kd, 1.0);
    Sos { sections, order: n }
}

/// Butterworth low-pass of the given order; `wn` is the cut-off as a fraction of the Nyquist
/// frequency (MATLAB `butter(n, wn)`), in (0, 1).
///
/// # Panics
/// Never on valid input; `order == 0` or `wn` outside (0, 1) is a programming error and
/// asserts.
pub fn butter_lowpass(order: usize, wn: f64) -> Sos {
    assert!(
        order > 0 && wn > 0.0 && wn < 1.0,
        "butter: order ≥ 1, 0 < wn < 1"
    );
    let poles: Vec<C64> = (0..order)
        .map(|k| {
            let th = PI * (2 * k + order + 1) as f64 / (2 * order) as f64;
            C64::new(th.cos(), th.sin())
        })
        .collect();
    lowpass_from_prototype(&poles, 1.0, wn)
}

/// Chebyshev type I low-pass with pass-band ripple `rp_db` (dB); `wn` relative to Nyquist
/// (MATLAB `cheby1(n, rp, wn)`).
pub fn cheby1_lowpass(order: usize, rp_db: f64, wn: f64) -> Sos {
    assert!(order > 0 && wn > 0.0 && wn < 1.0 && rp_db > 0.0);
    let eps = (10f64.powf(rp_db / 10.0) - 1.0).sqrt();
    let mu = (1.0 / eps).asinh() / order as f64;
    let poles: Vec<C64> = (0..order)
        .map(|k| {
            let th = PI * (2 * k + 1) as f64 / (2 * order) as f64;
            C64::new(-mu.sinh() * th.sin(), mu.cosh() * th.cos())
        })
        .collect();
    let mut gain = poles
        .iter()
        .fold(C64::new(1.0, 0.0), |acc, p| acc.mul(p.scale(-1.0)))
        .re;
    if order.is_multiple_of(2) {
        gain /= (1.0 + eps * eps).sqrt();
    }
    lowpass_from_prototype(&poles, gain, wn)
}

impl Sos {
    /// The equivalent transfer function `(b, a)` with `a[0] = 1` (for tests and reports).
    pub fn to_tf(&self) -> (Vec<f64>, Vec<f64>) {
        let mut b = vec![1.0];
        let mut a = vec![1.0];
        for s in &self.sections {
            b = poly_mul(&b, &s.b);
            a = poly_mul(&a, &[1.0, s.a[0], s.a[1]]);
        }
        let n = self.order + 1;
        b.truncate(n);
        a.truncate(n);
        (b, a)
    }

    /// Steady-state initial conditions of every section for a unit constant input
    /// (`scipy.signal.sosfilt_zi`).
    fn zi(&self) -> Vec<[f64; 2]> {
        let mut scale = 1.0;
        self.sections
            .iter()
            .map(|s| {
                let y = (s.b[0] + s.b[1] + s.b[2]) / (1.0 + s.a[0] + s.a[1]);
                let z2 = s.b[2] - s.a[1] * y;
                let z1 = s.b[1] - s.a[0] * y + z2;
                let out = [z1 * scale, z2 * scale];
                scale *= y;
                out
            })
            .collect()
    }

    /// Filter `x` in place through every section with initial states `zi · x0`.
    ///
    /// Each sample goes through the whole cascade before the next one is read: section s
    /// at sample k needs only its own state and section s − 1's output at k, so the
    /// sections' recursions overlap in the processor instead of running one after another
    /// over the whole signal. Every section computes the same operations in the same order
    /// as a section-by-section pass, so the result is the same to the bit.
    fn run(&self, x: &mut [f64], zi: &[[f64; 2]], x0: f64) {
        // The states live in registers where the number of sections is known at compile
        // time (the 4th- to 12th-order filters this crate designs).
        match self.sections.len() {
            1 => cascade::<1>(&self.sections, x, zi, x0),
            2 => cascade::<2>(&self.sections, x, zi, x0),
            3 => cascade::<3>(&self.sections, x, zi, x0),
            4 => cascade::<4>(&self.sections, x, zi, x0),
            5 => cascade::<5>(&self.sections, x, zi, x0),
            6 => cascade::<6>(&self.sections, x, zi, x0),
            _ => {
                let mut z: Vec<[f64; 2]> = zi.iter().map(|z0| [z0[0] * x0, z0[1] * x0]).collect();
                for v in x.iter_mut() {
                    let mut u = *v;
                    for (s, zs) in self.sections.iter().zip(z.iter_mut()) {
                        u = s.step(u, zs);
                    }
                    *v = u;
                }
            }
        }
    }

    /// Causal filtering from rest (MATLAB `filter`, zero initial state).
    pub fn filter(&self, x: &[f64]) -> Vec<f64> {
        let mut y = x.to_vec();
        let zi = vec![[0.0; 2]; self.sections.len()];
        self.run(&mut y, &zi, 0.0);
        y
    }

    /// Zero-phase forward-backward filtering as MATLAB `filtfilt`: odd reflection of
    /// `3·order` samples at both ends, steady-state initial conditions scaled by the first
    /// sample of each pass, forward pass, reversal, backward pass, reversal.
    ///
    /// Returns `None` when `x` is too short (≤ 3·order samples).
    pub fn filtfilt(&self, x: &[f64]) -> Option<Vec<f64>> {
        let nfact = 3 * self.order;
        let n = x.len();
        if n <= nfact {
            return None;
        }
        let mut ext = Vec::with_capacity(n + 2 * nfact);
        for i in (1..=nfact).rev() {
            ext.push(2.0 * x[0] - x[i]);
        }
        ext.extend_from_slice(x);
        for i in 1..=nfact {
            ext.push(2.0 * x[n - 1] - x[n - 1 - i]);
        }
        let zi = self.zi();
        let x0 = ext[0];
        self.run(&mut ext, &zi, x0);
        ext.reverse();
        let x0 = ext[0];
        self.run(&mut ext, &zi, x0);
        ext.reverse();
        Some(ext[nfact..nfact + n].to_vec())
    }
}

fn poly_mul(p: &[f64], q: &[f64]) -> Vec<f64> {
    let mut r = vec![0.0; p.len() + q.len() - 1];
    for (i, a) in p.iter().enumerate() {
        for (j, b) in q.iter().enumerate() {
            r[i + j] += a * b;
        }
    }
    r
}

/// MATLAB `decimate(x, r)` with its default IIR filter: an 8th-order Chebyshev type I
/// low-pass (0.05 dB ripple, cut-off 0.8/r of Nyquist) applied with `filtfilt`, then every
/// r-th sample, aligned so that the last sample is kept.
///
/// Returns `None` when `x` is too short for the filter.
pub fn decimate(x: &[f64], r: usize) -> Option<Vec<f64>> {
    if r <= 1 {
        return Some(x.to_vec());
    }
    let f = cheby1_lowpass(8, 0.05, 0.8 / r as f64);
    let y = f.filtfilt(x)?;
    Some(decimation_indices(x.len(), r).map(|i| y[i]).collect())
}

/// Indices MATLAB `decimate` keeps for a record of length `n`: `nbeg:r:n` (1-based) with
/// `nbeg = r − (r·⌈n/r⌉ − n)`.
pub fn decimation_indices(n: usize, r: usize) -> impl Iterator<Item = usize> {
    let nout = n.div_ceil(r);
    let nbeg = r - (r * nout - n); // 1-based
    (nbeg - 1..n).step_by(r)
}

/// The modified Bessel function of the first kind, order 0: I0(z) = Σ_k ((z/2)^k / k!)²
/// (to double precision for |z| ≤ 20; the Kaiser window's).
pub fn bessel_i0(z: f64) -> f64 {
    let (mut term, mut sum) = (1.0, 1.0);
    for k in 1..80 {
        term *= z / (2.0 * k as f64);
        sum += term * term;
    }
    sum
}

/// How a sampled signal is differentiated.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Differentiator {
    /// Central differences, applied twice for the second derivative (MATLAB's practice and
    /// the EMPS benchmark's): accurate where the signal is slow against the sampling rate.
    #[default]
    Central,
    /// The band-limited differentiators ([`bandlimited_derivatives`]): exact to 1e-6 up to
    /// 0.4 of the sampling rate.
    Bandlimited,
}

impl Differentiator {
    /// First and second derivatives of `x` sampled every `dt`, both of `x`'s length.
    pub fn derivatives(self, x: &[f64], dt: f64) -> (Vec<f64>, Vec<f64>) {
        match self {
            Differentiator::Central => {
                let d1 = central_difference(x, dt);
                let d2 = central_difference(&d1, dt);
                (d1, d2)
            }
            Differentiator::Bandlimited => bandlimited_derivatives(x, dt),
        }
    }
}

impl std::str::FromStr for Differentiator {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "central" => Ok(Differentiator::Central),
            "bandlimited" => Ok(Differentiator::Bandlimited),
            _ => Err(format!("expected `central` or `bandlimited`, got `{s}`")),
        }
    }
}

impl std::fmt::Display for Differentiator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Differentiator::Central => "central differences",
            Differentiator::Bandlimited => "band-limited differentiators",
        })
    }
}

/// Samples each side of the band-limited differentiators ([`bandlimited_derivatives`]).
pub const DIFFERENTIATOR_TAPS: usize = 32;

/// The Kaiser window's β of the band-limited differentiators.
pub const DIFFERENTIATOR_BETA: f64 = 18.0;

/// First and second derivatives of a signal sampled every `dt` below its Nyquist frequency:
/// the derivatives of its band-limited (sinc) reconstruction at the samples, the ideal
/// differentiators' kernels h₁\[m\] = (−1)^(m+1)/(m·dt), h₂\[0\] = −π²/(3 dt²),
/// h₂\[m\] = 2 (−1)^(m+1)/(m² dt²) (m ≠ 0) windowed by a Kaiser window over
/// ±[`DIFFERENTIATOR_TAPS`] samples (β = [`DIFFERENTIATOR_BETA`]), h₂\[0\] set so that the
/// second's DC gain is 0.
///
/// Central differences (`d[k] = (x[k+1] − x[k−1]) / 2dt`, applied twice) have a gain of
/// sinc(ωdt) and sinc²(ωdt) against the true derivatives: 6 % and 12 % low at a fifth of
/// the sampling rate (a 60 Hz resonance sampled at 610 Hz). These stay within 1e-6 of the
/// true derivatives up to 0.4 of the sampling rate (0.8 of Nyquist; 3e-7 measured, 4e-7
/// in the design's frequency response; β = 8 left 3e-3 at low frequencies, the window's
/// side lobes against a kernel whose response has a kink at Nyquist;
/// `bandlimited_derivatives_are_exact_across_the_band`). Within [`DIFFERENTIATOR_TAPS`] of
/// either end the kernels would reach past the record, so those samples take central
/// differences. Both outputs have the input's length.
pub fn bandlimited_derivatives(x: &[f64], dt: f64) -> (Vec<f64>, Vec<f64>) {
    let n = x.len();
    let l = DIFFERENTIATOR_TAPS;
    let d1c = central_difference(x, dt);
    let d2c = central_difference(&d1c, dt);
    if n <= 2 * l + 1 {
        return (d1c, d2c);
    }
    let window: Vec<f64> = (0..=l)
        .map(|m| {
            let r = m as f64 / (l + 1) as f64;
            bessel_i0(DIFFERENTIATOR_BETA * (1.0 - r * r).sqrt()) / bessel_i0(DIFFERENTIATOR_BETA)
        })
        .collect();
    let sign = |m: usize| if m % 2 == 1 { 1.0 } else { -1.0 };
    let h1: Vec<f64> = (1..=l)
        .map(|m| window[m] * sign(m) / (m as f64 * dt))
        .collect();
    let h2: Vec<f64> = (1..=l)
        .map(|m| window[m] * 2.0 * sign(m) / ((m * m) as f64 * dt * dt))
        .collect();
    // The window moves the second kernel's DC gain off 0 (a constant would come out as a
    // curvature): h₂[0] restores it.
    let h20 = -2.0 * h2.iter().sum::<f64>();
    let (mut d1, mut d2) = (d1c, d2c);
    for k in l..n - l {
        let (mut a, mut b) = (0.0, h20 * x[k]);
        for m in 1..=l {
            a += h1[m - 1] * (x[k + m] - x[k - m]);
            b += h2[m - 1] * (x[k + m] + x[k - m]);
        }
        d1[k] = a;
        d2[k] = b;
    }
    (d1, d2)
}

/// Central differences: `d[k] = (x[k+1] − x[k−1]) / (2·dt)` for interior samples; the end
/// samples use one-sided differences so the output has the input's length.
pub fn central_difference(x: &[f64], dt: f64) -> Vec<f64> {
    let n = x.len();
    let mut d = vec![0.0; n];
    if n < 2 {
        return d;
    }
    for k in 1..n - 1 {
        d[k] = (x[k + 1] - x[k - 1]) / (2.0 * dt);
    }
    d[0] = (x[1] - x[0]) / dt;
    d[n - 1] = (x[n - 1] - x[n - 2]) / dt;
    d
}

/// Standard deviation of white measurement noise on a smooth sampled signal `y`, from its
/// data alone: the k-th difference of a signal whose samples follow a polynomial of degree
/// below k vanishes, while white noise of variance σ² gives differences of variance
/// C(2k, k) σ²; the median absolute difference / 0.6745 (a robust standard deviation,
/// insensitive to the few samples where the motion has fast content) divided by
/// √C(2k, k) estimates σ (k = 5, C = 252).
///
/// On the synthetic Freedom 6S files (σ = 2e-4 rad, quantisation 1e-4 rad, 100 Hz) it
/// gives 1.96e-4 to 2.24e-4 rad per joint. Returns 0 for fewer than 12 samples.
pub fn noise_sigma(y: &[f64]) -> f64 {
    const K: usize = 5;
    if y.len() < 2 * K + 2 {
        return 0.0;
    }
    let mut d = y.to_vec();
    for _ in 0..K {
        d = d.windows(2).map(|w| w[1] - w[0]).collect();
    }
    let mut a: Vec<f64> = d.iter().map(|x| x.abs()).collect();
    let mid = a.len() / 2;
    let (_, median, _) = a.select_nth_unstable_by(mid, f64::total_cmp);
    *median / 0.6745 / 252f64.sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: &[f64], b: &[f64], tol: f64) {
        assert_eq!(a.len(), b.len());
        for (x, y) in a.iter().zip(b) {
            assert!((x - y).abs() <= tol * (1.0 + y.abs()), "{x} vs {y}");
        }
    }

    #[test]
    fn bandlimited_derivatives_are_exact_across_the_band() {
        // sin(ωt) sampled at 1, ω up to 0.4 of the sampling rate; interior samples.
        let n = 400;
        let mut worst = (0.0f64, 0.0f64, 0.0);
        for i in 1..=40 {
            let f = 0.01 * i as f64;
            let w = 2.0 * std::f64::consts::PI * f;
            let x: Vec<f64> = (0..n).map(|k| (w * k as f64 + 0.3).sin()).collect();
            let (d1, d2) = bandlimited_derivatives(&x, 1.0);
            for k in DIFFERENTIATOR_TAPS..n - DIFFERENTIATOR_TAPS {
                let t = k as f64;
                let e1 = (d1[k] - w * (w * t + 0.3).cos()).abs() / w;
                let e2 = (d2[k] + w * w * (w * t + 0.3).sin()).abs() / (w * w);
                if e1.max(e2) > worst.0.max(worst.1) {
                    worst = (e1, e2, f);
                }
            }
        }
        eprintln!("worst relative error {worst:?}");
        assert!(worst.0 < 1e-6 && worst.1 < 1e-6, "{worst:?}");
    }

    // Reference values: scipy.signal 1.x, `butter(4, 0.2)` and `cheby1(8, 0.05, 0.08)`.
    #[test]
    fn butterworth_matches_scipy() {
        let (b, a) = butter_lowpass(4, 0.2).to_tf();
        close(
            &b,
            &[0.00482434, 0.01929737, 0.02894606, 0.01929737, 0.00482434],
            1e-7,
        );
        close(
            &a,
            &[1.0, -2.36951301, 2.31398841, -1.05466541, 0.18737949],
            1e-7,
        );
    }

    #[test]
    fn chebyshev_matches_scipy() {
        let (b, a) = cheby1_lowpass(8, 0.05, 0.08).to_tf();
        close(
            &b[..3],
            &[3.58632432e-09, 2.86905946e-08, 1.00417081e-07],
            1e-6,
        );
        close(
            &a,
            &[
                1.0,
                -7.39772047,
                24.07272776,
                -44.99891467,
                52.84346677,
                -39.91591435,
                18.93766581,
                -5.15917943,
                0.6178695,
            ],
            1e-7,
        );
    }

    #[test]
    fn filtfilt_matches_scipy_with_matlab_padding() {
        // scipy.signal.filtfilt(b, a, x, padlen=12) for butter(4, 0.2): MATLAB's padding.
        let x: Vec<f64> = (0..50)
            .map(|i| (i as f64 * 0.3).sin() + 0.1 * i as f64)
            .collect();
        let y = butter_lowpass(4, 0.2).filtfilt(&x).unwrap();
        let want = [
            (0, -8.97181987e-04),
            (1, 3.96506262e-01),
            (10, 1.14055842e+00),
            (25, 3.43552465e+00),
            (48, 5.67620016e+00),
            (49, 5.71016861e+00),
        ];
        for (i, v) in want {
            assert!((y[i] - v).abs() < 1e-7, "y[{i}] = {} vs {v}", y[i]);
        }
    }

    #[test]
    fn the_cascade_per_sample_equals_the_sections_in_turn_to_the_bit() {
        // The textbook order: each section over the whole signal, then the next.
        let f = cheby1_lowpass(8, 0.05, 0.8 / 10.0);
        let x: Vec<f64> = (0..2000)
            .map(|i| (i as f64 * 0.013).sin() + 0.3 * (i as f64 * 0.7).cos())
            .collect();
        let zi = f.zi();
        let mut by_section = x.clone();
        for (s, z0) in f.sections.iter().zip(&zi) {
            let (mut z1, mut z2) = (z0[0] * x[0], z0[1] * x[0]);
            for v in by_section.iter_mut() {
                let y = s.b[0] * *v + z1;
                z1 = s.b[1] * *v - s.a[0] * y + z2;
                z2 = s.b[2] * *v - s.a[1] * y;
                *v = y;
            }
        }
        let mut per_sample = x.clone();
        f.run(&mut per_sample, &zi, x[0]);
        assert_eq!(by_section, per_sample);
        // And the filter does something: the fast cosine is removed.
        let diff = x.iter().zip(&per_sample).map(|(a, b)| (a - b).abs());
        assert!(diff.fold(0.0, f64::max) > 0.2);
    }

    #[test]
    fn decimate_keeps_last_sample_alignment() {
        let idx: Vec<usize> = decimation_indices(25, 10).collect();
        assert_eq!(idx, vec![4, 14, 24]);
        // A constant passes unchanged (unit DC gain of the Chebyshev filter, even order:
        // the DC gain is the ripple floor 10^(-0.05/20)).
        let y = decimate(&[2.0; 100], 10).unwrap();
        let dc = 10f64.powf(-0.05 / 20.0);
        for v in y {
            assert!((v - 2.0 * dc * dc).abs() < 1e-9, "{v}");
        }
    }

    #[test]
    fn central_difference_of_quadratic_is_exact() {
        let dt = 0.01;
        let x: Vec<f64> = (0..10).map(|k| (k as f64 * dt).powi(2)).collect();
        let d = central_difference(&x, dt);
        for (k, v) in d.iter().enumerate().take(9).skip(1) {
            assert!((v - 2.0 * k as f64 * dt).abs() < 1e-12);
        }
    }

    /// A smooth multi-sine at 100 Hz (0.7 and 1.5 Hz, amplitude 1 rad) with white noise of
    /// σ = 2e-4 rad (the synthetic data's own Gaussian, fixed seed): the estimate is within 10 % of σ, and 0
    /// (to rounding) without noise.
    #[test]
    fn noise_sigma_recovers_white_noise_under_a_smooth_motion() {
        let mut rng = generated::inertia::Xorshift(0x2545_f491_4f6c_dd1d);
        let n = 4000;
        let smooth: Vec<f64> = (0..n)
            .map(|k| {
                let t = k as f64 * 0.01;
                (2.0 * std::f64::consts::PI * 0.7 * t).sin()
                    + 0.3 * (2.0 * std::f64::consts::PI * 1.5 * t).cos()
            })
            .collect();
        let noisy: Vec<f64> = smooth
            .iter()
            .map(|y| y + 2e-4 * crate::synthetic::gaussian(&mut rng))
            .collect();
        let s = noise_sigma(&noisy);
        assert!((s - 2e-4).abs() < 0.1 * 2e-4, "σ̂ = {s}");
        assert!(noise_sigma(&smooth) < 1e-6, "σ̂ = {}", noise_sigma(&smooth));
        assert_eq!(noise_sigma(&smooth[..5]), 0.0);
    }
}
