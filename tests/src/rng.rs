//! A deterministic generator for test data: a 64-bit LCG, so failures reproduce.

/// Numbers in `[-1, 1)` from a 64-bit linear congruential generator (Knuth's MMIX
/// constants), seeded by the test.
pub struct Lcg(pub u64);

impl Lcg {
    /// The next number in `[-1, 1)`.
    pub fn uniform(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((self.0 >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }
}
