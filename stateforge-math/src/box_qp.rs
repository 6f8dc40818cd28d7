//! The generated MPC's box-constrained QP, `min 1/2 v' H v + c' v` with `low <= v <= high`,
//! by a dual active-set method (Goldfarb and Idnani, "A numerically stable dual method
//! for solving strictly convex quadratic programs", in the form of Arnström, Bemporad and
//! Axehill, "A dual active-set solver for embedded quadratic programming using recursive
//! LDL' updates"), on `G = H^-1`, which the MPC keeps while its Hessian is unchanged.
//!
//! A held bound `j` on move `i_j` has the side `s_j` (`+1` lower, `-1` upper) and a
//! multiplier `lambda_j >= 0`. For the held set `W`, the KKT conditions give the moves
//! `v = v* + G N_W lambda` (`v* = -G c`, `N_W`'s columns `s_j e_(i_j)`), and holding the
//! bounds gives `S lambda = d`, `S = N_W' G N_W`, `d_j = s_j (bound_j - v*_(i_j))`. The
//! multipliers stay non-negative throughout (dual feasibility); each iteration either
//! holds the most violated bound (when the held set's multipliers are non-negative) or
//! steps the multipliers towards that set's solution until one reaches zero and releases
//! it. `S`'s `L D L'` factor follows the held set: a row is added by one forward
//! substitution, and a released row's part is a rank-one update of the rows after it
//! (Gill, Golub, Murray and Saunders, "Methods for modifying matrix factorizations",
//! method C1), so an iteration costs `O(n k)` for `k` bounds held, never a refactoring.
//!
//! With a warm start (the last solve's held set, shifted by a step) the set is usually
//! right at once: one solve of `S lambda = d`, the moves, and the check that none is
//! violated.

#![allow(clippy::needless_range_loop)] // The factor is indexed by row and column, as written.

use crate::covariance::Real;

/// What a solve returns: the moves, whether they are optimal (within the tolerance of
/// the bounds), and the changes of the held set it took.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoxQpSolution<T, const M: usize> {
    /// The moves `v`: optimal when `optimal` is, else those of the last held set, which
    /// may violate bounds not yet held (clip them).
    pub moves: [T; M],
    /// Whether no bound is violated by more than its tolerance and every multiplier is
    /// non-negative.
    pub optimal: bool,
    /// Bounds held or released, at most the `max_iterations` given.
    pub iterations: usize,
}

/// The held bounds in the order they were held, with `S`'s factor and their multipliers.
struct HeldSet<T, const M: usize> {
    /// Per held bound: its move.
    moves: [usize; M],
    /// Per held bound: its side, `+1` (lower) or `-1` (upper).
    sides: [T; M],
    /// Per held bound: its multiplier.
    multipliers: [T; M],
    /// `L` strictly below the diagonal, `D` on it; the first `len` rows are `S`'s factor.
    factor: [[T; M]; M],
    /// `1 / D`, row by row.
    reciprocals: [T; M],
    len: usize,
}

impl<T: Real, const M: usize> HeldSet<T, M> {
    fn empty() -> Self {
        HeldSet {
            moves: [0; M],
            sides: [T::ZERO; M],
            multipliers: [T::ZERO; M],
            factor: [[T::ZERO; M]; M],
            reciprocals: [T::ZERO; M],
            len: 0,
        }
    }

    /// Holds the bound on move `index` of side `side` with a zero multiplier: `S`'s new
    /// row `s_j = side s_j G[index][i_j]` by forward substitution, `y = L^-1 s`, the
    /// factor's row `y / D` and pivot `G[index][index] - y' D^-1 y`. False (the set
    /// unchanged) when the pivot is not positive: the bound depends on those held.
    fn hold(&mut self, inverse: &[[T; M]; M], index: usize, side: T) -> bool {
        let k = self.len;
        let (Some(column), true) = (inverse.get(index), k < M) else {
            return false;
        };
        let (factor, below) = self.factor.split_at_mut(k);
        let Some(row) = below.first_mut() else {
            return false;
        };
        // y = L^-1 s, kept in the new row until it is scaled by D^-1.
        for (c, prior) in factor.iter().enumerate() {
            let mut entry = side * self.sides[c] * column[self.moves[c] % M];
            for (&l, &y) in prior[..c].iter().zip(&row[..c]) {
                entry = entry - l * y;
            }
            row[c] = entry;
        }
        let mut pivot = column[index];
        for (y, &reciprocal) in row[..k].iter_mut().zip(&self.reciprocals[..k]) {
            let l = *y * reciprocal;
            pivot = pivot - l * *y;
            *y = l;
        }
        // (A NaN pivot is not positive either.)
        let positive = pivot > T::EPSILON * column[index];
        if !positive {
            return false;
        }
        row[k] = pivot;
        self.reciprocals[k] = T::from_count(1) / pivot;
        self.moves[k] = index;
        self.sides[k] = side;
        self.multipliers[k] = T::ZERO;
        self.len = k + 1;
        true
    }

