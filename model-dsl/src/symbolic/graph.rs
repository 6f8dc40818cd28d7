//! A hash-consed expression graph.
//!
//! Nodes live in one list and refer only to earlier nodes, so the list in order is
//! straight-line code. Every node is built through a constructor that folds constants and
//! applies algebraic identities first, then looks the node up: an expression built twice
//! is one node (common subexpressions are shared by construction), and a structural zero
//! or one is the literal node, never an operation.

use crate::ast::Comparison;
use crate::model::Func;
use std::collections::HashMap;

/// Index of a node in its [`Graph`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct NodeId(u32);

impl NodeId {
    /// Position in the graph's node list.
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

/// Index of a free variable (a state, input, covariance entry...) in its [`Graph`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct VarId(pub u32);

/// Index of a named constant in its [`Graph`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ConstId(pub u32);

/// One operation. Children are always earlier nodes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Node {
    /// A literal, as the bits of an `f64` (negative zero normalised to zero).
    Num(u64),
    /// A named constant, kept by name so generated code reads `TS * x2`.
    Named(ConstId),
    /// A free variable.
    Var(VarId),
    /// `-a`
    Neg(NodeId),
    /// `a + b`, children ordered so `a + b` and `b + a` are one node.
    Add(NodeId, NodeId),
    /// `a - b`
    Sub(NodeId, NodeId),
    /// `a * b`, children ordered.
    Mul(NodeId, NodeId),
    /// `a / b`
    Div(NodeId, NodeId),
    /// `f(a)`
    Call(Func, NodeId),
    /// `atan2(y, x)`
    Atan2(NodeId, NodeId),
    /// `if lhs cmp rhs { then } else { otherwise }`
    Select {
        /// The comparison.
        cmp: Comparison,
        /// Left side of the condition.
        lhs: NodeId,
        /// Right side of the condition.
        rhs: NodeId,
        /// Value when the condition holds.
        then: NodeId,
        /// Value otherwise.
        otherwise: NodeId,
    },
}

impl Node {
    /// The node's operands.
    pub fn children(self) -> Vec<NodeId> {
        match self {
            Node::Num(_) | Node::Named(_) | Node::Var(_) => vec![],
            Node::Neg(a) | Node::Call(_, a) => vec![a],
            Node::Add(a, b)
            | Node::Sub(a, b)
            | Node::Mul(a, b)
            | Node::Div(a, b)
            | Node::Atan2(a, b) => vec![a, b],
            Node::Select {
                lhs,
                rhs,
                then,
                otherwise,
                ..
            } => vec![lhs, rhs, then, otherwise],
        }
    }
}

/// A free variable's name, used in generated code.
#[derive(Clone, Debug)]
pub struct VarInfo {
    /// Identifier in generated code.
    pub name: String,
}

/// A named constant's name and value.
#[derive(Clone, Debug)]
pub struct ConstInfo {
    /// Identifier in generated code.
    pub name: String,
    /// Value used when folding.
    pub value: f64,
}

/// The expression graph. See the module documentation.
#[derive(Clone, Debug, Default)]
pub struct Graph {
    nodes: Vec<Node>,
    lookup: crate::fast_hash::FastMap<Node, NodeId>,
    vars: Vec<VarInfo>,
    constants: Vec<ConstInfo>,
    /// Names the model gave some nodes (`let` intermediates), for generated temporaries.
    name_hints: HashMap<NodeId, String>,
}

impl Graph {
    /// An empty graph.
    pub fn new() -> Graph {
        Graph::default()
    }

    /// The node behind an id.
    pub fn node(&self, id: NodeId) -> Node {
        self.nodes[id.index()]
    }

    /// Every node id, in order: children before parents.
    pub fn ids(&self) -> impl Iterator<Item = NodeId> {
        (0..self.nodes.len() as u32).map(NodeId)
    }

    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// Whether the graph has no nodes.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// A free variable's description.
    pub fn var_info(&self, var: VarId) -> &VarInfo {
        &self.vars[var.0 as usize]
    }

