//! 3-vectors and rotations (unit quaternions) as ordinary graph nodes (issue 40).
//!
//! A vector is three nodes, a quaternion four stored `[x, y, z, w]` (nalgebra's
//! `Quaternion::coords` order, SymForce's `Rot3` storage). Every operation expands to
//! scalar nodes through the simplifying constructors, so structural zeros, shared
//! subexpressions and cost counting apply to geometry as to any scalar model.
//!
//! Conventions follow Solà, "Quaternion kinematics for the error-state Kalman filter"
//! (2017), cited below as "Solà" by section: Hamilton product, `R(q) v = q ⊗ v ⊗ q*`
//! (active rotation, as nalgebra's `q * v`).

use super::graph::{Graph, NodeId};
use super::linalg;
use crate::ast::Comparison;
use crate::model::Func;

/// A 3-vector's components, `[x, y, z]`.
pub type Vec3Nodes = [NodeId; 3];

/// A quaternion's components, stored `[x, y, z, w]` (vector part, then scalar part).
pub type QuatNodes = [NodeId; 4];

/// A 3×3 matrix, row by row.
pub type Mat3Nodes = [[NodeId; 3]; 3];

/// `ε²` of the exponential map and logarithm, `|θ| ≈ sqrt(θ·θ + ε²)` (see [`exp`]).
///
/// One literal serves `f32` and `f64`: `ε²/8` (its largest effect on a value) is below
/// `f64`'s rounding of 1 (1.1e-16), and `ε⁴ = 1e-36` (the smallest denominator of a
/// second derivative) is above `f32`'s smallest normal number (1.2e-38).
pub const EPSILON_SQUARED: f64 = 1e-18;

/// `a + b`
pub fn vec_add(g: &mut Graph, a: Vec3Nodes, b: Vec3Nodes) -> Vec3Nodes {
    [0, 1, 2].map(|i| g.add(a[i], b[i]))
}

/// `a - b`
pub fn vec_sub(g: &mut Graph, a: Vec3Nodes, b: Vec3Nodes) -> Vec3Nodes {
    [0, 1, 2].map(|i| g.sub(a[i], b[i]))
}

/// `-a`
pub fn vec_neg(g: &mut Graph, a: Vec3Nodes) -> Vec3Nodes {
    a.map(|c| g.neg(c))
}

/// `k a`, a scalar times a vector.
pub fn vec_scale(g: &mut Graph, k: NodeId, a: Vec3Nodes) -> Vec3Nodes {
    a.map(|c| g.mul(k, c))
}

/// `a · b = a_x b_x + a_y b_y + a_z b_z`
pub fn dot(g: &mut Graph, a: Vec3Nodes, b: Vec3Nodes) -> NodeId {
    linalg::dot(g, &a, &b)
}

/// `a × b = [a_y b_z - a_z b_y, a_z b_x - a_x b_z, a_x b_y - a_y b_x]`, right-handed.
pub fn cross(g: &mut Graph, a: Vec3Nodes, b: Vec3Nodes) -> Vec3Nodes {
    [(1, 2), (2, 0), (0, 1)].map(|(i, j)| {
        let (ab, ba) = (g.mul(a[i], b[j]), g.mul(a[j], b[i]));
        g.sub(ab, ba)
    })
}

/// `|a|² = a · a`
pub fn norm_squared(g: &mut Graph, a: Vec3Nodes) -> NodeId {
    dot(g, a, a)
}

/// `|a| = sqrt(a · a)`, exact (no `ε`): its derivative `a/|a|` does not exist at 0,
/// where it evaluates to NaN, as `sqrt`'s does.
pub fn norm(g: &mut Graph, a: Vec3Nodes) -> NodeId {
    let squared = norm_squared(g, a);
    g.call(Func::Sqrt, squared)
}

/// `a / |a|`, as `a (1/|a|)`: one division, three products (one more rounding than three
/// divisions). Undefined (NaN) at `a = 0`, like nalgebra's `normalize`.
pub fn normalize(g: &mut Graph, a: Vec3Nodes) -> Vec3Nodes {
    let length = norm(g, a);
    let one = g.one();
    let reciprocal = g.div(one, length);
    vec_scale(g, reciprocal, a)
}

/// The vector part `[x, y, z]` of a quaternion.
pub fn vector_part(q: QuatNodes) -> Vec3Nodes {
    [q[0], q[1], q[2]]
}

