//! The test a generated filter makes of every covariance it is given (an initial
//! covariance, a process or measurement noise): symmetric, and positive semi-definite by an
//! `L D L'` factorisation, in the filter's own scalar. Written once, generic over `f32`
//! and `f64`; [`crate::f32::is_covariance`] and [`crate::f64::is_covariance`] are its
//! entry points.

use core::ops::{Add, Div, Mul, Sub};

/// The arithmetic the test needs of a scalar.
pub(crate) trait Real:
    Copy
    + PartialOrd
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
{
    /// `0`.
    const ZERO: Self;
    /// The distance from 1 to the next value up.
    const EPSILON: Self;
    /// `n` as a value of this type (exact for the sizes a filter has).
    fn from_count(n: usize) -> Self;
    /// Whether the value is neither infinite nor NaN.
    fn finite(self) -> bool;
    /// The least whole number at or above the value, for a value in `[0, 1e5]`.
    fn ceil_count(self) -> usize;
}

impl Real for f32 {
    const ZERO: Self = 0.0;
    const EPSILON: Self = f32::EPSILON;
    #[allow(clippy::cast_precision_loss)] // A matrix dimension, far below 2^24.
    fn from_count(n: usize) -> Self {
        n as f32
    }
    fn finite(self) -> bool {
        self.is_finite()
    }
    // Within [0, 1e5]: the conversion is exact but for the fraction.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    #[allow(clippy::cast_precision_loss)]
    fn ceil_count(self) -> usize {
        let whole = self as usize;
        whole + usize::from((whole as f32) < self)
    }
}

impl Real for f64 {
    const ZERO: Self = 0.0;
    const EPSILON: Self = f64::EPSILON;
    #[allow(clippy::cast_precision_loss)] // A matrix dimension, far below 2^53.
    fn from_count(n: usize) -> Self {
        n as f64
    }
    fn finite(self) -> bool {
        self.is_finite()
    }
    // Within [0, 1e5]: the conversion is exact but for the fraction.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    #[allow(clippy::cast_precision_loss)]
    fn ceil_count(self) -> usize {
        let whole = self as usize;
        whole + usize::from((whole as f64) < self)
    }
}

/// Whether `m` is a covariance: non-negative diagonal, symmetric to within rounding
/// (`(m[i][j] - m[j][i])^2 <= eps (m[i][i] + t) (m[j][j] + t)`), and positive
/// semi-definite to within rounding. The entries must be finite (the caller has tested
/// that); a NaN arising on the way fails.
///
/// "To within rounding" is the shift `M + delta diag(M) + t I`, `delta = 2 n (n + 1) eps`,
/// `t = delta max_i m[i][i]`, whose `L D L'` factorisation (without pivoting, on the upper
/// triangle) must have positive pivots. Scaled to unit variances, `M` is a correlation
/// matrix `C`, and `delta diag(M)` forgives an indefiniteness of `delta` in `C`: what
/// rounding `C` to the scalar (`n eps`) and factorising it (`n^2 eps`, Cholesky's backward
/// error) can make of a semi-definite matrix, and nothing of a variance below zero or a
/// correlation beyond 1 by more than that. `t I` forgives the same relative to the largest
/// variance: a covariance computed in the scalar, as a filter's own is, carries rounding
/// errors of the size of the largest entries it was computed from, and a state measured
/// far more precisely than the others is left with a variance below them (the cantilever's
/// `f32` EKF with a precise sensor: a correlation of 2.5 between a variance of 5e-4 and one
/// of 1.6e6, an eigenvalue of -4.8 beside 1.6e6). `reset` takes back what `covariance()`
/// gives. A variance of 1e8 beside one of 1e-6 is therefore judged on its own scale only
/// where `t` is below it (in `f64`; in `f32` the small block is below the rounding of the
/// large variance). A zero variance (a state known exactly) with every other variance zero
/// has a zero pivot and must have zero covariances.
pub(crate) fn is_covariance<T: Real, const N: usize>(m: &[[T; N]; N]) -> bool {
    let Some((delta, shift)) = tolerances(m) else {
        return false;
    };
    is_symmetric(m, shift) && is_semidefinite_upper(m, delta, shift)
}

