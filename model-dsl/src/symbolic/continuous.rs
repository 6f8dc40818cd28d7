//! Stages of the continuous filters on graph nodes: one explicit integration sub-step of an
//! ODE system, the covariance rate `F P + P F' + Q` (hybrid EKF, Takacs et al., eq. 21) and the
//! Riccati rate of the continuous-time EKF (Kulkarni and Purwar, eq. 5, with Reif et al.'s prescribed
//! degree of stability, eq. 26). Symmetric rates are built on the upper triangle.

// Index loops mirror the formulas' subscripts (P_ij, K_il) more plainly than iterators.
#![allow(clippy::needless_range_loop)]

use super::graph::{Graph, Node, NodeId, VarId};
use super::linalg::{matmul, packed_upper, sparser_row_last, symmetric_from_packed, Matrix};
use crate::model::Method;
use std::collections::HashMap;

/// The right-hand side of an ODE system `dz/dt = rate(t, z)`, built as nodes.
pub type Rate<'a> = dyn FnMut(&mut Graph, NodeId, &[NodeId]) -> Vec<NodeId> + 'a;

/// One explicit step of length `h` from time `t` of `dz/dt = rate(t, z)`: forward Euler
/// `z + h k1`, or classical Runge-Kutta `z + h/6 (k1 + 2 k2 + 2 k3 + k4)`.
pub fn integrate_substep(
    g: &mut Graph,
    method: Method,
    h: NodeId,
    t: NodeId,
    z: &[NodeId],
    rate: &mut Rate<'_>,
) -> Vec<NodeId> {
    let axpy = |g: &mut Graph, a: NodeId, y: &[NodeId]| -> Vec<NodeId> {
        z.iter()
            .zip(y)
            .map(|(&zi, &yi)| {
                let step = g.mul(a, yi);
                g.add(zi, step)
            })
            .collect()
    };
    match method {
        Method::Euler => {
            let k1 = rate(g, t, z);
            axpy(g, h, &k1)
        }
        Method::Rk4 => {
            let half = g.num(0.5);
            let half_h = g.mul(half, h);
            let t_mid = g.add(t, half_h);
            let t_end = g.add(t, h);
            let k1 = rate(g, t, z);
            let z2 = axpy(g, half_h, &k1);
            let k2 = rate(g, t_mid, &z2);
            let z3 = axpy(g, half_h, &k2);
            let k3 = rate(g, t_mid, &z3);
            let z4 = axpy(g, h, &k3);
            let k4 = rate(g, t_end, &z4);
            let sixth = g.num(1.0 / 6.0);
            let h_sixth = g.mul(h, sixth);
            let two = g.num(2.0);
            (0..z.len())
                .map(|i| {
                    let middle = g.add(k2[i], k3[i]);
                    let twice_middle = g.mul(two, middle);
                    let ends = g.add(k1[i], k4[i]);
                    let sum = g.add(ends, twice_middle);
                    let step = g.mul(h_sixth, sum);
                    g.add(z[i], step)
                })
                .collect()
        }
    }
}

/// `F P + P F' + Q + 2 alpha P` (the last term only with `two_alpha`), upper triangle
/// computed once: Takacs et al., eq. (21), and with `alpha` the Riccati equation of Reif et al.,
/// where `(F + alpha I) P + P (F + alpha I)' = F P + P F' + 2 alpha P`.
pub fn covariance_rate(
    g: &mut Graph,
    f: &Matrix,
    p: &Matrix,
    q: &Matrix,
    two_alpha: Option<NodeId>,
) -> Matrix {
    let n = p.len();
    let fp = matmul(g, f, p);
    let zero = g.zero();
    let mut rate = vec![vec![zero; n]; n];
    for i in 0..n {
        for j in i..n {
            // (P F')_ij = (F P)_ji since P is symmetric.
            let mut v = g.add(fp[i][j], fp[j][i]);
            v = g.add(v, q[i][j]);
            if let Some(two_alpha) = two_alpha {
                let growth = g.mul(two_alpha, p[i][j]);
                v = g.add(v, growth);
            }
            rate[i][j] = v;
            rate[j][i] = v;
        }
    }
    rate
}

