//! What a generated error-state filter calls on a state it is given: each rotation's
//! quaternion checked and normalised. Written once, generic over `f32` and `f64`; the
//! modules of each scalar are their entry points.

use crate::covariance::Real;

/// How far a given quaternion's norm may be from one: a rotation written with a few
/// digits, or normalised in another precision, is accepted and normalised; anything
/// further is not a rotation.
const NORM_TOLERANCE: f64 = 0.01;

/// `x` with the quaternions `[x, y, z, w]` starting at each of `firsts` divided by their
/// norm; `None` if a norm is not within 1 % of one (or `x` is too short to hold them).
pub(crate) fn with_unit_rotations<T: Real, const N: usize>(
    x: &[T; N],
    firsts: &[usize],
    sqrt: fn(T) -> T,
    tolerance: T,
) -> Option<[T; N]> {
    let mut unit = *x;
    let one = T::from_count(1);
    for &first in firsts {
        let q = unit.get_mut(first..first + 4)?;
        let squared = q.iter().fold(T::ZERO, |sum, &e| sum + e * e);
        let norm = sqrt(squared);
        let off = if norm > one { norm - one } else { one - norm };
        // False for NaN too.
        let near_unit = off <= tolerance;
        if !near_unit {
            return None;
        }
        for e in q.iter_mut() {
            *e = *e / norm;
        }
    }
    Some(unit)
}

/// [`NORM_TOLERANCE`] in `f32`.
#[allow(clippy::cast_possible_truncation)] // 0.01, well within f32.
pub(crate) const NORM_TOLERANCE_F32: f32 = NORM_TOLERANCE as f32;

/// [`NORM_TOLERANCE`] in `f64`.
pub(crate) const NORM_TOLERANCE_F64: f64 = NORM_TOLERANCE;
