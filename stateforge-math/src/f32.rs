//! `f32` functions computed in `f32` only.
//!
//! Every function here is IEEE single-precision arithmetic (`+ - * /`, comparisons and bit
//! operations on the representation), never `f64` and never a fused multiply-add, so its
//! result is the same bit pattern on every target. `sqrt` is the one exception in kind,
//! not in value: the FPU's `vsqrt.f32` on an Arm target with hardware floats, `libm::sqrtf`
//! elsewhere, both correctly rounded.
//!
//! Methods: Cody and Waite's range reduction ("Software Manual for the Elementary
//! Functions") with a four-part pi/2, and the minimax polynomials of the Cephes library
//! (Moshier, "Methods and Programs for Mathematical Functions"): `sinf`, `cosf`, `expf`,
//! `logf`, `atanf`, `tanhf`.

/// `1.5 * 2^23`: adding it to an `f32` of magnitude below `2^22` rounds that value to an
/// integer (ties to even), which the sum's low mantissa bits then hold.
const ROUNDER: f32 = 12_582_912.0;
/// The bits of [`ROUNDER`].
const ROUNDER_BITS: i32 = 0x4B40_0000;

use core::f32::consts::{FRAC_1_SQRT_2, FRAC_2_PI, FRAC_PI_2, FRAC_PI_4, LOG2_E, PI};
/// pi/2 in four parts, `P1 + P2 + P3 + P4`, the first three of at most 12 significant
/// bits (so `k * Pi` is exact for `|k| < 2^12`), the last rounded: 64 bits of pi/2.
const PIO2_1: f32 = 1.570_312_5;
/// Second part of pi/2 (`0x39fda000`).
const PIO2_2: f32 = 4.837_513e-4;
/// Third part of pi/2 (`0x33a22000`).
const PIO2_3: f32 = 7.549_533_6e-8;
/// Fourth part of pi/2 (`0x2c34611a`).
const PIO2_4: f32 = 2.563_344e-12;

/// Largest `|x|` whose sine and cosine are reduced accurately: `4096 pi/2 - pi/4`, below
/// which the quadrant `k` has at most 12 bits and every product `k * Pi` above is exact.
/// Past it, [`sin_cos`] stays finite and within `[-1, 1]` but loses accuracy (the
/// reduction is not Payne and Hanek's).
pub const TRIG_ACCURATE: f32 = 6433.0;

/// The sine and cosine of `r + r_lo`, `|r| <= pi/4`, `|r_lo|` below half an ulp of `r`
/// (Cephes `sinf`, `cosf` polynomials in `r`; `r_lo` enters to first order:
/// `sin(r + r_lo) = sin r + r_lo cos r`, `cos(r + r_lo) = cos r - r_lo sin r`, with
/// `cos r` and `sin r` taken as 1 and `r`, which is exact to far below an ulp).
#[inline(always)]
fn sin_cos_kernel(r: f32, r_lo: f32) -> (f32, f32) {
    let z = r * r;
    let sin = r + (((-1.951_529_6e-4 * z + 8.332_161e-3) * z - 1.666_665_5e-1) * z * r + r_lo);
    let cos = ((2.443_315_7e-5 * z - 1.388_731_6e-3) * z + 4.166_664_6e-2) * z * z
        - (r * r_lo + 0.5 * z)
        + 1.0;
    (sin, cos)
}

/// `x - k pi/2` as `r + r_lo` (`|r_lo|` at most half an ulp of `r`), for
/// `|x| <=` [`TRIG_ACCURATE`] and `k` the nearest integer to `x 2/pi` (Cody and Waite).
/// `x - k P1 - k P2` is exact (each product is, and the differences fit in 24 bits);
/// subtracting `k P3` is rounded once, its error recovered exactly by Knuth's two-sum,
/// and `k P4` (below `2^-26`) joins that error: `r + r_lo` is `x - k pi/2` to about
/// `2^-45` relative, however near `x` is to a multiple of pi/2.
#[inline(always)]
fn reduce(x: f32, k: f32) -> (f32, f32) {
    let b = x - k * PIO2_1 - k * PIO2_2;
    let t = k * PIO2_3;
    let s = b - t;
    // Two-sum: s + e = b - t exactly.
    let bb = s - b;
    let e = (b - (s - bb)) - (t + bb);
    let c = e - k * PIO2_4;
    let r = s + c;
    (r, c - (r - s))
}

