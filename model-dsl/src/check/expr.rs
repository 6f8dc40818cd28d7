//! Expressions: names resolved to what they refer to, function calls checked for their
//! arity and domain, piecewise terms, and every constant part folded and checked finite in
//! the model's scalar types.

use super::expr_algebra::ExprAlgebra;
use crate::ast::{Comparison, Name, SurfaceExpr, SurfaceKind};
use crate::diagnostics::{closest, Diagnostics};
use crate::model::{Expr, Func, Local, Scalar, Type, Value};
use crate::scope::{Binding, Scope};

/// Why `value` cannot be a literal of the model's scalar types, if it cannot: it must be
/// finite, and a non-zero value must not round to zero or overflow in `f32`.
fn unrepresentable(value: f64, scalars: &[Scalar]) -> Option<String> {
    if !value.is_finite() {
        return Some(format!(
            "evaluates to {value}: every constant must be a finite number"
        ));
    }
    let narrow = value as f32;
    if scalars.contains(&Scalar::F32) && (narrow.is_infinite() || (narrow == 0.0 && value != 0.0)) {
        let what = if narrow == 0.0 {
            "rounds to zero"
        } else {
            "overflows"
        };
        return Some(format!(
            "evaluates to {value:e}, which {what} in f32 (its normal numbers run from \
             {:e} to {:e}): rescale the model's units",
            f32::MIN_POSITIVE,
            f32::MAX
        ));
    }
    None
}

