//! The delayed fusion horizon (`sensor fix(delay = 3)` beside a current compass): the
//! generated filter, which fuses a late fix on a horizon `DELAY` samples behind, holds the
//! compass's headings until the horizon reaches them, and predicts the current state
//! through its buffered inputs, against an independent nalgebra filter that keeps every
//! input and measurement and replays them from the start, each measurement fused at the
//! sample it describes (estimate and covariance), to 1e-9 in `f64`; and the same with
//! each measurement's delay given at run time (`sensor fix(max_delay = 4)`), varying from
//! one measurement to the next.

use nalgebra::{Matrix2, Matrix2x3, Matrix3, Vector2, Vector3};
use tests::plane::{f, jacobian};

include!("../models/delayed_fix.rs");
include!("../models/jittered_late.rs");
include!("../models/varying_delay.rs");

const DT: f64 = 0.1;
const DELAY: usize = 3;

/// A measurement, as the reference keeps it.
#[derive(Clone, Copy)]
enum Measurement {
    Fix([f64; 2]),
    Compass(f64),
}

/// The reference: keeps every input and measurement (with the sample it describes) and,
/// at each sample, runs a plain EKF from the start to the horizon, fusing at each sample
/// the measurements that describe it (those before the start at the start, once they have
/// waited as the filter makes them) in the order they arrived; the current state is the
/// horizon's estimate propagated through the inputs since.
struct Replaying {
    x0: Vector3<f64>,
    p0: Matrix3<f64>,
    /// Each sample's interval and input.
    inputs: Vec<(f64, [f64; 2])>,
    /// Whether `q` is a density (a model with a sample interval: `Q dt`), else per sample.
    q_density: bool,
    /// Each measurement with the sample it describes (the start for one before it) and the
    /// prediction from which the filter has fused it: a measurement `d` samples late on a
    /// horizon `late` behind waits `late - d` predictions, so one that describes a sample
    /// before the start is fused there once it has waited.
    measurements: Vec<(usize, usize, Measurement)>,
    q: Matrix3<f64>,
    r_fix: Matrix2<f64>,
    r_compass: f64,
}

impl Replaying {
    /// The reference from the initial estimate and covariance, with the process noise `q`
    /// (a density if `q_density`) and the measurement noise of `r` below, before any
    /// sample: the fix's block `[[0.5, 0.1], [0.1, 0.7]]`, the compass's 0.04.
    fn new(
        (x0, p0): (Vector3<f64>, Matrix3<f64>),
        (q, q_density): (Matrix3<f64>, bool),
    ) -> Replaying {
        Replaying {
            x0,
            p0,
            inputs: Vec::new(),
            q_density,
            measurements: Vec::new(),
            q,
            r_fix: Matrix2::new(0.5, 0.1, 0.1, 0.7),
            r_compass: 0.04,
        }
    }

    /// The estimate and covariance at sample `at`, every measurement of it and before
    /// fused.
    fn at(&self, at: usize, now: usize) -> (Vector3<f64>, Matrix3<f64>) {
        let (mut x, mut p) = (self.x0, self.p0);
        for j in 0..=at {
            if j > 0 {
                let (dt, u) = self.inputs[j - 1];
                let a = jacobian(dt, &x, u);
                let q = if self.q_density { self.q * dt } else { self.q };
                (x, p) = (f(dt, &x, u), a * p * a.transpose() + q);
            }
            let fused = |&&(of, from, _): &&(usize, usize, Measurement)| of == j && from <= now;
            for &(_, _, y) in self.measurements.iter().filter(fused) {
                (x, p) = self.fuse(x, p, y);
            }
        }
        (x, p)
    }