/// Places the kernel's values `(sin r, cos r)` in quadrant `q` (`x = r + q pi/2`).
#[inline(always)]
fn quadrant((s, c): (f32, f32), q: u32) -> (f32, f32) {
    let (sin, cos) = if q & 1 == 0 { (s, c) } else { (c, s) };
    // sin(r + q pi/2) is negative in quadrants 2 and 3, cos in quadrants 1 and 2.
    let sin_sign = (q & 2) << 30;
    let cos_sign = (q.wrapping_add(1) & 2) << 30;
    (
        f32::from_bits(sin.to_bits() ^ sin_sign),
        f32::from_bits(cos.to_bits() ^ cos_sign),
    )
}

/// `(sin x, cos x)` with one range reduction.
///
/// `x = r + k pi/2` with `k` the nearest integer to `x 2/pi` and `r` computed as
/// `x - k P1 - k P2 - k P3 - k P4` (Cody and Waite): each product is exact and, for
/// `|x| <=` [`TRIG_ACCURATE`], each subtraction but the last is exact, so `r` carries one
/// rounding. Largest measured error: 1.26 ulp (sine 1.255, cosine 1.247). Past
/// [`TRIG_ACCURATE`] the values lose accuracy gradually but stay finite and in `[-1, 1]`;
/// `sin_cos(±inf)` and `sin_cos(NaN)` are `(NaN, NaN)`. `sin_cos(-0.0) = (0.0, 1.0)`: the
/// sign of a zero sine is not kept (`r + r^3 p` adds zeros of opposite signs; keeping it
/// would cost a comparison on every call), which no model's arithmetic can tell apart.
#[inline]
pub fn sin_cos(x: f32) -> (f32, f32) {
    if abs(x) <= TRIG_ACCURATE {
        let shifted = x * FRAC_2_PI + ROUNDER;
        let k = shifted - ROUNDER;
        let (r, r_lo) = reduce(x, k);
        quadrant(sin_cos_kernel(r, r_lo), shifted.to_bits())
    } else {
        sin_cos_far(x)
    }
}

/// [`sin_cos`] past [`TRIG_ACCURATE`] and of infinities and NaN: the same reduction with
/// an inexact `k Pi`, its remainder held within `[-pi/4, pi/4]` so the polynomials stay
/// within `[-1, 1]`.
#[cold]
#[inline(never)]
fn sin_cos_far(x: f32) -> (f32, f32) {
    if !x.is_finite() {
        return (f32::NAN, f32::NAN);
    }
    let k_int = (x * FRAC_2_PI) as i64;
    let k = k_int as f32;
    let r = x - k * PIO2_1 - k * PIO2_2 - k * PIO2_3 - k * PIO2_4;
    let r = r.clamp(-FRAC_PI_4, FRAC_PI_4);
    quadrant(sin_cos_kernel(r, 0.0), k_int as u32)
}

/// Sine (see [`sin_cos`] for the method, accuracy and edges).
#[inline]
pub fn sin(x: f32) -> f32 {
    sin_cos(x).0
}

/// Cosine (see [`sin_cos`] for the method, accuracy and edges).
#[inline]
pub fn cos(x: f32) -> f32 {
    sin_cos(x).1
}

/// Tangent, `sin x / cos x` from one [`sin_cos`]: largest measured error 3.05 ulp for
/// `|x| <=` [`TRIG_ACCURATE`]; NaN for ±inf and NaN.
#[inline]
pub fn tan(x: f32) -> f32 {
    let (s, c) = sin_cos(x);
    s / c
}

/// `ln 2` in two parts: `LN2_HI` has 9 significant bits, so `k LN2_HI` is exact for the
/// `|k| <= 160` of [`exp`] and of [`ln`]'s exponent.
const LN2_HI: f32 = 0.693_359_4;
/// `ln 2 - LN2_HI`.
const LN2_LO: f32 = -2.121_944_4e-4;

/// `2^n` for `-126 <= n <= 127`, built from its exponent bits.
#[inline(always)]
fn pow2(n: i32) -> f32 {
    f32::from_bits((n.wrapping_add(127) as u32) << 23)
}

