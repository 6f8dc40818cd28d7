//! Deterministic measured sequences for the firmware checks of the compile-time designed
//! observers: the piecewise beam (of the piecewise linear beam report) under the 35 Hz
//! mass-unbalance force, and a flexible-arm hub angle (of Shults, Brubaker and Lee). The
//! firmware embeds them (computed on the host when
//! it is built) and the host filters the same `f32` values, so both must agree.

use crate::piecewise_beam::in_f64 as beam;

/// Uniform noise in `[-1, 1)` from a 64-bit xorshift generator.
fn unit_noise(state: &mut u64) -> f64 {
    *state ^= *state << 13;
    *state ^= *state >> 7;
    *state ^= *state << 17;
    let fraction = (*state >> 11) as f64 / (1u64 << 53) as f64;
    2.0 * fraction - 1.0
}

/// `sqrt(3)`: uniform noise in `[-a, a)` has standard deviation `a / sqrt(3)`.
const SQRT_3: f64 = 1.732_050_807_568_877_2;

/// One beam sample: the force `u\[k\]` \[N\] and the LVDTs `y\[k\]` \[m\].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BeamSample {
    /// Measured force.
    pub u: f32,
    /// Measured `[q_act, q_mid]`.
    pub y: [f32; 2],
}

/// The beam (its observers' own discrete model, `piecewise_beam::f`) driven at 35 Hz from
/// rest, with uniform LVDT noise of standard deviation `sqrt(R_LVDT)`.
#[derive(Clone, Debug)]
pub struct BeamMeasured {
    x: [f64; 6],
    k: u32,
    noise: u64,
}

impl Default for BeamMeasured {
    fn default() -> Self {
        Self::new()
    }
}

impl BeamMeasured {
    /// Excitation frequency \[Hz\].
    pub const FREQUENCY: f64 = 35.0;

    /// The beam at rest at sample 0.
    #[must_use]
    pub fn new() -> BeamMeasured {
        BeamMeasured {
            x: [0.0; 6],
            k: 0,
            noise: 0x9E37_79B9_7F4A_7C15,
        }
    }
}

impl Iterator for BeamMeasured {
    type Item = BeamSample;

    fn next(&mut self) -> Option<BeamSample> {
        let w = 2.0 * core::f64::consts::PI * Self::FREQUENCY;
        let u = beam::C_H * w * w * libm::sin(w * f64::from(self.k) * beam::TS);
        let amplitude = libm::sqrt(beam::R_LVDT) * SQRT_3;
        let y = [
            self.x[0] + amplitude * unit_noise(&mut self.noise),
            self.x[1] + amplitude * unit_noise(&mut self.noise),
        ];
        self.x = beam::f(&self.x, &[u]);
        self.k += 1;
        Some(BeamSample {
            u: u as f32,
            y: [y[0] as f32, y[1] as f32],
        })
    }
}

/// A flexible-arm hub angle \[rad\] sampled at 100 Hz (a 0.25 Hz slew and flexible motion at
/// 1.1 and 3.3 Hz) with uniform noise of variance 1e-4, as `f32` samples.
#[derive(Clone, Debug)]
pub struct HubMeasured {
    k: u32,
    noise: u64,
}

impl Default for HubMeasured {
    fn default() -> Self {
        Self::new()
    }
}

impl HubMeasured {
    /// The sequence from sample 0.
    #[must_use]
    pub fn new() -> HubMeasured {
        HubMeasured {
            k: 0,
            noise: 0x2545_F491_4F6C_DD1D,
        }
    }
}

impl Iterator for HubMeasured {
    type Item = f32;

    fn next(&mut self) -> Option<f32> {
        let t = f64::from(self.k) * 0.01;
        let two_pi = 2.0 * core::f64::consts::PI;
        let angle = 0.4 * libm::sin(two_pi * 0.25 * t)
            + 0.05 * libm::sin(two_pi * 1.1 * t + 0.4)
            + 0.01 * libm::sin(two_pi * 3.3 * t + 1.3);
        self.k += 1;
        Some((angle + 0.01 * SQRT_3 * unit_noise(&mut self.noise)) as f32)
    }
}
