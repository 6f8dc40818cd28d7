//! What a generated MPC keeps of its condensed QP for the dual active set, `G = H^-1` and
//! the unconstrained plan's gain, computed by the Riccati recursion over the horizon
//! without ever forming the condensed Hessian `H`.
//!
//! `H = Gamma' Qbar Gamma + Rbar` (`Qbar = diag(Q, .., Q, P_f)`, `Rbar = diag(R, .., R)`,
//! `Gamma` the moves' responses) is ill-conditioned when the model integrates its inputs
//! (TinyMPC's quadrotor: a position from a tilt from a rate, condition number 1.7e5), and
//! in `f32` the rounding of `H`'s sums, amplified by that, decides the plan's accuracy
//! (2.6e-3 of the input range where the QP's own solve reaches 1e-5). The recursion
//! factors `H` instead (the backward Riccati recursion is the `L D L'` factorisation of
//! the condensed problem):
//!
//! ```text
//! P_N = P_f,  D_k = R + B' P_(k+1) B,  K_k = D_k^-1 B' P_(k+1) A,
//! P_k = Q + A' P_(k+1) A - (B' P_(k+1) A)' K_k        (k = N-1, .., 0)
//! ```
//!
//! With the moves written along the closed loop, `u_k = c_k - K_k x_k`,
//! `x_(k+1) = (A - B K_k) x_k + B c_k`, the cost is `sum_k c_k' D_k c_k` plus a term in
//! `x_0` alone; as `u = T c + S x_0` (`T` unit block lower triangular,
//! `T_kj = -K_k Phi_(k-1) .. Phi_(j+1) B`, `Phi_k = A - B K_k`), `H = T^-T D T^-1`, so
//! `G = T D^-1 T'`, and the unconstrained plan is `c = 0`: `v* = S x_0`, `S`'s block `k`
//! `-K_k Phi_(k-1) .. Phi_0`. Every product is of the closed loop's stable quantities;
//! none is of `H`. These are loops (they run only when the model or the weights change),
//! where a generated solve's per-step code is straight-line.

#![allow(clippy::needless_range_loop)] // Matrices are indexed by row and column, as written.

use crate::covariance::Real;
use crate::mpc_qp::symmetric_inverse;

/// `G = H^-1` of a generated MPC's condensed Hessian and its unconstrained plan's gain
/// `K` (`v* = -K x`, `x` the regulated states' deviation from their reference), kept
/// transposed: per state, per move.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CondensedInverse<T, const M: usize, const NS: usize> {
    /// `G = H^-1`, symmetric positive definite, exactly symmetric.
    pub inverse: [[T; M]; M],
    /// `K'`: row `j` is the plan's response to state `j`, negated.
    pub gain: [[T; M]; NS],
}

/// The prediction model and weights of a condensed QP: `x_(k+1) = A x_k + B u_k`, cost
/// `sum_(k<N) x_k' Q x_k + u_k' R u_k + x_N' P_f x_N`.
#[derive(Clone, Copy, Debug)]
pub struct PredictionProblem<'a, T, const NS: usize, const NU: usize> {
    /// `A`.
    pub a: &'a [[T; NS]; NS],
    /// `B`.
    pub b: &'a [[T; NU]; NS],
    /// `Q`, symmetric.
    pub q: &'a [[T; NS]; NS],
    /// `R`, symmetric positive definite.
    pub r: &'a [[T; NU]; NU],
    /// The terminal weight `P_f`, symmetric.
    pub terminal: &'a [[T; NS]; NS],
}

/// The backward recursion's gains `K_k` (rows `k NU ..`) and `D_k^-1` (the same rows).
struct Backward<T, const M: usize, const NS: usize, const NU: usize> {
    gains: [[T; NS]; M],
    inverse_weights: [[T; NU]; M],
}

/// `G` and `K'` for `M / NU` moves of `NU` inputs; `None` when `M` is not a whole number
/// of moves, a `D_k` is not positive definite to within rounding, or an entry of `G` or
/// `K'` is not finite.
pub(crate) fn condensed_inverse<T: Real, const M: usize, const NS: usize, const NU: usize>(
    problem: &PredictionProblem<T, NS, NU>,
) -> Option<CondensedInverse<T, M, NS>> {
    if NU == 0 || !M.is_multiple_of(NU) {
        return None;
    }
    let backward = backward::<T, M, NS, NU>(problem)?;
    let gain = unconstrained_gain(problem, &backward);
    if !gain.iter().flatten().all(|g| g.finite()) {
        return None;
    }
    let inverse = inverse(&closed_loop_responses(problem, &backward), &backward)?;
    Some(CondensedInverse { inverse, gain })
}

