//! A deterministic "measured" sequence of the cantilever experiment, the same on every
//! machine: the firmware under QEMU and the host run the generated filters on it and must
//! agree. No floating-point library call is involved, so host and target compute the
//! same data bit for bit (IEEE arithmetic only).
//!
//! The beam is the Euler model with the Euler-equivalent parameters of wn = 20 rad/s,
//! zeta = 0.026, alpha = 0.5 (the notes, "Simulating the cantilever"); the input is the
//! paper's PRBS (+-100 V, 9-bit LFSR, each bit held 4 samples); the measurement noise is
//! uniform with standard deviation `NOISE_SIGMA`.

use crate::cantilever::in_f64::f;

/// Euler-equivalent `[x3, x4, x5]` of the beam (wn = 20 rad/s, zeta = 0.026, alpha = 0.5).
pub const TRUE_PARAMETERS: [f64; 3] = [
    -393.928_367_564_155_85,
    -6.940_855_531_862_915,
    0.492_410_459_455_194_8,
];
/// Standard deviation of the measurement noise \[mm\].
pub const NOISE_SIGMA: f64 = 1e-4;

/// One sample: the input applied from `k` to `k + 1` and the measurement `y\[k\]`, as the
/// `f32` values a sensor and a DAC would give.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// Input `u\[k\]` \[V\].
    pub u: f32,
    /// Measurement `y\[k\]` \[mm\].
    pub y: f32,
}

/// The sequence, sample by sample.
#[derive(Clone, Debug)]
pub struct Measured {
    x: [f64; 5],
    register: u16,
    held: u32,
    level: f64,
    noise: u64,
}

impl Default for Measured {
    fn default() -> Self {
        Self::new()
    }
}

impl Measured {
    /// The beam at rest at sample 0.
    #[must_use]
    pub fn new() -> Measured {
        let [x3, x4, x5] = TRUE_PARAMETERS;
        Measured {
            x: [0.0, 0.0, x3, x4, x5],
            register: 0x1FF,
            held: 0,
            level: 100.0,
            noise: 0x2545_F491_4F6C_DD1D,
        }
    }

    /// The same beam and input with another measurement noise sequence, from `seed`
    /// (`new()` is seed `0x2545_F491_4F6C_DD1D`; zero, which the generator cannot use, is
    /// taken as one).
    #[must_use]
    pub fn with_noise_seed(seed: u64) -> Measured {
        Measured {
            noise: seed.max(1),
            ..Measured::new()
        }
    }

    /// Uniform noise in `[-1, 1)` from a 64-bit xorshift generator.
    fn unit_noise(&mut self) -> f64 {
        self.noise ^= self.noise << 13;
        self.noise ^= self.noise >> 7;
        self.noise ^= self.noise << 17;
        // 53 high bits as a fraction in [0, 1), then to [-1, 1).
        let fraction = (self.noise >> 11) as f64 / (1u64 << 53) as f64;
        2.0 * fraction - 1.0
    }
}

impl Iterator for Measured {
    type Item = Sample;

    fn next(&mut self) -> Option<Sample> {
        if self.held == 0 {
            // x^9 + x^5 + 1, a maximal-length 9-bit LFSR.
            let bit = ((self.register >> 8) ^ (self.register >> 4)) & 1;
            self.register = ((self.register << 1) | bit) & 0x1FF;
            self.level = if bit == 1 { 100.0 } else { -100.0 };
            self.held = 4;
        }
        self.held -= 1;
        // Uniform on [-a, a) has standard deviation a / sqrt(3).
        let noise = NOISE_SIGMA * 1.732_050_807_568_877_2 * self.unit_noise();
        let sample = Sample {
            u: self.level as f32,
            y: (self.x[0] + noise) as f32,
        };
        self.x = f(&self.x, &[self.level]);
        Some(sample)
    }
}
