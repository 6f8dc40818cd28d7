//! A deterministic sequence of blade estimates for the MPC, computed in `f32` the same way
//! on the host and on the Cortex-M4F: the blade of Takács et al. simulated by the model's own
//! generated `f32` dynamics (`mass_spring_damper::f`, 500 Euler sub-steps a sample), struck
//! every second and damped by a clipped velocity feedback (so the sequence does not depend
//! on the controller under test), with 54 g added half-way through; the estimate is the
//! true position and velocity and a mass estimate that follows the true one with a lag, as
//! the control-mode EKF's does. The firmware runs the `f32` MPC on it and the host the
//! `f64` MPC on the same values, widened.

use crate::mass_spring_damper;

/// Samples between impacts (1 s).
pub const IMPACT_PERIOD: u32 = 100;
/// The sample from which 54 g sit on the blade (1/m from 5 to 1/0.254 1/kg).
pub const MASS_CHANGE: u32 = 150;
/// Velocity an impact adds [m/s]: about 6 mm of tip amplitude at 8 Hz.
const IMPACT_VELOCITY: f32 = 0.3;
/// Gain of the clipped velocity feedback damping the truth \[V s/m\], and its limit \[V\].
const DAMPING_GAIN: f32 = 2000.0;
const U_LIMIT: f32 = 100.0;
/// Fraction of the remaining error in 1/m the estimate closes each sample.
const MASS_TRACKING: f32 = 0.05;

/// The blade struck every [`IMPACT_PERIOD`] samples (alternating in sign), whose estimates
/// `[q, qd, eta1, eta2, inv_m]` (shaping-filter states zero) it yields sample by sample.
#[derive(Clone, Debug)]
pub struct BladeEstimates {
    truth: [f32; 5],
    inv_m_estimate: f32,
    k: u32,
}

impl BladeEstimates {
    /// The sequence from its first sample.
    pub fn new() -> BladeEstimates {
        BladeEstimates {
            truth: [0.0, 0.0, 0.0, 0.0, 5.0],
            inv_m_estimate: 5.0,
            k: 0,
        }
    }
}

impl Default for BladeEstimates {
    fn default() -> Self {
        Self::new()
    }
}

impl Iterator for BladeEstimates {
    type Item = [f32; 5];

    fn next(&mut self) -> Option<Self::Item> {
        if self.k.is_multiple_of(IMPACT_PERIOD) {
            let sign = if (self.k / IMPACT_PERIOD).is_multiple_of(2) {
                1.0
            } else {
                -1.0
            };
            self.truth[1] += sign * IMPACT_VELOCITY;
        }
        if self.k == MASS_CHANGE {
            self.truth[4] = 1.0 / (1.0 / 5.0 + 0.054);
        }
        let u = (-DAMPING_GAIN * self.truth[1]).clamp(-U_LIMIT, U_LIMIT);
        self.truth = mass_spring_damper::f(&self.truth, &[u]);
        self.inv_m_estimate += MASS_TRACKING * (self.truth[4] - self.inv_m_estimate);
        self.k += 1;
        Some([self.truth[0], self.truth[1], 0.0, 0.0, self.inv_m_estimate])
    }
}

/// The MPC's tuning on the sequence: the paper's weights `Q = C'C`, `R = 1e-10` and
/// bounds of +-100 V (Takács et al., sect. 4.1).
pub mod mpc_tuning {
    /// State weight on `[q, qd]`.
    pub const Q: [[f32; 2]; 2] = [[1.0, 0.0], [0.0, 0.0]];
    /// Input weight.
    pub const R: [[f32; 1]; 1] = [[1e-10]];
    /// Input bound \[V\].
    pub const U_MAX: f32 = 100.0;
}
