//! The paper's initial guesses and the tuning that reproduces its divergence result
//! (generated-demo's notes, "Simulating the cantilever"), shared by the tests and benchmarks of the cantilever's filters.

/// The close initial guess (x3 near the beam's -wn^2).
pub const X0_CLOSE: [f64; 5] = [0.01, 0.0, -400.0, -1.0, 0.01];
/// The paper's wrong initial guess.
pub const X0_WRONG: [f64; 5] = [0.01, 0.0, -50000.0, -10.0, 0.01];
/// One process noise diagonal for EKF, AKF and LKF.
pub const Q_DIAG: [f64; 5] = [0.0, 0.0, 100.0, 300.0, 1e-3];
/// The paper's measurement noise variance.
pub const R: f64 = 0.001;

/// The diagonal matrix of `d`.
pub fn diag(d: [f64; 5]) -> [[f64; 5]; 5] {
    std::array::from_fn(|i| std::array::from_fn(|j| if i == j { d[i] } else { 0.0 }))
}

/// The initial covariance: `p3 = 2e4` for the close guess, `2e6` for the wrong one.
pub fn p0(p3: f64) -> [[f64; 5]; 5] {
    diag([0.1, 1.0, p3, 1000.0, 0.1])
}