/// `K_k` and `D_k^-1` from `P_N = P_f` back to `k = 0`; `P_k` symmetric by construction
/// (its upper triangle computed and mirrored).
fn backward<T: Real, const M: usize, const NS: usize, const NU: usize>(
    problem: &PredictionProblem<T, NS, NU>,
) -> Option<Backward<T, M, NS, NU>> {
    let PredictionProblem { a, b, r, .. } = *problem;
    let mut out = Backward {
        gains: [[T::ZERO; NS]; M],
        inverse_weights: [[T::ZERO; NU]; M],
    };
    let mut p = *problem.terminal;
    for k in (0..M / NU).rev() {
        // B' P, then D = R + B' P B and B' P A.
        let bt_p: [[T; NS]; NU] =
            core::array::from_fn(|i| core::array::from_fn(|j| column_dot(b, i, &p, j)));
        let d: [[T; NU]; NU] = core::array::from_fn(|i| {
            core::array::from_fn(|j| r[i][j] + row_column(&bt_p[i], b, j))
        });
        let d_inverse = symmetric_inverse(&d)?;
        let bt_p_a: [[T; NS]; NU] =
            core::array::from_fn(|i| core::array::from_fn(|j| row_column(&bt_p[i], a, j)));
        for i in 0..NU {
            for j in 0..NS {
                let mut entry = T::ZERO;
                for l in 0..NU {
                    entry = entry + d_inverse[i][l] * bt_p_a[l][j];
                }
                out.gains[k * NU + i][j] = entry;
            }
            out.inverse_weights[k * NU + i] = d_inverse[i];
        }
        if k > 0 {
            p = next_weight(problem, &p, &bt_p_a, &out.gains[k * NU..(k + 1) * NU]);
        }
    }
    Some(out)
}

/// `P_k = Q + A' P A - (B' P A)' K_k`, its upper triangle mirrored.
fn next_weight<T: Real, const NS: usize, const NU: usize>(
    problem: &PredictionProblem<T, NS, NU>,
    p: &[[T; NS]; NS],
    bt_p_a: &[[T; NS]; NU],
    gain: &[[T; NS]],
) -> [[T; NS]; NS] {
    let (a, q) = (problem.a, problem.q);
    let p_a: [[T; NS]; NS] =
        core::array::from_fn(|i| core::array::from_fn(|j| row_column(&p[i], a, j)));
    let mut next = [[T::ZERO; NS]; NS];
    for i in 0..NS {
        for j in i..NS {
            let mut entry = q[i][j] + column_dot(a, i, &p_a, j);
            for l in 0..NU {
                entry = entry - bt_p_a[l][i] * gain[l][j];
            }
            next[i][j] = entry;
            next[j][i] = entry;
        }
    }
    next
}

/// `K'` of `v* = -K x`: block `k` of `K` is `K_k Phi_(k-1) .. Phi_0`.
fn unconstrained_gain<T: Real, const M: usize, const NS: usize, const NU: usize>(
    problem: &PredictionProblem<T, NS, NU>,
    backward: &Backward<T, M, NS, NU>,
) -> [[T; M]; NS] {
    let mut gain = [[T::ZERO; M]; NS];
    // The closed loop's transition from x_0, `Phi_(k-1) .. Phi_0`.
    let mut transition: [[T; NS]; NS] = core::array::from_fn(|i| {
        core::array::from_fn(|j| if i == j { T::from_count(1) } else { T::ZERO })
    });
    for k in 0..M / NU {
        let k_x: [[T; NS]; NU] = core::array::from_fn(|i| {
            core::array::from_fn(|j| row_column(&backward.gains[k * NU + i], &transition, j))
        });
        for (i, row) in k_x.iter().enumerate() {
            for (j, &entry) in row.iter().enumerate() {
                gain[j][k * NU + i] = entry;
            }
        }
        transition = closed_loop_step(problem, &transition, &k_x);
    }
    gain
}

