//! Dead reckoning in the plane, written out with nalgebra: the dynamics of the test models
//! `delayed_fix`, `jittered` and `jittered_late` (an odometer's speed and a gyro's yaw rate
//! drive the position and the heading), for the independent filters they are checked
//! against.

use nalgebra::{Matrix3, Vector3};

/// One step over the interval `dt` from `x = [px, py, heading]` with `u = [speed,
/// yaw_rate]`: the heading turns first, the position moves along the new heading.
#[must_use]
pub fn f(dt: f64, x: &Vector3<f64>, u: [f64; 2]) -> Vector3<f64> {
    let turned = x[2] + dt * u[1];
    Vector3::new(
        x[0] + dt * u[0] * turned.cos(),
        x[1] + dt * u[0] * turned.sin(),
        turned,
    )
}

/// The Jacobian of [`f`] with respect to `x`.
#[must_use]
pub fn jacobian(dt: f64, x: &Vector3<f64>, u: [f64; 2]) -> Matrix3<f64> {
    let turned = x[2] + dt * u[1];
    let mut a = Matrix3::identity();
    a[(0, 2)] = -dt * u[0] * turned.sin();
    a[(1, 2)] = dt * u[0] * turned.cos();
    a
}