    /// One measurement fused (textbook form).
    fn fuse(
        &self,
        x: Vector3<f64>,
        p: Matrix3<f64>,
        y: Measurement,
    ) -> (Vector3<f64>, Matrix3<f64>) {
        let (x, p) = match y {
            Measurement::Fix(y) => {
                let h = Matrix2x3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0);
                let s = h * p * h.transpose() + self.r_fix;
                let k = p * h.transpose() * s.try_inverse().unwrap();
                (
                    x + k * (Vector2::new(y[0], y[1]) - h * x),
                    (Matrix3::identity() - k * h) * p,
                )
            }
            Measurement::Compass(y) => {
                let h = Vector3::new(0.0, 0.0, 1.0).transpose();
                let k = p * h.transpose() / ((h * p * h.transpose())[(0, 0)] + self.r_compass);
                (x + k * (y - x[2]), (Matrix3::identity() - k * h) * p)
            }
        };
        (x, 0.5 * (p + p.transpose()))
    }

    /// That a filter on a horizon `late` samples behind, at sample `k`, holds the estimate
    /// and covariance of the horizon and the current state of sample `k` (its `state()`,
    /// `covariance()` and `current_state()`).
    fn assert_matches(&self, k: usize, late: usize, filter: ([f64; 3], [[f64; 3]; 3], [f64; 3])) {
        let (state, covariance, current) = filter;
        let horizon = k.saturating_sub(late);
        let (x_delayed, p_delayed) = self.at(horizon, k);
        assert_close("delayed estimate", k, &state, x_delayed.as_slice());
        let p: Vec<f64> = covariance.iter().flatten().copied().collect();
        let p_reference: Vec<f64> = (0..9).map(|i| p_delayed[(i / 3, i % 3)]).collect();
        assert_close("delayed covariance", k, &p, &p_reference);
        let x_now = self.current(horizon, k);
        assert_close("current state", k, &current, x_now.as_slice());
    }

    /// A measurement given after the `k`-th prediction, `d` samples late, to a filter on a
    /// horizon `late` samples behind.
    fn given(&mut self, (k, d, late): (usize, usize, usize), y: Measurement) {
        self.measurements
            .push((k.saturating_sub(d), k + late - d, y));
    }

    /// The current state at sample `k`, from the horizon `horizon`.
    fn current(&self, horizon: usize, k: usize) -> Vector3<f64> {
        let (x, _) = self.at(horizon, k);
        self.inputs[horizon..k]
            .iter()
            .fold(x, |x, &(dt, u)| f(dt, &x, u))
    }
}

fn as_array(m: &Matrix3<f64>) -> [[f64; 3]; 3] {
    std::array::from_fn(|i| std::array::from_fn(|j| m[(i, j)]))
}

fn assert_close(what: &str, k: usize, generated: &[f64], reference: &[f64]) {
    for (g, r) in generated.iter().zip(reference) {
        assert!(
            (g - r).abs() <= 1e-9 * (1.0 + r.abs()),
            "{what} at sample {k}: generated {generated:?}, replayed {reference:?}"
        );
    }
}

#[test]
fn delayed_fusion_equals_fusing_at_the_described_sample_and_replaying() {
    use delayed_fix::in_f64::{Ekf, Status};
    assert_eq!(Ekf::DELAY, DELAY);
    let x0 = Vector3::new(1.0, -2.0, 0.3);
    let p0 = Matrix3::new(4.0, 0.5, 0.1, 0.5, 3.0, -0.2, 0.1, -0.2, 0.5);
    let q = Matrix3::new(0.02, 0.001, 0.0, 0.001, 0.03, 0.002, 0.0, 0.002, 0.01);
    let r = [[0.5, 0.1, 0.0], [0.1, 0.7, 0.0], [0.0, 0.0, 0.04]];
    let mut ekf = Ekf::new(&x0.into(), &as_array(&p0), &as_array(&q), &r).unwrap();
    let mut replaying = Replaying::new((x0, p0), (q, false));
    let (mut fixes, mut headings) = (0, 0);
    for k in 1..=60_usize {
        let t = k as f64 * DT;
        let u = [2.0 + (0.7 * t).sin(), 0.3 * (0.4 * t).cos()];
        // A prediction fuses the compass headings the horizon reaches.
        assert_eq!(ekf.predict(&u), Status::Ok);
        replaying.inputs.push((DT, u));
        // Fixes from the second sample on, some before the buffer is full (they describe
        // the start, where the horizon still is); the current compass every third sample.
        if k % 2 == 0 {
            let y = [2.0 * t + (1.3 * t).cos(), 0.5 * t - (0.9 * t).sin()];
            assert_eq!(ekf.update_fix(&y), Status::Ok);
            replaying.given((k, DELAY, DELAY), Measurement::Fix(y));
            fixes += 1;
        }
        if k % 3 == 0 {
            let y = 0.3 + 0.1 * (0.5 * t).sin();
            assert_eq!(ekf.update_compass_sensor(&[y]), Status::Ok);
            replaying.given((k, 0, DELAY), Measurement::Compass(y));
            headings += 1;
        }
        let filter = (ekf.state(), ekf.covariance(), ekf.current_state());
        replaying.assert_matches(k, DELAY, filter);
    }
    assert_eq!((fixes, headings), (30, 20));
    // The output predictor moved the estimate: the current state is not the delayed one.
    assert!((ekf.current_state()[0] - ekf.state()[0]).abs() > 0.1);
    // The compass measurements fused so far moved the heading's variance below what the
    // fixes alone leave: the waiting ones were fused, not dropped.
    assert!(ekf.covariance()[2][2] < 0.04);
}

