//! Updates per sensor on the 24-state navigation model (`generated-demo/models/navigation.rs`):
//! a sensor's update equals a dense nalgebra Kalman update with its rows of `H` and its
//! block of `R`, stores its own innovation and normalised innovation squared and leaves
//! the filter's untouched; updating with each sensor in turn equals the joint update when
//! the sensors' noise is uncorrelated; each sensor has a gate of its own; and bad samples
//! (non-finite IMU, GNSS or magnetometer values, a singular innovation covariance) return a
//! status with the filter unchanged.

use generated_demo::navigation::in_f64::{f, h, jacobian_h_wrt_x, Ekf, Status};
use nalgebra::{DMatrix, DVector};
use tests::compare::largest_relative_difference;
use tests::rng::Lcg;

const N: usize = 24;
const M: usize = 9;
/// The GNSS receiver's outputs, then the magnetometer's, as the model orders them.
const GNSS: [usize; 6] = [0, 1, 2, 3, 4, 5];
const MAGNETOMETER: [usize; 3] = [6, 7, 8];

/// Level, heading 30 degrees, at rest, with a typical mid-latitude earth field.
fn initial_state() -> [f64; N] {
    let half = 15.0_f64.to_radians();
    let mut x = [0.0; N];
    x[0] = half.cos();
    x[3] = half.sin();
    x[16] = 0.2;
    x[17] = 0.02;
    x[18] = 0.45;
    x
}

fn diagonal<const K: usize>(d: [f64; K]) -> [[f64; K]; K] {
    std::array::from_fn(|i| std::array::from_fn(|j| if i == j { d[i] } else { 0.0 }))
}

/// Standard deviations of the initial estimate, by state.
fn initial_sigma() -> [f64; N] {
    let mut s = [0.0; N];
    s[..4].fill(0.05);
    s[4..7].fill(0.5);
    s[7..10].fill(2.0);
    s[10..13].fill(1e-4);
    s[13..16].fill(1e-3);
    s[16..19].fill(0.02);
    s[19..22].fill(0.02);
    s[22..24].fill(1.0);
    s
}

fn measurement_variances() -> [f64; M] {
    [0.09, 0.09, 0.16, 0.25, 0.25, 0.49, 2.5e-5, 2.5e-5, 2.5e-5]
}

fn filter(r: &[[f64; M]; M]) -> Ekf {
    let p0 = diagonal(initial_sigma().map(|s| s * s));
    let mut q = [0.0; N];
    q[..4].fill(1e-9);
    q[4..7].fill(1e-6);
    q[10..16].fill(1e-12);
    q[16..22].fill(1e-10);
    q[22..24].fill(1e-6);
    Ekf::new(&initial_state(), &p0, &q, r).unwrap()
}

/// An IMU sample of a slow turn with a little climb: delta angle and delta velocity over
/// the model's 4 ms, with gravity's reaction on the accelerometer.
fn imu(k: usize) -> [f64; 6] {
    let t = k as f64 * 0.004;
    let (rate, dt) = (0.2 * (0.5 * t).sin(), 0.004);
    [0.001 * dt, -0.002 * dt, rate * dt, 0.1 * dt, 0.0, -9.7 * dt]
}

/// The filter after a second of prediction, so that its covariance couples the states.
fn predicted_filter(r: &[[f64; M]; M]) -> Ekf {
    let mut ekf = filter(r);
    for k in 0..250 {
        assert_eq!(ekf.predict(&imu(k)), Status::Ok);
    }
    ekf
}

/// The Joseph-form Kalman update with `rows` of the measurement, dense, in nalgebra.
fn dense_update(ekf: &Ekf, r: &[[f64; M]; M], rows: &[usize], y: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let (x, p) = (ekf.state(), ekf.covariance());
    let (k, hx, jac) = (rows.len(), h(&x), jacobian_h_wrt_x(&x));
    let pm = DMatrix::from_fn(N, N, |i, j| p[i][j]);
    let c = DMatrix::from_fn(k, N, |a, j| jac[rows[a]][j]);
    let rm = DMatrix::from_fn(k, k, |a, b| r[rows[a]][rows[b]]);
    let residual = DVector::from_fn(k, |a, _| y[a] - hx[rows[a]]);
    let s = &c * &pm * c.transpose() + &rm;
    let gain = &pm * c.transpose() * s.try_inverse().unwrap();
    let x_new = DVector::from_row_slice(&x) + &gain * residual;
    let i_kc = DMatrix::identity(N, N) - &gain * &c;
    let p_new = &i_kc * &pm * i_kc.transpose() + &gain * rm * gain.transpose();
    let p_rows: Vec<f64> = (0..N)
        .flat_map(|i| (0..N).map(move |j| (i, j)))
        .map(|(i, j)| p_new[(i, j)])
        .collect();
    (x_new.as_slice().to_vec(), p_rows)
}

