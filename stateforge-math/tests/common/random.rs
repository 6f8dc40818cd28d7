//! A small deterministic generator (xorshift64*) for sampled inputs, shared by the crate's
//! tests and `cargo xtask math-ulps` (which includes this file by path).

/// xorshift64* from a non-zero seed.
pub struct Random(pub u64);

impl Random {
    /// The next 64 random bits.
    pub fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
}
