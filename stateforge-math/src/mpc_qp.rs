//! The generated MPC's QP, `min 1/2 v' H v + c' v` over the moves `v`, with bounds on the
//! moves (`low <= v <= high`) and limit rows (`lower_r <= a_r' v <= upper_r`: limits on
//! input changes, states and outputs over the horizon), each row hard or soft, by a dual
//! active-set method (Goldfarb and Idnani, "A numerically stable dual method for solving
//! strictly convex quadratic programs", in the form of Arnström, Bemporad and Axehill, "A
//! dual active-set solver for embedded quadratic programming using recursive LDL'
//! updates"), on `G = H^-1`, which the MPC keeps while its Hessian is unchanged.
//!
//! Every limit, a move's bound or a row's, is a constraint `s n' v >= s b` of side `s`
//! (`+1` a lower limit, `-1` an upper one), `n` the move's unit vector or the row `a_r`,
//! with a multiplier `lambda >= 0`. The KKT conditions give the moves
//! `v = v* + sum_j lambda_j s_j G n_j` (`v* = -G c`); the limits held exactly (the set
//! `W`) give `S lambda_W = d`, `S_jk = s_j s_k n_j' G n_k`, `d_j = s_j (b_j - n_j' v_0)`,
//! `v_0` the moves without `W`'s terms. A soft row is an exact penalty `penalty_r`
//! times its violation (the slack): in the dual, its multiplier is at most `penalty_r`,
//! and a soft row at that bound (saturated) adds `penalty_r s_r G a_r` to `v_0` and is no
//! longer held exactly; the plan then violates it by its slack. Hard rows have an infinite
//! penalty.
//!
//! The multipliers stay within their bounds throughout (dual feasibility). Each
//! iteration either holds the limit most violated by the moves (or releases a saturated
//! row's saturation when the moves satisfy it with room), once the held set's multipliers
//! are within their bounds, or steps the multipliers towards the held set's until one
//! reaches a bound: at zero the limit is released, at its penalty the soft row saturates.
//! `S`'s `L D L'` factor follows the held set: a row is added by one forward substitution,
//! and a released row's part is a rank-one update of the rows after it (Gill, Golub,
//! Murray and Saunders, "Methods for modifying matrix factorizations", method C1), so an
//! iteration costs `O((M + R) k)` for `k` limits held, never a refactorisation.

#![allow(clippy::needless_range_loop)] // The factor is indexed by row and column, as written.

use crate::covariance::Real;

/// The limit rows `lower_r <= a_r' v <= upper_r` of an MPC's QP (an infinite `lower_r`
/// or `upper_r`: no limit on that side).
#[derive(Clone, Copy, Debug)]
pub struct LimitRows<'a, T, const M: usize, const R: usize> {
    /// `a_r`, in the moves.
    pub coefficients: &'a [[T; M]; R],
    /// `G a_r`.
    pub columns: &'a [[T; M]; R],
    /// The rows' lower limits.
    pub lower: &'a [T; R],
    /// The rows' upper limits.
    pub upper: &'a [T; R],
    /// The exact penalty of each row's violation: infinite for a hard row.
    pub penalty: &'a [T; R],
}

/// An MPC's QP: `G = H^-1`, the unconstrained minimiser `v* = -G c`, the moves' bounds
/// (`low < high`) and the limit rows.
#[derive(Clone, Copy, Debug)]
pub struct MpcQp<'a, T, const M: usize, const R: usize> {
    /// `G = H^-1`, symmetric positive definite.
    pub inverse: &'a [[T; M]; M],
    /// `v* = -G c`.
    pub unconstrained: &'a [T; M],
    /// The moves' lower bounds.
    pub low: &'a [T; M],
    /// The moves' upper bounds.
    pub high: &'a [T; M],
    /// The limit rows.
    pub rows: LimitRows<'a, T, M, R>,
}

