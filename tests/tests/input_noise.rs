//! Noise on inputs (`ekf(input_noise = [..])`): the generated filter's predicted covariance
//! is `F P F' + Q + G diag(qu) G'`, computed here densely with nalgebra, `F` and `G` the
//! Jacobians of the generated `f` by central differences (over the tangent space for the
//! AHRS, whose attitude is a rotation: `x ⊞ δx` turns it by `Exp(δθ) ⊗ q`); and its tuning
//! (`new`'s `qu`, `set_input_noise`) rejects what is not a variance. With a sample
//! interval `dt` (`interval`), `qu` is a density: the prediction adds `G diag(qu) G' / dt`,
//! `G` the Jacobian over that interval, beside `Q dt`.

use nalgebra::{DMatrix, DVector, Quaternion, UnitQuaternion, Vector3};

include!("../models/dead_reckoning.rs");
include!("../models/dead_reckoning_timed.rs");

stateforge::model! {
    /// The AHRS of `examples/ahrs` with the gyro's noise on its input.
    mod ahrs {
        scalar f64;
        const DT = 0.01;
        const GRAVITY = 9.80665;
        const MAG_N = 0.21;
        const MAG_D = 0.45;
        state q: Rot3;
        param gyro_bias: Vec3;
        input gyro: Vec3;
        output
            accel = q.inverse() * vec3(0.0, 0.0, -GRAVITY),
            mag = q.inverse() * vec3(MAG_N, 0.0, MAG_D);
        generate ekf(input_noise = [gyro], process_noise = diagonal,
            process_noise_on = [gyro_bias]);
        dynamics discrete {
            q = q * exp((gyro - gyro_bias) * DT);
        }
    }
}

/// The central difference's step.
const H: f64 = 1e-5;
/// How far the filter's covariance may be from the reference's (the differences' error).
const TOLERANCE: f64 = 1e-9;

/// `(d(dx) - d(-dx)) / 2h` for each unit step `dx` along `n` coordinates: a Jacobian by
/// central differences, `d(dx)` a column.
fn central(rows: usize, n: usize, d: impl Fn(&DVector<f64>) -> DVector<f64>) -> DMatrix<f64> {
    let mut jacobian = DMatrix::zeros(rows, n);
    for k in 0..n {
        let step = DVector::from_fn(n, |i, _| if i == k { H } else { 0.0 });
        let column = (d(&step) - d(&-step)) / (2.0 * H);
        jacobian.set_column(k, &column);
    }
    jacobian
}

/// `F P F' + Q + G diag(qu) G'` and the last term alone.
fn reference(
    (f, g): (&DMatrix<f64>, &DMatrix<f64>),
    p: &DMatrix<f64>,
    q: &DMatrix<f64>,
    qu: &[f64],
) -> (DMatrix<f64>, DMatrix<f64>) {
    let mapped = g * DMatrix::from_diagonal(&DVector::from_column_slice(qu)) * g.transpose();
    (f * p * f.transpose() + q + &mapped, mapped)
}

/// Asserts `predicted` equals `expected` entry by entry to [`TOLERANCE`], and that the
/// input noise's share `mapped` is far larger than that (so that leaving it out fails).
fn assert_agrees(predicted: &DMatrix<f64>, expected: &DMatrix<f64>, mapped: &DMatrix<f64>) {
    let worst = (predicted - expected).abs().max();
    assert!(
        worst < TOLERANCE,
        "predicted covariance off by {worst:.2e}:{predicted}expected{expected}"
    );
    let share = mapped.abs().max();
    assert!(
        share > 1e3 * TOLERANCE,
        "the input noise adds only {share:.1e}"
    );
    println!(
        "predicted covariance = F P F' + Q + G diag(qu) G' within {worst:.1e} \
         (G diag(qu) G' up to {share:.1e})"
    );
}

fn dense<const N: usize>(m: &[[f64; N]; N]) -> DMatrix<f64> {
    DMatrix::from_fn(N, N, |i, j| m[i][j])
}

fn array<const N: usize>(v: &DVector<f64>) -> [f64; N] {
    core::array::from_fn(|i| v[i])
}

/// A covariance of `n`: `diagonal` on the diagonal, `off` elsewhere.
fn covariance<const N: usize>(diagonal: f64, off: f64) -> [[f64; N]; N] {
    core::array::from_fn(|i| core::array::from_fn(|j| if i == j { diagonal } else { off }))
}

const DR_X: [f64; 4] = [3.0, -2.0, 0.7, 0.01];
const DR_U: [f64; 2] = [1.5, 0.3];
/// The variances of the inputs listed, `[yaw_rate, speed]`.
const DR_QU: [f64; 2] = [4e-4, 2.5e-3];
const DR_Q: [f64; 1] = [1e-6];
const DR_R: [[f64; 2]; 2] = [[0.25, 0.0], [0.0, 0.25]];