/// The Hamilton product `a ⊗ b` (Solà sect. 1.2.2):
/// `[a_w b_v + b_w a_v + a_v × b_v, a_w b_w - a_v · b_v]`, 16 products and 12 sums.
/// `R(a ⊗ b) = R(a) R(b)`: `b` acts first.
pub fn compose(g: &mut Graph, a: QuatNodes, b: QuatNodes) -> QuatNodes {
    let (av, bv) = (vector_part(a), vector_part(b));
    let (aw_bv, bw_av) = (vec_scale(g, a[3], bv), vec_scale(g, b[3], av));
    let sum = vec_add(g, aw_bv, bw_av);
    let turn = cross(g, av, bv);
    let [x, y, z] = vec_add(g, sum, turn);
    let (ww, vv) = (g.mul(a[3], b[3]), dot(g, av, bv));
    [x, y, z, g.sub(ww, vv)]
}

/// The conjugate `q* = [-q_v, q_w]` (Solà sect. 1.2.4), which is the inverse of a unit
/// quaternion (sect. 1.2.6, `q⁻¹ = q*/|q|²`).
pub fn conjugate(g: &mut Graph, q: QuatNodes) -> QuatNodes {
    let [x, y, z] = vec_neg(g, vector_part(q));
    [x, y, z, q[3]]
}

/// The rotation matrix of a unit quaternion (Solà sect. 2.5, its unit-norm form):
///
/// ```text
/// R = [ 1 - 2(y² + z²)   2(xy - wz)       2(xz + wy)
///       2(xy + wz)       1 - 2(x² + z²)   2(yz - wx)
///       2(xz - wy)       2(yz + wx)       1 - 2(x² + y²) ]
/// ```
///
/// Its nine products are nodes of their own, shared by every entry (and by [`rotate`]
/// and [`inverse_rotate`] on the same `q`). The form assumes `|q| = 1`; for another norm
/// it is not a multiple of a rotation (the homogeneous form would be).
pub fn rotation_matrix(g: &mut Graph, q: QuatNodes) -> Mat3Nodes {
    let [x, y, z, w] = q;
    let [xx, yy, zz] = [x, y, z].map(|c| g.mul(c, c));
    let [xy, xz, yz] = [(x, y), (x, z), (y, z)].map(|(a, b)| g.mul(a, b));
    let [wx, wy, wz] = [x, y, z].map(|c| g.mul(w, c));
    let (one, two) = (g.one(), g.num(2.0));
    let mut diagonal = |a: NodeId, b: NodeId| {
        let sum = g.add(a, b);
        let twice = g.mul(two, sum);
        g.sub(one, twice)
    };
    let (r00, r11, r22) = (diagonal(yy, zz), diagonal(xx, zz), diagonal(xx, yy));
    let mut twice = |a: NodeId, b: NodeId, plus: bool| {
        let inner = if plus { g.add(a, b) } else { g.sub(a, b) };
        g.mul(two, inner)
    };
    let (r01, r10) = (twice(xy, wz, false), twice(xy, wz, true));
    let (r02, r20) = (twice(xz, wy, true), twice(xz, wy, false));
    let (r12, r21) = (twice(yz, wx, false), twice(yz, wx, true));
    [[r00, r01, r02], [r10, r11, r12], [r20, r21, r22]]
}

/// `q * v = R(q) v` (Solà sect. 2.4, `q ⊗ v ⊗ q*`, with the matrix of [`rotation_matrix`]).
pub fn rotate(g: &mut Graph, q: QuatNodes, v: Vec3Nodes) -> Vec3Nodes {
    let r = rotation_matrix(g, q);
    r.map(|row| linalg::dot(g, &row, &v))
}

/// `q⁻¹ * v = R(q)ᵀ v`, on the same nine products as [`rotate`].
pub fn inverse_rotate(g: &mut Graph, q: QuatNodes, v: Vec3Nodes) -> Vec3Nodes {
    let r = rotation_matrix(g, q);
    [0, 1, 2].map(|j| {
        let column = [r[0][j], r[1][j], r[2][j]];
        linalg::dot(g, &column, &v)
    })
}

/// `sqrt(v·v + ε²)`, the regularised length of [`exp`] and [`log`].
fn padded_norm(g: &mut Graph, v: Vec3Nodes) -> NodeId {
    let squared = norm_squared(g, v);
    let epsilon_squared = g.num(EPSILON_SQUARED);
    let padded = g.add(squared, epsilon_squared);
    g.call(Func::Sqrt, padded)
}

