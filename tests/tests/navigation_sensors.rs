//! Updates per sensor on the navigation model (`generated-demo/models/navigation.rs`), an
//! error-state EKF (24 entries, a covariance over 23 tangent coordinates): a sensor's
//! update equals a dense nalgebra error-state Kalman update with its rows of `H` (over
//! the tangent), its block of `R`, the retraction `q <- Exp(δθ) q` and the covariance
//! reset; it stores its own innovation and normalised innovation squared and leaves the
//! filter's untouched; updating with each sensor in turn equals the joint update on every
//! Euclidean entry and block, and on the attitude up to the reset's second-order terms;
//! each sensor has a gate of its own; and bad samples (non-finite IMU, GNSS or
//! magnetometer values, an interval not positive and finite, a singular innovation
//! covariance) return a status with the filter unchanged.

use generated_demo::navigation::in_f64::{f, h, jacobian_h_wrt_x, Ekf, Status};
use generated_demo::navigation::{TANGENT_LEN as T, X_LEN as N};
use nalgebra::{DMatrix, DVector, Matrix3, Quaternion, UnitQuaternion, Vector3};
use tests::compare::largest_relative_difference;
use tests::rng::Lcg;

const M: usize = 9;
/// The GNSS receiver's outputs, then the magnetometer's, as the model orders them.
const GNSS: [usize; 6] = [0, 1, 2, 3, 4, 5];
const MAGNETOMETER: [usize; 3] = [6, 7, 8];
/// The attitude's coordinates in the tangent space; every other entry of `x` is a
/// tangent coordinate one place earlier (after the quaternion's four entries).
const ATTITUDE: std::ops::Range<usize> = 0..3;

/// Level, heading 30 degrees, at rest, with a typical mid-latitude earth field.
fn initial_state() -> [f64; N] {
    let half = 15.0_f64.to_radians();
    let mut x = [0.0; N];
    x[2] = half.sin();
    x[3] = half.cos();
    x[16] = 0.2;
    x[17] = 0.02;
    x[18] = 0.45;
    x
}

fn diagonal<const K: usize>(d: [f64; K]) -> [[f64; K]; K] {
    std::array::from_fn(|i| std::array::from_fn(|j| if i == j { d[i] } else { 0.0 }))
}

/// Standard deviations of the initial estimate, by tangent coordinate.
fn initial_sigma() -> [f64; T] {
    let mut s = [0.0; T];
    s[ATTITUDE].fill(0.1);
    s[3..6].fill(0.5);
    s[6..9].fill(2.0);
    s[9..12].fill(0.025);
    s[12..15].fill(0.25);
    s[15..18].fill(0.02);
    s[18..21].fill(0.02);
    s[21..23].fill(1.0);
    s
}

fn measurement_variances() -> [f64; M] {
    [0.09, 0.09, 0.16, 0.25, 0.25, 0.49, 2.5e-5, 2.5e-5, 2.5e-5]
}

/// The IMU's sample interval \[s\] in these tests (the model's nominal one).
const DT: f64 = 0.004;

fn filter(r: &[[f64; M]; M]) -> Ekf {
    let p0 = diagonal(initial_sigma().map(|s| s * s));
    // Densities (per second) of the variances per sample below.
    let mut q = [0.0; T];
    q[ATTITUDE].fill(4e-9);
    q[3..6].fill(1e-6);
    q[9..15].fill(6e-8);
    q[15..21].fill(1e-10);
    q[21..23].fill(1e-6);
    Ekf::new(&initial_state(), &p0, &q.map(|v| v / DT), r).unwrap()
}

/// An IMU sample of a slow turn with a little climb, as the model takes it: the rate
/// \[rad/s\] and the specific force \[m/s^2\], gravity's reaction on the accelerometer.
fn imu(k: usize) -> [f64; 6] {
    let t = k as f64 * DT;
    let rate = 0.2 * (0.5 * t).sin();
    [0.001, -0.002, rate, 0.1, 0.0, -9.7]
}

/// The filter after a second of prediction, so that its covariance couples the states.
fn predicted_filter(r: &[[f64; M]; M]) -> Ekf {
    let mut ekf = filter(r);
    for k in 0..250 {
        assert_eq!(ekf.predict(DT, &imu(k)), Status::Ok);
    }
    ekf
}

/// The attitude `[x, y, z, w]` of a state.
fn attitude(x: &[f64; N]) -> UnitQuaternion<f64> {
    UnitQuaternion::from_quaternion(Quaternion::new(x[3], x[0], x[1], x[2]))
}