/// Exponential, by exponent splitting: `x = r + k ln 2` with `k` the nearest integer to
/// `x / ln 2` and `|r| <= ln 2 / 2`, `e^x = 2^k e^r`, `e^r` by the Cephes `expf`
/// polynomial, and `2^k` applied as two exact powers of two so that a subnormal result is
/// rounded once. Largest measured error: 0.99 ulp.
///
/// Edges: `exp(x) = inf` for `x > 88.72284` (and `+inf`); `0` for `x < -103.97208` (and
/// `-inf`); subnormal between; NaN for NaN.
#[inline]
pub fn exp(x: f32) -> f32 {
    // Past these bounds the result is inf or 0 anyway; within them, |k| <= 160 keeps
    // both powers of two below normal. NaN fails both comparisons and propagates.
    let x = x.clamp(-110.0, 89.0);
    let shifted = x * LOG2_E + ROUNDER;
    let k = shifted - ROUNDER;
    let k_int = (shifted.to_bits() as i32).wrapping_sub(ROUNDER_BITS);
    let r = x - k * LN2_HI - k * LN2_LO;
    let z = r * r;
    let p = (((((1.987_569_1e-4 * r + 1.398_199_9e-3) * r + 8.333_452e-3) * r + 4.166_579_6e-2)
        * r
        + 1.666_666_5e-1)
        * r
        + 0.5)
        * z
        + r
        + 1.0;
    let half = k_int >> 1;
    p * pow2(half) * pow2(k_int.wrapping_sub(half))
}

/// Natural logarithm: `x = m 2^e` with `m` in `[sqrt(1/2), sqrt(2))`,
/// `ln x = e ln 2 + ln m`, `ln m` by the Cephes `logf` polynomial in `m - 1`. Largest
/// measured error: 0.83 ulp.
///
/// Edges: NaN for `x < 0` and NaN; `-inf` for `±0`; `inf` for `inf`; subnormal `x` scaled
/// exactly first.
#[inline]
pub fn ln(x: f32) -> f32 {
    if (f32::MIN_POSITIVE..f32::INFINITY).contains(&x) {
        ln_normal(x, 0)
    } else {
        ln_special(x)
    }
}

/// [`ln`] of zeros, negatives, subnormals, infinity and NaN.
#[cold]
#[inline(never)]
fn ln_special(x: f32) -> f32 {
    if x.is_nan() || x < 0.0 {
        f32::NAN
    } else if x == 0.0 {
        f32::NEG_INFINITY
    } else if x == f32::INFINITY {
        x
    } else {
        // A positive subnormal times 2^25 is normal, exactly.
        ln_normal(x * 33_554_432.0, -25)
    }
}

/// `ln(x 2^scale)` for a normal positive finite `x`.
#[inline(always)]
fn ln_normal(x: f32, scale: i32) -> f32 {
    let bits = x.to_bits();
    let mut e = ((bits >> 23) as i32) - 126 + scale;
    // The mantissa in [0.5, 1).
    let m = f32::from_bits((bits & 0x007F_FFFF) | 0x3F00_0000);
    let f = if m < FRAC_1_SQRT_2 {
        e -= 1;
        m + m - 1.0
    } else {
        m - 1.0
    };
    let z = f * f;
    let p = ((((((((7.037_683_6e-2 * f - 1.151_461e-1) * f + 1.167_699_9e-1) * f
        - 1.242_014_1e-1)
        * f
        + 1.424_932_3e-1)
        * f
        - 1.666_805_8e-1)
        * f
        + 2.000_071_4e-1)
        * f
        - 2.499_999_4e-1)
        * f
        + 3.333_333e-1)
        * f
        * z;
    let e = e as f32;
    let y = p + e * LN2_LO - 0.5 * z;
    f + y + e * LN2_HI
}

/// `pi/2 - FRAC_PI_2`: pi/2 in two parts, `FRAC_PI_2 + PIO2_LO`.
const PIO2_LO: f32 = -4.371_139e-8;
/// `pi - PI`: pi in two parts, `PI + PI_LO`.
const PI_LO: f32 = -8.742_278e-8;
/// `tan(pi/8)`: [`atan_ratio`] reduces ratios above it.
const TAN_PI_8: f32 = 0.414_213_57;
/// `pi/4 - FRAC_PI_4`: pi/4 in two parts.
const PIO4_LO: f32 = -2.185_569_5e-8;

