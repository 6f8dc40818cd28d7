//! The navigation EKF on a delayed fusion horizon (`generated_demo::navigation::DelayedEkf`,
//! `f32`: the GNSS fix 38 samples late, the magnetometer's samples waiting for the
//! horizon, the current state from the output predictor) on the target, over the same
//! embedded flight and calls as [`crate::navigation`]. A prediction that fuses a waiting
//! magnetometer sample (one in five, from the 39th on) re-propagates the current state
//! through the buffered inputs; the others move it one step: the two are read apart.
//!
//! Output: the `cost` and `stack` lines of `navigation_delayed_predict` (no fusion),
//! `navigation_delayed_predict_fusing`, `navigation_delayed_update_gnss` and
//! `navigation_delayed_update_magnetometer` (which only buffers), and a `ram` line with
//! the buffers' bytes, `DELAYED_EKF_BUFFER_BYTES`.

use crate::matrix::diag;
use crate::measure::{report, stack_depth, traced, Calls, Clock};
use crate::navigation::{
    events, flight, used, Event, GNSS_UPDATES, MAGNETOMETER_UPDATES, PREDICTIONS,
};
use core::hint::black_box;
use generated_demo::flight::MAGNETOMETER_GATE;
use generated_demo::navigation::{DelayedEkf, Status, DELAYED_EKF_BUFFER_BYTES};

/// The filter at the flight's start, with the experiment's magnetometer gate.
fn filter() -> DelayedEkf {
    let ekf = DelayedEkf::new(&flight::X0, &diag(flight::P0), &flight::Q, &diag(flight::R));
    let mut ekf = match ekf {
        Ok(ekf) => ekf,
        Err(status) => panic!(
            "the delayed navigation EKF rejected its tuning: {:?}",
            status
        ),
    };
    let status = ekf.set_magnetometer_innovation_gate(MAGNETOMETER_GATE as f32);
    assert!(status == Status::Ok, "magnetometer gate: {:?}", status);
    ekf
}

/// Whether the prediction of IMU sample `k` fuses a waiting magnetometer sample: the one
/// given after the prediction `DELAY` samples before.
fn fuses(k: usize) -> bool {
    k.checked_sub(DelayedEkf::DELAY).is_some_and(|given| {
        flight::MAGNETOMETER
            .binary_search_by_key(&given, |(at, _)| *at)
            .is_ok()
    })
}

/// `DelayedEkf::predict`.
#[inline(never)]
pub fn generated_navigation_delayed_predict(
    filter: &mut DelayedEkf,
    dt: f32,
    imu: &[f32; 6],
) -> Status {
    filter.predict(dt, imu)
}

/// `DelayedEkf::predict` where it fuses a waiting magnetometer sample: a symbol of its
/// own, so that the trace reads these calls apart (the filter passed through `black_box`,
/// so that the two wrappers are not merged into one).
#[inline(never)]
pub fn generated_navigation_delayed_predict_fusing(
    filter: &mut DelayedEkf,
    dt: f32,
    imu: &[f32; 6],
) -> Status {
    black_box(filter).predict(dt, imu)
}

/// `DelayedEkf::update_gnss`.
#[inline(never)]
pub fn generated_navigation_delayed_update_gnss(filter: &mut DelayedEkf, y: &[f32; 6]) -> Status {
    filter.update_gnss(y)
}

/// `DelayedEkf::update_magnetometer`.
#[inline(never)]
pub fn generated_navigation_delayed_update_magnetometer(
    filter: &mut DelayedEkf,
    y: &[f32; 3],
) -> Status {
    filter.update_magnetometer(y)
}

/// The deepest stack of the prediction (through a fusion: a magnetometer sample waiting
/// `DELAY` predictions), the GNSS update and the magnetometer's call, each on a copy of
/// `ekf`.
fn stacks(ekf: &DelayedEkf) -> (usize, usize, usize) {
    let stack = |kernel: &dyn Fn(&mut DelayedEkf)| {
        let mut copy = *ekf;
        stack_depth(|| kernel(black_box(&mut copy)))
    };
    let predict_stack = stack(&|f| {
        let _ = black_box(generated_navigation_delayed_update_magnetometer(
            f,
            &flight::MAGNETOMETER[0].1,
        ));
        for _ in 0..DelayedEkf::DELAY {
            let _ = black_box(generated_navigation_delayed_predict(
                f,
                flight::INTERVAL[0],
                &flight::IMU[0],
            ));
        }
    });
    let gnss_stack = stack(&|f| {
        let _ = black_box(generated_navigation_delayed_update_gnss(
            f,
            &flight::GNSS[0].1,
        ));
    });
    let magnetometer_stack = stack(&|f| {
        let _ = black_box(generated_navigation_delayed_update_magnetometer(
            f,
            &flight::MAGNETOMETER[0].1,
        ));
    });
    (predict_stack, gnss_stack, magnetometer_stack)
}

/// Flies the flight, reading every call; prints each kernel's `cost` and `stack` lines
/// and the buffers' RAM.
pub fn costs(clock: &Clock) {
    let mut ekf = filter();
    let mut predict = Calls::<PREDICTIONS>::new();
    let mut predict_fusing = Calls::<PREDICTIONS>::new();
    let mut magnetometer = Calls::<MAGNETOMETER_UPDATES>::new();
    let mut gnss = Calls::<GNSS_UPDATES>::new();
    let mut sample = 0;
    traced(|| {
        for (call, event) in events().enumerate() {
            let status = match event {
                Event::Predict(dt, u) => {
                    let fusing = fuses(sample);
                    sample += 1;
                    if fusing {
                        predict_fusing.measure(clock, || {
                            generated_navigation_delayed_predict_fusing(&mut ekf, dt, u)
                        })
                    } else {
                        predict.measure(clock, || {
                            generated_navigation_delayed_predict(&mut ekf, dt, u)
                        })
                    }
                }
                Event::Magnetometer(y) => magnetometer.measure(clock, || {
                    generated_navigation_delayed_update_magnetometer(&mut ekf, y)
                }),
                Event::Gnss(y) => gnss.measure(clock, || {
                    generated_navigation_delayed_update_gnss(&mut ekf, y)
                }),
            };
            let _ = used(status, event, call);
        }
    });
    let (predict_stack, gnss_stack, magnetometer_stack) = stacks(&ekf);
    report(
        "navigation_delayed_predict",
        (predict.mean(), 0),
        (predict_stack, 0),
    );
    report(
        "navigation_delayed_predict_fusing",
        (predict_fusing.mean(), 0),
        (predict_stack, 0),
    );
    report(
        "navigation_delayed_update_gnss",
        (gnss.mean(), 0),
        (gnss_stack, 0),
    );
    report(
        "navigation_delayed_update_magnetometer",
        (magnetometer.mean(), 0),
        (magnetometer_stack, 0),
    );
    cortex_m_semihosting::hprintln!(
        "ram navigation_delayed_buffers {}",
        DELAYED_EKF_BUFFER_BYTES
    );
}
