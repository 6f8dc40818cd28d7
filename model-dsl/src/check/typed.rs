//! The typing rules of vectors and rotations: which operations apply to which types, what
//! each gives, and for a misuse an error under the operand that does not fit, saying what
//! to write. Each typed value is expanded into scalar entries here ([`crate::geometry`]).

use super::expr::{article, resolve_call, Resolver};
use super::expr_algebra::ExprAlgebra;
use crate::ast::{BinaryOp, Comparison, Name, SurfaceExpr, SurfaceKind};
use crate::diagnostics::Diagnostics;
use crate::geometry::{self, Algebra};
use crate::model::{Expr, Type, Value};

/// Why a rotation takes no arithmetic.
pub(super) const ROTATION_ARITHMETIC: &str = "rotations compose with `*` (`q1 * q2`); the \
     inverse is `q.inverse()`; to scale an angle, write `exp(k * log(q))`";

/// Why a rotation stands where a vector was expected.
fn rotation_not_vector(what: &str) -> String {
    format!("{what} is a rotation: rotate a vector, `q * v`, or take its rotation vector, `log(q)`")
}

impl Resolver<'_, '_> {
    /// `-a`
    pub(super) fn negate(&mut self, a: &SurfaceExpr, diag: &mut Diagnostics) -> Option<Value> {
        Some(match self.value(a, diag)? {
            Value::Scalar(e) => Value::Scalar(Expr::Neg(Box::new(e))),
            Value::Vec3(v) => Value::Vec3(geometry::neg(&mut self.algebra(), v)),
            Value::Rot3 { .. } => {
                diag.error(a.span, ROTATION_ARITHMETIC);
                return None;
            }
        })
    }

    /// `a op b` of any types.
    pub(super) fn binary(
        &mut self,
        op: BinaryOp,
        a: &SurfaceExpr,
        b: &SurfaceExpr,
        diag: &mut Diagnostics,
    ) -> Option<Value> {
        let left = self.value(a, diag);
        let right = self.value(b, diag);
        self.combine(op, (left?, a), (right?, b), diag)
    }

    /// `left op right`, resolved: apart from [`Resolver::binary`], whose frame a long sum
    /// recurses through.
    fn combine(
        &mut self,
        op: BinaryOp,
        (left, a): (Value, &SurfaceExpr),
        (right, b): (Value, &SurfaceExpr),
        diag: &mut Diagnostics,
    ) -> Option<Value> {
        let (left, right) = match (left, right) {
            (Value::Scalar(x), Value::Scalar(y)) => {
                let (x, y) = (Box::new(x), Box::new(y));
                return Some(Value::Scalar(match op {
                    BinaryOp::Add => Expr::Add(x, y),
                    BinaryOp::Sub => Expr::Sub(x, y),
                    BinaryOp::Mul => Expr::Mul(x, y),
                    BinaryOp::Div => Expr::Div(x, y),
                }));
            }
            pair => pair,
        };
        match op {
            BinaryOp::Add | BinaryOp::Sub => self.sum(op, (left, a), (right, b), diag),
            BinaryOp::Mul => self.product((left, a), (right, b), diag),
            BinaryOp::Div => self.quotient((left, a), (right, b), diag),
        }
    }

    /// `a + b`, `a - b` with a vector or rotation among them.
    fn sum(
        &mut self,
        op: BinaryOp,
        (left, a): (Value, &SurfaceExpr),
        (right, b): (Value, &SurfaceExpr),
        diag: &mut Diagnostics,
    ) -> Option<Value> {
        let message = match (&left, &right) {
            (Value::Vec3(x), Value::Vec3(y)) => {
                let (x, y) = (x.clone(), y.clone());
                let mut alg = self.algebra();
                return Some(Value::Vec3(match op {
                    BinaryOp::Add => geometry::add(&mut alg, x, y),
                    _ => geometry::sub(&mut alg, x, y),
                }));
            }
            (Value::Rot3 { .. }, _) => (a.span, ROTATION_ARITHMETIC.to_owned()),
            (_, Value::Rot3 { .. }) => (b.span, ROTATION_ARITHMETIC.to_owned()),
            (Value::Scalar(_), _) => (a.span, scalar_plus_vector()),
            _ => (b.span, scalar_plus_vector()),
        };
        diag.error(message.0, message.1);
        None
    }