/// `atan(num / den)` for `0 <= num <= den`, `den` finite and not zero: Cephes `atanf`'s
/// polynomial, with ratios above `tan(pi/8)` reduced to
/// `pi/4 + atan((num - den) / (num + den))` (the quotient of the operands, not of a
/// rounded ratio: one rounding fewer) and pi/4 in two parts.
#[inline(always)]
fn atan_ratio(num: f32, den: f32) -> f32 {
    // num + den overflows only past f32::MAX / 2; a quarter of both is exact there.
    let (num, den) = if den > 1e38 {
        (num * 0.25, den * 0.25)
    } else {
        (num, den)
    };
    let (hi, lo, t) = if num > TAN_PI_8 * den {
        (FRAC_PI_4, PIO4_LO, (num - den) / (num + den))
    } else {
        (0.0, 0.0, num / den)
    };
    let z = t * t;
    let p =
        (((8.053_744_5e-2 * z - 1.387_768_6e-1) * z + 1.997_771_1e-1) * z - 3.333_295e-1) * z * t;
    hi + (t + (lo + p))
}

/// Four-quadrant arctangent of `y / x`, in `[-pi, pi]`: `atan` of the smaller magnitude
/// over the larger (in `[0, 1]`), then placed in its octant with pi/2 and pi in two parts.
/// Largest measured error: 2.07 ulp (a grid and 2^28 random pairs).
///
/// Edges as C's `atan2`: `atan2(±0, +0) = ±0`, `atan2(±0, -0) = ±pi`, `atan2(±inf, ±inf)`
/// is `±pi/4` or `±3pi/4`, the sign of `y` is the result's; NaN if either is NaN.
#[inline]
pub fn atan2(y: f32, x: f32) -> f32 {
    if x.is_nan() || y.is_nan() {
        return x + y;
    }
    let (ax, ay) = (abs(x), abs(y));
    let steep = ay > ax;
    let (num, den) = if steep { (ax, ay) } else { (ay, ax) };
    let a = if den == 0.0 || den == f32::INFINITY {
        // Both zero (0), an infinity over a finite value (0), or both infinite (pi/4).
        if num == f32::INFINITY {
            FRAC_PI_4
        } else {
            0.0
        }
    } else {
        atan_ratio(num, den)
    };
    // atan2 = offset + sign a: a, pi/2 - a, pi - a or pi/2 + a by octant.
    let a = match (steep, x.is_sign_negative()) {
        (false, false) => a,
        (true, false) => FRAC_PI_2 + (PIO2_LO - a),
        (false, true) => PI + (PI_LO - a),
        (true, true) => FRAC_PI_2 + (PIO2_LO + a),
    };
    copysign(a, y)
}

/// Hyperbolic tangent: `1 - 2 / (e^(2|x|) + 1)` with its sign for `|x| >= 0.625`, the
/// Cephes `tanhf` polynomial below. Largest measured error: 1.33 ulp.
///
/// Edges: `±1` once `e^(2|x|)` overflows (`|x| > 44`, and the rounded value is 1 from
/// `|x| > 9.01`); `tanh(-0.0) = -0.0`; NaN for NaN.
#[inline]
pub fn tanh(x: f32) -> f32 {
    let ax = abs(x);
    if ax >= 0.625 {
        let s = exp(ax + ax);
        return copysign(1.0 - 2.0 / (s + 1.0), x);
    }
    let z = x * x;
    // Odd: the sign of x, which also keeps tanh(-0.0) = -0.0.
    let small =
        ((((-5.704_988_7e-3 * z + 2.063_908_8e-2) * z - 5.373_971_5e-2) * z + 1.333_144_2e-1) * z
            - 3.333_328e-1)
            * z
            * x
            + x;
    copysign(small, x)
}

