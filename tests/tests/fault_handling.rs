//! The fault handling the filters share: the innovation gate of the hybrid and the
//! continuous-time EKF (an outlier rejected, the prediction kept, the filter going on), and
//! covariance arguments that are not covariances rejected where they enter, by every
//! filter, leaving it unchanged. The error-state EKF of a model with a rotation (the AHRS
//! test model, `tests/models/ahrs.rs`, with its gated `GatedEkf`)
//! in `f32` and `f64`: non-finite entries, rotations that are not unit quaternions and
//! covariances over its tangent space that are not covariances rejected where they enter,
//! and each sensor's gate judging that sensor's update alone.

use generated_demo::{blade_identification, cantilever, helicopter, polynomial};
use nalgebra::SMatrix;
use std::ops::Range;
use tests::cantilever_sim::Sample;
use tests::reference::{self, State};
use tests::tuning::{diag, p0, Q_DIAG, R, X0_CLOSE};

include!("../models/ahrs.rs");

/// The blade's identification prior of sect. 4.1 (`x0`, `P0`, `Q = Q~ / T`, `R`).
mod blade {
    pub const X0: [f64; 6] = [0.0, 0.0, 450.0, 0.1, 5e-4, 2.0];
    pub const P0: [f64; 6] = [1e-5, 1.0, 1e4, 1e-2, 1e-6, 0.1];
    pub const Q: [f64; 6] = [0.0, 1e-2, 1e3, 1e-3, 1e-9, 1.0];
    pub const R: f64 = 1e-10;
}

/// A square matrix with `d` on its diagonal.
fn diagonal<const N: usize, T: Copy + Default>(d: [T; N]) -> [[T; N]; N] {
    core::array::from_fn(|i| core::array::from_fn(|j| if i == j { d[i] } else { T::default() }))
}

/// A measurement consistent with the filter: its own prediction of the output, which the
/// gate passes whatever its threshold.
macro_rules! consistent_measurement {
    ($filter:expr, $($predict_args:expr),*) => {{
        let mut predicted = $filter;
        assert_eq!(predicted.predict($($predict_args),*), Status::Ok);
        predicted.state()[0]
    }};
}

/// An ungated EKF refuses a measurement beyond the divergence bound on its normalised
/// innovation squared (1e8) with `Diverged`, the filter unchanged, in `step` and `update`
/// alike, while one just inside the bound is used: the bound, not the probe on the result,
/// decides (the measurement of 1e4 standard deviations moves the estimate by far less than
/// 1e18).
#[test]
fn an_ungated_ekf_refuses_a_measurement_beyond_the_divergence_bound() {
    use cantilever::in_f64::{Ekf, Status};
    let mut filter = Ekf::new(&X0_CLOSE, &p0(2e4), &Q_DIAG, &[[R]]).unwrap();
    let u = [0.1];
    for _ in 0..10 {
        let y = consistent_measurement!(filter, &u);
        assert_eq!(filter.step(&u, &[y]), Status::Ok);
    }
    let mut predicted = filter;
    assert_eq!(predicted.predict(&u), Status::Ok);
    let sigma = (predicted.covariance()[0][0] + R).sqrt();
    let y = predicted.state()[0];
    for (standard_deviations, expected) in [(1.01e4, Status::Diverged), (0.99e4, Status::Ok)] {
        let outlier = y + standard_deviations * sigma;
        let mut stepped = filter;
        assert_eq!(
            stepped.step(&u, &[outlier]),
            expected,
            "{standard_deviations}"
        );
        let mut updated = predicted;
        assert_eq!(
            updated.update(&[outlier]),
            expected,
            "{standard_deviations}"
        );
        if expected == Status::Diverged {
            // Nothing applied; the refusal counted (`recover_after`), which is all a
            // refusal changes: the filter is otherwise as it was.
            for (after, before) in [(stepped, filter), (updated, predicted)] {
                assert_eq!(after.refusals(), before.refusals() + 1);
                let observed = |f: &cantilever::in_f64::Ekf| {
                    (f.state(), f.covariance(), f.innovation(), f.refusals())
                };
                let mut counted = observed(&before);
                counted.3 += 1;
                assert_eq!(observed(&after), counted);
            }
        } else {
            let moved = (updated.state()[0] - y).abs();
            assert!(moved > 1.0 && moved < 1e18, "{moved}");
        }
    }
}

/// The cantilever's DKF as the tests build it, ungated.
fn new_dkf() -> cantilever::in_f64::Dkf {
    use cantilever::in_f64::Dkf;
    Dkf::new(&X0_CLOSE, &p0(2e4), &Q_DIAG, &p0(2e4), &Q_DIAG, &[[R]]).unwrap()
}

