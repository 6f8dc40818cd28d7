//! The cantilever filters' tuning (the notes, "Simulating the cantilever"), shared by
//! the estimation runs and the fault experiment.

use super::diag;

/// The paper's initial guesses (sect. 5, with x3 of the close guess near the beam's).
pub const X0_CLOSE: [f64; 5] = [0.01, 0.0, -400.0, -1.0, 0.01];
/// The paper's wrong initial guess.
pub const X0_WRONG: [f64; 5] = [0.01, 0.0, -50000.0, -10.0, 0.01];
/// One process noise for EKF, AKF and LKF.
pub const Q_DIAG: [f64; 5] = [0.0, 0.0, 100.0, 300.0, 1e-3];
/// The paper's measurement noise variance R \[mm^2\].
pub const R: f64 = 0.001;

/// The initial covariance of the tuning note: p3 = 2e4 (close) or 2e6 (wrong guess).
pub fn p0(p3: f64) -> [[f64; 5]; 5] {
    diag([0.1, 1.0, p3, 1000.0, 0.1])
}
