//! The generators: one folder per kind of filter or controller a model can ask for.

pub mod continuous_ekf;
pub mod dkf;
pub mod ekf;
pub mod hybrid_ekf;
pub mod lqr;
pub mod mpc;
pub mod polynomial_kf;
pub mod switched_observer;
