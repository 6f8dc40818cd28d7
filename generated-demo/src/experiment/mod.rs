//! Host-side harness of the double Kalman filter paper's cantilever experiment (sect. 5):
//! a simulated beam, the PRBS excitation, read-outs of physical parameters from estimates, metrics and the
//! report (table, CSV, SVG). The filters and the LQR live elsewhere; this module only
//! feeds them data and reports what they estimated.
//!
//! Units throughout: mm, mm/s, V, s (the notes, "Simulating the cantilever").

pub mod blade;
pub mod blade_ablation;
pub mod blade_control;
pub mod blade_modes;
pub mod blade_plant;
pub mod blade_rig;
pub mod butterworth;
pub mod controllers;
pub mod excitation;
pub mod flight;
pub mod flight_delay;
pub mod hub_polynomial;
pub mod metrics;
pub mod outliers;
pub mod plant;
pub mod ppf;
pub mod quadrotor_limits;
pub mod readout;
pub mod report;
pub mod sensitivity;
pub mod stinger;
pub mod switched_beam;
pub mod trms;
pub mod tuning;

/// The diagonal matrix with `d` on its diagonal (the tunings are diagonal covariances).
pub fn diag<T: Copy + Default, const N: usize>(d: [T; N]) -> [[T; N]; N] {
    std::array::from_fn(|i| std::array::from_fn(|j| if i == j { d[i] } else { T::default() }))
}

/// Sample time \[s\], taken from the generated cantilever model so the harness and the
/// filters can never disagree on it ("the sampling period has been set to 15 ms", sect. 4.1).
pub const TS: f64 = generated_demo::cantilever::in_f64::TS;
