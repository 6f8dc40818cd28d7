//! The Kalman filter's algebra on graph nodes, shared by every generated filter: the
//! covariance prediction and the Joseph-form measurement update (Alg. 1 and 2), the EKF's
//! prediction and correction with the model's `f`, `h` and their Jacobians.

use super::continuous::AtPoint;
use super::graph::{Graph, NodeId};
use super::linalg::{
    add, dot, ldl_factor, matmul, sandwich_symmetric, sparser_row_last, transpose, Coefficients,
    Matrix,
};
use super::model_graph::ModelGraph;
use crate::model::Func;

/// `A P A' + Q`, upper triangle computed once.
pub fn predict_covariance(g: &mut Graph, a: &Matrix, p: &Matrix, q: &Matrix) -> Matrix {
    let apa = sandwich_symmetric(g, a, p, a);
    add(g, &apa, q)
}

/// [`predict_covariance`] with entry `ij` as `(A P)_j . A_i` rather than
/// `(A P)_i . A_j` where that sum has fewer terms ([`sparser_row_last`]: the EKF's
/// `x1 = x1 + TS x2` row against the cantilever's `x2` row).
// `out[i][j]` and its mirror `out[j][i]` are written together: index loops.
#[allow(clippy::needless_range_loop)]
pub fn predict_covariance_by_sparse_rows(
    g: &mut Graph,
    a: &Matrix,
    p: &Matrix,
    q: &Matrix,
) -> Matrix {
    let ap = matmul(g, a, p);
    let n = a.len();
    let mut out = vec![vec![g.zero(); n]; n];
    for i in 0..n {
        for j in i..n {
            let (dense, sparse) = sparser_row_last(g, a, i, j);
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
/// measurement Jacobian `c` and noise `r`, through the factorisation of the innovation
/// covariance `S = C P C' + R = L D L'` (guarded pivots: `reciprocal(graph, j)` declares
/// the variable for `t_j = 1 / d_j`), in the Joseph form.
///
/// With `U = P C'` and `Z = U L^-T` (each row of `U` forward-substituted through `L`),
/// `S^-1 = L^-T D^-1 L^-1` gives the gain `K = Z T L^-1`, `T = diag(t_j)`, the estimate
/// `x + Z T e` with `e = L^-1 r`, and the normalised innovation squared `sum_j t_j e_j^2`.
/// The Joseph form of that gain, `(I - K C) P (I - K C)' + K R K'`, expands to
/// `P - Z (2 T - T D T) Z'` where `L^-1 S L^-T = D`: per measurement `j`, the weight
/// `w_j = t_j (2 - d_j t_j)` and one multiply-add per entry of the triangle, as updating
/// with the factor's measurements one at a time does, in one pass. The reciprocals'
/// rounding reaches the weights at the second order (`w_j - 1 / d_j = -d_j (t_j - 1 /
/// d_j)^2`), as a gain's error reaches the Joseph form; `L`'s, through `L^-1 S L^-T - D`,
/// at the first, as every other rounding of the update does. One measurement: `L` is
/// empty, `Z = U`, `d = S`, and the form is the Joseph form of its gain exactly.
/// A large update (over `SMALL_UPDATE` values in `Z`) writes `Z W Z'` as `Y Y'` with
/// `Y = Z W^1/2`, `m` square roots (the FPU's `vsqrt`) for half the values kept.
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
    let m = residual.len();
    // P C' is shared by S, the gain and the covariance update.
    let pct = matmul(g, p, &transpose(c));
    let cpct = matmul(g, c, &pct);
    let s = add(g, &cpct, r);
    let factor = ldl_factor(g, &s, reciprocal);
    let t = factor.reciprocals.clone();
    let e = factor.forward_substitute(g, residual);
    let scaled: Vec<NodeId> = e.iter().zip(&t).map(|(&ej, &tj)| g.mul(ej, tj)).collect();
    let nis = dot(g, &e, &scaled);
    let z: Matrix = pct
        .iter()
        .map(|u_i| factor.forward_substitute(g, u_i))
        .collect();
    let x_new = x
        .iter()
        .zip(&z)
        .map(|(&xi, z_i)| {
            let correction = dot(g, z_i, &scaled);
            g.add(xi, correction)
        })
        .collect();
    let two = g.num(2.0);
    let weights: Vec<NodeId> = (0..m)
        .map(|j| {
            let dt = g.mul(factor.pivots[j], t[j]);
            let twice_minus = g.sub(two, dt);
            g.mul(t[j], twice_minus)
        })
        .collect();
    let p_new = if n * m > SMALL_UPDATE {
        // `Z W Z' = Y Y'` with `Y = Z W^1/2` (each `w_j > 0` where the pivot is): one
        // matrix of `n m` values where `Z` and `Z W` are two, which is what a large
        // update's code keeps in memory between its tests and its stores.
        let roots: Vec<NodeId> = weights.iter().map(|&w| g.call(Func::Sqrt, w)).collect();
        let y = scale_columns(g, &z, &roots);
        let mut p_new = subtract_products(g, p, &y, &y);
        measured_states_in_place(g, &mut p_new, c, (&factor, &y));
        p_new
    } else {
        let weighted = scale_columns(g, &z, &weights);
        subtract_products(g, p, &weighted, &z)
    };
    Update {
        x: x_new,
        p: p_new,
        pivots: factor.pivots,
        reciprocals: factor.reciprocals,
        s,
        nis,
    }
}

/// `P - A B'` (symmetric), upper triangle computed once.
fn subtract_products(g: &mut Graph, p: &Matrix, a: &Matrix, b: &Matrix) -> Matrix {
    let n = p.len();
    let zero = g.zero();
    let mut p_new = vec![vec![zero; n]; n];
    for i in 0..n {
        for j in i..n {
            let mut v_ij = p[i][j];
            for (&a_il, &b_jl) in a[i].iter().zip(&b[j]) {
                let term = g.mul(a_il, b_jl);
                v_ij = g.sub(v_ij, term);
            }
            p_new[i][j] = v_ij;
            p_new[j][i] = v_ij;
        }
    }
    p_new
}

/// The covariance of a state the update measures directly (a row `a` of `C` that is the
/// unit vector `e_s`: a GNSS fix of a position), `P - Y Y'` where `Y = Z W^1/2`, written
/// `Y G_a'` instead: `P_is = (L z_i)_a` and `z_i = W^-1/2 y_i`, so
/// `P_new_is = sum_l y_il G_al` with `G_al = L_al w_l^-1/2 - y_sl` (`L_aa = 1`, `L_al = 0`
/// for `l > a`), `m^2` values computed once. The code then keeps `Y` alone between its
/// tests and its stores, not `Y` and the covariance's column `s` it read to make `Z`.
/// `w_l^-1/2` is taken as `d_l^1/2`: with `e = 1 - d_l t_l` (the reciprocal's rounding),
/// `w_l d_l = 1 - e^2`, so the entry is the same to the second order in `e` (1e-14 in
/// `f32`), and no division is needed. The variance `P_ss` keeps its form, which the
/// step's tests read.
fn measured_states_in_place(
    g: &mut Graph,
    p_new: &mut Matrix,
    c: &Matrix,
    (factor, y): (&super::linalg::LdlFactor, &Matrix),
) {
    let m = factor.pivots.len();
    let measured: Vec<(usize, usize)> = c
        .iter()
        .enumerate()
        .filter_map(|(a, row)| {
            let ones: Vec<usize> = (0..row.len()).filter(|&k| g.is_one(row[k])).collect();
            let zeros = row.iter().filter(|&&v| g.is_zero(v)).count();
            (ones.len() == 1 && zeros + 1 == row.len()).then(|| (a, ones[0]))
        })
        .collect();
    if measured.is_empty() {
        return;
    }
    let roots: Vec<NodeId> = factor
        .pivots
        .iter()
        .map(|&d| g.call(Func::Sqrt, d))
        .collect();
    for (a, s) in measured {
        let gain: Vec<NodeId> = (0..m)
            .map(|l| {
                let l_al = match l.cmp(&a) {
                    std::cmp::Ordering::Less => g.mul(factor.l[a][l], roots[l]),
                    std::cmp::Ordering::Equal => roots[l],
                    std::cmp::Ordering::Greater => g.zero(),
                };
                g.sub(l_al, y[s][l])
            })
            .collect();
        for (i, y_i) in y.iter().enumerate().filter(|&(i, _)| i != s) {
            let entry = dot(g, y_i, &gain);
            p_new[i][s] = entry;
            p_new[s][i] = entry;
        }
    }
}

/// The most values (`n m`, states times measurements) an update keeps as `Z` and `Z W`
/// both; beyond, it keeps `Z W^1/2` alone (see [`update`]).
const SMALL_UPDATE: usize = 16;

/// `m` with each column `l` multiplied by `scales[l]`.
fn scale_columns(g: &mut Graph, m: &Matrix, scales: &[NodeId]) -> Matrix {
    m.iter()
        .map(|row| row.iter().zip(scales).map(|(&v, &s)| g.mul(v, s)).collect())
        .collect()
}

/// The EKF's prediction (Alg. 1): `x = f(x, u)` and `P = A P A' + Q` with `A = df/dx` at
/// the estimate; with `t_prev`, both evaluated at that time (a step predicts from the
/// previous sample's time, and corrects at the measurement's). With noise on inputs
/// (`input_noise`, each input's index with the variable of its variance per sample), `Q`
/// gains `G diag(qu) G'`, `G = df/du` over those inputs (as PX4's EKF2 maps its IMU's
/// noise). `A`'s and `G`'s computed entries are bound to variables (`a21`, `g21`) in
/// `coefficients`. Returns `f`, the new `P` and `A`.
pub fn ekf_predict(
    mg: &mut ModelGraph,
    (p, q): (&Matrix, &Matrix),
    input_noise: &[(usize, NodeId)],
    t_prev: Option<NodeId>,
    coefficients: &mut Coefficients,
) -> (Vec<NodeId>, Matrix, Matrix) {
    let mut a = mg.tangent_jacobian_f_wrt_x();
    let mut f = mg.f.clone();
    // Only a filter with noise on inputs differentiates by them: no other's graph changes.
    let mut gu = if input_noise.is_empty() {
        Vec::new()
    } else {
        let all = mg.tangent_jacobian_f_wrt_u();
        let columns = |row: &Vec<NodeId>| input_noise.iter().map(|&(j, _)| row[j]).collect();
        all.iter().map(columns).collect()
    };
    if let Some(t_prev) = t_prev {
        let at_prev = AtPoint::new(vec![mg.var_id(mg.t)]);
        f = at_prev.eval(&mut mg.graph, &[t_prev], &f);
        a = at_prev.eval_matrix(&mut mg.graph, &[t_prev], &a);
        if !gu.is_empty() {
            gu = at_prev.eval_matrix(&mut mg.graph, &[t_prev], &gu);
        }
    }
    let a = coefficients.bind(&mut mg.graph, &a, "a");
    let q = if input_noise.is_empty() {
        q.clone()
    } else {
        let gu = coefficients.bind(&mut mg.graph, &gu, "g");
        let variances: Vec<NodeId> = input_noise.iter().map(|&(_, v)| v).collect();
        let mapped = input_noise_covariance(&mut mg.graph, &gu, &variances);
        add(&mut mg.graph, q, &mapped)
    };
    let p = predict_covariance_by_sparse_rows(&mut mg.graph, &a, p, &q);
    (f, p, a)
}

/// `G diag(qu) G'`, the covariance the noise of variances `qu` on `G`'s columns makes:
/// `G diag(qu)` once, then its rows against `G`'s, upper triangle computed once; `G`'s
/// structural zeros skipped.
// `out[i][j]` and its mirror `out[j][i]` are written together: index loops.
#[allow(clippy::needless_range_loop)]
pub fn input_noise_covariance(g: &mut Graph, gu: &Matrix, qu: &[NodeId]) -> Matrix {
    let scaled = scale_columns(g, gu, qu);
    let n = gu.len();
    let mut out = vec![vec![g.zero(); n]; n];
    for i in 0..n {
        for j in i..n {
            let v = dot(g, &scaled[i], &gu[j]);
            out[i][j] = v;
            out[j][i] = v;
        }
    }
    out
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
/// Joseph-form [`update`] (`reciprocal` declares the pivots' reciprocals). `C`'s computed
/// entries are bound to variables (`c11`) in `coefficients`.
pub fn ekf_correct(
    mg: &mut ModelGraph,
    (t, x): (Option<NodeId>, &[NodeId]),
    p: &Matrix,
    (y, outputs): (&[NodeId], &[usize]),
    r: &Matrix,
    (coefficients, reciprocal): (&mut Coefficients, impl FnMut(&mut Graph, usize) -> NodeId),
) -> Correction {
    let mut vars: Vec<_> = mg.x.iter().map(|&v| mg.var_id(v)).collect();
    let mut point = x.to_vec();
    if let Some(t) = t {
        vars.push(mg.var_id(mg.t));
        point.push(t);
    }
    let at = AtPoint::new(vars);
    let c = mg.tangent_jacobian_h_wrt_x();
    let c: Matrix = outputs.iter().map(|&i| c[i].clone()).collect();
    let c = at.eval_matrix(&mut mg.graph, &point, &c);
    let c = coefficients.bind(&mut mg.graph, &c, "c");
    let h: Vec<NodeId> = outputs.iter().map(|&i| mg.h[i]).collect();
    let h = at.eval(&mut mg.graph, &point, &h);
    let layout = mg.tangent.clone();
    let graph = &mut mg.graph;
    let residual: Vec<NodeId> = y.iter().zip(&h).map(|(&y, &h)| graph.sub(y, h)).collect();
    if layout.is_euclidean() {
        let update = update(graph, x, p, &residual, &c, r, reciprocal);
        return Correction { residual, update };
    }
    // The error state (Solà, sect. 7): the update estimates the error `δx` (zero before
    // it), which moves into the estimate, and the covariance is reset around it.
    let zero = graph.zero();
    let mut update = update(
        graph,
        &vec![zero; layout.n_p],
        p,
        &residual,
        &c,
        r,
        reciprocal,
    );
    let dx = std::mem::take(&mut update.x);
    update.x = super::error_state::retract(graph, &layout, x, &dx);
    update.p = super::error_state::reset_covariance(graph, &layout, &update.p, &dx);
    Correction { residual, update }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `x + K r` and `(I - K C) P (I - K C)' + K R K'` with `K = P C' S^-1`, by plain
    /// arithmetic (`S^-1` by Gauss-Jordan elimination).
    // Index loops mirror the formula's subscripts.
    #[allow(clippy::needless_range_loop)]
    fn dense_joseph(
        x: &[f64],
        p: &[Vec<f64>],
        c: &[Vec<f64>],
        r: &[Vec<f64>],
        residual: &[f64],
    ) -> (Vec<f64>, Vec<Vec<f64>>) {
        let (n, m) = (x.len(), c.len());
        let u: Vec<Vec<f64>> = (0..n)
            .map(|i| {
                (0..m)
                    .map(|a| (0..n).map(|k| p[i][k] * c[a][k]).sum())
                    .collect()
            })
            .collect();
        let mut s: Vec<Vec<f64>> = (0..m)
            .map(|a| {
                (0..m)
                    .map(|b| (0..n).map(|k| c[a][k] * u[k][b]).sum::<f64>() + r[a][b])
                    .collect()
            })
            .collect();
        let mut inverse: Vec<Vec<f64>> = (0..m)
            .map(|a| (0..m).map(|b| f64::from(u8::from(a == b))).collect())
            .collect();
        for col in 0..m {
            let pivot = s[col][col];
            for b in 0..m {
                s[col][b] /= pivot;
                inverse[col][b] /= pivot;
            }
            for row in (0..m).filter(|&row| row != col) {
                let factor = s[row][col];
                for b in 0..m {
                    s[row][b] -= factor * s[col][b];
                    inverse[row][b] -= factor * inverse[col][b];
                }
            }
        }
        let k: Vec<Vec<f64>> = (0..n)
            .map(|i| {
                (0..m)
                    .map(|b| (0..m).map(|a| u[i][a] * inverse[a][b]).sum())
                    .collect()
            })
            .collect();
        let x_new = (0..n)
            .map(|i| x[i] + (0..m).map(|a| k[i][a] * residual[a]).sum::<f64>())
            .collect();
        let a = |i: usize, j: usize| {
            f64::from(u8::from(i == j)) - (0..m).map(|b| k[i][b] * c[b][j]).sum::<f64>()
        };
        let p_new = (0..n)
            .map(|i| {
                (0..n)
                    .map(|j| {
                        let mut v = 0.0;
                        for l in 0..n {
                            for q in 0..n {
                                v += a(i, l) * p[l][q] * a(j, q);
                            }
                        }
                        for b in 0..m {
                            for e in 0..m {
                                v += k[i][b] * r[b][e] * k[j][e];
                            }
                        }
                        v
                    })
                    .collect()
            })
            .collect();
        (x_new, p_new)
    }

    /// With several measurements, the update through `S`'s factorisation is the Kalman
    /// update in the Joseph form, whether it keeps `Z` and `Z W` (4 states, 3 outputs) or
    /// `Z W^1/2` alone (7 states, where the covariance of the directly measured states is
    /// written through `G`).
    #[test]
    // Index loops mirror the formula's subscripts.
    #[allow(clippy::needless_range_loop)]
    fn a_factored_update_is_the_joseph_form_of_the_kalman_gain() {
        for n in [4, 7] {
            let m = 3;
            let mut g = Graph::new();
            let value = |i: usize, j: usize| {
                let d = if i == j { 2.0 + i as f64 } else { 0.0 };
                d + 0.3 / (1.0 + (i + j) as f64)
            };
            let pm: Vec<Vec<f64>> = (0..n)
                .map(|i| (0..n).map(|j| value(i, j)).collect())
                .collect();
            // Two outputs measure a state directly (`e_1`, `e_3`; see
            // `measured_states_in_place`), one a combination.
            let cm: Vec<Vec<f64>> = (0..m)
                .map(|a| {
                    (0..n)
                        .map(|k| match a {
                            0 => f64::from(u8::from(k == 1)),
                            1 => ((a * 7 + k * 3) % 5) as f64 - 1.5,
                            _ => f64::from(u8::from(k == 3)),
                        })
                        .collect()
                })
                .collect();
            let rm: Vec<Vec<f64>> = (0..m)
                .map(|a| (0..m).map(|b| if a == b { 0.5 } else { 0.1 }).collect())
                .collect();
            let (xm, residual) = (
                (0..n).map(|i| i as f64).collect::<Vec<_>>(),
                [0.4, -1.1, 0.7],
            );
            let lift = |g: &mut Graph, m: &[Vec<f64>]| -> Matrix {
                m.iter()
                    .map(|row| row.iter().map(|&v| g.num(v)).collect())
                    .collect()
            };
            let (p, c, r) = (lift(&mut g, &pm), lift(&mut g, &cm), lift(&mut g, &rm));
            let x: Vec<NodeId> = xm.iter().map(|&v| g.num(v)).collect();
            let res: Vec<NodeId> = residual.iter().map(|&v| g.num(v)).collect();
            let update = update(&mut g, &x, &p, &res, &c, &r, |g, j| g.var(&format!("t{j}")));
            let mut t: Vec<f64> = Vec::new();
            for &pivot in &update.pivots {
                let known = t.clone();
                t.push(1.0 / g.eval(pivot, &move |v| known[v.0 as usize]));
            }
            let at = |id: NodeId| g.eval(id, &|v| t[v.0 as usize]);
            let (x_want, p_want) = dense_joseph(&xm, &pm, &cm, &rm, &residual);
            for i in 0..n {
                assert!((at(update.x[i]) - x_want[i]).abs() < 1e-12, "x{i}, n = {n}");
                for j in 0..n {
                    let (got, want) = (at(update.p[i][j]), p_want[i][j]);
                    assert!(
                        (got - want).abs() < 1e-12,
                        "P{i}{j}, n = {n}: {got} vs {want}"
                    );
                }
            }
        }
    }

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