/// `d x ⊞ δx / dδx` at `δx = 0`: for the attitude, `d(Exp(δθ) q)/dδθ = ½ [q_w I - [q_v]×;
/// -q_v']` (the product `(δθ/2, 1) ⊗ q`); the identity for every other entry.
fn retraction_jacobian(x: &[f64; N]) -> DMatrix<f64> {
    let (v, w) = (Vector3::new(x[0], x[1], x[2]), x[3]);
    let top = (Matrix3::identity() * w - v.cross_matrix()) * 0.5;
    let mut j = DMatrix::zeros(N, T);
    j.view_mut((0, 0), (3, 3)).copy_from(&top);
    j.view_mut((3, 0), (1, 3))
        .copy_from(&(-0.5 * v.transpose()));
    for entry in 4..N {
        j[(entry, entry - 1)] = 1.0;
    }
    j
}

/// `x ⊞ δx`: the attitude turned by `Exp(δθ)` in the earth frame, the rest added.
fn retract(x: &[f64; N], dx: &DVector<f64>) -> Vec<f64> {
    let turn = UnitQuaternion::from_scaled_axis(Vector3::new(dx[0], dx[1], dx[2]));
    let q = (turn * attitude(x)).into_inner().coords;
    let rest = (4..N).map(|entry| x[entry] + dx[entry - 1]);
    q.iter().copied().chain(rest).collect()
}

