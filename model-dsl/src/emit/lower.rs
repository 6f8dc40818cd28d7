//! Lowers graph nodes to straight-line Rust: `let` temporaries for shared subexpressions,
//! inline expressions for the rest, and an operation count of what was emitted.

use super::names::TempNamer;
use crate::model::{Func, Scalar};
use crate::symbolic::{Graph, Node, NodeId, VarId};
use proc_macro2::{Literal, TokenStream};
use quote::quote;
use std::collections::BTreeSet;
use std::str::FromStr;

/// Arithmetic a generated function performs, counted from the emitted code.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct OpCount {
    /// Additions, subtractions and negations.
    pub add: u32,
    /// Multiplications.
    pub mul: u32,
    /// Divisions.
    pub div: u32,
    /// Library calls: `sin cos tan exp ln sqrt abs`.
    pub call: u32,
    /// Comparisons of piecewise terms.
    pub compare: u32,
}

/// Straight-line code computing some root nodes.
pub struct Lowered {
    /// `let` statements in dependency order.
    pub lets: Vec<TokenStream>,
    /// One expression per root, referring to the temporaries.
    pub roots: Vec<TokenStream>,
    /// Free variables the code reads.
    pub used_vars: BTreeSet<VarId>,
    /// What the code computes.
    pub ops: OpCount,
}

/// Binding strength of a rendered expression, to place parentheses.
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Prec {
    Sum,
    Product,
    Prefix,
    Atom,
}