/// One forward Euler sub-step of length `h` of the covariance equation
/// `P' = A P + P A' + S` (`A = F`, or `F + alpha I` with `alpha`), taken as the covariance
/// of the Euler step itself: `(I + h A) P (I + h A)' + h S`, i.e.
/// `P + h (A P + P A' + S) + h^2 A P A'`. The last term, which a plain Euler step of the
/// ODE leaves out, is what keeps `P` positive semi-definite for any `h` (each term is), and
/// with it one Euler sub-step is exactly the discrete EKF's `A_d P A_d' + Q` of the Euler
/// model (`A_d = I + h F`, `Q = h Q_c`).
///
/// Computed as two products by `Phi = I + h A`, whose entries do not change over a
/// sub-step where `A` does not (computed once before a loop of sub-steps) and are mostly
/// structural zeros and ones (a row of `F` that is a unit vector, as `der(q) = qd`
/// gives): `G = Phi P`, then the upper triangle of `G Phi' + h S`, each entry from the row
/// of `G` that gives it in fewer terms (`N_ij = G_i Phi_j' = G_j Phi_i'`). In each entry the
/// off-diagonal products are summed first and the diagonal one, usually the entry
/// itself, added last: a small increment added to the value it changes.
pub fn euler_covariance_step(
    g: &mut Graph,
    h: NodeId,
    f: &Matrix,
    alpha: Option<NodeId>,
    p: &Matrix,
    s: &Matrix,
) -> Matrix {
    let phi = euler_transition(g, h, f, alpha);
    let noise: Matrix = s
        .iter()
        .map(|row| row.iter().map(|&v| g.mul(h, v)).collect())
        .collect();
    covariance_of_transition(g, &phi, p, &noise)
}

/// `Phi P Phi' + W`, upper triangle computed once, as [`euler_covariance_step`] computes
/// it: the covariance after a step whose transition is `Phi` and whose noise adds `W`.
pub fn covariance_of_transition(g: &mut Graph, phi: &Matrix, p: &Matrix, w: &Matrix) -> Matrix {
    let n = p.len();
    // G = Phi P: G_ij = sum_k Phi_ik P_kj.
    let left: Matrix = (0..n)
        .map(|i| {
            (0..n)
                .map(|j| {
                    let terms = (0..n).map(|k| (phi[i][k], p[k][j]));
                    increment_then_diagonal(g, terms, i, None)
                })
                .collect()
        })
        .collect();
    // N = G Phi' + W: N_ij = sum_k G_ik Phi_jk + W_ij, upper triangle; or the same sum
    // from row j of G where it has fewer terms (`sparser_row_last`).
    let zero = g.zero();
    let mut out = vec![vec![zero; n]; n];
    for i in 0..n {
        for j in i..n {
            let (row, col) = sparser_row_last(g, phi, i, j);
            let terms = (0..n).map(|k| (left[row][k], phi[col][k]));
            let v = increment_then_diagonal(g, terms, col, Some(w[i][j]));
            out[i][j] = v;
            out[j][i] = v;
        }
    }
    out
}

/// `Phi = I + h A` of an Euler sub-step, `A = F`, or `F + alpha I` with `alpha`.
pub fn euler_transition(g: &mut Graph, h: NodeId, f: &Matrix, alpha: Option<NodeId>) -> Matrix {
    euler_transition_with(g, f, alpha, |_, _| Some(h))
}

/// `Phi = I + (h A)` with the step of each entry `(i, j)` of `A` given by `step(i, j)`:
/// `h` itself, or a scaled `h` (see `scaled_covariance`), `None` for one.
pub fn euler_transition_with(
    g: &mut Graph,
    f: &Matrix,
    alpha: Option<NodeId>,
    step: impl Fn(usize, usize) -> Option<NodeId>,
) -> Matrix {
    let n = f.len();
    let one = g.one();
    (0..n)
        .map(|i| {
            (0..n)
                .map(|j| {
                    let a = match alpha {
                        Some(alpha) if i == j => g.add(f[i][j], alpha),
                        _ => f[i][j],
                    };
                    let increment = match step(i, j) {
                        Some(h) => scale(g, h, a),
                        None => a,
                    };
                    if i == j {
                        g.add(one, increment)
                    } else {
                        increment
                    }
                })
                .collect()
        })
        .collect()
}

/// `h e`, with `h` distributed over the sums of `e` when each of their terms has a
/// constant factor (`h (c u - k q)` as `(h c) u - (h k) q`: the constants fold, one
/// operation fewer).
pub(super) fn scale(g: &mut Graph, h: NodeId, e: NodeId) -> NodeId {
    if !matches!(g.node(e), Node::Add(..) | Node::Sub(..) | Node::Neg(_)) || !distributes(g, e) {
        return g.mul(h, e);
    }
    match g.node(e) {
        Node::Add(a, b) => {
            let (a, b) = (scale(g, h, a), scale(g, h, b));
            g.add(a, b)
        }
        Node::Sub(a, b) => {
            let (a, b) = (scale(g, h, a), scale(g, h, b));
            g.sub(a, b)
        }
        Node::Neg(a) => {
            let a = scale(g, h, a);
            g.neg(a)
        }
        _ => g.mul(h, e),
    }
}

