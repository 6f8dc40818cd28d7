//! Symbolic differentiation on the graph, memoised per variable.

use super::graph::{Graph, Node, NodeId, VarId};
use crate::ast::Comparison;
use crate::model::Func;
use std::collections::HashMap;

/// Differentiates graph nodes with respect to one variable, reusing earlier results.
pub struct Differentiator {
    var: VarId,
    memo: HashMap<NodeId, NodeId>,
}

impl Differentiator {
    /// A differentiator with respect to `var`.
    pub fn new(var: VarId) -> Differentiator {
        Differentiator {
            var,
            memo: HashMap::new(),
        }
    }

    /// `d root / d var`. Built with the simplifying constructors, so a derivative that is
    /// structurally zero is the literal zero node.
    pub fn diff(&mut self, g: &mut Graph, root: NodeId) -> NodeId {
        if let Some(&d) = self.memo.get(&root) {
            return d;
        }
        let d = match g.node(root) {
            Node::Num(_) | Node::Named(_) => g.zero(),
            Node::Var(v) => {
                if v == self.var {
                    g.one()
                } else {
                    g.zero()
                }
            }
            Node::Neg(a) => {
                let da = self.diff(g, a);
                g.neg(da)
            }
            Node::Add(a, b) => {
                let (da, db) = (self.diff(g, a), self.diff(g, b));
                g.add(da, db)
            }
            Node::Sub(a, b) => {
                let (da, db) = (self.diff(g, a), self.diff(g, b));
                g.sub(da, db)
            }
            Node::Mul(a, b) => {
                // (ab)' = a'b + ab'
                let (da, db) = (self.diff(g, a), self.diff(g, b));
                let (left, right) = (g.mul(da, b), g.mul(a, db));
                g.add(left, right)
            }
            Node::Div(a, b) => {
                // (a/b)' = a'/b - a b' / b^2
                let (da, db) = (self.diff(g, a), self.diff(g, b));
                let first = g.div(da, b);
                let b_squared = g.mul(b, b);
                let a_db = g.mul(a, db);
                let second = g.div(a_db, b_squared);
                g.sub(first, second)
            }
            Node::Call(f, a) => {
                let da = self.diff(g, a);
                if g.is_zero(da) {
                    return self.remember(root, da);
                }
                let outer = self.derivative_of(g, f, a, root);
                g.mul(outer, da)
            }
            Node::Select {
                cmp,
                lhs,
                rhs,
                then,
                otherwise,
            } => {
                // Piecewise terms differentiate branch by branch (the kink has measure zero).
                let (dt, de) = (self.diff(g, then), self.diff(g, otherwise));
                g.select(cmp, lhs, rhs, dt, de)
            }
        };
        self.remember(root, d)
    }

    fn remember(&mut self, root: NodeId, d: NodeId) -> NodeId {
        self.memo.insert(root, d);
        d
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
            Func::Abs => {
                // sign(a), taking +1 at zero
                let zero = g.zero();
                let (one, minus_one) = (g.one(), g.num(-1.0));
                g.select(Comparison::Ge, a, zero, one, minus_one)
            }
        }
    }
}
