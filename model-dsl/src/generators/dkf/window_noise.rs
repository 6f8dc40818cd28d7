//! The least-squares window's uncertainty: how the measurement noise `R` reaches its
//! parameters through the finite differences and the solve, so that the AKF can carry it
//! instead of taking `F`, `G` and `d` as exact.
//!
//! Each equation of the window's system (eq. 8) is `a_e' theta = z_e`, its entries
//! functions of the window's outputs `y_s`; least squares solves the normal equations
//! `M theta = A' z`, `M = A' A`. Noise `v_s` on the outputs moves `theta`, to first order
//! about the noise-free window (where every equation holds), by
//! `M d(theta) = sum_s w_s v_s`, with `w_s = sum_e a_e d(z_e - a_e' theta)/dy_s` (the
//! regressors' own noise included through the derivative). With independent noise of
//! variance `R_ii` per sample of output `i`, the parameters' covariance is the sandwich
//! `C = M^-1 (sum_s R_ii w_s w_s') M^-1 = adj(M) B adj(M) / det(M)^2` (the delta method).
//! Neighbouring equations share samples, so their errors are correlated (for a second
//! difference, strongly and negatively); the sandwich keeps that, which the textbook
//! `s^2 M^-1` of independent errors would not (it overstated the cantilever's scatter
//! threefold). What first order leaves out: the bias the regressors' noise gives the
//! solution, of second order in the noise.

use super::window::{determinant, WindowTransform};
use crate::symbolic::diff::Differentiator;
use crate::symbolic::linalg::{matmul, packed_upper, Matrix};
use crate::symbolic::{substitute, Graph, Node, NodeId, VarId};

/// The error of equation `e` at the parameters' variables: `z_e - a_e' theta`.
fn equation_error(graph: &mut Graph, wt: &WindowTransform, e: usize) -> NodeId {
    let mut error = wt.rhs[e];
    for (&a, &theta) in wt.matrix[e].iter().zip(&wt.phi_params) {
        let term = graph.mul(a, theta);
        error = graph.sub(error, term);
    }
    error
}

/// The variance of one equation's error per unit of measurement noise, over the
/// measurement noise's variances `r_diagonal` (one per output) and the parameters'
/// variables: summed over the most recent equation of each row.
fn equation_variance(graph: &mut Graph, wt: &WindowTransform, r_diagonal: &[NodeId]) -> NodeId {
    let mut variance = graph.zero();
    for &e in &wt.newest_equations {
        let error = equation_error(graph, wt, e);
        for (outputs, &r) in wt.outputs.iter().zip(r_diagonal) {
            let mut gain_sq = graph.zero();
            for &y in outputs {
                let mut d = Differentiator::new(var_of(graph, y));
                let gain = d.diff(graph, error);
                let sq = graph.mul(gain, gain);
                gain_sq = graph.add(gain_sq, sq);
            }
            let term = graph.mul(r, gain_sq);
            variance = graph.add(variance, term);
        }
    }
    variance
}

/// `B = sum_s R_ii w_s w_s'` (the sandwich's filling), over the measurement noise's
/// variances `r_diagonal` and the parameters' variables.
fn noise_filling(graph: &mut Graph, wt: &WindowTransform, r_diagonal: &[NodeId]) -> Matrix {
    let np = wt.phi_params.len();
    let errors: Vec<NodeId> = (0..wt.matrix.len())
        .map(|e| equation_error(graph, wt, e))
        .collect();
    let zero = graph.zero();
    let mut filling = vec![vec![zero; np]; np];
    for (outputs, &r) in wt.outputs.iter().zip(r_diagonal) {
        for &y in outputs {
            let mut d = Differentiator::new(var_of(graph, y));
            let mut w = vec![zero; np];
            for (row, &error) in wt.matrix.iter().zip(&errors) {
                let gain = d.diff(graph, error);
                if graph.is_zero(gain) {
                    continue;
                }
                for (w_p, &a) in w.iter_mut().zip(row) {
                    let term = graph.mul(a, gain);
                    *w_p = graph.add(*w_p, term);
                }
            }
            for p in 0..np {
                let rw = graph.mul(r, w[p]);
                for q in p..np {
                    let term = graph.mul(rw, w[q]);
                    filling[p][q] = graph.add(filling[p][q], term);
                }
            }
        }
    }
    (0..np)
        .map(|p| (0..np).map(|q| filling[p.min(q)][p.max(q)]).collect())
        .collect()
}

/// The noise gain `|g|` of the most recent equation at `theta = 0` (the finite
/// differences alone), when it is a number: the design aid `WINDOW_NOISE_GAIN`.
pub fn noise_gain_at_zero(graph: &mut Graph, wt: &WindowTransform) -> Option<f64> {
    let one = graph.one();
    let ones = vec![one; wt.outputs.len()];
    let variance = equation_variance(graph, wt, &ones);
    let zero = graph.zero();
    let at_zero: Vec<(VarId, NodeId)> = wt
        .phi_params
        .iter()
        .map(|&p| (var_of(graph, p), zero))
        .collect();
    let variance = substitute(graph, variance, &at_zero);
    graph.constant_value(variance).map(f64::sqrt)
}

/// The least-squares parameters' covariance `adj(M) B adj(M) / det(M)^2` (packed upper
/// triangle), with `M = A' A` the normal matrix, `det` its determinant and `r_diagonal`
/// the measurement noise's variances, over the parameters' variables.
pub fn parameter_covariance(
    graph: &mut Graph,
    wt: &WindowTransform,
    normal: &Matrix,
    det: NodeId,
    r_diagonal: &[NodeId],
) -> Vec<NodeId> {
    let np = normal.len();
    let filling = noise_filling(graph, wt, r_diagonal);
    let adjugate: Matrix = (0..np)
        .map(|p| (0..np).map(|q| cofactor(graph, normal, q, p)).collect())
        .collect();
    let left = matmul(graph, &adjugate, &filling);
    let sandwich = matmul(graph, &left, &adjugate);
    let det_sq = graph.mul(det, det);
    packed_upper(&sandwich)
        .into_iter()
        .map(|entry| graph.div(entry, det_sq))
        .collect()
}

/// The cofactor `(-1)^(i+j) det(M without row i and column j)`.
fn cofactor(graph: &mut Graph, m: &Matrix, i: usize, j: usize) -> NodeId {
    let n = m.len();
    let rows: Vec<usize> = (0..n).filter(|&r| r != i).collect();
    let cols: Vec<usize> = (0..n).filter(|&c| c != j).collect();
    let minor = determinant(graph, m, &rows, &cols);
    if (i + j).is_multiple_of(2) {
        minor
    } else {
        let zero = graph.zero();
        graph.sub(zero, minor)
    }
}

/// The variable a variable node stands for.
fn var_of(graph: &Graph, node: NodeId) -> VarId {
    match graph.node(node) {
        Node::Var(v) => v,
        other => unreachable!("the window's values are variables, not {other:?}"),
    }
}