/// Which limits a solve holds, per move and per row: `1` the lower limit held, `-1` the
/// upper, `0` neither; a soft row's `2` or `-2`: its lower or upper limit saturated (its
/// multiplier at its penalty, the plan violating it by its slack). A solve starts from
/// those of its warm start and leaves its solution's.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HeldLimits<const M: usize, const R: usize> {
    /// Per move.
    pub moves: [i8; M],
    /// Per row.
    pub rows: [i8; R],
}

impl<const M: usize, const R: usize> HeldLimits<M, R> {
    /// Nothing held.
    pub const NONE: Self = HeldLimits {
        moves: [0; M],
        rows: [0; R],
    };
}

impl<const M: usize, const R: usize> HeldLimits<M, R> {
    /// The limits held a step on, for the next solve's warm start: over a horizon of
    /// `horizon` steps, each step's moves and rows move one step earlier (the first step's
    /// were applied), and the last step's start free.
    #[must_use]
    pub fn shifted(&self, horizon: usize) -> Self {
        let mut shifted = Self::NONE;
        let steps = horizon.max(1);
        for (held, state) in [
            (&mut shifted.moves[..], &self.moves[..]),
            (&mut shifted.rows[..], &self.rows[..]),
        ] {
            let per_step = state.len() / steps;
            if let Some(later) = state.get(per_step..) {
                held[..later.len()].copy_from_slice(later);
            }
        }
        shifted
    }
}

impl<const M: usize, const R: usize> Default for HeldLimits<M, R> {
    /// Nothing held.
    fn default() -> Self {
        Self::NONE
    }
}

/// What a solve returns: the moves, whether they are optimal, and the changes of the
/// held set it took.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MpcQpSolution<T, const M: usize> {
    /// The moves `v`: optimal when `optimal` is, else those of the last held set, which
    /// may violate limits not yet held (clip them to the moves' bounds).
    pub moves: [T; M],
    /// Whether no limit is violated by more than its tolerance but by a saturated soft
    /// row's slack, and every multiplier is within its bounds. False also when a hard
    /// limit could not be held: the hard limits are then infeasible (or dependent).
    pub optimal: bool,
    /// Limits held, released or saturated, at most the `max_iterations` given.
    pub iterations: usize,
}

/// What [`HeldSet::hold`] did.
enum Hold<T, const M: usize> {
    Held,
    /// Not held: the limit depends on those held, whose multipliers must fall along
    /// this direction as its own rises.
    Dependent([T; M]),
}

/// A limit: a move's bound (`index < M`) or a row's (`index - M`).
type Limit = usize;

/// The held limits in the order they were held, with `S`'s factor and their multipliers.
struct HeldSet<T, const M: usize> {
    /// Per held limit: which.
    limits: [Limit; M],
    /// Per held limit: its side, `+1` (lower) or `-1` (upper).
    sides: [T; M],
    /// Per held limit: its multiplier.
    multipliers: [T; M],
    /// `L` strictly below the diagonal, `D` on it; the first `len` rows are `S`'s factor.
    factor: [[T; M]; M],
    /// `1 / D`, row by row.
    reciprocals: [T; M],
    len: usize,
}

/// What the solve reads of a limit (a move's bound, `index < M`, or a row's).
trait Limits<T, const M: usize> {
    /// `G n` of a limit.
    fn column(&self, limit: Limit) -> &[T; M];
    /// `n' x` of a limit.
    fn value(&self, limit: Limit, x: &[T; M]) -> T;
    /// The limit's bound on its side `side`.
    fn bound(&self, limit: Limit, side: T) -> T;
    /// The penalty bounding a limit's multiplier: `None` for a move's bound and a hard row.
    fn penalty(&self, limit: Limit) -> Option<T>;
}

