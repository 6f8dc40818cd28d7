//! The continuous-time EKF's measurement terms (Kulkarni and Purwar, "Nonlinear
//! experimental estimation and verification of a MIMO system through EKF", eq. 5): the
//! innovation feedback `K (y - h)` of the state, `- P H' R^-1 H P` of the Riccati equation
//! (the Kalman-Bucy filter's), and how stiff they make the equations over a sample.

use super::graph::{Graph, NodeId};
use super::linalg::{dot, matmul, transpose, Matrix};

/// The gain `K = P H' R^-1` and `rate - K (P H')'`, i.e. `rate - P H' R^-1 H P`, as a full
/// symmetric matrix (each entry of the upper triangle computed once).
pub fn riccati_measurement_terms(
    g: &mut Graph,
    rate: &Matrix,
    p: &Matrix,
    h: &Matrix,
    r_inv: &Matrix,
) -> (Matrix, Matrix) {
    let n = p.len();
    let pht = matmul(g, p, &transpose(h));
    let gain = matmul(g, &pht, r_inv);
    let mut out = rate.clone();
    for i in 0..n {
        for j in i..n {
            let mut v = rate[i][j];
            for (&k, &u) in gain[i].iter().zip(&pht[j]) {
                let term = g.mul(k, u);
                v = g.sub(v, term);
            }
            out[i][j] = v;
            out[j][i] = v;
        }
    }
    (gain, out)
}

/// The state rate with the innovation feedback, `rate + K (y - h)`, each row summed term
/// by term.
pub fn innovation_feedback(
    g: &mut Graph,
    rate: &[NodeId],
    gain: &Matrix,
    y: &[NodeId],
    h: &[NodeId],
) -> Vec<NodeId> {
    rate.iter()
        .zip(gain)
        .map(|(&rate, gain_row)| {
            let mut v = rate;
            for ((&k, &yj), &hj) in gain_row.iter().zip(y).zip(h) {
                let innovation = g.sub(yj, hj);
                let term = g.mul(k, innovation);
                v = g.add(v, term);
            }
            v
        })
        .collect()
}

/// The stiffness of the measurement terms over a sample `T`: `T tr(R^-1 H P H')`, the sum
/// of `T` times the rates `P H' R^-1 H` pulls the estimate at (the eigenvalues of
/// `R^-1 H P H'`, all real and non-negative), so at least the largest of them.
pub fn measurement_stiffness(
    g: &mut Graph,
    duration: NodeId,
    p: &Matrix,
    h: &Matrix,
    r_inv: &Matrix,
) -> NodeId {
    let pht = matmul(g, p, &transpose(h));
    let hpht = matmul(g, h, &pht);
    // `tr(A B) = sum_ij A_ij B_ji`, and `H P H'` is symmetric.
    let mut trace = g.zero();
    for (row, other) in r_inv.iter().zip(&hpht) {
        let term = dot(g, row, other);
        trace = g.add(trace, term);
    }
    g.mul(duration, trace)
}
