//! The algebra of the model predictive controller on graph nodes: the zero-order-hold
//! discretisation of a linearised continuous model, and the condensed quadratic program of
//! the dual-mode cost (Takacs, Polóni, Rohal'-Ilkiv, "Adaptive predictive control of
//! transient vibrations of cantilevers with changing weight", eqs. 32-44).

use crate::ast::Comparison;
use crate::model::Func;
use crate::symbolic::graph::{Graph, NodeId};
use crate::symbolic::linalg::{
    add, identity, matmul, packed_upper, sandwich_symmetric, transpose, Matrix,
};

/// Terms of the Taylor series of the matrix exponential: the paper discretises with
/// `j = 10` terms (sect. 4.1). On a matrix of 1-norm at most 1/2, which the scaling
/// guarantees, the first omitted term bounds the relative error by
/// `(1/2)^11 / 11! < 1.3e-11`.
pub const TAYLOR_TERMS: u32 = 10;

/// The zero-order hold of `x' = F x + G u` over one (scaled) step, as the blocks of
/// `exp([[F, G], [0, 0]]) = [[A, B], [0, I]]`: the Taylor series of `TAYLOR_TERMS` terms
/// in Horner form, `T_j = I + X T_(j+1) / j`, whose blocks are
/// `A_j = I + F A_(j+1) / j` and `B_j = (F B_(j+1) + G) / j` (Franklin, Powell and
/// Workman's series for `A` and `B`, evaluated together).
pub fn zoh_taylor(g: &mut Graph, f: &Matrix, gamma: &Matrix) -> (Matrix, Matrix) {
    let n = f.len();
    let inputs = gamma.first().map_or(0, Vec::len);
    let eye = identity(g, n);
    let mut a = eye.clone();
    let mut b = vec![vec![g.zero(); inputs]; n];
    for j in (1..=TAYLOR_TERMS).rev() {
        let inv_j = g.num(1.0 / f64::from(j));
        let fa = matmul(g, f, &a);
        let scaled = scale(g, &fa, inv_j);
        a = add(g, &eye, &scaled);
        let fb = matmul(g, f, &b);
        let sum = add(g, &fb, gamma);
        b = scale(g, &sum, inv_j);
    }
    (a, b)
}

/// One squaring of the hold over a step to the hold over two: `A <- A A`, `B <- A B + B`
/// (the blocks of `[[A, B], [0, I]]^2`).
pub fn zoh_square(g: &mut Graph, a: &Matrix, b: &Matrix) -> (Matrix, Matrix) {
    let aa = matmul(g, a, a);
    let ab = matmul(g, a, b);
    (aa, add(g, &ab, b))
}

/// `k m`
pub fn scale(g: &mut Graph, m: &Matrix, k: NodeId) -> Matrix {
    m.iter()
        .map(|row| row.iter().map(|&v| g.mul(v, k)).collect())
        .collect()
}

/// `|| [Phi Gamma] ||_1`: the largest column sum of magnitudes, which decides how often
/// the hold's step is halved.
pub fn column_norm(g: &mut Graph, phi: &Matrix, gamma: &Matrix) -> NodeId {
    let ns = phi.len();
    let columns = ns + gamma.first().map_or(0, Vec::len);
    let mut norm = None;
    for j in 0..columns {
        let mut sum = g.zero();
        for i in 0..ns {
            let entry = if j < ns { phi[i][j] } else { gamma[i][j - ns] };
            let magnitude = g.call(Func::Abs, entry);
            sum = g.add(sum, magnitude);
        }
        norm = Some(match norm {
            None => sum,
            Some(n) => g.select(Comparison::Gt, sum, n, sum, n),
        });
    }
    norm.unwrap_or_else(|| g.zero())
}

/// The model's part of the condensed problem `min 1/2 U' H U + c' U` over the moves
/// `U = [u_0; ..; u_(n-1)]` (step by step, each `u_i` all inputs): what does not depend on
/// the estimate, so it can be kept while the prediction model is.
pub struct CondensedModel {
    /// `H`, packed upper triangle, `n m` unknowns.
    pub hessian: Vec<NodeId>,
    /// `S_(i+1) B` for each move `i`, which the linear term weighs the free response by.
    pub weighted: Vec<Matrix>,
}

/// Eqs. (42)-(43) without forming the prediction matrices `M` and `N` of eqs. (32)-(33):
/// with the cost-to-go weights `S_n = P_f`, `S_k = Q + A' S_(k+1) A`, the block of `H`
/// coupling moves `i <= j` is `(A^(j-i) B)' S_(j+1) B` (plus `R` on the diagonal).
/// `J = x' Q x` summed over the horizon plus `x_n' P_f x_n` and `u' R u` is then
/// `1/2 U' (2H) U + (2c)' U` + const, which has the same minimiser.
pub fn condensed_hessian(
    g: &mut Graph,
    (a, b): (&Matrix, &Matrix),
    (q, r, terminal): (&Matrix, &Matrix, &Matrix),
    horizon: usize,
) -> CondensedModel {
    let inputs = b.first().map_or(0, Vec::len);
    let a_t = transpose(a);
    // cost_to_go[k] = S_(k+1), k = 0..horizon-1.
    let mut cost_to_go = vec![terminal.clone()];
    for _ in 1..horizon {
        let next = cost_to_go.last().cloned().unwrap_or_default();
        let propagated = sandwich_symmetric(g, &a_t, &next, &a_t);
        cost_to_go.push(add(g, q, &propagated));
    }
    cost_to_go.reverse();
    // responses[d] = A^d B.
    let mut responses = vec![b.clone()];
    for _ in 1..horizon {
        let previous = responses.last().cloned().unwrap_or_default();
        responses.push(matmul(g, a, &previous));
    }
    // weighted[j] = S_(j+1) B.
    let weighted: Vec<Matrix> = cost_to_go.iter().map(|s| matmul(g, s, b)).collect();
    let unknowns = horizon * inputs;
    let zero = g.zero();
    let mut hessian = vec![vec![zero; unknowns]; unknowns];
    for i in 0..horizon {
        for j in i..horizon {
            let block = matmul(g, &transpose(&responses[j - i]), &weighted[j]);
            for (k, row) in block.iter().enumerate() {
                for (l, &v) in row.iter().enumerate() {
                    let v = if i == j { g.add(v, r[k][l]) } else { v };
                    hessian[i * inputs + k][j * inputs + l] = v;
                    hessian[j * inputs + l][i * inputs + k] = v;
                }
            }
        }
    }
    CondensedModel {
        hessian: packed_upper(&hessian),
        weighted,
    }
}

/// Eq. (44) times `x0`: the linear term of move `i` is `(S_(i+1) B)' A^(i+1) x0`, one entry
/// per unknown, from the weighted responses of [`condensed_hessian`].
pub fn condensed_linear(
    g: &mut Graph,
    a: &Matrix,
    weighted: &[Matrix],
    x0: &[NodeId],
) -> Vec<NodeId> {
    let mut linear = Vec::new();
    let mut state: Matrix = x0.iter().map(|&v| vec![v]).collect();
    for w in weighted {
        state = matmul(g, a, &state);
        let term = matmul(g, &transpose(w), &state);
        linear.extend(term.iter().map(|row| row[0]));
    }
    linear
}
