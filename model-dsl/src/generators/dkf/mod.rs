//! The double Kalman filter: the window transform and its two Kalman filters.

pub mod filters;
pub mod lower;
pub mod ltv;
pub mod transform;
pub mod window;
