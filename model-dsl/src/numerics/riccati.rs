//! Algebraic Riccati equations, solved once at generation time and checked by their
//! residual (not only by convergence).
//!
//! - DARE, `X = A'XA - A'XB (R + B'XB)^-1 B'XA + Q`: the structure-preserving doubling
//!   algorithm (Chu, Fan, Lin; the doubling iteration of Anderson and Moore), quadratically
//!   convergent whenever a stabilising solution exists.
//! - CARE, `A'X + XA - XBR^-1B'X + Q = 0`: the matrix sign function of the Hamiltonian
//!   (Roberts; Byers' scaling), then the stabilising invariant subspace by least squares.

use super::matrix::Mat;
use super::svd::pinv;

/// Why a Riccati equation has no (computable) stabilising solution.
#[derive(Clone, Debug, PartialEq)]
pub enum RiccatiError {
    /// A matrix to invert was singular (for example `R` not positive definite).
    Singular(&'static str),
    /// The iteration did not settle within its iteration limit.
    NoConvergence,
    /// The solution does not satisfy the equation: its relative residual.
    Residual(f64),
}

impl std::fmt::Display for RiccatiError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            RiccatiError::Singular(what) => write!(f, "{what} is singular"),
            RiccatiError::NoConvergence => write!(
                f,
                "the iteration did not converge (is the pair stabilisable and detectable?)"
            ),
            RiccatiError::Residual(r) => write!(f, "the solution's relative residual is {r:.3e}"),
        }
    }
}

/// Largest relative residual a solution may keep.
const RESIDUAL_LIMIT: f64 = 1e-10;

/// The residual of the DARE at `x`, relative to `|X| + |Q|` (Frobenius norms).
pub fn dare_residual(a: &Mat, b: &Mat, q: &Mat, r: &Mat, x: &Mat) -> f64 {
    let at_x = &a.t() * x;
    let btxb = &(&b.t() * x) * b;
    let Some(s_inv) = (r + &btxb).inverse() else {
        return f64::INFINITY;
    };
    let at_x_b = &at_x * b;
    let correction = &(&at_x_b * &s_inv) * &at_x_b.t();
    let rhs = &(&(&at_x * a) - &correction) + q;
    (x - &rhs).norm() / (x.norm() + q.norm()).max(f64::MIN_POSITIVE)
}

/// The stabilising solution of the DARE (control form).
pub fn dare(a: &Mat, b: &Mat, q: &Mat, r: &Mat) -> Result<Mat, RiccatiError> {
    let n = a.rows();
    let r_inv = r.inverse().ok_or(RiccatiError::Singular("R"))?;
    let mut ak = a.clone();
    let mut gk = &(b * &r_inv) * &b.t();
    let mut hk = q.clone();
    let identity = Mat::identity(n);
    for _ in 0..200 {
        let w_inv = (&identity + &(&gk * &hk))
            .inverse()
            .ok_or(RiccatiError::Singular("I + G H in the doubling"))?;
        let a_winv = &ak * &w_inv;
        let a_next = &a_winv * &ak;
        let g_next = &gk + &(&(&a_winv * &gk) * &ak.t());
        let h_next = &hk + &(&(&(&ak.t() * &hk) * &w_inv) * &ak);
        let change = (&h_next - &hk).norm();
        ak = a_next;
        gk = g_next.symmetrised();
        hk = h_next.symmetrised();
        if !hk.is_finite() {
            return Err(RiccatiError::NoConvergence);
        }
        if change <= 1e-15 * hk.norm() {
            let residual = dare_residual(a, b, q, r, &hk);
            return if residual < RESIDUAL_LIMIT {
                Ok(hk)
            } else {
                Err(RiccatiError::Residual(residual))
            };
        }
    }
    Err(RiccatiError::NoConvergence)
}

/// The residual of the CARE at `x`, relative to `|A'X| + |Q|`.
pub fn care_residual(a: &Mat, b: &Mat, q: &Mat, r: &Mat, x: &Mat) -> f64 {
    let Some(r_inv) = r.inverse() else {
        return f64::INFINITY;
    };
    let xb = x * b;
    let at_x = &a.t() * x;
    let lhs = &(&(&at_x + &at_x.t()) - &(&(&xb * &r_inv) * &xb.t())) + q;
    lhs.norm() / (at_x.norm() + q.norm()).max(f64::MIN_POSITIVE)
}

/// The stabilising solution of the CARE.
pub fn care(a: &Mat, b: &Mat, q: &Mat, r: &Mat) -> Result<Mat, RiccatiError> {
    let n = a.rows();
    let r_inv = r.inverse().ok_or(RiccatiError::Singular("R"))?;
    let g = &(b * &r_inv) * &b.t();
    // The Hamiltonian [A, -G; -Q, -A'].
    let mut z = Mat::zeros(2 * n, 2 * n);
    for i in 0..n {
        for j in 0..n {
            z[(i, j)] = a[(i, j)];
            z[(i, j + n)] = -g[(i, j)];
            z[(i + n, j)] = -q[(i, j)];
            z[(i + n, j + n)] = -a[(j, i)];
        }
    }
    let mut converged = false;
    for _ in 0..100 {
        let z_inv = z.inverse().ok_or(RiccatiError::Singular(
            "the Hamiltonian (a pole on the imaginary axis)",
        ))?;
        // Byers' norm scaling speeds the first iterations.
        let c = (z_inv.norm() / z.norm()).sqrt();
        let next = (&z.scale(c) + &z_inv.scale(1.0 / c)).scale(0.5);
        let change = (&next - &z).norm();
        z = next;
        if !z.is_finite() {
            return Err(RiccatiError::NoConvergence);
        }
        if change <= 1e-13 * z.norm() {
            converged = true;
            break;
        }
    }
    if !converged {
        return Err(RiccatiError::NoConvergence);
    }
    // sign(H) = [W11 W12; W21 W22]; X solves [W12; W22 + I] X = -[W11 + I; W21].
    let identity = Mat::identity(n);
    let lhs = z
        .block(0, n, n, 2 * n)
        .stack(&(&z.block(n, 2 * n, n, 2 * n) + &identity));
    let rhs = (&z.block(0, n, 0, n) + &identity).stack(&z.block(n, 2 * n, 0, n));
    let x = (&pinv(&lhs) * &rhs).scale(-1.0).symmetrised();
    let residual = care_residual(a, b, q, r, &x);
    if residual < RESIDUAL_LIMIT {
        Ok(x)
    } else {
        Err(RiccatiError::Residual(residual))
    }
}

/// The steady-state Kalman gain of the one-step predictor
/// `x[k+1] = A x[k] + K (y[k] - C x[k])` for process noise `Q` and measurement noise `R`:
/// `K = A P C' (C P C' + R)^-1` with `P` the stabilising solution of the filter DARE
/// `P = A P A' - A P C' (C P C' + R)^-1 C P A' + Q` (the control DARE of `(A', C')`).
/// Returns `(K, P)`.
pub fn kalman_predictor_gain(
    a: &Mat,
    c: &Mat,
    q: &Mat,
    r: &Mat,
) -> Result<(Mat, Mat), RiccatiError> {
    let p = dare(&a.t(), &c.t(), q, r)?;
    let pct = &p * &c.t();
    let s_inv = (&(c * &pct) + r)
        .inverse()
        .ok_or(RiccatiError::Singular("C P C' + R"))?;
    Ok((&(a * &pct) * &s_inv, p))
}
