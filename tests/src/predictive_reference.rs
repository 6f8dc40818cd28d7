//! Dense references for the MPC, written independently of the generated code: the
//! zero-order hold by nalgebra's matrix exponential, the DARE by the structured doubling
//! algorithm (not the Riccati iteration the generated code runs), the condensed problem
//! from the explicit prediction matrices of eqs. (32)-(33), and the box-constrained QP by
//! the Clarabel interior-point solver.

use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettingsBuilder, DefaultSolver, IPSolver, NonnegativeConeT, SolverStatus,
};
use nalgebra::{DMatrix, DVector};

/// `(A, B)` of the zero-order hold of `x' = phi x + gamma u` over `period`: the blocks of
/// `exp([[phi, gamma], [0, 0]] period)`.
pub fn zero_order_hold(
    phi: &DMatrix<f64>,
    gamma: &DMatrix<f64>,
    period: f64,
) -> (DMatrix<f64>, DMatrix<f64>) {
    let (n, m) = (phi.nrows(), gamma.ncols());
    let mut augmented = DMatrix::zeros(n + m, n + m);
    augmented.view_mut((0, 0), (n, n)).copy_from(phi);
    augmented.view_mut((0, n), (n, m)).copy_from(gamma);
    let held = (augmented * period).exp();
    (
        held.view((0, 0), (n, n)).into_owned(),
        held.view((0, n), (n, m)).into_owned(),
    )
}

/// The stabilising solution of `P = A'PA - A'PB (R + B'PB)^-1 B'PA + Q` by the structured
/// doubling algorithm (Chu, Fan, Lin 2005): `A_k`, `G_k`, `H_k` with `H_k -> P`, each
/// step doubling the horizon.
pub fn dare(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    q: &DMatrix<f64>,
    r: &DMatrix<f64>,
) -> DMatrix<f64> {
    let n = a.nrows();
    let identity = DMatrix::<f64>::identity(n, n);
    let r_inv = r.clone().try_inverse().expect("R invertible");
    let (mut ak, mut gk, mut hk) = (a.clone(), b * r_inv * b.transpose(), q.clone());
    for _ in 0..60 {
        let w = (&identity + &gk * &hk)
            .try_inverse()
            .expect("I + G H invertible");
        let a_next = &ak * &w * &ak;
        let g_next = &gk + &ak * &w * &gk * ak.transpose();
        let h_next = &hk + ak.transpose() * &hk * &w * &ak;
        let change = (&h_next - &hk).norm() / h_next.norm();
        (ak, gk, hk) = (a_next, g_next, h_next);
        if change < 1e-15 {
            break;
        }
    }
    hk
}

/// The LQR gain `K = (R + B'PB)^-1 B'PA` of a weight `P`.
pub fn gain(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    r: &DMatrix<f64>,
    p: &DMatrix<f64>,
) -> DMatrix<f64> {
    let weight = r + b.transpose() * p * b;
    weight.try_inverse().expect("R + B'PB invertible") * b.transpose() * p * a
}

/// `H` and `c` of `min 1/2 U'HU + c'U` for the cost of eq. (34) from `x0`, built from the
/// prediction matrices `M = [A^0; ..; A^n]` and `N` (eqs. 32-33) as eqs. (43)-(44) write.
pub fn condensed(
    (a, b): (&DMatrix<f64>, &DMatrix<f64>),
    (q, r, terminal): (&DMatrix<f64>, &DMatrix<f64>, &DMatrix<f64>),
    x0: &DVector<f64>,
    horizon: usize,
) -> (DMatrix<f64>, DVector<f64>) {
    let (n, m) = (a.nrows(), b.ncols());
    let mut powers = vec![DMatrix::<f64>::identity(n, n)];
    for i in 1..=horizon {
        powers.push(a * &powers[i - 1]);
    }
    // Block row i of N: sum over j < i of A^(i-1-j) B in column block j.
    let block_row = |i: usize| {
        let mut row = DMatrix::zeros(n, horizon * m);
        for j in 0..i {
            row.view_mut((0, j * m), (n, m))
                .copy_from(&(&powers[i - 1 - j] * b));
        }
        row
    };
    let mut h = DMatrix::zeros(horizon * m, horizon * m);
    let mut c = DVector::zeros(horizon * m);
    for (i, power) in powers.iter().enumerate().skip(1) {
        let weight = if i == horizon { terminal } else { q };
        let ni = block_row(i);
        h += ni.transpose() * weight * &ni;
        c += ni.transpose() * weight * power * x0;
    }
    for j in 0..horizon {
        let mut block = h.view_mut((j * m, j * m), (m, m));
        block += r;
    }
    (h, c)
}

