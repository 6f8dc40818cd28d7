//! Resolves a [`ModelDecl`] into the model IR, collecting every mistake on the way.

use crate::ast::{
    ArgValue, BinaryOp, Comparison, DynamicsDecl, DynamicsKind, GenerateArg, GenerateDecl,
    ModelDecl, Name, Statement, SurfaceExpr, SurfaceKind, SymbolKind,
};
use crate::diagnostics::Diagnostics;
use crate::model::{
    Constant, ContinuousEkfSpec, Discretisation, DkfSpec, Dynamics, EkfSpec, Expr, Func, Generate,
    HybridEkfSpec, Local, Method, Model, Output, Scalar, Symbol,
};
use indexmap::IndexMap;
use proc_macro2::Span;

/// Items the generated module defines; a constant (also an item) may not take their names.
const GENERATED_ITEMS: &[&str] = &[
    "f",
    "F_SUBSTEPS",
    "h",
    "jacobian_f_wrt_x",
    "jacobian_f_wrt_u",
    "jacobian_h_wrt_x",
    "index",
    "in_f32",
    "in_f64",
    "OpCount",
    "X_LEN",
    "STATE_LEN",
    "PARAM_LEN",
    "U_LEN",
    "Y_LEN",
    "X_NAMES",
    "U_NAMES",
    "Y_NAMES",
    "KNOWN_LEN",
    "KNOWN_NAMES",
    "Ekf",
    "Dkf",
    "DkfStatus",
    "Lqr",
    "Mpc",
    "MpcStatus",
    "PredictionModel",
    "Status",
    "WindowStatus",
    "HybridEkf",
    "ContinuousEkf",
    "PolynomialKf",
    "LinearErrorObserver",
    "SwitchedKalmanObserver",
    "CommonGainObserver",
    "ltv_model",
];

/// What a name in an expression refers to.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Binding {
    Const(usize),
    State(usize),
    Param(usize),
    Input(usize),
    Known(usize),
    Local(usize),
}

/// The names declared so far, and what expressions need to know of them.
pub(crate) struct Scope {
    names: IndexMap<String, (Binding, Span)>,
    /// The values of the constants declared so far, by index.
    const_values: Vec<f64>,
    /// The model's scalar types: every constant must be finite in each.
    scalars: Vec<Scalar>,
    /// What each name of the model is, declared yet or not, for a name used before (or
    /// where) it can be.
    declared: std::collections::HashMap<String, &'static str>,
}

impl Scope {
    fn new(decl: &ModelDecl) -> Scope {
        let mut declared = std::collections::HashMap::new();
        for sym in &decl.symbols {
            let what = match sym.kind {
                SymbolKind::State => "a state",
                SymbolKind::Param => "a parameter",
                SymbolKind::Input => "an input",
                SymbolKind::Known => "a constant known at run time",
            };
            declared.insert(sym.name.text.clone(), what);
        }
        for out in &decl.outputs {
            declared.insert(out.name.text.clone(), "an output");
        }
        for statement in decl.dynamics.iter().flat_map(|d| &d.statements) {
            if let Statement::Let { name, .. } = statement {
                declared.insert(name.text.clone(), "an intermediate of `dynamics`");
            }
        }
        Scope {
            names: IndexMap::new(),
            const_values: Vec::new(),
            scalars: Vec::new(),
            declared,
        }
    }

    pub(crate) fn get(&self, name: &str) -> Option<&(Binding, Span)> {
        self.names.get(name)
    }

    fn contains_key(&self, name: &str) -> bool {
        self.names.contains_key(name)
    }
}

