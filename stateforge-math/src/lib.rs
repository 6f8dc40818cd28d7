//! Elementary functions for the code `stateforge` generates, in one `no_std` crate.
//!
//! [`f32`](mod@f32) computes every function in single precision only: range reduction
//! and polynomial evaluation are IEEE `f32` additions, multiplications and divisions
//! (never `f64`, never a fused multiply-add), so a Cortex-M4F, whose FPU has no double
//! precision, runs them in hardware, and a host computes the same bits. `libm`'s `f32`
//! functions compute in software `f64` there (about 1000 instructions a call).
//! [`f64`](mod@f64) delegates to `libm`, so a crate using generated code depends on this
//! crate alone, whatever its scalar. Both have `all_finite`, the test generated steps
//! make of their arguments, and `is_covariance`, the test of a covariance argument.
//!
//! # Accuracy (f32)
//!
//! Largest error against `libm`'s `f64` function of the same input, in units in the last
//! place of the `f32` result, measured over every `f32` input (`cargo xtask math-ulps`;
//! `atan2` over a dense grid and random pairs), and asserted on millions of samples by the
//! crate's tests:
//!
//! | function | domain | largest error (ulp) | edges |
//! |---|---|---|---|
//! | `sin`, `cos`, `sin_cos` | \|x\| ≤ 6433 ([`TRIG_ACCURATE`](crate::f32::TRIG_ACCURATE)) | 1.26 | beyond: finite, in \[-1, 1\], not accurate; ±inf, NaN → NaN; `sin(-0) = +0` |
//! | `tan` | \|x\| ≤ 6433 | 3.05 | beyond: finite, not accurate; ±inf, NaN → NaN |
//! | `exp` | all | 0.99 | > 88.72 → inf; < -103.97 → 0; subnormal results rounded once; NaN → NaN |
//! | `ln` | all | 0.83 | < 0 → NaN; ±0 → -inf; inf → inf; subnormals scaled exactly; NaN → NaN |
//! | `atan2` | all pairs | 2.07 (grid and 2^28 random pairs) | signed zeros and infinities as C's `atan2`; NaN → NaN |
//! | `tanh` | all | 1.33 | ±1 past ±9.01; `tanh(-0) = -0`; NaN → NaN |
//! | `sqrt` | all | 0.5 (correctly rounded) | `vsqrt.f32` on an Arm FPU, `libm::sqrtf` elsewhere; < 0 → NaN |
//!
//! The error is `|result - exact| / ulp`, the ulp of the `f32` nearest the exact value
//! (libm's `f64` of the same input). The numbers are the measured bounds the tests assert.
#![no_std]
#![deny(unsafe_code)]
#![warn(missing_docs)]

#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
mod arm;
mod covariance;
pub mod f32;
pub mod f64;
mod mpc_condense;
mod mpc_qp;
mod recovery;
mod rotation;
#[cfg(test)]
mod test_rng;

pub use mpc_condense::{CondensedInverse, PredictionProblem};
pub use mpc_qp::{HeldLimits, LimitRows, MpcQp, MpcQpSolution};

/// `value` unchanged, opaque to the optimiser (`core::hint::black_box`): what is read
/// through a reference it returns is not known to be what is read through another
/// reference to the same memory. A large generated filter step reads its covariance
/// through it for the tests it makes before storing anything, and through the field
/// itself for the stores: the compiler then loads each entry again where the stores need
/// it, instead of keeping every entry the tests read until its store (hundreds of values,
/// spilled to the stack). It affects the code's speed only, never its result.
#[inline(always)]
#[must_use]
pub fn opaque<T>(value: T) -> T {
    core::hint::black_box(value)
}

/// A filter stage's count of the measurements it refused in a row, before any (and after
/// one it took): what the generated code stores in it.
pub const NO_REFUSALS: u32 = 0;

/// Counts a refused measurement in `count`, a filter stage's refusals in a row: whether it
/// is the `limit`-th in a row, when the count starts again from [`NO_REFUSALS`] and the
/// stage recovers (scales its covariance). Saturates; never overflows.
#[must_use]
#[inline(always)]
pub fn refusal_run_complete(count: &mut u32, limit: u32) -> bool {
    let counted = count.saturating_add(1);
    if counted >= limit {
        *count = NO_REFUSALS;
        true
    } else {
        *count = counted;
        false
    }
}
