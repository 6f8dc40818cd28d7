//! Run-time tuning of every generated filter: `Q` and `R` set after construction act as if
//! given to `new`, and a non-finite entry (or a negative `alpha`) is rejected, leaving the
//! filter exactly as it was. The error-state EKF (the AHRS test model, `tests/models/ahrs.rs`)
//! too, its `Q` over the tangent space.

use generated_demo::{cantilever, helicopter, mass_spring_damper};
use tests::tuning::{diag, p0, Q_DIAG, R, X0_CLOSE};

include!("../models/ahrs.rs");

#[test]
fn ekf_and_dkf_noise_setters() {
    use cantilever::in_f64::{Dkf, Ekf, Status};
    let q2 = [0.0, 0.0, 50.0, 100.0, 1e-4];
    let mut ekf = Ekf::new(&X0_CLOSE, &p0(2e4), &Q_DIAG, &[[R]]).unwrap();
    let before = ekf;
    assert_eq!(
        ekf.set_process_noise(&[0.0, f64::NAN, 0.0, 0.0, 0.0]),
        Status::RejectedInput
    );
    assert_eq!(
        ekf.set_measurement_noise(&[[f64::INFINITY]]),
        Status::RejectedInput
    );
    assert_eq!(ekf, before);
    assert_eq!(ekf.set_process_noise(&q2), Status::Ok);
    assert_eq!(ekf.set_measurement_noise(&[[2.0 * R]]), Status::Ok);
    assert_eq!(
        ekf,
        Ekf::new(&X0_CLOSE, &p0(2e4), &q2, &[[2.0 * R]]).unwrap()
    );

    let mut dkf = Dkf::new(&X0_CLOSE, &p0(2e4), &Q_DIAG, &p0(2e4), &Q_DIAG, &[[R]]).unwrap();
    let before = dkf;
    assert_eq!(
        dkf.set_akf_process_noise(&[f64::NAN; 5]),
        Status::RejectedInput
    );
    assert_eq!(dkf, before);
    assert_eq!(dkf.set_process_noise(&q2), Status::Ok);
    assert_eq!(dkf.set_akf_process_noise(&Q_DIAG), Status::Ok);
    assert_eq!(dkf.set_measurement_noise(&[[2.0 * R]]), Status::Ok);
    assert_eq!(
        dkf,
        Dkf::new(&X0_CLOSE, &p0(2e4), &q2, &p0(2e4), &Q_DIAG, &[[2.0 * R]]).unwrap()
    );
}

#[test]
fn hybrid_ekf_noise_setters() {
    use mass_spring_damper::in_f64::{HybridEkf, Status};
    let x0 = [0.0, 0.0, 0.0, 0.0, 2.0];
    let p = [1e-5, 1.0, 1e-4, 1e-6, 1e-6];
    // The process noise enters eta2 and inv_m (`process_noise_on`).
    let q = [3e4, 1e4];
    let mut filter = HybridEkf::new(&x0, &diag(p), &q, &[[1e-6]]).unwrap();
    let before = filter;
    assert_eq!(
        filter.set_measurement_noise(&[[f64::NAN]]),
        Status::RejectedInput
    );
    assert_eq!(filter, before);
    assert_eq!(filter.set_process_noise(&[1.0; 2]), Status::Ok);
    assert_eq!(filter.set_measurement_noise(&[[1e-4]]), Status::Ok);
    let mut fresh = HybridEkf::new(&x0, &diag(p), &[1.0; 2], &[[1e-4]]).unwrap();
    assert_eq!(filter.step(&[10.0], &[1e-3]), Status::Ok);
    assert_eq!(fresh.step(&[10.0], &[1e-3]), Status::Ok);
    assert_eq!(filter, fresh);
}

