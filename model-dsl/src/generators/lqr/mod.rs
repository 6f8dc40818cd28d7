//! The adaptive finite-horizon LQR.

pub mod lower;