#[test]
fn reset_empties_the_buffer() {
    use delayed_fix::in_f64::Ekf;
    let p0 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.1]];
    let q = [[0.01, 0.0, 0.0], [0.0, 0.01, 0.0], [0.0, 0.0, 0.001]];
    let r = [[0.5, 0.0, 0.0], [0.0, 0.5, 0.0], [0.0, 0.0, 0.1]];
    let mut ekf = Ekf::new(&[0.0; 3], &p0, &q, &r).unwrap();
    for _ in 0..10 {
        assert_eq!(ekf.predict(&[1.0, 0.0]), delayed_fix::in_f64::Status::Ok);
    }
    assert_eq!(
        ekf.reset(&[5.0, 5.0, 0.0], &p0),
        delayed_fix::in_f64::Status::Ok
    );
    assert_eq!(ekf.current_state(), [5.0, 5.0, 0.0]);
    // The horizon waits for `DELAY` samples before it moves again.
    for _ in 0..DELAY {
        assert_eq!(ekf.predict(&[1.0, 0.0]), delayed_fix::in_f64::Status::Ok);
        assert_eq!(ekf.state(), [5.0, 5.0, 0.0]);
    }
    assert_eq!(ekf.predict(&[1.0, 0.0]), delayed_fix::in_f64::Status::Ok);
    assert!((ekf.state()[0] - 5.1).abs() < 1e-12);
    assert!((ekf.current_state()[0] - 5.4).abs() < 1e-12);
    assert_eq!(
        ekf.predict(&[f64::NAN, 0.0]),
        delayed_fix::in_f64::Status::RejectedInput
    );
}

#[test]
fn a_step_is_a_prediction_then_an_update_on_the_horizon() {
    use delayed_fix::in_f64::{Ekf, Status};
    let p0 = [[1.0, 0.2, 0.0], [0.2, 1.0, 0.0], [0.0, 0.0, 0.1]];
    let q = [[0.01, 0.0, 0.0], [0.0, 0.01, 0.0], [0.0, 0.0, 0.001]];
    let r = [[0.5, 0.0, 0.0], [0.0, 0.5, 0.0], [0.0, 0.0, 0.1]];
    let mut stepped = Ekf::new(&[0.0, 1.0, 0.2], &p0, &q, &r).unwrap();
    let mut split = stepped;
    for k in 0..12 {
        let t = f64::from(k) * DT;
        let u = [1.0 + t, 0.1];
        let y = [t, 1.0 - t, 0.2];
        assert_eq!(stepped.step(&u, &y), Status::Ok);
        assert_eq!(split.predict(&u), Status::Ok);
        assert_eq!(split.update(&y), Status::Ok);
        assert_close("delayed estimate", 0, &stepped.state(), &split.state());
        assert_close(
            "current state",
            0,
            &stepped.current_state(),
            &split.current_state(),
        );
    }
    // A step refused for its measurement leaves the buffer and the horizon as they were.
    let before = stepped;
    assert_eq!(
        stepped.step(&[1.0, 0.0], &[f64::NAN, 0.0, 0.0]),
        Status::RejectedInput
    );
    assert_eq!(stepped, before);
}