/// Steps the DKF through samples `ks` (input of the previous sample), each step passing.
fn step_through(filter: &mut cantilever::in_f64::Dkf, samples: &[Sample], ks: Range<usize>) {
    for k in ks {
        let status = filter.step(&[samples[k - 1].u], &[samples[k].y]);
        assert!(status.is_ok(), "step {k}: {status:?}");
    }
}

/// Checks the LKF's prediction against the reference's equations: `f` linearised about the
/// AKF's previous estimate, `x = f(xbar) + A (x - xbar)`, `P = A P A' + Q`.
fn assert_lkf_prediction_matches_the_reference(
    filter: &cantilever::in_f64::Dkf,
    predicted: &cantilever::in_f64::Dkf,
    u: f64,
) {
    let (xbar, x) = (State::from(filter.akf_state()), State::from(filter.state()));
    let a = reference::jacobian_f_x(&xbar, u);
    let x_pred = reference::f(&xbar, u) + a * (x - xbar);
    let p = SMatrix::<f64, 5, 5>::from_fn(|i, j| filter.covariance()[i][j]);
    let p_pred = a * p * a.transpose() + SMatrix::<f64, 5, 5>::from_diagonal(&State::from(Q_DIAG));
    for i in 0..5 {
        let scale = x_pred.amax();
        assert!(
            (predicted.state()[i] - x_pred[i]).abs() <= 1e-9 * scale,
            "x{i}"
        );
        for j in 0..5 {
            let scale = p_pred[(i, i)].max(p_pred[(j, j)]).max(1e-300);
            assert!(
                (predicted.covariance()[i][j] - p_pred[(i, j)]).abs() <= 1e-9 * scale,
                "P{i}{j}"
            );
        }
    }
}

/// Steps the DKF with `spike`; checks both filters reject it, keep `predicted`'s estimates
/// and record their innovations.
fn assert_both_reject_the_spike(
    filter: &mut cantilever::in_f64::Dkf,
    predicted: &cantilever::in_f64::Dkf,
    u: &[f64; 1],
    spike: f64,
) {
    use cantilever::in_f64::Status;
    let status = filter.step(u, &[spike]);
    assert_eq!(
        (status.lkf, status.akf),
        (Status::OutlierRejected, Status::OutlierRejected)
    );
    assert_eq!(
        (filter.state(), filter.covariance()),
        (predicted.state(), predicted.covariance())
    );
    assert_eq!(
        (filter.akf_state(), filter.akf_covariance()),
        (predicted.akf_state(), predicted.akf_covariance())
    );
    for nis in [
        filter.normalised_innovation_squared(),
        filter.akf_normalised_innovation_squared(),
    ] {
        assert!(nis > 100.0, "{nis}");
    }
    assert!((filter.innovation()[0] - (spike - predicted.state()[0])).abs() < 1e-9);
    assert!((filter.akf_innovation()[0] - (spike - predicted.akf_state()[0])).abs() < 1e-9);
}

/// Checks `reset` gives the filter `new` builds, gate kept, and refuses a negative `P0`
/// of the AKF, leaving it so.
fn assert_reset_gives_a_fresh_gated_filter(filter: &mut cantilever::in_f64::Dkf) {
    use cantilever::in_f64::Status;
    assert_eq!(filter.reset(&X0_CLOSE, &p0(2e4), &p0(2e4)), Status::Ok);
    let mut fresh = new_dkf();
    assert_eq!(fresh.set_innovation_gate(100.0), Status::Ok);
    assert_eq!(*filter, fresh);
    let mut negative = p0(2e4);
    negative[1][1] = -1.0;
    assert_eq!(
        filter.reset(&X0_CLOSE, &p0(2e4), &negative),
        Status::InvalidCovariance
    );
    assert_eq!(*filter, fresh);
}