#[test]
fn euclidean_prediction_adds_the_input_noise_through_the_input_jacobian() {
    use dead_reckoning::in_f64::{f, Ekf, Status};
    let (x, u) = (
        DVector::from_column_slice(&DR_X),
        DVector::from_column_slice(&DR_U),
    );
    let at =
        |x: &DVector<f64>, u: &DVector<f64>| DVector::from_column_slice(&f(&array(x), &array(u)));
    let f_x = central(4, 4, |dx| at(&(&x + dx), &u));
    let g_u = central(4, 2, |du| at(&x, &(&u + du)));
    // `qu` in the order listed, [yaw_rate, speed]: the Jacobian's columns swapped.
    let g_listed = DMatrix::from_columns(&[g_u.column(1), g_u.column(0)]);
    let mut q = DMatrix::zeros(4, 4);
    q[(3, 3)] = DR_Q[0];
    let p0 = covariance(0.5, 0.05);
    let mut filter = Ekf::new(&DR_X, &p0, &DR_Q, &DR_QU, &DR_R).unwrap();
    assert_eq!(filter.predict(&DR_U), Status::Ok);
    let (expected, mapped) = reference((&f_x, &g_listed), &dense(&p0), &q, &DR_QU);
    assert_agrees(&dense(&filter.covariance()), &expected, &mapped);
}

/// The AHRS's estimate `[q_x, q_y, q_z, q_w, b_x, b_y, b_z]`, its attitude.
fn attitude(x: &[f64; 7]) -> UnitQuaternion<f64> {
    UnitQuaternion::from_quaternion(Quaternion::new(x[3], x[0], x[1], x[2]))
}

/// `x ⊞ δx`: the attitude turned by `Exp(δθ) ⊗ q`, the bias moved by `δb`.
fn retract(x: &[f64; 7], dx: &DVector<f64>) -> [f64; 7] {
    let turned = UnitQuaternion::from_scaled_axis(Vector3::new(dx[0], dx[1], dx[2])) * attitude(x);
    let q = turned.quaternion().coords;
    [q.x, q.y, q.z, q.w, x[4] + dx[3], x[5] + dx[4], x[6] + dx[5]]
}

/// `y ⊟ x`: `Log(q_y ⊗ q_x⁻¹)` and the bias's difference.
fn local(y: &[f64; 7], x: &[f64; 7]) -> DVector<f64> {
    let theta = (attitude(y) * attitude(x).inverse()).scaled_axis();
    DVector::from_column_slice(&[
        theta.x,
        theta.y,
        theta.z,
        y[4] - x[4],
        y[5] - x[5],
        y[6] - x[6],
    ])
}

#[test]
fn error_state_prediction_adds_the_input_noise_over_the_tangent_space() {
    use ahrs::{f, Ekf, Status};
    let q = UnitQuaternion::from_euler_angles(0.3, -0.6, 2.0);
    let c = q.quaternion().coords;
    let x = [c.x, c.y, c.z, c.w, 0.01, -0.02, 0.005];
    let u = DVector::from_column_slice(&[0.8, -0.4, 1.2]);
    let fx = f(&x, &array(&u));
    let f_x = central(6, 6, |dx| local(&f(&retract(&x, dx), &array(&u)), &fx));
    let g_u = central(6, 3, |du| local(&f(&x, &array(&(&u + du))), &fx));
    let qu = [0.04, 0.09, 0.0625];
    let q_bias = [1e-8, 2e-8, 3e-8];
    let mut q_dense = DMatrix::zeros(6, 6);
    for (i, v) in q_bias.iter().enumerate() {
        q_dense[(3 + i, 3 + i)] = *v;
    }
    let p0 = covariance(1e-2, 1e-3);
    let r = covariance(1e-2, 0.0);
    let mut filter = Ekf::new(&x, &p0, &q_bias, &qu, &r).unwrap();
    assert_eq!(filter.predict(&array(&u)), Status::Ok);
    let (expected, mapped) = reference((&f_x, &g_u), &dense(&p0), &q_dense, &qu);
    assert_agrees(&dense(&filter.covariance()), &expected, &mapped);
}

#[test]
fn a_step_predicts_with_the_input_noise_as_predict_does() {
    use dead_reckoning::in_f64::{Ekf, Status};
    let p0 = covariance(0.5, 0.05);
    let mut stepped = Ekf::new(&DR_X, &p0, &DR_Q, &DR_QU, &DR_R).unwrap();
    let mut parts = stepped;
    let y = [3.2, -1.9];
    assert_eq!(stepped.step(&DR_U, &y), Status::Ok);
    assert_eq!(parts.predict(&DR_U), Status::Ok);
    assert_eq!(parts.update(&y), Status::Ok);
    let worst = (dense(&stepped.covariance()) - dense(&parts.covariance()))
        .abs()
        .max();
    assert!(
        worst < 1e-14,
        "step and predict + update differ by {worst:.1e}"
    );
}