/// What an expression belongs to: what its errors call it, and so what it may read.
#[derive(Clone, Copy)]
pub(super) enum Reader<'a> {
    /// `const NAME = ..;`, a number fixed when the code is generated.
    Constant(&'a str),
    /// The step `dt` of continuous dynamics, a constant expression.
    Step,
    /// `output y = ..;`, computed from the model's variables and intermediates.
    Output(&'a str),
    /// `let a = ..;` in `dynamics`, which reads the intermediates above it.
    Intermediate(&'a str),
    /// A state's equation, which reads the intermediates above it.
    Equation(&'a str),
}

impl std::fmt::Display for Reader<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        match self {
            Reader::Constant(name) => write!(f, "the constant `{name}`"),
            Reader::Step => f.write_str("the step `dt`"),
            Reader::Output(name) => write!(f, "the output `{name}`"),
            Reader::Intermediate(name) => write!(f, "the intermediate `{name}`"),
            Reader::Equation(name) => write!(f, "the dynamics of `{name}`"),
        }
    }
}

/// Resolves a scalar expression: names, function calls and typed parts (a vector's
/// component, a dot product); returns `None` after recording an error, or when it reads a
/// name whose definition failed (its error recorded already: see [`Scope::failed`]).
/// `locals` is where the intermediates are, `None` where none may be read (a constant).
pub(super) fn resolve(
    expr: &SurfaceExpr,
    scope: &Scope,
    locals: Option<&mut Vec<Local>>,
    context: Reader,
    diag: &mut Diagnostics,
) -> Option<Expr> {
    let mut resolver = Resolver {
        scope,
        locals,
        context,
    };
    resolver.scalar(expr, diag, &|ty| {
        format!("{context} is a number, and this is {}", article(ty))
    })
}

/// Resolves an expression of any type (see [`resolve`]).
pub(super) fn resolve_value(
    expr: &SurfaceExpr,
    scope: &Scope,
    locals: Option<&mut Vec<Local>>,
    context: Reader,
    diag: &mut Diagnostics,
) -> Option<Value> {
    let mut resolver = Resolver {
        scope,
        locals,
        context,
    };
    resolver.value(expr, diag)
}

/// `a Vec3`, `a Rot3`, `a scalar`: a type in a sentence.
pub(super) fn article(ty: Type) -> String {
    match ty {
        Type::Scalar => "a scalar".to_owned(),
        other => format!("a `{}`", other.name()),
    }
}

/// What resolves one expression: the names it may read, where its shared parts go.
pub(super) struct Resolver<'a, 'l> {
    pub(super) scope: &'a Scope,
    /// The intermediates it may read, and where the entries of a typed value read more
    /// than once are named (computed once); `None` for a constant, which reads none.
    pub(super) locals: Option<&'l mut Vec<Local>>,
    pub(super) context: Reader<'a>,
}

impl Resolver<'_, '_> {
    /// The value of `expr`, of whatever type it has.
    pub(super) fn value(&mut self, expr: &SurfaceExpr, diag: &mut Diagnostics) -> Option<Value> {
        match self.value_of_kind(expr, diag)? {
            Value::Scalar(e) => {
                check_constant_parts(e, expr, self.scope, self.context, diag).map(Value::Scalar)
            }
            typed => Some(typed),
        }
    }

    /// [`Resolver::value`] before its constant parts are checked. Each arm only calls: a
    /// sum of 500 terms recurses through here 500 times, so the frame is kept small.
    fn value_of_kind(&mut self, expr: &SurfaceExpr, diag: &mut Diagnostics) -> Option<Value> {
        match &expr.kind {
            SurfaceKind::Number(v) => Some(Value::Scalar(Expr::Number(*v))),
            SurfaceKind::Name(name) => self.name(expr, name, diag),
            SurfaceKind::Neg(a) => self.negate(a, diag),
            SurfaceKind::Binary(op, a, b) => self.binary(*op, a, b, diag),
            SurfaceKind::Call(func, args) => self.call(expr, func, args, diag),
            SurfaceKind::Field(base, component) => self.field(base, component, diag),
            SurfaceKind::If {
                cmp,
                lhs,
                rhs,
                then,
                otherwise,
            } => self.piecewise(*cmp, [lhs, rhs, then, otherwise], diag),
        }
    }

    /// The value of `expr`, which must be a number: `why(its type)` says why otherwise.
    pub(super) fn scalar(
        &mut self,
        expr: &SurfaceExpr,
        diag: &mut Diagnostics,
        why: &dyn Fn(Type) -> String,
    ) -> Option<Expr> {
        match self.value(expr, diag)? {
            Value::Scalar(e) => Some(e),
            typed => {
                diag.error(expr.span, why(typed.ty()));
                None
            }
        }
    }

    /// A name: what it is bound to, or an error saying what is wrong.
    fn name(&mut self, expr: &SurfaceExpr, name: &str, diag: &mut Diagnostics) -> Option<Value> {
        let visible = self.locals.as_deref().map_or(0, Vec::len);
        if let Some((Binding::Typed(i), _)) = self.scope.get(name) {
            let value = self.scope.typed(*i)?.clone();
            let reads_later = |e: &Expr| matches!(e, Expr::Local(j) if *j >= visible);
            let entries: Vec<&Expr> = match &value {
                Value::Scalar(e) => vec![e],
                Value::Vec3(v) => v.iter().collect(),
                Value::Rot3 { q, .. } => q.iter().collect(),
            };
            if entries.into_iter().any(reads_later) {
                let context = self.context;
                diag.error(
                    expr.span,
                    format!("`{name}` is an intermediate of the dynamics block: {context} cannot use it"),
                );
                return None;
            }
            return Some(value);
        }
        resolve_name(expr, name, self.scope, visible, self.context, diag).map(Value::Scalar)
    }

    /// The algebra that builds this expression's scalar entries.
    pub(super) fn algebra(&mut self) -> ExprAlgebra<'_> {
        ExprAlgebra {
            locals: self.locals.as_deref_mut(),
        }
    }
}