    /// Gives the variable `var` another identifier in generated code; the nodes over it
    /// are unchanged.
    pub fn rename_var(&mut self, var: VarId, name: &str) {
        self.vars[var.0 as usize].name = name.to_owned();
    }

    /// A named constant's description.
    pub fn const_info(&self, c: ConstId) -> &ConstInfo {
        &self.constants[c.0 as usize]
    }

    /// The name the model gave a node, if any.
    pub fn name_hint(&self, id: NodeId) -> Option<&str> {
        self.name_hints.get(&id).map(String::as_str)
    }

    /// Gives `id` a name for generated code, unless it is a leaf or already named.
    pub fn set_name_hint(&mut self, id: NodeId, name: &str) {
        if !self.is_leaf(id) {
            self.name_hints.entry(id).or_insert_with(|| name.to_owned());
        }
    }

    /// Whether the node is a literal, named constant or variable.
    pub fn is_leaf(&self, id: NodeId) -> bool {
        matches!(self.node(id), Node::Num(_) | Node::Named(_) | Node::Var(_))
    }

    /// Declares a free variable and returns its node.
    pub fn var(&mut self, name: &str) -> NodeId {
        let id = VarId(self.vars.len() as u32);
        self.vars.push(VarInfo {
            name: name.to_owned(),
        });
        self.intern(Node::Var(id))
    }

    /// Declares a named constant and returns its node.
    pub fn named_const(&mut self, name: &str, value: f64) -> NodeId {
        let id = ConstId(self.constants.len() as u32);
        self.constants.push(ConstInfo {
            name: name.to_owned(),
            value,
        });
        self.intern(Node::Named(id))
    }

    /// A literal.
    pub fn num(&mut self, value: f64) -> NodeId {
        let value = if value == 0.0 { 0.0 } else { value };
        self.intern(Node::Num(value.to_bits()))
    }

    /// The literal zero.
    pub fn zero(&mut self) -> NodeId {
        self.num(0.0)
    }

    /// The literal one.
    pub fn one(&mut self) -> NodeId {
        self.num(1.0)
    }

    /// The value of a literal node (not of a named constant).
    pub fn literal(&self, id: NodeId) -> Option<f64> {
        match self.node(id) {
            Node::Num(bits) => Some(f64::from_bits(bits)),
            _ => None,
        }
    }

    /// The value of a literal or named constant.
    pub fn constant_value(&self, id: NodeId) -> Option<f64> {
        match self.node(id) {
            Node::Num(bits) => Some(f64::from_bits(bits)),
            Node::Named(c) => Some(self.const_info(c).value),
            _ => None,
        }
    }

    /// Whether the node is the literal zero: a structural zero.
    pub fn is_zero(&self, id: NodeId) -> bool {
        self.literal(id) == Some(0.0)
    }

    /// Whether the node is the literal one.
    pub fn is_one(&self, id: NodeId) -> bool {
        self.literal(id) == Some(1.0)
    }

    fn intern(&mut self, node: Node) -> NodeId {
        if let Some(&id) = self.lookup.get(&node) {
            return id;
        }
        let id = NodeId(self.nodes.len() as u32);
        self.nodes.push(node);
        self.lookup.insert(node, id);
        id
    }

    /// `-a`
    pub fn neg(&mut self, a: NodeId) -> NodeId {
        if let Some(v) = self.literal(a) {
            return self.num(-v);
        }
        match self.node(a) {
            Node::Neg(inner) => inner,
            Node::Sub(x, y) => self.sub(y, x),
            _ => self.intern(Node::Neg(a)),
        }
    }