/// Square root, correctly rounded: the FPU's `vsqrt.f32` on Arm with hardware floats
/// (`target_abi = "eabihf"`), `libm::sqrtf` elsewhere. Both give the same bits.
/// `sqrt(-0.0) = -0.0`; NaN for `x < 0` and NaN.
#[inline]
pub fn sqrt(x: f32) -> f32 {
    #[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
    {
        crate::arm::vsqrt(x)
    }
    #[cfg(not(all(target_arch = "arm", target_abi = "eabihf")))]
    {
        libm::sqrtf(x)
    }
}

/// Whether every value is finite (neither infinite nor NaN), tested in floating point:
/// `v - v` is exactly `0` for a finite `v` and NaN for an infinite or NaN one, and a sum
/// of zeros is zero. A filter step checks its inputs so before using them. On a
/// Cortex-M4F this is one subtraction and one addition a value, where `is_finite` moves
/// each value to an integer register and tests its bits (for two values, 6 instructions
/// instead of 13). (On a core without an FPU it is two library calls a value, as is every
/// `f32` operation of the code that calls it.)
#[inline(always)]
#[allow(clippy::eq_op)] // `v - v` is the test, not a mistake.
pub fn all_finite<const N: usize>(values: [f32; N]) -> bool {
    values
        .iter()
        .map(|&v| v - v)
        .reduce(|sum, zero| sum + zero)
        .is_none_or(|sum| sum == 0.0)
}

/// Absolute value (clears the sign bit; NaN stays NaN).
#[inline]
pub fn abs(x: f32) -> f32 {
    f32::from_bits(x.to_bits() & 0x7FFF_FFFF)
}

/// `magnitude` with the sign of `sign`.
#[inline(always)]
fn copysign(magnitude: f32, sign: f32) -> f32 {
    f32::from_bits((magnitude.to_bits() & 0x7FFF_FFFF) | (sign.to_bits() & 0x8000_0000))
}

/// Whether `m` is a covariance: symmetric to within rounding and positive semi-definite,
/// tested by an `L D L'` factorisation in `f32`. Semi-definite means that
/// `M + delta diag(M) + t I`, `delta = 2 n (n + 1) eps`, `t = delta max_i m[i][i]`,
/// factorises with positive pivots; symmetric, that
/// `(m[i][j] - m[j][i])^2 <= eps (m[i][i] + t) (m[j][j] + t)`. The first shift forgives
/// what rounding makes of a semi-definite matrix scaled to unit variances, and nothing of a
/// negative variance or a correlation beyond 1 by more than that, so that variances of
/// very different scales are judged each on its own, down to the second's scale; the
/// second forgives rounding at the
/// scale of the largest variance, which a covariance computed in `f32` (a filter's own,
/// as `covariance()` returns it) carries. A zero variance among zeros must have zero
/// covariances. A filter tests every covariance it is given (initial, process and
/// measurement noise, `reset`) so; the entries must be finite (tested first).
#[must_use]
pub fn is_covariance<const N: usize>(m: &[[f32; N]; N]) -> bool {
    crate::covariance::is_covariance(m)
}

/// Whether the weight `m` (a controller's state or input weight), read from its upper
/// triangle, is positive semi-definite to within rounding, as [`is_covariance`] judges a
/// covariance: a negative weight, or a cross weight beyond the geometric mean of its two
/// diagonal weights, fails. The lower triangle is not read; the entries read must be
/// finite (tested first). An LQR or MPC tests its weights so when they are given.
#[must_use]
pub fn is_weight<const N: usize>(m: &[[f32; N]; N]) -> bool {
    crate::covariance::is_weight(m)
}

/// Whether every entry of the upper triangle of `m` between two blocks (`block[i] !=
/// block[j]`) is zero (a negative zero is zero): what a filter whose covariance has
/// blocks that nothing couples (its `COVARIANCE_BLOCKS`) requires of an initial
/// covariance, whose entries there it never computes again.
#[must_use]
pub fn zero_between_blocks<const N: usize>(m: &[[f32; N]; N], block: &[usize; N]) -> bool {
    crate::covariance::zero_between_blocks(m, block)
}

/// Whether every entry of the upper triangle of `m` (diagonal included) is finite: what a
/// generated filter reads of a symmetric matrix argument, tested by a loop.
#[must_use]
pub fn upper_triangle_finite<const N: usize>(m: &[[f32; N]; N]) -> bool {
    crate::covariance::upper_triangle_finite(m)
}

