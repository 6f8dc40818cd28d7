//! An attitude and heading reference system (AHRS), as a user of `stateforge` declares
//! it: a unit-quaternion attitude and the gyro's biases, turned each sample by the gyro and
//! corrected by an accelerometer at 100 Hz and a magnetometer at 25 Hz, two sensors at
//! different rates. `generate ekf` on a model with a rotation gives an error-state EKF:
//! its covariance is over the attitude's 3-dimensional error, and its quaternion stays a
//! unit quaternion.
//!
//! The library is `no_std`, as firmware would use it; [`simulation`] is the tumbling body
//! the host program and the tests run the generated filter against.

#![no_std]
#![forbid(unsafe_code)]

pub mod model;
pub mod simulation;

pub use model::ahrs;
