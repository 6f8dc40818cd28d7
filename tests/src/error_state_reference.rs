//! An independent dense `f64` error-state EKF (Solà, "Quaternion kinematics for the
//! error-state Kalman filter", 2017, sect. 7, with global angular errors), for a model
//! given as closures: the nominal `f` (the state vector to the next, its input bound by
//! the caller) and `h` (the state vector to the outputs). A rotation is stored as a unit
//! quaternion `[x, y, z, w]`; the covariance is over the tangent space, where a
//! rotation's error `δθ` is a rotation vector in the earth frame: the true rotation is
//! `Exp(δθ) ⊗ q`.
//!
//! Written from the paper's equations with `nalgebra`'s `UnitQuaternion` (`Exp` is
//! `from_scaled_axis`, `Log` is `scaled_axis`) and dense matrices; nothing comes from the
//! code generator or the project's geometry, so tests can check generated filters against
//! it. Its Jacobians are not derived: they are central differences on the manifold,
//!
//! ```text
//! F[:, j] = ((f(x ⊞ ε e_j) ⊟ f(x)) - (f(x ⊞ -ε e_j) ⊟ f(x))) / 2ε
//! H[:, j] = (h(x ⊞ ε e_j) - h(x ⊞ -ε e_j)) / 2ε
//! ```
//!
//! with `x ⊞ δ` the retraction (`x + δ`, a rotation `Exp(δθ) ⊗ q`) and `y ⊟ x` its
//! inverse (`y - x`, a rotation `Log(q_y ⊗ q_x⁻¹)`). Their error is the truncation
//! `ε² |g'''| / 6` plus the rounding `u |g| / ε` (`u` = 1.1e-16): at [`STEP`] = 1e-5 and
//! a model whose `g` and derivatives are of the order of its values, about 2e-11 and 1e-11
//! of the Jacobian's scale, so the reference's results carry a relative error of order
//! 1e-10 (more where the innovation covariance is ill-conditioned).
//!
//! The filter: predict `x = f(x)`, `P = F P F' + Q`; update `δx = K (y - h(x))` with
//! `K = P H' S⁻¹`, `S = H P H' + R` inverted densely, `P = (I - K H) P (I - K H)' + K R K'`
//! (Joseph form), then the injection `x = x ⊞ δx` and the reset `P = G P G'`, `G` the
//! identity but for each rotation's block `I + [δθ/2]×` (Solà eq. 287, global errors).

use nalgebra::{DMatrix, DVector, Matrix3, Quaternion, UnitQuaternion, Vector3};

/// The central differences' step: near the optimum `(3 u)^(1/3)` ≈ 7e-6 of a function
/// whose values and third derivatives are of one order. (`from_scaled_axis` is the
/// identity for an angle up to 4.4e-16, far below it.)
pub const STEP: f64 = 1e-5;

/// How far a given rotation's norm may be from one before `reset` refuses it.
pub const NORM_TOLERANCE: f64 = 0.01;

/// Where a state vector's rotations are.
#[derive(Clone, Debug)]
pub struct Layout {
    /// Length of the state vector, four entries per rotation.
    pub n_x: usize,
    /// Index of each rotation's first entry (`x` of `[x, y, z, w]`), increasing.
    pub rotations: Vec<usize>,
}

/// One part of the state vector: a scalar or a rotation, at `storage` in the state
/// vector and `tangent` in the tangent space.
#[derive(Clone, Copy, Debug)]
enum Part {
    Scalar { storage: usize, tangent: usize },
    Rotation { storage: usize, tangent: usize },
}

impl Layout {
    /// The tangent space's dimension: three per rotation, one per other entry.
    pub fn n_p(&self) -> usize {
        self.n_x - self.rotations.len()
    }

    /// The parts, in order.
    fn parts(&self) -> Vec<Part> {
        let mut parts = Vec::new();
        let (mut storage, mut tangent) = (0, 0);
        while storage < self.n_x {
            if self.rotations.contains(&storage) {
                parts.push(Part::Rotation { storage, tangent });
                (storage, tangent) = (storage + 4, tangent + 3);
            } else {
                parts.push(Part::Scalar { storage, tangent });
                (storage, tangent) = (storage + 1, tangent + 1);
            }
        }
        parts
    }

    /// `x ⊞ δ`: `x + δ` for a scalar, `Exp(δθ) ⊗ q` for a rotation.
    pub fn retract(&self, x: &DVector<f64>, delta: &DVector<f64>) -> DVector<f64> {
        let mut next = x.clone();
        for part in self.parts() {
            match part {
                Part::Scalar { storage, tangent } => next[storage] += delta[tangent],
                Part::Rotation { storage, tangent } => {
                    let theta = delta.fixed_rows::<3>(tangent).into_owned();
                    let turned = UnitQuaternion::from_scaled_axis(theta) * rotation(x, storage);
                    store_rotation(&mut next, storage, &turned);
                }
            }
        }
        next
    }

