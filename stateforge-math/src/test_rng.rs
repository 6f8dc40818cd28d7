//! The unit tests' random numbers: a small linear congruential generator, so that every
//! run draws the same problems.

/// A linear congruential generator (Knuth's MMIX constants).
pub struct Lcg(pub u64);

impl Lcg {
    /// The next number, uniform in `[-1, 1)`.
    pub fn uniform(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        // The top 21 bits, in [-1, 1).
        f64::from(u32::try_from(self.0 >> 43).unwrap_or(0)) / f64::from(1_u32 << 20) - 1.0
    }
}
