//! The error state of a model with rotations: its estimate is stored in the state's own
//! entries (a rotation as a unit quaternion `[x, y, z, w]`), its uncertainty in the
//! tangent space (a rotation as a rotation vector), as the error-state Kalman filter of
//! J. Solà, "Quaternion kinematics for the error-state Kalman filter" (2017), sect. 7, with
//! global (earth-frame) angular errors: the true rotation is `Exp(δθ) ⊗ q`. This is PX4
//! EKF2's convention since 2024. Here are the maps between the two spaces and their
//! Jacobians at zero error; a model without a rotation has the identity for each.

use super::graph::{Graph, NodeId};
use super::linalg::Matrix;
use crate::geometry;
use crate::model::{Model, Rotation};

/// Where a state vector's rotations are, and its two dimensions.
#[derive(Clone, Debug, Default)]
pub struct TangentLayout {
    /// The rotations, in order.
    pub rotations: Vec<Rotation>,
    /// The state vector's length.
    pub n_x: usize,
    /// The tangent space's dimension.
    pub n_p: usize,
}

impl TangentLayout {
    /// The layout of `model`'s state vector.
    pub fn of(model: &Model) -> TangentLayout {
        TangentLayout {
            rotations: model.rotations(),
            n_x: model.state_len(),
            n_p: model.tangent_len(),
        }
    }

    /// Whether the state has no rotation: both spaces are then one.
    pub fn is_euclidean(&self) -> bool {
        self.rotations.is_empty()
    }

    /// The entries that are not a rotation's, each with its tangent coordinate.
    fn euclidean(&self) -> Vec<(usize, usize)> {
        let mut pairs = Vec::with_capacity(self.n_x);
        let (mut i, mut k) = (0, 0);
        while i < self.n_x {
            if self.rotations.iter().any(|r| r.storage == i) {
                (i, k) = (i + 4, k + 3);
            } else {
                pairs.push((i, k));
                (i, k) = (i + 1, k + 1);
            }
        }
        pairs
    }
}

/// The quaternion stored at `r` in `x`.
fn quaternion(x: &[NodeId], r: Rotation) -> [NodeId; 4] {
    [
        x[r.storage],
        x[r.storage + 1],
        x[r.storage + 2],
        x[r.storage + 3],
    ]
}

/// `d(x ⊞ δx)/dδx` at `δx = 0` (`n_x × n_p`): one for an entry that is not a rotation's;
/// for a rotation `q`, perturbed as `Exp(δθ) ⊗ q`, the block
/// `½ [q_w I - [q_v]×; -q_vᵀ]` (the product `[δθ/2, 1] ⊗ q` differentiated).
pub fn retraction_jacobian(g: &mut Graph, layout: &TangentLayout, x: &[NodeId]) -> Matrix {
    let zero = g.zero();
    let mut j = vec![vec![zero; layout.n_p]; layout.n_x];
    for (i, k) in layout.euclidean() {
        j[i][k] = g.one();
    }
    let half = g.num(0.5);
    for &r in &layout.rotations {
        let [qx, qy, qz, qw] = quaternion(x, r).map(|e| g.mul(half, e));
        let (nx, ny, nz) = (g.neg(qx), g.neg(qy), g.neg(qz));
        // Rows x, y, z: q_w I - [q_v]×; row w: -q_vᵀ.
        let block = [[qw, qz, ny], [nz, qw, qx], [qy, nx, qw], [nx, ny, nz]];
        for (a, row) in block.iter().enumerate() {
            j[r.storage + a][r.tangent..r.tangent + 3].copy_from_slice(row);
        }
    }
    j
}

/// `d(y ⊟ x)/dy` at `y = x` (`n_p × n_x`), where `y ⊟ x` is the error that takes `x` to
/// `y`: one for an entry that is not a rotation's; for a rotation `r`, whose error is
/// `Log(y ⊗ r⁻¹)`, the block `2 [r_w I + [r_v]×, -r_v]`. At a unit `r` it is the inverse
/// of [`retraction_jacobian`]'s block: their product is `(r_w² + |r_v|²) I`.
pub fn local_jacobian(g: &mut Graph, layout: &TangentLayout, x: &[NodeId]) -> Matrix {
    let zero = g.zero();
    let mut j = vec![vec![zero; layout.n_x]; layout.n_p];
    for (i, k) in layout.euclidean() {
        j[k][i] = g.one();
    }
    let two = g.num(2.0);
    for &r in &layout.rotations {
        let [rx, ry, rz, rw] = quaternion(x, r).map(|e| g.mul(two, e));
        let (nx, ny, nz) = (g.neg(rx), g.neg(ry), g.neg(rz));
        // Columns x, y, z: r_w I + [r_v]×; column w: -r_v.
        let block = [[rw, nz, ry, nx], [rz, rw, nx, ny], [ny, rx, rw, nz]];
        for (a, row) in block.iter().enumerate() {
            j[r.tangent + a][r.storage..r.storage + 4].copy_from_slice(row);
        }
    }
    j
}

