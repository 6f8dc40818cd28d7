//! Prints model expressions in `meval` syntax, the language of model files, and builds the
//! `meval` context that evaluates them. Tests use it to evaluate a model numerically by a
//! path independent of the symbolic engine and the emitters.

use stateforge_compiler::ast::Comparison;
use stateforge_compiler::model::{Expr, Func, Model};

/// `expr` of `model` as a `meval` expression over the model's own names and `t`.
/// Intermediates are written out in place; piecewise terms use `if_gt(a, b, then, else)`
/// and its siblings.
pub fn to_meval(model: &Model, expr: &Expr) -> String {
    let go = |e: &Expr| to_meval(model, e);
    match expr {
        Expr::Number(v) => format!("({v:e})"),
        Expr::Const(i) => model.constants[*i].name.clone(),
        Expr::State(i) => model.states[*i].name.clone(),
        Expr::Param(i) => model.params[*i].name.clone(),
        Expr::Input(i) => model.inputs[*i].name.clone(),
        Expr::Known(i) => model.known[*i].name.clone(),
        Expr::Local(i) => format!("({})", go(&model.locals[*i].expr)),
        Expr::Time => "t".into(),
        Expr::Neg(a) => format!("(-{})", go(a)),
        Expr::Add(a, b) => format!("({} + {})", go(a), go(b)),
        Expr::Sub(a, b) => format!("({} - {})", go(a), go(b)),
        Expr::Mul(a, b) => format!("({} * {})", go(a), go(b)),
        Expr::Div(a, b) => format!("({} / {})", go(a), go(b)),
        Expr::Powi(a, n) => format!("({}^({n}))", go(a)),
        Expr::Call(f, a) => format!("{}({})", f.name(), go(a)),
        Expr::Atan2(y, x) => format!("{}({}, {})", Func::ATAN2.name, go(y), go(x)),
        Expr::Select {
            cmp,
            lhs,
            rhs,
            then,
            otherwise,
        } => format!(
            "{}({}, {}, {}, {})",
            piecewise_function(*cmp),
            go(lhs),
            go(rhs),
            go(then),
            go(otherwise)
        ),
    }
}

/// The model-file function for a piecewise term with comparison `cmp`.
pub fn piecewise_function(cmp: Comparison) -> &'static str {
    match cmp {
        Comparison::Gt => "if_gt",
        Comparison::Ge => "if_ge",
        Comparison::Lt => "if_lt",
        Comparison::Le => "if_le",
    }
}

/// A `meval` context with `meval`'s built-in functions, the model's constants and the
/// piecewise functions. Add the variables (`t`, states, parameters, inputs) before use.
pub fn context(model: &Model) -> meval::Context<'static> {
    let mut ctx = meval::Context::new();
    for c in &model.constants {
        ctx.var(c.name.clone(), c.value);
    }
    for cmp in [
        Comparison::Gt,
        Comparison::Ge,
        Comparison::Lt,
        Comparison::Le,
    ] {
        ctx.funcn(
            piecewise_function(cmp),
            move |a: &[f64]| {
                if cmp.holds(a[0], a[1]) {
                    a[2]
                } else {
                    a[3]
                }
            },
            4,
        );
    }
    ctx
}