/// The exponential map of a rotation vector `θ`, `Exp(θ) = e^(θ/2)` of the pure quaternion
/// `θ/2` (Solà sect. 1.3.4; the rotation by `φ = |θ|` about `u = θ/φ`, sect. 2.4):
/// `[u sin(φ/2), cos(φ/2)]`, computed exact and branch-free:
/// `n = sqrt(θ·θ + ε²)`, `Exp(θ) = [θ sin(n/2)/n, cos(n/2)]`. The sine and cosine of
/// one argument become one `sin_cos` in the lowering.
///
/// Why `ε` ([`EPSILON_SQUARED`] = 1e-18):
/// - **Values.** `sin(n/2)/n` and `cos(n/2)` are even and flat in `n` at 0, so `n` in place
///   of `|θ|` moves them by at most `ε²/48` and `ε²/8`, below rounding in `f32` and `f64`.
///   At `θ = 0`, `sin(n/2)/n = 1/2` and `cos(n/2) = 1` exactly: the identity.
/// - **Jacobian at 0**, `[I/2; 0]` (`Jr(0) = I`), with no `0·∞`: `dn/dθ_j = θ_j/n` is 0
///   over a finite `n = 1e-9`, so the derivative of `sin(n/2)/n` is exactly 0 there.
///   Near 0 the quotient rule's two terms (each about `1/(2n)`) cancel; the error is an
///   ulp of them, multiplied by `θ_i θ_j / n ≤ n`: an ulp of `1/2` at most.
/// - **Second derivatives** divide by `n⁴ ≥ 1e-36`, normal in `f32`: finite everywhere.
///   At 0 they are exact to rounding (the cancelling term is multiplied by `θ = 0`). Near
///   0 it is not multiplied away: the error is a few ulps of `1/(2n)`, absolute, against
///   entries of about 1/4. Measured: in `f64` 5e-8 at `|θ| = 1e-9`, 2e-10 at 1e-6; in
///   `f32` 32 at 1e-9, 0.06 at 1e-6, 4e-4 at 1e-4, 1e-5 at 1e-2. A Taylor arm for small
///   `|θ|` (design step 11) would remove it.
pub fn exp(g: &mut Graph, theta: Vec3Nodes) -> QuatNodes {
    let n = padded_norm(g, theta);
    let half = g.num(0.5);
    let half_angle = g.mul(half, n);
    let (sine, cosine) = (g.call(Func::Sin, half_angle), g.call(Func::Cos, half_angle));
    let k = g.div(sine, n);
    let [x, y, z] = vec_scale(g, k, theta);
    [x, y, z, cosine]
}

/// The logarithm of a unit quaternion as a rotation vector, the inverse of [`exp`] (Solà
/// sect. 1.3.6, `Log(q) = 2 atan2(|v|, w) v/|v|`): the shortest rotation, branch-free and
/// total. `n = sqrt(v·v + ε²)`, `σ = -1 if w < 0 else 1`, `Log(q) = σ (2 atan2(n, |w|)/n) v`.
///
/// - **`q` and `-q`** give the same vector (`σ` flips with `v`), of angle at most `π`.
///   At `w = 0` exactly (a half turn) `q` and `-q` give opposite vectors, the two names of
///   that rotation; across `w = 0` the result jumps between them, as every logarithm of
///   SO(3) must somewhere.
/// - **Exact, not first order.** `atan2(n, |w|)/n` is even and flat in `n` at 0 (for
///   `|w| > 0`), so `ε` moves it by at most `ε²/(3w²)` relative, and by at most
///   `ε²/(2|v|²)`: below rounding for a unit `q`, whose `|w|` or `|v|` is at least 0.7.
///   Near the identity it is `2v` (derivative `2I`); near a half turn (`w ≈ 0`) `atan2`
///   keeps full accuracy, where `2 acos(w)` would not.
/// - **Total.** `n ≥ ε`: no division by zero, whatever `q`; `Log(0) = 0`.
///   `atan2` sees only the ratio of `|v|` to `|w|`, so a non-unit `q` gives the log of
///   `q/|q|` (for `|v| ≫ ε`).
///
/// Matches nalgebra's `UnitQuaternion::scaled_axis`, which uses the same `atan2` and sign.
pub fn log(g: &mut Graph, q: QuatNodes) -> Vec3Nodes {
    let (v, w) = (vector_part(q), q[3]);
    let n = padded_norm(g, v);
    let magnitude_w = g.call(Func::Abs, w);
    let half_angle = g.atan2(n, magnitude_w);
    let two = g.num(2.0);
    let angle = g.mul(two, half_angle);
    let k = g.div(angle, n);
    let (zero, minus_k) = (g.zero(), g.neg(k));
    let signed = g.select(Comparison::Lt, w, zero, minus_k, k);
    vec_scale(g, signed, v)
}