#[test]
fn with_a_sample_interval_the_buffer_holds_each_sample_s() {
    use jittered_late::in_f64::{Ekf, Status};
    const LATE: usize = 2;
    assert_eq!(Ekf::DELAY, LATE);
    let x0 = Vector3::new(1.0, -2.0, 0.3);
    let p0 = Matrix3::new(4.0, 0.5, 0.1, 0.5, 3.0, -0.2, 0.1, -0.2, 0.5);
    // Densities: per second.
    let q = Matrix3::new(0.2, 0.01, 0.0, 0.01, 0.3, 0.02, 0.0, 0.02, 0.1);
    let r = [[0.5, 0.1, 0.0], [0.1, 0.7, 0.0], [0.0, 0.0, 0.04]];
    let mut ekf = Ekf::new(&x0.into(), &as_array(&p0), &as_array(&q), &r).unwrap();
    let mut replaying = Replaying::new((x0, p0), (q, true));
    let mut t = 0.0;
    for k in 1..=50_usize {
        let dt = 0.1 * (1.0 + 0.33 * (1.7 * k as f64).sin());
        t += dt;
        let u = [2.0 + (0.7 * t).sin(), 0.3 * (0.4 * t).cos()];
        assert_eq!(ekf.predict(dt, &u), Status::Ok);
        replaying.inputs.push((dt, u));
        if k % 2 == 0 {
            let y = [2.0 * t + (1.3 * t).cos(), 0.5 * t - (0.9 * t).sin()];
            assert_eq!(ekf.update_fix(&y), Status::Ok);
            replaying.given((k, LATE, LATE), Measurement::Fix(y));
        }
        if k % 3 == 0 {
            let y = 0.3 + 0.1 * (0.5 * t).sin();
            assert_eq!(ekf.update_compass_sensor(&[y]), Status::Ok);
            replaying.given((k, 0, LATE), Measurement::Compass(y));
        }
        let filter = (ekf.state(), ekf.covariance(), ekf.current_state());
        replaying.assert_matches(k, LATE, filter);
    }
    // An interval that is not positive is refused before anything is buffered.
    let before = ekf;
    assert_eq!(ekf.predict(0.0, &[1.0, 0.0]), Status::RejectedInput);
    assert_eq!(ekf.predict(f64::NAN, &[1.0, 0.0]), Status::RejectedInput);
    assert_eq!(ekf, before);
}

stateforge::model! {
    /// A cart with a gated fix two samples late: a step that refuses an outlier keeps the
    /// horizon's prediction.
    pub mod gated_late {
        scalar f64;
        const DT = 0.1;
        state p, v;
        input a;
        output fix = p;
        sensor gnss(delay = 2) = [fix];
        generate ekf(gate = 9.0);
        dynamics discrete {
            p = p + DT * v;
            v = v + DT * a;
        }
    }
}

#[test]
fn a_gated_step_that_refuses_an_outlier_keeps_the_horizon_s_prediction() {
    use gated_late::{Ekf, Status};
    let p0 = [[1.0, 0.0], [0.0, 1.0]];
    let q = [[1e-4, 0.0], [0.0, 1e-4]];
    let mut stepped = Ekf::new(&[0.0, 1.0], &p0, &q, &[[0.01]]).unwrap();
    let mut split = stepped;
    for k in 0..8_u32 {
        // The horizon moves from the third sample on; the fifth fix is an outlier.
        let y = if k == 4 {
            [100.0]
        } else {
            [0.1 * f64::from(k)]
        };
        let expected = if k == 4 {
            Status::OutlierRejected
        } else {
            Status::Ok
        };
        let u = [0.3 * f64::from(k)];
        assert_eq!(stepped.step(&u, &y), expected, "sample {k}");
        assert_eq!(split.predict(&u), Status::Ok);
        assert_eq!(split.update(&y), expected, "sample {k}");
        assert_close(
            "delayed estimate",
            k as usize,
            &stepped.state(),
            &split.state(),
        );
        let p = |f: &Ekf| -> Vec<f64> { f.covariance().iter().flatten().copied().collect() };
        assert_close("delayed covariance", k as usize, &p(&stepped), &p(&split));
        let (now, reference) = (stepped.current_state(), split.current_state());
        assert_close("current state", k as usize, &now, &reference);
    }
}

