//! The MPC's QP solver (`stateforge_math::f64::mpc_qp`: a dual active set on `H^-1`)
//! against Clarabel on random problems with bounds on the moves and limit rows, hard and
//! soft, active and inactive, cold and warm-started; and what it returns when hard limits
//! cannot be met or its iterations run out.

use nalgebra::{DMatrix, DVector};
use stateforge_math::f64::{limit_columns, mpc_qp, symmetric_inverse};
use stateforge_math::{HeldLimits, LimitRows, MpcQp};
use tests::predictive_reference::{limited_qp, LimitRow};
use tests::rng::Lcg;

/// A random problem: `H = A' A + I/10` with columns over three decades, `c`, bounds
/// around zero, and rows whose limits sit near the moves of a point within the bounds
/// (so the hard rows are feasible together), some hard and some soft.
struct Problem<const M: usize, const R: usize> {
    h: [[f64; M]; M],
    c: [f64; M],
    low: [f64; M],
    high: [f64; M],
    rows: [[f64; M]; R],
    lower: [f64; R],
    upper: [f64; R],
    penalty: [f64; R],
}

impl<const M: usize, const R: usize> Problem<M, R> {
    fn random(rng: &mut Lcg) -> Self {
        let a = DMatrix::<f64>::from_fn(M, M, |_, j| {
            rng.uniform() * 10_f64.powf(3.0 * j as f64 / M as f64 - 1.5)
        });
        let hessian = a.transpose() * a + DMatrix::identity(M, M) * 0.1;
        let h = core::array::from_fn(|i| core::array::from_fn(|j| hessian[(i, j)]));
        let c = core::array::from_fn(|_| 5.0 * rng.uniform());
        let low = core::array::from_fn(|_| -1.0 - 0.5 * rng.uniform().abs());
        let high = core::array::from_fn(|_| 1.0 + 0.5 * rng.uniform().abs());
        let inside: [f64; M] = core::array::from_fn(|_| 0.8 * rng.uniform());
        let rows: [[f64; M]; R] = core::array::from_fn(|_| {
            core::array::from_fn(|_| {
                if rng.uniform() > 0.0 {
                    rng.uniform()
                } else {
                    0.0
                }
            })
        });
        let at = |r: usize| -> f64 { rows[r].iter().zip(&inside).map(|(a, v)| a * v).sum() };
        let mut lower = [f64::NEG_INFINITY; R];
        let mut upper = [f64::INFINITY; R];
        for r in 0..R {
            let width = 0.3 * rng.uniform().abs();
            match rng.uniform() {
                u if u < -0.3 => lower[r] = at(r) - width,
                u if u < 0.4 => upper[r] = at(r) + width,
                _ => {
                    lower[r] = at(r) - width;
                    upper[r] = at(r) + width;
                }
            }
        }
        let penalty = core::array::from_fn(|_| match rng.uniform() {
            u if u < 0.0 => f64::INFINITY,
            u => 0.2 + 3.0 * u,
        });
        Problem {
            h,
            c,
            low,
            high,
            rows,
            lower,
            upper,
            penalty,
        }
    }

    /// The solver's answer from `held`, with `G`, `v*` and `G a` computed here.
    fn solve(&self, held: &mut HeldLimits<M, R>, max_iterations: usize) -> ([f64; M], bool, usize) {
        let inverse = symmetric_inverse(&self.h).expect("positive definite");
        let unconstrained: [f64; M] = core::array::from_fn(|i| {
            -inverse[i]
                .iter()
                .zip(&self.c)
                .map(|(g, c)| g * c)
                .sum::<f64>()
        });
        let columns = limit_columns(&inverse, &self.rows);
        let qp = MpcQp {
            inverse: &inverse,
            unconstrained: &unconstrained,
            low: &self.low,
            high: &self.high,
            rows: LimitRows {
                coefficients: &self.rows,
                columns: &columns,
                lower: &self.lower,
                upper: &self.upper,
                penalty: &self.penalty,
            },
        };
        let solution = mpc_qp(&qp, held, max_iterations, 1e-12);
        (solution.moves, solution.optimal, solution.iterations)
    }

    /// Clarabel's moves.
    fn reference(&self) -> DVector<f64> {
        let h = DMatrix::from_fn(M, M, |i, j| self.h[i][j]);
        let c = DVector::from_row_slice(&self.c);
        let rows: Vec<LimitRow> = (0..R)
            .map(|r| LimitRow {
                coefficients: self.rows[r].to_vec(),
                lower: self.lower[r],
                upper: self.upper[r],
                penalty: self.penalty[r].is_finite().then_some(self.penalty[r]),
            })
            .collect();
        limited_qp(&h, &c, (&self.low, &self.high), &rows)
    }
}