    /// `a + b`
    pub fn add(&mut self, a: NodeId, b: NodeId) -> NodeId {
        if self.is_zero(a) {
            return b;
        }
        if self.is_zero(b) {
            return a;
        }
        if let (Some(x), Some(y)) = (self.constant_value(a), self.constant_value(b)) {
            return self.num(x + y);
        }
        if let Some(collected) = self.collect_like_terms(a, b, 1.0) {
            return collected;
        }
        // `(x - b) + b` and `b + (x - b)` are `x`.
        for (sum, term) in [(a, b), (b, a)] {
            if let Node::Sub(x, y) = self.node(sum) {
                if y == term {
                    return x;
                }
            }
        }
        if let Node::Neg(nb) = self.node(b) {
            return self.sub(a, nb);
        }
        if let Node::Neg(na) = self.node(a) {
            return self.sub(b, na);
        }
        if let Some(v) = self.literal(b).filter(|v| *v < 0.0) {
            let positive = self.num(-v);
            return self.sub(a, positive);
        }
        if let Some(v) = self.literal(a).filter(|v| *v < 0.0) {
            let positive = self.num(-v);
            return self.sub(b, positive);
        }
        let (a, b) = self.commutative_order(a, b);
        self.intern(Node::Add(a, b))
    }

    /// `a - b`
    pub fn sub(&mut self, a: NodeId, b: NodeId) -> NodeId {
        if self.is_zero(b) {
            return a;
        }
        if let (Some(x), Some(y)) = (self.constant_value(a), self.constant_value(b)) {
            return self.num(x - y);
        }
        if self.is_zero(a) {
            return self.neg(b);
        }
        if let Some(collected) = self.collect_like_terms(a, b, -1.0) {
            return collected;
        }
        if let Some(rest) = self.cancel(a, b) {
            return rest;
        }
        if let Node::Neg(nb) = self.node(b) {
            return self.add(a, nb);
        }
        if let Some(v) = self.literal(b).filter(|v| *v < 0.0) {
            let positive = self.num(-v);
            return self.add(a, positive);
        }
        if let Node::Neg(na) = self.node(a) {
            // -x - y = -(x + y)
            let sum = self.add(na, b);
            return self.neg(sum);
        }
        self.intern(Node::Sub(a, b))
    }

    /// `a * b`
    pub fn mul(&mut self, a: NodeId, b: NodeId) -> NodeId {
        if self.is_zero(a) || self.is_zero(b) {
            return self.zero();
        }
        if self.is_one(a) {
            return b;
        }
        if self.is_one(b) {
            return a;
        }
        if let (Some(x), Some(y)) = (self.constant_value(a), self.constant_value(b)) {
            return self.num(x * y);
        }
        if self.literal(a) == Some(-1.0) {
            return self.neg(b);
        }
        if self.literal(b) == Some(-1.0) {
            return self.neg(a);
        }
        // Move negations outward so `-a * -b` is `a * b` and signs meet in one place.
        match (self.node(a), self.node(b)) {
            (Node::Neg(x), Node::Neg(y)) => return self.mul(x, y),
            (Node::Neg(x), _) => {
                let p = self.mul(x, b);
                return self.neg(p);
            }
            (_, Node::Neg(y)) => {
                let p = self.mul(a, y);
                return self.neg(p);
            }
            _ => {}
        }
        if let Some(v) = self.literal(a).filter(|v| *v < 0.0) {
            let positive = self.num(-v);
            let p = self.mul(positive, b);
            return self.neg(p);
        }
        if let Some(v) = self.literal(b).filter(|v| *v < 0.0) {
            let positive = self.num(-v);
            let p = self.mul(a, positive);
            return self.neg(p);
        }
        // Literal factors move outward, c (x) * y = c (x y), so like terms meet as c * t.
        if self.literal(a).is_none() && self.literal(b).is_none() {
            if let Node::Mul(c, rest) = self.node(a) {
                if self.literal(c).is_some() {
                    let inner = self.mul(rest, b);
                    return self.mul(c, inner);
                }
            }
            if let Node::Mul(c, rest) = self.node(b) {
                if self.literal(c).is_some() {
                    let inner = self.mul(a, rest);
                    return self.mul(c, inner);
                }
            }
        }
        // Fold chains of constant factors: c1 * (c2 * x) = (c1 c2) * x.
        if let Some(c1) = self.constant_value(a) {
            if let Node::Mul(x, y) = self.node(b) {
                if let Some(c2) = self.constant_value(x) {
                    let c = self.num(c1 * c2);
                    return self.mul(c, y);
                }
            }
        }
        if let Some(c2) = self.constant_value(b) {
            if let Node::Mul(x, y) = self.node(a) {
                if let Some(c1) = self.constant_value(x) {
                    let c = self.num(c1 * c2);
                    return self.mul(c, y);
                }
            }
        }
        let (a, b) = self.commutative_order(a, b);
        self.intern(Node::Mul(a, b))
    }

