//! The symbolic graph as an [`Algebra`] of scalars, so that vectors and rotations
//! ([`crate::geometry`], written once for the checks and the graph) expand into ordinary
//! graph nodes: structural zeros, shared subexpressions and cost counting apply to
//! geometry as to any scalar model.

use super::graph::{Graph, NodeId};
use crate::ast::Comparison;
use crate::geometry::Algebra;
use crate::model::Func;

/// Each operation is the graph's simplifying constructor. [`Algebra::share`] returns the
/// node itself, named for the generated code: the graph is hash-consed, so a node read
/// twice is computed once already.
impl Algebra for Graph {
    type S = NodeId;

    fn num(&mut self, value: f64) -> NodeId {
        Graph::num(self, value)
    }

    fn add(&mut self, a: NodeId, b: NodeId) -> NodeId {
        Graph::add(self, a, b)
    }

    fn sub(&mut self, a: NodeId, b: NodeId) -> NodeId {
        Graph::sub(self, a, b)
    }

    fn mul(&mut self, a: NodeId, b: NodeId) -> NodeId {
        Graph::mul(self, a, b)
    }

    fn div(&mut self, a: NodeId, b: NodeId) -> NodeId {
        Graph::div(self, a, b)
    }

    fn neg(&mut self, a: NodeId) -> NodeId {
        Graph::neg(self, a)
    }

    fn call(&mut self, f: Func, a: NodeId) -> NodeId {
        Graph::call(self, f, a)
    }

    fn atan2(&mut self, y: NodeId, x: NodeId) -> NodeId {
        Graph::atan2(self, y, x)
    }

    fn select(
        &mut self,
        cmp: Comparison,
        lhs: NodeId,
        rhs: NodeId,
        then: NodeId,
        otherwise: NodeId,
    ) -> NodeId {
        Graph::select(self, cmp, lhs, rhs, then, otherwise)
    }

    /// The graph computes a node once however often it is read: sharing only names it
    /// for the generated code, unless it has a name already.
    fn share(&mut self, a: NodeId, hint: &str) -> NodeId {
        self.set_name_hint(a, hint);
        a
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{self, ANGLE_EPSILON_SQUARED};
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
        let q = geometry::exp(&mut g, theta);
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
        let log_q = geometry::log(&mut g, q);
        let theta = vars::<3>(&mut g);
        let exp_theta = geometry::exp(&mut g, theta);
        let round_trip = geometry::log(&mut g, exp_theta);
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
        let log_q = geometry::log(&mut g, q);
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
        let product = geometry::compose(&mut g, a, b);
        let a_inverse = geometry::inverse(&mut g, a);
        let identity = geometry::compose(&mut g, a, a_inverse);
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
        let rotated = geometry::rotate(&mut g, q, v);
        let before = g.len();
        let back = geometry::inverse_rotate(&mut g, q, v);
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
        let sum = geometry::add(&mut g, a, b);
        let difference = geometry::sub(&mut g, a, b);
        let negated = geometry::neg(&mut g, a);
        let scaled = geometry::scale(&mut g, k, a);
        let product = geometry::cross(&mut g, a, b);
        let [inner, length, squared] = [
            geometry::dot(&mut g, a, b),
            geometry::norm(&mut g, a),
            geometry::norm_squared(&mut g, a),
        ];
        let unit = geometry::normalize(&mut g, a);
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
        let q = geometry::exp(&mut g, theta);
        let columns = jacobian(&mut g, q, 3);
        for (j, column) in columns.into_iter().enumerate() {
            let got = eval(&g, column, &[0.0; 3]);
            let mut want = [0.0; 4];
            want[j] = 0.5;
            assert_eq!(got, want, "dExp/dθ_{j} at 0 is column {j} of [I/2; 0]");
        }
        let mut g = Graph::new();
        let q = vars::<4>(&mut g);
        let log_q = geometry::log(&mut g, q);
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
        q: [NodeId; 4],
        columns: &[[NodeId; 4]],
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
        let q = geometry::exp(&mut g, theta);
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

    /// The error of `Exp`'s second derivatives near 0 that [`geometry::exp`] documents: a few ulps
    /// (here 4) of the cancelling terms `1/(2n)`, `n = sqrt(θ·θ + ε²)`. Measured: 5e-8 in
    /// `f64` and 32 in `f32` at `|θ| = 1e-9`, 0.06 in `f32` at 1e-6, 4e-4 at 1e-4.
    fn cancellation_bound(ulp: f64, angle: f64) -> f64 {
        let n = (angle * angle + ANGLE_EPSILON_SQUARED).sqrt();
        4.0 * ulp / (2.0 * n)
    }

    #[test]
    fn second_derivatives_of_exp_are_finite_and_exact_at_zero() {
        let mut g = Graph::new();
        let theta = vars::<3>(&mut g);
        let q = geometry::exp(&mut g, theta);
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
        let step = geometry::renormalize(&mut g, q);
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
        let q = geometry::exp(&mut g, theta);
        let back = geometry::log(&mut g, q);
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
