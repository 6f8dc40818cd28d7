//! What the firmware of `stateforge-codegen measure` needs beside the shared harness
//! (`measure.rs`): deterministic data, covariances given by their variances, and the line
//! it prints for each call.

use crate::measure::Calls;
use core::fmt::Debug;
use cortex_m_semihosting::hprintln;

/// A deterministic number in `[-1, 1)` for sample `k` and entry `i`: a hash of both
/// (a multiply-xorshift mix), the same on every run.
pub fn uniform(k: usize, i: usize) -> f32 {
    let mut z = (k as u32).wrapping_mul(0x9E37_79B9) ^ (i as u32).wrapping_mul(0x85EB_CA6B);
    z ^= 0x2545_F491;
    z ^= z >> 16;
    z = z.wrapping_mul(0x7FEB_352D);
    z ^= z >> 15;
    z = z.wrapping_mul(0x846C_A68B);
    z ^= z >> 16;
    (z >> 8) as f32 / (1_u32 << 23) as f32 - 1.0
}

/// The `N` x `N` matrix with `variance` on its diagonal and zeros elsewhere.
pub fn diag<const N: usize>(variance: f32) -> [[f32; N]; N] {
    let mut m = [[0.0; N]; N];
    for (i, row) in m.iter_mut().enumerate() {
        row[i] = variance;
    }
    m
}

/// The calls of one kind whose result says they did not take their data (a refused
/// measurement, a rejected input), and the first such result.
pub struct Refused<R> {
    count: u32,
    first: Option<R>,
}

impl<R: Copy + Debug> Refused<R> {
    /// None yet.
    pub fn new() -> Self {
        Refused {
            count: 0,
            first: None,
        }
    }

    /// Counts `result` if it was not `accepted`.
    pub fn add(&mut self, accepted: bool, result: R) {
        if !accepted {
            self.count += 1;
            self.first.get_or_insert(result);
        }
    }
}

/// `call <index> <mean> <stack> <refused> [<first refused result>]`: the mean
/// instructions of the calls read, the deepest stack of one call in bytes, and how many
/// calls did not take their data. (The trace gives each call's instructions and cycles.)
pub fn report<const N: usize, R: Copy + Debug>(
    index: usize,
    calls: &Calls<N>,
    stack: usize,
    refused: &Refused<R>,
) {
    let mean = calls.mean();
    match refused.first {
        Some(first) => hprintln!(
            "call {} {} {} {} {:?}",
            index,
            mean,
            stack,
            refused.count,
            first
        ),
        None => hprintln!("call {} {} {} 0", index, mean, stack),
    }
}
