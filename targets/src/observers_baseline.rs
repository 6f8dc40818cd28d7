//! The same observers written plainly with nalgebra fixed-size `f32` matrices, as a
//! careful engineer would without the generator: the baseline of the cost table. Their
//! matrices come from the generated constants (the design is not what is measured).

use generated_demo::piecewise_beam::{
    LinearErrorObserver, OUTPUT_C, REGIME_A, REGIME_B, REGIME_OFFSET,
};
use generated_demo::polynomial::{PolynomialKf as Generated, FADE, SIGMA2};
use nalgebra::{Matrix2x6, Matrix4, Matrix6, Matrix6x2, SMatrix, Vector2, Vector4, Vector6};

/// `x = F_i x + B_i u + c_i + K_i y`, `F_i = A_i - K_i C`, regime from `y_mid > 0`.
pub struct SwitchedObserver {
    f: [Matrix6<f32>; 2],
    b: [Vector6<f32>; 2],
    c: [Vector6<f32>; 2],
    k: [Matrix6x2<f32>; 2],
    x: Vector6<f32>,
}

impl SwitchedObserver {
    /// From a zero estimate.
    pub fn new() -> Self {
        let c = Matrix2x6::from_fn(|i, j| OUTPUT_C[i][j]);
        let k = [0, 1].map(|i| Matrix6x2::from_fn(|r, s| LinearErrorObserver::GAINS[i][r][s]));
        let a = [0, 1].map(|i| Matrix6::from_fn(|r, s| REGIME_A[i][r][s]));
        SwitchedObserver {
            f: [a[0] - k[0] * c, a[1] - k[1] * c],
            b: [0, 1].map(|i| Vector6::from_fn(|r, _| REGIME_B[i][r][0])),
            c: [0, 1].map(|i| Vector6::from_fn(|r, _| REGIME_OFFSET[i][r])),
            k,
            x: Vector6::zeros(),
        }
    }

    /// One sample.
    pub fn step(&mut self, u: f32, y: &[f32; 2]) {
        let i = usize::from(y[1] > 0.0);
        self.x = self.f[i] * self.x + self.b[i] * u + self.c[i] + self.k[i] * Vector2::from(*y);
    }
}

/// The polynomial Kalman filter of eq. (5)-(9) with the window fit every 100 samples.
pub struct PolynomialKf {
    phi: Matrix4<f32>,
    fit: SMatrix<f32, 4, 25>,
    fit_covariance: Matrix4<f32>,
    x: Vector4<f32>,
    s: Matrix4<f32>,
    window: [f32; 25],
    filled: usize,
    since: usize,
}

impl PolynomialKf {
    /// From a zero estimate and covariance `p0`.
    pub fn new(p0: &[[f32; 4]; 4]) -> Self {
        PolynomialKf {
            phi: Matrix4::new(
                1.0, 1.0, 1.0, 1.0, 0.0, 1.0, 2.0, 3.0, 0.0, 0.0, 1.0, 3.0, 0.0, 0.0, 0.0, 1.0,
            ),
            fit: SMatrix::from_fn(|i, j| Generated::FIT_GAIN[i][j]),
            fit_covariance: Matrix4::from_fn(|i, j| Generated::FIT_COVARIANCE[i][j]),
            x: Vector4::zeros(),
            s: Matrix4::from_fn(|i, j| p0[i][j]),
            window: [0.0; 25],
            filled: 0,
            since: 0,
        }
    }

    /// One sample.
    pub fn step(&mut self, y: f32) {
        self.window.copy_within(1.., 0);
        self.window[24] = y;
        self.filled = (self.filled + 1).min(25);
        self.since += 1;
        if self.since >= 100 && self.filled == 25 {
            self.x = self.fit * SMatrix::<f32, 25, 1>::from_column_slice(&self.window);
            self.s = self.fit_covariance;
            self.since = 0;
            return;
        }
        let x1 = self.phi * self.x;
        let s1 = self.phi * self.s * self.phi.transpose() + Matrix4::identity() * FADE;
        let k = s1.column(0) / (SIGMA2 + s1[(0, 0)]);
        let mut ikm = Matrix4::<f32>::identity();
        for i in 0..4 {
            ikm[(i, 0)] -= k[i];
        }
        self.s = ikm * s1;
        self.x = x1 + k * (y - x1[0]);
    }
}