    /// `a * b` with a vector or rotation among them.
    fn product(
        &mut self,
        (left, a): (Value, &SurfaceExpr),
        (right, b): (Value, &SurfaceExpr),
        diag: &mut Diagnostics,
    ) -> Option<Value> {
        let mut alg = self.algebra();
        let (span, message) = match (left, right) {
            (Value::Scalar(s), Value::Vec3(v)) | (Value::Vec3(v), Value::Scalar(s)) => {
                return Some(Value::Vec3(geometry::scale(&mut alg, s, v)));
            }
            (Value::Rot3 { q, inverted }, Value::Vec3(v)) => {
                return Some(Value::Vec3(if inverted {
                    geometry::inverse_rotate(&mut alg, q, v)
                } else {
                    geometry::rotate(&mut alg, q, v)
                }));
            }
            (p @ Value::Rot3 { .. }, q @ Value::Rot3 { .. }) => {
                let (p, q) = (materialise(&mut alg, p), materialise(&mut alg, q));
                let q = geometry::compose(&mut alg, p?, q?);
                return Some(Value::Rot3 { q, inverted: false });
            }
            (Value::Vec3(_), Value::Vec3(_)) => (
                b.span,
                "the product of two vectors: write `a.dot(b)` or `a.cross(b)`".to_owned(),
            ),
            (Value::Vec3(_), Value::Rot3 { .. }) => (
                b.span,
                "a rotation acts on the vector to its right: write `q * v` (or \
                 `q.inverse() * v`)"
                    .to_owned(),
            ),
            (Value::Scalar(_), Value::Rot3 { .. }) => (b.span, ROTATION_ARITHMETIC.to_owned()),
            (Value::Rot3 { .. }, _) => (a.span, ROTATION_ARITHMETIC.to_owned()),
            (Value::Scalar(_), Value::Scalar(_)) => return None,
        };
        diag.error(span, message);
        None
    }

    /// `a / b` with a vector or rotation among them: only a vector over a number.
    fn quotient(
        &mut self,
        (left, a): (Value, &SurfaceExpr),
        (right, b): (Value, &SurfaceExpr),
        diag: &mut Diagnostics,
    ) -> Option<Value> {
        let (span, message) = match (left, right) {
            (Value::Vec3(v), Value::Scalar(s)) => {
                let constant = |i: usize| self.scope.const_value(i);
                if s.fold(&constant) == Some(0.0) {
                    diag.error(b.span, "division by zero");
                    return None;
                }
                return Some(Value::Vec3(geometry::div_scalar(&mut self.algebra(), v, s)));
            }
            (Value::Rot3 { .. }, _) => (a.span, ROTATION_ARITHMETIC.to_owned()),
            (_, Value::Rot3 { .. }) => (b.span, ROTATION_ARITHMETIC.to_owned()),
            (_, divisor) => (
                b.span,
                format!(
                    "a division by {}: divide a vector by a number (`v / s`), or a component \
                     (`a.x / b.x`)",
                    article(divisor.ty())
                ),
            ),
        };
        diag.error(span, message);
        None
    }

    /// `v.x`: a vector's component.
    pub(super) fn field(
        &mut self,
        base: &SurfaceExpr,
        component: &Name,
        diag: &mut Diagnostics,
    ) -> Option<Value> {
        let value = self.value(base, diag)?;
        let message = match value {
            Value::Vec3(v) => {
                match geometry::VEC3_ENTRIES
                    .iter()
                    .position(|&c| c == component.text)
                {
                    Some(i) => return Some(Value::Scalar(v[i].clone())),
                    None => format!(
                        "a vector's components are `x`, `y` and `z`, not `{}`",
                        component.text
                    ),
                }
            }
            Value::Rot3 { .. } => format!(
                "a rotation has no components in a model: measure a vector it rotates, \
                 `(q * vec3(1.0, 0.0, 0.0)).{0}`, or its rotation vector, `log(q).{0}`",
                component.text
            ),
            Value::Scalar(_) => format!(
                "this is a scalar: it has no component `{}` (only vectors do)",
                component.text
            ),
        };
        diag.error(component.span, message);
        None
    }