    /// `a * b` with both factors kept whole: unlike [`Graph::mul`], no literal factor
    /// moves out of a product (`(c x) * y` stays so, not `c (x y)`), so a coefficient `c x`
    /// computed once, before a loop, is one multiplication per use. Zeros, ones, signs
    /// and products of literals fold as in [`Graph::mul`].
    pub fn mul_whole(&mut self, a: NodeId, b: NodeId) -> NodeId {
        if self.literal(a).is_some() || self.literal(b).is_some() {
            return self.mul(a, b);
        }
        match (self.node(a), self.node(b)) {
            (Node::Neg(x), Node::Neg(y)) => self.mul_whole(x, y),
            (Node::Neg(x), _) => {
                let p = self.mul_whole(x, b);
                self.neg(p)
            }
            (_, Node::Neg(y)) => {
                let p = self.mul_whole(a, y);
                self.neg(p)
            }
            _ => {
                let (a, b) = self.commutative_order(a, b);
                self.intern(Node::Mul(a, b))
            }
        }
    }

    /// `a / b`; division by a literal becomes multiplication by its reciprocal.
    pub fn div(&mut self, a: NodeId, b: NodeId) -> NodeId {
        if self.is_one(b) {
            return a;
        }
        if let Some(y) = self.constant_value(b).filter(|y| *y != 0.0) {
            let reciprocal = self.num(1.0 / y);
            return self.mul(a, reciprocal);
        }
        if self.is_zero(a) {
            return self.zero();
        }
        if a == b {
            return self.one();
        }
        match (self.node(a), self.node(b)) {
            (Node::Neg(x), Node::Neg(y)) => self.div(x, y),
            (Node::Neg(x), _) => {
                let q = self.div(x, b);
                self.neg(q)
            }
            (_, Node::Neg(y)) => {
                let q = self.div(a, y);
                self.neg(q)
            }
            _ => self.intern(Node::Div(a, b)),
        }
    }

    /// `a` to an integer power, as products (squaring) and at most one division.
    pub fn powi(&mut self, a: NodeId, n: i32) -> NodeId {
        if n < 0 {
            let positive = self.powi(a, -n);
            let one = self.one();
            return self.div(one, positive);
        }
        let mut result = self.one();
        let mut square = a;
        let mut n = n;
        while n > 0 {
            if n & 1 == 1 {
                result = self.mul(result, square);
            }
            n >>= 1;
            if n > 0 {
                square = self.mul(square, square);
            }
        }
        result
    }

    /// `f(a)`; a sine or cosine of a double angle, `2 x`, is written with `sin x` and
    /// `cos x` (see `Graph::double_angle`).
    pub fn call(&mut self, f: Func, a: NodeId) -> NodeId {
        if let Some(x) = self.constant_value(a) {
            return self.num(f.eval(x));
        }
        if let Some(value) = self.double_angle(f, a) {
            return value;
        }
        match (f, self.node(a)) {
            (Func::Abs, Node::Neg(x)) => self.call(Func::Abs, x),
            (Func::Cos, Node::Neg(x)) => self.call(Func::Cos, x),
            (Func::Sin | Func::Tan | Func::Tanh, Node::Neg(x)) => {
                let v = self.call(f, x);
                self.neg(v)
            }
            _ => self.intern(Node::Call(f, a)),
        }
    }