impl<T: Real, const M: usize, const R: usize> Limits<T, M> for MpcQp<'_, T, M, R> {
    fn column(&self, limit: Limit) -> &[T; M] {
        match limit.checked_sub(M) {
            None => &self.inverse[limit % M],
            Some(row) => &self.rows.columns[row % R.max(1)],
        }
    }

    fn value(&self, limit: Limit, x: &[T; M]) -> T {
        match limit.checked_sub(M) {
            None => x[limit % M],
            Some(row) => dot(&self.rows.coefficients[row % R.max(1)], x),
        }
    }

    fn bound(&self, limit: Limit, side: T) -> T {
        let lower = side > T::ZERO;
        match (limit.checked_sub(M), lower) {
            (None, true) => self.low[limit % M],
            (None, false) => self.high[limit % M],
            (Some(row), true) => self.rows.lower[row % R.max(1)],
            (Some(row), false) => self.rows.upper[row % R.max(1)],
        }
    }

    fn penalty(&self, limit: Limit) -> Option<T> {
        let row = limit.checked_sub(M)?;
        let penalty = self.rows.penalty[row % R.max(1)];
        penalty.finite().then_some(penalty)
    }
}

fn dot<T: Real, const M: usize>(a: &[T; M], b: &[T; M]) -> T {
    a.iter().zip(b).fold(T::ZERO, |sum, (&x, &y)| sum + x * y)
}

/// `1` for a lower limit's side, `-1` for an upper one's.
fn side_value<T: Real>(side: i8) -> T {
    let one = T::from_count(1);
    if side > 0 {
        one
    } else {
        T::ZERO - one
    }
}

/// `x + weight column`.
fn add_scaled<T: Real, const M: usize>(x: &mut [T; M], weight: T, column: &[T; M]) {
    for (x_i, &c) in x.iter_mut().zip(column) {
        *x_i = *x_i + weight * c;
    }
}

impl<T: Real, const M: usize> HeldSet<T, M> {
    fn empty() -> Self {
        HeldSet {
            limits: [0; M],
            sides: [T::ZERO; M],
            multipliers: [T::ZERO; M],
            factor: [[T::ZERO; M]; M],
            reciprocals: [T::ZERO; M],
            len: 0,
        }
    }

    /// Holds `limit` on `side` with the multiplier `multiplier`: `S`'s new row
    /// `s_j = side s_j n' G n_j` by forward substitution, `y = L^-1 s`, the factor's row
    /// `y / D` and pivot `n' G n - y' D^-1 y`. When the pivot is not positive (the limit
    /// depends on those held, or `M` are held), the set is unchanged and the answer is
    /// the direction `S^-1 s` in which the held multipliers must fall as the limit's
    /// rises, the moves unchanged.
    fn hold<const R: usize>(
        &mut self,
        qp: &MpcQp<T, M, R>,
        (limit, side): (Limit, T),
        multiplier: T,
    ) -> Hold<T, M> {
        let k = self.len.min(M);
        let own = qp.column(limit);
        // y = L^-1 s, then l = D^-1 y.
        let mut y = [T::ZERO; M];
        for c in 0..k {
            let mut entry = side * self.sides[c] * qp.value(limit, qp.column(self.limits[c]));
            for (&l, &y_t) in self.factor[c][..c].iter().zip(&y[..c]) {
                entry = entry - l * y_t;
            }
            y[c] = entry;
        }
        let diagonal = qp.value(limit, own);
        let mut pivot = diagonal;
        for (y_c, &reciprocal) in y[..k].iter_mut().zip(&self.reciprocals[..k]) {
            let l = *y_c * reciprocal;
            pivot = pivot - l * *y_c;
            *y_c = l;
        }
        // (A NaN pivot is not positive either.)
        let positive = pivot > T::from_count(M) * T::EPSILON * diagonal;
        let Some(row) = self.factor.get_mut(k).filter(|_| positive) else {
            // S^-1 s = L^-T l.
            for r in (0..k).rev() {
                let mut entry = y[r];
                for (row, &x_c) in self.factor[r + 1..k].iter().zip(&y[r + 1..k]) {
                    entry = entry - row[r] * x_c;
                }
                y[r] = entry;
            }
            return Hold::Dependent(y);
        };
        row[..k].copy_from_slice(&y[..k]);
        row[k] = pivot;
        self.reciprocals[k] = T::from_count(1) / pivot;
        self.limits[k] = limit;
        self.sides[k] = side;
        self.multipliers[k] = multiplier;
        self.len = k + 1;
        Hold::Held
    }