#[test]
fn a_sensor_update_equals_a_dense_kalman_update() {
    let r = diagonal(measurement_variances());
    for (rows, name) in [(&GNSS[..], "gnss"), (&MAGNETOMETER[..], "magnetometer")] {
        let mut ekf = predicted_filter(&r);
        let hx = h(&ekf.state());
        let y: Vec<f64> = rows
            .iter()
            .enumerate()
            .map(|(a, &i)| hx[i] + 0.3 * (a as f64 - 1.0) * r[i][i].sqrt())
            .collect();
        let (x_want, p_want) = dense_update(&ekf, &r, rows, &y);
        let status = match name {
            "gnss" => ekf.update_gnss(&y.clone().try_into().unwrap()),
            _ => ekf.update_magnetometer(&y.clone().try_into().unwrap()),
        };
        assert_eq!(status, Status::Ok);
        let x_error = largest_relative_difference(&ekf.state(), &x_want);
        let p_error = largest_relative_difference(&ekf.covariance().concat(), &p_want);
        eprintln!("{name}: state {x_error:e}, covariance {p_error:e} relative");
        assert!(
            x_error < 1e-13 && p_error < 1e-12,
            "{name}: {x_error:e} {p_error:e}"
        );
    }
}

#[test]
fn a_sensor_stores_its_own_innovation_and_nis() {
    let r = diagonal(measurement_variances());
    let mut ekf = predicted_filter(&r);
    let (x, p) = (ekf.state(), ekf.covariance());
    let hx = h(&x);
    let y = [hx[6] + 0.01, hx[7] - 0.004, hx[8] + 0.002];
    assert_eq!(ekf.update_magnetometer(&y), Status::Ok);
    let residual: Vec<f64> = (0..3).map(|a| y[a] - hx[6 + a]).collect();
    assert!(largest_relative_difference(&ekf.magnetometer_innovation(), &residual) < 1e-12);
    let jac = jacobian_h_wrt_x(&x);
    let c = DMatrix::from_fn(3, N, |a, j| jac[6 + a][j]);
    let pm = DMatrix::from_fn(N, N, |i, j| p[i][j]);
    let s = &c * pm * c.transpose() + DMatrix::from_fn(3, 3, |a, b| r[6 + a][6 + b]);
    let rv = DVector::from_vec(residual);
    let nis = (rv.transpose() * s.try_inverse().unwrap() * &rv)[(0, 0)];
    let got = ekf.magnetometer_normalised_innovation_squared();
    assert!((got - nis).abs() <= 1e-10 * nis, "{got} against {nis}");
    // The other sensor's and the filter's stored innovations are untouched.
    assert_eq!(ekf.gnss_innovation(), [0.0; 6]);
    assert_eq!(ekf.gnss_normalised_innovation_squared(), 0.0);
    assert_eq!(ekf.innovation(), [0.0; M]);
    // `reset` clears the sensors' innovations too.
    let p0 = diagonal(initial_sigma().map(|s| s * s));
    assert_eq!(ekf.reset(&initial_state(), &p0), Status::Ok);
    assert_eq!(ekf.magnetometer_innovation(), [0.0; 3]);
    assert_eq!(ekf.magnetometer_normalised_innovation_squared(), 0.0);
}