/// Checks a declaration and resolves it into a [`Model`], reporting every error found
/// together with those the front end already recorded in `diag`.
pub fn check(decl: &ModelDecl, mut diag: Diagnostics) -> syn::Result<Model> {
    let mut scope = Scope::new(decl);

    check_identifier(&decl.name, &mut diag);
    check_case_collisions(decl, &mut diag);
    let scalars = check_scalars(decl, &mut diag);
    scope.scalars = scalars.clone();
    let constants = check_constants(decl, &mut scope, &mut diag);

    let (mut states, mut params, mut inputs) = (Vec::new(), Vec::new(), Vec::new());
    let mut known = Vec::new();
    let mut state_spans = Vec::new();
    for sym in &decl.symbols {
        let symbol = Symbol {
            docs: sym.docs.clone(),
            name: sym.name.text.clone(),
        };
        let binding = match sym.kind {
            SymbolKind::State => {
                state_spans.push(sym.name.span);
                states.push(symbol);
                Binding::State(states.len() - 1)
            }
            SymbolKind::Param => {
                params.push(symbol);
                Binding::Param(params.len() - 1)
            }
            SymbolKind::Input => {
                inputs.push(symbol);
                Binding::Input(inputs.len() - 1)
            }
            SymbolKind::Known => {
                known.push(symbol);
                Binding::Known(known.len() - 1)
            }
        };
        declare(&mut scope, &sym.name, binding, &mut diag);
    }
    if states.is_empty() {
        diag.error(
            decl.name.span,
            "the model declares no state: add a line such as `state x1, x2;`",
        );
    }

    let mut outputs = Vec::new();
    let mut output_names = std::collections::HashSet::new();
    for out in &decl.outputs {
        if output_names.contains(out.name.text.as_str()) || scope.contains_key(&out.name.text) {
            duplicate_error(&mut diag, &out.name);
        } else {
            check_name_allowed(&out.name, false, &mut diag);
            output_names.insert(out.name.text.as_str());
        }
        let context = format!("the output `{}`", out.name.text);
        if let Some(expr) = resolve(&out.expr, &scope, &[], &context, &mut diag) {
            outputs.push(Output {
                docs: out.docs.clone(),
                name: out.name.text.clone(),
                expr,
            });
        }
    }

    let mut locals = Vec::new();
    let dynamics = match decl.dynamics.as_slice() {
        [] => {
            diag.error(
                decl.name.span,
                "the model has no dynamics: add `dynamics discrete { x1 = ...; }` or \
                 `dynamics continuous(rk4, dt = TS) { der(x1) = ...; }`",
            );
            None
        }
        [block, extra @ ..] => {
            for other in extra {
                diag.error(
                    other.span,
                    "a model has one dynamics block: move these equations into the first",
                );
            }
            check_dynamics(
                block,
                &mut scope,
                &state_spans,
                &states,
                &mut locals,
                &mut diag,
            )
        }
    };

    let generate = check_generate(decl, &scope, &mut diag);
    check_known_support(decl, &mut diag);
    let model = dynamics.map(|dynamics| Model {
        docs: decl.docs.clone(),
        vis: decl.vis.clone(),
        name: decl.name.text.clone(),
        scalars,
        constants,
        states,
        params,
        inputs,
        known,
        outputs,
        dynamics,
        locals,
        generate,
    });
    match model {
        Some(model) => diag.finish(model),
        None => {
            // `check_dynamics` only returns `None` after recording an error.
            debug_assert!(diag.has_errors());
            diag.finish(()).and_then(|()| {
                Err(syn::Error::new(
                    decl.span,
                    "the model has no valid dynamics",
                ))
            })
        }
    }
}

fn check_scalars(decl: &ModelDecl, diag: &mut Diagnostics) -> Vec<Scalar> {
    let mut scalars = Vec::new();
    for name in &decl.scalars {
        let scalar = match name.text.as_str() {
            "f32" => Scalar::F32,
            "f64" => Scalar::F64,
            other => {
                diag.error(
                    name.span,
                    format!("unsupported scalar type `{other}`: write `f32` or `f64`"),
                );
                continue;
            }
        };
        if scalars.contains(&scalar) {
            diag.error(
                name.span,
                format!("scalar type `{}` is listed twice", name.text),
            );
        } else {
            scalars.push(scalar);
        }
    }
    if decl.scalars.is_empty() {
        diag.error(
            decl.name.span,
            "the model names no scalar type: add `scalar f32;` (or `scalar f32, f64;` to \
             also generate an f64 version for host checks)",
        );
    }
    scalars
}

fn check_constants(decl: &ModelDecl, scope: &mut Scope, diag: &mut Diagnostics) -> Vec<Constant> {
    let mut constants = Vec::new();
    for c in &decl.constants {
        let context = format!("the constant `{}`", c.name.text);
        let value = resolve(&c.value, scope, &[], &context, diag).and_then(|expr| {
            let value = expr.fold(&|i| scope.const_values.get(i).copied());
            if value.is_none() {
                diag.error(
                    c.value.span,
                    format!("{context} must be computed from literals and earlier constants only"),
                );
            }
            value
        });
        constants.push(Constant {
            docs: c.docs.clone(),
            name: c.name.text.clone(),
            value: value.unwrap_or(0.0),
        });
        scope.const_values.push(value.unwrap_or(0.0));
        declare(scope, &c.name, Binding::Const(constants.len() - 1), diag);
    }
    constants
}

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

