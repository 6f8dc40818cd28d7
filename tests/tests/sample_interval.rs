//! The sample interval given at run time (`interval DT = 0.1;`, test model `jittered`):
//! the generated EKF, whose prediction takes each sample's own interval `dt` (its step a
//! function of it, its process noise a density scaled by it), against an independent
//! nalgebra EKF written from the model with `F(dt)` and `Q dt`, over intervals that jitter
//! by up to a third, to 1e-12 in `f64`; and the intervals it refuses.

use nalgebra::{Matrix2, Matrix2x3, Matrix3, Vector2, Vector3};
use tests::plane::{f, jacobian};

include!("../models/jittered.rs");

use jittered::in_f64::{Ekf, Status};

fn as_array(m: &Matrix3<f64>) -> [[f64; 3]; 3] {
    std::array::from_fn(|i| std::array::from_fn(|j| m[(i, j)]))
}

fn assert_close(what: &str, k: usize, generated: &[f64], reference: &[f64]) {
    for (g, r) in generated.iter().zip(reference) {
        assert!(
            (g - r).abs() <= 1e-12 * (1.0 + r.abs()),
            "{what} at sample {k}: generated {generated:?}, reference {reference:?}"
        );
    }
}

#[test]
fn the_prediction_follows_each_sample_s_own_interval() {
    let x0 = Vector3::new(1.0, -2.0, 0.3);
    let p0 = Matrix3::new(4.0, 0.5, 0.1, 0.5, 3.0, -0.2, 0.1, -0.2, 0.5);
    // Densities: per second.
    let q = Matrix3::new(0.2, 0.01, 0.0, 0.01, 0.3, 0.02, 0.0, 0.02, 0.1);
    let r = Matrix2::new(0.5, 0.1, 0.1, 0.7);
    let mut ekf = Ekf::new(
        &x0.into(),
        &as_array(&p0),
        &as_array(&q),
        &[[0.5, 0.1], [0.1, 0.7]],
    )
    .unwrap();
    let (mut x, mut p) = (x0, p0);
    let mut t = 0.0;
    for k in 1..=80_usize {
        // The nominal 0.1 s, jittered by up to a third.
        let dt = 0.1 * (1.0 + 0.33 * (1.7 * k as f64).sin());
        t += dt;
        let u = [2.0 + (0.7 * t).sin(), 0.3 * (0.4 * t).cos()];
        let a = jacobian(dt, &x, u);
        (x, p) = (f(dt, &x, u), a * p * a.transpose() + q * dt);
        // The model's own step over the interval.
        assert_close(
            "f",
            k,
            &jittered::in_f64::f(dt, &x.into(), &u),
            f(dt, &x, u).as_slice(),
        );
        let status = if k % 3 == 0 {
            let y = [2.0 * t + (1.3 * t).cos(), 0.5 * t - (0.9 * t).sin()];
            let h = Matrix2x3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0);
            let s = h * p * h.transpose() + r;
            let gain = p * h.transpose() * s.try_inverse().unwrap();
            x += gain * (Vector2::new(y[0], y[1]) - h * x);
            let joseph = Matrix3::identity() - gain * h;
            p = joseph * p * joseph.transpose() + gain * r * gain.transpose();
            ekf.step(dt, &u, &y)
        } else {
            ekf.predict(dt, &u)
        };
        assert_eq!(status, Status::Ok, "sample {k}");
        assert_close("estimate", k, &ekf.state(), x.as_slice());
        let generated: Vec<f64> = ekf.covariance().iter().flatten().copied().collect();
        let reference: Vec<f64> = (0..9).map(|i| p[(i / 3, i % 3)]).collect();
        assert_close("covariance", k, &generated, &reference);
    }
}

#[test]
fn an_interval_that_is_not_positive_and_finite_is_refused() {
    let p0 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.1]];
    let q = [[0.01, 0.0, 0.0], [0.0, 0.01, 0.0], [0.0, 0.0, 0.001]];
    let mut ekf = Ekf::new(&[0.0; 3], &p0, &q, &[[0.5, 0.0], [0.0, 0.5]]).unwrap();
    let before = ekf;
    for dt in [0.0, -0.1, f64::NAN, f64::INFINITY] {
        assert_eq!(ekf.predict(dt, &[1.0, 0.0]), Status::RejectedInput, "{dt}");
        assert_eq!(
            ekf.step(dt, &[1.0, 0.0], &[0.0, 0.0]),
            Status::RejectedInput,
            "{dt}"
        );
        assert_eq!(ekf, before);
    }
    // A longer interval moves further and adds more noise.
    let (mut short, mut long) = (ekf, ekf);
    assert_eq!(short.predict(0.05, &[1.0, 0.0]), Status::Ok);
    assert_eq!(long.predict(0.2, &[1.0, 0.0]), Status::Ok);
    assert!((short.state()[0] - 0.05).abs() < 1e-15 && (long.state()[0] - 0.2).abs() < 1e-15);
    assert!(long.covariance()[2][2] > short.covariance()[2][2]);
}
