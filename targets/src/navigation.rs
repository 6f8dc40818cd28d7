//! The navigation EKF (`generated_demo::navigation`, `f32`: PX4 EKF2's error-state
//! formulation, 24 entries, a covariance over 23 coordinates) on the target: the
//! first four seconds of the navigation experiment's flight (`generated_demo::flight`,
//! embedded by the build script), from the experiment's initial estimate and tuning, the
//! calls in the experiment's order (each IMU sample's prediction, then the magnetometer's
//! update and the GNSS's where they arrive): 1000 predictions, 200 magnetometer and 20
//! GNSS updates, every call read (`measure::Calls`).
//!
//! Output: the `cost` and `stack` lines of `navigation_predict`,
//! `navigation_update_gnss` and `navigation_update_magnetometer` (no nalgebra baseline:
//! printed as 0); a call that returns anything but `Status::Ok` or
//! `Status::OutlierRejected` panics (a non-zero exit).

use crate::matrix::diag;
use crate::measure::{report, stack_depth, traced, Calls, Clock};
use core::hint::black_box;
use generated_demo::flight::MAGNETOMETER_GATE;
use generated_demo::navigation::{Ekf, Status};

/// The embedded flight: `X0`, the tuning's diagonals `P0`, `Q` (a density), `R`, the IMU
/// samples' `INTERVAL`s and the `IMU` samples, and the `MAGNETOMETER` and `GNSS` readings
/// with the index of the IMU sample they follow.
pub mod flight {
    include!(concat!(env!("OUT_DIR"), "/navigation_flight.rs"));
}

/// Predictions in the embedded flight (one per IMU sample).
pub const PREDICTIONS: usize = flight::SAMPLES;
/// Magnetometer updates in the embedded flight.
pub const MAGNETOMETER_UPDATES: usize = flight::MAGNETOMETER_READINGS;
/// GNSS updates in the embedded flight.
pub const GNSS_UPDATES: usize = flight::GNSS_FIXES;

/// One call the flight makes of the filter, with its input or measurement.
#[derive(Clone, Copy, Debug)]
pub enum Event {
    /// The IMU sample's interval \[s\] and the sample as the model's inputs: gyro and
    /// accelerometer (the delta angle and delta velocity over the sample divided by its
    /// interval).
    Predict(f32, &'static [f32; 6]),
    /// A magnetometer reading.
    Magnetometer(&'static [f32; 3]),
    /// A GNSS fix.
    Gnss(&'static [f32; 6]),
}

/// The flight's calls in the experiment's order.
pub fn events() -> impl Iterator<Item = Event> {
    let mut magnetometer = flight::MAGNETOMETER.iter().peekable();
    let mut gnss = flight::GNSS.iter().peekable();
    let samples = flight::INTERVAL.iter().zip(&flight::IMU);
    samples.enumerate().flat_map(move |(k, (&dt, imu))| {
        let m = magnetometer.next_if(|(at, _)| *at == k);
        let g = gnss.next_if(|(at, _)| *at == k);
        [
            Some(Event::Predict(dt, imu)),
            m.map(|(_, y)| Event::Magnetometer(y)),
            g.map(|(_, y)| Event::Gnss(y)),
        ]
        .into_iter()
        .flatten()
    })
}

/// The filter at the flight's start, with the experiment's magnetometer gate.
pub fn filter() -> Ekf {
    let mut ekf = match Ekf::new(&flight::X0, &diag(flight::P0), &flight::Q, &diag(flight::R)) {
        Ok(ekf) => ekf,
        Err(status) => panic!("the navigation EKF rejected its tuning: {:?}", status),
    };
    let status = ekf.set_magnetometer_innovation_gate(MAGNETOMETER_GATE as f32);
    assert!(status == Status::Ok, "magnetometer gate: {:?}", status);
    ekf
}

// The kernels measured: one call each, never inlined, so each is one symbol whose size and
// stack use are its own.

/// `Ekf::predict`.
#[inline(never)]
pub fn generated_navigation_predict(filter: &mut Ekf, dt: f32, imu: &[f32; 6]) -> Status {
    filter.predict(dt, imu)
}

/// `Ekf::update_gnss`.
#[inline(never)]
pub fn generated_navigation_update_gnss(filter: &mut Ekf, y: &[f32; 6]) -> Status {
    filter.update_gnss(y)
}

/// `Ekf::update_magnetometer`.
#[inline(never)]
pub fn generated_navigation_update_magnetometer(filter: &mut Ekf, y: &[f32; 3]) -> Status {
    filter.update_magnetometer(y)
}

/// Whether the filter used the measurement (`true`) or rejected it as an outlier
/// (`false`); panics on any other status, naming the call.
pub fn used(status: Status, event: Event, call: usize) -> bool {
    match status {
        Status::Ok => true,
        Status::OutlierRejected => false,
        other => panic!("navigation EKF, call {} ({:?}): {:?}", call, event, other),
    }
}

/// Flies the flight, reading every call (between the trace markers, so the trace follows
/// them too); prints each kernel's `cost` (the mean of its calls) and `stack` lines.
pub fn costs(clock: &Clock) {
    let mut ekf = filter();
    let mut predict = Calls::<PREDICTIONS>::new();
    let mut magnetometer = Calls::<MAGNETOMETER_UPDATES>::new();
    let mut gnss = Calls::<GNSS_UPDATES>::new();
    traced(|| {
        for (call, event) in events().enumerate() {
            let status = match event {
                Event::Predict(dt, u) => {
                    predict.measure(clock, || generated_navigation_predict(&mut ekf, dt, u))
                }
                Event::Magnetometer(y) => magnetometer.measure(clock, || {
                    generated_navigation_update_magnetometer(&mut ekf, y)
                }),
                Event::Gnss(y) => {
                    gnss.measure(clock, || generated_navigation_update_gnss(&mut ekf, y))
                }
            };
            // A rejected outlier is part of the flight (the experiment's gates).
            let _ = used(status, event, call);
        }
    });
    // Stack depth on a copy, at the flight's end.
    let stack = |kernel: &dyn Fn(&mut Ekf)| {
        let mut copy = ekf;
        stack_depth(|| kernel(black_box(&mut copy)))
    };
    let predict_stack = stack(&|f| {
        let _ = black_box(generated_navigation_predict(
            f,
            flight::INTERVAL[0],
            &flight::IMU[0],
        ));
    });
    let gnss_stack = stack(&|f| {
        let _ = black_box(generated_navigation_update_gnss(f, &flight::GNSS[0].1));
    });
    let magnetometer_stack = stack(&|f| {
        let _ = black_box(generated_navigation_update_magnetometer(
            f,
            &flight::MAGNETOMETER[0].1,
        ));
    });
    report(
        "navigation_predict",
        (predict.mean(), 0),
        (predict_stack, 0),
    );
    report("navigation_update_gnss", (gnss.mean(), 0), (gnss_stack, 0));
    report(
        "navigation_update_magnetometer",
        (magnetometer.mean(), 0),
        (magnetometer_stack, 0),
    );
}
