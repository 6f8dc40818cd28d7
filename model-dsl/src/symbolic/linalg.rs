//! Matrix algebra on graph nodes. Products are built with the simplifying constructors, so
//! a structural zero in an operand contributes no operation, and symmetric results are
//! computed on the upper triangle only.

// Index loops mirror the textbook formulas (L_ij, d_j) more plainly than iterators here.
#![allow(clippy::needless_range_loop)]

use super::graph::{Graph, NodeId};

/// A dense matrix of nodes, row by row.
pub type Matrix = Vec<Vec<NodeId>>;

/// Position of entry `(i, j)` (either order) in the row-major packed upper triangle of an
/// `n x n` symmetric matrix: rows `0..i` hold `i n - i (i - 1) / 2` entries before it.
pub fn packed_index(n: usize, i: usize, j: usize) -> usize {
    let (i, j) = if i <= j { (i, j) } else { (j, i) };
    i * n - i * (i + 1) / 2 + j
}

/// Length of the packed upper triangle of an `n x n` symmetric matrix.
pub fn packed_len(n: usize) -> usize {
    n * (n + 1) / 2
}

/// The full symmetric matrix whose packed upper triangle is `packed`.
pub fn symmetric_from_packed(packed: &[NodeId], n: usize) -> Matrix {
    (0..n)
        .map(|i| (0..n).map(|j| packed[packed_index(n, i, j)]).collect())
        .collect()
}

/// The packed upper triangle of a (symmetric) matrix.
pub fn packed_upper(m: &Matrix) -> Vec<NodeId> {
    let n = m.len();
    (0..n)
        .flat_map(|i| (i..n).map(move |j| (i, j)))
        .map(|(i, j)| m[i][j])
        .collect()
}

/// `sum_k a_k b_k`, the terms with a factor of one first: the sum starts from such a term
/// (the identity's part of `A P`, `P_ij` in `(I + ..) P`) and adds each product to it, one
/// multiply-add each, where a product first would be a multiplication and the term one
/// more addition.
/// A pair with a structural zero is skipped: its product is zero and adding it leaves
/// the sum as it was, so the graph is the same, without a lookup per pair (the 300-state
/// chain's `A P` has 27 million pairs, nearly all zero).
pub fn dot(g: &mut Graph, a: &[NodeId], b: &[NodeId]) -> NodeId {
    let pairs: Vec<(NodeId, NodeId)> = a
        .iter()
        .copied()
        .zip(b.iter().copied())
        .filter(|&(x, y)| !g.is_zero(x) && !g.is_zero(y))
        .collect();
    let unit = |g: &Graph, &(x, y): &(NodeId, NodeId)| g.is_one(x) || g.is_one(y);
    let (units, products): (Vec<_>, Vec<_>) = pairs.iter().partition(|pair| unit(g, pair));
    let mut sum = g.zero();
    for (x, y) in units.into_iter().chain(products) {
        let term = g.mul(x, y);
        sum = g.add(sum, term);
    }
    sum
}

/// `a b`
pub fn matmul(g: &mut Graph, a: &Matrix, b: &Matrix) -> Matrix {
    let columns = transpose(b);
    a.iter()
        .map(|row| columns.iter().map(|column| dot(g, row, column)).collect())
        .collect()
}

/// `a'`
pub fn transpose(a: &Matrix) -> Matrix {
    let cols = a.first().map_or(0, Vec::len);
    (0..cols)
        .map(|j| a.iter().map(|row| row[j]).collect())
        .collect()
}

/// `a + b`
pub fn add(g: &mut Graph, a: &Matrix, b: &Matrix) -> Matrix {
    a.iter()
        .zip(b)
        .map(|(ra, rb)| ra.iter().zip(rb).map(|(&x, &y)| g.add(x, y)).collect())
        .collect()
}

/// `a - b`
pub fn sub(g: &mut Graph, a: &Matrix, b: &Matrix) -> Matrix {
    a.iter()
        .zip(b)
        .map(|(ra, rb)| ra.iter().zip(rb).map(|(&x, &y)| g.sub(x, y)).collect())
        .collect()
}

/// For entry `ij` (`i <= j`) of a symmetric `A M A'` from the rows of `A M`: which row of
/// `A M` to take and which row of `A` to dot it with, `(j, i)` rather than `(i, j)` (the
/// same sum, `M` being symmetric) where row `i` of `A` has fewer structural nonzeros than
/// row `j`, all among `j`'s. Row `j` of `A M` is then computed for the diagonal entry `jj`
/// anyway, and the sum has fewer terms: a kinematic row (`x1 = x1 + TS x2`, or
/// `der(q) = qd` in an Euler sub-step) has two against the row it integrates.
pub fn sparser_row_last(g: &Graph, a: &Matrix, i: usize, j: usize) -> (usize, usize) {
    let support =
        |row: &[NodeId]| -> Vec<usize> { (0..row.len()).filter(|&k| !g.is_zero(row[k])).collect() };
    let (si, sj) = (support(&a[i]), support(&a[j]));
    if si.len() < sj.len() && si.iter().all(|k| sj.contains(k)) {
        (j, i)
    } else {
        (i, j)
    }
}

