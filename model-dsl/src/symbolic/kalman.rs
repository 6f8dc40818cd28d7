//! The Kalman filter's algebra on graph nodes, shared by every generated filter: the
//! covariance prediction and the Joseph-form measurement update (Alg. 1 and 2), the EKF's
//! prediction and correction with the model's `f`, `h` and their Jacobians.

use super::continuous::AtPoint;
use super::graph::{Graph, NodeId};
use super::linalg::{add, dot, ldl_inverse, matmul, sandwich_symmetric, transpose, Matrix};
use super::model_graph::ModelGraph;

/// `A P A' + Q`, upper triangle computed once.
pub fn predict_covariance(g: &mut Graph, a: &Matrix, p: &Matrix, q: &Matrix) -> Matrix {
    let apa = sandwich_symmetric(g, a, p, a);
    add(g, &apa, q)
}

/// [`predict_covariance`] with entry `ij` as `(A P)_j . A_i` rather than
/// `(A P)_i . A_j` (the same sum) where row `i` of `A` has fewer structural nonzeros than
/// row `j`, all among `j`'s: that row of `A P` is computed for the diagonal entry `jj`
/// anyway, and the sum has fewer terms (the EKF's `x1 = x1 + TS x2` row against the
/// cantilever's `x2` row).
pub fn predict_covariance_by_sparse_rows(
    g: &mut Graph,
    a: &Matrix,
    p: &Matrix,
    q: &Matrix,
) -> Matrix {
    let ap = matmul(g, a, p);
    let n = a.len();
    let support = |g: &Graph, row: &[NodeId]| -> Vec<usize> {
        (0..row.len()).filter(|&k| !g.is_zero(row[k])).collect()
    };
    let mut out = vec![vec![g.zero(); n]; n];
    for i in 0..n {
        for j in i..n {
            let (si, sj) = (support(g, &a[i]), support(g, &a[j]));
            let (dense, sparse) = if si.len() < sj.len() && si.iter().all(|k| sj.contains(k)) {
                (j, i)
            } else {
                (i, j)
            };
            let v = dot(g, &ap[dense], &a[sparse]);
            out[i][j] = v;
            out[j][i] = v;
        }
    }
    add(g, &out, q)
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
    /// The innovation covariance `S = C P C' + R` (symmetric; both triangles filled).
    pub s: Matrix,
    /// The normalised innovation squared, `r' S^-1 r`: chi-square distributed with as many
    /// degrees of freedom as measurements while the filter is consistent.
    pub nis: NodeId,
}

/// The normalised innovation squared `r' S^-1 r` of `residual`, given `S^-1`.
pub fn normalised_innovation_squared(
    g: &mut Graph,
    residual: &[NodeId],
    s_inverse: &Matrix,
) -> NodeId {
    let innovation: Matrix = residual.iter().map(|&e| vec![e]).collect();
    let s_inverse_r = matmul(g, s_inverse, &innovation);
    let mut nis = g.zero();
    for (&ri, sr) in residual.iter().zip(&s_inverse_r) {
        let term = g.mul(ri, sr[0]);
        nis = g.add(nis, term);
    }
    nis
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
    // P C' is shared by S, the gain and the covariance update.
    let pct = matmul(g, p, &transpose(c));
    let cpct = matmul(g, c, &pct);
    let s = add(g, &cpct, r);
    let ldl = ldl_inverse(g, &s, reciprocal);
    let innovation: Matrix = residual.iter().map(|&e| vec![e]).collect();
    let nis = normalised_innovation_squared(g, residual, &ldl.inverse);
    // K r as U (T r): the measurements' `T r` first, shared with the NIS, then one
    // product per state and measurement.
    let weighted = matmul(g, &ldl.inverse, &innovation);
    let correction = matmul(g, &pct, &weighted);
    let x_new = x
        .iter()
        .zip(&correction)
        .map(|(&xi, dx)| g.add(xi, dx[0]))
        .collect();
    // Joseph form, (I - K C) P (I - K C)' + K R K'. The gain is K = U T with U = P C'
    // and T the computed inverse of S (whatever its rounding), so the form expands
    // exactly to P - U (2 T - T S T) U': one product per entry of the triangle, where the
    // expansion P - K U' - (U - K S) K' takes two. With T = S^-1 exactly it is
    // P - U S^-1 U'; the difference 2 T - T S T - S^-1 = -(T - S^-1) S (T - S^-1) is of the
    // second order in T's error, as the Joseph form's is in the gain's.
    let two = g.num(2.0);
    let st = matmul(g, &s, &ldl.inverse);
    let m = residual.len();
    let twice_minus_st: Matrix = (0..m)
        .map(|i| {
            (0..m)
                .map(|j| {
                    let diagonal = if i == j { two } else { g.zero() };
                    g.sub(diagonal, st[i][j])
                })
                .collect()
        })
        .collect();
    let weight = matmul(g, &ldl.inverse, &twice_minus_st);
    let v = matmul(g, &pct, &weight);
    let zero = g.zero();
    let mut p_new = vec![vec![zero; n]; n];
    for i in 0..n {
        for j in i..n {
            let mut v_ij = p[i][j];
            for l in 0..m {
                let term = g.mul(v[i][l], pct[j][l]);
                v_ij = g.sub(v_ij, term);
            }
            p_new[i][j] = v_ij;
            p_new[j][i] = v_ij;
        }
    }
    Update {
        x: x_new,
        p: p_new,
        pivots: ldl.pivots,
        reciprocals: ldl.reciprocals,
        s,
        nis,
    }
}