    /// Releases the held bound at position `j`: its row and column leave `S`, and the
    /// rows after it take `D_j l l'` (`l` its column of `L` below it) by a rank-one update
    /// of their factor, then move up one place.
    fn release(&mut self, j: usize) {
        let k = self.len;
        let mut alpha = self.factor[j][j];
        let mut w = [T::ZERO; M];
        for r in j + 1..k {
            w[r] = self.factor[r][j];
        }
        for c in j + 1..k {
            let p = w[c];
            let d = self.factor[c][c];
            let updated = d + alpha * p * p;
            let beta = p * alpha / updated;
            alpha = d * alpha / updated;
            self.factor[c][c] = updated;
            self.reciprocals[c] = T::from_count(1) / updated;
            for r in c + 1..k {
                w[r] = w[r] - p * self.factor[r][c];
                self.factor[r][c] = self.factor[r][c] + beta * w[r];
            }
        }
        for r in j + 1..k {
            let row = self.factor[r];
            let above = &mut self.factor[r - 1];
            above[..j].copy_from_slice(&row[..j]);
            above[j..r].copy_from_slice(&row[j + 1..=r]);
            self.reciprocals[r - 1] = self.reciprocals[r];
            self.moves[r - 1] = self.moves[r];
            self.sides[r - 1] = self.sides[r];
            self.multipliers[r - 1] = self.multipliers[r];
        }
        self.len = k - 1;
    }

    /// The multipliers that hold every bound of the set exactly, `S^-1 d`.
    fn equality_multipliers(&self, unconstrained: &[T; M], (low, high): Bounds<T, M>) -> [T; M] {
        let k = self.len.min(M);
        let mut x = [T::ZERO; M];
        for r in 0..k {
            let i = self.moves[r] % M;
            let bound = if self.sides[r] > T::ZERO {
                low[i]
            } else {
                high[i]
            };
            let mut entry = self.sides[r] * (bound - unconstrained[i]);
            for (&l, &x_c) in self.factor[r][..r].iter().zip(&x[..r]) {
                entry = entry - l * x_c;
            }
            x[r] = entry;
        }
        for (x_r, &reciprocal) in x[..k].iter_mut().zip(&self.reciprocals[..k]) {
            *x_r = *x_r * reciprocal;
        }
        for r in (0..k).rev() {
            let mut entry = x[r];
            for (row, &x_c) in self.factor[r + 1..k].iter().zip(&x[r + 1..k]) {
                entry = entry - row[r] * x_c;
            }
            x[r] = entry;
        }
        x
    }

    /// The moves of the current multipliers, `v* + G N_W lambda`.
    fn moves(&self, inverse: &[[T; M]; M], unconstrained: &[T; M]) -> [T; M] {
        let mut v = *unconstrained;
        for r in 0..self.len {
            let weight = self.sides[r] * self.multipliers[r];
            let column = &inverse[self.moves[r] % M];
            for (v_i, &g) in v.iter_mut().zip(column) {
                *v_i = *v_i + weight * g;
            }
        }
        v
    }
}

/// `1` for a held lower bound's side, `-1` for an upper one's.
fn side_value<T: Real>(side: i8) -> T {
    let one = T::from_count(1);
    if side > 0 {
        one
    } else {
        T::ZERO - one
    }
}

/// The moves' lower and upper bounds.
type Bounds<'a, T, const M: usize> = (&'a [T; M], &'a [T; M]);