/// `a m b'`, upper triangle only, for a result known to be symmetric (`a = b`, or the
/// caller's algebra says so); the lower triangle mirrors it.
pub fn sandwich_symmetric(g: &mut Graph, a: &Matrix, m: &Matrix, b: &Matrix) -> Matrix {
    let am = matmul(g, a, m);
    let n = a.len();
    let mut out = vec![vec![g.zero(); n]; n];
    for i in 0..n {
        for j in i..n {
            let v = dot(g, &am[i], &b[j]);
            out[i][j] = v;
            out[j][i] = v;
        }
    }
    out
}

/// Matrix entries bound to variables of their own, for a stage that uses each entry many
/// times (`A P A'`, `P C'`): built on the entries themselves, the simplifier moves their
/// literal factors out of every product (`0.5 (da_x p12)`) and multiplies by them again
/// each time; on a variable, each product is one multiply-add. An entry whose value is
/// another entry's, or its negation (`-0.5 da_x` beside `0.5 da_x`), shares that entry's
/// variable, so a product with it is one multiply-subtract. Leaves (literals, named
/// constants, variables) and their negations stay as they are.
#[derive(Default)]
pub struct Coefficients {
    /// Names the variables must not take (the model's own).
    avoid: crate::fast_hash::FastSet<String>,
    /// Each variable with the value the code computes for it once.
    pub definitions: Vec<(NodeId, NodeId)>,
    /// The variable standing for each magnitude bound so far (see [`signed_magnitude`]),
    /// and whether the variable holds its negation.
    bound: std::collections::HashMap<NodeId, (NodeId, bool)>,
}

impl Coefficients {
    /// A binder whose variables avoid the names in `avoid`.
    pub fn new(avoid: &[String]) -> Coefficients {
        Coefficients {
            avoid: avoid.iter().cloned().collect(),
            ..Coefficients::default()
        }
    }

    /// `matrix` with each computed entry replaced by a variable `{prefix}{row}{column}`
    /// (1-based; `{prefix}_{row}_{column}` where a dimension reaches 10), or by the
    /// variable of an equal or opposite entry bound before.
    pub fn bind(&mut self, g: &mut Graph, matrix: &Matrix, prefix: &str) -> Matrix {
        let wide = matrix.len() >= 10 || matrix.first().is_some_and(|row| row.len() >= 10);
        let mut out = matrix.clone();
        for (i, row) in matrix.iter().enumerate() {
            for (j, &value) in row.iter().enumerate() {
                let name = if wide {
                    format!("{prefix}_{}_{}", i + 1, j + 1)
                } else {
                    format!("{prefix}{}{}", i + 1, j + 1)
                };
                out[i][j] = self.entry(g, value, name);
            }
        }
        out
    }

    /// The variable for `value` (or `value` itself, a leaf or a leaf's negation).
    fn entry(&mut self, g: &mut Graph, value: NodeId, mut name: String) -> NodeId {
        let (negative, magnitude) = signed_magnitude(g, value);
        if g.is_leaf(magnitude) {
            return value;
        }
        if let Some(&(var, var_negative)) = self.bound.get(&magnitude) {
            return if var_negative == negative {
                var
            } else {
                g.neg(var)
            };
        }
        while self.avoid.contains(&name) {
            name.push('_');
        }
        let var = g.var(&name);
        // A later matrix bound under the same prefix (a split step's Jacobian at another
        // point) takes another name: two variables of one name would shadow each other.
        self.avoid.insert(name);
        self.definitions.push((var, value));
        self.bound.insert(magnitude, (var, negative));
        var
    }
}