#[allow(clippy::too_many_arguments)]
fn check_dynamics(
    block: &DynamicsDecl,
    scope: &mut Scope,
    state_spans: &[Span],
    states: &[Symbol],
    locals: &mut Vec<Local>,
    diag: &mut Diagnostics,
) -> Option<Dynamics> {
    let continuous = matches!(block.kind, DynamicsKind::Continuous { .. });
    let discretisation = match &block.kind {
        DynamicsKind::Discrete => Some(Discretisation::Discrete),
        DynamicsKind::Continuous {
            method,
            dt,
            substeps,
        } => check_discretisation(block.span, method, dt, substeps, scope, diag),
    };

    // Per state: `None` until an equation is written, then its right-hand side (`None`
    // inside when that had errors, already reported: no follow-on "no dynamics" error).
    let mut rhs: Vec<Option<Option<Expr>>> = vec![None; states.len()];
    for statement in &block.statements {
        match statement {
            Statement::Let { name, value } => {
                let context = format!("the intermediate `{}`", name.text);
                if let Some(expr) = resolve(value, scope, locals, &context, diag) {
                    locals.push(Local {
                        name: name.text.clone(),
                        expr,
                    });
                    declare(scope, name, Binding::Local(locals.len() - 1), diag);
                }
            }
            Statement::Equation {
                target,
                derivative,
                value,
            } => {
                let context = format!("the dynamics of `{}`", target.text);
                let expr = resolve(value, scope, locals, &context, diag);
                let index = match scope.get(&target.text) {
                    Some((Binding::State(i), _)) => *i,
                    Some((Binding::Param(_), _)) => {
                        diag.error(
                            target.span,
                            format!(
                                "`{}` is a parameter: an unknown constant estimated as a random \
                                 walk, so it takes no dynamics; declare it with `state` if it evolves",
                                target.text
                            ),
                        );
                        continue;
                    }
                    Some((Binding::Input(_), _)) => {
                        diag.error(
                            target.span,
                            format!(
                                "`{}` is an input: it is given each sample, not computed",
                                target.text
                            ),
                        );
                        continue;
                    }
                    Some((Binding::Known(_), _)) => {
                        diag.error(
                            target.span,
                            format!(
                                "`{}` is known at run time: it is given when the filter is \
                                 made, not computed; declare it with `state` if it evolves",
                                target.text
                            ),
                        );
                        continue;
                    }
                    Some((Binding::Const(_) | Binding::Local(_), _)) => {
                        diag.error(
                            target.span,
                            format!(
                                "`{}` is not a state: only states take dynamics",
                                target.text
                            ),
                        );
                        continue;
                    }
                    None => {
                        diag.error(
                            target.span,
                            format!(
                                "unknown state `{}`: declare it with `state {};`",
                                target.text, target.text
                            ),
                        );
                        continue;
                    }
                };
                if continuous && !derivative {
                    diag.error(
                        target.span,
                        format!(
                            "continuous dynamics give derivatives: write `der({}) = ...;`",
                            target.text
                        ),
                    );
                } else if !continuous && *derivative {
                    diag.error(
                        target.span,
                        format!(
                            "`der(..)` needs continuous dynamics: write `{} = ...;` for the next \
                             sample, or `dynamics continuous(euler, dt = TS)`",
                            target.text
                        ),
                    );
                }
                if rhs[index].is_some() {
                    diag.error(
                        target.span,
                        format!(
                            "state `{}` has a second equation: each state takes exactly one",
                            target.text
                        ),
                    );
                } else {
                    rhs[index] = Some(expr);
                }
            }
        }
    }

    let mut complete = Vec::with_capacity(states.len());
    for ((slot, state), span) in rhs.into_iter().zip(states).zip(state_spans) {
        match slot {
            Some(Some(expr)) => complete.push(expr),
            Some(None) => {}
            None => {
                let form = if continuous {
                    format!("der({}) = ...;", state.name)
                } else {
                    format!("{} = ...;", state.name)
                };
                diag.error(
                    *span,
                    format!("state `{}` has no dynamics: add `{form}`", state.name),
                );
            }
        }
    }
    let discretisation = discretisation?;
    (complete.len() == states.len()).then_some(Dynamics {
        discretisation,
        rhs: complete,
    })
}