/// Whether `m`, read from its upper triangle (diagonal included), is a weight: positive
/// semi-definite to within rounding, as [`is_covariance`] judges it, whatever its lower
/// triangle holds. The entries read must be finite (the caller has tested that).
pub(crate) fn is_weight<T: Real, const N: usize>(m: &[[T; N]; N]) -> bool {
    tolerances(m).is_some_and(|(delta, shift)| is_semidefinite_upper(m, delta, shift))
}

/// The rounding [`is_covariance`] forgives of `m`: `delta = 2 n (n + 1) eps` and `t =
/// delta max_i m[i][i]`; `None` if a diagonal entry is negative (or NaN).
fn tolerances<T: Real, const N: usize>(m: &[[T; N]; N]) -> Option<(T, T)> {
    if !(0..N).all(|i| m[i][i] >= T::ZERO) {
        return None;
    }
    let n = T::from_count(N);
    let delta = (n + n) * (n + T::from_count(1)) * T::EPSILON;
    let mut largest = T::ZERO;
    for (i, row) in m.iter().enumerate() {
        if row[i] > largest {
            largest = row[i];
        }
    }
    Some((delta, delta * largest))
}

/// Whether `M + delta diag(M) + t I`, read from the upper triangle of `m`, factorises as
/// `L D L'` with positive pivots; a zero variance among zeros (an exactly known state, or
/// an unweighted one) must have zeros beside it.
#[allow(clippy::needless_range_loop)] // `L` is indexed by row and column, as written.
fn is_semidefinite_upper<T: Real, const N: usize>(m: &[[T; N]; N], delta: T, shift: T) -> bool {
    let mut l = [[T::ZERO; N]; N];
    let mut d = [T::ZERO; N];
    for j in 0..N {
        let mut pivot = m[j][j] + delta * m[j][j] + shift;
        for k in 0..j {
            pivot = pivot - l[j][k] * l[j][k] * d[k];
        }
        let exactly_known = m[j][j] == T::ZERO && pivot == T::ZERO;
        if !(pivot > T::ZERO || exactly_known) {
            return false;
        }
        for i in j + 1..N {
            let mut c = m[j][i];
            for k in 0..j {
                c = c - l[i][k] * l[j][k] * d[k];
            }
            if exactly_known {
                if c != T::ZERO {
                    return false;
                }
            } else {
                l[i][j] = c / pivot;
            }
        }
        d[j] = pivot;
    }
    true
}

/// Whether the lower triangle of `m` equals its upper one to within `sqrt(eps)` of the
/// entries' variances, each raised by `shift`.
fn is_symmetric<T: Real, const N: usize>(m: &[[T; N]; N], shift: T) -> bool {
    (0..N).all(|i| {
        (i + 1..N).all(|j| {
            let difference = m[i][j] - m[j][i];
            difference * difference <= T::EPSILON * (m[i][i] + shift) * (m[j][j] + shift)
        })
    })
}

/// Whether every variance is non-negative (a diagonal covariance); NaN fails.
pub(crate) fn all_non_negative<T: Real, const N: usize>(variances: &[T; N]) -> bool {
    variances.iter().all(|&v| v >= T::ZERO)
}

/// Whether every entry of `m`'s upper triangle (diagonal included) is finite: the entries
/// a filter reads of a symmetric matrix argument. A loop, so that a constructor checking a
/// 100-state covariance's 5050 entries is a few instructions of code, not one test each.
pub(crate) fn upper_triangle_finite<T: Real, const N: usize>(m: &[[T; N]; N]) -> bool {
    m.iter()
        .enumerate()
        .all(|(i, row)| row.iter().skip(i).all(|&v| v.finite()))
}