/// `value` as a sign (`true`: negative) and a magnitude that an equal or opposite value
/// shares: a negation stripped, and a difference, alone or as a factor, written `a - b`
/// with `a` the earlier node, so that `0.5 (b - a)` and `-(0.5 (a - b))` meet.
fn signed_magnitude(g: &mut Graph, value: NodeId) -> (bool, NodeId) {
    use super::graph::Node;
    let (negative, v) = match g.node(value) {
        Node::Neg(inner) => (true, inner),
        _ => (false, value),
    };
    // `a - b` with `b` the earlier node, as `-(b - a)`.
    let reversed = |g: &Graph, id: NodeId| match g.node(id) {
        Node::Sub(a, b) if b < a => Some((b, a)),
        _ => None,
    };
    match g.node(v) {
        Node::Sub(..) => match reversed(g, v) {
            Some((a, b)) => (!negative, g.sub(a, b)),
            None => (negative, v),
        },
        Node::Mul(x, y) => {
            if let Some((a, b)) = reversed(g, y) {
                let difference = g.sub(a, b);
                (!negative, g.mul(x, difference))
            } else if let Some((a, b)) = reversed(g, x) {
                let difference = g.sub(a, b);
                (!negative, g.mul(difference, y))
            } else {
                (negative, v)
            }
        }
        _ => (negative, v),
    }
}

/// The identity of size `n`.
pub fn identity(g: &mut Graph, n: usize) -> Matrix {
    let (zero, one) = (g.zero(), g.one());
    (0..n)
        .map(|i| (0..n).map(|j| if i == j { one } else { zero }).collect())
        .collect()
}

/// The inverse of a symmetric positive-definite matrix through `S = L D L'`.
pub struct LdlInverse {
    /// The pivots `d_j` in order. The caller checks `d_j > 0` before it binds
    /// `reciprocals[j] = 1 / d_j`: later pivots and the inverse use the reciprocals only.
    pub pivots: Vec<NodeId>,
    /// Variables standing for `1 / d_j`.
    pub reciprocals: Vec<NodeId>,
    /// `S^-1`, in terms of the reciprocals.
    pub inverse: Matrix,
}

/// The unrolled factorisation `S = L D L'` of a symmetric matrix, `L` unit lower
/// triangular, written in terms of the reciprocal variables of the pivots.
pub struct LdlFactor {
    /// `L`, unit lower triangular (its diagonal and upper triangle are not used).
    pub l: Matrix,
    /// The pivots `d_j` in order, to be checked positive before their reciprocals are
    /// bound (as for [`LdlInverse`]).
    pub pivots: Vec<NodeId>,
    /// Variables standing for `1 / d_j`.
    pub reciprocals: Vec<NodeId>,
}

impl LdlFactor {
    /// `L^-1 b`: the forward substitution `w_i = b_i - sum_{k < i} L_ik w_k`.
    pub fn forward_substitute(&self, g: &mut Graph, b: &[NodeId]) -> Vec<NodeId> {
        let mut w: Vec<NodeId> = Vec::with_capacity(b.len());
        for (i, &bi) in b.iter().enumerate() {
            let mut v = bi;
            for (k, &wk) in w.iter().enumerate() {
                let term = g.mul(self.l[i][k], wk);
                v = g.sub(v, term);
            }
            w.push(v);
        }
        w
    }
}

/// Builds the unrolled factorisation `S = L D L'` of the symmetric `s`; `reciprocal(j)`
/// declares the variable that will hold `1 / d_j`, which later pivots and `L` use.
pub fn ldl_factor(
    g: &mut Graph,
    s: &Matrix,
    mut reciprocal: impl FnMut(&mut Graph, usize) -> NodeId,
) -> LdlFactor {
    let m = s.len();
    let zero = g.zero();
    let mut l = vec![vec![zero; m]; m];
    let mut d = Vec::with_capacity(m);
    let mut inv_d: Vec<NodeId> = Vec::with_capacity(m);
    for j in 0..m {
        // d_j = S_jj - sum_k L_jk^2 d_k
        let mut dj = s[j][j];
        for k in 0..j {
            let ljk_dk = g.mul(l[j][k], d[k]);
            let term = g.mul(ljk_dk, l[j][k]);
            dj = g.sub(dj, term);
        }
        d.push(dj);
        inv_d.push(reciprocal(g, j));
        // L_ij = (S_ij - sum_k L_ik L_jk d_k) / d_j
        for i in j + 1..m {
            let mut v = s[i][j];
            for k in 0..j {
                let lik_ljk = g.mul(l[i][k], l[j][k]);
                let term = g.mul(lik_ljk, d[k]);
                v = g.sub(v, term);
            }
            l[i][j] = g.mul(v, inv_d[j]);
        }
    }
    LdlFactor {
        l,
        pivots: d,
        reciprocals: inv_d,
    }
}

/// The solution of `S z = b` for a symmetric positive-definite `S`, through `S = L D L'`.
pub struct LdlSolve {
    /// The pivots `d_j` in order, to be checked positive as for [`LdlInverse`].
    pub pivots: Vec<NodeId>,
    /// Variables standing for `1 / d_j`.
    pub reciprocals: Vec<NodeId>,
    /// `z = S^-1 b`, in terms of the reciprocals.
    pub solution: Vec<NodeId>,
}