/// The slots of a sensor whose delay is given at run time, as the reference sees them: the
/// samples its waiting measurements describe (before the start, negative), so that a
/// second measurement for a sample one already waits for is expected refused.
struct Slots {
    /// The samples the horizon lags.
    late: usize,
    waiting: Vec<i64>,
}

impl Slots {
    fn new(late: usize) -> Slots {
        Slots {
            late,
            waiting: Vec::new(),
        }
    }

    /// Whether a measurement given after the `k`-th prediction, `d` samples late, is
    /// taken: fused at once at the horizon's delay; else stored unless its sample's slot
    /// is taken (the predictions since fused what the horizon reached).
    fn take(&mut self, k: usize, d: usize) -> bool {
        let (k, d, late) = (k as i64, d as i64, self.late as i64);
        self.waiting.retain(|&sample| sample > k - late);
        if d == late {
            return true;
        }
        if self.waiting.contains(&(k - d)) {
            return false;
        }
        self.waiting.push(k - d);
        true
    }
}

/// Runs a filter of the plane with a fix and a compass whose delays are given at run time
/// (or the fix's fixed, at the horizon's), `late` samples behind, against the replaying
/// reference: `$fix(ekf, delay, y)` and `$compass(ekf, delay, y)` update it; the fix's
/// delay follows `fix_delay(k)`. Each sample's delays differ from the last's, from 0 to
/// each maximum; a measurement for a sample whose slot is taken must be refused and leave
/// the filter as it was, and so must a delay beyond the maximum and a non-finite
/// measurement. Returns the delays taken, fix's and compass's, how many were refused for
/// a taken slot, and how many fixes were taken after one of a later sample (out of order).
macro_rules! run_against_replaying {
    ($module:ident, $late:expr, $fix_max:expr, $fix_delay:expr, $fix:expr, $compass:expr) => {{
        use $module::in_f64::{Ekf, Status};
        let late: usize = $late;
        let fix_delay: fn(usize) -> usize = $fix_delay;
        let fix: fn(&mut Ekf, usize, &[f64; 2]) -> Status = $fix;
        let compass: fn(&mut Ekf, usize, &[f64; 1]) -> Status = $compass;
        assert_eq!(Ekf::DELAY, late);
        let x0 = Vector3::new(1.0, -2.0, 0.3);
        let p0 = Matrix3::new(4.0, 0.5, 0.1, 0.5, 3.0, -0.2, 0.1, -0.2, 0.5);
        let q = Matrix3::new(0.02, 0.001, 0.0, 0.001, 0.03, 0.002, 0.0, 0.002, 0.01);
        let r = [[0.5, 0.1, 0.0], [0.1, 0.7, 0.0], [0.0, 0.0, 0.04]];
        let mut ekf = Ekf::new(&x0.into(), &as_array(&p0), &as_array(&q), &r).unwrap();
        let mut replaying = Replaying::new((x0, p0), (q, false));
        let (mut fix_slots, mut compass_slots) = (Slots::new(late), Slots::new(late));
        let (mut fix_delays, mut compass_delays, mut refused) = (Vec::new(), Vec::new(), 0);
        let (mut latest_fix, mut out_of_order) = (0, 0);
        for k in 1..=90_usize {
            let t = k as f64 * DT;
            let u = [2.0 + (0.7 * t).sin(), 0.3 * (0.4 * t).cos()];
            assert_eq!(ekf.predict(&u), Status::Ok);
            replaying.inputs.push((DT, u));
            if k % 2 == 0 || k % 5 == 1 {
                let d = fix_delay(k);
                let s = (k as f64 - d as f64) * DT;
                let y = [2.0 * s + (1.3 * s).cos(), 0.5 * s - (0.9 * s).sin()];
                let before = ekf;
                if fix_slots.take(k, d) {
                    assert_eq!(fix(&mut ekf, d, &y), Status::Ok, "fix at {k}, {d} late");
                    replaying.given((k, d, late), Measurement::Fix(y));
                    fix_delays.push(d);
                    let sample = k.saturating_sub(d);
                    out_of_order += usize::from(sample < latest_fix);
                    latest_fix = latest_fix.max(sample);
                } else {
                    assert_eq!(fix(&mut ekf, d, &y), Status::RejectedInput, "at {k}");
                    assert_eq!(ekf, before, "a refused fix changed the filter at {k}");
                    refused += 1;
                }
            }
            if k % 3 != 1 {
                let d = (k / 2 + k / 7) % 3;
                let s = (k as f64 - d as f64) * DT;
                let y = [0.3 + 0.1 * (0.5 * s).sin()];
                let before = ekf;
                if compass_slots.take(k, d) {
                    assert_eq!(compass(&mut ekf, d, &y), Status::Ok, "compass at {k}");
                    replaying.given((k, d, late), Measurement::Compass(y[0]));
                    compass_delays.push(d);
                } else {
                    assert_eq!(compass(&mut ekf, d, &y), Status::RejectedInput, "at {k}");
                    assert_eq!(ekf, before, "a refused heading changed the filter at {k}");
                    refused += 1;
                }
            }
            // Refused, the filter left as it was: a delay beyond the maximum, and a
            // non-finite measurement.
            let before = ekf;
            assert_eq!(compass(&mut ekf, 3, &[0.3]), Status::RejectedInput);
            assert_eq!(compass(&mut ekf, usize::MAX, &[0.3]), Status::RejectedInput);
            assert_eq!(compass(&mut ekf, 0, &[f64::NAN]), Status::RejectedInput);
            if let Some(max) = $fix_max {
                assert_eq!(fix(&mut ekf, max + 1, &[1.0, 2.0]), Status::RejectedInput);
            }
            assert_eq!(
                fix(&mut ekf, 0, &[f64::INFINITY, 2.0]),
                Status::RejectedInput
            );
            assert_eq!(
                ekf, before,
                "a refused measurement changed the filter at {k}"
            );
            let filter = (ekf.state(), ekf.covariance(), ekf.current_state());
            replaying.assert_matches(k, late, filter);
        }
        (fix_delays, compass_delays, refused, out_of_order)
    }};
}