    /// `y ⊟ x`, the error that takes `x` to `y`: `y - x` for a scalar, `Log(q_y ⊗ q_x⁻¹)`
    /// for a rotation.
    pub fn local(&self, y: &DVector<f64>, x: &DVector<f64>) -> DVector<f64> {
        let mut delta = DVector::zeros(self.n_p());
        for part in self.parts() {
            match part {
                Part::Scalar { storage, tangent } => delta[tangent] = y[storage] - x[storage],
                Part::Rotation { storage, tangent } => {
                    let error = rotation(y, storage) * rotation(x, storage).inverse();
                    delta
                        .fixed_rows_mut::<3>(tangent)
                        .copy_from(&error.scaled_axis());
                }
            }
        }
        delta
    }

    /// The reset Jacobian after injecting `delta`: the identity but for each rotation's
    /// block `I + [δθ/2]×`.
    pub fn reset_jacobian(&self, delta: &DVector<f64>) -> DMatrix<f64> {
        let mut g = DMatrix::identity(self.n_p(), self.n_p());
        for part in self.parts() {
            if let Part::Rotation { tangent, .. } = part {
                let half = delta.fixed_rows::<3>(tangent) / 2.0;
                let block = Matrix3::identity() + half.cross_matrix();
                g.fixed_view_mut::<3, 3>(tangent, tangent).copy_from(&block);
            }
        }
        g
    }

    /// `x` with each rotation divided by its norm; `None` if a norm is not within
    /// [`NORM_TOLERANCE`] of one.
    pub fn normalised(&self, x: &DVector<f64>) -> Option<DVector<f64>> {
        let mut unit = x.clone();
        for &storage in &self.rotations {
            let mut q = unit.fixed_rows_mut::<4>(storage);
            let norm = q.norm();
            if (norm - 1.0).abs() > NORM_TOLERANCE {
                return None;
            }
            q /= norm;
        }
        Some(unit)
    }
}

/// The rotation stored at `storage` in `x` (`[x, y, z, w]`), normalised.
pub fn rotation(x: &DVector<f64>, storage: usize) -> UnitQuaternion<f64> {
    let [i, j, k, w] = [0, 1, 2, 3].map(|a| x[storage + a]);
    UnitQuaternion::from_quaternion(Quaternion::new(w, i, j, k))
}

/// Stores `q` at `storage` in `x` as `[x, y, z, w]`.
pub fn store_rotation(x: &mut DVector<f64>, storage: usize, q: &UnitQuaternion<f64>) {
    let c = q.quaternion().coords;
    x.fixed_rows_mut::<4>(storage).copy_from(&c);
}

/// A 3-vector from three entries of `x` starting at `first`.
pub fn vector(x: &DVector<f64>, first: usize) -> Vector3<f64> {
    x.fixed_rows::<3>(first).into_owned()
}

/// The central difference, column by column, of `g` at zero over `n` coordinates.
fn central_difference(n: usize, g: impl Fn(&DVector<f64>) -> DVector<f64>) -> DMatrix<f64> {
    let columns: Vec<DVector<f64>> = (0..n)
        .map(|j| {
            let step = DVector::from_fn(n, |i, _| if i == j { STEP } else { 0.0 });
            (g(&step) - g(&-step)) / (2.0 * STEP)
        })
        .collect();
    DMatrix::from_columns(&columns)
}

/// `F = d(f(x ⊞ δ) ⊟ f(x))/dδ` at zero, by central differences.
pub fn tangent_jacobian_f(
    layout: &Layout,
    f: &dyn Fn(&DVector<f64>) -> DVector<f64>,
    x: &DVector<f64>,
) -> DMatrix<f64> {
    let fx = f(x);
    central_difference(layout.n_p(), |delta| {
        layout.local(&f(&layout.retract(x, delta)), &fx)
    })
}

/// `H = d h(x ⊞ δ)/dδ` at zero, by central differences.
pub fn tangent_jacobian_h(
    layout: &Layout,
    h: &dyn Fn(&DVector<f64>) -> DVector<f64>,
    x: &DVector<f64>,
) -> DMatrix<f64> {
    central_difference(layout.n_p(), |delta| h(&layout.retract(x, delta)))
}

/// The error-state EKF's estimate, covariance and noise covariances.
#[derive(Clone, Debug)]
pub struct Eskf {
    /// Where the state's rotations are.
    pub layout: Layout,
    /// The estimate, rotations as unit quaternions.
    pub x: DVector<f64>,
    /// Its covariance over the tangent space.
    pub p: DMatrix<f64>,
    /// The process noise covariance, over the tangent space.
    pub q: DMatrix<f64>,
    /// The measurement noise covariance of all outputs.
    pub r: DMatrix<f64>,
}

/// What an update saw: the innovation `y - h(x)` and its normalised square.
#[derive(Clone, Debug)]
pub struct Innovation {
    /// `y - h(x)`, of the outputs updated with.
    pub residual: DVector<f64>,
    /// `r' S⁻¹ r`.
    pub nis: f64,
}

impl Eskf {
    /// `x = f(x)`, `P = F P F' + Q`.
    pub fn predict(&mut self, f: &dyn Fn(&DVector<f64>) -> DVector<f64>) {
        let a = tangent_jacobian_f(&self.layout, f, &self.x);
        self.x = f(&self.x);
        self.p = &a * &self.p * a.transpose() + &self.q;
    }

