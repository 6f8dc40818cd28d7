//! The adaptive finite-horizon LQR.

pub mod lower;
pub mod steady_state;
