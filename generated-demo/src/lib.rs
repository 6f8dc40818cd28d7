//! The systems of the five papers the project comes from (the double Kalman filter
//! paper's cantilever, Takacs, Poloni and Rohal-Ilkiv's blade, the polynomial Kalman
//! filter, the piecewise-linear beam's switched observers, Kulkarni and Purwar's
//! helicopter), declared once with `model!`, two
//! variants of the cantilever that exercise the window transform on other structures, and
//! the cantilever with a least-squares DKF window (`cantilever_long_window`), and a 24-state
//! strapdown navigation model with GNSS and magnetometer sensors (`navigation`), and
//! TinyMPC's 12-state quadrotor hover model for the embedded-QP benchmark (`quadrotor`),
//! and the same model with limits on its motors' rates, tilt and speed
//! (`quadrotor_limited`).
//! The library is `no_std` and builds for `thumbv7em-none-eabihf` as well as the host.
//! Beside the models: the deterministic sequences the firmware and the host both filter
//! (`sequence` and its siblings), and the navigation model's simulated flight (`flight`)
//! with its seeded noise (`noise`), which the main job flies and the firmware's build
//! script embeds.
//! Each model's source lives in `models/`, where the snapshot and Jacobian tests read it.

#![no_std]
#![forbid(unsafe_code)]

pub mod continuous_sequence;
pub mod flight;
pub mod mpc_sequence;
pub mod noise;
pub mod observer_sequences;
pub mod quadrotor_tuning;
pub mod sequence;

/// The project's notes, documentation only: what the main job runs and prints, the
/// firmware's checks and cost table on the Cortex-M4F, the benchmarks, the tests, the
/// layout and where the issues stand. Each is a file in `generated-demo/doc/`; `cargo
/// xtask test` builds them with `cargo doc -D warnings`, so a broken intra-doc link fails.
/// The user's guide is the `stateforge` crate's documentation.
pub mod notes {
    #[doc = include_str!("../doc/experiments.md")]
    pub mod experiments {}
    #[doc = include_str!("../doc/cortex-m4f.md")]
    pub mod cortex_m4f {}
    #[doc = include_str!("../doc/benchmarks.md")]
    pub mod benchmarks {}
    #[doc = include_str!("../doc/tests.md")]
    pub mod tests {}
    #[doc = include_str!("../doc/layout.md")]
    pub mod layout {}
    #[doc = include_str!("../doc/status.md")]
    pub mod status {}
}

include!("../models/cantilever.rs");
include!("../models/mass_spring_damper.rs");
include!("../models/blade_identification.rs");
include!("../models/polynomial.rs");
include!("../models/piecewise_beam.rs");
include!("../models/helicopter.rs");
include!("../models/beam_two_actuators.rs");
include!("../models/duffing_beam.rs");
include!("../models/cantilever_long_window.rs");
include!("../models/navigation.rs");
include!("../models/quadrotor.rs");
include!("../models/quadrotor_limited.rs");
