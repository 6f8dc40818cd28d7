//! The systems of the five papers in `shared/seeds`, declared once with `model!`.
//! The library is `no_std` and builds for `thumbv7em-none-eabihf` as well as the host.
//! Each model's source lives in `models/`, where the snapshot and Jacobian tests read it.

#![no_std]
#![forbid(unsafe_code)]

include!("../models/cantilever.rs");
include!("../models/mass_spring_damper.rs");
include!("../models/polynomial.rs");
include!("../models/piecewise_beam.rs");
include!("../models/helicopter.rs");
