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

/// [`riccati_step`] with the next `P` in fewer operations where one input acts on one
/// state (`B = b e_r`, the regulators of the demo models); otherwise that step itself.
/// The same recursion, `P <- A' M A + Q` with `M = P - P B W^-1 B' P` and
/// `W = R + b^2 P_rr`: `M B = P B W^-1 R` gives `M`'s row and column `r` as `P`'s scaled by
/// `R W^-1` (no difference of nearly equal terms), the others are
/// `P_ij - b^2 W^-1 P_ir P_jr`, and each entry of `A' M A` is a sum over `M`'s upper
/// triangle with coefficients of `A` alone, computed once before the horizon's loop.
// Index loops mirror the formulas' subscripts (M_kl, P_ir) more plainly than iterators.
#[allow(clippy::needless_range_loop)]
pub fn riccati_step_single_input(
    g: &mut Graph,
    (a, b): (&Matrix, &Matrix),
    p: &Matrix,
    (q, r): (&Matrix, &Matrix),
    reciprocal: impl FnMut(&mut Graph, usize) -> NodeId,
) -> RiccatiStep {
    let mut step = riccati_step(g, (a, b), p, (q, r), reciprocal);
    let Some(row) = single_entry(g, b) else {
        return step;
    };
    let n = p.len();
    let b_squared = g.mul(b[row][0], b[row][0]);
    let control = g.mul_whole(b_squared, p[row][row]);
    let weight = g.add(r[0][0], control);
    let inv_weight = step.reciprocals[0];
    let kept = g.mul_whole(r[0][0], inv_weight);
    let removed = g.mul_whole(b_squared, inv_weight);
    let zero = g.zero();
    let mut m = vec![vec![zero; n]; n];
    for i in 0..n {
        let removed_i = g.mul_whole(removed, p[i][row]);
        for j in i..n {
            m[i][j] = if i == row || j == row {
                g.mul_whole(p[i][j], kept)
            } else {
                let term = g.mul_whole(removed_i, p[j][row]);
                g.sub(p[i][j], term)
            };
            m[j][i] = m[i][j];
        }
    }
    let mut p_next = Vec::with_capacity(n * (n + 1) / 2);
    for i in 0..n {
        for j in i..n {
            let mut v = zero;
            for k in 0..n {
                for l in k..n {
                    let coefficient = sandwich_coefficient(g, a, (i, j), (k, l));
                    let term = g.mul_whole(coefficient, m[k][l]);
                    v = g.add(v, term);
                }
            }
            p_next.push(g.add(v, q[i][j]));
        }
    }
    step.p_next = p_next;
    step.pivots = vec![weight];
    step
}

/// The row of `B`'s only structurally nonzero entry, if it has one input and one such.
fn single_entry(g: &Graph, b: &Matrix) -> Option<usize> {
    if b.first().map_or(0, Vec::len) != 1 {
        return None;
    }
    let mut rows = (0..b.len()).filter(|&i| !g.is_zero(b[i][0]));
    let row = rows.next()?;
    rows.next().is_none().then_some(row)
}

/// The coefficient of `M_kl` (`k <= l`, with `M_lk`, symmetric) in `(A' M A)_ij`:
/// `A_ki A_lj + A_li A_kj`, or `A_ki A_kj` on the diagonal.
fn sandwich_coefficient(
    g: &mut Graph,
    a: &Matrix,
    (i, j): (usize, usize),
    (k, l): (usize, usize),
) -> NodeId {
    let first = g.mul(a[k][i], a[l][j]);
    if k == l {
        return first;
    }
    let second = g.mul(a[l][i], a[k][j]);
    g.add(first, second)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn constant(g: &mut Graph, rows: &[&[f64]]) -> Matrix {
        rows.iter()
            .map(|row| row.iter().map(|&v| g.num(v)).collect())
            .collect()
    }

    /// The single-input step equals the general one (both evaluated, the reciprocal
    /// variable bound to `1 / W`), and its pivot is the same weight.
    #[test]
    fn single_input_step_is_the_riccati_step() {
        let mut g = Graph::new();
        let a = constant(&mut g, &[&[1.0, 0.015], &[-6.0, 0.99]]);
        let b = constant(&mut g, &[&[0.0], &[0.3]]);
        let p = constant(&mut g, &[&[2.0, 0.7], &[0.7, 1.5]]);
        let q = constant(&mut g, &[&[1.0, 0.1], &[0.1, 2.0]]);
        let r = constant(&mut g, &[&[0.001]]);
        let general = riccati_step(&mut g, (&a, &b), &p, (&q, &r), |g, _| g.var("s"));
        let single = riccati_step_single_input(&mut g, (&a, &b), &p, (&q, &r), |g, _| g.var("s"));
        assert_ne!(
            general.p_next, single.p_next,
            "the compact form was not taken"
        );
        let no_vars = |_| f64::NAN;
        let w = g.eval(general.pivots[0], &no_vars);
        assert!((g.eval(single.pivots[0], &no_vars) - w).abs() < 1e-12 * w);
        let s = |_| 1.0 / w;
        for (&x, &y) in general.p_next.iter().zip(&single.p_next) {
            let (x, y) = (g.eval(x, &s), g.eval(y, &s));
            assert!((x - y).abs() < 1e-10 * x.abs().max(1.0), "{x} vs {y}");
        }
    }
}
