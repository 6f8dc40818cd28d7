//! The singular value decomposition by one-sided Jacobi rotations (Hestenes), and what it
//! gives: the least-squares pseudo-inverse and the numerical rank.

use super::matrix::Mat;

/// `A = U diag(s) V'` with `U` (`m x k`) and `V` (`n x k`) orthonormal columns,
/// `k = min(m, n)`, singular values `s` in decreasing order.
#[derive(Clone, Debug)]
pub struct Svd {
    /// Left singular vectors, as columns.
    pub u: Mat,
    /// Singular values, largest first.
    pub s: Vec<f64>,
    /// Right singular vectors, as columns.
    pub v: Mat,
}

/// The thin SVD of `a`. One-sided Jacobi: rotate pairs of columns of `A V` until every
/// pair is orthogonal to working precision; the column norms are the singular values.
pub fn svd(a: &Mat) -> Svd {
    if a.rows() < a.cols() {
        let Svd { u, s, v } = svd(&a.t());
        return Svd { u: v, s, v: u };
    }
    let (m, n) = (a.rows(), a.cols());
    let mut w = a.clone();
    let mut v = Mat::identity(n);
    for _sweep in 0..60 {
        let mut rotated = false;
        for p in 0..n {
            for q in p + 1..n {
                let (mut alpha, mut beta, mut gamma) = (0.0, 0.0, 0.0);
                for i in 0..m {
                    alpha += w[(i, p)] * w[(i, p)];
                    beta += w[(i, q)] * w[(i, q)];
                    gamma += w[(i, p)] * w[(i, q)];
                }
                if gamma == 0.0 || gamma.abs() <= 1e-15 * (alpha * beta).sqrt() {
                    continue;
                }
                rotated = true;
                // The rotation that zeroes the (p, q) entry of W'W.
                let zeta = (beta - alpha) / (2.0 * gamma);
                let t = zeta.signum() / (zeta.abs() + (1.0 + zeta * zeta).sqrt());
                let t = if zeta == 0.0 { 1.0 } else { t };
                let c = 1.0 / (1.0 + t * t).sqrt();
                let s = c * t;
                for mat in [&mut w, &mut v] {
                    for i in 0..mat.rows() {
                        let (x, y) = (mat[(i, p)], mat[(i, q)]);
                        mat[(i, p)] = c * x - s * y;
                        mat[(i, q)] = s * x + c * y;
                    }
                }
            }
        }
        if !rotated {
            break;
        }
    }
    let norms: Vec<f64> = (0..n)
        .map(|j| (0..m).map(|i| w[(i, j)] * w[(i, j)]).sum::<f64>().sqrt())
        .collect();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&i, &j| norms[j].total_cmp(&norms[i]));
    let mut u = Mat::zeros(m, n);
    let mut v_sorted = Mat::zeros(n, n);
    for (k, &j) in order.iter().enumerate() {
        for i in 0..m {
            u[(i, k)] = if norms[j] > 0.0 {
                w[(i, j)] / norms[j]
            } else {
                0.0
            };
        }
        for i in 0..n {
            v_sorted[(i, k)] = v[(i, j)];
        }
    }
    Svd {
        u,
        s: order.iter().map(|&j| norms[j]).collect(),
        v: v_sorted,
    }
}

/// The default tolerance below which a singular value counts as zero:
/// `max(m, n) * eps * s_max`, as LAPACK's and numpy's rank.
fn default_tolerance(a: &Mat, s: &[f64]) -> f64 {
    let largest = s.first().copied().unwrap_or(0.0);
    a.rows().max(a.cols()) as f64 * f64::EPSILON * largest
}

/// The Moore-Penrose pseudo-inverse: `x = pinv(A) b` minimises `|A x - b|` (and `|x|`
/// among the minimisers). Singular values at or below the default tolerance are dropped.
pub fn pinv(a: &Mat) -> Mat {
    let Svd { u, s, v } = svd(a);
    let tol = default_tolerance(a, &s);
    let mut vs = v.clone();
    for (k, &sk) in s.iter().enumerate() {
        let scale = if sk > tol { 1.0 / sk } else { 0.0 };
        for i in 0..vs.rows() {
            vs[(i, k)] *= scale;
        }
    }
    &vs * &u.t()
}

/// The numerical rank: how many singular values exceed the default tolerance.
pub fn rank(a: &Mat) -> usize {
    let s = svd(a).s;
    let tol = default_tolerance(a, &s);
    s.iter().filter(|&&sk| sk > tol).count()
}