/// The DKF's gate judges each filter by its own NIS: with the gate at 100 (ten standard
/// deviations: a run of consistent samples passes it), a spike of 100 standard deviations
/// of the wider of the two filters' predictions is rejected by both, each keeping its prediction (what `predict` gives, the window emptied),
/// the innovations recorded; the window then refills and the filter goes on. `reset`
/// gives the filter that `new` builds, keeping the gate; `predict` rejects a NaN input.
#[test]
fn a_gated_dkf_keeps_both_predictions_empties_its_window_and_resets() {
    use cantilever::in_f64::{Status, WindowStatus};
    let mut filter = new_dkf();
    assert_eq!(filter.set_innovation_gate(100.0), Status::Ok);
    let samples = tests::cantilever_sim::run(400, 1e-4, 3);
    step_through(&mut filter, &samples, 1..300);
    let (k, u) = (300, [samples[299].u]);
    let mut predicted = filter;
    assert!(predicted.predict(&u).is_ok());
    assert_lkf_prediction_matches_the_reference(&filter, &predicted, u[0]);
    assert_eq!(
        predicted.predict(&[f64::NAN]).lkf,
        Status::RejectedInput,
        "a NaN input"
    );
    let widest = predicted.covariance()[0][0].max(predicted.akf_covariance()[0][0]);
    let spike = samples[k].y + 100.0 * (widest + R).sqrt();
    assert_both_reject_the_spike(&mut filter, &predicted, &u, spike);
    let next = filter.step(&[samples[k].u], &[samples[k + 1].y]);
    assert!(next.is_ok(), "{next:?}");
    assert_eq!(next.window, WindowStatus::Filling, "the window refills");
    step_through(&mut filter, &samples, k + 2..samples.len());
    assert_reset_gives_a_fresh_gated_filter(&mut filter);
}

#[test]
fn gated_hybrid_ekf_rejects_an_outlier_keeps_the_prediction_and_goes_on() {
    use blade_identification::{HybridEkf, Status};
    let f32s = |v: [f64; 6]| v.map(|v| v as f32);
    let mut filter = HybridEkf::new(
        &f32s(blade::X0),
        &diagonal(f32s(blade::P0)),
        &f32s(blade::Q),
        &[[blade::R as f32]],
    )
    .unwrap();
    // Generated with `gate = off`: open (to the divergence bound) until set.
    assert_eq!(
        filter.innovation_gate(),
        stateforge_math::f32::DIVERGENCE_NIS
    );
    assert_eq!(filter.set_innovation_gate(f32::INFINITY), Status::Ok);
    assert_eq!(
        filter.innovation_gate(),
        stateforge_math::f32::DIVERGENCE_NIS
    );
    assert_eq!(filter.set_innovation_gate(0.0), Status::RejectedInput);
    assert_eq!(filter.set_innovation_gate(10.83), Status::Ok);
    let u = |k: usize| [(k as f32 * 0.37).sin()];
    for k in 0..20 {
        let y = consistent_measurement!(filter, &u(k));
        assert_eq!(filter.step(&u(k), &[y]), Status::Ok, "sample {k}");
    }
    // The fault: a measurement of 1e30 (and a spike of 30 sigma of the innovation,
    // `S = P + R` at the prediction) is not used; the step keeps its prediction, and says
    // what the measurement was.
    let mut predicted = filter;
    assert_eq!(predicted.predict(&u(20)), Status::Ok);
    let spike = 30.0 * (predicted.covariance()[0][0] + blade::R as f32).sqrt();
    for outlier in [1e30_f32, spike] {
        let mut predicted = filter;
        assert_eq!(predicted.predict(&u(20)), Status::Ok);
        let y = predicted.state()[0] + outlier;
        assert_eq!(filter.step(&u(20), &[y]), Status::OutlierRejected);
        assert_eq!(filter.state(), predicted.state());
        assert_eq!(filter.covariance(), predicted.covariance());
        assert_eq!(filter.innovation(), [y - predicted.state()[0]]);
        assert!(filter.normalised_innovation_squared() > 10.83);
        filter = predicted;
    }
    for k in 21..40 {
        let y = consistent_measurement!(filter, &u(k));
        assert_eq!(filter.step(&u(k), &[y]), Status::Ok, "sample {k}");
        assert!(filter.normalised_innovation_squared() <= 10.83);
    }
    // `update` rejects the outlier and leaves the estimate as it was.
    let before = filter;
    assert_eq!(filter.update(&[1e30]), Status::OutlierRejected);
    assert_eq!(
        (filter.state(), filter.covariance()),
        (before.state(), before.covariance())
    );
}