fn check_discretisation(
    span: Span,
    method: &Option<Name>,
    dt: &Option<SurfaceExpr>,
    substeps: &Option<(u64, Span)>,
    scope: &Scope,
    diag: &mut Diagnostics,
) -> Option<Discretisation> {
    let hint = "write `dynamics continuous(euler, dt = TS)` or `dynamics continuous(rk4, dt = TS, substeps = 2)`";
    let method = match method {
        None => {
            diag.error(
                span,
                format!("continuous dynamics need a discretisation: {hint}"),
            );
            None
        }
        Some(name) => match name.text.as_str() {
            "euler" => Some(Method::Euler),
            "rk4" => Some(Method::Rk4),
            other => {
                diag.error(
                    name.span,
                    format!("unknown integration method `{other}`: use `euler` or `rk4`"),
                );
                None
            }
        },
    };
    let dt = match dt {
        None => {
            if method.is_some() {
                diag.error(
                    span,
                    format!("the discretisation needs a step `dt`: {hint}"),
                );
            }
            None
        }
        Some(expr) => resolve(expr, scope, &[], "the step `dt`", diag).and_then(|e| {
            let consts_only = !e.any(&|e| {
                !matches!(
                    e,
                    Expr::Number(_)
                        | Expr::Const(_)
                        | Expr::Neg(_)
                        | Expr::Add(..)
                        | Expr::Sub(..)
                        | Expr::Mul(..)
                        | Expr::Div(..)
                )
            });
            if !consts_only {
                diag.error(
                    expr.span,
                    "the step `dt` must be a constant expression, such as `TS`",
                );
                return None;
            }
            Some(e)
        }),
    };
    let substeps = match substeps {
        None => Some(1),
        Some((0, span)) => {
            diag.error(*span, "`substeps` must be at least 1");
            None
        }
        Some((n, span)) => match u32::try_from(*n) {
            Ok(n) if n <= crate::model::SUBSTEPS_MAX => Some(n),
            _ => {
                diag.error(
                    *span,
                    format!(
                        "`substeps` is at most {}: sub-steps above {} run in a loop, but \
                         each still costs time on the target",
                        crate::model::SUBSTEPS_MAX,
                        crate::model::UNROLLED_SUBSTEPS_MAX
                    ),
                );
                None
            }
        },
    };
    Some(Discretisation::Continuous {
        method: method?,
        dt: dt?,
        substeps: substeps?,
    })
}

fn declare(scope: &mut Scope, name: &Name, binding: Binding, diag: &mut Diagnostics) {
    if scope.contains_key(&name.text) {
        duplicate_error(diag, name);
        return;
    }
    check_name_allowed(name, matches!(binding, Binding::Const(_)), diag);
    scope.names.insert(name.text.clone(), (binding, name.span));
}

fn duplicate_error(diag: &mut Diagnostics, name: &Name) {
    diag.error(
        name.span,
        format!(
            "`{}` is declared twice: every constant, symbol and output needs its own name",
            name.text
        ),
    );
}

fn check_name_allowed(name: &Name, is_item: bool, diag: &mut Diagnostics) {
    let generated = GENERATED_ITEMS.contains(&name.text.as_str())
        || name.text.ends_with("_OPS")
        || name.text.ends_with("_NONZERO");
    if name.text == "t" {
        diag.error(name.span, "`t` is the time in seconds: choose another name");
    } else if is_item && generated {
        diag.error(
            name.span,
            format!(
                "`{}` is a name the generated module uses: choose another",
                name.text
            ),
        );
    } else {
        check_identifier(name, diag);
    }
}

/// A name that becomes an identifier of the generated code must be a plain Rust
/// identifier: model files can hold any text, and a raw identifier (`r#type`) would need
/// its `r#` at every use, in every name derived from it (`index::R#TYPE` is none).
fn check_identifier(name: &Name, diag: &mut Diagnostics) {
    if let Some(keyword) = name.text.strip_prefix("r#") {
        diag.error(
            name.span,
            format!("raw identifiers are not supported: choose a name that is not the keyword `{keyword}`"),
        );
    } else if !is_identifier(&name.text) {
        diag.error(
            name.span,
            format!(
                "`{}` is not a Rust identifier: use letters, digits and `_`, starting with a \
                 letter, and no keyword",
                name.text
            ),
        );
    }
}

/// Whether `text` is one Rust identifier, character by character (a parser would skip a
/// trailing comment, `x // y`), and not a keyword.
fn is_identifier(text: &str) -> bool {
    let mut chars = text.chars();
    let starts = chars
        .next()
        .is_some_and(|c| c == '_' || unicode_ident::is_xid_start(c));
    starts
        && chars.all(unicode_ident::is_xid_continue)
        && syn::parse_str::<syn::Ident>(text).is_ok()
}

