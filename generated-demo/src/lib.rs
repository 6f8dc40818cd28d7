//! The systems of the five papers in `shared/seeds`, declared once with `model!`, and two
//! variants of the cantilever that exercise the window transform on other structures.
//! The library is `no_std` and builds for `thumbv7em-none-eabihf` as well as the host.
//! Each model's source lives in `models/`, where the snapshot and Jacobian tests read it.

#![no_std]
#![forbid(unsafe_code)]

pub mod continuous_sequence;
pub mod mpc_sequence;
pub mod observer_sequences;
pub mod sequence;

include!("../models/cantilever.rs");
include!("../models/mass_spring_damper.rs");
include!("../models/blade_identification.rs");
include!("../models/polynomial.rs");
include!("../models/piecewise_beam.rs");
include!("../models/helicopter.rs");
include!("../models/beam_two_actuators.rs");
include!("../models/duffing_beam.rs");