#[test]
fn gated_continuous_ekf_rejects_an_outlier_keeps_the_prediction_and_goes_on() {
    use helicopter::in_f64::{ContinuousEkf, Status, TS};
    let x0 = [0.05, 0.0, -0.05, 0.0, 0.0, 0.0];
    let q = [0.0099, 0.0022, 0.0894, 0.0017, 1.2678, 1.27];
    let r = [[0.0007, 0.0], [0.0, 0.00193]];
    let mut filter = ContinuousEkf::new(&x0, &diagonal([1.0; 6]), &q, &r).unwrap();
    assert_eq!(filter.set_innovation_gate(13.82), Status::Ok);
    let u = [0.1, 0.1];
    let t = |k: usize| k as f64 * TS;
    let consistent = |filter: &ContinuousEkf, k: usize| {
        let mut predicted = *filter;
        assert_eq!(predicted.predict(t(k), &u), Status::Ok);
        let x = predicted.state();
        [x[0], x[2]]
    };
    for k in 0..50 {
        let y = consistent(&filter, k);
        assert_eq!(filter.step(t(k), &u, &y), Status::Ok, "sample {k}");
    }
    // 30 sigma of the pitch's innovation, `S = P + R / T` at the start of the sample,
    // where the continuous-time EKF takes it (the measurement noise over a sample is
    // `R / T`).
    let spike = 30.0 * (filter.covariance()[0][0] + r[0][0] / TS).sqrt();
    for outlier in [1e30, spike] {
        let mut predicted = filter;
        assert_eq!(predicted.predict(t(50), &u), Status::Ok);
        let [y_psi, y_phi] = consistent(&filter, 50);
        let y = [y_psi + outlier, y_phi];
        let start = filter.state();
        assert_eq!(filter.step(t(50), &u, &y), Status::OutlierRejected);
        assert_eq!(filter.state(), predicted.state());
        assert_eq!(filter.covariance(), predicted.covariance());
        assert_eq!(filter.innovation()[0], y[0] - start[0]);
        assert!(filter.normalised_innovation_squared() > 13.82);
        filter = predicted;
    }
    for k in 51..100 {
        let y = consistent(&filter, k);
        assert_eq!(filter.step(t(k), &u, &y), Status::Ok, "sample {k}");
    }
}

/// The case: a 5 rad outlier of the pitch, which the joint update rejects, must
/// not move the angle through the per-output update either. Each output's update is gated
/// on its own normalised innovation squared and stores its innovation.
#[test]
fn per_output_updates_are_gated_and_keep_their_innovation() {
    use helicopter::in_f64::{h, Ekf, Status};
    let p0 = diagonal([0.1; 6]);
    let q = diagonal([1e-6, 1e-4, 1e-6, 1e-4, 1e-5, 1e-5]);
    let r = diagonal([1e-4, 2e-4]);
    let mut filter = Ekf::new(&[0.1, 0.0, -0.2, 0.0, 0.0, 0.0], &p0, &q, &r).unwrap();
    assert_eq!(filter.set_innovation_gate(10.83), Status::Ok);
    let t = 0.0;
    assert_eq!(filter.predict(t, &[0.1, -0.2]), Status::Ok);
    let before = filter;
    let [psi, phi] = h(t, &filter.state());
    assert_eq!(filter.update(t, &[psi + 5.0, phi]), Status::OutlierRejected);
    assert_eq!(
        (filter.state(), filter.covariance()),
        (before.state(), before.covariance())
    );
    assert_eq!(filter.update_y_psi(t, psi + 5.0), Status::OutlierRejected);
    assert_eq!(
        (filter.state(), filter.covariance()),
        (before.state(), before.covariance())
    );
    assert_eq!(filter.innovation(), [5.0, 0.0]);
    let s = before.covariance()[0][0] + 1e-4;
    let nis = filter.normalised_innovation_squared();
    assert!(
        (nis - 25.0 / s).abs() <= 1e-12 * nis,
        "{nis} against {}",
        25.0 / s
    );
    // The other output's consistent measurement is used, and its innovation stored.
    assert_eq!(filter.update_y_phi(t, phi + 0.01), Status::Ok);
    assert_eq!(filter.innovation()[0], 0.0);
    assert!((filter.innovation()[1] - 0.01).abs() < 1e-12);
    assert!(filter.state()[2] > before.state()[2]);
}

/// Checks the cantilever's EKF and DKF refuse an indefinite, an asymmetric and a negative
/// `P0` in `new` and `reset`, and the EKF's setters negative noise, the filter unchanged.
fn assert_cantilever_filters_reject_bad_covariances() -> cantilever::in_f64::Ekf {
    use cantilever::in_f64::{Dkf, Ekf, Status};
    let mut indefinite = p0(2e4);
    indefinite[0][1] = 1.0; // A correlation of 1 / sqrt(1e-4 * 1) = 100.
    indefinite[1][0] = 1.0;
    let mut asymmetric = p0(2e4);
    asymmetric[2][3] = 1.0;
    let negative = diag([1e-4, 1.0, -2e4, 1.0, 1.0]);
    for bad in [indefinite, asymmetric, negative] {
        assert_eq!(
            Ekf::new(&X0_CLOSE, &bad, &Q_DIAG, &[[R]]),
            Err(Status::InvalidCovariance)
        );
        assert_eq!(
            Dkf::new(&X0_CLOSE, &p0(2e4), &Q_DIAG, &bad, &Q_DIAG, &[[R]]),
            Err(Status::InvalidCovariance)
        );
        let mut ekf = Ekf::new(&X0_CLOSE, &p0(2e4), &Q_DIAG, &[[R]]).unwrap();
        let before = ekf;
        assert_eq!(ekf.reset(&X0_CLOSE, &bad), Status::InvalidCovariance);
        assert_eq!(ekf, before);
    }
    let mut ekf = Ekf::new(&X0_CLOSE, &p0(2e4), &Q_DIAG, &[[R]]).unwrap();
    let before = ekf;
    assert_eq!(
        ekf.set_measurement_noise(&[[-R]]),
        Status::InvalidCovariance
    );
    assert_eq!(
        ekf.set_process_noise(&[0.0, 0.0, -1.0, 0.0, 0.0]),
        Status::InvalidCovariance
    );
    assert_eq!(ekf, before);
    ekf
}

