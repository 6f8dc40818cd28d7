//! The extended Kalman filter (Alg. 1 of the double Kalman filter paper).

pub mod lower;