/// What a name refers to in an expression of `context`, which may read the first
/// `visible` intermediates.
fn resolve_name(
    expr: &SurfaceExpr,
    name: &str,
    scope: &Scope,
    visible: usize,
    context: Reader,
    diag: &mut Diagnostics,
) -> Option<Expr> {
    // A name whose own definition was wrong is reported there, once: what reads it stays
    // unresolved without an error of its own, which would bury the real one.
    if scope.failed.contains(name) {
        return None;
    }
    let message = match scope.get(name) {
        Some((Binding::Const(i), _)) => return Some(Expr::Const(*i)),
        Some((Binding::State(i), _)) => return Some(Expr::State(*i)),
        Some((Binding::Param(i), _)) => return Some(Expr::Param(*i)),
        Some((Binding::Input(i), _)) => return Some(Expr::Input(*i)),
        Some((Binding::Known(i), _)) => return Some(Expr::Known(*i)),
        Some((Binding::Local(i), _)) if *i < visible => return Some(Expr::Local(*i)),
        Some((Binding::Local(_) | Binding::Typed(_), _)) => {
            format!("`{name}` is an intermediate of the dynamics block: {context} cannot use it")
        }
        None if name == "t" => return Some(Expr::Time),
        None if scope.declared.contains_key(name) => {
            cannot_read(context, name, scope.declared[name])
        }
        None => {
            let known = scope.names.keys().chain(scope.declared.keys());
            match closest(name, known.map(String::as_str)) {
                Some(near) => format!(
                    "unknown symbol `{name}` in {context}: did you mean `{near}`? (a new name \
                     is declared with `state`, `param`, `input` or `const`)"
                ),
                None => format!(
                    "unknown symbol `{name}` in {context}: declare it with `state`, `param`, \
                     `input` or `const`"
                ),
            }
        }
    };
    diag.error(expr.span, message);
    None
}

/// Why `context` cannot read `name`, a declared name (`what` it is) not in its scope, and
/// what to write instead.
fn cannot_read(context: Reader, name: &str, what: &str) -> String {
    match (context, what) {
        (Reader::Constant(_) | Reader::Step, _) => format!(
            "{context} cannot use `{name}`, {what}: a constant is a number fixed when the \
             code is generated; compute a value that depends on the model's variables with \
             `let` inside `dynamics`"
        ),
        // Outputs are measurements: nothing in the model reads one back.
        (_, "an output") => format!(
            "{context} cannot use `{name}`, an output: an expression reads the model's \
             variables, not its outputs; to share a value, name it with `let` inside \
             `dynamics` and read that (an output may read it too)"
        ),
        // The lines of `dynamics` are read in order, each `let` naming a value for the
        // lines below it (which also rules out an intermediate defined by itself).
        (Reader::Intermediate(_) | Reader::Equation(_), _) => format!(
            "{context} cannot use `{name}`, an intermediate not defined above this line: a \
             line of `dynamics` reads the intermediates above it; move `let {name} = ..;` up"
        ),
        (Reader::Output(_), _) => format!(
            "{context} cannot use `{name}`, {what}: an output reads the states, parameters, \
             inputs and constants, and the intermediates of the model's `dynamics`"
        ),
    }
}

/// Every constant part is folded into a literal of the generated code: it must be finite
/// in the model's scalar types, and no divisor may fold to zero.
fn check_constant_parts(
    e: Expr,
    expr: &SurfaceExpr,
    scope: &Scope,
    context: Reader,
    diag: &mut Diagnostics,
) -> Option<Expr> {
    let constant = |i: usize| scope.const_values.get(i).copied();
    if let (Expr::Div(_, divisor), SurfaceKind::Binary(_, _, surface_divisor)) = (&e, &expr.kind) {
        if divisor.fold(&constant) == Some(0.0) {
            diag.error(surface_divisor.span, "division by zero");
            return None;
        }
    }
    if let Some(value) = e.fold(&constant) {
        if let Some(why) = unrepresentable(value, &scope.scalars) {
            diag.error(expr.span, format!("in {context}, this {why}"));
            return None;
        }
    }
    Some(e)
}

pub(super) fn resolve_call(
    expr: &SurfaceExpr,
    func: &Name,
    args: &[SurfaceExpr],
    const_values: &[f64],
    go: &mut dyn FnMut(&SurfaceExpr, &mut Diagnostics) -> Option<Expr>,
    diag: &mut Diagnostics,
) -> Option<Expr> {
    if func.text == "powi" {
        if args.len() != 2 {
            diag.error(
                expr.span,
                format!(
                    "`powi` takes 2 arguments (base, integer exponent), found {}",
                    args.len()
                ),
            );
            return None;
        }
        let base = go(&args[0], diag);
        let exponent = match &args[1].kind {
            SurfaceKind::Number(n) if n.fract() == 0.0 && n.abs() <= 64.0 => Some(*n as i32),
            SurfaceKind::Neg(inner) => match inner.kind {
                SurfaceKind::Number(n) if n.fract() == 0.0 && n.abs() <= 64.0 => Some(-(n as i32)),
                _ => None,
            },
            _ => None,
        };
        let Some(exponent) = exponent else {
            diag.error(
                args[1].span,
                "the exponent of `powi` must be an integer literal between -64 and 64",
            );
            return None;
        };
        return Some(Expr::Powi(Box::new(base?), exponent));
    }
    if let Some(resolved) = resolve_piecewise_call(expr, func, args, const_values, go, diag) {
        return resolved;
    }
    let Some(f) = Func::from_name(&func.text) else {
        let known: Vec<_> = Func::ALL.iter().map(|f| f.name()).collect();
        diag.error(
            func.span,
            format!(
                "unsupported function `{}`: use one of {}, powi, atan2, min, max, clamp",
                func.text,
                known.join(", ")
            ),
        );
        for arg in args {
            go(arg, diag);
        }
        return None;
    };
    if args.len() != 1 {
        diag.error(
            func.span,
            format!("`{}` takes 1 argument, found {}", func.text, args.len()),
        );
        return None;
    }
    Some(Expr::Call(f, Box::new(go(&args[0], diag)?)))
}