/// That `delays` holds every delay from 0 to `max`.
fn assert_every_delay(what: &str, delays: &[usize], max: usize) {
    for d in 0..=max {
        assert!(
            delays.contains(&d),
            "no {what} {d} samples late in {delays:?}"
        );
    }
}

#[test]
fn run_time_delays_equal_fusing_each_at_the_described_sample_and_replaying() {
    let (fixes, headings, refused, out_of_order) = run_against_replaying!(
        varying_delay,
        4,
        Some(4_usize),
        |k| (3 * k + k / 7) % 5,
        |ekf, d, y| ekf.update_fix(d, y),
        |ekf, d, y| ekf.update_compass_sensor(d, y)
    );
    // Every delay taken, the horizon's (fused at once) and none (waiting longest)
    // included, and some measurements refused for a slot taken.
    assert_every_delay("fix", &fixes, 4);
    assert_every_delay("heading", &headings, 2);
    assert!(refused > 0);
    // Consecutive measurements of a sensor had different delays, and some fixes arrived
    // after one of a later sample: each was fused at its own.
    assert!(fixes.windows(2).filter(|w| w[0] != w[1]).count() > fixes.len() / 2);
    assert!(out_of_order > 0);
}

stateforge::model! {
    /// The plane with a fix of a fixed delay, which sets the horizon, and a compass whose
    /// delay is given at run time, shorter.
    pub mod fixed_and_varying {
        scalar f64;
        const DT = 0.1;
        state px, py, heading;
        input speed, yaw_rate;
        output fix_x = px, fix_y = py, compass = heading;
        sensor fix(delay = 3) = [fix_x, fix_y];
        sensor compass_sensor(max_delay = 2) = [compass];
        dynamics discrete {
            let turned = heading + DT * yaw_rate;
            px = px + DT * speed * cos(turned);
            py = py + DT * speed * sin(turned);
            heading = turned;
        }
        generate ekf;
    }
}