/// Whether every term of the sum `e` is a constant or has a constant factor.
fn distributes(g: &Graph, e: NodeId) -> bool {
    match g.node(e) {
        Node::Add(a, b) | Node::Sub(a, b) => distributes(g, a) && distributes(g, b),
        Node::Neg(a) => distributes(g, a),
        Node::Mul(a, b) => g.constant_value(a).is_some() || g.constant_value(b).is_some(),
        Node::Num(_) | Node::Named(_) => true,
        _ => false,
    }
}

/// `sum_k a_k b_k (+ extra)` with the products of `k != diagonal` and `extra` summed
/// first and the product at `diagonal` (the entry being changed, times `Phi`'s diagonal
/// entry, usually one) added last, each product with its factors whole
/// ([`Graph::mul_whole`]: a coefficient hoisted out of the loop is one multiplication).
fn increment_then_diagonal(
    g: &mut Graph,
    terms: impl Iterator<Item = (NodeId, NodeId)>,
    diagonal: usize,
    extra: Option<NodeId>,
) -> NodeId {
    let mut sum = g.zero();
    let mut last = sum;
    for (k, (a, b)) in terms.enumerate() {
        let term = g.mul_whole(a, b);
        if k == diagonal {
            last = term;
        } else {
            sum = g.add(sum, term);
        }
    }
    if let Some(extra) = extra {
        sum = g.add(sum, extra);
    }
    g.add(sum, last)
}

/// A state vector `x` followed by the packed upper triangle of its covariance, as one
/// vector for [`integrate_substep`].
pub fn join(x: &[NodeId], p: &Matrix) -> Vec<NodeId> {
    x.iter().copied().chain(packed_upper(p)).collect()
}

/// Splits a joined vector (see [`join`]) of a state of length `n` back into `x` and `P`.
pub fn split(z: &[NodeId], n: usize) -> (Vec<NodeId>, Matrix) {
    let (x, packed) = z.split_at(n);
    (x.to_vec(), symmetric_from_packed(packed, n))
}

/// Expressions over variables, re-evaluated at other points by substitution: the model's
/// right-hand side, its Jacobian and the measurement, built once over the variables.
pub struct AtPoint {
    vars: Vec<VarId>,
}

impl AtPoint {
    /// Substitution of the variables `vars` (in order) by the values a call gives.
    pub fn new(vars: Vec<VarId>) -> AtPoint {
        AtPoint { vars }
    }

    /// `exprs` with the variables replaced by `values`; unchanged when every value is its
    /// own variable (the Euler stage, the fused update), so no node is rebuilt.
    pub fn eval(&self, g: &mut Graph, values: &[NodeId], exprs: &[NodeId]) -> Vec<NodeId> {
        let map: HashMap<VarId, NodeId> = self
            .vars
            .iter()
            .copied()
            .zip(values.iter().copied())
            .filter(|&(v, node)| g.node(node) != super::graph::Node::Var(v))
            .collect();
        if map.is_empty() {
            return exprs.to_vec();
        }
        let mut memo = HashMap::new();
        exprs
            .iter()
            .map(|&e| g.substitute(e, &map, &mut memo))
            .collect()
    }