    /// `sin 2x = 2 sin x cos x` and `cos 2x = 1 - 2 sin^2 x`, for `f(a)` with `a = 2 x`:
    /// generated code computes `sin x` and `cos x` with one call
    /// (`stateforge_math::*::sin_cos`, one range reduction), and a model that has `sin x`
    /// or `cos x` beside `sin 2x` (the helicopter's `sin(psi)`, `cos(psi)`, `sin(2 psi)`)
    /// gets `sin 2x` and its derivative `2 cos 2x` for a few products. Accuracy: the sine's
    /// relative error is its factors' plus one rounding (no cancellation); the cosine's
    /// error is absolute, about one ulp of 1, where `cos 2x` crosses zero.
    fn double_angle(&mut self, f: Func, a: NodeId) -> Option<NodeId> {
        if !matches!(f, Func::Sin | Func::Cos) {
            return None;
        }
        let (factor, x) = self.literal_multiple(a);
        if factor != 2.0 || x == a {
            return None;
        }
        let (sin, two) = (self.call(Func::Sin, x), self.num(2.0));
        Some(match f {
            Func::Sin => {
                let cos = self.call(Func::Cos, x);
                let product = self.mul(sin, cos);
                self.mul(two, product)
            }
            _ => {
                let square = self.mul(sin, sin);
                let twice = self.mul(two, square);
                let one = self.one();
                self.sub(one, twice)
            }
        })
    }

    /// The node `node` if the graph has it (a lowering looks for the cosine beside a
    /// sine, say), without adding it.
    pub fn find(&self, node: Node) -> Option<NodeId> {
        self.lookup.get(&node).copied()
    }

    /// `atan2(y, x)`, folded when both are constants.
    pub fn atan2(&mut self, y: NodeId, x: NodeId) -> NodeId {
        if let (Some(y), Some(x)) = (self.constant_value(y), self.constant_value(x)) {
            return self.num(y.atan2(x));
        }
        self.intern(Node::Atan2(y, x))
    }

    /// `if lhs cmp rhs { then } else { otherwise }`
    pub fn select(
        &mut self,
        cmp: Comparison,
        lhs: NodeId,
        rhs: NodeId,
        then: NodeId,
        otherwise: NodeId,
    ) -> NodeId {
        if then == otherwise {
            return then;
        }
        if let (Some(l), Some(r)) = (self.constant_value(lhs), self.constant_value(rhs)) {
            return if cmp.holds(l, r) { then } else { otherwise };
        }
        self.intern(Node::Select {
            cmp,
            lhs,
            rhs,
            then,
            otherwise,
        })
    }

    /// `c1 t + sign c2 t = (c1 + sign c2) t` when both sides are literal multiples of one
    /// term `t` (a bare `t` counts as `1 t`).
    /// `a - b` where `b` is a term of the sum or difference `a`: what is left of `a`
    /// (`(x + b) - b` is `x`, `(b - y) - b` is `-y`), so that a product of matrices whose
    /// terms cancel (a Jacobian taken to the tangent space) leaves no `p - p` behind.
    fn cancel(&mut self, a: NodeId, b: NodeId) -> Option<NodeId> {
        match self.node(a) {
            Node::Add(x, y) if y == b => Some(x),
            Node::Add(x, y) if x == b => Some(y),
            Node::Sub(x, y) if x == b => Some(self.neg(y)),
            _ => None,
        }
    }

    fn collect_like_terms(&mut self, a: NodeId, b: NodeId, sign: f64) -> Option<NodeId> {
        let (ca, ta) = self.literal_multiple(a);
        let (cb, tb) = self.literal_multiple(b);
        if ta != tb || self.literal(ta).is_some() {
            return None;
        }
        let c = self.num(ca + sign * cb);
        Some(self.mul(c, ta))
    }

    /// `(c, t)` with the node equal to the literal `c` times `t`.
    fn literal_multiple(&self, id: NodeId) -> (f64, NodeId) {
        match self.node(id) {
            Node::Mul(c, t) => match self.literal(c) {
                Some(value) => (value, t),
                None => (1.0, id),
            },
            Node::Neg(t) => {
                let (c, inner) = self.literal_multiple(t);
                (-c, inner)
            }
            _ => (1.0, id),
        }
    }

