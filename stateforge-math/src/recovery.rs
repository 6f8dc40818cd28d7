//! What a generated filter's recovery after a run of refused measurements calls (its
//! covariance's inflation), and the double Kalman filter's design aid naming a window
//! length. Written once, generic over `f32` and `f64`; the modules of each scalar are
//! their entry points.

use crate::covariance::Real;

/// Scales the packed covariance `packed` (upper triangle, row by row) by `scale` when
/// `scale` is above 1 and the scaled variances sum to at most `bound`; whether it did. A
/// common scale keeps a covariance positive semi-definite. NaN scales nothing.
#[inline(always)]
pub(crate) fn inflate<T: Real, const L: usize>(packed: &mut [T; L], scale: T, bound: T) -> bool {
    // The dimension `n`, `n (n + 1) / 2 = L`; row `i`'s variance follows the `n - i + 1`
    // entries of row `i - 1`.
    let mut n = 0;
    while n * (n + 1) / 2 < L {
        n += 1;
    }
    let (mut variances, mut diagonal) = (T::ZERO, 0);
    for row in 0..n {
        if let Some(&variance) = packed.get(diagonal) {
            variances = variances + variance;
        }
        diagonal += n - row;
    }
    let one = T::from_count(1);
    if !(scale > one && variances * scale <= bound) {
        return false;
    }
    for entry in packed.iter_mut() {
        *entry = *entry * scale;
    }
    true
}

/// The least-squares window length at which one window equation's error `noise`, averaged
/// over the window's `N - minimum_window + params` equations as if independent, is a
/// tenth of `terms`; never below `minimum_window`. `None` when `terms` is not positive
/// and finite, `noise` is negative or not finite, or more than 100 000 equations are
/// needed.
pub(crate) fn window_len_for<T: Real>(
    noise: T,
    terms: T,
    minimum_window: usize,
    params: usize,
) -> Option<usize> {
    let zero = T::ZERO;
    let known = terms > zero && terms.finite() && noise >= zero && noise.finite();
    if !known {
        return None;
    }
    let ratio = T::from_count(10) * noise / terms;
    let equations = ratio * ratio;
    if equations > T::from_count(100_000) {
        return None;
    }
    let whole = equations.ceil_count();
    let length = (whole.max(params) + minimum_window).saturating_sub(params);
    Some(length.max(minimum_window))
}
