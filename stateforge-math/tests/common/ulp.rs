//! The error measure of the `f32` functions, shared by the crate's tests and `cargo xtask
//! math-ulps` (which includes this file by path), so that the bounds they state are of
//! the same quantity.

/// Error of `got` against `exact` in units in the last place of the `f32` nearest `exact`
/// (subnormal spacing below the normal range): a correctly rounded result is within 0.5.
/// Matching NaNs and infinities are 0; a NaN or infinity on one side only is infinite.
pub fn ulp_error(got: f32, exact: f64) -> f64 {
    if exact.is_nan() || got.is_nan() {
        return if exact.is_nan() && got.is_nan() {
            0.0
        } else {
            f64::INFINITY
        };
    }
    if got.is_infinite() || (exact as f32).is_infinite() {
        return if got == exact as f32 {
            0.0
        } else {
            f64::INFINITY
        };
    }
    let magnitude = (exact as f32).abs().max(f32::MIN_POSITIVE);
    let exponent = ((magnitude.to_bits() >> 23) as i32) - 127;
    (f64::from(got) - exact).abs() / 2f64.powi(exponent - 23)
}