    /// Orders the operands of a commutative operation so equal expressions written in
    /// either order are one node: constants, then compound terms, then variables, each by
    /// age. Compound terms on the left print without parentheses (`TS * x1 * x3`).
    fn commutative_order(&self, a: NodeId, b: NodeId) -> (NodeId, NodeId) {
        let key = |id: NodeId| {
            let class = match self.node(id) {
                Node::Num(_) | Node::Named(_) => 0,
                Node::Var(_) => 2,
                _ => 1,
            };
            (class, id)
        };
        if key(a) <= key(b) {
            (a, b)
        } else {
            (b, a)
        }
    }

    /// The nodes `root` depends on through `operands` (itself included) that `done` does
    /// not already hold, operands first: the order to compute something for each of them
    /// without recursion. Operands are always earlier nodes, so ascending ids are that order.
    pub fn pending_from(
        &self,
        root: NodeId,
        operands: impl Fn(Node) -> Vec<NodeId>,
        done: impl Fn(NodeId) -> bool,
    ) -> Vec<NodeId> {
        let mut seen = crate::fast_hash::FastSet::default();
        let mut stack = vec![root];
        let mut pending = Vec::new();
        while let Some(id) = stack.pop() {
            if done(id) || !seen.insert(id) {
                continue;
            }
            pending.push(id);
            stack.extend(operands(self.node(id)));
        }
        pending.sort_unstable();
        pending
    }

    /// Whether `root` holds an `if` whose condition reads any of `vars`: an expression whose
    /// derivatives by them read none of them may still change with them, by a switch
    /// (`if v > 0 { 2 } else { -2 }`, a Coulomb friction, has derivative zero in `v`), so
    /// it is affine in them only where this is false.
    pub fn switches_on(&self, root: NodeId, vars: &[VarId]) -> bool {
        let reads = self.reading(root, vars);
        reads.keys().any(|&id| match self.node(id) {
            Node::Select { lhs, rhs, .. } => reads[&lhs] || reads[&rhs],
            _ => false,
        })
    }

    /// Whether `root` reads any of `vars`.
    pub fn reads_any(&self, root: NodeId, vars: &[VarId]) -> bool {
        self.reading(root, vars)[&root]
    }

    /// For `root` and each node it depends on, whether it reads any of `vars`.
    fn reading(&self, root: NodeId, vars: &[VarId]) -> HashMap<NodeId, bool> {
        let mut reads: HashMap<NodeId, bool> = HashMap::new();
        for id in self.pending_from(root, Node::children, |_| false) {
            let node = self.node(id);
            let own = matches!(node, Node::Var(v) if vars.contains(&v));
            let value = own || node.children().iter().any(|c| reads[c]);
            reads.insert(id, value);
        }
        reads
    }

    /// Rebuilds `root` with variables replaced by the nodes `map` gives (memoised).
    pub fn substitute(
        &mut self,
        root: NodeId,
        map: &HashMap<VarId, NodeId>,
        memo: &mut HashMap<NodeId, NodeId>,
    ) -> NodeId {
        for id in self.pending_from(root, Node::children, |id| memo.contains_key(&id)) {
            let new = |a: NodeId| memo[&a];
            let result = match self.node(id) {
                Node::Num(_) | Node::Named(_) => id,
                Node::Var(v) => map.get(&v).copied().unwrap_or(id),
                Node::Neg(a) => self.neg(new(a)),
                Node::Add(a, b) => self.add(new(a), new(b)),
                Node::Sub(a, b) => self.sub(new(a), new(b)),
                Node::Mul(a, b) => self.mul(new(a), new(b)),
                Node::Div(a, b) => self.div(new(a), new(b)),
                Node::Call(f, a) => self.call(f, new(a)),
                Node::Atan2(y, x) => self.atan2(new(y), new(x)),
                Node::Select {
                    cmp,
                    lhs,
                    rhs,
                    then,
                    otherwise,
                } => self.select(cmp, new(lhs), new(rhs), new(then), new(otherwise)),
            };
            memo.insert(id, result);
        }
        memo[&root]
    }

