//! `f64` functions: `libm`'s, under the names [`crate::f32`] uses, so generated code in
//! either scalar calls this crate only. (A host has double precision in hardware; an MCU
//! without it runs `libm`'s software `f64` either way.)

/// Sine (`libm::sin`).
#[inline]
pub fn sin(x: f64) -> f64 {
    libm::sin(x)
}

/// Cosine (`libm::cos`).
#[inline]
pub fn cos(x: f64) -> f64 {
    libm::cos(x)
}

/// Sine and cosine of one argument, `(sin x, cos x)`, with one range reduction
/// (`libm::sincos`).
#[inline]
pub fn sin_cos(x: f64) -> (f64, f64) {
    libm::sincos(x)
}

/// Tangent (`libm::tan`).
#[inline]
pub fn tan(x: f64) -> f64 {
    libm::tan(x)
}

/// Exponential (`libm::exp`).
#[inline]
pub fn exp(x: f64) -> f64 {
    libm::exp(x)
}

/// Natural logarithm (`libm::log`).
#[inline]
pub fn ln(x: f64) -> f64 {
    libm::log(x)
}

/// Four-quadrant arctangent of `y / x` (`libm::atan2`).
#[inline]
pub fn atan2(y: f64, x: f64) -> f64 {
    libm::atan2(y, x)
}

/// Hyperbolic tangent (`libm::tanh`).
#[inline]
pub fn tanh(x: f64) -> f64 {
    libm::tanh(x)
}

/// Square root, correctly rounded (`libm::sqrt`).
#[inline]
pub fn sqrt(x: f64) -> f64 {
    libm::sqrt(x)
}

/// Whether every value is finite (neither infinite nor NaN), tested in floating point:
/// `v - v` is exactly `0` for a finite `v` and NaN for an infinite or NaN one, and a sum
/// of zeros is zero. A filter step checks its inputs so before using them. On a
/// Cortex-M4F this is one subtraction and one addition a value, where `is_finite` moves
/// each value to an integer register and tests its bits (for two values, 6 instructions
/// instead of 13).
#[inline(always)]
#[allow(clippy::eq_op)] // `v - v` is the test, not a mistake.
pub fn all_finite<const N: usize>(values: [f64; N]) -> bool {
    values
        .iter()
        .map(|&v| v - v)
        .reduce(|sum, zero| sum + zero)
        .is_none_or(|sum| sum == 0.0)
}

/// Absolute value (clears the sign bit; NaN stays NaN).
#[inline]
pub fn abs(x: f64) -> f64 {
    f64::from_bits(x.to_bits() & !(1 << 63))
}