/// Checks the cantilever's EKF accepts a semi-definite `P0`: the position known exactly,
/// two parameters perfectly correlated.
fn assert_a_semi_definite_covariance_is_accepted(mut ekf: cantilever::in_f64::Ekf) {
    use cantilever::in_f64::Status;
    let mut known = p0(2e4);
    known[0][0] = 0.0;
    (known[2][2], known[3][3], known[2][3], known[3][2]) = (4.0, 9.0, 6.0, 6.0);
    assert_eq!(ekf.reset(&X0_CLOSE, &known), Status::Ok);
}

/// Checks the blade's hybrid EKF refuses an indefinite `P0` in `reset` and a negative `Q`
/// in its setter, the filter unchanged.
fn assert_hybrid_ekf_rejects_bad_covariances() {
    use blade_identification::in_f64::{HybridEkf, Status};
    let blade_filter =
        || HybridEkf::new(&blade::X0, &diagonal(blade::P0), &blade::Q, &[[blade::R]]);
    let mut hybrid = blade_filter().unwrap();
    let before = hybrid;
    let mut p = diagonal(blade::P0);
    p[2][3] = 1e3; // 1e3 against sqrt(1e4 * 1e-2) = 10.
    p[3][2] = 1e3;
    assert_eq!(hybrid.reset(&blade::X0, &p), Status::InvalidCovariance);
    assert_eq!(
        hybrid.set_process_noise(&[0.0, -1e-2, 1e3, 1e-3, 1e-9, 1.0]),
        Status::InvalidCovariance
    );
    assert_eq!(hybrid, before);
}

/// Checks the helicopter's continuous EKF refuses an indefinite `P0` and an indefinite `R`.
fn assert_continuous_ekf_rejects_bad_covariances() {
    use helicopter::in_f64::{ContinuousEkf, Status};
    let r = [[0.0007, 0.0], [0.0, 0.00193]];
    let q = [0.0099, 0.0022, 0.0894, 0.0017, 1.2678, 1.27];
    let x0 = [0.0; 6];
    let mut p = diagonal([1.0; 6]);
    p[4][5] = 1.5;
    p[5][4] = 1.5;
    assert_eq!(
        ContinuousEkf::new(&x0, &p, &q, &r),
        Err(Status::InvalidCovariance)
    );
    assert_eq!(
        ContinuousEkf::new(&x0, &diagonal([1.0; 6]), &q, &[[1e-3, 1e-3], [1e-3, 1e-4]]),
        Err(Status::InvalidCovariance)
    );
}

/// Checks the polynomial KF refuses an indefinite `P0`.
fn assert_polynomial_kf_rejects_a_bad_covariance() {
    use polynomial::in_f64::{PolynomialKf, Status};
    let mut p = diagonal([1.0; 4]);
    p[0][3] = -1.01;
    p[3][0] = -1.01;
    assert_eq!(
        PolynomialKf::new(&[0.0; 4], &p),
        Err(Status::InvalidCovariance)
    );
}

/// Of each kind of covariance argument that is not one, rejected by every filter's
/// constructor, `reset` and setters with `InvalidCovariance`, the filter unchanged; a
/// semi-definite one (a state known exactly, perfectly correlated entries) accepted.
#[test]
fn covariances_that_are_not_covariances_are_rejected_where_they_enter() {
    let ekf = assert_cantilever_filters_reject_bad_covariances();
    assert_a_semi_definite_covariance_is_accepted(ekf);
    assert_hybrid_ekf_rejects_bad_covariances();
    assert_continuous_ekf_rejects_bad_covariances();
    assert_polynomial_kf_rejects_a_bad_covariance();
}

/// The AHRS's prior: an attitude 1.2 rad from the reference, as a quaternion `[x, y, z, w]`,
/// and a gyro bias [rad/s].
fn ahrs_x0() -> [f64; 7] {
    let attitude =
        nalgebra::UnitQuaternion::from_scaled_axis(nalgebra::Vector3::new(0.3, -0.2, 1.1));
    let [qx, qy, qz, qw] = attitude.coords.into();
    [qx, qy, qz, qw, 0.01, -0.02, 0.015]
}