#[test]
fn a_run_time_delay_beside_a_fixed_one_equals_replaying() {
    mod fixed_and_varying {
        pub use super::fixed_and_varying::{Ekf, Status};
        pub mod in_f64 {
            pub use super::{Ekf, Status};
        }
    }
    let (fixes, headings, refused, _) = run_against_replaying!(
        fixed_and_varying,
        3,
        None::<usize>,
        |_| 3,
        // The fix's delay is fixed, always 3.
        |ekf, _, y| ekf.update_fix(y),
        |ekf, d, y| ekf.update_compass_sensor(d, y)
    );
    assert_eq!(fixes.len(), 54);
    assert_every_delay("heading", &headings, 2);
    assert!(refused > 0);
}

#[test]
fn a_joint_update_and_step_take_each_sensor_s_delay() {
    use varying_delay::in_f64::{Ekf, Status};
    let p0 = [[1.0, 0.2, 0.0], [0.2, 1.0, 0.0], [0.0, 0.0, 0.1]];
    let q = [[0.01, 0.0, 0.0], [0.0, 0.01, 0.0], [0.0, 0.0, 0.001]];
    let r = [[0.5, 0.0, 0.0], [0.0, 0.5, 0.0], [0.0, 0.0, 0.1]];
    let mut stepped = Ekf::new(&[0.0, 1.0, 0.2], &p0, &q, &r).unwrap();
    let (mut joint, mut split) = (stepped, stepped);
    for k in 0..20_usize {
        let t = k as f64 * DT;
        let (u, y) = ([1.0 + t, 0.1], [t, 1.0 - t, 0.2]);
        let (d_fix, d_compass) = (k % 5, (k / 3) % 3);
        let expected = stepped.step(d_fix, d_compass, &u, &y);
        assert_eq!(joint.predict(&u), Status::Ok);
        assert_eq!(joint.update(d_fix, d_compass, &y), expected, "sample {k}");
        assert_eq!(split.predict(&u), Status::Ok);
        let fix = split.update_fix(d_fix, &[y[0], y[1]]);
        let compass = split.update_compass_sensor(d_compass, &[y[2]]);
        let first = if fix == Status::Ok { compass } else { fix };
        assert_eq!(first, expected, "sample {k}");
        assert_eq!(stepped, joint, "sample {k}");
        assert_eq!(stepped, split, "sample {k}");
    }
    // A joint update refused for its measurement leaves the filter as it was.
    let before = joint;
    assert_eq!(
        joint.update(0, 0, &[f64::NAN, 0.0, 0.0]),
        Status::RejectedInput
    );
    assert_eq!(joint, before);
}

#[test]
fn reset_empties_the_slots() {
    use varying_delay::in_f64::{Ekf, Status};
    let p0 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.1]];
    let q = [[0.01, 0.0, 0.0], [0.0, 0.01, 0.0], [0.0, 0.0, 0.001]];
    let r = [[0.5, 0.0, 0.0], [0.0, 0.5, 0.0], [0.0, 0.0, 0.1]];
    let mut ekf = Ekf::new(&[0.0; 3], &p0, &q, &r).unwrap();
    assert_eq!(ekf.update_fix(1, &[3.0, 3.0]), Status::Ok);
    assert_eq!(ekf.update_fix(1, &[3.0, 3.0]), Status::RejectedInput);
    assert_eq!(ekf.reset(&[5.0, 5.0, 0.0], &p0), Status::Ok);
    // The slot is free again, and the fix given before the reset is never fused.
    assert_eq!(ekf.update_fix(1, &[5.0, 5.0]), Status::Ok);
    let mut unfused = Ekf::new(&[0.0; 3], &p0, &q, &r).unwrap();
    assert_eq!(unfused.reset(&[5.0, 5.0, 0.0], &p0), Status::Ok);
    assert_eq!(unfused.update_fix(1, &[5.0, 5.0]), Status::Ok);
    for _ in 0..6 {
        assert_eq!(ekf.predict(&[1.0, 0.0]), Status::Ok);
        assert_eq!(unfused.predict(&[1.0, 0.0]), Status::Ok);
    }
    assert_eq!(ekf, unfused);
}