/// Builds the unrolled solve of `S z = b`: the factorisation, then forward substitution
/// `L w = b`, scaling `v = D^-1 w` and back substitution `L' z = v`. `reciprocal(j)`
/// declares the variable that will hold `1 / d_j`.
pub fn ldl_solve(
    g: &mut Graph,
    s: &Matrix,
    b: &[NodeId],
    reciprocal: impl FnMut(&mut Graph, usize) -> NodeId,
) -> LdlSolve {
    let m = s.len();
    let factor = ldl_factor(g, s, reciprocal);
    let w = factor.forward_substitute(g, b);
    let LdlFactor {
        l,
        pivots,
        reciprocals,
    } = factor;
    let scaled: Vec<NodeId> = w
        .iter()
        .zip(&reciprocals)
        .map(|(&wi, &inv)| g.mul(wi, inv))
        .collect();
    let mut z = vec![g.zero(); m];
    for i in (0..m).rev() {
        let mut v = scaled[i];
        for k in i + 1..m {
            let term = g.mul(l[k][i], z[k]);
            v = g.sub(v, term);
        }
        z[i] = v;
    }
    LdlSolve {
        pivots,
        reciprocals,
        solution: z,
    }
}

/// Builds the unrolled `L D L'` inverse of the symmetric `s`; `reciprocal(j)` declares the
/// variable that will hold `1 / d_j`.
pub fn ldl_inverse(
    g: &mut Graph,
    s: &Matrix,
    reciprocal: impl FnMut(&mut Graph, usize) -> NodeId,
) -> LdlInverse {
    let m = s.len();
    let zero = g.zero();
    let LdlFactor {
        l,
        pivots: d,
        reciprocals: inv_d,
    } = ldl_factor(g, s, reciprocal);
    // X = L^-1 (unit lower triangular), then S^-1 = X' D^-1 X.
    let one = g.one();
    let mut x = vec![vec![zero; m]; m];
    for i in 0..m {
        x[i][i] = one;
        for j in 0..i {
            let mut v = zero;
            for k in j..i {
                let term = g.mul(l[i][k], x[k][j]);
                v = g.add(v, term);
            }
            x[i][j] = g.neg(v);
        }
    }
    let mut inverse = vec![vec![zero; m]; m];
    for i in 0..m {
        for j in i..m {
            let mut v = zero;
            for k in j..m {
                let scaled = g.mul(x[k][i], inv_d[k]);
                let term = g.mul(scaled, x[k][j]);
                v = g.add(v, term);
            }
            inverse[i][j] = v;
            inverse[j][i] = v;
        }
    }
    LdlInverse {
        pivots: d,
        reciprocals: inv_d,
        inverse,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packed_positions_run_along_the_rows_of_the_upper_triangle() {
        let order: Vec<usize> = (0..3)
            .flat_map(|i| (i..3).map(move |j| packed_index(3, i, j)))
            .collect();
        assert_eq!(order, vec![0, 1, 2, 3, 4, 5]);
        assert_eq!(packed_index(3, 2, 1), packed_index(3, 1, 2));
        assert_eq!(packed_len(5), 15);
    }

    #[test]
    fn ldl_inverse_inverts() {
        let mut g = Graph::new();
        let values = [[4.0, 1.0, 0.5], [1.0, 3.0, 0.2], [0.5, 0.2, 2.0]];
        let s: Matrix = values
            .iter()
            .map(|row| row.iter().map(|&v| g.num(v)).collect())
            .collect();
        let mut names = Vec::new();
        let ldl = ldl_inverse(&mut g, &s, |g, j| {
            names.push(j);
            g.var(&format!("inv_d{j}"))
        });
        // Evaluate pivots in order, feeding each reciprocal back in.
        let mut reciprocal_values: Vec<f64> = Vec::new();
        for &pivot in &ldl.pivots {
            let known = reciprocal_values.clone();
            let d = g.eval(pivot, &move |v| known[v.0 as usize]);
            reciprocal_values.push(1.0 / d);
        }
        for i in 0..3 {
            for j in 0..3 {
                let known = reciprocal_values.clone();
                let product: f64 = (0..3)
                    .map(|k| {
                        let known = known.clone();
                        values[i][k] * g.eval(ldl.inverse[k][j], &move |v| known[v.0 as usize])
                    })
                    .sum();
                let expected = if i == j { 1.0 } else { 0.0 };
                assert!((product - expected).abs() < 1e-12, "({i},{j}): {product}");
            }
        }
    }
}