/// The AHRS's covariances, over the tangent space (the rotation's 3, the bias's 3): the
/// prior's variances (0.1 rad, 0.01 rad/s), the process noise variances, the accelerometer's
/// (0.1 m/s^2) and magnetometer's (5 mgauss) noise variances.
const AHRS_P0: [f64; 6] = [1e-2, 1e-2, 1e-2, 1e-4, 1e-4, 1e-4];
const AHRS_Q: [f64; 6] = [2.5e-9, 2.5e-9, 2.5e-9, 1e-10, 1e-10, 1e-10];
const AHRS_R: [f64; 6] = [1e-2, 1e-2, 1e-2, 2.5e-5, 2.5e-5, 2.5e-5];

/// The AHRS's `(x0, p0, q, r)` in the scalar `$s`.
macro_rules! ahrs_setup {
    ($s:ty) => {
        (
            ahrs_x0().map(|v| v as $s),
            diagonal(AHRS_P0.map(|v| v as $s)),
            AHRS_Q.map(|v| v as $s),
            diagonal(AHRS_R.map(|v| v as $s)),
        )
    };
}

/// Checks the AHRS's error-state EKF of the module `$m` (scalar `$s`) rejects a non-finite
/// entry of every argument with `RejectedInput`, in `new` and in every call, the filter
/// unchanged.
macro_rules! assert_ahrs_rejects_non_finite_entries {
    ($s:ty, $($m:ident)::+) => {{
        use $($m)::+::{h, Ekf, Status};
        let (x0, p0, q, r) = ahrs_setup!($s);
        let (nan, inf) = (<$s>::NAN, <$s>::INFINITY);
        for i in [0, 3, 5] {
            let mut x = x0;
            x[i] = nan;
            assert_eq!(Ekf::new(&x, &p0, &q, &r), Err(Status::RejectedInput), "x0[{i}]");
        }
        let (mut p_inf, mut q_nan, mut r_inf) = (p0, q, r);
        p_inf[1][4] = inf;
        q_nan[3] = nan;
        r_inf[2][5] = -inf;
        assert_eq!(Ekf::new(&x0, &p_inf, &q, &r), Err(Status::RejectedInput));
        assert_eq!(Ekf::new(&x0, &p0, &q_nan, &r), Err(Status::RejectedInput));
        assert_eq!(Ekf::new(&x0, &p0, &q, &r_inf), Err(Status::RejectedInput));
        let mut ekf = Ekf::new(&x0, &p0, &q, &r).unwrap();
        let u = [0.1, -0.2, 0.3];
        assert_eq!(ekf.predict(&u), Status::Ok);
        let y = h(&ekf.state());
        assert_eq!(ekf.update(&y), Status::Ok);
        let before = ekf;
        let [a0, a1, _, _, m1, m2] = y;
        let mut y_inf = y;
        y_inf[4] = inf;
        let mut x_nan = x0;
        x_nan[6] = nan;
        let rejected = [
            ("predict", ekf.predict(&[0.1, nan, 0.3])),
            ("step, input", ekf.step(&[inf, -0.2, 0.3], &y)),
            ("step, measurement", ekf.step(&u, &y_inf)),
            ("update", ekf.update(&y_inf)),
            ("update_accel", ekf.update_accel(&[a0, a1, nan])),
            ("update_mag", ekf.update_mag(&[-inf, m1, m2])),
            ("reset, x0", ekf.reset(&x_nan, &p0)),
            ("reset, p0", ekf.reset(&x0, &p_inf)),
            ("set_process_noise", ekf.set_process_noise(&q_nan)),
            ("set_measurement_noise", ekf.set_measurement_noise(&r_inf)),
        ];
        for (call, status) in rejected {
            assert_eq!(status, Status::RejectedInput, "{call}");
        }
        assert_eq!(ekf, before);
    }};
}

#[test]
fn the_error_state_ekf_rejects_non_finite_entries_where_they_enter() {
    assert_ahrs_rejects_non_finite_entries!(f32, ahrs);
    assert_ahrs_rejects_non_finite_entries!(f64, ahrs::in_f64);
}

