//! Partial updates for sensors at different rates: the helicopter's EKF (two outputs,
//! `y_psi` and `y_phi`, pitch and yaw) updated with each output in turn equals the joint update with both
//! when the measurement noise is uncorrelated (a diagonal `R`), and a single-output
//! update equals a dense nalgebra Kalman update with that output's row of `H`.

use generated_demo::helicopter::in_f64::{f, h, jacobian_h_wrt_x, Ekf, Status};
use nalgebra::{SMatrix, SVector};
use tests::compare::largest_relative_difference;
use tests::rng::Lcg;

fn diagonal<const N: usize>(d: [f64; N]) -> [[f64; N]; N] {
    std::array::from_fn(|i| std::array::from_fn(|j| if i == j { d[i] } else { 0.0 }))
}

fn filter() -> Ekf {
    let p0 = diagonal([0.1; 6]);
    let q = diagonal([1e-6, 1e-4, 1e-6, 1e-4, 1e-5, 1e-5]);
    Ekf::new(
        &[0.1, 0.0, -0.2, 0.0, 0.0, 0.0],
        &p0,
        &q,
        &diagonal([1e-4, 2e-4]),
    )
    .unwrap()
}

#[test]
fn sequential_updates_equal_the_joint_update() {
    let dt = 0.001;
    let (mut joint, mut sequential) = (filter(), filter());
    let mut truth = [0.0, 0.0, 0.0, 0.0, 0.3, -0.2];
    let mut rng = Lcg(31);
    let mut worst: f64 = 0.0;
    for k in 1..1000 {
        let (t_prev, t) = ((k - 1) as f64 * dt, k as f64 * dt);
        let u = [0.4 * (3.0 * t_prev).sin(), 0.3 * (5.0 * t_prev).cos()];
        truth = f(t_prev, &truth, &u);
        let y = h(t, &truth);
        let y = [y[0] + 0.01 * rng.uniform(), y[1] + 0.014 * rng.uniform()];
        for ekf in [&mut joint, &mut sequential] {
            assert_eq!(ekf.predict(t_prev, &u), Status::Ok);
        }
        assert_eq!(joint.update(t, &y), Status::Ok);
        assert_eq!(sequential.update_y_psi(t, y[0]), Status::Ok);
        assert_eq!(sequential.update_y_phi(t, y[1]), Status::Ok);
        let flat = |p: [[f64; 6]; 6]| p.concat();
        worst = worst
            .max(largest_relative_difference(
                &sequential.state(),
                &joint.state(),
            ))
            .max(largest_relative_difference(
                &flat(sequential.covariance()),
                &flat(joint.covariance()),
            ));
    }
    eprintln!("sequential against joint update: {worst:e} relative");
    assert!(worst < 1e-12, "{worst:e}");
}

#[test]
fn one_output_update_equals_a_dense_kalman_update() {
    let mut ekf = filter();
    let (t, u) = (0.0, [0.1, -0.2]);
    assert_eq!(ekf.predict(t, &u), Status::Ok);
    let (x, p) = (ekf.state(), ekf.covariance());
    let y_yaw = h(t, &x)[1] + 0.05;
    assert_eq!(ekf.update_y_phi(t, y_yaw), Status::Ok);

    let xv = SVector::<f64, 6>::from(x);
    let pm = SMatrix::<f64, 6, 6>::from_fn(|i, j| p[i][j]);
    let c = SMatrix::<f64, 1, 6>::from_fn(|_, j| jacobian_h_wrt_x(t, &x)[1][j]);
    let s = (c * pm * c.transpose())[(0, 0)] + 2e-4;
    let gain = pm * c.transpose() / s;
    let x_new = xv + gain * (y_yaw - h(t, &x)[1]);
    let i_kc = SMatrix::<f64, 6, 6>::identity() - gain * c;
    let p_new = i_kc * pm * i_kc.transpose() + gain * 2e-4 * gain.transpose();
    assert!(largest_relative_difference(&ekf.state(), x_new.as_slice()) < 1e-14);
    let p_flat: Vec<f64> = (0..6)
        .flat_map(|i| (0..6).map(move |j| p_new[(i, j)]))
        .collect();
    assert!(largest_relative_difference(&ekf.covariance().concat(), &p_flat) < 1e-13);
    // A partial update stores its own innovation (zero for the other output) and its
    // normalised square, `r^2 / S`.
    let r = y_yaw - h(t, &x)[1];
    assert_eq!(ekf.innovation()[0], 0.0);
    assert!((ekf.innovation()[1] - r).abs() <= 1e-15 * r.abs());
    let nis = ekf.normalised_innovation_squared();
    assert!(
        (nis - r * r / s).abs() <= 1e-12 * nis,
        "{nis} against {}",
        r * r / s
    );
    assert_eq!(ekf.update_y_phi(t, f64::NAN), Status::RejectedInput);
}
