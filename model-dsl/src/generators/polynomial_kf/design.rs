//! The polynomial Kalman filter's stages (Shults, Brubaker and Lee, "A fast algorithm for
//! control and estimation using a polynomial state-space structure"): the check that a
//! model is the polynomial family, the window fit's constant matrix (a pseudo-inverse
//! computed once), and the recursive step (prediction with `Phi(1)`, eq. 5-6, and the
//! Joseph-form update, eq. 7-9) as graph nodes.

use super::spec::PolynomialKfSpec;
use crate::model::Model;
use crate::numerics::{pinv, Mat};
use crate::symbolic::graph::{Graph, NodeId};
use crate::symbolic::kalman::{self, Update};
use crate::symbolic::linalg::Matrix;
use crate::symbolic::ModelGraph;

/// `Phi(1)` of eq. (4) for order `m`: entry `(i, j)` is `C(j, i)` for `j >= i` (the
/// Taylor series of `x_i = T^i / i! z^(i)` over one sample), an upper Pascal matrix.
pub fn transition(order: usize) -> Vec<Vec<f64>> {
    let n = order + 1;
    let mut phi = vec![vec![0.0; n]; n];
    for i in 0..n {
        phi[i][i] = 1.0;
        for j in i + 1..n {
            // C(j, i) = C(j - 1, i - 1) + C(j - 1, i)
            let above = if i == 0 { 0.0 } else { phi[i - 1][j - 1] };
            phi[i][j] = above + phi[i][j - 1];
        }
    }
    phi
}

/// Checks that `model` is the polynomial family of `spec`'s order: `order + 1` states,
/// no parameters, inputs or time, one output measuring the first state, and the step
/// `x[k+1] = Phi(1) x[k]` exactly. Says what differs otherwise.
pub fn check_family(
    model: &Model,
    spec: &PolynomialKfSpec,
    mg: &mut ModelGraph,
) -> Result<(), String> {
    let n = spec.order + 1;
    if model.states.len() != n || !model.params.is_empty() {
        return Err(format!(
            "a polynomial of order {} has {n} states (z, T z', .., T^m/m! z^(m)) and no \
             parameters; this model has {} states and {} parameters",
            spec.order,
            model.states.len(),
            model.params.len()
        ));
    }
    if !model.inputs.is_empty() || model.uses_time() {
        return Err("the polynomial model has no input and does not use the time `t`".into());
    }
    let c = mg.jacobian_h_wrt_x();
    let first_state: Vec<f64> = (0..n).map(|j| if j == 0 { 1.0 } else { 0.0 }).collect();
    let measures_first = c.len() == 1
        && c[0]
            .iter()
            .zip(&first_state)
            .all(|(&e, &want)| mg.graph.constant_value(e) == Some(want))
        && mg.graph.eval(mg.h[0], &|_| 0.0) == 0.0;
    if !measures_first {
        return Err(format!(
            "the polynomial filter measures the position: the model needs one output `y = {}`",
            model.states[0].name
        ));
    }
    let a = mg.jacobian_f_wrt_x();
    let phi = transition(spec.order);
    for (i, row) in a.iter().enumerate() {
        for (j, &entry) in row.iter().enumerate() {
            let value = mg.graph.constant_value(entry);
            if value != Some(phi[i][j]) {
                let found = value.map_or("a non-constant term".to_string(), |v| v.to_string());
                return Err(format!(
                    "the step of `{}` is not row {} of the transition Phi(1) of eq. (4): \
                     its coefficient of `{}` is {found}, not {}",
                    model.states[i].name,
                    i + 1,
                    model.states[j].name,
                    phi[i][j]
                ));
            }
        }
    }
    let offset = mg.f.iter().map(|&f| mg.graph.eval(f, &|_| 0.0));
    if offset.into_iter().any(|v| v != 0.0) {
        return Err("the polynomial step is linear: it has no constant term".into());
    }
    Ok(())
}

