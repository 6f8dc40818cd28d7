//! The delayed fusion horizon (`sensor fix(delay = 3)`): the generated filter, which fuses
//! a late fix on a horizon `DELAY` samples behind and predicts the current state through
//! its buffered inputs, against an independent nalgebra filter that keeps its whole
//! history and, when a fix arrives, fuses it at the sample it describes and replays the
//! inputs since (estimate and covariance), to 1e-9 in `f64`.

use nalgebra::{Matrix2, Matrix2x3, Matrix3, Vector2, Vector3};

include!("../models/delayed_fix.rs");

const DT: f64 = 0.1;
const DELAY: usize = 3;

/// `f` of the model, written out.
fn f(x: &Vector3<f64>, u: [f64; 2]) -> Vector3<f64> {
    let turned = x[2] + DT * u[1];
    Vector3::new(
        x[0] + DT * u[0] * turned.cos(),
        x[1] + DT * u[0] * turned.sin(),
        turned,
    )
}

/// Its Jacobian `df/dx`.
fn jacobian(x: &Vector3<f64>, u: [f64; 2]) -> Matrix3<f64> {
    let turned = x[2] + DT * u[1];
    Matrix3::new(
        1.0,
        0.0,
        -DT * u[0] * turned.sin(),
        0.0,
        1.0,
        DT * u[0] * turned.cos(),
        0.0,
        0.0,
        1.0,
    )
}

/// The replaying filter: the posterior at every sample so far, and the inputs between.
struct Replaying {
    history: Vec<(Vector3<f64>, Matrix3<f64>)>,
    inputs: Vec<[f64; 2]>,
    q: Matrix3<f64>,
    r: Matrix2<f64>,
}

impl Replaying {
    fn predict_from(&self, k: usize) -> (Vector3<f64>, Matrix3<f64>) {
        let (x, p) = self.history[k];
        let u = self.inputs[k];
        let a = jacobian(&x, u);
        (f(&x, u), a * p * a.transpose() + self.q)
    }

    fn predict(&mut self, u: [f64; 2]) {
        self.inputs.push(u);
        let next = self.predict_from(self.history.len() - 1);
        self.history.push(next);
    }

    /// Fuses `y`, a fix of the sample `at`, there (textbook form), then replays the
    /// predictions from it to the present.
    fn fuse(&mut self, y: [f64; 2], at: usize) {
        let (x, p) = self.history[at];
        let h = Matrix2x3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0);
        let s = h * p * h.transpose() + self.r;
        let k = p * h.transpose() * s.try_inverse().unwrap();
        let x = x + k * (Vector2::new(y[0], y[1]) - h * x);
        let p = (Matrix3::identity() - k * h) * p;
        self.history[at] = (x, 0.5 * (p + p.transpose()));
        for j in at..self.history.len() - 1 {
            self.history[j + 1] = self.predict_from(j);
        }
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
fn delayed_fusion_equals_fusing_at_the_fix_time_and_replaying() {
    use delayed_fix::in_f64::Ekf;
    assert_eq!(Ekf::DELAY, DELAY);
    let x0 = Vector3::new(1.0, -2.0, 0.3);
    let p0 = Matrix3::new(4.0, 0.5, 0.1, 0.5, 3.0, -0.2, 0.1, -0.2, 0.5);
    let q = Matrix3::new(0.02, 0.001, 0.0, 0.001, 0.03, 0.002, 0.0, 0.002, 0.01);
    let r = Matrix2::new(0.5, 0.1, 0.1, 0.7);
    let r_array = [[0.5, 0.1], [0.1, 0.7]];
    let mut ekf = Ekf::new(&x0.into(), &as_array(&p0), &as_array(&q), &r_array).unwrap();
    let mut replaying = Replaying {
        history: vec![(x0, p0)],
        inputs: Vec::new(),
        q,
        r,
    };
    let mut fixes = 0;
    for k in 1..=60_usize {
        let t = k as f64 * DT;
        let u = [2.0 + (0.7 * t).sin(), 0.3 * (0.4 * t).cos()];
        assert_eq!(ekf.predict(&u), delayed_fix::in_f64::Status::Ok);
        replaying.predict(u);
        // Fixes from the second sample on, some before the buffer is full (they describe
        // the start, where the horizon still is).
        if k % 2 == 0 {
            let y = [2.0 * t + (1.3 * t).cos(), 0.5 * t - (0.9 * t).sin()];
            assert_eq!(ekf.update_fix(&y), delayed_fix::in_f64::Status::Ok);
            replaying.fuse(y, k.saturating_sub(DELAY));
            fixes += 1;
        }
        let (x_delayed, p_delayed) = replaying.history[k.saturating_sub(DELAY)];
        let (x_now, _) = replaying.history[k];
        assert_close("delayed estimate", k, &ekf.state(), x_delayed.as_slice());
        let p: Vec<f64> = ekf.covariance().iter().flatten().copied().collect();
        let p_reference: Vec<f64> = (0..9).map(|i| p_delayed[(i / 3, i % 3)]).collect();
        assert_close("delayed covariance", k, &p, &p_reference);
        assert_close("current state", k, &ekf.current_state(), x_now.as_slice());
    }
    assert_eq!(fixes, 30);
    // The output predictor moved the estimate: the current state is not the delayed one.
    assert!((ekf.current_state()[0] - ekf.state()[0]).abs() > 0.1);
}

#[test]
fn reset_empties_the_buffer() {
    use delayed_fix::in_f64::Ekf;
    let p0 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.1]];
    let q = [[0.01, 0.0, 0.0], [0.0, 0.01, 0.0], [0.0, 0.0, 0.001]];
    let mut ekf = Ekf::new(&[0.0; 3], &p0, &q, &[[0.5, 0.0], [0.0, 0.5]]).unwrap();
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
    let r = [[0.5, 0.0], [0.0, 0.5]];
    let mut stepped = Ekf::new(&[0.0, 1.0, 0.2], &p0, &q, &r).unwrap();
    let mut split = stepped;
    for k in 0..12 {
        let t = f64::from(k) * DT;
        let u = [1.0 + t, 0.1];
        let y = [t, 1.0 - t];
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
        stepped.step(&[1.0, 0.0], &[f64::NAN, 0.0]),
        Status::RejectedInput
    );
    assert_eq!(stepped, before);
}
