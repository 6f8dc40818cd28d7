//! The functions of vectors and rotations, named as nalgebra names them where nalgebra and
//! SymForce agree: `vec3(a, b, c)`, `a.dot(b)`, `a.cross(b)`, `a.norm()`,
//! `a.norm_squared()`, `a.normalize()`, `q.inverse()`, `exp(theta)` (a rotation vector's
//! rotation) and `log(q)` (a rotation's rotation vector). Each also reads as a function
//! (`dot(a, b)`), as a method reads `f(receiver, args)`.

use super::expr::{article, Resolver};
use super::typed::{materialise, not_a_vector, written_name};
use crate::ast::{Name, SurfaceExpr};
use crate::diagnostics::Diagnostics;
use crate::geometry;
use crate::model::{Expr, Func, Type, Value};

/// How each function of vectors and rotations is written, for its arity errors.
const USAGE: [(&str, &str, usize); 9] = [
    ("vec3", "`vec3(x, y, z)`", 3),
    ("dot", "`a.dot(b)`", 2),
    ("cross", "`a.cross(b)`", 2),
    ("norm", "`a.norm()`", 1),
    ("norm_squared", "`a.norm_squared()`", 1),
    ("normalize", "`a.normalize()`", 1),
    ("inverse", "`q.inverse()`", 1),
    ("exp", "`exp(theta)`", 1),
    ("log", "`log(q)`", 1),
];

impl Resolver<'_, '_> {
    /// `Some` of the call's value (or of `None` after an error) if `func` is a function of
    /// vectors or rotations; `None` for a function of numbers. `exp` is both: the argument's
    /// type decides.
    pub(super) fn geometry_call(
        &mut self,
        expr: &SurfaceExpr,
        func: &Name,
        args: &[SurfaceExpr],
        diag: &mut Diagnostics,
    ) -> Option<Option<Value>> {
        let &(name, usage, arity) = USAGE.iter().find(|(name, ..)| *name == func.text)?;
        if args.len() != arity {
            if name == "exp" {
                return None;
            }
            diag.error(
                func.span,
                format!("{usage} takes {arity} argument(s), found {}", args.len()),
            );
            return Some(None);
        }
        if name == "vec3" {
            return Some(self.vec3(expr, args, diag));
        }
        let values: Vec<Option<Value>> = args.iter().map(|a| self.value(a, diag)).collect();
        let values: Option<Vec<Value>> = values.into_iter().collect();
        Some(self.apply(name, values?, args, diag))
    }

    /// `vec3(x, y, z)`, of three numbers; not in a constant, which is a number.
    fn vec3(
        &mut self,
        expr: &SurfaceExpr,
        args: &[SurfaceExpr],
        diag: &mut Diagnostics,
    ) -> Option<Value> {
        if self.locals.is_none() {
            let context = self.context;
            diag.error(
                expr.span,
                format!(
                    "{context} is a number fixed when the code is generated: write the vector \
                     where it is used (in `dynamics` or an output), `vec3(..)` of constants"
                ),
            );
            return None;
        }
        let why = |ty| {
            format!(
                "a vector's entries are numbers, and this is {}",
                article(ty)
            )
        };
        let entries: Vec<Option<Expr>> = args.iter().map(|a| self.scalar(a, diag, &why)).collect();
        let [x, y, z]: [Option<Expr>; 3] = entries.try_into().ok()?;
        Some(Value::Vec3([x?, y?, z?]))
    }

    /// The function `name` of its resolved arguments `values` (written as `args`).
    fn apply(
        &mut self,
        name: &str,
        values: Vec<Value>,
        args: &[SurfaceExpr],
        diag: &mut Diagnostics,
    ) -> Option<Value> {
        let mut alg = self.algebra();
        let mut values = values.into_iter();
        let first = values.next()?;
        let result = match (name, first, values.next()) {
            ("dot", Value::Vec3(a), Some(Value::Vec3(b))) => {
                Value::Scalar(geometry::dot(&mut alg, a, b))
            }
            ("cross", Value::Vec3(a), Some(Value::Vec3(b))) => {
                Value::Vec3(geometry::cross(&mut alg, a, b))
            }
            ("norm", Value::Vec3(a), None) => Value::Scalar(geometry::norm(&mut alg, a)),
            ("norm_squared", Value::Vec3(a), None) => {
                Value::Scalar(geometry::norm_squared(&mut alg, a))
            }
            ("normalize", Value::Vec3(a), None) => Value::Vec3(geometry::normalize(&mut alg, a)),
            ("inverse", Value::Rot3 { q, inverted }, None) => Value::Rot3 {
                q,
                inverted: !inverted,
            },
            ("exp", Value::Scalar(x), None) => Value::Scalar(Expr::Call(Func::Exp, Box::new(x))),
            ("exp", Value::Vec3(theta), None) => Value::Rot3 {
                q: geometry::exp(&mut alg, theta),
                inverted: false,
            },
            ("log", rotation @ Value::Rot3 { .. }, None) => {
                let q = materialise(&mut alg, rotation)?;
                Value::Vec3(geometry::log(&mut alg, q))
            }
            (name, first, second) => {
                let (span, message) = misuse(name, &first, second.as_ref(), args);
                diag.error(span, message);
                return None;
            }
        };
        Some(result)
    }
}

/// Where a function of vectors or rotations was given a wrong argument, and what to write.
fn misuse(
    name: &str,
    first: &Value,
    second: Option<&Value>,
    args: &[SurfaceExpr],
) -> (proc_macro2::Span, String) {
    let vector_args = matches!(
        name,
        "dot" | "cross" | "norm" | "norm_squared" | "normalize"
    );
    if vector_args {
        for (value, arg) in std::iter::once(first).chain(second).zip(args) {
            if value.ty() != Type::Vec3 {
                return (arg.span, not_a_vector(&written_name(arg), value));
            }
        }
    }
    let arg = &args[0];
    let message = match (name, first.ty()) {
        ("inverse", _) => format!(
            "`inverse` is a rotation's, and this is {}: for a number write `1.0 / x`",
            article(first.ty())
        ),
        ("exp", _) => format!(
            "`exp` takes a number (its exponential) or a rotation vector `Vec3` (its \
             rotation), and this is {}: to scale a rotation's angle write `exp(k * log(q))`",
            article(first.ty())
        ),
        ("log", Type::Scalar) => {
            "`log` is a rotation's logarithm: the natural log of a number is `ln(x)`".to_owned()
        }
        ("log", ty) => format!(
            "`log` takes a rotation (`Rot3`), and this is {}",
            article(ty)
        ),
        _ => format!("`{name}` does not apply to {}", article(first.ty())),
    };
    (arg.span, message)
}