/// The upper triangle of the symmetric `m`, row by row (`L = N (N + 1) / 2` entries, checked
/// when the code is compiled): how a generated filter stores a covariance.
#[must_use]
pub fn pack_upper<const N: usize, const L: usize>(m: &[[f32; N]; N]) -> [f32; L] {
    crate::covariance::pack_upper(m)
}

/// The upper triangle, row by row, of the `K x K` block of the symmetric `m` on the rows
/// and columns `rows`, in that order (`L = K (K + 1) / 2` entries, each read from `m`'s
/// upper triangle): how a generated filter stores one sensor's measurement noise out of a
/// whole `R`.
#[must_use]
pub fn pack_upper_of<const N: usize, const K: usize, const L: usize>(
    m: &[[f32; N]; N],
    rows: &[usize; K],
) -> [f32; L] {
    crate::covariance::pack_upper_of(m, rows)
}

/// Whether every entry of `m` between two of `blocks` (lists of its rows and columns) is
/// zero: a generated filter's test that a whole measurement noise `R` leaves its sensors
/// independent, each sensor's outputs one block.
#[must_use]
pub fn is_block_diagonal<const N: usize>(m: &[[f32; N]; N], blocks: &[&[usize]]) -> bool {
    crate::covariance::is_block_diagonal(m, blocks)
}

/// The symmetric matrix whose upper triangle, row by row, is `packed` (see [`pack_upper`]).
#[must_use]
pub fn unpack_symmetric<const N: usize, const L: usize>(packed: &[f32; L]) -> [[f32; N]; N] {
    crate::covariance::unpack_symmetric(packed)
}

/// A filter stage's recovery after a run of refused measurements: scales the packed
/// covariance `packed` by `scale` when that is above 1 and the scaled variances stay within
/// [`DIVERGENCE_BOUND`]; whether it did (never for NaN).
#[must_use]
#[inline(always)]
pub fn inflate_covariance<const L: usize>(packed: &mut [f32; L], scale: f32) -> bool {
    crate::recovery::inflate(packed, scale, DIVERGENCE_BOUND)
}

/// A design aid of the double Kalman filter's window: the least-squares window length
/// (`dkf(window = N)`) at which one window equation's error `equation_noise` (a standard
/// deviation, as `Dkf::window_equation_noise` gives it), averaged over the window's
/// `N - minimum_window + params` equations as if they were independent, is a tenth of
/// `equation_terms` (the size of the equation's terms at the excitation); never below the
/// minimum window, `minimum_window` outputs that determine the `params` parameters. A rule of thumb: neighbouring equations share
/// measurements, so check the length it names with a simulation. `None` when
/// `equation_terms` is not positive and finite, `equation_noise` is negative or not finite,
/// or the window would need more than 100 000 equations.
#[must_use]
pub fn window_len_for(
    equation_noise: f32,
    equation_terms: f32,
    minimum_window: usize,
    params: usize,
) -> Option<usize> {
    crate::recovery::window_len_for(equation_noise, equation_terms, minimum_window, params)
}

/// Whether every variance of a diagonal covariance is non-negative (NaN is not).
#[must_use]
pub fn all_non_negative<const N: usize>(variances: &[f32; N]) -> bool {
    crate::covariance::all_non_negative(variances)
}

/// The divergence bound on a filter step's result: a step is applied only when the sum of
/// its new estimate's entries and variances lies within plus or minus this (1e18), far
/// below where `f32` arithmetic overflows (1e18 squared is 1e36; `f32::MAX` is 3.4e38).
/// One test of a sum, it bounds a diverging estimate, not each entry: entries of opposite
/// signs can cancel in it. The same in `f64`, so that a host check of an `f32` filter
/// accepts what the target does.
pub const DIVERGENCE_BOUND: f32 = 1e18;

/// The divergence bound on a correction: a filter without an innovation gate rejects a
/// measurement whose normalised innovation squared `r' S^-1 r` exceeds this (1e8, an
/// innovation of 1e4 standard deviations), and a gate can be opened no further. It bounds
/// the correction's change: `dx' P^-1 dx <= r' S^-1 r` for the Kalman gain.
pub const DIVERGENCE_NIS: f32 = 1e8;

