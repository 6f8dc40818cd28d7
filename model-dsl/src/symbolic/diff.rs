//! Symbolic differentiation on the graph, memoised per variable.

use super::graph::{Graph, Node, NodeId, VarId};
use crate::ast::Comparison;
use crate::fast_hash::FastMap;
use crate::model::Func;

/// Differentiates graph nodes with respect to one variable, reusing earlier results.
pub struct Differentiator {
    var: VarId,
    memo: FastMap<NodeId, NodeId>,
}

/// The operands a node's derivative is built from: a piecewise term differentiates its
/// branches, not its condition.
fn operands_to_differentiate(node: Node) -> Vec<NodeId> {
    match node {
        Node::Select {
            then, otherwise, ..
        } => vec![then, otherwise],
        other => other.children(),
    }
}

impl Differentiator {
    /// A differentiator with respect to `var`.
    pub fn new(var: VarId) -> Differentiator {
        Differentiator {
            var,
            memo: FastMap::default(),
        }
    }

    /// `d root / d var`. Built with the simplifying constructors, so a derivative that is
    /// structurally zero is the literal zero node.
    ///
    /// Works through the nodes in the graph's order (operands first) rather than by
    /// recursion, so a model whose `let`s chain ten thousand deep cannot exhaust the stack.
    pub fn diff(&mut self, g: &mut Graph, root: NodeId) -> NodeId {
        let pending = g.pending_from(root, operands_to_differentiate, |id| {
            self.memo.contains_key(&id)
        });
        for id in pending {
            let d = self.diff_node(g, id);
            self.memo.insert(id, d);
        }
        self.memo[&root]
    }

    /// The derivative of one node whose operands' derivatives are known.
    fn diff_node(&mut self, g: &mut Graph, root: NodeId) -> NodeId {
        let known = |memo: &FastMap<NodeId, NodeId>, id: NodeId| memo[&id];
        match g.node(root) {
            Node::Num(_) | Node::Named(_) => g.zero(),
            Node::Var(v) => {
                if v == self.var {
                    g.one()
                } else {
                    g.zero()
                }
            }
            Node::Neg(a) => {
                let da = known(&self.memo, a);
                g.neg(da)
            }
            Node::Add(a, b) => {
                let (da, db) = (known(&self.memo, a), known(&self.memo, b));
                g.add(da, db)
            }
            Node::Sub(a, b) => {
                let (da, db) = (known(&self.memo, a), known(&self.memo, b));
                g.sub(da, db)
            }
            Node::Mul(a, b) => {
                // (ab)' = a'b + ab'
                let (da, db) = (known(&self.memo, a), known(&self.memo, b));
                let (left, right) = (g.mul(da, b), g.mul(a, db));
                g.add(left, right)
            }
            Node::Div(a, b) => {
                // (a/b)' = a'/b - a b' / b^2
                let (da, db) = (known(&self.memo, a), known(&self.memo, b));
                let first = g.div(da, b);
                let b_squared = g.mul(b, b);
                let a_db = g.mul(a, db);
                let second = g.div(a_db, b_squared);
                g.sub(first, second)
            }
            Node::Call(f, a) => {
                let da = known(&self.memo, a);
                if g.is_zero(da) {
                    return da;
                }
                let outer = self.derivative_of(g, f, a, root);
                g.mul(outer, da)
            }
            Node::Atan2(y, x) => {
                // d atan2(y, x) = (x dy - y dx) / (x^2 + y^2)
                let (dy, dx) = (known(&self.memo, y), known(&self.memo, x));
                let (x_dy, y_dx) = (g.mul(x, dy), g.mul(y, dx));
                let numerator = g.sub(x_dy, y_dx);
                if g.is_zero(numerator) {
                    return numerator;
                }
                let (xx, yy) = (g.mul(x, x), g.mul(y, y));
                let radius_squared = g.add(xx, yy);
                g.div(numerator, radius_squared)
            }
            Node::Select {
                cmp,
                lhs,
                rhs,
                then,
                otherwise,
            } => {
                // Piecewise terms differentiate branch by branch (the kink has measure zero).
                let (dt, de) = (known(&self.memo, then), known(&self.memo, otherwise));
                g.select(cmp, lhs, rhs, dt, de)
            }
        }
    }