/// The Joseph-form error-state update with `rows` of the measurement, dense, in nalgebra:
/// `H` over the tangent (`H_x` times the retraction's Jacobian), the error estimated and
/// moved into the estimate, the covariance reset with `G = I + [δθ/2]×` on the attitude's
/// block.
fn dense_update(ekf: &Ekf, r: &[[f64; M]; M], rows: &[usize], y: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let (x, p) = (ekf.state(), ekf.covariance());
    let (k, hx, jac) = (rows.len(), h(&x), jacobian_h_wrt_x(&x));
    let pm = DMatrix::from_fn(T, T, |i, j| p[i][j]);
    let c = DMatrix::from_fn(k, N, |a, j| jac[rows[a]][j]) * retraction_jacobian(&x);
    let rm = DMatrix::from_fn(k, k, |a, b| r[rows[a]][rows[b]]);
    let residual = DVector::from_fn(k, |a, _| y[a] - hx[rows[a]]);
    let s = &c * &pm * c.transpose() + &rm;
    let gain = &pm * c.transpose() * s.try_inverse().unwrap();
    let dx = &gain * residual;
    let i_kc = DMatrix::identity(T, T) - &gain * &c;
    let joseph = &i_kc * &pm * i_kc.transpose() + &gain * rm * gain.transpose();
    let mut g = DMatrix::identity(T, T);
    let half_turn = Vector3::new(dx[0], dx[1], dx[2]) * 0.5;
    g.view_mut((0, 0), (3, 3))
        .copy_from(&(Matrix3::identity() + half_turn.cross_matrix()));
    let p_new = &g * joseph * g.transpose();
    let p_rows: Vec<f64> = (0..T)
        .flat_map(|i| (0..T).map(move |j| (i, j)))
        .map(|(i, j)| p_new[(i, j)])
        .collect();
    (retract(&x, &dx), p_rows)
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
    let c = DMatrix::from_fn(3, N, |a, j| jac[6 + a][j]) * retraction_jacobian(&x);
    let pm = DMatrix::from_fn(T, T, |i, j| p[i][j]);
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
/// the Euclidean entries, so updating with the magnetometer first (at the prediction too),
/// then the GNSS, is the same linear update of the error; the other order would linearise
/// the magnetometer at the GNSS-corrected estimate, a different (iterated-like) filter.
/// What the error-state filter adds, the retraction and the covariance reset after each
/// update, touches the attitude only: the Euclidean entries and their covariance block
/// agree to rounding. The attitudes, corrected by `a` then `b` in turn and by about `a + b`
/// jointly, differ at second order by the composition (`Exp(b) Exp(a)` against
/// `Exp(a + b)`: `(b × a) / 2`) and by the first reset's turn of the second correction
/// (`G = I + [a/2]×`: `(a × b) / 2`), which cancel: what is left is third order. Measured
/// below `0.1 |a| |b| (|a| + |b|)` (corrections of 1e-3 to 3e-2 rad here), asserted below
/// a quarter of it; a reset of the wrong sign would leave `|a × b|`, some 100 times more.
#[test]
fn sensor_updates_in_turn_equal_the_joint_update_but_for_the_attitude_reset() {
    let r = diagonal(measurement_variances());
    let mut joint = filter(&r);
    let mut truth = initial_state();
    let mut rng = Lcg(7);
    let (mut euclidean, mut attitude_ratio): (f64, f64) = (0.0, 0.0);
    for k in 0..500 {
        let u = imu(k);
        truth = f(DT, &truth, &u);
        assert_eq!(joint.predict(DT, &u), Status::Ok);
        if k % 50 != 49 {
            continue;
        }
        let y: [f64; M] = std::array::from_fn(|i| h(&truth)[i] + r[i][i].sqrt() * rng.uniform());
        let (mut in_turn, prior) = (joint, attitude(&joint.state()));
        assert_eq!(joint.update(&y), Status::Ok);
        assert_eq!(
            in_turn.update_magnetometer(&y[6..].try_into().unwrap()),
            Status::Ok
        );
        let between = attitude(&in_turn.state());
        assert_eq!(in_turn.update_gnss(&y[..6].try_into().unwrap()), Status::Ok);
        let (x, p) = (in_turn.state(), in_turn.covariance());
        let (x_joint, p_joint) = (joint.state(), joint.covariance());
        let block = |p: [[f64; T]; T]| -> Vec<f64> {
            p[3..].iter().flat_map(|row| row[3..].to_vec()).collect()
        };
        euclidean = euclidean
            .max(largest_relative_difference(&x[4..], &x_joint[4..]))
            .max(largest_relative_difference(&block(p), &block(p_joint)));
        let (a, b) = (
            (between * prior.inverse()).angle(),
            (attitude(&x) * between.inverse()).angle(),
        );
        let apart = (attitude(&x) * attitude(&x_joint).inverse()).angle();
        attitude_ratio = attitude_ratio.max(apart / (a * b * (a + b)));
        joint = in_turn;
    }
    eprintln!(
        "sensors in turn against the joint update: Euclidean {euclidean:e} relative, attitude {attitude_ratio:.3} |a| |b| (|a| + |b|)"
    );
    assert!(euclidean < 1e-12, "{euclidean:e}");
    assert!(attitude_ratio <= 0.25, "{attitude_ratio}");
}

#[test]
fn each_sensor_has_a_gate_of_its_own() {
    let r = diagonal(measurement_variances());
    let mut ekf = predicted_filter(&r);
    // Declared with each sensor (`sensor gnss(gate = 22.46)`, the chi-square 99.9 %
    // quantile for 6 outputs; `sensor magnetometer(gate = 16.27)`, for 3); the joint
    // update's is the filter's `gate = 27.88`, for all 9. The flight experiment's constant
    // is the model's.
    assert_eq!(ekf.gnss_innovation_gate(), 22.46);
    assert_eq!(ekf.magnetometer_innovation_gate(), 16.27);
    assert_eq!(ekf.innovation_gate(), 27.88);
    assert_eq!(
        ekf.magnetometer_innovation_gate(),
        generated_demo::flight::MAGNETOMETER_GATE
    );
    // Set apart at run time.
    assert_eq!(ekf.set_magnetometer_innovation_gate(16.0), Status::Ok);
    assert_eq!(ekf.magnetometer_innovation_gate(), 16.0);
    assert_eq!(ekf.gnss_innovation_gate(), 22.46);
    assert_eq!(ekf.innovation_gate(), 27.88);
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
    assert!(ekf.magnetometer_normalised_innovation_squared() > 16.0);
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
            assert_eq!(
                ekf.predict(DT, &u),
                Status::RejectedInput,
                "IMU {i} = {bad}"
            );
            assert_eq!(
                ekf.predict(bad, &imu(0)),
                Status::RejectedInput,
                "interval {bad}"
            );
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
    for interval in [0.0, -DT] {
        assert_eq!(ekf.predict(interval, &imu(0)), Status::RejectedInput);
    }
    assert_eq!(ekf, before);
}

#[test]
fn a_singular_magnetometer_innovation_covariance_returns_a_status() {
    // No magnetometer noise and nothing uncertain that it sees: the innovation covariance
    // is zero, which the update must not divide by.
    let mut r = diagonal(measurement_variances());
    for i in MAGNETOMETER {
        r[i][i] = 0.0;
    }
    let mut p0 = [[0.0; T]; T];
    p0[3][3] = 1.0;
    let ekf_q = [0.0; T];
    let mut ekf = Ekf::new(&initial_state(), &p0, &ekf_q, &r).unwrap();
    let before = ekf;
    let y: [f64; 3] = std::array::from_fn(|j| h(&ekf.state())[6 + j] + 0.01);
    let status = ekf.update_magnetometer(&y);
    assert_eq!(status, Status::NonPositiveInnovation);
    assert_eq!(ekf, before);
    assert!(ekf.state().iter().all(|v| v.is_finite()));
}