    /// Releases the held limit at position `j`: its row and column leave `S`, and the
    /// rows after it take `D_j l l'` (`l` its column of `L` below it) by a rank-one update
    /// of their factor, then move up one place.
    fn release(&mut self, j: usize) {
        let k = self.len.min(M);
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
            self.limits[r - 1] = self.limits[r];
            self.sides[r - 1] = self.sides[r];
            self.multipliers[r - 1] = self.multipliers[r];
        }
        self.len = k - 1;
    }

    /// Lets the held limit at position `j` go: released (its multiplier at zero), or,
    /// when it `saturates` (a soft row at its penalty), saturated: its term moves into
    /// `base` and `held` marks it `2` or `-2`.
    fn let_go<const R: usize>(
        &mut self,
        qp: &MpcQp<T, M, R>,
        (j, saturates): (usize, bool),
        base: &mut [T; M],
        held: &mut HeldLimits<M, R>,
    ) {
        let (limit, side) = (self.limits[j], self.sides[j]);
        let state = match (saturates, qp.penalty(limit)) {
            (true, Some(penalty)) => {
                add_scaled(base, side * penalty, qp.column(limit));
                if side > T::ZERO {
                    2
                } else {
                    -2
                }
            }
            _ => 0,
        };
        mark(held, limit, state);
        self.release(j);
    }

    /// The multipliers that hold every limit of the set exactly from the moves `base`,
    /// `S^-1 d`.
    fn equality_multipliers<const R: usize>(&self, qp: &MpcQp<T, M, R>, base: &[T; M]) -> [T; M] {
        let k = self.len.min(M);
        let mut x = [T::ZERO; M];
        for r in 0..k {
            let (limit, side) = (self.limits[r], self.sides[r]);
            let mut entry = side * (qp.bound(limit, side) - qp.value(limit, base));
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

    /// `v` with the held limits met again: one step of iterative refinement, the
    /// multipliers corrected by `S^-1` times what `v` misses of each held limit (in
    /// `f32`, `G`'s rounding on an ill-conditioned Hessian leaves the held limits off by
    /// far more than the moves' own rounding; the correction takes them to it).
    fn refined<const R: usize>(&mut self, qp: &MpcQp<T, M, R>, v: [T; M]) -> [T; M] {
        if self.len == 0 {
            return v;
        }
        let correction = self.equality_multipliers(qp, &v);
        let mut refined = v;
        for r in 0..self.len.min(M) {
            self.multipliers[r] = self.multipliers[r] + correction[r];
            add_scaled(
                &mut refined,
                self.sides[r] * correction[r],
                qp.column(self.limits[r]),
            );
        }
        refined
    }

    /// The moves of the current multipliers, `base + G N_W lambda`.
    fn moves<const R: usize>(&self, qp: &MpcQp<T, M, R>, base: &[T; M]) -> [T; M] {
        let mut v = *base;
        for r in 0..self.len.min(M) {
            add_scaled(
                &mut v,
                self.sides[r] * self.multipliers[r],
                qp.column(self.limits[r]),
            );
        }
        v
    }

    /// The blocking limit of a step from the multipliers towards `target`: the held
    /// limit whose multiplier reaches a bound first (zero, or a soft row's penalty), the
    /// step's length, and whether it reached the penalty; `None` when every target is
    /// within its bounds.
    fn blocking<const R: usize>(
        &self,
        qp: &MpcQp<T, M, R>,
        target: &[T; M],
    ) -> Option<(usize, T, bool)> {
        let mut first: Option<(usize, T, bool)> = None;
        for j in 0..self.len.min(M) {
            let (now, wanted) = (self.multipliers[j], target[j]);
            let reached = if wanted < T::ZERO {
                Some((now / (now - wanted), false))
            } else {
                match qp.penalty(self.limits[j]) {
                    Some(penalty) if wanted > penalty => {
                        Some(((penalty - now) / (wanted - now), true))
                    }
                    _ => None,
                }
            };
            if let Some((length, saturated)) = reached {
                let shorter = match first {
                    None => true,
                    Some((_, shortest, _)) => length < shortest,
                };
                if shorter {
                    first = Some((j, length, saturated));
                }
            }
        }
        first
    }
}

/// Marks `limit` in `held` as `state`.
fn mark<const M: usize, const R: usize>(held: &mut HeldLimits<M, R>, limit: Limit, state: i8) {
    match limit.checked_sub(M) {
        None => held.moves[limit % M] = state,
        Some(row) => {
            if let Some(entry) = held.rows.get_mut(row) {
                *entry = state;
            }
        }
    }
}

/// How far the moves `v` are past a limit on `side` beyond its tolerance (positive:
/// violated): a move's tolerance is `tolerance (high - low)`, a row's
/// `tolerance (1 + |bound|)`.
fn excess<T: Real, const M: usize, const R: usize>(
    qp: &MpcQp<T, M, R>,
    (limit, side): (Limit, T),
    value: T,
    tolerance: T,
) -> T {
    let bound = qp.bound(limit, side);
    let scale = if limit < M {
        qp.high[limit % M] - qp.low[limit % M]
    } else {
        let magnitude = if bound < T::ZERO {
            T::ZERO - bound
        } else {
            bound
        };
        T::from_count(1) + magnitude
    };
    side * (bound - value) - tolerance * scale
}

/// The limit most violated by `v` among those neither held nor saturated, or the
/// saturated soft row the moves satisfy with the most room (its multiplier must come
/// down from its penalty): the limit, its side, and whether it was saturated.
fn most_violated<T: Real, const M: usize, const R: usize>(
    qp: &MpcQp<T, M, R>,
    v: &[T; M],
    held: &HeldLimits<M, R>,
    tolerance: T,
) -> Option<(Limit, i8, bool)> {
    let mut worst = None;
    let mut largest = T::ZERO;
    let mut consider = |candidate: (Limit, i8, bool), amount: T| {
        if amount > largest {
            largest = amount;
            worst = Some(candidate);
        }
    };
    // The moves' bounds, directly: the check every solve makes.
    for i in 0..M {
        if held.moves[i] == 0 {
            let allowed = tolerance * (qp.high[i] - qp.low[i]);
            consider((i, 1, false), qp.low[i] - v[i] - allowed);
            consider((i, -1, false), v[i] - qp.high[i] - allowed);
        }
    }
    for r in 0..R {
        let limit = M + r;
        let value = qp.value(limit, v);
        match held.rows[r] {
            0 => {
                for side in [1, -1] {
                    let amount = excess(qp, (limit, side_value(side)), value, tolerance);
                    consider((limit, side, false), amount);
                }
            }
            2 | -2 => {
                // Satisfied with room beyond its tolerance: `-excess` is the room.
                let side = held.rows[r] / 2;
                let s = side_value(side);
                let room = T::ZERO - excess(qp, (limit, s), value, T::ZERO);
                let allowed = excess(qp, (limit, s), value, T::ZERO)
                    - excess(qp, (limit, s), value, tolerance);
                consider((limit, side, true), room - allowed);
            }
            _ => {}
        }
    }
    worst
}

/// The moves without the held set's terms: `v*` plus each saturated soft row's
/// `penalty s G a`, the saturations of the warm start whose row is hard or whose limit is
/// infinite dropped.
fn saturated_base<T: Real, const M: usize, const R: usize>(
    qp: &MpcQp<T, M, R>,
    held: &mut HeldLimits<M, R>,
) -> [T; M] {
    let mut base = *qp.unconstrained;
    // Only a soft row saturates.
    for state in held.moves.iter_mut() {
        if !(-1..=1).contains(state) {
            *state = 0;
        }
    }
    for r in 0..R {
        let state = held.rows[r];
        if state == 2 || state == -2 {
            let side = side_value(state);
            match qp.penalty(M + r) {
                Some(penalty) if qp.bound(M + r, side).finite() => {
                    add_scaled(&mut base, side * penalty, &qp.rows.columns[r]);
                }
                _ => held.rows[r] = 0,
            }
        } else if !(-1..=1).contains(&state) {
            held.rows[r] = 0;
        }
    }
    base
}

/// Holds the warm start's limits (`1` or `-1`) in the set, moves first; drops those that
/// cannot be held (an infinite limit, or one dependent on those already held).
fn hold_warm_start<T: Real, const M: usize, const R: usize>(
    qp: &MpcQp<T, M, R>,
    held: &mut HeldLimits<M, R>,
) -> HeldSet<T, M> {
    let mut set = HeldSet::<T, M>::empty();
    for limit in 0..M + R {
        let state = match limit.checked_sub(M) {
            None => held.moves[limit],
            Some(row) => held.rows[row],
        };
        if state == 1 || state == -1 {
            let side = side_value(state);
            let holdable = qp.bound(limit, side).finite()
                && matches!(set.hold(qp, (limit, side), T::ZERO), Hold::Held);
            if !holdable {
                mark(held, limit, 0);
            }
        }
    }
    set
}

/// A limit being held, its multiplier rising from `multiplier`.
struct Adding<T> {
    limit: Limit,
    side: T,
    multiplier: T,
}

impl<T: Real> Adding<T> {
    /// Holds the limit. When it depends on those held, the dual step of Goldfarb and
    /// Idnani's method with a zero primal step: its multiplier rises by `t` and the held
    /// ones fall by `t r` (the moves unchanged) until one reaches a bound, which is
    /// released (at zero) or saturates (a soft row at its penalty), and the limit is held
    /// again; or until its own reaches its penalty, when it saturates itself. False when
    /// nothing bounds the step: the hard limits cannot be met together.
    fn add<const M: usize, const R: usize>(
        &mut self,
        qp: &MpcQp<T, M, R>,
        (set, held): (&mut HeldSet<T, M>, &mut HeldLimits<M, R>),
        base: &mut [T; M],
        iterations: &mut usize,
    ) -> bool {
        loop {
            let direction = match set.hold(qp, (self.limit, self.side), self.multiplier) {
                Hold::Held => {
                    mark(held, self.limit, if self.side > T::ZERO { 1 } else { -1 });
                    return true;
                }
                Hold::Dependent(direction) => direction,
            };
            let k = set.len.min(M);
            // (which held limit blocks, if not the limit itself; the step; whether it
            // saturates)
            let mut first: Option<(Option<usize>, T, bool)> = qp
                .penalty(self.limit)
                .map(|penalty| (None, penalty - self.multiplier, true));
            for j in 0..k {
                let (now, rate) = (set.multipliers[j], direction[j]);
                let (length, saturates) = if rate > T::ZERO {
                    (now / rate, false)
                } else {
                    match qp.penalty(set.limits[j]) {
                        Some(penalty) if rate < T::ZERO => {
                            ((penalty - now) / (T::ZERO - rate), true)
                        }
                        _ => continue,
                    }
                };
                if first.is_none_or(|(_, shortest, _)| length < shortest) {
                    first = Some((Some(j), length, saturates));
                }
            }
            let Some((blocking, length, saturates)) = first else {
                return false;
            };
            for j in 0..k {
                set.multipliers[j] = set.multipliers[j] - length * direction[j];
            }
            self.multiplier = self.multiplier + length;
            let Some(j) = blocking else {
                // Its own penalty reached: the row saturates.
                add_scaled(base, self.side * self.multiplier, qp.column(self.limit));
                mark(held, self.limit, if self.side > T::ZERO { 2 } else { -2 });
                return true;
            };
            set.let_go(qp, (j, saturates), base, held);
            *iterations += 1;
        }
    }
}

/// Solves the MPC's QP `qp`, warm-started from `held`, which it leaves as the solution's
/// held and saturated limits; at most `max_iterations` changes of that set. A limit
/// counts as violated beyond its tolerance ([`excess`]).
pub(crate) fn solve<T: Real, const M: usize, const R: usize>(
    qp: &MpcQp<T, M, R>,
    held: &mut HeldLimits<M, R>,
    (max_iterations, tolerance): (usize, T),
) -> MpcQpSolution<T, M> {
    let mut base = saturated_base(qp, held);
    let solution = |moves, optimal, iterations| MpcQpSolution {
        moves,
        optimal,
        iterations,
    };
    // Without a limit held exactly, `base` is the solution when it violates none: no
    // factor to set up.
    let nothing_held = held
        .moves
        .iter()
        .chain(&held.rows)
        .all(|&s| s != 1 && s != -1);
    if nothing_held && most_violated(qp, &base, held, tolerance).is_none() {
        return solution(base, true, 0);
    }
    let mut set = hold_warm_start(qp, held);
    let mut iterations = 0;
    while iterations < max_iterations {
        let target = set.equality_multipliers(qp, &base);
        if let Some((j, length, saturated)) = set.blocking(qp, &target) {
            for r in 0..set.len.min(M) {
                let m = set.multipliers[r];
                set.multipliers[r] = m + length * (target[r] - m);
            }
            set.let_go(qp, (j, saturated), &mut base, held);
            iterations += 1;
            continue;
        }
        set.multipliers = target;
        let v = set.moves(qp, &base);
        let Some((limit, side, was_saturated)) = most_violated(qp, &v, held, tolerance) else {
            return solution(set.refined(qp, v), true, iterations);
        };
        let s = side_value::<T>(side);
        let penalty = qp.penalty(limit).filter(|_| was_saturated);
        // A saturated row's term moves from the base into the held set, its multiplier
        // still its penalty.
        if let Some(penalty) = penalty {
            add_scaled(&mut base, T::ZERO - s * penalty, qp.column(limit));
        }
        let mut adding = Adding {
            limit,
            side: s,
            multiplier: penalty.unwrap_or(T::ZERO),
        };
        let added = adding.add(qp, (&mut set, held), &mut base, &mut iterations);
        iterations += 1;
        if !added {
            return solution(set.moves(qp, &base), false, iterations);
        }
    }
    // Out of iterations: the moves of the multipliers reached.
    let target = set.equality_multipliers(qp, &base);
    let settled = set.blocking(qp, &target).is_none();
    if settled {
        set.multipliers = target;
    }
    let v = set.moves(qp, &base);
    let optimal = settled && most_violated(qp, &v, held, tolerance).is_none();
    solution(v, optimal, iterations)
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

/// `G a` for each row `a` of `rows`: what a generated MPC keeps of its limit rows.
pub(crate) fn columns<T: Real, const M: usize, const R: usize>(
    inverse: &[[T; M]; M],
    rows: &[[T; M]; R],
) -> [[T; M]; R] {
    core::array::from_fn(|r| core::array::from_fn(|i| dot(&inverse[i], &rows[r])))
}

#[cfg(test)]
mod tests {
    use super::{symmetric_inverse, HeldLimits, LimitRows, MpcQp, MpcQpSolution};
    use crate::test_rng::Lcg;
    use nalgebra::{SMatrix, SVector};

    /// The solve of the box-constrained problem alone (no rows), from `held`.
    fn solve<const M: usize>(
        inverse: &[[f64; M]; M],
        unconstrained: &[f64; M],
        (low, high): (&[f64; M], &[f64; M]),
        held: &mut [i8; M],
        limits: (usize, f64),
    ) -> MpcQpSolution<f64, M> {
        let qp = MpcQp {
            inverse,
            unconstrained,
            low,
            high,
            rows: LimitRows {
                coefficients: &[],
                columns: &[],
                lower: &[],
                upper: &[],
                penalty: &[],
            },
        };
        let mut limits_held = HeldLimits::<M, 0> {
            moves: *held,
            rows: [],
        };
        let solution = super::solve(&qp, &mut limits_held, limits);
        *held = limits_held.moves;
        solution
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
    fn the_held_limits_move_a_step_earlier() {
        // Three steps of two moves and one row each.
        let held = HeldLimits::<6, 3> {
            moves: [1, -1, 0, 1, -1, -1],
            rows: [2, 0, -1],
        };
        let shifted = held.shifted(3);
        assert_eq!(shifted.moves, [0, 1, -1, -1, 0, 0]);
        assert_eq!(shifted.rows, [0, -1, 0]);
        assert_eq!(HeldLimits::<6, 0>::NONE.shifted(3).moves, [0; 6]);
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