    /// Evaluates `root` in `f64` with the given variable values (tests and folding checks).
    pub fn eval(&self, root: NodeId, vars: &dyn Fn(VarId) -> f64) -> f64 {
        let mut values: HashMap<NodeId, f64> = HashMap::new();
        for id in self.pending_from(root, Node::children, |_| false) {
            let value = |a: NodeId| values[&a];
            let v = match self.node(id) {
                Node::Num(bits) => f64::from_bits(bits),
                Node::Named(c) => self.const_info(c).value,
                Node::Var(v) => vars(v),
                Node::Neg(a) => -value(a),
                Node::Add(a, b) => value(a) + value(b),
                Node::Sub(a, b) => value(a) - value(b),
                Node::Mul(a, b) => value(a) * value(b),
                Node::Div(a, b) => value(a) / value(b),
                Node::Call(f, a) => f.eval(value(a)),
                Node::Atan2(y, x) => value(y).atan2(value(x)),
                Node::Select {
                    cmp,
                    lhs,
                    rhs,
                    then,
                    otherwise,
                } => {
                    if cmp.holds(value(lhs), value(rhs)) {
                        value(then)
                    } else {
                        value(otherwise)
                    }
                }
            };
            values.insert(id, v);
        }
        values[&root]
    }
}

/// Rebuilds `root` with the given variables replaced.
pub fn substitute(graph: &mut Graph, root: NodeId, map: &[(VarId, NodeId)]) -> NodeId {
    let map: std::collections::HashMap<VarId, NodeId> = map.iter().copied().collect();
    graph.substitute(root, &map, &mut std::collections::HashMap::new())
}