/// Names that differ only in case would give the same constant in the generated `index`
/// module (`x2` and `X2` are both `index::X2`).
fn check_case_collisions(decl: &ModelDecl, diag: &mut Diagnostics) {
    let mut seen: std::collections::HashMap<String, &Name> = std::collections::HashMap::new();
    let names = decl.symbols.iter().map(|s| &s.name);
    for name in names.chain(decl.outputs.iter().map(|o| &o.name)) {
        match seen.get(&name.text.to_uppercase()) {
            Some(first) if first.text != name.text => diag.error(
                name.span,
                format!(
                    "`{}` and `{}` differ only in case: both would be `index::{}` in the \
                     generated code; choose names that differ in their letters",
                    name.text,
                    first.text,
                    name.text.to_uppercase()
                ),
            ),
            _ => {
                seen.insert(name.text.to_uppercase(), name);
            }
        }
    }
}

/// Resolves names and function calls; returns `None` after recording an error.
fn resolve(
    expr: &SurfaceExpr,
    scope: &Scope,
    locals: &[Local],
    context: &str,
    diag: &mut Diagnostics,
) -> Option<Expr> {
    let mut go = |e: &SurfaceExpr, diag: &mut Diagnostics| resolve(e, scope, locals, context, diag);
    Some(match &expr.kind {
        SurfaceKind::Number(v) => Expr::Number(*v),
        SurfaceKind::Name(name) => match scope.get(name) {
            Some((Binding::Const(i), _)) => Expr::Const(*i),
            Some((Binding::State(i), _)) => Expr::State(*i),
            Some((Binding::Param(i), _)) => Expr::Param(*i),
            Some((Binding::Input(i), _)) => Expr::Input(*i),
            Some((Binding::Known(i), _)) => Expr::Known(*i),
            Some((Binding::Local(i), _)) if *i < locals.len() => Expr::Local(*i),
            Some((Binding::Local(_), _)) => {
                diag.error(
                    expr.span,
                    format!("`{name}` is an intermediate of the dynamics block: {context} cannot use it"),
                );
                return None;
            }
            None if name == "t" => Expr::Time,
            None if scope.declared.contains_key(name) => {
                let what = scope.declared[name];
                diag.error(
                    expr.span,
                    format!(
                        "{context} cannot use `{name}`, {what}: a constant is a number fixed \
                         when the code is generated; compute a value that depends on the \
                         model's variables with `let` inside `dynamics`"
                    ),
                );
                return None;
            }
            None => {
                diag.error(
                    expr.span,
                    format!(
                        "unknown symbol `{name}` in {context}: declare it with `state`, `param`, \
                         `input` or `const`"
                    ),
                );
                return None;
            }
        },
        SurfaceKind::Neg(a) => Expr::Neg(Box::new(go(a, diag)?)),
        SurfaceKind::Binary(op, a, b) => {
            let (a, b) = (go(a, diag), go(b, diag));
            let (a, b) = (Box::new(a?), Box::new(b?));
            match op {
                BinaryOp::Add => Expr::Add(a, b),
                BinaryOp::Sub => Expr::Sub(a, b),
                BinaryOp::Mul => Expr::Mul(a, b),
                BinaryOp::Div => Expr::Div(a, b),
            }
        }
        SurfaceKind::Call(func, args) => {
            resolve_call(expr, func, args, &scope.const_values, &mut go, diag)?
        },
        SurfaceKind::If {
            cmp,
            lhs,
            rhs,
            then,
            otherwise,
        } => {
            let parts = [lhs, rhs, then, otherwise].map(|e| go(e, diag));
            let [lhs, rhs, then, otherwise] = parts;
            Expr::Select {
                cmp: *cmp,
                lhs: Box::new(lhs?),
                rhs: Box::new(rhs?),
                then: Box::new(then?),
                otherwise: Box::new(otherwise?),
            }
        }
    })
    .and_then(|e| {
        if let (Expr::Div(_, divisor), SurfaceKind::Binary(_, _, surface_divisor)) =
            (&e, &expr.kind)
        {
            if divisor.fold(&|i| scope.const_values.get(i).copied()) == Some(0.0) {
                diag.error(surface_divisor.span, "division by zero");
                return None;
            }
        }
        // Every constant part is folded into a literal of the generated code.
        if let Some(value) = e.fold(&|i| scope.const_values.get(i).copied()) {
            if let Some(why) = unrepresentable(value, &scope.scalars) {
                diag.error(expr.span, format!("in {context}, this {why}"));
                return None;
            }
        }
        Some(e)
    })
}