/// Checks `new` and `reset` of the module `$m` (scalar `$s`) refuse, with `RejectedInput`
/// and the filter unchanged, quaternions whose norm cannot be divided by: zero, subnormal,
/// or whose squares overflow; and one of norm 1.5 (`tests/error_state_ekf.rs` checks the
/// 1 % bound in `new` of both scalars and in `reset` of `f64`).
macro_rules! assert_ahrs_refuses_non_rotations {
    ($s:ty, $($m:ident)::+) => {{
        use $($m)::+::{Ekf, Status};
        let (x0, p0, q, r) = ahrs_setup!($s);
        let mut ekf = Ekf::new(&x0, &p0, &q, &r).unwrap();
        assert_eq!(ekf.predict(&[0.1, -0.2, 0.3]), Status::Ok);
        let before = ekf;
        let scaled = x0.map(|v| 1.5 * v);
        let quaternions = [
            [0.0; 4],
            [<$s>::MIN_POSITIVE; 4],
            [<$s>::MAX / 2.0; 4],
            [scaled[0], scaled[1], scaled[2], scaled[3]],
        ];
        for quaternion in quaternions {
            let mut x = x0;
            x[..4].copy_from_slice(&quaternion);
            assert_eq!(Ekf::new(&x, &p0, &q, &r), Err(Status::RejectedInput), "{x:?}");
            assert_eq!(ekf.reset(&x, &p0), Status::RejectedInput, "{x:?}");
            assert_eq!(ekf, before, "{x:?}");
        }
    }};
}

#[test]
fn the_error_state_ekf_refuses_a_quaternion_it_cannot_normalise() {
    assert_ahrs_refuses_non_rotations!(f32, ahrs);
    assert_ahrs_refuses_non_rotations!(f64, ahrs::in_f64);
}

/// Checks `new` and `reset` of the module `$m` (scalar `$s`) refuse a `p0` over the
/// tangent space that is not a covariance (indefinite: the attitude's x and the bias's x
/// correlated by 2; asymmetric; a negative variance), and `new` a `q` and an `r` that are
/// not, with `InvalidCovariance`, the filter unchanged; `reset` accepts a semi-definite one
/// (the bias known exactly, two attitude errors perfectly correlated).
macro_rules! assert_ahrs_rejects_bad_covariances {
    ($s:ty, $($m:ident)::+) => {{
        use $($m)::+::{Ekf, Status};
        let (x0, p0, q, r) = ahrs_setup!($s);
        let mut indefinite = p0;
        (indefinite[0][3], indefinite[3][0]) = (2e-3, 2e-3);
        let mut asymmetric = p0;
        asymmetric[1][2] = 1e-3;
        let mut negative = p0;
        negative[5][5] = -1e-4;
        let mut ekf = Ekf::new(&x0, &p0, &q, &r).unwrap();
        assert_eq!(ekf.predict(&[0.1, -0.2, 0.3]), Status::Ok);
        let before = ekf;
        for bad in [indefinite, asymmetric, negative] {
            assert_eq!(Ekf::new(&x0, &bad, &q, &r), Err(Status::InvalidCovariance), "{bad:?}");
            assert_eq!(ekf.reset(&x0, &bad), Status::InvalidCovariance, "{bad:?}");
            assert_eq!(ekf, before);
        }
        let mut q_negative = q;
        q_negative[2] = -1e-9;
        let mut r_indefinite = r;
        (r_indefinite[2][3], r_indefinite[3][2]) = (1e-3, 1e-3);
        assert_eq!(Ekf::new(&x0, &p0, &q_negative, &r), Err(Status::InvalidCovariance));
        assert_eq!(Ekf::new(&x0, &p0, &q, &r_indefinite), Err(Status::InvalidCovariance));
        let mut semi_definite = diagonal([1e-2, 1e-2, 1e-2, 0.0, 0.0, 0.0]);
        (semi_definite[0][1], semi_definite[1][0]) = (1e-2, 1e-2);
        assert_eq!(ekf.reset(&x0, &semi_definite), Status::Ok);
        assert_eq!(ekf.covariance(), semi_definite);
    }};
}

#[test]
fn the_error_state_ekf_rejects_covariances_that_are_not_covariances() {
    assert_ahrs_rejects_bad_covariances!(f32, ahrs);
    assert_ahrs_rejects_bad_covariances!(f64, ahrs::in_f64);
}

/// The measurement of a sensor of the gated AHRS, `$y` (the sensor's prediction moved
/// along its first axis), moved so that the sensor's normalised innovation squared is
/// `$nis`: a probe's, scaled (it grows with the square of the move).
macro_rules! with_nis {
    ($ekf:expr, $update:ident, $normalised:ident, $y:expr, $nis:expr) => {{
        let mut probe = $ekf;
        let mut y = $y;
        y[0] += 1.0;
        let _ = probe.$update(&y);
        let scale = ($nis / probe.$normalised()).sqrt();
        y[0] += scale - 1.0;
        (y, scale)
    }};
}