/// `min 1/2 v'Hv + c'v` over `low <= v <= high` by Clarabel, the problem scaled so that
/// `H`'s diagonal is about one (the minimiser does not change).
pub fn box_qp(h: &DMatrix<f64>, c: &DVector<f64>, low: &[f64], high: &[f64]) -> DVector<f64> {
    let k = h.nrows();
    let scale = h.diagonal().mean();
    let upper: Vec<Vec<f64>> = (0..k)
        .map(|i| {
            (0..k)
                .map(|j| if j >= i { h[(i, j)] / scale } else { 0.0 })
                .collect()
        })
        .collect();
    let p = CscMatrix::from(&upper);
    let linear: Vec<f64> = c.iter().map(|v| v / scale).collect();
    let mut a_rows = Vec::with_capacity(2 * k);
    for sign in [1.0, -1.0] {
        for i in 0..k {
            a_rows.push(
                (0..k)
                    .map(|j| if i == j { sign } else { 0.0 })
                    .collect::<Vec<f64>>(),
            );
        }
    }
    let a = CscMatrix::from(&a_rows);
    let b: Vec<f64> = high.iter().copied().chain(low.iter().map(|l| -l)).collect();
    let cones = [NonnegativeConeT(2 * k)];
    let settings = DefaultSettingsBuilder::default()
        .verbose(false)
        .tol_gap_abs(1e-11)
        .tol_gap_rel(1e-11)
        .tol_feas(1e-11)
        .build()
        .expect("settings");
    let mut solver = DefaultSolver::new(&p, &linear, &a, &b, &cones, settings).expect("solver");
    solver.solve();
    assert!(
        solver.solution.status == SolverStatus::Solved,
        "Clarabel: {:?}",
        solver.solution.status
    );
    polish(
        h,
        c,
        low,
        high,
        &DVector::from_vec(solver.solution.x.clone()),
    )
}

/// An interior-point solution is accurate to its tolerances, about `1e-8` of the scale:
/// take the bounds it (nearly) touches as active, solve the equality-constrained problem
/// on the rest exactly, and check the result's optimality conditions. On an
/// ill-conditioned problem a bound the solution lies just beyond `1e-6` of is taken as
/// free: the exact solve then crosses it, and is corrected by holding the bound most
/// crossed (or releasing the one with the most negative multiplier) and solving again,
/// a few steps of a primal active-set method from Clarabel's guess.
fn polish(
    h: &DMatrix<f64>,
    c: &DVector<f64>,
    low: &[f64],
    high: &[f64],
    approximate: &DVector<f64>,
) -> DVector<f64> {
    let k = h.nrows();
    let width = |i: usize| high[i] - low[i];
    let mut v = approximate.clone();
    let mut free = Vec::new();
    for i in 0..k {
        if (v[i] - low[i]).abs() < 1e-6 * width(i) {
            v[i] = low[i];
        } else if (high[i] - v[i]).abs() < 1e-6 * width(i) {
            v[i] = high[i];
        } else {
            free.push(i);
        }
    }
    for _ in 0..k {
        solve_free(h, c, &free, &mut v);
        let crossed = free
            .iter()
            .map(|&i| (i, (low[i] - v[i]).max(v[i] - high[i]) / width(i)))
            .filter(|&(_, beyond)| beyond > 1e-12)
            .max_by(|a, b| a.1.total_cmp(&b.1));
        if let Some((i, _)) = crossed {
            v[i] = v[i].clamp(low[i], high[i]);
            free.retain(|&j| j != i);
            continue;
        }
        let gradient = h * &v + c;
        let wrong = (0..k)
            .filter(|i| !free.contains(i))
            .map(|i| {
                (
                    i,
                    if v[i] == low[i] {
                        gradient[i]
                    } else {
                        -gradient[i]
                    },
                )
            })
            .filter(|&(_, multiplier)| multiplier < 0.0)
            .min_by(|a, b| a.1.total_cmp(&b.1));
        let scale = h.diagonal().amax() * width(0);
        match wrong {
            Some((i, multiplier)) if multiplier < -1e-12 * scale => {
                free.push(i);
                free.sort_unstable();
            }
            _ => break,
        }
    }
    // Optimality: within the bounds, and each held bound's multiplier non-negative.
    let gradient = h * &v + c;
    let scale = h.diagonal().amax() * width(0);
    for i in 0..k {
        assert!(v[i] >= low[i] - 1e-9 * width(i) && v[i] <= high[i] + 1e-9 * width(i));
        let multiplier = if v[i] == low[i] {
            gradient[i]
        } else if v[i] == high[i] {
            -gradient[i]
        } else {
            0.0
        };
        assert!(
            multiplier >= -1e-9 * scale,
            "move {i}: multiplier {multiplier:e}"
        );
        if free.contains(&i) {
            assert!(
                gradient[i].abs() <= 1e-9 * scale,
                "move {i}: gradient {:e}",
                gradient[i]
            );
        }
    }
    v
}

