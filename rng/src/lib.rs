//! xorshift64* (Vigna, *An experimental exploration of Marsaglia's xorshift generators,
//! scrambled*, ACM TOMS 42, 2016): the one small deterministic random generator of lockstep,
//! shared by the generator's generation-time checks (`codegen`) and the runtime's
//! reproducible samples (`generated::inertia`, identification checks). Its own crate because
//! the generator cannot depend on the kernels crate it builds.

/// xorshift64* with the state in the tuple (a non-zero seed; zero stays zero).
#[derive(Debug, Clone)]
pub struct Xorshift(pub u64);

impl Xorshift {
    /// A uniform sample in `[lo, hi)` (53 random bits).
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let x = (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 / (1u64 << 53) as f64;
        lo + (hi - lo) * x
    }
}

#[cfg(test)]
mod tests {
    use super::Xorshift;

    /// The first states and outputs of seed 1, computed independently (Python's big
    /// integers, masked to 64 bits): states 0x2000001, 0x4004000802801; outputs
    /// 0x47e4ce4b896cdd1d, 0xabcfa6a8e079651d, of which `uniform` takes the top 53 bits.
    #[test]
    fn the_sequence_is_xorshift64_star() {
        let mut r = Xorshift(1);
        let top53 = |x: u64| (x >> 11) as f64 / (1u64 << 53) as f64;
        assert_eq!(r.uniform(0.0, 1.0), top53(0x47e4_ce4b_896c_dd1d));
        assert_eq!(r.0, 0x200_0001);
        assert_eq!(r.uniform(0.0, 1.0), top53(0xabcf_a6a8_e079_651d));
        assert_eq!(r.0, 0x4_0040_0080_2801);
        // Samples stay in [lo, hi).
        let mut r = Xorshift(7);
        assert!((0..1000)
            .map(|_| r.uniform(-2.0, 3.0))
            .all(|v| (-2.0..3.0).contains(&v)));
    }
}