fn resolve_call(
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

/// A constant known only at run time enters the model functions, the EKF and the LQR as
/// an argument or a stored value; the other generators compute their design or derive
/// their window transform when the code is generated, or integrate in a loop that does not
/// carry it, so they need every coefficient as a number then.
fn check_known_support(decl: &ModelDecl, diag: &mut Diagnostics) {
    let Some(first) = decl.symbols.iter().find(|s| s.kind == SymbolKind::Known) else {
        return;
    };
    for item in &decl.generate {
        if !matches!(item.name.text.as_str(), "ekf" | "lqr") {
            diag.error(
                item.name.span,
                format!(
                    "`{}` needs every coefficient when the code is generated, and `{}` is \
                     known only at run time: declare it with `const`, or use `ekf` and `lqr`",
                    item.name.text, first.name.text
                ),
            );
        }
    }
    if let Some(DynamicsDecl {
        kind:
            DynamicsKind::Continuous {
                substeps: Some((n, span)),
                ..
            },
        ..
    }) = decl.dynamics.first()
    {
        if *n > u64::from(crate::model::UNROLLED_SUBSTEPS_MAX) {
            diag.error(
                *span,
                format!(
                    "sub-steps past {} run as a loop, which does not read `{}`, known at run \
                     time: use at most {0} sub-steps, or declare it with `const`",
                    crate::model::UNROLLED_SUBSTEPS_MAX,
                    first.name.text
                ),
            );
        }
    }
}

/// Checks the `generate` items: known generators, known arguments of the right kinds.
fn check_generate(decl: &ModelDecl, scope: &Scope, diag: &mut Diagnostics) -> Generate {
    let mut generate = Generate::default();
    let mut seen = std::collections::HashSet::new();
    for item in &decl.generate {
        // Several EKFs may be asked for under different type names.
        let key = match item.name.text.as_str() {
            "ekf" => format!("ekf {}", ekf_type_name(item)),
            other => other.to_owned(),
        };
        if !seen.insert(key) {
            let message = if item.name.text == "ekf" {
                format!(
                    "an `ekf` of type `{}` is asked for twice: give the second another type \
                     name, `ekf(name = GatedEkf)`",
                    ekf_type_name(item)
                )
            } else {
                format!("`{}` is asked for twice", item.name.text)
            };
            diag.error(item.name.span, message);
            continue;
        }
        let mut args = Args::new(item, diag);
        match item.name.text.as_str() {
            "ekf" | "dkf" if decl.outputs.is_empty() => {
                diag.error(
                    item.name.span,
                    format!(
                        "`{}` corrects its estimate with measurements: declare them with \
                         `output y = ...;`",
                        item.name.text
                    ),
                );
                continue;
            }
            "ekf" => {
                let type_name = args.type_name("Ekf", diag);
                let gate = args.gate(diag);
                generate.ekf.push(EkfSpec {
                    type_name,
                    gate,
                    diagonal_noise: args.process_noise(diag),
                });
            }
            "dkf" => {
                let (eta, eta_span) = args.number("eta", 0.5, diag);
                let diagonal_noise = args.process_noise(diag);
                if !(0.0..=1.0).contains(&eta) {
                    diag.error(eta_span, "`eta` weights a split: it lies in 0..=1");
                }
                generate.dkf = Some(DkfSpec {
                    eta,
                    diagonal_noise,
                    span: item.name.span,
                });
            }
            "lqr" => {
                generate.lqr = Some(crate::check_controllers::lqr(item, &mut args, scope, diag));
            }
            "mpc" => {
                generate.mpc = Some(crate::check_controllers::mpc(
                    decl, item, &mut args, scope, diag,
                ));
            }
            "hybrid_ekf" => {
                require_continuous(decl, item, diag);
                generate.hybrid_ekf = Some(HybridEkfSpec {
                    diagonal_noise: args.process_noise(diag),
                });
            }
            "continuous_ekf" => {
                require_continuous(decl, item, diag);
                let alpha = args.optional_number("alpha", diag);
                if let Some((a, span)) = alpha.filter(|(a, _)| !(*a >= 0.0 && a.is_finite())) {
                    diag.error(
                        span,
                        format!(
                            "`alpha`, the prescribed degree of stability, is finite and at \
                             least 0 (per second), not {a}"
                        ),
                    );
                }
                generate.continuous_ekf = Some(ContinuousEkfSpec {
                    diagonal_noise: args.process_noise(diag),
                    alpha: alpha.map(|(a, _)| a),
                });
            }
            "polynomial_kf" => {
                let value = |name: &Name| constant_value(scope, name);
                generate.polynomial_kf =
                    crate::check_designs::polynomial_kf(item, &mut args, &value, diag);
            }
            "switched_observer" => {
                let value = |name: &Name| constant_value(scope, name);
                generate.switched_observer =
                    crate::check_designs::switched_observer(item, &mut args, &value, diag);
            }
            other => {
                diag.error(
                    item.name.span,
                    format!(
                        "unknown generator `{other}`: use `ekf`, `dkf(eta = ..)`, `lqr(..)`, \
                         `mpc(..)`, `hybrid_ekf`, `continuous_ekf(alpha = ..)`, `polynomial_kf(..)` or \
                         `switched_observer(..)`"
                    ),
                );
                continue;
            }
        }
        if matches!(item.name.text.as_str(), "ekf" | "dkf" | "lqr") {
            require_unrolled(decl, item, diag);
        }
        args.report_unused(diag);
    }
    generate
}

/// The type name an `ekf` item asks for (`Ekf` unless `name = ..`), for telling two apart.
fn ekf_type_name(item: &GenerateDecl) -> String {
    item.args
        .iter()
        .find(|a| a.name.text == "name")
        .and_then(|a| match &a.value {
            ArgValue::Name(n) => Some(n.text.clone()),
            _ => None,
        })
        .unwrap_or_else(|| "Ekf".to_owned())
}

/// An UpperCamelCase identifier (`GatedEkf`): a capital first, then letters and digits.
fn is_type_name(text: &str) -> bool {
    text.chars().next().is_some_and(|c| c.is_ascii_uppercase())
        && text.chars().all(|c| c.is_ascii_alphanumeric())
        && text.chars().any(|c| c.is_ascii_lowercase())
}

/// A type the generated module defines whatever the model asks for, or may define.
fn generated_type(text: &str) -> bool {
    GENERATED_ITEMS.contains(&text) || text == "Self"
}

/// The continuous filters integrate `dx/dt` between samples: the model must give it.
fn require_continuous(decl: &ModelDecl, item: &GenerateDecl, diag: &mut Diagnostics) {
    let continuous = decl
        .dynamics
        .iter()
        .any(|d| matches!(d.kind, DynamicsKind::Continuous { .. }));
    if !continuous {
        diag.error(
            item.name.span,
            format!(
                "`{}` integrates the continuous dynamics between samples: declare them as \
                 `dynamics continuous(euler, dt = TS) {{ der(x) = ..; }}`",
                item.name.text
            ),
        );
    }
}

/// The discrete filters and the LQR are built on the unrolled step `f` and its Jacobian.
fn require_unrolled(decl: &ModelDecl, item: &GenerateDecl, diag: &mut Diagnostics) {
    let looped = decl.dynamics.iter().any(|d| match &d.kind {
        DynamicsKind::Continuous { substeps, .. } => substeps
            .as_ref()
            .is_some_and(|(n, _)| *n > u64::from(crate::model::UNROLLED_SUBSTEPS_MAX)),
        DynamicsKind::Discrete => false,
    });
    if looped {
        diag.error(
            item.name.span,
            format!(
                "`{}` differentiates the unrolled sample step, which allows at most {} \
                 sub-steps: use fewer, or `hybrid_ekf`, which integrates them in a loop",
                item.name.text,
                crate::model::UNROLLED_SUBSTEPS_MAX
            ),
        );
    }
}

/// The value of the model constant `name`, if it names one.
fn constant_value(scope: &Scope, name: &Name) -> Option<f64> {
    match scope.names.get(&name.text) {
        Some((Binding::Const(i), _)) => scope.const_values.get(*i).copied(),
        _ => None,
    }
}

/// The arguments of one `generate` item, taken one by one; what is left is an error.
pub(crate) struct Args<'a> {
    item: &'a GenerateDecl,
    used: Vec<bool>,
}

