//! The cantilever's EKF, DKF and LQR written plainly with nalgebra fixed-size `f32`
//! matrices: the baseline the generated code is measured against in the same firmware.
//! Same algorithms, index convention and Joseph form as the generated code; no structure
//! exploited beyond what the algorithm states.

use nalgebra::{Matrix2, Matrix3, Matrix5, RowVector2, RowVector5, Vector2, Vector3, Vector5};

const TS: f32 = 0.015;

fn f(x: &Vector5<f32>, u: f32) -> Vector5<f32> {
    Vector5::new(
        x[0] + TS * x[1],
        TS * x[0] * x[2] + (1.0 + TS * x[3]) * x[1] + TS * x[4] * u,
        x[2],
        x[3],
        x[4],
    )
}

fn jacobian(x: &Vector5<f32>, u: f32) -> Matrix5<f32> {
    let mut a = Matrix5::identity();
    a[(0, 1)] = TS;
    a[(1, 0)] = TS * x[2];
    a[(1, 1)] = 1.0 + TS * x[3];
    a[(1, 2)] = TS * x[0];
    a[(1, 3)] = TS * x[1];
    a[(1, 4)] = TS * u;
    a
}

/// The measurement update with `y = x1`, Joseph form; `None` if `S <= 0`.
fn update(
    x: &Vector5<f32>,
    p: &Matrix5<f32>,
    y: f32,
    r: f32,
) -> Option<(Vector5<f32>, Matrix5<f32>)> {
    let c = RowVector5::new(1.0, 0.0, 0.0, 0.0, 0.0);
    let s = (c * p * c.transpose())[0] + r;
    if s.is_nan() || s <= 0.0 {
        return None;
    }
    let k = p * c.transpose() / s;
    let x = x + k * (y - (c * x)[0]);
    let i_kc = Matrix5::identity() - k * c;
    let p = i_kc * p * i_kc.transpose() + k * r * k.transpose();
    Some((x, p))
}

/// Alg. 1.
pub struct Ekf {
    x: Vector5<f32>,
    p: Matrix5<f32>,
    q: Matrix5<f32>,
    r: f32,
}

impl Ekf {
    /// A filter from `x0`, diagonal `p0` and `q`, and `r`.
    pub fn new(x0: [f32; 5], p0: [f32; 5], q: [f32; 5], r: f32) -> Ekf {
        Ekf {
            x: Vector5::from(x0),
            p: Matrix5::from_diagonal(&Vector5::from(p0)),
            q: Matrix5::from_diagonal(&Vector5::from(q)),
            r,
        }
    }

    /// One sample; false if the update was refused.
    pub fn step(&mut self, u_prev: f32, y: f32) -> bool {
        let a = jacobian(&self.x, u_prev);
        let p = a * self.p * a.transpose() + self.q;
        let x = f(&self.x, u_prev);
        match update(&x, &p, y, self.r) {
            Some((x, p)) => {
                self.x = x;
                self.p = p;
                true
            }
            None => false,
        }
    }
}

/// Alg. 2 with the window transform written out for this model (eqs. 8-12).
pub struct Dkf {
    ys: [f32; 5],
    us: [f32; 4],
    filled: usize,
    params: Vector3<f32>,
    xbar: Vector5<f32>,
    pbar: Matrix5<f32>,
    qbar: Matrix5<f32>,
    x: Vector5<f32>,
    p: Matrix5<f32>,
    q: Matrix5<f32>,
    r: f32,
}

impl Dkf {
    /// Both stages from `x0`, diagonal covariances and noises.
    pub fn new(x0: [f32; 5], p0: [f32; 5], q: [f32; 5], r: f32) -> Dkf {
        let p0 = Matrix5::from_diagonal(&Vector5::from(p0));
        let q = Matrix5::from_diagonal(&Vector5::from(q));
        Dkf {
            ys: [0.0; 5],
            us: [0.0; 4],
            filled: 0,
            params: Vector3::new(x0[2], x0[3], x0[4]),
            xbar: Vector5::from(x0),
            pbar: p0,
            qbar: q,
            x: Vector5::from(x0),
            p: p0,
            q,
            r,
        }
    }