/// The non-recursive filter used to re-initialise: `x = W [y[k-N+1], .., y[k]]` is the
/// least-squares polynomial through the window, evaluated at its newest sample, and
/// `P = sigma^2 W W'` its covariance for white measurement noise of variance `sigma^2`.
pub struct WindowFit {
    /// `(m + 1) x N`, oldest sample first.
    pub gain: Mat,
    /// `(m + 1) x (m + 1)`.
    pub covariance: Mat,
}

/// The window fit of `spec`. With `h` the sample offset from the newest sample
/// (`-(N-1) ..= 0`), `z(h) = sum_j x_j h^j` (eq. 2-3), so `x = pinv(H) y` with `H[i][j] =
/// h_i^j`. Time is scaled by `N - 1` for the pseudo-inverse (a Vandermonde matrix in raw
/// samples is ill-conditioned) and the coefficients scaled back.
pub fn window_fit(spec: &PolynomialKfSpec) -> WindowFit {
    let (n, window) = (spec.order + 1, spec.window);
    let span = (window.max(2) - 1) as f64;
    let rows: Vec<Vec<f64>> = (0..window)
        .map(|i| {
            let tau = (i as f64 - (window - 1) as f64) / span;
            (0..n).map(|j| tau.powi(j as i32)).collect()
        })
        .collect();
    let mut gain = pinv(&Mat::from_rows(&rows));
    for j in 0..n {
        let largest = (0..window).fold(0.0_f64, |m, i| m.max(gain[(j, i)].abs()));
        for i in 0..window {
            // A coefficient that is zero by symmetry (the middle sample's weight in an odd
            // derivative) comes out as rounding noise; it is exactly zero.
            if gain[(j, i)].abs() < 1e-12 * largest {
                gain[(j, i)] = 0.0;
            }
            gain[(j, i)] /= span.powi(j as i32);
        }
    }
    let covariance = (&gain * &gain.t()).scale(spec.noise_variance).symmetrised();
    WindowFit { gain, covariance }
}

/// The prediction as nodes: `x = Phi x`, `S1 = Phi S Phi' + f I` (eq. 5-6).
pub fn predict(
    g: &mut Graph,
    spec: &PolynomialKfSpec,
    x: &[NodeId],
    p: &Matrix,
) -> (Vec<NodeId>, Matrix) {
    let n = spec.order + 1;
    let phi: Matrix = transition(spec.order)
        .iter()
        .map(|row| row.iter().map(|&v| g.num(v)).collect())
        .collect();
    let (zero, fading) = (g.zero(), g.num(spec.fading));
    let q: Matrix = (0..n)
        .map(|i| (0..n).map(|j| if i == j { fading } else { zero }).collect())
        .collect();
    let p_pred = kalman::predict_covariance(g, &phi, p, &q);
    let x_pred: Vec<NodeId> = phi
        .iter()
        .map(|row| crate::symbolic::linalg::dot(g, row, x))
        .collect();
    (x_pred, p_pred)
}

/// One recursive step as nodes: the prediction ([`predict`]), then the Joseph-form update
/// with `M = [1 0 .. 0]` and `sigma^2` (eq. 7-9; the Joseph form equals eq. 8 for the
/// optimal gain and keeps `S` symmetric and positive in `f32`). Returns the update and the
/// innovation `y - x_pred[0]`.
pub fn step(
    g: &mut Graph,
    spec: &PolynomialKfSpec,
    x: &[NodeId],
    p: &Matrix,
    measured: NodeId,
    reciprocal: impl FnMut(&mut Graph, usize) -> NodeId,
) -> (Update, NodeId) {
    let n = spec.order + 1;
    let (x_pred, p_pred) = predict(g, spec, x, p);
    let zero = g.zero();
    let one = g.one();
    let m: Matrix = vec![(0..n).map(|j| if j == 0 { one } else { zero }).collect()];
    let r = vec![vec![g.num(spec.noise_variance)]];
    let residual = g.sub(measured, x_pred[0]);
    let update = kalman::update(g, &x_pred, &p_pred, &[residual], &m, &r, reciprocal);
    (update, residual)
}
