//! The generated EKF with two measurements (the helicopter of Kulkarni and Purwar's helicopter paper: its innovation
//! covariance is inverted by an unrolled, guarded `L D L'` solve) against a dense EKF
//! written with nalgebra on the same model functions, matrix inverse and all.

use generated_demo::helicopter::in_f64::{f, h, jacobian_f_wrt_x, jacobian_h_wrt_x, Ekf, Status};
use nalgebra::{SMatrix, SVector};

type M6 = SMatrix<f64, 6, 6>;
type M2 = SMatrix<f64, 2, 2>;
type V6 = SVector<f64, 6>;
type V2 = SVector<f64, 2>;

const DT: f64 = 0.001;

/// Copies nested arrays into a dense 6x6 matrix.
fn dense(m: [[f64; 6]; 6]) -> M6 {
    M6::from_fn(|i, j| m[i][j])
}

/// Copies a dense 6x6 matrix into the nested arrays the generated filter takes.
fn to_array(m: &M6) -> [[f64; 6]; 6] {
    std::array::from_fn(|i| std::array::from_fn(|j| m[(i, j)]))
}

/// The dense reference: a textbook EKF (Alg. 1, Joseph form) on the model functions.
struct DenseEkf {
    x: V6,
    p: M6,
    q: M6,
    r: M2,
}

/// What the dense EKF saw in one step: the innovation and its normalised square.
struct DenseInnovation {
    innovation: V2,
    nis: f64,
}

impl DenseEkf {
    /// Predicts over `[t_prev, t]` with input `u`, then corrects with measurement `y` at `t`.
    fn step(&mut self, t_prev: f64, t: f64, u: &[f64; 2], y: &[f64; 2]) -> DenseInnovation {
        let (q, r) = (self.q, self.r);
        let (mut x, mut p) = (self.x, self.p);
        let xa: [f64; 6] = x.into();
        let a = dense(jacobian_f_wrt_x(t_prev, &xa, u));
        p = a * p * a.transpose() + q;
        x = SVector::from(f(t_prev, &xa, u));
        let xa: [f64; 6] = x.into();
        let cm = jacobian_h_wrt_x(t, &xa);
        let c = SMatrix::<f64, 2, 6>::from_fn(|i, j| cm[i][j]);
        let s = c * p * c.transpose() + r;
        let gain = p * c.transpose() * s.try_inverse().expect("S invertible");
        let hx = h(t, &xa);
        let innovation = V2::new(y[0] - hx[0], y[1] - hx[1]);
        // The innovation and its normalised square, r' S^-1 r, as the filter reports them.
        let nis = (innovation.transpose() * s.try_inverse().expect("S invertible") * innovation)[0];
        x += gain * innovation;
        let i_kc = M6::identity() - gain * c;
        p = i_kc * p * i_kc.transpose() + gain * r * gain.transpose();
        (self.x, self.p) = (x, p);
        DenseInnovation { innovation, nis }
    }
}

/// The noise both filters use: a diagonal process noise `Q` and a correlated `R`.
fn helicopter_noise() -> (M6, M2) {
    let q_diag = [1e-6, 1e-4, 1e-6, 1e-4, 1e-5, 1e-5];
    let q = dense(std::array::from_fn(|i| {
        std::array::from_fn(|j| if i == j { q_diag[i] } else { 0.0 })
    }));
    let r = M2::new(1e-4, 2e-5, 2e-5, 2e-4);
    (q, r)
}

/// Advances the true helicopter to step `k`; returns its times, input and noisy measurement.
fn advance_truth(k: usize, truth: &mut [f64; 6]) -> (f64, f64, [f64; 2], [f64; 2]) {
    let t_prev = (k - 1) as f64 * DT;
    let t = k as f64 * DT;
    let u = [0.4 * (3.0 * t_prev).sin(), 0.3 * (5.0 * t_prev).cos()];
    *truth = f(t_prev, truth, &u);
    let y = h(t, truth);
    let y = [
        y[0] + 1e-3 * (7.0 * t).sin(),
        y[1] - 1e-3 * (11.0 * t).cos(),
    ];
    (t_prev, t, u, y)
}

/// Checks the generated filter's innovation and NIS against the dense ones at step `k`.
fn assert_innovation_agrees(ekf: &Ekf, dense: &DenseInnovation, k: usize) {
    for (i, (&g, &d)) in ekf
        .innovation()
        .iter()
        .zip(dense.innovation.iter())
        .enumerate()
    {
        assert!(
            (g - d).abs() <= 1e-9 * g.abs().max(d.abs()).max(1e-9),
            "innovation[{i}] at {k}: {g} vs {d}"
        );
    }
    let (reported, nis) = (ekf.normalised_innovation_squared(), dense.nis);
    assert!(
        (reported - nis).abs() <= 1e-9 * nis.max(1e-9),
        "NIS at {k}: {reported} vs {nis}"
    );
}

/// Checks the generated filter's state and covariance against the dense ones at step `k`.
fn assert_estimate_agrees(ekf: &Ekf, reference: &DenseEkf, k: usize) {
    let (x, p) = (reference.x, reference.p);
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

#[test]
fn two_measurement_ekf_agrees_with_a_dense_ekf() {
    let (q, r) = helicopter_noise();
    let p0 = M6::identity() * 0.1;
    let x0 = [0.1, 0.0, -0.2, 0.0, 0.0, 0.0];
    let mut ekf = Ekf::new(
        &x0,
        &to_array(&p0),
        &to_array(&q),
        &[[r[(0, 0)], r[(0, 1)]], [r[(1, 0)], r[(1, 1)]]],
    )
    .unwrap();
    let mut reference = DenseEkf {
        x: V6::from(x0),
        p: p0,
        q,
        r,
    };
    let mut truth = [0.0, 0.0, 0.0, 0.0, 0.3, -0.2];
    for k in 1..600 {
        let (t_prev, t, u, y) = advance_truth(k, &mut truth);
        assert_eq!(ekf.step(t_prev, &u, &y), Status::Ok, "step {k}");
        let seen = reference.step(t_prev, t, &u, &y);
        assert_innovation_agrees(&ekf, &seen, k);
        assert_estimate_agrees(&ekf, &reference, k);
    }
}
