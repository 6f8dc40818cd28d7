//! Deterministic measured sequences for the continuous filters, computed in `f32` the same
//! way on the host and on the Cortex-M4F: the papers' models' own generated `f32` dynamics
//! (`helicopter::f`, `mass_spring_damper::f`; `libm` is software, so its results are the
//! same on both), integer pseudo-random inputs and measurement noise. The firmware runs the
//! `f32` filters on them and the host the `f64` filters on the same values, widened.

use crate::{helicopter, mass_spring_damper};

/// A 32-bit linear congruential generator (Numerical Recipes' constants): integer only.
#[derive(Clone, Copy, Debug)]
struct Lcg(u32);

impl Lcg {
    /// A value uniform in `[-0.5, 0.5)`, from the generator's top 24 bits.
    fn next(&mut self) -> f32 {
        self.0 = self.0.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (self.0 >> 8) as f32 / 16_777_216.0 - 0.5
    }
}

/// One sample of a sequence: the time the sample interval starts, the input held over it
/// and the measurement at its end.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample<const U: usize, const Y: usize> {
    /// `t\[k-1\]` \[s\].
    pub t_prev: f32,
    /// `u\[k-1\]`.
    pub u_prev: [f32; U],
    /// `y\[k\]`.
    pub y: [f32; Y],
}

/// The helicopter of Kulkarni and Purwar from rest under rotor voltages switching every 0.7 s and
/// 0.9 s, encoders with uniform noise of +-1 mrad.
#[derive(Clone, Debug)]
pub struct Helicopter {
    truth: [f32; 6],
    k: u32,
    noise: Lcg,
}

impl Helicopter {
    /// The sequence from its first sample.
    pub fn new() -> Helicopter {
        Helicopter {
            truth: [0.0; 6],
            k: 0,
            noise: Lcg(4),
        }
    }
}

impl Default for Helicopter {
    fn default() -> Self {
        Self::new()
    }
}

impl Iterator for Helicopter {
    type Item = Sample<2, 2>;

    fn next(&mut self) -> Option<Self::Item> {
        let t_prev = self.k as f32 * helicopter::TS;
        let u_prev = [
            if (self.k / 700).is_multiple_of(2) {
                0.3
            } else {
                -0.1
            },
            if (self.k / 900).is_multiple_of(2) {
                0.2
            } else {
                -0.2
            },
        ];
        self.truth = helicopter::f(t_prev, &self.truth, &u_prev);
        self.k += 1;
        let clean = helicopter::h(t_prev + helicopter::TS, &self.truth);
        let y = [
            clean[0] + 2e-3 * self.noise.next(),
            clean[1] + 2e-3 * self.noise.next(),
        ];
        Some(Sample { t_prev, u_prev, y })
    }
}

/// The blade of Takács, Polóni and Rohal-Ilkiv in control mode (true 1/m = 5 1/kg) under a +-50 V random binary
/// input, with uniform laser noise of +-10 um.
#[derive(Clone, Debug)]
pub struct Blade {
    truth: [f32; 5],
    k: u32,
    random: Lcg,
}

impl Blade {
    /// The sequence from its first sample.
    pub fn new() -> Blade {
        Blade {
            truth: [1e-3, 0.0, 0.0, 0.0, 5.0],
            k: 0,
            random: Lcg(7),
        }
    }
}

impl Default for Blade {
    fn default() -> Self {
        Self::new()
    }
}

impl Iterator for Blade {
    type Item = Sample<1, 1>;

    fn next(&mut self) -> Option<Self::Item> {
        let t_prev = self.k as f32 * mass_spring_damper::TS;
        let u_prev = [if self.random.next() < 0.0 {
            -50.0
        } else {
            50.0
        }];
        self.truth = mass_spring_damper::f(&self.truth, &u_prev);
        self.k += 1;
        let y = [self.truth[0] + 2e-5 * self.random.next()];
        Some(Sample { t_prev, u_prev, y })
    }
}

/// The continuous-time EKF's tuning for the sequence: the paper's `x0`, `P0` (`gamma = 1`),
/// `Q` and `R` (Kulkarni and Purwar, sects. 4 and 6.1).
pub mod helicopter_tuning {
    /// Initial estimate.
    pub const X0: [f32; 6] = [0.05, 0.0, -0.05, 0.0, 0.0, 0.0];
    /// Initial covariance (diagonal).
    pub const P0: [f32; 6] = [1.05, 0.05, 1.0, 1.0, 1.0, 1.0];
    /// Process noise density (diagonal).
    pub const Q: [f32; 6] = [0.0099, 0.0022, 0.0894, 0.0017, 1.2678, 1.27];
    /// Measurement noise density (diagonal).
    pub const R: [f32; 2] = [0.0007, 0.00193];
}

/// The control-mode hybrid EKF's tuning for the sequence: the paper's `x0`, `P0`, `R` and
/// `Q = Q~ / T` (Takács et al., sect. 4.1), in the order `[q, q', eta1, eta2, 1/m]`.
pub mod blade_tuning {
    /// Initial estimate.
    pub const X0: [f32; 5] = [0.0, 0.0, 0.0, 0.0, 2.0];
    /// Initial covariance (diagonal).
    pub const P0: [f32; 5] = [1e-5, 1.0, 0.0, 0.0, 1e-4];
    /// Process noise density (diagonal), on the states it enters (`eta2`, `inv_m`):
    /// `2 alpha_n (0.63 F_e)^2 / T` on the shaping filter's drive, `1e2 / T` on 1/m.
    pub const Q: [f32; 2] = [31_752.0, 1e4];
    /// Measurement noise variance.
    pub const R: f32 = 1e-6;
}
