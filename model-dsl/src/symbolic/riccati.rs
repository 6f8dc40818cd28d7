//! One step of the discrete Riccati recursion, shared by the finite-horizon LQR and the
//! MPC's terminal weight: `K = (R + B'PB)^-1 B'PA` and `P <- A'PA - A'PB K + Q`, with
//! `R + B'PB` inverted through guarded `L D L'` pivots.

use super::graph::{Graph, NodeId};
use super::linalg::{
    add, ldl_inverse, matmul, packed_upper, sandwich_symmetric, sub, transpose, Matrix,
};

/// A Riccati step, as nodes.
pub struct RiccatiStep {
    /// The gain `K = (R + B'PB)^-1 B'PA` (inputs x states).
    pub gain: Matrix,
    /// The next `P`, packed upper triangle.
    pub p_next: Vec<NodeId>,
    /// Pivots of `R + B'PB`; each must be checked positive before its reciprocal
    /// variable is bound.
    pub pivots: Vec<NodeId>,
    /// Variables standing for the pivots' reciprocals.
    pub reciprocals: Vec<NodeId>,
}

/// The step from `p` on the model `x+ = A x + B u` with weights `q`, `r` (all symmetric,
/// both triangles filled); `reciprocal(graph, j)` declares the variable for `1 / d_j`.
pub fn riccati_step(
    g: &mut Graph,
    (a, b): (&Matrix, &Matrix),
    p: &Matrix,
    (q, r): (&Matrix, &Matrix),
    reciprocal: impl FnMut(&mut Graph, usize) -> NodeId,
) -> RiccatiStep {
    let pb = matmul(g, p, b);
    let btpb = matmul(g, &transpose(b), &pb);
    let weight = add(g, r, &btpb);
    let btpa = matmul(g, &transpose(&pb), a);
    let ldl = ldl_inverse(g, &weight, reciprocal);
    let gain = matmul(g, &ldl.inverse, &btpa);
    let at = transpose(a);
    let atpa = sandwich_symmetric(g, &at, p, &at);
    let correction = symmetric_product(g, &transpose(&btpa), &gain);
    let difference = sub(g, &atpa, &correction);
    let p_next = add(g, &difference, q);
    RiccatiStep {
        gain,
        p_next: packed_upper(&p_next),
        pivots: ldl.pivots,
        reciprocals: ldl.reciprocals,
    }
}

/// The upper triangle (mirrored) of `a b` for a product known to be symmetric.
fn symmetric_product(g: &mut Graph, a: &Matrix, b: &Matrix) -> Matrix {
    let n = a.len();
    let full = matmul(g, a, b);
    let mut out = full.clone();
    for i in 0..n {
        for j in 0..i {
            out[i][j] = full[j][i];
        }
    }
    out
}