impl<'a> Args<'a> {
    fn new(item: &'a GenerateDecl, diag: &mut Diagnostics) -> Args<'a> {
        let mut names = std::collections::HashSet::new();
        for arg in &item.args {
            if !names.insert(arg.name.text.as_str()) {
                diag.error(arg.name.span, format!("`{}` is given twice", arg.name.text));
            }
        }
        Args {
            item,
            used: vec![false; item.args.len()],
        }
    }

    pub(crate) fn take(&mut self, names: &[&str]) -> Option<&'a GenerateArg> {
        let i = self
            .item
            .args
            .iter()
            .position(|a| names.contains(&a.name.text.as_str()))?;
        self.used[i] = true;
        Some(&self.item.args[i])
    }

    /// The number given as `name`, or `default`, with where to report a wrong value: the
    /// value, or the generator's name when the default is taken.
    pub(crate) fn number(
        &mut self,
        name: &str,
        default: f64,
        diag: &mut Diagnostics,
    ) -> (f64, Span) {
        match self.take(&[name]).map(|a| &a.value) {
            None => (default, self.item.name.span),
            Some(ArgValue::Number(v, span)) => (*v, *span),
            Some(other) => {
                diag.error(other.span(), format!("`{name}` takes a number"));
                (default, other.span())
            }
        }
    }