/// `atan2(y, x)`, `min(a, b)`, `max(a, b)` and `clamp(x, lo, hi)` (a saturation); `None`
/// for any other function. The last three are piecewise terms, so they are differentiated
/// branch by branch like `if`: `min(a, b)` is `if a < b { a } else { b }`, `max(a, b)` is
/// `if a > b { a } else { b }`, and `clamp(x, lo, hi)` is
/// `if x < lo { lo } else { if x > hi { hi } else { x } }`. As methods they read as in Rust
/// (`y.atan2(x)`, `a.min(b)`, `x.clamp(lo, hi)`).
fn resolve_piecewise_call(
    expr: &SurfaceExpr,
    func: &Name,
    args: &[SurfaceExpr],
    const_values: &[f64],
    go: &mut dyn FnMut(&SurfaceExpr, &mut Diagnostics) -> Option<Expr>,
    diag: &mut Diagnostics,
) -> Option<Option<Expr>> {
    let usage = match func.text.as_str() {
        "atan2" => "`atan2(y, x)` takes 2 arguments",
        "min" => "`min(a, b)` takes 2 arguments",
        "max" => "`max(a, b)` takes 2 arguments",
        "clamp" => "`clamp(x, lo, hi)` (a saturation) takes 3 arguments",
        _ => return None,
    };
    let arity = if func.text == "clamp" { 3 } else { 2 };
    if args.len() != arity {
        diag.error(func.span, format!("{usage}, found {}", args.len()));
        for arg in args {
            go(arg, diag);
        }
        return Some(None);
    }
    let resolved: Vec<Option<Expr>> = args.iter().map(|a| go(a, diag)).collect();
    let Some(resolved) = resolved.into_iter().collect::<Option<Vec<Expr>>>() else {
        return Some(None);
    };
    let select = |cmp, lhs: &Expr, rhs: &Expr, then: &Expr, otherwise: Expr| Expr::Select {
        cmp,
        lhs: Box::new(lhs.clone()),
        rhs: Box::new(rhs.clone()),
        then: Box::new(then.clone()),
        otherwise: Box::new(otherwise),
    };
    Some(Some(match (func.text.as_str(), resolved.as_slice()) {
        ("atan2", [y, x]) => Expr::Atan2(Box::new(y.clone()), Box::new(x.clone())),
        ("min", [a, b]) => select(Comparison::Lt, a, b, a, b.clone()),
        ("max", [a, b]) => select(Comparison::Gt, a, b, a, b.clone()),
        ("clamp", [x, lo, hi]) => {
            let constant = |i: usize| const_values.get(i).copied();
            let bounds = (lo.fold(&constant), hi.fold(&constant));
            if let (Some(lo_value), Some(hi_value)) = bounds {
                if lo_value > hi_value {
                    diag.error(
                        expr.span,
                        format!(
                            "`clamp(x, lo, hi)` needs `lo <= hi`, found {lo_value} > {hi_value}: \
                             write the lower bound first"
                        ),
                    );
                    return Some(None);
                }
            }
            let upper = select(Comparison::Gt, x, hi, hi, x.clone());
            select(Comparison::Lt, x, lo, lo, upper)
        }
        _ => return Some(None),
    }))
}