/// `x ⊞ δx`, exactly: `x + δx` for an entry that is not a rotation's, `Exp(δθ) ⊗ q` for a
/// rotation, renormalised by one Newton step so that its norm stays one to rounding.
pub fn retract(g: &mut Graph, layout: &TangentLayout, x: &[NodeId], dx: &[NodeId]) -> Vec<NodeId> {
    let mut next = x.to_vec();
    for (i, k) in layout.euclidean() {
        next[i] = g.add(x[i], dx[k]);
    }
    for &r in &layout.rotations {
        let theta = [dx[r.tangent], dx[r.tangent + 1], dx[r.tangent + 2]];
        let theta = geometry::share3(g, theta, "angle_correction");
        let increment = geometry::exp(g, theta);
        let increment = geometry::share4(g, increment, "increment");
        let turned = geometry::compose(g, increment, quaternion(x, r));
        let unit = geometry::renormalize(g, turned);
        next[r.storage..r.storage + 4].copy_from_slice(&unit);
    }
    next
}

/// The covariance after the error `dx` is moved into the estimate (Solà, sect. 7.3, with
/// global angular errors): `G P G'`, `G` the identity but for each rotation's block,
/// `I + [δθ/2]×`. The products skip `G`'s zeros: only a rotation's rows and columns mix.
pub fn reset_covariance(
    g: &mut Graph,
    layout: &TangentLayout,
    p: &Matrix,
    dx: &[NodeId],
) -> Matrix {
    let mut gp = p.clone();
    let half = g.num(0.5);
    let blocks: Vec<(usize, Matrix)> = layout
        .rotations
        .iter()
        .map(|r| {
            let [hx, hy, hz] = [0, 1, 2].map(|a| g.mul(half, dx[r.tangent + a]));
            let (one, nx, ny, nz) = (g.one(), g.neg(hx), g.neg(hy), g.neg(hz));
            let block = vec![vec![one, nz, hy], vec![hz, one, nx], vec![ny, hx, one]];
            (r.tangent, block)
        })
        .collect();
    for (t, block) in &blocks {
        for c in 0..layout.n_p {
            for a in 0..3 {
                let column: Vec<NodeId> = (0..3).map(|b| p[t + b][c]).collect();
                gp[t + a][c] = super::linalg::dot(g, &block[a], &column);
            }
        }
    }
    let mut gpg = gp.clone();
    for (t, block) in &blocks {
        for row in 0..layout.n_p {
            for a in 0..3 {
                let entries: Vec<NodeId> = (0..3).map(|b| gp[row][t + b]).collect();
                gpg[row][t + a] = super::linalg::dot(g, &block[a], &entries);
            }
        }
    }
    gpg
}

/// Whether the rotation `r` is advanced as `q ⊗ X` with `X` independent of `q` (a body
/// rate's `q * exp(w DT)`): `next`, its next value before renormalisation, reads `q` only
/// through `jacobian` (`d next / dq`, the rows and columns of `r` in the state's Jacobian),
/// which is then `X`'s right-multiplication matrix, reading no entry of `q`, and `next` is
/// zero at `q = 0`. Its global error then carries over unchanged
/// (`Exp(δθ) ⊗ q ⊗ X ⊗ (q ⊗ X)⁻¹ = Exp(δθ)`): the error-state Jacobian's block is exactly
/// the identity, which the chain of matrices computes only to rounding, at a cost.
pub fn turns_by_right_factor(
    g: &mut Graph,
    (x, next): (&[NodeId], &[NodeId]),
    r: Rotation,
    jacobian: &Matrix,
) -> bool {
    let s = r.storage;
    let block: Vec<&[NodeId]> = (s..s + 4).map(|i| &jacobian[i][s..s + 4]).collect();
    // `q ⊗ X` is `R(X) q`, and `R(X)`'s last column (the one of `q_w`) is `X` itself.
    let [xx, xy, xz, xw] = [0, 1, 2, 3].map(|i| block[i][3]);
    let (nx, ny, nz) = (g.neg(xx), g.neg(xy), g.neg(xz));
    let right = [
        [xw, xz, ny, xx],
        [nz, xw, xx, xy],
        [xy, nx, xw, xz],
        [nx, ny, nz, xw],
    ];
    let q_vars: Vec<_> = (s..s + 4)
        .filter_map(|i| match g.node(x[i]) {
            super::graph::Node::Var(v) => Some(v),
            _ => None,
        })
        .collect();
    let matches = block
        .iter()
        .zip(&right)
        .all(|(row, expected)| row == expected);
    if !matches || q_vars.len() != 4 || right.iter().flatten().any(|&e| g.reads_any(e, &q_vars)) {
        return false;
    }
    let zero = g.zero();
    let at_zero: Vec<(super::graph::VarId, NodeId)> = q_vars.iter().map(|&v| (v, zero)).collect();
    (s..s + 4).all(|i| {
        let value = super::graph::substitute(g, next[i], &at_zero);
        g.is_zero(value)
    })
}

