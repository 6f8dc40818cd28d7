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

/// Whether every value is finite (neither infinite nor NaN): `is_finite` on each. (The
/// `f32` version tests in floating point, cheaper on a single-precision FPU; an `f64`
/// subtraction there is a library call, so this one tests the bits.)
#[inline(always)]
pub fn all_finite<const N: usize>(values: [f64; N]) -> bool {
    values.iter().all(|v| v.is_finite())
}

/// Absolute value (clears the sign bit; NaN stays NaN).
#[inline]
pub fn abs(x: f64) -> f64 {
    f64::from_bits(x.to_bits() & !(1 << 63))
}

/// Whether `m` is a covariance: symmetric to within rounding and positive semi-definite,
/// tested by an `L D L'` factorisation in `f64`. Semi-definite means that
/// `M + delta diag(M) + t I`, `delta = 2 n (n + 1) eps`, `t = delta max_i m[i][i]`,
/// factorises with positive pivots; symmetric, that
/// `(m[i][j] - m[j][i])^2 <= eps (m[i][i] + t) (m[j][j] + t)`. The first shift forgives
/// what rounding makes of a semi-definite matrix scaled to unit variances, and nothing of a
/// negative variance or a correlation beyond 1 by more than that, so that variances of
/// very different scales are judged each on its own, down to the second's scale; the
/// second forgives rounding at the
/// scale of the largest variance, which a covariance computed in `f64` (a filter's own,
/// as `covariance()` returns it) carries. A zero variance among zeros must have zero
/// covariances. A filter tests every covariance it is given (initial, process and
/// measurement noise, `reset`) so; the entries must be finite (tested first).
#[must_use]
pub fn is_covariance<const N: usize>(m: &[[f64; N]; N]) -> bool {
    crate::covariance::is_covariance(m)
}

/// Whether the weight `m` (a controller's state or input weight), read from its upper
/// triangle, is positive semi-definite to within rounding, as [`is_covariance`] judges a
/// covariance: a negative weight, or a cross weight beyond the geometric mean of its two
/// diagonal weights, fails. The lower triangle is not read; the entries read must be
/// finite (tested first). An LQR or MPC tests its weights so when they are given.
#[must_use]
pub fn is_weight<const N: usize>(m: &[[f64; N]; N]) -> bool {
    crate::covariance::is_weight(m)
}

/// Whether every entry of the upper triangle of `m` between two blocks (`block[i] !=
/// block[j]`) is zero (a negative zero is zero): what a filter whose covariance has
/// blocks that nothing couples (its `COVARIANCE_BLOCKS`) requires of an initial
/// covariance, whose entries there it never computes again.
#[must_use]
pub fn zero_between_blocks<const N: usize>(m: &[[f64; N]; N], block: &[usize; N]) -> bool {
    crate::covariance::zero_between_blocks(m, block)
}

/// Whether every entry of the upper triangle of `m` (diagonal included) is finite: what a
/// generated filter reads of a symmetric matrix argument, tested by a loop.
#[must_use]
pub fn upper_triangle_finite<const N: usize>(m: &[[f64; N]; N]) -> bool {
    crate::covariance::upper_triangle_finite(m)
}

/// The upper triangle of the symmetric `m`, row by row (`L = N (N + 1) / 2` entries, checked
/// when the code is compiled): how a generated filter stores a covariance.
#[must_use]
pub fn pack_upper<const N: usize, const L: usize>(m: &[[f64; N]; N]) -> [f64; L] {
    crate::covariance::pack_upper(m)
}

/// The upper triangle, row by row, of the `K x K` block of the symmetric `m` on the rows
/// and columns `rows`, in that order (`L = K (K + 1) / 2` entries, each read from `m`'s
/// upper triangle): how a generated filter stores one sensor's measurement noise out of a
/// whole `R`.
#[must_use]
pub fn pack_upper_of<const N: usize, const K: usize, const L: usize>(
    m: &[[f64; N]; N],
    rows: &[usize; K],
) -> [f64; L] {
    crate::covariance::pack_upper_of(m, rows)
}

/// Whether every entry of `m` between two of `blocks` (lists of its rows and columns) is
/// zero: a generated filter's test that a whole measurement noise `R` leaves its sensors
/// independent, each sensor's outputs one block.
#[must_use]
pub fn is_block_diagonal<const N: usize>(m: &[[f64; N]; N], blocks: &[&[usize]]) -> bool {
    crate::covariance::is_block_diagonal(m, blocks)
}

/// The symmetric matrix whose upper triangle, row by row, is `packed` (see [`pack_upper`]).
#[must_use]
pub fn unpack_symmetric<const N: usize, const L: usize>(packed: &[f64; L]) -> [[f64; N]; N] {
    crate::covariance::unpack_symmetric(packed)
}

