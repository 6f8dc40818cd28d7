//! The scalar algebra of model expressions, in which the checks expand vectors and
//! rotations ([`crate::geometry`]): an entry read more than once becomes a named
//! intermediate, so that an expression's expansion grows with its size, not with its
//! nesting, and the generated code computes it once.

use crate::ast::Comparison;
use crate::geometry::Algebra;
use crate::model::{Expr, Func, Local};

/// Builds [`Expr`] trees; shares into `locals`.
pub(super) struct ExprAlgebra<'l> {
    /// Where shared entries are named; `None` in a constant, which holds no vector (its
    /// entries are then copied, a few literals).
    pub(super) locals: Option<&'l mut Vec<Local>>,
}

impl Algebra for ExprAlgebra<'_> {
    type S = Expr;

    fn num(&mut self, value: f64) -> Expr {
        Expr::Number(value)
    }

    fn add(&mut self, a: Expr, b: Expr) -> Expr {
        Expr::Add(Box::new(a), Box::new(b))
    }

    fn sub(&mut self, a: Expr, b: Expr) -> Expr {
        Expr::Sub(Box::new(a), Box::new(b))
    }

    fn mul(&mut self, a: Expr, b: Expr) -> Expr {
        Expr::Mul(Box::new(a), Box::new(b))
    }

    fn div(&mut self, a: Expr, b: Expr) -> Expr {
        Expr::Div(Box::new(a), Box::new(b))
    }

    fn neg(&mut self, a: Expr) -> Expr {
        Expr::Neg(Box::new(a))
    }

    fn call(&mut self, f: Func, a: Expr) -> Expr {
        Expr::Call(f, Box::new(a))
    }

    fn atan2(&mut self, y: Expr, x: Expr) -> Expr {
        Expr::Atan2(Box::new(y), Box::new(x))
    }

    fn select(
        &mut self,
        cmp: Comparison,
        lhs: Expr,
        rhs: Expr,
        then: Expr,
        otherwise: Expr,
    ) -> Expr {
        Expr::Select {
            cmp,
            lhs: Box::new(lhs),
            rhs: Box::new(rhs),
            then: Box::new(then),
            otherwise: Box::new(otherwise),
        }
    }

    fn share(&mut self, a: Expr, hint: &str) -> Expr {
        match &mut self.locals {
            Some(locals) if !a.is_leaf() => {
                locals.push(Local {
                    name: hint.to_owned(),
                    expr: a,
                });
                Expr::Local(locals.len() - 1)
            }
            _ => a,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry;

    /// The expansion of nested rotations grows linearly: each product names its operands.
    #[test]
    fn nested_products_grow_linearly() {
        let mut locals = Vec::new();
        let mut alg = ExprAlgebra {
            locals: Some(&mut locals),
        };
        let q = [0, 1, 2, 3].map(Expr::State);
        let mut p = q.clone();
        for _ in 0..40 {
            p = geometry::compose(&mut alg, p, q.clone());
        }
        fn size(e: &Expr) -> usize {
            match e {
                Expr::Neg(a) | Expr::Call(_, a) | Expr::Powi(a, _) => 1 + size(a),
                Expr::Add(a, b) | Expr::Sub(a, b) | Expr::Mul(a, b) | Expr::Div(a, b) => {
                    1 + size(a) + size(b)
                }
                _ => 1,
            }
        }
        let total: usize =
            locals.iter().map(|l| size(&l.expr)).sum::<usize>() + p.iter().map(size).sum::<usize>();
        // 4 entries of 4 products each per step, about 30 nodes an entry.
        assert!(total < 41 * 4 * 32, "{total} nodes");
    }
}