/// `A X - B (K_k X)`: `X` a step further along the closed loop, given `K_k X`.
fn closed_loop_step<T: Real, const NS: usize, const NU: usize, const C: usize>(
    problem: &PredictionProblem<T, NS, NU>,
    x: &[[T; C]; NS],
    k_x: &[[T; C]; NU],
) -> [[T; C]; NS] {
    let (a, b) = (problem.a, problem.b);
    core::array::from_fn(|i| {
        core::array::from_fn(|j| row_column(&a[i], x, j) - row_column(&b[i], k_x, j))
    })
}

/// `T`, row by row (moves), column by column (the closed loop's moves `c`): unit block
/// lower triangular, `T_kj = -K_k Phi_(k-1) .. Phi_(j+1) B` below the diagonal.
fn closed_loop_responses<T: Real, const M: usize, const NS: usize, const NU: usize>(
    problem: &PredictionProblem<T, NS, NU>,
    backward: &Backward<T, M, NS, NU>,
) -> [[T; M]; M] {
    let mut t = [[T::ZERO; M]; M];
    let horizon = M / NU;
    for j in 0..horizon {
        for i in 0..NU {
            t[j * NU + i][j * NU + i] = T::from_count(1);
        }
        // The closed loop's response to c_j, `Phi_(k-1) .. Phi_(j+1) B`.
        let mut response = *problem.b;
        for k in j + 1..horizon {
            // K_k Phi_(k-1) .. Phi_(j+1) B: block (k, j) of T, negated.
            let k_z: [[T; NU]; NU] = core::array::from_fn(|i| {
                core::array::from_fn(|c| row_column(&backward.gains[k * NU + i], &response, c))
            });
            for (i, row) in k_z.iter().enumerate() {
                for (c, &entry) in row.iter().enumerate() {
                    t[k * NU + i][j * NU + c] = T::ZERO - entry;
                }
            }
            if k + 1 < horizon {
                response = closed_loop_step(problem, &response, &k_z);
            }
        }
    }
    t
}

/// `G = T D^-1 T'`, over the blocks where `T` is not zero; `None` if an entry is not
/// finite.
fn inverse<T: Real, const M: usize, const NS: usize, const NU: usize>(
    t: &[[T; M]; M],
    backward: &Backward<T, M, NS, NU>,
) -> Option<[[T; M]; M]> {
    let mut g = [[T::ZERO; M]; M];
    for row in 0..M {
        // Row `row` of T D^-1: T's row is zero past its own block.
        let width = (row / NU + 1) * NU;
        let mut weighted = [T::ZERO; M];
        for column in 0..width {
            let block = column / NU * NU;
            let mut entry = T::ZERO;
            for l in 0..NU {
                entry =
                    entry + t[row][block + l] * backward.inverse_weights[block + l][column - block];
            }
            weighted[column] = entry;
        }
        for other in row..M {
            let mut entry = T::ZERO;
            for column in 0..width {
                entry = entry + weighted[column] * t[other][column];
            }
            if !entry.finite() {
                return None;
            }
            g[row][other] = entry;
            g[other][row] = entry;
        }
    }
    Some(g)
}

/// `(X' Y)_ij`: column `i` of `x` dotted with column `j` of `y`.
fn column_dot<T: Real, const R: usize, const C: usize, const D: usize>(
    x: &[[T; C]; R],
    i: usize,
    y: &[[T; D]; R],
    j: usize,
) -> T {
    (0..R).fold(T::ZERO, |sum, l| sum + x[l][i] * y[l][j])
}

/// `row . y[.][j]`: a row times column `j` of `y`.
fn row_column<T: Real, const R: usize, const C: usize>(
    row: &[T; R],
    y: &[[T; C]; R],
    j: usize,
) -> T {
    (0..R).fold(T::ZERO, |sum, l| sum + row[l] * y[l][j])
}

#[cfg(test)]
mod tests {
    use super::{condensed_inverse, PredictionProblem};
    use crate::test_rng::Lcg;
    use nalgebra::{DMatrix, SMatrix};

    const NS: usize = 4;
    const NU: usize = 2;
    const HORIZON: usize = 5;
    const M: usize = HORIZON * NU;

    /// A random `R x C` matrix, entries in `[-1, 1)`.
    fn random<const R: usize, const C: usize>(rng: &mut Lcg) -> [[f64; C]; R] {
        core::array::from_fn(|_| core::array::from_fn(|_| rng.uniform()))
    }

    /// A random weight `X' X + I / 10`, symmetric positive definite.
    fn weight<const N: usize>(rng: &mut Lcg) -> [[f64; N]; N] {
        let x = SMatrix::<f64, N, N>::from_fn(|_, _| rng.uniform());
        let w = x.transpose() * x + SMatrix::<f64, N, N>::identity() * 0.1;
        core::array::from_fn(|i| core::array::from_fn(|j| w[(i, j)]))
    }

