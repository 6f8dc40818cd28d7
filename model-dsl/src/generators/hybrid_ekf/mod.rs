//! The hybrid (continuous-discrete) EKF.

pub mod lower;