/// The bound most violated by `v` among the moves not held (`sides[i] == 0`), beyond
/// `tolerance (high - low)`: its move and side.
fn most_violated<T: Real, const M: usize>(
    v: &[T; M],
    (low, high): Bounds<T, M>,
    sides: &[i8; M],
    tolerance: T,
) -> Option<(usize, i8)> {
    let mut worst = None;
    let mut largest = T::ZERO;
    for i in 0..M {
        if sides[i] != 0 {
            continue;
        }
        let allowed = tolerance * (high[i] - low[i]);
        let (below, above) = (low[i] - v[i] - allowed, v[i] - high[i] - allowed);
        if below > largest {
            largest = below;
            worst = Some((i, 1));
        }
        if above > largest {
            largest = above;
            worst = Some((i, -1));
        }
    }
    worst
}

/// The blocking bound of a step from the multipliers towards `target`: the held bound
/// whose multiplier reaches zero first among those whose target is negative, and the
/// step's length; `None` when no target is negative.
fn blocking<T: Real, const M: usize>(set: &HeldSet<T, M>, target: &[T; M]) -> Option<(usize, T)> {
    let mut first: Option<(usize, T)> = None;
    for j in 0..set.len {
        if target[j] < T::ZERO {
            let length = set.multipliers[j] / (set.multipliers[j] - target[j]);
            let shorter = match first {
                None => true,
                Some((_, shortest)) => length < shortest,
            };
            if shorter {
                first = Some((j, length));
            }
        }
    }
    first
}

/// Solves the box-constrained QP from `G = H^-1` (symmetric positive definite), the
/// unconstrained minimiser `v* = -G c` and the bounds (`low < high`), warm-started from
/// `sides` (per move: `1` lower bound held, `-1` upper, `0` free), which it leaves as the
/// solution's held set; at most `max_iterations` changes of that set. A bound counts as
/// violated beyond `tolerance (high - low)`.
pub(crate) fn solve<T: Real, const M: usize>(
    inverse: &[[T; M]; M],
    unconstrained: &[T; M],
    bounds: Bounds<T, M>,
    sides: &mut [i8; M],
    (max_iterations, tolerance): (usize, T),
) -> BoxQpSolution<T, M> {
    // Without a bound held, the unconstrained minimiser is the solution when it violates
    // none: no factor to set up.
    if sides.iter().all(|&side| side == 0)
        && most_violated(unconstrained, bounds, sides, tolerance).is_none()
    {
        return BoxQpSolution {
            moves: *unconstrained,
            optimal: true,
            iterations: 0,
        };
    }
    let mut set = HeldSet::<T, M>::empty();
    for i in 0..M {
        let side = sides[i];
        if side == 0 || !set.hold(inverse, i, side_value(side)) {
            sides[i] = 0;
        }
    }
    let mut iterations = 0;
    loop {
        let target = set.equality_multipliers(unconstrained, bounds);
        if let Some((j, length)) = blocking(&set, &target) {
            if iterations == max_iterations {
                break;
            }
            for r in 0..set.len {
                let m = set.multipliers[r];
                set.multipliers[r] = m + length * (target[r] - m);
            }
            sides[set.moves[j] % M] = 0;
            set.release(j);
            iterations += 1;
            continue;
        }
        set.multipliers = target;
        let v = set.moves(inverse, unconstrained);
        let Some((i, side)) = most_violated(&v, bounds, sides, tolerance) else {
            return BoxQpSolution {
                moves: v,
                optimal: true,
                iterations,
            };
        };
        if iterations == max_iterations || !set.hold(inverse, i, side_value(side)) {
            return BoxQpSolution {
                moves: v,
                optimal: false,
                iterations,
            };
        }
        sides[i] = side;
        iterations += 1;
    }
    // Out of iterations with a multiplier to release: the moves of the multipliers
    // stepped so far.
    BoxQpSolution {
        moves: set.moves(inverse, unconstrained),
        optimal: false,
        iterations,
    }
}

