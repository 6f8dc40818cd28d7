//! A deterministic simulation of the cantilever experiment for tests: the Euler model run
//! with Euler-equivalent parameters (generated-demo's notes, "Simulating the cantilever"), a PRBS of
//! +-100 V from a 9-bit LFSR with each bit held 4 samples, and Gaussian measurement noise.

use crate::reference::{euler_equivalent, f, State};

/// One sample of a simulated run.
#[derive(Clone, Copy, Debug)]
pub struct Sample {
    /// The true state `x[k]` (physical states, then the true parameters).
    pub truth: State,
    /// The measurement `y[k]`.
    pub y: f64,
    /// The input applied from `k` to `k + 1`.
    pub u: f64,
}

/// `steps` samples of the beam (wn = 20 rad/s, zeta = 0.026, alpha = 0.5) with noise of
/// standard deviation `sigma` mm, starting at rest.
pub fn run(steps: usize, sigma: f64, seed: u64) -> Vec<Sample> {
    let [x3, x4, x5] = euler_equivalent(20.0, 0.026, 0.5);
    let mut x = State::new(0.0, 0.0, x3, x4, x5);
    let mut prbs = Prbs::new();
    let mut noise = Gaussian::new(seed);
    (0..steps)
        .map(|_| {
            let u = prbs.next_input();
            let sample = Sample {
                truth: x,
                y: x[0] + sigma * noise.next(),
                u,
            };
            x = f(&x, u);
            sample
        })
        .collect()
}

/// +-100 V from a 9-bit maximal-length LFSR, each bit held 4 samples.
struct Prbs {
    register: u16,
    held: u32,
    level: f64,
}

impl Prbs {
    fn new() -> Prbs {
        Prbs {
            register: 0x1FF,
            held: 0,
            level: 100.0,
        }
    }

    fn next_input(&mut self) -> f64 {
        if self.held == 0 {
            // x^9 + x^5 + 1
            let bit = ((self.register >> 8) ^ (self.register >> 4)) & 1;
            self.register = ((self.register << 1) | bit) & 0x1FF;
            self.level = if bit == 1 { 100.0 } else { -100.0 };
            self.held = 4;
        }
        self.held -= 1;
        self.level
    }
}

/// Standard normal numbers from SplitMix64 and Box-Muller.
struct Gaussian {
    state: u64,
}

impl Gaussian {
    fn new(seed: u64) -> Gaussian {
        Gaussian { state: seed }
    }

    fn uniform(&mut self) -> f64 {
        self.state = self.state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        ((z >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }

    fn next(&mut self) -> f64 {
        let (a, b) = (self.uniform(), self.uniform());
        (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
    }
}