/// The EKF's prediction (Alg. 1): `x = f(x, u)` and `P = A P A' + Q` with `A = df/dx` at
/// the estimate; with `t_prev`, both evaluated at that time (a step predicts from the
/// previous sample's time, and corrects at the measurement's).
pub fn ekf_predict(
    mg: &mut ModelGraph,
    p: &Matrix,
    q: &Matrix,
    t_prev: Option<NodeId>,
) -> (Vec<NodeId>, Matrix) {
    let mut a = mg.jacobian_f_wrt_x();
    let mut f = mg.f.clone();
    if let Some(t_prev) = t_prev {
        let at_prev = AtPoint::new(vec![mg.var_id(mg.t)]);
        f = at_prev.eval(&mut mg.graph, &[t_prev], &f);
        a = at_prev.eval_matrix(&mut mg.graph, &[t_prev], &a);
    }
    let p = predict_covariance_by_sparse_rows(&mut mg.graph, &a, p, q);
    (f, p)
}

/// A measurement update with the model's `h`, and the innovation it used.
pub struct Correction {
    /// The innovation `y - h(x)`, one entry per output corrected with.
    pub residual: Vec<NodeId>,
    /// The update.
    pub update: Update,
}

/// The EKF's correction (Alg. 1; Takacs et al., eqs. 24-26) of the estimate `x`, covariance `p`
/// with the measurement `y` of the model's outputs `outputs` and their noise covariance
/// `r`: `h` and its Jacobian `C = dh/dx` evaluated at `x` (and at the measurement's time
/// `t`, if given; else at the variable `t`), the innovation `y - h(x)`, and the
/// Joseph-form [`update`] (`reciprocal` declares the pivots' reciprocals).
pub fn ekf_correct(
    mg: &mut ModelGraph,
    (t, x): (Option<NodeId>, &[NodeId]),
    p: &Matrix,
    (y, outputs): (&[NodeId], &[usize]),
    r: &Matrix,
    reciprocal: impl FnMut(&mut Graph, usize) -> NodeId,
) -> Correction {
    let mut vars: Vec<_> = mg.x.iter().map(|&v| mg.var_id(v)).collect();
    let mut point = x.to_vec();
    if let Some(t) = t {
        vars.push(mg.var_id(mg.t));
        point.push(t);
    }
    let at = AtPoint::new(vars);
    let c = mg.jacobian_h_wrt_x();
    let c: Matrix = outputs.iter().map(|&i| c[i].clone()).collect();
    let c = at.eval_matrix(&mut mg.graph, &point, &c);
    let h: Vec<NodeId> = outputs.iter().map(|&i| mg.h[i]).collect();
    let h = at.eval(&mut mg.graph, &point, &h);
    let graph = &mut mg.graph;
    let residual: Vec<NodeId> = y.iter().zip(&h).map(|(&y, &h)| graph.sub(y, h)).collect();
    let update = update(graph, x, p, &residual, &c, r, reciprocal);
    Correction { residual, update }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The update's covariance is the Joseph form `(I - K C) P (I - K C)' + K R K'` with
    /// the gain `K = P C' t` it uses, also when `t` is not exactly `1 / S`.
    #[test]
    // Index loops mirror the formula's subscripts.
    #[allow(clippy::needless_range_loop)]
    fn update_is_the_joseph_form_of_its_gain() {
        let mut g = Graph::new();
        let pm = [[2.0, 0.3, -0.4], [0.3, 1.5, 0.2], [-0.4, 0.2, 0.9]];
        let cm = [0.7, -1.2, 0.5];
        let rm = 0.25;
        let p: Matrix = pm
            .iter()
            .map(|row| row.iter().map(|&v| g.num(v)).collect())
            .collect();
        let c: Matrix = vec![cm.iter().map(|&v| g.num(v)).collect()];
        let r = vec![vec![g.num(rm)]];
        let x: Vec<NodeId> = (0..3).map(|_| g.zero()).collect();
        let residual = vec![g.zero()];
        let update = update(&mut g, &x, &p, &residual, &c, &r, |g, _| g.var("t"));
        let s: f64 = rm
            + (0..3)
                .map(|i| (0..3).map(|j| cm[i] * pm[i][j] * cm[j]).sum::<f64>())
                .sum::<f64>();
        let t = 1.01 / s;
        let k: Vec<f64> = (0..3)
            .map(|i| (0..3).map(|j| pm[i][j] * cm[j]).sum::<f64>() * t)
            .collect();
        let a = |i: usize, j: usize| f64::from(u8::from(i == j)) - k[i] * cm[j];
        for i in 0..3 {
            for j in 0..3 {
                let mut joseph = k[i] * rm * k[j];
                for l in 0..3 {
                    for m in 0..3 {
                        joseph += a(i, l) * pm[l][m] * a(j, m);
                    }
                }
                let got = g.eval(update.p[i][j], &|_| t);
                assert!((got - joseph).abs() < 1e-12, "({i},{j}): {got} vs {joseph}");
            }
        }
    }
}