    /// `f'(a)`, given `call` = `f(a)` so results such as `exp` can reuse it.
    fn derivative_of(&mut self, g: &mut Graph, f: Func, a: NodeId, call: NodeId) -> NodeId {
        match f {
            Func::Sin => g.call(Func::Cos, a),
            Func::Cos => {
                let s = g.call(Func::Sin, a);
                g.neg(s)
            }
            Func::Tan => {
                // 1 + tan^2
                let one = g.one();
                let sq = g.mul(call, call);
                g.add(one, sq)
            }
            Func::Exp => call,
            Func::Ln => {
                let one = g.one();
                g.div(one, a)
            }
            Func::Sqrt => {
                // 1 / (2 sqrt a)
                let half = g.num(0.5);
                g.div(half, call)
            }
            Func::Tanh => {
                // 1 - tanh^2
                let one = g.one();
                let sq = g.mul(call, call);
                g.sub(one, sq)
            }
            Func::Abs => {
                // sign(a), taking +1 at zero
                let zero = g.zero();
                let (one, minus_one) = (g.one(), g.num(-1.0));
                g.select(Comparison::Ge, a, zero, one, minus_one)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn var_of(g: &Graph, node: NodeId) -> VarId {
        match g.node(node) {
            Node::Var(v) => v,
            _ => unreachable!(),
        }
    }

    #[test]
    fn product_rule_and_structural_zeros() {
        let mut g = Graph::new();
        let (x, y) = (g.var("x"), g.var("y"));
        let xx = g.mul(x, x);
        let mut d = Differentiator::new(var_of(&g, x));
        let dxx = d.diff(&mut g, xx);
        let two = g.num(2.0);
        assert_eq!(g.node(dxx), Node::Mul(two, x));
        let mut dy = Differentiator::new(var_of(&g, y));
        let zero = dy.diff(&mut g, xx);
        assert!(g.is_zero(zero), "d(x^2)/dy is a structural zero");
    }

    #[test]
    fn chain_rule_through_functions() {
        let mut g = Graph::new();
        let x = g.var("x");
        let sin = g.call(Func::Sin, x);
        let mut d = Differentiator::new(var_of(&g, x));
        let dsin = d.diff(&mut g, sin);
        assert_eq!(g.node(dsin), Node::Call(Func::Cos, x));
        let exp = g.call(Func::Exp, sin);
        let dexp = d.diff(&mut g, exp);
        assert_eq!(g.node(dexp), Node::Mul(dsin, exp));
    }

    #[test]
    fn piecewise_terms_differentiate_branch_by_branch() {
        let mut g = Graph::new();
        let x = g.var("x");
        let (zero, k) = (g.zero(), g.named_const("K", 3.0));
        let kx = g.mul(k, x);
        let spring = g.select(Comparison::Gt, x, zero, kx, zero);
        let mut d = Differentiator::new(var_of(&g, x));
        let dspring = d.diff(&mut g, spring);
        assert_eq!(
            g.node(dspring),
            Node::Select {
                cmp: Comparison::Gt,
                lhs: x,
                rhs: zero,
                then: k,
                otherwise: zero
            }
        );
    }

    #[test]
    fn derivatives_match_finite_differences() {
        let mut g = Graph::new();
        let x = g.var("x");
        let (sqrt, ln, tan, abs) = (
            g.call(Func::Sqrt, x),
            g.call(Func::Ln, x),
            g.call(Func::Tan, x),
            g.call(Func::Abs, x),
        );
        let quotient = g.div(sqrt, ln);
        let product = g.mul(tan, abs);
        let expr = g.add(quotient, product);
        let mut d = Differentiator::new(var_of(&g, x));
        let derivative = d.diff(&mut g, expr);
        for point in [0.3, 1.7, 2.9] {
            let at = |v: f64| g.eval(expr, &move |_| v);
            let h = 1e-6;
            let fd = (at(point + h) - at(point - h)) / (2.0 * h);
            let exact = g.eval(derivative, &|_| point);
            assert!(
                (fd - exact).abs() < 1e-6 * exact.abs().max(1.0),
                "{fd} vs {exact}"
            );
        }
    }
}