    /// `gate = 10.83` (the default threshold on the normalised innovation squared) or
    /// `gate = off` (a gate that is open until set at run time); `None` without `gate`.
    fn gate(&mut self, diag: &mut Diagnostics) -> Option<f64> {
        match self.take(&["gate"]).map(|a| &a.value) {
            None => None,
            Some(ArgValue::Number(v, _)) if *v > 0.0 && v.is_finite() => Some(*v),
            Some(ArgValue::Name(n)) if n.text == "off" => Some(f64::INFINITY),
            Some(other) => {
                diag.error(
                    other.span(),
                    "`gate` is a threshold on the normalised innovation squared, a positive \
                     number (a chi-square quantile: 10.83 rejects one in a thousand \
                     consistent scalar measurements), or `off` to set it at run time",
                );
                None
            }
        }
    }

    /// `name = GatedEkf`: the generated type's name, or `default`. An UpperCamelCase
    /// identifier that names none of the module's other items.
    fn type_name(&mut self, default: &str, diag: &mut Diagnostics) -> String {
        match self.take(&["name"]).map(|a| &a.value) {
            None => default.to_owned(),
            Some(ArgValue::Name(n)) if n.text == default => default.to_owned(),
            Some(ArgValue::Name(n)) if is_type_name(&n.text) && !generated_type(&n.text) => {
                n.text.clone()
            }
            Some(ArgValue::Name(n)) if generated_type(&n.text) => {
                diag.error(
                    n.span,
                    format!(
                        "`{}` is already an item of the generated module: choose another \
                         type name",
                        n.text
                    ),
                );
                default.to_owned()
            }
            Some(other) => {
                diag.error(
                    other.span(),
                    "`name` is the generated type's name, in UpperCamelCase: `name = GatedEkf`",
                );
                default.to_owned()
            }
        }
    }

    pub(crate) fn optional_number(
        &mut self,
        name: &str,
        diag: &mut Diagnostics,
    ) -> Option<(f64, Span)> {
        match self.take(&[name]).map(|a| &a.value) {
            None => None,
            Some(ArgValue::Number(v, span)) => Some((*v, *span)),
            Some(other) => {
                diag.error(other.span(), format!("`{name}` takes a number"));
                None
            }
        }
    }

    pub(crate) fn names(&mut self, names: &[&str], diag: &mut Diagnostics) -> Vec<Name> {
        match self.take(names).map(|a| &a.value) {
            None => Vec::new(),
            Some(ArgValue::Name(n)) => vec![n.clone()],
            Some(ArgValue::Names(list, _)) => list.clone(),
            Some(ArgValue::Number(_, span)) => {
                diag.error(
                    *span,
                    format!("`{}` takes a name or a list of names", names[0]),
                );
                Vec::new()
            }
        }
    }

    /// `process_noise = diagonal` or `full` (the default).
    fn process_noise(&mut self, diag: &mut Diagnostics) -> bool {
        match self.take(&["process_noise"]).map(|a| &a.value) {
            None => false,
            Some(ArgValue::Name(n)) if n.text == "diagonal" => true,
            Some(ArgValue::Name(n)) if n.text == "full" => false,
            Some(other) => {
                diag.error(
                    other.span(),
                    "`process_noise` is `diagonal` (only the variances) or `full` (a symmetric matrix)",
                );
                false
            }
        }
    }

    fn report_unused(&self, diag: &mut Diagnostics) {
        for (arg, used) in self.item.args.iter().zip(&self.used) {
            if !used {
                diag.error(
                    arg.name.span,
                    format!(
                        "`{}` takes no argument `{}`",
                        self.item.name.text, arg.name.text
                    ),
                );
            }
        }
    }
}
