//! The generated EKF with two measurements (the helicopter of seed 004: its innovation
//! covariance is inverted by an unrolled, guarded `L D L'` solve) against a dense EKF
//! written with nalgebra on the same model functions, matrix inverse and all.

use generated_demo::helicopter::in_f64::{f, h, jacobian_f_wrt_x, jacobian_h_wrt_x, Ekf, Status};
use nalgebra::{SMatrix, SVector};

type M6 = SMatrix<f64, 6, 6>;

fn dense(m: [[f64; 6]; 6]) -> M6 {
    M6::from_fn(|i, j| m[i][j])
}

#[test]
fn two_measurement_ekf_agrees_with_a_dense_ekf() {
    let dt = 0.001;
    let q_diag = [1e-6, 1e-4, 1e-6, 1e-4, 1e-5, 1e-5];
    let q = dense(std::array::from_fn(|i| {
        std::array::from_fn(|j| if i == j { q_diag[i] } else { 0.0 })
    }));
    let r = SMatrix::<f64, 2, 2>::new(1e-4, 2e-5, 2e-5, 2e-4);
    let p0 = M6::identity() * 0.1;
    let x0 = [0.1, 0.0, -0.2, 0.0, 0.0, 0.0];
    let to_array =
        |m: &M6| -> [[f64; 6]; 6] { std::array::from_fn(|i| std::array::from_fn(|j| m[(i, j)])) };
    let mut ekf = Ekf::new(
        &x0,
        &to_array(&p0),
        &to_array(&q),
        &[[r[(0, 0)], r[(0, 1)]], [r[(1, 0)], r[(1, 1)]]],
    )
    .unwrap();
    let (mut x, mut p) = (SVector::<f64, 6>::from(x0), p0);
    let mut truth = [0.0, 0.0, 0.0, 0.0, 0.3, -0.2];
    for k in 1..600 {
        let t_prev = (k - 1) as f64 * dt;
        let t = k as f64 * dt;
        let u = [0.4 * (3.0 * t_prev).sin(), 0.3 * (5.0 * t_prev).cos()];
        truth = f(t_prev, &truth, &u);
        let y = h(t, &truth);
        let y = [
            y[0] + 1e-3 * (7.0 * t).sin(),
            y[1] - 1e-3 * (11.0 * t).cos(),
        ];

        assert_eq!(ekf.step(t_prev, &u, &y), Status::Ok, "step {k}");

        // Dense EKF (Alg. 1, Joseph form) on the same model functions.
        let xa: [f64; 6] = x.into();
        let a = dense(jacobian_f_wrt_x(t_prev, &xa, &u));
        p = a * p * a.transpose() + q;
        x = SVector::from(f(t_prev, &xa, &u));
        let xa: [f64; 6] = x.into();
        let cm = jacobian_h_wrt_x(t, &xa);
        let c = SMatrix::<f64, 2, 6>::from_fn(|i, j| cm[i][j]);
        let s = c * p * c.transpose() + r;
        let gain = p * c.transpose() * s.try_inverse().expect("S invertible");
        let hx = h(t, &xa);
        let innovation = SVector::<f64, 2>::new(y[0] - hx[0], y[1] - hx[1]);
        // The innovation and its normalised square, r' S^-1 r, as the filter reports them.
        let nis = (innovation.transpose() * s.try_inverse().expect("S invertible") * innovation)[0];
        for (i, (&g, &d)) in ekf.innovation().iter().zip(innovation.iter()).enumerate() {
            assert!(
                (g - d).abs() <= 1e-9 * g.abs().max(d.abs()).max(1e-9),
                "innovation[{i}] at {k}: {g} vs {d}"
            );
        }
        let reported = ekf.normalised_innovation_squared();
        assert!(
            (reported - nis).abs() <= 1e-9 * nis.max(1e-9),
            "NIS at {k}: {reported} vs {nis}"
        );
        x += gain * innovation;
        let i_kc = M6::identity() - gain * c;
        p = i_kc * p * i_kc.transpose() + gain * r * gain.transpose();

        let scale = x.amax().max(1e-12);
        for (i, (&g, &d)) in ekf.state().iter().zip(x.iter()).enumerate() {
            assert!(
                (g - d).abs() <= 1e-9 * g.abs().max(d.abs()).max(scale),
                "x[{i}] at {k}: {g} vs {d}"
            );
        }
        let covariance = ekf.covariance();
        let scale = p.amax();
        for i in 0..6 {
            for j in 0..6 {
                let (g, d) = (covariance[i][j], p[(i, j)]);
                assert!(
                    (g - d).abs() <= 1e-9 * g.abs().max(d.abs()).max(scale),
                    "P[{i}][{j}] at {k}: {g} vs {d}"
                );
            }
        }
    }
}