/// `local · m · retraction`: a Jacobian over the state's entries taken to the tangent
/// space on either side given (`None` for the identity), skipping structural zeros.
pub fn to_tangent(
    g: &mut Graph,
    local: Option<&Matrix>,
    m: &Matrix,
    retraction: Option<&Matrix>,
) -> Matrix {
    let left = match local {
        Some(l) => super::linalg::matmul(g, l, m),
        None => m.clone(),
    };
    match retraction {
        Some(r) => super::linalg::matmul(g, &left, r),
        None => left,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A layout of a rotation between two scalars: `[a, q_x, q_y, q_z, q_w, b]`.
    fn layout() -> TangentLayout {
        TangentLayout {
            rotations: vec![Rotation {
                storage: 1,
                tangent: 1,
            }],
            n_x: 6,
            n_p: 5,
        }
    }

    /// The Jacobian of `next` over the variables `x`.
    fn jacobian(g: &mut Graph, next: &[NodeId], x: &[NodeId]) -> Matrix {
        let mut rows = vec![Vec::new(); next.len()];
        for &v in x {
            let super::super::graph::Node::Var(var) = g.node(v) else {
                unreachable!("x holds variables")
            };
            let mut d = super::super::diff::Differentiator::new(var);
            for (row, &n) in rows.iter_mut().zip(next) {
                row.push(d.diff(g, n));
            }
        }
        rows
    }

    /// `q ⊗ X` is recognised when `X` reads no entry of `q`; `X ⊗ q` and `q ⊗ q` are not.
    #[test]
    fn a_turn_by_a_right_factor_is_recognised() {
        let mut g = Graph::new();
        let x: Vec<NodeId> = (0..6).map(|i| g.var(&format!("x{i}"))).collect();
        let w = g.var("w");
        let (q, r) = (
            [x[1], x[2], x[3], x[4]],
            Rotation {
                storage: 1,
                tangent: 1,
            },
        );
        let rate = [x[0], w, x[5]];
        let increment = crate::geometry::exp(&mut g, rate);
        let cases = [
            (crate::geometry::compose(&mut g, q, increment), true),
            (crate::geometry::compose(&mut g, increment, q), false),
            (crate::geometry::compose(&mut g, q, q), false),
        ];
        for (turned, expected) in cases {
            let next = [x[0], turned[0], turned[1], turned[2], turned[3], x[5]];
            let a = jacobian(&mut g, &next, &x);
            let found = turns_by_right_factor(&mut g, (&x, &next), r, &a);
            assert_eq!(found, expected);
        }
    }

    /// The local Jacobian undoes the retraction's at a unit quaternion.
    #[test]
    fn local_jacobian_inverts_the_retraction_jacobian() {
        let mut g = Graph::new();
        let x: Vec<NodeId> = (0..6).map(|i| g.var(&format!("x{i}"))).collect();
        let layout = layout();
        let into = retraction_jacobian(&mut g, &layout, &x);
        let out = local_jacobian(&mut g, &layout, &x);
        let product = super::super::linalg::matmul(&mut g, &out, &into);
        let q = [0.1_f64, -0.7, 0.3, 0.5];
        let norm = q.iter().map(|v| v * v).sum::<f64>().sqrt();
        let values = [
            2.0,
            q[0] / norm,
            q[1] / norm,
            q[2] / norm,
            q[3] / norm,
            -1.0,
        ];
        let at = |v: super::super::graph::VarId| values[v.0 as usize];
        for (i, row) in product.iter().enumerate() {
            for (k, &entry) in row.iter().enumerate() {
                let expected = if i == k { 1.0 } else { 0.0 };
                let value = g.eval(entry, &|v| at(v));
                assert!((value - expected).abs() < 1e-15, "[{i}][{k}] = {value}");
            }
        }
    }
}