    /// `phi` from the window `ys = y[k-4..=k]`, `us = u[k-4..k-1]` (oldest first).
    fn phi(&mut self) -> Vector5<f32> {
        if self.filled < 5 {
            return self.xbar;
        }
        let (y, u) = (&self.ys, &self.us);
        let dy = |j: usize| (y[j] - y[j - 1]) / TS;
        // Rows for j = k, k-1, k-2: dy[j] - dy[j-1] = TS (y[j-2] x3 + dy[j-1] x4 + u[j-2] x5).
        let m = Matrix3::from_fn(|r, c| {
            let j = 4 - r;
            TS * match c {
                0 => y[j - 2],
                1 => dy(j - 1),
                _ => u[j - 2],
            }
        });
        let b = Vector3::from_fn(|r, _| dy(4 - r) - dy(3 - r));
        let det = m.determinant();
        let norms =
            m.column(0).norm_squared() * m.column(1).norm_squared() * m.column(2).norm_squared();
        if det * det > 1e-12 * norms {
            if let Some(solution) = m.lu().solve(&b) {
                self.params = solution;
            }
        }
        let [p3, p4, p5]: [f32; 3] = self.params.into();
        let phi2 = TS * y[3] * p3 + (1.0 + TS * p4) * dy(4) + TS * p5 * u[3];
        Vector5::new(y[4], phi2, p3, p4, p5)
    }

    /// One sample (Alg. 2); false if an update was refused.
    pub fn step(&mut self, u_prev: f32, y: f32) -> bool {
        let phi = self.phi();
        // eq. (12) with eta = 0.5
        let mut fm = Matrix5::identity();
        fm[(0, 1)] = TS;
        fm[(1, 0)] = 0.5 * TS * phi[2];
        fm[(1, 1)] = 1.0 + 0.5 * TS * phi[3];
        fm[(1, 2)] = 0.5 * TS * phi[0];
        fm[(1, 3)] = 0.5 * TS * phi[1];
        fm[(1, 4)] = 0.5 * TS * u_prev;
        let g = Vector5::new(0.0, 0.5 * TS * phi[4], 0.0, 0.0, 0.0);
        let xbar_pred = fm * self.xbar + g * u_prev;
        let pbar_pred = fm * self.pbar * fm.transpose() + self.qbar;
        let a = jacobian(&self.xbar, u_prev);
        let x_pred = f(&self.xbar, u_prev) + a * (self.x - self.xbar);
        let p_pred = a * self.p * a.transpose() + self.q;
        let akf = update(&xbar_pred, &pbar_pred, y, self.r);
        let lkf = update(&x_pred, &p_pred, y, self.r);
        self.ys = [self.ys[1], self.ys[2], self.ys[3], self.ys[4], y];
        self.us = [self.us[1], self.us[2], self.us[3], u_prev];
        self.filled = (self.filled + 1).min(5);
        match (akf, lkf) {
            (Some((xbar, pbar)), Some((x, p))) => {
                self.xbar = xbar;
                self.pbar = pbar;
                self.x = x;
                self.p = p;
                true
            }
            _ => false,
        }
    }

    /// The estimate.
    pub fn state(&self) -> [f32; 5] {
        self.x.into()
    }
}

/// Alg. 3: the gain after `n` Riccati steps from `P = Q`.
pub fn lqr_gain(x: &[f32; 5], n: u32, q: Matrix2<f32>, r: f32) -> Option<RowVector2<f32>> {
    let a = Matrix2::new(1.0, TS, TS * x[2], 1.0 + TS * x[3]);
    let b = Vector2::new(0.0, TS * x[4]);
    let gain = |p: &Matrix2<f32>| {
        let s = r + (b.transpose() * p * b)[0];
        (s > 0.0).then(|| b.transpose() * p * a / s)
    };
    let mut p = q;
    for _ in 0..n {
        let k = gain(&p)?;
        p = a.transpose() * p * a - a.transpose() * p * b * k + q;
    }
    gain(&p)
}