#[test]
fn continuous_ekf_noise_and_alpha_setters() {
    use helicopter::in_f64::{ContinuousEkf, Status};
    let x0 = [0.05, 0.0, -0.05, 0.0, 0.0, 0.0];
    let p: [[f64; 6]; 6] =
        std::array::from_fn(|i| std::array::from_fn(|j| if i == j { 1.0 } else { 0.0 }));
    let q = [0.0099, 0.0022, 0.0894, 0.0017, 1.2678, 1.27];
    let r = [[0.0007, 0.0], [0.0, 0.00193]];
    let mut filter = ContinuousEkf::new(&x0, &p, &q, &r).unwrap();
    assert_eq!(filter.alpha(), ContinuousEkf::ALPHA);
    let before = filter;
    assert_eq!(filter.set_alpha(-0.1), Status::RejectedInput);
    assert_eq!(filter.set_alpha(f64::NAN), Status::RejectedInput);
    assert_eq!(
        filter.set_process_noise(&[f64::NEG_INFINITY; 6]),
        Status::RejectedInput
    );
    assert_eq!(filter, before);
    // A negative variance, or a correlation beyond 1, is not a covariance: rejected where it
    // enters, the filter unchanged.
    assert_eq!(
        filter.set_measurement_noise(&[[-1.0, 0.0], [0.0, 1.0]]),
        Status::InvalidCovariance
    );
    assert_eq!(
        filter.set_measurement_noise(&[[1e-3, 2e-3], [2e-3, 1e-3]]),
        Status::InvalidCovariance
    );
    assert_eq!(
        filter.set_process_noise(&[0.1, -1e-9, 0.1, 0.1, 0.1, 0.1]),
        Status::InvalidCovariance
    );
    assert_eq!(filter, before);
    assert_eq!(filter.set_measurement_noise(&r), Status::Ok);
    assert_eq!(filter, before);
    // The step's update divides by `H P H' + R / T`, never by `R`: a perfect sensor (a zero
    // variance) is a covariance, and is used.
    let mut perfect = filter;
    assert_eq!(
        perfect.set_measurement_noise(&[[0.0, 0.0], [0.0, 1.0]]),
        Status::Ok
    );
    assert_eq!(perfect.step(0.0, &[0.0; 2], &[0.01, 0.0]), Status::Ok);
    // The perfect sensor's angle is the measurement, to rounding.
    assert!((perfect.state()[0] - 0.01).abs() < 1e-15);
    assert_eq!(filter.set_alpha(0.0), Status::Ok);
    assert_eq!(filter.step(0.0, &[0.1; 2], &[0.01, 0.0]), Status::Ok);
    assert_eq!(
        filter.step(0.001, &[f64::NAN, 0.1], &[0.01, 0.0]),
        Status::RejectedInput
    );
}

/// A square matrix with `d` on its diagonal, of the filter's scalar.
fn diagonal<const N: usize, T: Copy + Default>(d: [T; N]) -> [[T; N]; N] {
    std::array::from_fn(|i| std::array::from_fn(|j| if i == j { d[i] } else { T::default() }))
}

/// Checks the noise setters of the AHRS's error-state EKF (module `$m`, scalar `$s`): a
/// non-finite entry is `RejectedInput`, a negative variance of `Q` (over the tangent
/// space) or an indefinite `R` `InvalidCovariance`, the filter unchanged; the noises set
/// act as if given to `new`, through a predict and an update.
macro_rules! assert_ahrs_noise_setters {
    ($s:ty, $($m:ident)::+) => {{
        use $($m)::+::{h, Ekf, Status};
        // An attitude of 0.5 rad about z, a gyro bias [rad/s].
        let (sin, cos) = (0.25_f64.sin(), 0.25_f64.cos());
        let x0 = [0.0, 0.0, sin, cos, 0.01, -0.02, 0.015].map(|v| v as $s);
        let p0 = diagonal([1e-2, 1e-2, 1e-2, 1e-4, 1e-4, 1e-4].map(|v| v as $s));
        let q = [2.5e-9, 2.5e-9, 2.5e-9, 1e-10, 1e-10, 1e-10].map(|v| v as $s);
        let r = diagonal([1e-2, 1e-2, 1e-2, 2.5e-5, 2.5e-5, 2.5e-5].map(|v| v as $s));
        let mut ekf = Ekf::new(&x0, &p0, &q, &r).unwrap();
        let before = ekf;
        let (mut q_bad, mut r_bad) = (q, r);
        q_bad[4] = <$s>::NAN;
        r_bad[0][5] = <$s>::INFINITY;
        assert_eq!(ekf.set_process_noise(&q_bad), Status::RejectedInput);
        assert_eq!(ekf.set_measurement_noise(&r_bad), Status::RejectedInput);
        q_bad[4] = -1e-10;
        r_bad[0][5] = 0.0;
        (r_bad[1][4], r_bad[4][1]) = (1e-2, 1e-2);
        assert_eq!(ekf.set_process_noise(&q_bad), Status::InvalidCovariance);
        assert_eq!(ekf.set_measurement_noise(&r_bad), Status::InvalidCovariance);
        assert_eq!(ekf, before);
        let q2 = q.map(|v| 4.0 * v);
        let r2 = diagonal([4e-2, 4e-2, 4e-2, 1e-4, 1e-4, 1e-4].map(|v| v as $s));
        assert_eq!(ekf.set_process_noise(&q2), Status::Ok);
        assert_eq!(ekf.set_measurement_noise(&r2), Status::Ok);
        let mut fresh = Ekf::new(&x0, &p0, &q2, &r2).unwrap();
        assert_eq!(ekf, fresh);
        let u = [0.1, -0.2, 0.3];
        let y = h(&x0).map(|v| v + 0.01);
        for filter in [&mut ekf, &mut fresh] {
            assert_eq!(filter.step(&u, &y), Status::Ok);
        }
        assert_eq!(ekf, fresh);
    }};
}

#[test]
fn error_state_ekf_noise_setters() {
    assert_ahrs_noise_setters!(f32, ahrs);
    assert_ahrs_noise_setters!(f64, ahrs::in_f64);
}