/// Checks the gates of the gated AHRS's error-state EKF (module `$m`, scalar `$s`): each
/// sensor has its own, generated at the filter's and set alone (`RejectedInput` unless
/// positive, infinity the divergence bound); an accelerometer measurement of normalised
/// innovation squared 19 (between the chi-square 99.9 % quantiles of 3 and of 6 outputs,
/// 16.27 and 22.46) is refused under the sensor's gate at 16.27, the estimate and the
/// other innovations kept and the refusal counted, and used under its gate at 22.46; the
/// magnetometer's gate and the joint update's reject their own outliers of 30 standard
/// deviations, the estimate kept.
macro_rules! assert_ahrs_gates_are_per_sensor {
    ($s:ident, $($m:ident)::+) => {{
        use $($m)::+::{h, GatedEkf, Status};
        let (x0, p0, q, r) = ahrs_setup!($s);
        let mut ekf = GatedEkf::new(&x0, &p0, &q, &r).unwrap();
        let gates = |f: &GatedEkf| {
            (f.innovation_gate(), f.accel_innovation_gate(), f.mag_innovation_gate())
        };
        let (gate, tight) = (22.46 as $s, 16.27 as $s);
        assert_eq!(gates(&ekf), (gate, gate, gate));
        for bad in [0.0, -1.0, <$s>::NAN] {
            assert_eq!(ekf.set_accel_innovation_gate(bad), Status::RejectedInput, "{bad}");
        }
        assert_eq!(ekf.set_accel_innovation_gate(<$s>::INFINITY), Status::Ok);
        assert_eq!(ekf.accel_innovation_gate(), stateforge_math::$s::DIVERGENCE_NIS);
        assert_eq!(ekf.set_accel_innovation_gate(tight), Status::Ok);
        assert_eq!(gates(&ekf), (gate, tight, gate));
        let u = [0.1, -0.2, 0.3];
        for k in 0..20 {
            assert_eq!(ekf.predict(&u), Status::Ok);
            let [a0, a1, a2, m0, m1, m2] = h(&ekf.state());
            assert_eq!(ekf.update_mag(&[m0, m1, m2]), Status::Ok, "sample {k}");
            assert_eq!(ekf.update_accel(&[a0, a1, a2]), Status::Ok, "sample {k}");
        }
        assert_eq!(ekf.predict(&u), Status::Ok);
        let before = ekf;
        let [a0, a1, a2, m0, m1, m2] = h(&ekf.state());
        let (y, moved) = with_nis!(
            ekf,
            update_accel,
            accel_normalised_innovation_squared,
            [a0, a1, a2],
            19.0
        );
        assert_eq!(ekf.update_accel(&y), Status::OutlierRejected);
        assert_eq!((ekf.state(), ekf.covariance()), (before.state(), before.covariance()));
        let nis = ekf.accel_normalised_innovation_squared();
        assert!((nis - 19.0).abs() < 1e-3, "{nis}");
        let innovation = ekf.accel_innovation();
        assert!((innovation[0] - moved).abs() < 1e-4 * moved, "{innovation:?}");
        assert!(innovation[1].abs() < 1e-4 * moved && innovation[2].abs() < 1e-4 * moved);
        let others = |f: &GatedEkf| (f.innovation(), f.mag_innovation());
        assert_eq!(others(&ekf), others(&before));
        assert_eq!(
            (ekf.accel_refusals(), ekf.mag_refusals(), ekf.refusals()),
            (1, 0, 0)
        );
        assert_eq!(ekf.set_accel_innovation_gate(gate), Status::Ok);
        assert_eq!(ekf.update_accel(&y), Status::Ok);
        assert_ne!(ekf.state(), before.state());
        assert_eq!(ekf.accel_refusals(), 0);
        let mut rejected = before;
        let sigma = |i: usize| (30.0 as $s) * r[i][i].sqrt();
        assert_eq!(rejected.update_mag(&[m0 + sigma(3), m1, m2]), Status::OutlierRejected);
        let joint = [a0 + sigma(0), a1 + sigma(1), a2, m0, m1, m2 + sigma(5)];
        assert_eq!(rejected.update(&joint), Status::OutlierRejected);
        let estimate = |f: &GatedEkf| (f.state(), f.covariance());
        assert_eq!(estimate(&rejected), estimate(&before));
        let refusals = |f: &GatedEkf| (f.accel_refusals(), f.mag_refusals(), f.refusals());
        assert_eq!(refusals(&rejected), (0, 1, 1));
    }};
}

#[test]
fn the_error_state_ekf_gates_each_sensor_on_its_own() {
    assert_ahrs_gates_are_per_sensor!(f32, ahrs);
    assert_ahrs_gates_are_per_sensor!(f64, ahrs::in_f64);
}