/// One Newton step towards a unit quaternion, `q (3 - q·q)/2`, written `q (1.5 - 0.5 q·q)`:
/// Newton's iteration for `1/sqrt(q·q)` from 1. With `q·q = 1 + e` the result's squared
/// norm is `1 - 3e²/4 + e³/4`: the error is squared, with no `sqrt` or division.
/// 9 products, 4 sums.
pub fn renormalize(g: &mut Graph, q: QuatNodes) -> QuatNodes {
    let squared = linalg::dot(g, &q, &q);
    let (three_halves, half) = (g.num(1.5), g.num(0.5));
    let half_squared = g.mul(half, squared);
    let factor = g.sub(three_halves, half_squared);
    q.map(|c| g.mul(factor, c))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::symbolic::diff::Differentiator;
    use crate::symbolic::graph::{Node, VarId};
    use nalgebra::{Matrix3, Quaternion, Unit, UnitQuaternion, Vector3, Vector4};
    use std::collections::HashMap;
    use std::f64::consts::PI;

    /// The angles of the design's step 3: zero, below and at `ε`, small, and near a half turn.
    const ANGLES: [f64; 7] = [0.0, 1e-20, 1e-9, 1e-4, 0.1, 1.0, PI - 1e-3];

    /// Unit axes: two coordinate axes and a few in general position.
    fn axes() -> Vec<Vector3<f64>> {
        [
            [1.0, 0.0, 0.0],
            [0.0, 0.0, -1.0],
            [0.3, -0.5, 0.81],
            [-0.7, 0.2, -0.1],
            [0.577, 0.6, -0.55],
        ]
        .iter()
        .map(|a| Vector3::from(*a).normalize())
        .collect()
    }

    /// Every angle of [`ANGLES`] about every axis of [`axes`].
    fn rotation_vectors() -> Vec<Vector3<f64>> {
        let axes = axes();
        ANGLES
            .iter()
            .flat_map(|&angle| axes.iter().map(move |axis| axis * angle))
            .collect()
    }

    /// `Exp(t)` by nalgebra's `from_axis_angle`, exact at every angle. (Its
    /// `from_scaled_axis` returns the identity for `|t| <= 2 f64::EPSILON`, a first-order
    /// value: at 1e-20 its vector part is 0, not `t/2`.)
    fn reference_exp(t: &Vector3<f64>) -> UnitQuaternion<f64> {
        match Unit::try_new(*t, 0.0) {
            Some(axis) => UnitQuaternion::from_axis_angle(&axis, t.norm()),
            None => UnitQuaternion::identity(),
        }
    }

    /// `N` fresh variables: in a new graph the `i`-th is `VarId(i)`.
    fn vars<const N: usize>(g: &mut Graph) -> [NodeId; N] {
        std::array::from_fn(|i| g.var(&format!("v{i}")))
    }

    /// The nodes' values with `VarId(i)` = `values[i]`.
    fn eval<const N: usize>(g: &Graph, nodes: [NodeId; N], values: &[f64]) -> [f64; N] {
        nodes.map(|node| g.eval(node, &|v: VarId| values[v.0 as usize]))
    }

    fn assert_relative(got: f64, want: f64, tolerance: f64, what: &str) {
        let error = (got - want).abs();
        assert!(
            error <= tolerance * want.abs(),
            "{what}: {got:e} vs {want:e} (error {error:e})"
        );
    }

    fn assert_absolute(got: f64, want: f64, tolerance: f64, what: &str) {
        let error = (got - want).abs();
        assert!(
            error <= tolerance,
            "{what}: {got:e} vs {want:e} (error {error:e})"
        );
    }

    #[test]
    fn exp_matches_nalgebra() {
        let mut g = Graph::new();
        let theta = vars::<3>(&mut g);
        let q = exp(&mut g, theta);
        for t in rotation_vectors() {
            let got = eval(&g, q, t.as_slice());
            let want = reference_exp(&t).into_inner().coords;
            for i in 0..3 {
                assert_relative(got[i], want[i], 1e-14, &format!("Exp({t:?})[{i}]"));
            }
            // cos(φ/2) near a half turn is ill-conditioned: the two computations' ulp of
            // φ/2 (2.2e-16) moves it by as much, absolutely; relative to |q| = 1 it is rounding.
            assert_absolute(got[3], want[3], 1e-15, &format!("Exp({t:?}).w"));
        }
    }

    #[test]
    fn log_matches_nalgebra_scaled_axis_and_inverts_exp() {
        let mut g = Graph::new();
        let q = vars::<4>(&mut g);
        let log_q = log(&mut g, q);
        let theta = vars::<3>(&mut g);
        let exp_theta = exp(&mut g, theta);
        let round_trip = log(&mut g, exp_theta);
        for t in rotation_vectors() {
            let unit = reference_exp(&t);
            let got = eval(&g, log_q, unit.coords.as_slice());
            let want = unit.scaled_axis();
            let mut values = vec![f64::NAN; 4];
            values.extend(t.iter());
            let back = eval(&g, round_trip, &values);
            for i in 0..3 {
                assert_relative(got[i], want[i], 1e-14, &format!("Log at {t:?}[{i}]"));
                assert_relative(back[i], t[i], 1e-14, &format!("Log(Exp({t:?}))[{i}]"));
            }
        }
    }

    #[test]
    fn q_and_minus_q_have_the_same_log_the_shortest_rotation() {
        let mut g = Graph::new();
        let q = vars::<4>(&mut g);
        let log_q = log(&mut g, q);
        for t in rotation_vectors() {
            let unit = reference_exp(&t).into_inner().coords;
            let got = eval(&g, log_q, unit.as_slice());
            let opposite = eval(&g, log_q, (-unit).as_slice());
            assert_eq!(got, opposite, "Log(q) and Log(-q) at {t:?}");
            let angle = Vector3::from(got).norm();
            assert!(angle <= PI, "Log(-q) at {t:?} has angle {angle}");
        }
        // Past a half turn, Exp gives w < 0; Log names the rotation by its short way round.
        let t = Vector3::new(0.0, 0.0, 2.0 * PI - 0.5);
        let past = reference_exp(&t).into_inner().coords;
        assert!(past[3] < 0.0);
        let got = eval(&g, log_q, past.as_slice());
        assert_absolute(got[2], -0.5, 1e-15, "Log of a turn of 2π - 0.5");
    }

    #[test]
    fn compose_is_the_hamilton_product_and_the_conjugate_inverts() {
        let mut g = Graph::new();
        let (a, b) = (vars::<4>(&mut g), vars::<4>(&mut g));
        let product = compose(&mut g, a, b);
        let a_inverse = conjugate(&mut g, a);
        let identity = compose(&mut g, a, a_inverse);
        let axes = axes();
        for (i, t) in rotation_vectors().iter().enumerate() {
            let qa = reference_exp(t).into_inner();
            // b is not a unit quaternion: the product is bilinear, any norm will do.
            let qb = Quaternion::from_vector(Vector4::new(0.3, -1.2, 0.7, 2.0))
                * UnitQuaternion::from_scaled_axis(axes[i % axes.len()]).into_inner();
            let mut values = qa.coords.as_slice().to_vec();
            values.extend(qb.coords.iter());
            let got = eval(&g, product, &values);
            let want = (qa * qb).coords;
            for k in 0..4 {
                assert_absolute(got[k], want[k], 1e-15 * qb.norm(), &format!("a ⊗ b [{k}]"));
            }
            let unit = eval(&g, identity, &values);
            let one = [0.0, 0.0, 0.0, 1.0];
            for k in 0..4 {
                assert_absolute(unit[k], one[k], 1e-15, &format!("q ⊗ q* [{k}] at {t:?}"));
            }
        }
    }

    #[test]
    fn rotations_match_nalgebra_on_the_same_nine_products() {
        let mut g = Graph::new();
        let (q, v) = (vars::<4>(&mut g), vars::<3>(&mut g));
        let rotated = rotate(&mut g, q, v);
        let before = g.len();
        let back = inverse_rotate(&mut g, q, v);
        // R' v needs only new sums and products with v: no new product of q's components.
        let of_q = |id: NodeId| q.contains(&id);
        for id in g.ids().skip(before) {
            if let Node::Mul(x, y) = g.node(id) {
                assert!(
                    !(of_q(x) && of_q(y)),
                    "R'(q) v computes a product of q again"
                );
            }
        }
        let vector = Vector3::new(1.5, -0.25, 4.0);
        for t in rotation_vectors() {
            let unit = reference_exp(&t);
            let mut values = unit.coords.as_slice().to_vec();
            values.extend(vector.iter());
            let (got, got_back) = (eval(&g, rotated, &values), eval(&g, back, &values));
            let (want, want_back) = (unit * vector, unit.inverse_transform_vector(&vector));
            let tolerance = 1e-14 * vector.norm();
            assert!(
                (Vector3::from(got) - want).norm() <= tolerance,
                "q * v at {t:?}"
            );
            let error_back = (Vector3::from(got_back) - want_back).norm();
            assert!(error_back <= tolerance, "q⁻¹ * v at {t:?}");
        }
    }

    #[test]
    fn vector_operations_match_nalgebra() {
        let mut g = Graph::new();
        let (a, b, k) = (vars::<3>(&mut g), vars::<3>(&mut g), g.var("k"));
        let sum = vec_add(&mut g, a, b);
        let difference = vec_sub(&mut g, a, b);
        let negated = vec_neg(&mut g, a);
        let scaled = vec_scale(&mut g, k, a);
        let product = cross(&mut g, a, b);
        let [inner, length, squared] =
            [dot(&mut g, a, b), norm(&mut g, a), norm_squared(&mut g, a)];
        let unit = normalize(&mut g, a);
        let (x, y, s) = (
            Vector3::new(0.3, -2.0, 5.5),
            Vector3::new(-1.25, 0.5, 3.0),
            -0.75,
        );
        let mut values = x.as_slice().to_vec();
        values.extend(y.iter().chain([s].iter()));
        let vectors = [
            (sum, x + y),
            (difference, x - y),
            (negated, -x),
            (scaled, x * s),
        ];
        for (nodes, want) in vectors.into_iter().chain([(product, x.cross(&y))]) {
            let got = Vector3::from(eval(&g, nodes, &values));
            assert!(
                (got - want).norm() <= 1e-15 * want.norm(),
                "{got:?} vs {want:?}"
            );
        }
        let got_unit = Vector3::from(eval(&g, unit, &values));
        assert!((got_unit - x.normalize()).norm() <= 1e-15, "normalize");
        let [inner, length, squared] = eval(&g, [inner, length, squared], &values);
        assert_relative(inner, x.dot(&y), 1e-15, "dot");
        assert_relative(length, x.norm(), 1e-15, "norm");
        assert_relative(squared, x.norm_squared(), 1e-15, "norm_squared");
    }

    /// `∂ roots[i] / ∂ VarId(j)` for the first `columns` variables, as nodes.
    fn jacobian<const N: usize>(
        g: &mut Graph,
        roots: [NodeId; N],
        columns: usize,
    ) -> Vec<[NodeId; N]> {
        (0..columns)
            .map(|j| {
                let mut d = Differentiator::new(VarId(j as u32));
                roots.map(|root| d.diff(g, root))
            })
            .collect()
    }

    #[test]
    fn derivatives_at_the_identity_are_exact() {
        let mut g = Graph::new();
        let theta = vars::<3>(&mut g);
        let q = exp(&mut g, theta);
        let columns = jacobian(&mut g, q, 3);
        for (j, column) in columns.into_iter().enumerate() {
            let got = eval(&g, column, &[0.0; 3]);
            let mut want = [0.0; 4];
            want[j] = 0.5;
            assert_eq!(got, want, "dExp/dθ_{j} at 0 is column {j} of [I/2; 0]");
        }
        let mut g = Graph::new();
        let q = vars::<4>(&mut g);
        let log_q = log(&mut g, q);
        let columns = jacobian(&mut g, log_q, 4);
        for (j, column) in columns.into_iter().enumerate() {
            let got = eval(&g, column, &[0.0, 0.0, 0.0, 1.0]);
            let mut want = [0.0; 3];
            if j < 3 {
                want[j] = 2.0;
            }
            assert_eq!(
                got, want,
                "dLog/dq_{j} at the identity is column {j} of [2I, 0]"
            );
        }
    }

    /// `[θ]x`, the skew-symmetric matrix with `[θ]x v = θ × v`.
    fn skew(t: &Vector3<f64>) -> Matrix3<f64> {
        Matrix3::new(0.0, -t.z, t.y, t.z, 0.0, -t.x, -t.y, t.x, 0.0)
    }

    /// `Jr(θ) = I - (1 - cos φ)/φ² [θ]x + (φ - sin φ)/φ³ [θ]x²` (Solà, "A micro Lie theory
    /// for state estimation in robotics", 2018, the right Jacobian of SO(3)), `φ = |θ|`.
    fn right_jacobian_closed_form(t: &Vector3<f64>) -> Matrix3<f64> {
        let phi = t.norm();
        let k = skew(t);
        Matrix3::identity() - k * ((1.0 - phi.cos()) / (phi * phi))
            + k * k * ((phi - phi.sin()) / (phi * phi * phi))
    }

    /// `Jr` by central differences of nalgebra's maps: column `j` is
    /// `(Log(q⁻¹ Exp(θ + h e_j)) - Log(q⁻¹ Exp(θ - h e_j))) / 2h`.
    fn right_jacobian_by_differences(t: &Vector3<f64>) -> Matrix3<f64> {
        let inverse = reference_exp(t).inverse();
        let h = 1e-6;
        let step = |j: usize, h: f64| {
            let moved = t + Vector3::ith(j, h);
            (inverse * UnitQuaternion::from_scaled_axis(moved)).scaled_axis()
        };
        Matrix3::from_fn(|i, j| (step(j, h)[i] - step(j, -h)[i]) / (2.0 * h))
    }

    /// `Jr(θ)` from the graph's derivative of `Exp`: `q(θ + δ) = q ⊗ Exp(Jr δ)`, which is
    /// `q ⊗ [Jr δ/2, 1]` to first order, so `Jr e_j = 2 vec(q* ⊗ ∂q/∂θ_j)`.
    fn right_jacobian_symbolic(
        g: &Graph,
        q: QuatNodes,
        columns: &[QuatNodes],
        t: &Vector3<f64>,
    ) -> Matrix3<f64> {
        let value = |nodes| Quaternion::from_vector(Vector4::from(eval(g, nodes, t.as_slice())));
        let inverse = value(q).conjugate();
        Matrix3::from_fn(|i, j| 2.0 * (inverse * value(columns[j])).imag()[i])
    }

    #[test]
    fn right_jacobian_of_exp_matches_central_differences() {
        let mut g = Graph::new();
        let theta = vars::<3>(&mut g);
        let q = exp(&mut g, theta);
        let columns = jacobian(&mut g, q, 3);
        let axes = axes();
        for (t, closed) in [(1e-4, false), (0.1, true), (1.0, true), (3.0, true)]
            .into_iter()
            .flat_map(|(angle, closed)| axes.iter().map(move |a| (a * angle, closed)))
        {
            let symbolic = right_jacobian_symbolic(&g, q, &columns, &t);
            let differences = right_jacobian_by_differences(&t);
            let error = (symbolic - differences).amax();
            assert!(
                error <= 1e-8,
                "Jr at {t:?}: error {error:e} against differences"
            );
            if closed {
                let error = (symbolic - right_jacobian_closed_form(&t)).amax();
                assert!(
                    error <= 1e-14,
                    "Jr at {t:?}: error {error:e} against the formula"
                );
            }
        }
    }

    /// `∂² roots[i] / ∂ VarId(j) ∂ VarId(l)`, indexed `[j][l]`.
    fn hessian<const N: usize>(g: &mut Graph, roots: [NodeId; N]) -> Vec<Vec<[NodeId; N]>> {
        let first = jacobian(g, roots, 3);
        first
            .into_iter()
            .map(|column| jacobian(g, column, 3))
            .collect()
    }

    /// `∂² Exp(θ)_i / ∂θ_j ∂θ_l` by the Taylor series at 0 (`θ sin(φ/2)/φ = θ/2 - θ s/48`,
    /// `cos(φ/2) = 1 - s/8 + s²/384`, `s = θ·θ`), to `O(|θ|³)`.
    fn exp_second_derivative_near_zero(t: &Vector3<f64>, i: usize, j: usize, l: usize) -> f64 {
        let delta = |a: usize, b: usize| if a == b { 1.0 } else { 0.0 };
        if i == 3 {
            let s = t.norm_squared();
            return -delta(j, l) / 4.0 + t[j] * t[l] / 48.0 + s * delta(j, l) / 96.0;
        }
        -(delta(i, j) * t[l] + delta(i, l) * t[j] + t[i] * delta(j, l)) / 24.0
    }

    /// The largest error of the second derivatives of `Exp` at `t`, evaluated by `eval`.
    fn exp_second_derivative_error(
        hessian: &[Vec<[NodeId; 4]>],
        t: &Vector3<f64>,
        eval: impl Fn([NodeId; 4]) -> [f64; 4],
    ) -> f64 {
        let mut largest: f64 = 0.0;
        for (j, row) in hessian.iter().enumerate() {
            for (l, entry) in row.iter().enumerate() {
                for (i, got) in eval(*entry).into_iter().enumerate() {
                    assert!(got.is_finite(), "d²Exp_{i}/dθ_{j}dθ_{l} at {t:?}: {got}");
                    let want = exp_second_derivative_near_zero(t, i, j, l);
                    largest = largest.max((got - want).abs());
                }
            }
        }
        largest
    }

    /// The error of `Exp`'s second derivatives near 0 that `exp` documents: a few ulps
    /// (here 4) of the cancelling terms `1/(2n)`, `n = sqrt(θ·θ + ε²)`. Measured: 5e-8 in
    /// `f64` and 32 in `f32` at `|θ| = 1e-9`, 0.06 in `f32` at 1e-6, 4e-4 at 1e-4.
    fn cancellation_bound(ulp: f64, angle: f64) -> f64 {
        let n = (angle * angle + EPSILON_SQUARED).sqrt();
        4.0 * ulp / (2.0 * n)
    }

    #[test]
    fn second_derivatives_of_exp_are_finite_and_exact_at_zero() {
        let mut g = Graph::new();
        let theta = vars::<3>(&mut g);
        let q = exp(&mut g, theta);
        let second = hessian(&mut g, q);
        let zero = Vector3::zeros();
        let at_zero = exp_second_derivative_error(&second, &zero, |n| eval(&g, n, &[0.0; 3]));
        assert!(at_zero <= f64::EPSILON / 4.0, "at 0: error {at_zero:e}");
        for angle in [1e-20, 1e-9, 1e-6, 1e-4] {
            for axis in axes() {
                let t = axis * angle;
                let error = exp_second_derivative_error(&second, &t, |n| eval(&g, n, t.as_slice()));
                let bound = cancellation_bound(f64::EPSILON, angle) + 1e-12;
                assert!(error <= bound, "at {t:?}: error {error:e} above {bound:e}");
            }
        }
    }

    #[test]
    fn newton_step_squares_the_norm_error() {
        let mut g = Graph::new();
        let q = vars::<4>(&mut g);
        let step = renormalize(&mut g, q);
        for t in rotation_vectors() {
            let unit = reference_exp(&t).into_inner().coords;
            let same = eval(&g, step, unit.as_slice());
            assert!(
                (Vector4::from(same) - unit).amax() <= 2.0 * f64::EPSILON,
                "{t:?}"
            );
            for stretch in [1e-3, -1e-4, 1e-6] {
                let e = (1.0 + stretch) * (1.0 + stretch) - 1.0;
                let stretched = unit * (1.0 + stretch);
                let got = Vector4::from(eval(&g, step, stretched.as_slice()));
                let want = -0.75 * e * e + 0.25 * e * e * e;
                assert_absolute(got.norm_squared() - 1.0, want, 4.0 * f64::EPSILON, "norm²");
            }
        }
    }

    /// `f(x)` in `f32`, as generated code computes it (`std`'s functions here, the runtime
    /// crate's there).
    fn call_f32(f: Func, x: f32) -> f32 {
        match f {
            Func::Sin => x.sin(),
            Func::Cos => x.cos(),
            Func::Sqrt => x.sqrt(),
            Func::Abs => x.abs(),
            other => unreachable!("geometry does not call {other:?}"),
        }
    }

    /// `root` evaluated in `f32`, literals rounded to `f32` as the lowering writes them;
    /// the graph has no `f32` evaluator of its own.
    fn eval_f32(g: &Graph, root: NodeId, values: &[f32]) -> f32 {
        let mut done: HashMap<NodeId, f32> = HashMap::new();
        for id in g.pending_from(root, Node::children, |_| false) {
            let at = |a: NodeId| done[&a];
            let value = match g.node(id) {
                Node::Num(bits) => f64::from_bits(bits) as f32,
                Node::Named(c) => g.const_info(c).value as f32,
                Node::Var(v) => values[v.0 as usize],
                Node::Neg(a) => -at(a),
                Node::Add(a, b) => at(a) + at(b),
                Node::Sub(a, b) => at(a) - at(b),
                Node::Mul(a, b) => at(a) * at(b),
                Node::Div(a, b) => at(a) / at(b),
                Node::Call(f, a) => call_f32(f, at(a)),
                Node::Atan2(y, x) => at(y).atan2(at(x)),
                Node::Select {
                    cmp,
                    lhs,
                    rhs,
                    then,
                    otherwise,
                } => {
                    let holds = cmp.holds(at(lhs).into(), at(rhs).into());
                    at(if holds { then } else { otherwise })
                }
            };
            done.insert(id, value);
        }
        done[&root]
    }

    #[test]
    fn exp_and_log_are_sane_in_f32() {
        let mut g = Graph::new();
        let theta = vars::<3>(&mut g);
        let q = exp(&mut g, theta);
        let back = log(&mut g, q);
        let (first, second) = (jacobian(&mut g, q, 3), hessian(&mut g, q));
        let eval32 = |nodes: [NodeId; 4], t: &[f32]| nodes.map(|n| eval_f32(&g, n, t));
        for t in rotation_vectors() {
            let t32 = t.map(|c| c as f32);
            let got = eval32(q, t32.as_slice());
            let want = reference_exp(&t).into_inner().coords;
            for i in 0..4 {
                let error = (f64::from(got[i]) - want[i]).abs();
                let scale = if i == 3 { 1.0 } else { want[i].abs() };
                assert!(
                    error <= 4.0 * f64::from(f32::EPSILON) * scale,
                    "Exp({t:?})[{i}]"
                );
            }
            let round_trip = back.map(|n| eval_f32(&g, n, t32.as_slice()));
            for i in 0..3 {
                let error = (round_trip[i] - t32[i]).abs();
                assert!(
                    error <= 4.0 * f32::EPSILON * t32[i].abs(),
                    "Log(Exp({t:?}))[{i}]"
                );
            }
        }
        for (j, column) in first.into_iter().enumerate() {
            let mut want = [0.0; 4];
            want[j] = 0.5;
            assert_eq!(eval32(column, &[0.0; 3]), want, "dExp/dθ_{j} at 0 in f32");
        }
        // Finite everywhere, exact at 0; near 0 the cancellation costs an ulp of 1/(2n).
        for angle in [0.0, 1e-20, 1e-9, 1e-6, 1e-4, 1e-2] {
            let t = axes()[2] * angle;
            let t32 = t.map(|c| c as f32);
            let error = exp_second_derivative_error(&second, &t, |n| {
                eval32(n, t32.as_slice()).map(f64::from)
            });
            let bound = cancellation_bound(f32::EPSILON.into(), angle) + 1e-6;
            assert!(
                error <= bound,
                "f32 at |θ| = {angle:e}: {error:e} above {bound:e}"
            );
        }
    }
}