#[test]
fn a_step_with_a_sample_interval_predicts_as_predict_does() {
    use dead_reckoning_timed::{Ekf, Status};
    let p0 = covariance(0.5, 0.05);
    let mut stepped = Ekf::new(&DR_X, &p0, &DR_Q, &DR_QU, &DR_R).unwrap();
    let mut parts = stepped;
    let y = [3.2, -1.9];
    assert_eq!(stepped.step(0.13, &DR_U, &y), Status::Ok);
    assert_eq!(parts.predict(0.13, &DR_U), Status::Ok);
    assert_eq!(parts.update(&y), Status::Ok);
    let worst = (dense(&stepped.covariance()) - dense(&parts.covariance()))
        .abs()
        .max();
    assert!(
        worst < 1e-14,
        "step and predict + update differ by {worst:.1e}"
    );
}

#[test]
fn the_input_noise_is_checked_a_variance() {
    use dead_reckoning::in_f64::{Ekf, Status};
    let p0 = covariance(0.5, 0.05);
    let new = |qu: &[f64; 2]| Ekf::new(&DR_X, &p0, &DR_Q, qu, &DR_R);
    assert_eq!(new(&[f64::NAN, 1e-3]), Err(Status::RejectedInput));
    assert_eq!(new(&[1e-3, f64::INFINITY]), Err(Status::RejectedInput));
    assert_eq!(new(&[1e-3, -1e-9]), Err(Status::InvalidCovariance));
    let mut filter = new(&[0.0, 0.0]).unwrap();
    let before = filter;
    assert_eq!(
        filter.set_input_noise(&[1e-3, f64::NAN]),
        Status::RejectedInput
    );
    assert_eq!(
        filter.set_input_noise(&[-1e-3, 1e-3]),
        Status::InvalidCovariance
    );
    assert_eq!(
        filter, before,
        "a refused setting leaves the filter unchanged"
    );
    // A setting taken predicts as a filter built with it.
    assert_eq!(filter.set_input_noise(&DR_QU), Status::Ok);
    let mut built = new(&DR_QU).unwrap();
    assert_eq!(filter.predict(&DR_U), Status::Ok);
    assert_eq!(built.predict(&DR_U), Status::Ok);
    assert_eq!(filter.covariance(), built.covariance());
    // And one without input noise predicts less.
    let mut quiet = before;
    assert_eq!(quiet.predict(&DR_U), Status::Ok);
    let grown = filter.covariance()[2][2] - quiet.covariance()[2][2];
    assert!(
        grown > 0.5 * DR_QU[0] * 0.01,
        "heading variance grew by {grown:.1e}"
    );
}

/// With a sample interval, over intervals from a third below to twice the nominal one:
/// `F P F' + Q dt + G diag(qu) G' / dt`, `F` and `G` the Jacobians of `f(dt, ..)` over that
/// interval; and at the nominal interval the filter of densities `qu DT` and `Q / DT`
/// predicts as the fixed-interval filter of variances `qu` and `Q` does.
#[test]
fn with_a_sample_interval_the_input_noise_is_a_density() {
    use dead_reckoning_timed::{f, Ekf, Status, DT};
    let (x, u) = (
        DVector::from_column_slice(&DR_X),
        DVector::from_column_slice(&DR_U),
    );
    let p0 = covariance(0.5, 0.05);
    for dt in [0.067, 0.1, 0.2] {
        let at = |x: &DVector<f64>, u: &DVector<f64>| {
            DVector::from_column_slice(&f(dt, &array(x), &array(u)))
        };
        let f_x = central(4, 4, |dx| at(&(&x + dx), &u));
        let g_u = central(4, 2, |du| at(&x, &(&u + du)));
        let g_listed = DMatrix::from_columns(&[g_u.column(1), g_u.column(0)]);
        let mut q = DMatrix::zeros(4, 4);
        q[(3, 3)] = DR_Q[0] * dt;
        let per_sample = DR_QU.map(|v| v / dt);
        let mut filter = Ekf::new(&DR_X, &p0, &DR_Q, &DR_QU, &DR_R).unwrap();
        assert_eq!(filter.predict(dt, &DR_U), Status::Ok);
        let (expected, mapped) = reference((&f_x, &g_listed), &dense(&p0), &q, &per_sample);
        assert_agrees(&dense(&filter.covariance()), &expected, &mapped);
    }
    let mut fixed = dead_reckoning::in_f64::Ekf::new(&DR_X, &p0, &DR_Q, &DR_QU, &DR_R).unwrap();
    let densities = DR_QU.map(|v| v * DT);
    let mut timed = Ekf::new(&DR_X, &p0, &DR_Q.map(|v| v / DT), &densities, &DR_R).unwrap();
    assert_eq!(fixed.predict(&DR_U), dead_reckoning::in_f64::Status::Ok);
    assert_eq!(timed.predict(DT, &DR_U), Status::Ok);
    let worst = (dense(&fixed.covariance()) - dense(&timed.covariance()))
        .abs()
        .max();
    assert!(worst < 1e-15, "the two filters differ by {worst:.1e}");
}