/// Whether a filter step's probe (the sum of its new estimate's entries and variances) is
/// within [`DIVERGENCE_BOUND`]: false for NaN and the infinities.
#[must_use]
#[inline(always)]
pub fn within_divergence_bound(probe: f32) -> bool {
    abs(probe) <= DIVERGENCE_BOUND
}

/// Whether `value` is at most `limit` (false for NaN): a generated step's test of a
/// measure against the bound of the code path it takes (the continuous-time EKF's
/// stiffness against the whole equations' RK4).
#[must_use]
#[inline(always)]
pub fn at_most(value: f32, limit: f32) -> bool {
    value <= limit
}

/// Whether a normalised innovation squared is within `gate` (false for NaN).
#[must_use]
#[inline(always)]
pub fn within_gate(nis: f32, gate: f32) -> bool {
    nis <= gate
}

/// `x` with each rotation's quaternion (`[x, y, z, w]`, starting at each of `firsts`)
/// divided by its norm; `None` if a norm is not within 1 % of one. A generated
/// error-state filter's check of the state it is given (`new`, `reset`).
#[must_use]
pub fn with_unit_rotations<const N: usize>(x: &[f32; N], firsts: &[usize]) -> Option<[f32; N]> {
    crate::rotation::with_unit_rotations(x, firsts, sqrt, crate::rotation::NORM_TOLERANCE_F32)
}

/// The QP of a generated MPC, `min 1/2 v' H v + c' v` with bounds on the moves and limit
/// rows (hard, or soft with an exact penalty on their violation), by a dual active-set
/// method on `qp.inverse = H^-1` (symmetric positive definite, as [`symmetric_inverse`]
/// gives it) from the unconstrained minimiser `qp.unconstrained = -H^-1 c`; `low < high`
/// entry by entry. `held` is the warm start (the limits the last solve held) and is left
/// as the solution's. At most `max_iterations` limits are held, released or saturated; a
/// limit counts as violated beyond `tolerance` of its move's range or of `1 + |limit|`
/// for a row. Each iteration costs `O((M + R) k)` for `k` limits held: the held set's
/// `L D L'` factor is updated, never refactorised.
#[must_use]
pub fn mpc_qp<const M: usize, const R: usize>(
    qp: &crate::MpcQp<f32, M, R>,
    held: &mut crate::HeldLimits<M, R>,
    max_iterations: usize,
    tolerance: f32,
) -> crate::MpcQpSolution<f32, M> {
    crate::mpc_qp::solve(qp, held, (max_iterations, tolerance))
}

/// `G a` for each of the limit rows `rows` (`G = H^-1`): what a generated MPC keeps of
/// its limit rows for [`mpc_qp`].
#[must_use]
pub fn limit_columns<const M: usize, const R: usize>(
    inverse: &[[f32; M]; M],
    rows: &[[f32; M]; R],
) -> [[f32; M]; R] {
    crate::mpc_qp::columns(inverse, rows)
}

/// `G = H^-1` of a generated MPC's condensed Hessian over `M / NU` moves and its
/// unconstrained plan's gain, by the Riccati recursion from the terminal weight, never
/// forming `H` (whose rounding, amplified by its condition number, would decide the
/// plan's accuracy); `None` when `M` is not a whole number of moves, `R + B' P B` is not
/// positive definite to within rounding at a step, or an entry of `G` or the gain is not
/// finite. What a generated MPC keeps of its condensed QP for [`mpc_qp`].
#[must_use]
pub fn condensed_inverse<const M: usize, const NS: usize, const NU: usize>(
    problem: &crate::PredictionProblem<f32, NS, NU>,
) -> Option<crate::CondensedInverse<f32, M, NS>> {
    crate::mpc_condense::condensed_inverse(problem)
}

/// The inverse of the symmetric positive definite `h` (its upper triangle read), exactly
/// symmetric, by an `L D L'` factorisation; `None` when a pivot is not above `M eps` of its
/// diagonal entry or an entry of the inverse is not finite: what a generated MPC keeps of
/// its condensed Hessian for [`mpc_qp`].
#[must_use]
pub fn symmetric_inverse<const M: usize>(h: &[[f32; M]; M]) -> Option<[[f32; M]; M]> {
    crate::mpc_qp::symmetric_inverse(h)
}