/// Nodes the loop body reads that do not change from one iteration to the next: operands
/// of loop-dependent nodes that depend on no loop variable, and are not leaves.
pub fn loop_invariant_operands(g: &Graph, roots: &[NodeId], loop_vars: &[NodeId]) -> Vec<NodeId> {
    let mut varies = vec![false; g.len()];
    for id in g.ids() {
        varies[id.index()] =
            loop_vars.contains(&id) || g.node(id).children().iter().any(|c| varies[c.index()]);
    }
    let mut reached = vec![false; g.len()];
    let mut stack = roots.to_vec();
    let mut invariant = Vec::new();
    while let Some(id) = stack.pop() {
        if std::mem::replace(&mut reached[id.index()], true) {
            continue;
        }
        if !varies[id.index()] {
            if !matches!(g.node(id), Node::Num(_) | Node::Named(_) | Node::Var(_)) {
                invariant.push(id);
            }
            continue;
        }
        stack.extend(g.node(id).children());
    }
    invariant.sort();
    invariant
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn double_angles_are_written_with_the_sine_and_cosine_of_the_angle() {
        let mut g = Graph::new();
        let x = g.var("x");
        let two = g.num(2.0);
        let twice = g.mul(two, x);
        let (sin2, cos2) = (g.call(Func::Sin, twice), g.call(Func::Cos, twice));
        let (sin, cos) = (g.call(Func::Sin, x), g.call(Func::Cos, x));
        let product = g.mul(sin, cos);
        assert_eq!(sin2, g.mul(two, product));
        let square = g.mul(sin, sin);
        let twice_square = g.mul(two, square);
        let one = g.one();
        assert_eq!(cos2, g.sub(one, twice_square));
        assert!(g.find(Node::Call(Func::Sin, twice)).is_none());
        // sin(-2x) is -(2 sin x cos x); sin(3x) stays a call.
        let minus = g.neg(twice);
        let negated = g.call(Func::Sin, minus);
        assert_eq!(negated, g.neg(sin2));
        let three = g.num(3.0);
        let thrice = g.mul(three, x);
        let sin3 = g.call(Func::Sin, thrice);
        assert!(matches!(g.node(sin3), Node::Call(Func::Sin, _)));
    }

    #[test]
    fn equal_expressions_are_one_node_in_either_order() {
        let mut g = Graph::new();
        let (x, y) = (g.var("x"), g.var("y"));
        let xy = g.mul(x, y);
        assert_eq!(g.mul(y, x), xy);
        let before = g.len();
        let sum = g.add(xy, x);
        assert_eq!(g.add(x, xy), sum);
        assert_eq!(g.len(), before + 1, "only the sum is new");
    }

    #[test]
    fn identities_leave_no_operation() {
        let mut g = Graph::new();
        let x = g.var("x");
        let (zero, one) = (g.zero(), g.one());
        let product = g.mul(x, zero);
        assert!(g.is_zero(product));
        assert_eq!(g.add(x, zero), x);
        assert_eq!(g.mul(one, x), x);
        let difference = g.sub(x, x);
        assert!(g.is_zero(difference));
        let minus_x = g.neg(x);
        assert_eq!(g.neg(minus_x), x);
        assert_eq!(g.div(x, one), x);
        let quotient = g.div(x, x);
        assert!(g.is_one(quotient));
    }

    #[test]
    fn constants_fold_but_a_named_constant_keeps_its_name() {
        let mut g = Graph::new();
        let ts = g.named_const("TS", 0.015);
        let (one, two) = (g.one(), g.num(2.0));
        assert_eq!(g.mul(ts, one), ts);
        let doubled = g.mul(ts, two);
        assert_eq!(g.literal(doubled), Some(0.03));
        let x = g.var("x");
        // 2 * (TS * x) = 0.03 * x
        let ts_x = g.mul(ts, x);
        let folded = g.mul(two, ts_x);
        assert_eq!(g.node(folded), Node::Mul(doubled, x));
    }

    #[test]
    fn division_by_a_literal_is_a_multiplication() {
        let mut g = Graph::new();
        let x = g.var("x");
        let four = g.num(4.0);
        let q = g.div(x, four);
        let quarter = g.num(0.25);
        assert_eq!(g.node(q), Node::Mul(quarter, x));
    }

    #[test]
    fn integer_powers_are_products() {
        let mut g = Graph::new();
        let x = g.var("x");
        let cube = g.powi(x, 3);
        let square = g.mul(x, x);
        assert_eq!(g.node(cube), Node::Mul(square, x));
        let inverse_square = g.powi(x, -2);
        let one = g.one();
        assert_eq!(g.node(inverse_square), Node::Div(one, square));
        assert!(g.is_one(g.clone().powi(x, 0)));
    }

    #[test]
    fn negations_move_outward() {
        let mut g = Graph::new();
        let (x, y) = (g.var("x"), g.var("y"));
        let (nx, ny) = (g.neg(x), g.neg(y));
        let xy = g.mul(x, y);
        assert_eq!(g.mul(nx, ny), xy);
        let negated = g.mul(nx, y);
        assert_eq!(g.node(negated), Node::Neg(xy));
        let minus_three = g.num(-3.0);
        let sum = g.add(x, minus_three);
        let three = g.num(3.0);
        assert_eq!(g.node(sum), Node::Sub(x, three));
    }

    #[test]
    fn simplification_keeps_the_value() {
        let mut g = Graph::new();
        let (x, y) = (g.var("x"), g.var("y"));
        let ts = g.named_const("TS", 0.5);
        let nx = g.neg(x);
        let a = g.mul(ts, nx);
        let b = g.sub(a, y);
        let c = g.div(b, ts);
        let d = g.powi(c, 3);
        let e = g.call(Func::Sin, d);
        let value = g.eval(e, &|v| if v.0 == 0 { 0.7 } else { -1.3 });
        let expected = ((0.5 * -0.7 - -1.3) / 0.5f64).powi(3).sin();
        assert!((value - expected).abs() < 1e-15, "{value} vs {expected}");
    }
}