/// `H^-1` of the symmetric positive definite `h` (its upper triangle read), by `L D L'`
/// and `L^-T D^-1 L^-1`, exactly symmetric; `None` when a pivot is not above
/// `n eps` of its diagonal entry (not positive definite to within rounding) or an entry
/// is not finite.
pub(crate) fn symmetric_inverse<T: Real, const M: usize>(h: &[[T; M]; M]) -> Option<[[T; M]; M]> {
    let mut l = [[T::ZERO; M]; M];
    let mut d = [T::ZERO; M];
    let n = T::from_count(M);
    for j in 0..M {
        let mut pivot = h[j][j];
        for k in 0..j {
            pivot = pivot - l[j][k] * l[j][k] * d[k];
        }
        if !(pivot > n * T::EPSILON * h[j][j] && pivot.finite()) {
            return None;
        }
        d[j] = pivot;
        for i in j + 1..M {
            let mut entry = h[j][i];
            for k in 0..j {
                entry = entry - l[i][k] * l[j][k] * d[k];
            }
            l[i][j] = entry / pivot;
        }
    }
    // X = L^-1, unit lower triangular: row i is e_i' - sum_(k<i) l[i][k] X[k].
    let mut x = [[T::ZERO; M]; M];
    for i in 0..M {
        x[i][i] = T::from_count(1);
        for k in 0..i {
            let factor = l[i][k];
            for c in 0..=k {
                x[i][c] = x[i][c] - factor * x[k][c];
            }
        }
    }
    // G = X' D^-1 X: G[i][j] = sum_(k >= max(i, j)) X[k][i] X[k][j] / d[k].
    let one = T::from_count(1);
    let reciprocals: [T; M] = core::array::from_fn(|k| one / d[k]);
    let mut g = [[T::ZERO; M]; M];
    for i in 0..M {
        for j in i..M {
            let mut entry = T::ZERO;
            for k in j..M {
                entry = entry + x[k][i] * reciprocals[k] * x[k][j];
            }
            if !entry.finite() {
                return None;
            }
            g[i][j] = entry;
            g[j][i] = entry;
        }
    }
    Some(g)
}

#[cfg(test)]
mod tests {
    use super::{solve, symmetric_inverse};
    use nalgebra::{SMatrix, SVector};

    /// A small linear congruential generator: the same problems every run.
    struct Lcg(u64);

    impl Lcg {
        fn uniform(&mut self) -> f64 {
            self.0 = self
                .0
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            // The top 53 bits, in [-1, 1).
            f64::from(u32::try_from(self.0 >> 43).unwrap_or(0)) / f64::from(1_u32 << 20) - 1.0
        }
    }

    /// A random symmetric positive definite matrix `A' A + I/10`, its condition
    /// number raised by scaling the columns of `A` over four decades.
    fn hessian<const M: usize>(rng: &mut Lcg) -> SMatrix<f64, M, M> {
        let a = SMatrix::<f64, M, M>::from_fn(|_, j| {
            let scale = 10_f64.powf(4.0 * j as f64 / M as f64 - 2.0);
            rng.uniform() * scale
        });
        a.transpose() * a + SMatrix::identity() * 0.1
    }

    fn array<const M: usize>(m: &SMatrix<f64, M, M>) -> [[f64; M]; M] {
        core::array::from_fn(|i| core::array::from_fn(|j| m[(i, j)]))
    }

    #[test]
    fn the_inverse_is_nalgebras() {
        let mut rng = Lcg(7);
        for _ in 0..20 {
            let h = hessian::<32>(&mut rng);
            let expected = h.try_inverse().expect("positive definite");
            let g = symmetric_inverse(&array(&h)).expect("positive definite");
            let largest = expected.amax();
            for i in 0..32 {
                for j in 0..32 {
                    assert_eq!(g[i][j], g[j][i]);
                    let error = (g[i][j] - expected[(i, j)]).abs() / largest;
                    assert!(error < 1e-9, "{i} {j}: {error:e}");
                }
            }
        }
    }

    #[test]
    fn an_indefinite_or_non_finite_matrix_has_no_inverse() {
        let mut h = [[0.0; 3]; 3];
        for (i, row) in h.iter_mut().enumerate() {
            row[i] = 1.0;
        }
        h[0][1] = 2.0;
        h[1][0] = 2.0;
        assert_eq!(symmetric_inverse(&h), None);
        h[0][1] = f64::NAN;
        assert_eq!(symmetric_inverse(&h), None);
        h[0][1] = 0.5;
        assert!(symmetric_inverse(&h).is_some());
    }