/// The joint update linearises `h` once, at the prediction. The GNSS outputs are linear in
/// the state, so updating with the magnetometer first (at the prediction too), then the
/// GNSS, is the same update; the other order would linearise the magnetometer at the
/// GNSS-corrected estimate, a different (iterated-like) filter.
#[test]
fn sensor_updates_in_turn_equal_the_joint_update() {
    let r = diagonal(measurement_variances());
    let (mut joint, mut in_turn) = (filter(&r), filter(&r));
    let mut truth = initial_state();
    let mut rng = Lcg(7);
    let mut worst: f64 = 0.0;
    for k in 0..500 {
        let u = imu(k);
        truth = f(&truth, &u);
        for ekf in [&mut joint, &mut in_turn] {
            assert_eq!(ekf.predict(&u), Status::Ok);
        }
        if k % 50 != 49 {
            continue;
        }
        let y: [f64; M] = std::array::from_fn(|i| h(&truth)[i] + r[i][i].sqrt() * rng.uniform());
        assert_eq!(joint.update(&y), Status::Ok);
        let magnetometer = y[6..].try_into().unwrap();
        assert_eq!(in_turn.update_magnetometer(&magnetometer), Status::Ok);
        assert_eq!(in_turn.update_gnss(&y[..6].try_into().unwrap()), Status::Ok);
        worst = worst
            .max(largest_relative_difference(
                &in_turn.state(),
                &joint.state(),
            ))
            .max(largest_relative_difference(
                &in_turn.covariance().concat(),
                &joint.covariance().concat(),
            ));
    }
    eprintln!("sensors in turn against the joint update: {worst:e} relative");
    assert!(worst < 1e-12, "{worst:e}");
}

#[test]
fn each_sensor_has_a_gate_of_its_own() {
    let r = diagonal(measurement_variances());
    let mut ekf = predicted_filter(&r);
    // Generated from the filter's `gate = 22.46`, then set apart.
    assert_eq!(ekf.gnss_innovation_gate(), 22.46);
    assert_eq!(ekf.set_magnetometer_innovation_gate(16.27), Status::Ok);
    assert_eq!(ekf.magnetometer_innovation_gate(), 16.27);
    assert_eq!(ekf.gnss_innovation_gate(), 22.46);
    assert_eq!(ekf.innovation_gate(), 22.46);
    assert_eq!(ekf.set_gnss_innovation_gate(-1.0), Status::RejectedInput);
    // A magnetometer sample 0.4 gauss off on one axis (the field is 0.5 gauss, the
    // innovation's standard deviation about 0.03): rejected, recorded, the estimate
    // unchanged.
    let before = ekf;
    let hx = h(&ekf.state());
    let y = [hx[6] + 0.4, hx[7], hx[8]];
    assert_eq!(ekf.update_magnetometer(&y), Status::OutlierRejected);
    assert_eq!(ekf.state(), before.state());
    assert_eq!(ekf.covariance(), before.covariance());
    assert!(ekf.magnetometer_normalised_innovation_squared() > 16.27);
    // The GNSS, judged by its own gate, is used.
    let y: [f64; 6] = std::array::from_fn(|i| h(&ekf.state())[i] + 0.1);
    assert_eq!(ekf.update_gnss(&y), Status::Ok);
}

#[test]
fn bad_samples_leave_the_filter_unchanged() {
    let r = diagonal(measurement_variances());
    let mut ekf = predicted_filter(&r);
    let before = ekf;
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        for i in 0..6 {
            let mut u = imu(0);
            u[i] = bad;
            assert_eq!(ekf.predict(&u), Status::RejectedInput, "IMU {i} = {bad}");
            let mut gnss: [f64; 6] = std::array::from_fn(|j| h(&ekf.state())[j]);
            gnss[i] = bad;
            assert_eq!(
                ekf.update_gnss(&gnss),
                Status::RejectedInput,
                "GNSS {i} = {bad}"
            );
        }
        for i in 0..3 {
            let mut mag: [f64; 3] = std::array::from_fn(|j| h(&ekf.state())[6 + j]);
            mag[i] = bad;
            assert_eq!(
                ekf.update_magnetometer(&mag),
                Status::RejectedInput,
                "magnetometer {i}"
            );
        }
        assert_eq!(ekf, before);
    }
}

#[test]
fn a_singular_magnetometer_innovation_covariance_returns_a_status() {
    // No magnetometer noise and nothing uncertain that it sees: the innovation covariance
    // is zero, which the update must not divide by.
    let mut r = diagonal(measurement_variances());
    for i in MAGNETOMETER {
        r[i][i] = 0.0;
    }
    let mut p0 = [[0.0; N]; N];
    p0[4][4] = 1.0;
    let ekf_q = [0.0; N];
    let mut ekf = Ekf::new(&initial_state(), &p0, &ekf_q, &r).unwrap();
    let before = ekf;
    let y: [f64; 3] = std::array::from_fn(|j| h(&ekf.state())[6 + j] + 0.01);
    let status = ekf.update_magnetometer(&y);
    assert_eq!(status, Status::NonPositiveInnovation);
    assert_eq!(ekf, before);
    assert!(ekf.state().iter().all(|v| v.is_finite()));
}