    /// `if lhs cmp rhs { then } else { otherwise }`: the condition compares numbers, and
    /// both arms have one type; a vector's or rotation's is chosen entry by entry.
    pub(super) fn piecewise(
        &mut self,
        cmp: Comparison,
        [lhs, rhs, then, otherwise]: [&SurfaceExpr; 4],
        diag: &mut Diagnostics,
    ) -> Option<Value> {
        let compared = |ty| {
            format!(
                "`if` compares numbers, and this is {}: compare a component (`v.x`) or a \
                 norm (`v.norm()`)",
                article(ty)
            )
        };
        let lhs = self.scalar(lhs, diag, &compared);
        let rhs = self.scalar(rhs, diag, &compared);
        let (then_value, otherwise_value) = (self.value(then, diag), self.value(otherwise, diag));
        let (lhs, rhs, a, b) = (lhs?, rhs?, then_value?, otherwise_value?);
        if a.ty() != b.ty() {
            diag.error(
                otherwise.span,
                format!(
                    "both arms of `if` have one type: the first is {}, this one {}",
                    article(a.ty()),
                    article(b.ty())
                ),
            );
            return None;
        }
        let mut alg = self.algebra();
        // A typed value is chosen entry by entry: the condition's sides are read by each.
        let (lhs, rhs) = match a.ty() {
            Type::Scalar => (lhs, rhs),
            _ => (
                alg.share(lhs, "condition_lhs"),
                alg.share(rhs, "condition_rhs"),
            ),
        };
        let select = |x: Expr, y: Expr| Expr::Select {
            cmp,
            lhs: Box::new(lhs.clone()),
            rhs: Box::new(rhs.clone()),
            then: Box::new(x),
            otherwise: Box::new(y),
        };
        Some(match (a, b) {
            (Value::Scalar(x), Value::Scalar(y)) => Value::Scalar(select(x, y)),
            (Value::Vec3([x0, x1, x2]), Value::Vec3([y0, y1, y2])) => {
                Value::Vec3([select(x0, y0), select(x1, y1), select(x2, y2)])
            }
            (p, q) => {
                let (p, q) = (materialise(&mut alg, p)?, materialise(&mut alg, q)?);
                let [p0, p1, p2, p3] = p;
                let [q0, q1, q2, q3] = q;
                let q = [
                    select(p0, q0),
                    select(p1, q1),
                    select(p2, q2),
                    select(p3, q3),
                ];
                Value::Rot3 { q, inverted: false }
            }
        })
    }

    /// `f(args)`: a function of vectors or rotations, or of numbers.
    pub(super) fn call(
        &mut self,
        expr: &SurfaceExpr,
        func: &Name,
        args: &[SurfaceExpr],
        diag: &mut Diagnostics,
    ) -> Option<Value> {
        if let Some(result) = self.geometry_call(expr, func, args, diag) {
            return result;
        }
        let scope = self.scope;
        let name = func.text.clone();
        let mut go = |e: &SurfaceExpr, diag: &mut Diagnostics| {
            self.scalar(e, diag, &|ty| {
                format!(
                    "`{name}` applies to numbers, and this is {}: apply it to a component \
                     (`v.x.{name}()`)",
                    article(ty)
                )
            })
        };
        resolve_call(expr, func, args, &scope.const_values, &mut go, diag).map(Value::Scalar)
    }
}

/// A rotation's quaternion, the inverse taken (its conjugate) if it is one.
pub(super) fn materialise(alg: &mut ExprAlgebra, value: Value) -> Option<[Expr; 4]> {
    match value {
        Value::Rot3 { q, inverted: false } => Some(q),
        Value::Rot3 { q, inverted: true } => Some(geometry::inverse(alg, q)),
        _ => None,
    }
}

/// Why a number cannot be added to a vector.
fn scalar_plus_vector() -> String {
    "a scalar added to a vector: add to a component (`v.x + 1.0`) or add a vector \
     (`v + vec3(1.0, 0.0, 0.0)`)"
        .to_owned()
}

/// The messages of misuses that other modules report too.
pub(super) fn not_a_vector(what: &str, value: &Value) -> String {
    match value {
        Value::Rot3 { .. } => rotation_not_vector(what),
        other => format!(
            "{what} is {}: a vector is expected here",
            article(other.ty())
        ),
    }
}

/// Whether `expr` is written as a plain name (its errors can then name it).
pub(super) fn written_name(expr: &SurfaceExpr) -> String {
    match &expr.kind {
        SurfaceKind::Name(name) => format!("`{name}`"),
        _ => "this".to_owned(),
    }
}

/// The type a model writes after a symbol's name, or what to write instead.
pub(super) fn written_type(name: &Name) -> Result<Type, String> {
    match name.text.as_str() {
        "Vec3" => Ok(Type::Vec3),
        "Rot3" => Ok(Type::Rot3),
        "Vector3" | "V3" | "Vec" | "Vector" => {
            Err(format!("unknown type `{}`: write `Vec3`", name.text))
        }
        "UnitQuaternion" | "Quaternion" | "Rotation3" | "Rot" | "Quat" => Err(format!(
            "unknown type `{}`: a rotation is `Rot3` (a unit quaternion, stored `[x, y, z, w]`)",
            name.text
        )),
        "f32" | "f64" | "Scalar" => Err(format!(
            "a number needs no type: write the name alone (the model's scalar types are \
             `scalar {}`)",
            name.text
        )),
        other => Err(format!(
            "unknown type `{other}`: a symbol is a number (no type), a `Vec3` or a `Rot3`"
        )),
    }
}