    /// The largest violation of the KKT conditions of `min 1/2 v' H v + c' v`,
    /// `low <= v <= high` by `v`: its bounds, and the gradient `H v + c`, which must be
    /// zero on a free move, non-negative at a lower bound, non-positive at an upper one.
    fn kkt_violation<const M: usize>(
        h: &SMatrix<f64, M, M>,
        c: &SVector<f64, M>,
        v: &[f64; M],
        (low, high): (&[f64; M], &[f64; M]),
    ) -> f64 {
        let gradient = h * SVector::from(*v) + c;
        let scale = gradient.amax().max(1.0);
        (0..M)
            .map(|i| {
                let outside = (low[i] - v[i]).max(v[i] - high[i]).max(0.0);
                let at_lower = v[i] - low[i] <= 1e-9 * (high[i] - low[i]);
                let at_upper = high[i] - v[i] <= 1e-9 * (high[i] - low[i]);
                let wrong_sign = match (at_lower, at_upper) {
                    (true, _) => (-gradient[i]).max(0.0),
                    (_, true) => gradient[i].max(0.0),
                    _ => gradient[i].abs(),
                };
                outside.max(wrong_sign / scale)
            })
            .fold(0.0, f64::max)
    }

    /// Random problems, each solved cold and from a random warm start (whose wrong
    /// bounds must be released), checked against the KKT conditions.
    fn random_problems<const M: usize>(seed: u64) {
        let mut rng = Lcg(seed);
        let mut held_somewhere = 0;
        for problem in 0..200 {
            let h = hessian::<M>(&mut rng);
            let c = SVector::<f64, M>::from_fn(|_, _| 3.0 * rng.uniform());
            let g = symmetric_inverse(&array(&h)).expect("positive definite");
            let free: [f64; M] = (-(h.try_inverse().expect("invertible") * c)).into();
            let low: [f64; M] = core::array::from_fn(|_| -0.5 - 0.5 * rng.uniform().abs());
            let high: [f64; M] = core::array::from_fn(|_| 0.5 + 0.5 * rng.uniform().abs());
            let warm: [i8; M] = core::array::from_fn(|_| match rng.uniform() {
                u if u < -0.5 => -1,
                u if u > 0.5 => 1,
                _ => 0,
            });
            for start in [[0; M], warm] {
                let mut held = start;
                let solution = solve(&g, &free, (&low, &high), &mut held, (200, 1e-12));
                assert!(solution.optimal, "problem {problem}");
                let violation = kkt_violation(&h, &c, &solution.moves, (&low, &high));
                assert!(violation < 1e-9, "problem {problem}: {violation:e}");
                for i in 0..M {
                    let bound = match held[i] {
                        1 => low[i],
                        -1 => high[i],
                        _ => continue,
                    };
                    assert!((solution.moves[i] - bound).abs() < 1e-9);
                }
                held_somewhere += held.iter().filter(|&&s| s != 0).count();
            }
        }
        assert!(held_somewhere > 200, "the problems hold bounds");
    }

    #[test]
    fn random_problems_meet_the_kkt_conditions() {
        random_problems::<4>(1);
        random_problems::<12>(2);
        random_problems::<32>(3);
    }

    #[test]
    fn a_solve_out_of_iterations_is_not_optimal() {
        let mut rng = Lcg(11);
        let h = hessian::<12>(&mut rng);
        let c = SVector::<f64, 12>::from_fn(|_, _| 20.0 * rng.uniform());
        let g = symmetric_inverse(&array(&h)).expect("positive definite");
        let free: [f64; 12] = (-(h.try_inverse().expect("invertible") * c)).into();
        let (low, high) = ([-1.0; 12], [1.0; 12]);
        let mut held = [0; 12];
        let full = solve(&g, &free, (&low, &high), &mut held, (100, 1e-12));
        assert!(full.optimal && full.iterations >= 2, "{full:?}");
        let mut held = [0; 12];
        let cut = solve(&g, &free, (&low, &high), &mut held, (1, 1e-12));
        assert!(!cut.optimal);
        assert_eq!(cut.iterations, 1);
        assert_eq!(held.iter().filter(|&&s| s != 0).count(), 1);
        // Warm-started from the solution, the held set is right at once.
        let mut held = [0; 12];
        let _ = solve(&g, &free, (&low, &high), &mut held, (100, 1e-12));
        let again = solve(&g, &free, (&low, &high), &mut held, (100, 1e-12));
        assert!(again.optimal);
        assert_eq!(again.iterations, 0);
        // (The same set factorised in another order: equal to rounding.)
        for (again, full) in again.moves.iter().zip(&full.moves) {
            assert!((again - full).abs() < 1e-12);
        }
    }
}