    /// A matrix of expressions at `values`.
    pub fn eval_matrix(&self, g: &mut Graph, values: &[NodeId], m: &Matrix) -> Matrix {
        let cols = m.first().map_or(0, Vec::len);
        let flat: Vec<NodeId> = m.iter().flatten().copied().collect();
        let done = self.eval(g, values, &flat);
        done.chunks(cols.max(1)).map(<[NodeId]>::to_vec).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn constant<const N: usize>(g: &mut Graph, m: [[f64; N]; N]) -> Matrix {
        m.iter()
            .map(|row| row.iter().map(|&v| g.num(v)).collect())
            .collect()
    }

    fn value<const N: usize>(g: &Graph, m: &Matrix) -> [[f64; N]; N] {
        let no_vars = |_| f64::NAN;
        std::array::from_fn(|i| std::array::from_fn(|j| g.eval(m[i][j], &no_vars)))
    }

    #[test]
    fn covariance_rate_is_f_p_plus_p_f_transposed_plus_q_plus_two_alpha_p() {
        let mut g = Graph::new();
        let f = constant(&mut g, [[0.0, 1.0], [-4.0, -0.5]]);
        let p = constant(&mut g, [[2.0, 0.3], [0.3, 1.0]]);
        let q = constant(&mut g, [[0.1, 0.0], [0.0, 0.2]]);
        let two_alpha = g.num(2.0 * 0.25);
        let rate = covariance_rate(&mut g, &f, &p, &q, Some(two_alpha));
        // F P = [[0.3, 1], [-8.15, -1.7]]; F P + (F P)' + Q + 0.5 P:
        let expected = [
            [0.6 + 0.1 + 1.0, 1.0 - 8.15 + 0.15],
            [1.0 - 8.15 + 0.15, -3.4 + 0.2 + 0.5],
        ];
        for (row, want) in value::<2>(&g, &rate).iter().zip(expected) {
            for (v, w) in row.iter().zip(want) {
                assert!((v - w).abs() < 1e-12, "{v} vs {w}");
            }
        }
    }

    #[test]
    fn euler_covariance_step_is_the_covariance_of_the_euler_step() {
        let mut g = Graph::new();
        let f = constant(&mut g, [[0.0, 1.0], [-4.0, -0.5]]);
        let p = constant(&mut g, [[2.0, 0.3], [0.3, 1.0]]);
        let s = constant(&mut g, [[0.1, 0.0], [0.0, 0.2]]);
        let (h, alpha) = (0.1, 0.25);
        let (h_node, alpha_node) = (g.num(h), g.num(alpha));
        let step = euler_covariance_step(&mut g, h_node, &f, Some(alpha_node), &p, &s);
        // (I + h (F + alpha I)) P (I + h (F + alpha I))' + h S, by hand.
        let phi = [[1.0 + h * alpha, h], [-4.0 * h, 1.0 + h * (-0.5 + alpha)]];
        let pm = [[2.0, 0.3], [0.3, 1.0]];
        let sm = [[0.1, 0.0], [0.0, 0.2]];
        let got = value::<2>(&g, &step);
        for i in 0..2 {
            for j in 0..2 {
                let mut want = h * sm[i][j];
                for k in 0..2 {
                    for l in 0..2 {
                        want += phi[i][k] * pm[k][l] * phi[j][l];
                    }
                }
                assert!(
                    (got[i][j] - want).abs() < 1e-12,
                    "({i},{j}): {} vs {want}",
                    got[i][j]
                );
            }
        }
    }

    /// `(I + h F) P (I + h F)' + h S` summed term by term.
    fn by_hand<const N: usize>(
        h: f64,
        f: [[f64; N]; N],
        p: [[f64; N]; N],
        s: [[f64; N]; N],
    ) -> [[f64; N]; N] {
        let phi: [[f64; N]; N] = std::array::from_fn(|i| {
            std::array::from_fn(|j| f64::from(u8::from(i == j)) + h * f[i][j])
        });
        std::array::from_fn(|i| {
            std::array::from_fn(|j| {
                let mut sum = h * s[i][j];
                for k in 0..N {
                    for l in 0..N {
                        sum += phi[i][k] * p[k][l] * phi[j][l];
                    }
                }
                sum
            })
        })
    }

    #[test]
    fn an_entry_is_taken_from_the_row_whose_products_are_fewer() {
        // der(q) = qd, der(qd) = -4 q - 0.5 qd + 2 c, c a parameter: Phi_q = [1, h, 0] has
        // two terms, Phi_qd three, Phi_c one.
        let fm = [[0.0, 1.0, 0.0], [-4.0, -0.5, 2.0], [0.0, 0.0, 0.0]];
        let pm = [[2.0, 0.3, -0.2], [0.3, 1.0, 0.4], [-0.2, 0.4, 0.5]];
        let sm = [[0.1, 0.0, 0.0], [0.0, 0.2, 0.0], [0.0, 0.0, 0.3]];
        let h = 0.1;
        let mut g = Graph::new();
        let (f, p, s) = (
            constant(&mut g, fm),
            constant(&mut g, pm),
            constant(&mut g, sm),
        );
        let h_node = g.num(h);
        let phi = euler_transition(&mut g, h_node, &f, None);
        // N_(q, qd): two products from row qd of G, three from row q.
        assert_eq!(sparser_row_last(&g, &phi, 0, 1), (1, 0));
        // N_(q, c) = G_(q, c) is one product already; N_(qd, c) too.
        assert_eq!(sparser_row_last(&g, &phi, 0, 2), (0, 2));
        assert_eq!(sparser_row_last(&g, &phi, 1, 2), (1, 2));
        let step = euler_covariance_step(&mut g, h_node, &f, None, &p, &s);
        let got: [[f64; 3]; 3] = value(&g, &step);
        for (i, (got_row, want_row)) in got.iter().zip(by_hand(h, fm, pm, sm)).enumerate() {
            for (j, (v, w)) in got_row.iter().zip(want_row).enumerate() {
                assert!((v - w).abs() < 1e-12, "({i},{j}): {v} vs {w}");
            }
        }
    }
}