    /// The update with the measurement `y` of the outputs `outputs` of `h` (their rows
    /// of `h`, `H` and `R`): the error's estimate, its injection and the reset.
    pub fn update(
        &mut self,
        h: &dyn Fn(&DVector<f64>) -> DVector<f64>,
        y: &DVector<f64>,
        outputs: &[usize],
    ) -> Innovation {
        let all = tangent_jacobian_h(&self.layout, h, &self.x);
        let c = all.select_rows(outputs);
        let r = self.r.select_rows(outputs).select_columns(outputs);
        let residual = y - h(&self.x).select_rows(outputs);
        let s = &c * &self.p * c.transpose() + &r;
        let s_inverse = s.try_inverse().expect("a positive definite S");
        let k = &self.p * c.transpose() * &s_inverse;
        let delta = &k * &residual;
        let i_kc = DMatrix::identity(self.layout.n_p(), self.layout.n_p()) - &k * &c;
        let joseph = &i_kc * &self.p * i_kc.transpose() + &k * &r * k.transpose();
        let g = self.layout.reset_jacobian(&delta);
        self.x = self.layout.retract(&self.x, &delta);
        self.p = &g * joseph * g.transpose();
        let nis = (residual.transpose() * &s_inverse * &residual)[(0, 0)];
        Innovation { residual, nis }
    }

    /// Starts again from `x0` (its rotations normalised) and `p0`; `None`, leaving the
    /// filter as it was, if a rotation's norm is not within [`NORM_TOLERANCE`] of one.
    pub fn reset(&mut self, x0: &DVector<f64>, p0: &DMatrix<f64>) -> Option<()> {
        self.x = self.layout.normalised(x0)?;
        self.p = p0.clone();
        Some(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `[a, q_x, q_y, q_z, q_w, b]`: a rotation between two scalars.
    fn layout() -> Layout {
        Layout {
            n_x: 6,
            rotations: vec![1],
        }
    }

    fn point() -> DVector<f64> {
        let q = UnitQuaternion::from_scaled_axis(Vector3::new(0.3, -1.2, 0.7));
        let mut x = DVector::from_vec(vec![2.0, 0.0, 0.0, 0.0, 0.0, -1.0]);
        store_rotation(&mut x, 1, &q);
        x
    }

    #[test]
    fn local_undoes_retract() {
        let (layout, x) = (layout(), point());
        let delta = DVector::from_vec(vec![0.5, 0.1, -0.2, 0.3, -0.25]);
        let back = layout.local(&layout.retract(&x, &delta), &x);
        assert!((back - delta).norm() < 1e-15);
    }

    /// The reset's block is the derivative of the error after the injection,
    /// `Log(Exp(δθ) ⊗ Exp(-δθ̂))`, with respect to `δθ` at `δθ̂`, to first order in `δθ̂`
    /// (the exact one is the left Jacobian of `δθ̂`, `I + [δθ̂]×/2 + O(|δθ̂|²)`): the sign
    /// of the skew part is the global errors'.
    #[test]
    fn the_reset_block_is_the_derivative_of_the_error_after_injection() {
        let injected = Vector3::new(2e-3, -1e-3, 3e-3);
        let after = |theta: &DVector<f64>| -> DVector<f64> {
            let v = vector(theta, 0) + injected;
            let q =
                UnitQuaternion::from_scaled_axis(v) * UnitQuaternion::from_scaled_axis(-injected);
            DVector::from_column_slice(q.scaled_axis().as_slice())
        };
        let numeric = central_difference(3, after);
        let layout = Layout {
            n_x: 4,
            rotations: vec![0],
        };
        let delta = DVector::from_column_slice(injected.as_slice());
        let g = layout.reset_jacobian(&delta);
        let second_order = injected.norm_squared();
        assert!((&numeric - &g).amax() < second_order, "{numeric} {g}");
        let flipped = Matrix3::identity() - (injected / 2.0).cross_matrix();
        let flipped = DMatrix::from_column_slice(3, 3, flipped.as_slice());
        assert!((numeric - flipped).amax() > 10.0 * second_order);
    }

    /// The central differences of a map whose derivative is known: `h(x) = R(q)' v`,
    /// whose derivative under `Exp(δθ) ⊗ q` is `R(q)' [v]×`.
    #[test]
    fn central_differences_give_a_known_derivative() {
        let (layout, x) = (layout(), point());
        let v = Vector3::new(0.21, 0.0, 0.45);
        let h = |x: &DVector<f64>| -> DVector<f64> {
            let turned = rotation(x, 1).inverse_transform_vector(&v);
            DVector::from_column_slice(turned.as_slice())
        };
        let numeric = tangent_jacobian_h(&layout, &h, &x);
        let exact = rotation(&x, 1).to_rotation_matrix().matrix().transpose() * v.cross_matrix();
        let block = numeric.view((0, 1), (3, 3));
        assert!((block - exact).amax() < 1e-10 * v.norm());
        assert!(numeric.column(0).amax() < 1e-12 && numeric.column(4).amax() < 1e-12);
    }
}
