//! The algebra of the LQR's steady-state input on graph nodes: one Gauss-Newton step on
//! the fixed point `f(x_ref, u_ref) = x_ref` of the regulated states.

use crate::symbolic::graph::{Graph, NodeId};
use crate::symbolic::linalg::{ldl_inverse, matmul, transpose, Matrix};

/// A Gauss-Newton step towards the input holding a set-point, as nodes.
pub struct SteadyStateStep {
    /// `u_ref`, one node per input.
    pub input: Vec<NodeId>,
    /// Pivots of `B'B`; each must be checked positive before its reciprocal variable is
    /// bound.
    pub pivots: Vec<NodeId>,
    /// Variables standing for the pivots' reciprocals.
    pub reciprocals: Vec<NodeId>,
}

/// `u_ref = u + (B'B)^-1 B' (x_ref - f(x_ref, u))` for the regulated states `states`
/// (their variables, read as the set-point `x_ref`), their rows `rows` of `f`, the inputs
/// `inputs` and `B = df/d[inputs]`: exact for a model affine in its inputs, the least-
/// squares input when no input reaches the set-point. `reciprocal(graph, j)` declares the
/// variable for `1 / d_j` of `B'B`.
pub fn steady_state_step(
    g: &mut Graph,
    (states, rows): (&[NodeId], &[NodeId]),
    (inputs, b): (&[NodeId], &Matrix),
    reciprocal: impl FnMut(&mut Graph, usize) -> NodeId,
) -> SteadyStateStep {
    let residual: Matrix = states
        .iter()
        .zip(rows)
        .map(|(&x, &f)| vec![g.sub(x, f)])
        .collect();
    let bt = transpose(b);
    let gram = matmul(g, &bt, b);
    let ldl = ldl_inverse(g, &gram, reciprocal);
    let bt_residual = matmul(g, &bt, &residual);
    let delta = matmul(g, &ldl.inverse, &bt_residual);
    let input = inputs
        .iter()
        .zip(&delta)
        .map(|(&u, d)| g.add(u, d[0]))
        .collect();
    SteadyStateStep {
        input,
        pivots: ldl.pivots,
        reciprocals: ldl.reciprocals,
    }
}