/// Lowers `roots` of `graph` into code over `scalar`, naming temporaries with `namer`.
pub fn lower(graph: &Graph, roots: &[NodeId], scalar: Scalar, namer: &mut TempNamer) -> Lowered {
    // Count uses among the nodes the roots reach; a root counts as one use.
    let mut uses = vec![0u32; graph.len()];
    let mut reached = vec![false; graph.len()];
    let mut stack: Vec<NodeId> = roots.to_vec();
    for &r in roots {
        uses[r.index()] += 1;
    }
    while let Some(id) = stack.pop() {
        if std::mem::replace(&mut reached[id.index()], true) {
            continue;
        }
        for child in graph.node(id).children() {
            uses[child.index()] += 1;
            stack.push(child);
        }
    }

    let mut lowering = Lowering {
        graph,
        scalar,
        lets: Vec::new(),
        used_vars: BTreeSet::new(),
        ops: OpCount::default(),
    };
    // Children precede parents in the graph, so index order is a valid evaluation order.
    for id in graph.ids() {
        let index = id.index();
        if !reached[index] {
            continue;
        }
        let node = graph.node(id);
        lowering.count(node);
        if let Node::Var(v) = node {
            lowering.used_vars.insert(v);
        }
        let shared = uses[index] > 1 || graph.name_hint(id).is_some();
        let needs_let = !graph.is_leaf(id) && (shared || matches!(node, Node::Select { .. }));
        if needs_let {
            let (value, _) = lowering.render_node(node, namer);
            let name = namer.assign(graph, id);
            lowering.lets.push(quote! { let #name = #value; });
        }
    }
    let roots = roots.iter().map(|&r| lowering.render(r, namer).0).collect();
    Lowered {
        lets: lowering.lets,
        roots,
        used_vars: lowering.used_vars,
        ops: lowering.ops,
    }
}

struct Lowering<'g> {
    graph: &'g Graph,
    scalar: Scalar,
    lets: Vec<TokenStream>,
    used_vars: BTreeSet<VarId>,
    ops: OpCount,
}

impl Lowering<'_> {
    fn count(&mut self, node: Node) {
        let ops = &mut self.ops;
        match node {
            Node::Num(_) | Node::Named(_) | Node::Var(_) => {}
            Node::Neg(_) | Node::Add(..) | Node::Sub(..) => ops.add += 1,
            Node::Mul(..) => ops.mul += 1,
            Node::Div(..) => ops.div += 1,
            Node::Call(..) => ops.call += 1,
            Node::Select { .. } => ops.compare += 1,
        }
    }

    /// A node as an expression: its temporary's name if it has one, else inline.
    fn render(&self, id: NodeId, namer: &TempNamer) -> (TokenStream, Prec) {
        if let Some(name) = namer.get(id) {
            let name = super::names::ident(name);
            return (quote! { #name }, Prec::Atom);
        }
        self.render_node(self.graph.node(id), namer)
    }

    fn render_node(&self, node: Node, namer: &TempNamer) -> (TokenStream, Prec) {
        // Operands rendered with at least `min` binding strength, else parenthesised.
        let operand = |id, min: Prec| {
            let (tokens, prec) = self.render(id, namer);
            if prec < min {
                quote! { (#tokens) }
            } else {
                tokens
            }
        };
        match node {
            Node::Num(bits) => self.literal(f64::from_bits(bits)),
            Node::Named(c) => {
                let name = super::names::ident(&self.graph.const_info(c).name);
                (quote! { #name }, Prec::Atom)
            }
            Node::Var(v) => {
                let name = super::names::ident(&self.graph.var_info(v).name);
                (quote! { #name }, Prec::Atom)
            }
            Node::Neg(a) => {
                let a = operand(a, Prec::Prefix);
                (quote! { -#a }, Prec::Prefix)
            }
            // Right operands bind tighter than the operator: floating-point `a + (b + c)`
            // is not `a + b + c`, so the parentheses keep the computed value exact.
            Node::Add(a, b) => {
                let (a, b) = (operand(a, Prec::Sum), operand(b, Prec::Product));
                (quote! { #a + #b }, Prec::Sum)
            }
            Node::Sub(a, b) => {
                let (a, b) = (operand(a, Prec::Sum), operand(b, Prec::Product));
                (quote! { #a - #b }, Prec::Sum)
            }
            Node::Mul(a, b) => {
                let (a, b) = (operand(a, Prec::Product), operand(b, Prec::Prefix));
                (quote! { #a * #b }, Prec::Product)
            }
            Node::Div(a, b) => {
                let (a, b) = (operand(a, Prec::Product), operand(b, Prec::Prefix));
                (quote! { #a / #b }, Prec::Product)
            }
            Node::Call(f, a) => {
                let a = operand(a, Prec::Sum);
                let name = super::names::ident(libm_name(f, self.scalar));
                (quote! { libm::#name(#a) }, Prec::Atom)
            }
            Node::Select {
                cmp,
                lhs,
                rhs,
                then,
                otherwise,
            } => {
                let (lhs, rhs) = (operand(lhs, Prec::Sum), operand(rhs, Prec::Sum));
                let (then, otherwise) = (operand(then, Prec::Sum), operand(otherwise, Prec::Sum));
                let cmp = TokenStream::from_str(cmp.symbol()).unwrap_or_default();
                (
                    quote! { if #lhs #cmp #rhs { #then } else { #otherwise } },
                    Prec::Atom,
                )
            }
        }
    }

    fn literal(&self, v: f64) -> (TokenStream, Prec) {
        let tokens = literal(v, self.scalar);
        let prec = if v < 0.0 || !v.is_finite() {
            Prec::Prefix
        } else {
            Prec::Atom
        };
        (tokens, prec)
    }
}

/// A typed literal, `0.015_f32`; negative values as `-lit`.
pub fn literal(v: f64, scalar: Scalar) -> TokenStream {
    let ty = super::names::ident(scalar.type_name());
    if v.is_nan() {
        return quote! { #ty::NAN };
    }
    if v.is_infinite() {
        return if v > 0.0 {
            quote! { #ty::INFINITY }
        } else {
            quote! { #ty::NEG_INFINITY }
        };
    }
    let magnitude = v.abs();
    let mut text = match scalar {
        Scalar::F32 => format!("{:?}", magnitude as f32),
        Scalar::F64 => format!("{magnitude:?}"),
    };
    if !text.contains(['.', 'e']) {
        text.push_str(".0");
    }
    let lit = Literal::from_str(&format!("{text}_{}", scalar.type_name()))
        .unwrap_or_else(|_| Literal::f64_unsuffixed(magnitude));
    if v < 0.0 {
        quote! { -#lit }
    } else {
        quote! { #lit }
    }
}

/// The `libm` function for `f` in `scalar`.
fn libm_name(f: Func, scalar: Scalar) -> &'static str {
    let double = match f {
        Func::Sin => "sin",
        Func::Cos => "cos",
        Func::Tan => "tan",
        Func::Exp => "exp",
        Func::Ln => "log",
        Func::Sqrt => "sqrt",
        Func::Abs => "fabs",
    };
    match (scalar, f) {
        (Scalar::F64, _) => double,
        (Scalar::F32, Func::Sin) => "sinf",
        (Scalar::F32, Func::Cos) => "cosf",
        (Scalar::F32, Func::Tan) => "tanf",
        (Scalar::F32, Func::Exp) => "expf",
        (Scalar::F32, Func::Ln) => "logf",
        (Scalar::F32, Func::Sqrt) => "sqrtf",
        (Scalar::F32, Func::Abs) => "fabsf",
    }
}