/// Random problems of `M` moves and `R` rows: every plan within `1e-6` of Clarabel's,
/// cold and from a random warm start; returns how many limits the solutions held and
/// saturated, over all problems.
fn agrees_with_clarabel<const M: usize, const R: usize>(seed: u64) -> (usize, usize) {
    let mut rng = Lcg(seed);
    let (mut held_total, mut saturated_total) = (0, 0);
    for problem in 0..60 {
        let p = Problem::<M, R>::random(&mut rng);
        let expected = p.reference();
        let mut warm = HeldLimits::<M, R>::NONE;
        for state in warm.moves.iter_mut().chain(warm.rows.iter_mut()) {
            *state = match rng.uniform() {
                u if u < -0.8 => -1,
                u if u > 0.8 => 1,
                u if u > 0.7 => 2,
                _ => 0,
            };
        }
        for start in [HeldLimits::NONE, warm] {
            let mut held = start;
            let (moves, optimal, _) = p.solve(&mut held, 500);
            assert!(optimal, "problem {problem}");
            let error = moves
                .iter()
                .zip(expected.iter())
                .map(|(v, e)| (v - e).abs())
                .fold(0.0, f64::max);
            assert!(error < 1e-6, "problem {problem}: {error:e}");
            for (r, state) in held.rows.iter().enumerate() {
                if *state == 2 || *state == -2 {
                    assert!(p.penalty[r].is_finite(), "a hard row saturated");
                }
            }
            held_total += held
                .moves
                .iter()
                .chain(&held.rows)
                .filter(|&&s| s == 1 || s == -1)
                .count();
            saturated_total += held.rows.iter().filter(|&&s| s == 2 || s == -2).count();
        }
    }
    (held_total, saturated_total)
}

#[test]
fn random_limited_problems_agree_with_clarabel() {
    let (held, saturated) = agrees_with_clarabel::<8, 4>(1);
    assert!(
        held > 100 && saturated > 10,
        "{held} held, {saturated} saturated"
    );
    let (held, saturated) = agrees_with_clarabel::<24, 12>(2);
    assert!(
        held > 100 && saturated > 10,
        "{held} held, {saturated} saturated"
    );
}

#[test]
fn a_row_without_limits_is_the_box_problem() {
    let mut rng = Lcg(5);
    for _ in 0..20 {
        let mut p = Problem::<12, 3>::random(&mut rng);
        p.lower = [f64::NEG_INFINITY; 3];
        p.upper = [f64::INFINITY; 3];
        let expected = p.reference();
        let (moves, optimal, _) = p.solve(&mut HeldLimits::default(), 100);
        assert!(optimal);
        for (v, e) in moves.iter().zip(expected.iter()) {
            assert!((v - e).abs() < 1e-6);
        }
    }
}

#[test]
fn hard_limits_that_cannot_be_met_are_not_optimal() {
    let mut rng = Lcg(9);
    let mut p = Problem::<6, 2>::random(&mut rng);
    // Two rows that ask v_1 >= 5 through a' v with a = e_1, beyond its bound 1.5.
    p.rows = [[0.0; 6]; 2];
    p.rows[0][0] = 1.0;
    p.rows[1][0] = 1.0;
    p.lower = [5.0, 5.0];
    p.upper = [f64::INFINITY; 2];
    p.penalty = [f64::INFINITY; 2];
    let (moves, optimal, _) = p.solve(&mut HeldLimits::default(), 100);
    assert!(!optimal, "{moves:?}");
    // Soft, the same limit is met as far as the bound allows, its slack paid for.
    p.penalty = [1e3, 1e3];
    let (moves, optimal, _) = p.solve(&mut HeldLimits::default(), 100);
    assert!(optimal);
    assert!((moves[0] - p.high[0]).abs() < 1e-9, "{moves:?}");
}

#[test]
fn a_solve_out_of_iterations_is_not_optimal_and_a_warm_start_finishes_it() {
    let mut rng = Lcg(13);
    let p = Problem::<24, 12>::random(&mut rng);
    let mut held = HeldLimits::NONE;
    let (full, optimal, iterations) = p.solve(&mut held, 500);
    assert!(optimal && iterations >= 3, "{iterations}");
    let mut cut = HeldLimits::NONE;
    let (_, optimal, taken) = p.solve(&mut cut, 2);
    assert!(!optimal);
    assert_eq!(taken, 2);
    // From the solution's held set, nothing changes.
    let (again, optimal, iterations) = p.solve(&mut held, 500);
    assert!(optimal);
    assert_eq!(iterations, 0);
    for (a, f) in again.iter().zip(&full) {
        assert!((a - f).abs() < 1e-9);
    }
}
