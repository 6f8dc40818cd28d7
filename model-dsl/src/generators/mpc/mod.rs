//! The adaptive model predictive controller with input bounds.

pub mod lower;
pub mod names;
pub mod predictive;
pub mod qp;