/// Whether every entry of the upper triangle of `m` between two blocks (`block[i] !=
/// block[j]`) is zero: the structural zeros of a filter's covariance whose coordinates
/// nothing in the model couples.
pub(crate) fn zero_between_blocks<T: Real, const N: usize>(
    m: &[[T; N]; N],
    block: &[usize; N],
) -> bool {
    m.iter().zip(block).enumerate().all(|(i, (row, a))| {
        row.iter()
            .zip(block)
            .skip(i)
            .all(|(&v, b)| a == b || v == T::ZERO)
    })
}

/// The upper triangle of `m` row by row, `L = N (N + 1) / 2` entries: how a filter stores
/// a symmetric matrix. A loop, so that storing a 100-state covariance is a few
/// instructions of code, not 5050 moves.
pub(crate) fn pack_upper<T: Real, const N: usize, const L: usize>(m: &[[T; N]; N]) -> [T; L] {
    const {
        assert!(
            L == N * (N + 1) / 2,
            "L is the length of the packed triangle"
        )
    };
    let mut packed = [T::ZERO; L];
    let upper = m.iter().enumerate().flat_map(|(i, row)| row.iter().skip(i));
    for (slot, &value) in packed.iter_mut().zip(upper) {
        *slot = value;
    }
    packed
}

/// The upper triangle, row by row, of the `K x K` block of `m` on the rows and columns
/// `rows` (in that order): how a filter stores one sensor's measurement noise out of a
/// whole `R`. Each entry is read from `m`'s upper triangle (a sensor may list its outputs
/// in another order than the model's); an index beyond `m` reads zero.
pub(crate) fn pack_upper_of<T: Real, const N: usize, const K: usize, const L: usize>(
    m: &[[T; N]; N],
    rows: &[usize; K],
) -> [T; L] {
    const {
        assert!(
            L == K * (K + 1) / 2,
            "L is the length of the packed triangle"
        )
    };
    let entry = |i: usize, j: usize| {
        let (i, j) = (i.min(j), i.max(j));
        m.get(i)
            .and_then(|row| row.get(j))
            .copied()
            .unwrap_or(T::ZERO)
    };
    let mut packed = [T::ZERO; L];
    let upper = rows
        .iter()
        .enumerate()
        .flat_map(|(a, &i)| rows.iter().skip(a).map(move |&j| (i, j)));
    for (slot, (i, j)) in packed.iter_mut().zip(upper) {
        *slot = entry(i, j);
    }
    packed
}

/// Whether every entry of `m` between two of the `blocks` (lists of row and column
/// indices) is zero: the noise of two sensors is independent, so a filter that stores each
/// sensor's own `R` rejects a whole `R` that correlates them. Both triangles are read.
pub(crate) fn is_block_diagonal<T: Real, const N: usize>(
    m: &[[T; N]; N],
    blocks: &[&[usize]],
) -> bool {
    let entry = |i: usize, j: usize| m.get(i).and_then(|row| row.get(j)).copied();
    blocks.iter().enumerate().all(|(a, rows)| {
        blocks.iter().skip(a + 1).all(|columns| {
            rows.iter().all(|&i| {
                columns.iter().all(|&j| {
                    [entry(i, j), entry(j, i)]
                        .iter()
                        .all(|v| v.is_none_or(|v| v == T::ZERO))
                })
            })
        })
    })
}

/// The symmetric matrix whose upper triangle, row by row, is `packed` (see
/// [`pack_upper`]).
pub(crate) fn unpack_symmetric<T: Real, const N: usize, const L: usize>(
    packed: &[T; L],
) -> [[T; N]; N] {
    const {
        assert!(
            L == N * (N + 1) / 2,
            "L is the length of the packed triangle"
        )
    };
    let mut m = [[T::ZERO; N]; N];
    let mut entries = packed.iter();
    // The matrix is indexed by row and column; the lower triangle mirrors the upper.
    #[allow(clippy::needless_range_loop)]
    for i in 0..N {
        for j in i..N {
            let value = entries.next().copied().unwrap_or(T::ZERO);
            m[i][j] = value;
            m[j][i] = value;
        }
    }
    m
}
