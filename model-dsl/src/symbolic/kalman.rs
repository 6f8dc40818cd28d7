//! The Kalman filter's algebra on graph nodes, shared by every generated filter: the
//! covariance prediction and the Joseph-form measurement update (Alg. 1 and 2).

use super::graph::{Graph, NodeId};
use super::linalg::{
    add, identity, ldl_inverse, matmul, sandwich_symmetric, sub, transpose, Matrix,
};

/// `A P A' + Q`, upper triangle computed once.
pub fn predict_covariance(g: &mut Graph, a: &Matrix, p: &Matrix, q: &Matrix) -> Matrix {
    let apa = sandwich_symmetric(g, a, p, a);
    add(g, &apa, q)
}

/// A measurement update, as nodes.
pub struct Update {
    /// The corrected estimate.
    pub x: Vec<NodeId>,
    /// The corrected covariance (symmetric; both triangles filled).
    pub p: Matrix,
    /// Pivots of the innovation covariance; each must be checked positive before its
    /// reciprocal variable is bound.
    pub pivots: Vec<NodeId>,
    /// Variables standing for the pivots' reciprocals.
    pub reciprocals: Vec<NodeId>,
}

/// The update of estimate `x`, covariance `p` with innovation `residual = y - h(x)`,
/// measurement Jacobian `c` and noise `r`: `K = P C' S^-1` with `S = C P C' + R` inverted
/// through guarded pivots (`reciprocal(graph, j)` declares the variable for `1 / d_j`),
/// and the Joseph form `P = (I - K C) P (I - K C)' + K R K'`.
pub fn update(
    g: &mut Graph,
    x: &[NodeId],
    p: &Matrix,
    residual: &[NodeId],
    c: &Matrix,
    r: &Matrix,
    reciprocal: impl FnMut(&mut Graph, usize) -> NodeId,
) -> Update {
    let n = x.len();
    // P C' is shared by S and the gain.
    let pct = matmul(g, p, &transpose(c));
    let cpct = matmul(g, c, &pct);
    let s = add(g, &cpct, r);
    let ldl = ldl_inverse(g, &s, reciprocal);
    let k = matmul(g, &pct, &ldl.inverse);
    let innovation: Matrix = residual.iter().map(|&e| vec![e]).collect();
    let correction = matmul(g, &k, &innovation);
    let x_new = x
        .iter()
        .zip(&correction)
        .map(|(&xi, dx)| g.add(xi, dx[0]))
        .collect();
    let eye = identity(g, n);
    let kc = matmul(g, &k, c);
    let i_kc = sub(g, &eye, &kc);
    let joseph = sandwich_symmetric(g, &i_kc, p, &i_kc);
    let krk = sandwich_symmetric(g, &k, r, &k);
    Update {
        x: x_new,
        p: add(g, &joseph, &krk),
        pivots: ldl.pivots,
        reciprocals: ldl.reciprocals,
    }
}