/// `H_FF v_F = -(c_F + H_FA v_A)`: the free entries of `v` minimising the cost with the
/// others held.
fn solve_free(h: &DMatrix<f64>, c: &DVector<f64>, free: &[usize], v: &mut DVector<f64>) {
    if free.is_empty() {
        return;
    }
    let k = h.nrows();
    let h_ff = DMatrix::from_fn(free.len(), free.len(), |a, b| h[(free[a], free[b])]);
    let mut rhs = DVector::from_fn(free.len(), |a, _| -c[free[a]]);
    for (a, &i) in free.iter().enumerate() {
        for j in (0..k).filter(|j| !free.contains(j)) {
            rhs[a] -= h[(i, j)] * v[j];
        }
    }
    let v_free = h_ff.cholesky().expect("H_FF positive definite").solve(&rhs);
    for (a, &i) in free.iter().enumerate() {
        v[i] = v_free[a];
    }
}

/// A limit row of [`limited_qp`]: `lower <= a' v <= upper` (an infinite side: no limit),
/// hard, or soft with an exact penalty on its violation.
pub struct LimitRow {
    /// `a`, in the moves.
    pub coefficients: Vec<f64>,
    /// The lower limit.
    pub lower: f64,
    /// The upper limit.
    pub upper: f64,
    /// `None`: hard; `Some(rho)`: the violation `s >= 0` costs `rho s`.
    pub penalty: Option<f64>,
}

/// `min 1/2 v' H v + c' v + sum rho_r s_r` with `low <= v <= high` and each row's limits,
/// a soft row's relaxed by its slack `s_r >= 0`, by Clarabel (slacks as variables):
/// the moves.
pub fn limited_qp(
    h: &DMatrix<f64>,
    c: &DVector<f64>,
    (low, high): (&[f64], &[f64]),
    rows: &[LimitRow],
) -> DVector<f64> {
    let k = h.nrows();
    let soft: Vec<usize> = (0..rows.len())
        .filter(|&r| rows[r].penalty.is_some())
        .collect();
    let n = k + soft.len();
    let scale = h.diagonal().mean();
    let upper: Vec<Vec<f64>> = (0..n)
        .map(|i| {
            (0..n)
                .map(|j| match (i < k && j < k, j >= i) {
                    (true, true) => h[(i, j)] / scale,
                    _ => 0.0,
                })
                .collect()
        })
        .collect();
    let mut linear: Vec<f64> = c.iter().map(|v| v / scale).collect();
    linear.extend(soft.iter().map(|&r| rows[r].penalty.unwrap_or(0.0) / scale));
    // Each constraint `a' z <= b`.
    let mut a_rows: Vec<Vec<f64>> = Vec::new();
    let mut b = Vec::new();
    let mut push = |row: Vec<f64>, bound: f64| {
        a_rows.push(row);
        b.push(bound);
    };
    for i in 0..k {
        let unit = |sign: f64| (0..n).map(|j| if j == i { sign } else { 0.0 }).collect();
        push(unit(1.0), high[i]);
        push(unit(-1.0), -low[i]);
    }
    for (r, row) in rows.iter().enumerate() {
        let slack = soft.iter().position(|&s| s == r).map(|j| k + j);
        for (sign, bound) in [(1.0, row.upper), (-1.0, -row.lower)] {
            if bound.is_finite() {
                let coefficients = (0..n)
                    .map(|j| match (j < k, Some(j) == slack) {
                        (true, _) => sign * row.coefficients[j],
                        (false, true) => -1.0,
                        _ => 0.0,
                    })
                    .collect();
                push(coefficients, bound);
            }
        }
        if let Some(j) = slack {
            push(
                (0..n).map(|i| if i == j { -1.0 } else { 0.0 }).collect(),
                0.0,
            );
        }
    }
    let constraints = a_rows.len();
    let settings = DefaultSettingsBuilder::default()
        .verbose(false)
        .tol_gap_abs(1e-12)
        .tol_gap_rel(1e-12)
        .tol_feas(1e-12)
        .max_iter(500)
        .build()
        .expect("settings");
    let p = CscMatrix::from(&upper);
    let a = CscMatrix::from(&a_rows);
    let cones = [NonnegativeConeT(constraints)];
    let mut solver = DefaultSolver::new(&p, &linear, &a, &b, &cones, settings).expect("solver");
    solver.solve();
    assert!(
        matches!(
            solver.solution.status,
            SolverStatus::Solved | SolverStatus::AlmostSolved
        ),
        "Clarabel: {:?}",
        solver.solution.status
    );
    DVector::from_iterator(k, solver.solution.x.iter().take(k).copied())
}
