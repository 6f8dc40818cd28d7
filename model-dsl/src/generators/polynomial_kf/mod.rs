//! The polynomial Kalman filter with fading and periodic re-initialisation.

pub mod design;
pub mod lower;
