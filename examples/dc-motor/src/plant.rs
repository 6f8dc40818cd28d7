//! The simulated motor: the same physics as the model, integrated independently of the
//! generated code (RK4 with 20 sub-steps per sample, in `f64`), with sensor noise from a
//! small deterministic generator so runs repeat exactly.

use crate::motor::{in_f64::TS, index};

/// Physical constants of the simulated motor (the model's, in SI units).
const R: f64 = 1.0;
const L: f64 = 0.002;
const K_T: f64 = 0.05;
const J: f64 = 1.0e-4;
/// Sub-steps of the plant's integration per sample.
const SUBSTEPS: u32 = 20;

/// The true motor: its state and its unknown friction and load.
#[derive(Clone, Copy, Debug)]
pub struct Motor {
    /// Armature current [A].
    pub current: f64,
    /// Rotor speed [rad/s].
    pub speed: f64,
    /// Viscous friction [mN m s/rad].
    pub friction: f64,
    /// Load torque [mN m].
    pub load_torque: f64,
}

impl Motor {
    /// The derivative of `(current, speed)` under voltage `v`.
    fn derivative(&self, (i, w): (f64, f64), v: f64) -> (f64, f64) {
        (
            (v - R * i - K_T * w) / L,
            (K_T * i - 0.001 * (self.friction * w + self.load_torque)) / J,
        )
    }

    /// Applies the voltage `v` for one sample.
    pub fn advance(&mut self, v: f64) {
        let h = TS / f64::from(SUBSTEPS);
        for _ in 0..SUBSTEPS {
            let x = (self.current, self.speed);
            let k1 = self.derivative(x, v);
            let k2 = self.derivative((x.0 + 0.5 * h * k1.0, x.1 + 0.5 * h * k1.1), v);
            let k3 = self.derivative((x.0 + 0.5 * h * k2.0, x.1 + 0.5 * h * k2.1), v);
            let k4 = self.derivative((x.0 + h * k3.0, x.1 + h * k3.1), v);
            self.current += h / 6.0 * (k1.0 + 2.0 * k2.0 + 2.0 * k3.0 + k4.0);
            self.speed += h / 6.0 * (k1.1 + 2.0 * k2.1 + 2.0 * k3.1 + k4.1);
        }
    }

    /// The model's state vector `x` of the true motor (states, then parameters).
    pub fn state(&self) -> [f64; 4] {
        let mut x = [0.0; 4];
        x[index::I] = self.current;
        x[index::W] = self.speed;
        x[index::B] = self.friction;
        x[index::TAU_LOAD] = self.load_torque;
        x
    }
}

/// Gaussian noise from a xorshift generator (Box-Muller), seeded for repeatable runs.
pub struct Noise {
    state: u64,
}

impl Noise {
    /// A generator from a non-zero seed.
    pub fn new(seed: u64) -> Noise {
        Noise { state: seed.max(1) }
    }

    fn uniform(&mut self) -> f64 {
        self.state ^= self.state << 13;
        self.state ^= self.state >> 7;
        self.state ^= self.state << 17;
        // 53 random bits in (0, 1].
        ((self.state >> 11) + 1) as f64 / (1u64 << 53) as f64
    }

    /// A sample of the normal distribution with standard deviation `sigma`.
    pub fn normal(&mut self, sigma: f64) -> f64 {
        let (u1, u2) = (self.uniform(), self.uniform());
        sigma * libm::sqrt(-2.0 * libm::log(u1)) * libm::cos(2.0 * core::f64::consts::PI * u2)
    }
}