    fn dense<const R: usize, const C: usize>(m: &[[f64; C]; R]) -> DMatrix<f64> {
        DMatrix::from_fn(R, C, |i, j| m[i][j])
    }

    /// `H` and `F` (`c = F x_0`) condensed directly: `Gamma' Qbar Gamma + Rbar`,
    /// `Gamma' Qbar Phi`.
    fn condensed(problem: &PredictionProblem<f64, NS, NU>) -> (DMatrix<f64>, DMatrix<f64>) {
        let (a, b) = (dense(problem.a), dense(problem.b));
        let mut gamma = DMatrix::zeros(HORIZON * NS, M);
        let mut phi = DMatrix::zeros(HORIZON * NS, NS);
        let mut qbar = DMatrix::zeros(HORIZON * NS, HORIZON * NS);
        let mut rbar = DMatrix::zeros(M, M);
        let mut power = DMatrix::identity(NS, NS);
        for k in 0..HORIZON {
            // x_(k+1) = A^(k+1) x_0 + sum_(j<=k) A^(k-j) B u_j.
            let mut response = b.clone();
            for j in (0..=k).rev() {
                gamma
                    .view_mut((k * NS, j * NU), (NS, NU))
                    .copy_from(&response);
                response = &a * response;
            }
            power = &a * power;
            phi.view_mut((k * NS, 0), (NS, NS)).copy_from(&power);
            let weight = if k + 1 == HORIZON {
                problem.terminal
            } else {
                problem.q
            };
            qbar.view_mut((k * NS, k * NS), (NS, NS))
                .copy_from(&dense(weight));
            rbar.view_mut((k * NU, k * NU), (NU, NU))
                .copy_from(&dense(problem.r));
        }
        let h = gamma.transpose() * &qbar * &gamma + rbar;
        let f = gamma.transpose() * qbar * phi;
        (h, f)
    }

    #[test]
    fn the_inverse_and_gain_are_the_directly_condensed_problems() {
        let mut rng = Lcg(11);
        for _ in 0..20 {
            // Unstable as often as not: entries up to 1.5 in size.
            let a = random::<NS, NS>(&mut rng).map(|row| row.map(|x| 1.5 * x));
            let b = random::<NS, NU>(&mut rng);
            let (q, r, terminal) = (
                weight::<NS>(&mut rng),
                weight::<NU>(&mut rng),
                weight::<NS>(&mut rng),
            );
            let problem = PredictionProblem {
                a: &a,
                b: &b,
                q: &q,
                r: &r,
                terminal: &terminal,
            };
            let (h, f) = condensed(&problem);
            let expected = h.clone().try_inverse().expect("positive definite");
            let gain = &expected * f;
            let ours = condensed_inverse::<f64, M, NS, NU>(&problem).expect("positive definite");
            let scale = expected.amax();
            for i in 0..M {
                for j in 0..M {
                    assert!((ours.inverse[i][j] - expected[(i, j)]).abs() <= 1e-9 * scale);
                }
                for s in 0..NS {
                    assert!((ours.gain[s][i] - gain[(i, s)]).abs() <= 1e-9 * gain.amax());
                }
            }
        }
    }

    #[test]
    fn a_weight_that_is_not_positive_definite_or_a_partial_move_has_none() {
        let mut rng = Lcg(3);
        let (a, b) = (random::<NS, NS>(&mut rng), random::<NS, NU>(&mut rng));
        let (q, terminal) = (weight::<NS>(&mut rng), weight::<NS>(&mut rng));
        let r = [[1.0, 0.0], [0.0, 1.0]];
        let mut problem = PredictionProblem {
            a: &a,
            b: &b,
            q: &q,
            r: &r,
            terminal: &terminal,
        };
        assert!(condensed_inverse::<f64, M, NS, NU>(&problem).is_some());
        // Nine moves of two inputs: not a whole horizon.
        assert_eq!(condensed_inverse::<f64, 9, NS, NU>(&problem), None);
        // A control weight so negative that `R + B' P_f B` is not positive definite.
        let negative = [[-1e3, 0.0], [0.0, -1e3]];
        problem.r = &negative;
        assert_eq!(condensed_inverse::<f64, M, NS, NU>(&problem), None);
    }
}