/// A filter stage's recovery after a run of refused measurements: scales the packed
/// covariance `packed` by `scale` when that is above 1 and the scaled variances stay within
/// [`DIVERGENCE_BOUND`]; whether it did (never for NaN).
#[must_use]
#[inline(always)]
pub fn inflate_covariance<const L: usize>(packed: &mut [f64; L], scale: f64) -> bool {
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
    equation_noise: f64,
    equation_terms: f64,
    minimum_window: usize,
    params: usize,
) -> Option<usize> {
    crate::recovery::window_len_for(equation_noise, equation_terms, minimum_window, params)
}

/// Whether every variance of a diagonal covariance is non-negative (NaN is not).
#[must_use]
pub fn all_non_negative<const N: usize>(variances: &[f64; N]) -> bool {
    crate::covariance::all_non_negative(variances)
}

/// The divergence bound on a filter step's result: a step is applied only when the sum of
/// its new estimate's entries and variances lies within plus or minus this (1e18), far
/// below where `f32` arithmetic overflows (1e18 squared is 1e36; `f32::MAX` is 3.4e38).
/// One test of a sum, it bounds a diverging estimate, not each entry: entries of opposite
/// signs can cancel in it. The same in `f64`, so that a host check of an `f32` filter
/// accepts what the target does.
pub const DIVERGENCE_BOUND: f64 = 1e18;

/// The divergence bound on a correction: a filter without an innovation gate rejects a
/// measurement whose normalised innovation squared `r' S^-1 r` exceeds this (1e8, an
/// innovation of 1e4 standard deviations), and a gate can be opened no further. It bounds
/// the correction's change: `dx' P^-1 dx <= r' S^-1 r` for the Kalman gain.
pub const DIVERGENCE_NIS: f64 = 1e8;

/// Whether a filter step's probe (the sum of its new estimate's entries and variances) is
/// within [`DIVERGENCE_BOUND`]: false for NaN and the infinities.
#[must_use]
#[inline(always)]
pub fn within_divergence_bound(probe: f64) -> bool {
    abs(probe) <= DIVERGENCE_BOUND
}

/// Whether `value` is at most `limit` (false for NaN): a generated step's test of a
/// measure against the bound of the code path it takes (the continuous-time EKF's
/// stiffness against the whole equations' RK4).
#[must_use]
#[inline(always)]
pub fn at_most(value: f64, limit: f64) -> bool {
    value <= limit
}

/// Whether a normalised innovation squared is within `gate` (false for NaN).
#[must_use]
#[inline(always)]
pub fn within_gate(nis: f64, gate: f64) -> bool {
    nis <= gate
}

/// `x` with each rotation's quaternion (`[x, y, z, w]`, starting at each of `firsts`)
/// divided by its norm; `None` if a norm is not within 1 % of one. A generated
/// error-state filter's check of the state it is given (`new`, `reset`).
#[must_use]
pub fn with_unit_rotations<const N: usize>(x: &[f64; N], firsts: &[usize]) -> Option<[f64; N]> {
    crate::rotation::with_unit_rotations(x, firsts, sqrt, crate::rotation::NORM_TOLERANCE_F64)
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
    qp: &crate::MpcQp<f64, M, R>,
    held: &mut crate::HeldLimits<M, R>,
    max_iterations: usize,
    tolerance: f64,
) -> crate::MpcQpSolution<f64, M> {
    crate::mpc_qp::solve(qp, held, (max_iterations, tolerance))
}

/// `G a` for each of the limit rows `rows` (`G = H^-1`): what a generated MPC keeps of
/// its limit rows for [`mpc_qp`].
#[must_use]
pub fn limit_columns<const M: usize, const R: usize>(
    inverse: &[[f64; M]; M],
    rows: &[[f64; M]; R],
) -> [[f64; M]; R] {
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
    problem: &crate::PredictionProblem<f64, NS, NU>,
) -> Option<crate::CondensedInverse<f64, M, NS>> {
    crate::mpc_condense::condensed_inverse(problem)
}

/// The inverse of the symmetric positive definite `h` (its upper triangle read), exactly
/// symmetric, by an `L D L'` factorisation; `None` when a pivot is not above `M eps` of its
/// diagonal entry or an entry of the inverse is not finite: what a generated MPC keeps of
/// its condensed Hessian for [`mpc_qp`].
#[must_use]
pub fn symmetric_inverse<const M: usize>(h: &[[f64; M]; M]) -> Option<[[f64; M]; M]> {
    crate::mpc_qp::symmetric_inverse(h)
}
