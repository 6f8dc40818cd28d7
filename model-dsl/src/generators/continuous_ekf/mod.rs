//! The continuous-time EKF with an optional prescribed degree of stability.

pub mod lower;
