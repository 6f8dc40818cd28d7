//! Seeded Gaussian measurement noise, reproducible sample by sample.
//!
//! Counter-based (SplitMix64 evaluated at position k, then Box-Muller) rather than a
//! stateful generator: the noise on sample k depends only on (seed, k), so it does not
//! change when a caller reads the output twice or skips a step, and it needs no
//! dependency whose stream could change between crate versions.
//!
//! In the `no_std` library so that the firmware's build script embeds the same sensor
//! noise as the host's experiments use (`flight`); its logarithm, square root and cosine
//! are `libm`'s.

/// SplitMix64's increment (the golden ratio in 64-bit fixed point).
const GAMMA: u64 = 0x9E37_79B9_7F4A_7C15;

/// SplitMix64's output function.
fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The SplitMix64 stream of `seed` at position `j`.
fn stream(seed: u64, j: u64) -> u64 {
    mix(mix(seed ^ GAMMA).wrapping_add(GAMMA.wrapping_mul(j + 1)))
}

/// A uniform number in `0..1` (53 bits), position `j` of the stream named by `seed`: the
/// same on every call, like the noise.
pub fn uniform(seed: u64, j: u64) -> f64 {
    (stream(seed, j) >> 11) as f64 / (1u64 << 53) as f64
}

/// White Gaussian noise with standard deviation `sigma`, indexed by sample number.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GaussianNoise {
    /// Standard deviation (in the unit of the signal it is added to).
    pub sigma: f64,
    /// Seed; different seeds give independent-looking sequences.
    pub seed: u64,
}

impl GaussianNoise {
    /// Noise of standard deviation `sigma` drawn from the sequence named by `seed`.
    pub fn new(sigma: f64, seed: u64) -> Self {
        Self { sigma, seed }
    }

    /// The noise value of sample `k` (the same on every call).
    pub fn sample(&self, k: u64) -> f64 {
        if self.sigma == 0.0 {
            return 0.0;
        }
        // SplitMix64 stream of this seed at positions 2k and 2k + 1.
        let (h1, h2) = (stream(self.seed, 2 * k), stream(self.seed, 2 * k + 1));
        // 53-bit uniforms; u1 in (0, 1] so ln(u1) is finite.
        let scale = 1.0 / (1u64 << 53) as f64;
        let u1 = ((h1 >> 11) + 1) as f64 * scale;
        let u2 = (h2 >> 11) as f64 * scale;
        self.sigma * libm::sqrt(-2.0 * libm::log(u1)) * libm::cos(2.0 * core::f64::consts::PI * u2)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reproducible_and_gaussian_moments() {
        let noise = GaussianNoise::new(2.0, 7);
        assert_eq!(noise.sample(123), noise.sample(123));
        assert_ne!(noise.sample(123), GaussianNoise::new(2.0, 8).sample(123));
        let n = 200_000u64;
        let (mut sum, mut sq, mut quartic) = (0.0, 0.0, 0.0);
        for k in 0..n {
            let v = noise.sample(k) / 2.0;
            sum += v;
            sq += v * v;
            quartic += v * v * v * v;
        }
        let (mean, var) = (sum / n as f64, sq / n as f64);
        assert!(mean.abs() < 0.01, "mean {mean}");
        assert!((var - 1.0).abs() < 0.01, "variance {var}");
        // Kurtosis 3 distinguishes a Gaussian from, say, a uniform (1.8).
        assert!((quartic / n as f64 - 3.0).abs() < 0.1);
        assert_eq!(GaussianNoise::new(0.0, 1).sample(5), 0.0);
    }
}
