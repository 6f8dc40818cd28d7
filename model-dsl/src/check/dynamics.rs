//! The dynamics block: one equation per state, of the block's kind (`x = ..` for discrete
//! dynamics, `der(x) = ..` for continuous ones), named intermediates, and for continuous
//! dynamics the discretisation (integration rule, step and sub-steps).

use super::expr::{article, resolve, resolve_value, Reader};
use super::expr_algebra::ExprAlgebra;
use super::names::{declare, duplicate_error};
use super::typed::materialise;
use crate::ast::{DynamicsDecl, DynamicsKind, ModelDecl, Name, Statement, SurfaceExpr, SymbolKind};
use crate::diagnostics::Diagnostics;
use crate::geometry;
use crate::model::{
    Discretisation, Dynamics, Expr, Local, Method, Symbol, Type, Value, UNROLLED_SUBSTEPS_MAX,
};
use crate::scope::{Binding, Scope};
use proc_macro2::Span;

/// Resolves the dynamics of the states `(states, where each was declared)`; `None` after
/// recording an error.
pub(super) fn check_dynamics(
    block: &DynamicsDecl,
    scope: &mut Scope,
    (states, state_spans): (&[Symbol], &[Span]),
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
            Statement::Let { name, value } => check_let(name, value, scope, locals, diag),
            Statement::Equation {
                target,
                derivative,
                value,
            } => {
                let context = Reader::Equation(&target.text);
                let resolved = resolve_value(value, scope, Some(&mut *locals), context, diag);
                let Some((ty, entries)) = equation_target(target, scope, diag) else {
                    continue;
                };
                check_equation_kind(target, *derivative, continuous, diag);
                let written = (target, value, *derivative);
                let exprs = equation_entries(written, ty, resolved, locals, diag);
                for (&index, expr) in entries.iter().zip(exprs) {
                    if rhs[index].is_some() {
                        diag.error(
                            target.span,
                            format!(
                                "state `{}` has a second equation: each state takes exactly one",
                                target.text
                            ),
                        );
                        break;
                    }
                    rhs[index] = Some(expr);
                }
            }
        }
    }
    let complete = complete_equations(rhs, (states, state_spans), continuous, diag);
    let discretisation = discretisation?;
    let renormalised = rotation_states(scope);
    (complete.len() == states.len()).then_some(Dynamics {
        discretisation,
        rhs: complete,
        renormalised,
    })
}

/// `let name = value;`: an intermediate for the lines below (and the outputs). One whose
/// value has an error is marked failed (unless the name is taken, which `declare`
/// reports), so that what reads it reports nothing more.
fn check_let(
    name: &Name,
    value: &SurfaceExpr,
    scope: &mut Scope,
    locals: &mut Vec<Local>,
    diag: &mut Diagnostics,
) {
    let context = Reader::Intermediate(&name.text);
    match resolve_value(value, scope, Some(&mut *locals), context, diag) {
        Some(Value::Scalar(expr)) => {
            locals.push(Local {
                name: name.text.clone(),
                expr,
            });
            declare(scope, name, Binding::Local(locals.len() - 1), diag);
        }
        Some(typed) => {
            // Each entry computed once, named after the intermediate (`w_x`).
            let mut alg = ExprAlgebra {
                locals: Some(locals),
            };
            let named = match typed {
                Value::Vec3(v) => Value::Vec3(geometry::share3(&mut alg, v, &name.text)),
                Value::Rot3 { q, inverted } => Value::Rot3 {
                    q: geometry::share4(&mut alg, q, &name.text),
                    inverted,
                },
                scalar => scalar,
            };
            scope.typed.push(named);
            declare(scope, name, Binding::Typed(scope.typed.len() - 1), diag);
        }
        None if scope.contains_key(&name.text) || scope.failed.contains(&name.text) => {
            duplicate_error(diag, name);
        }
        None => {
            scope.failed.insert(name.text.clone());
        }
    }
}

/// The state an equation's left-hand side names, its type and the positions of its
/// entries among the states, or an error saying what it is instead.
fn equation_target(
    target: &Name,
    scope: &Scope,
    diag: &mut Diagnostics,
) -> Option<(Type, Vec<usize>)> {
    let name = &target.text;
    let message = match scope.get(name) {
        Some((Binding::State(i), _)) => return Some((Type::Scalar, vec![*i])),
        Some((Binding::Typed(i), _)) => match typed_entries(scope.typed(*i)?) {
            (ty, Some(entries)) => return Some((ty, entries)),
            (_, None) => format!(
                "`{name}` is not a state: only states take dynamics (a vector intermediate \
                 is named with `let`)"
            ),
        },
        Some((Binding::Param(_), _)) => format!(
            "`{name}` is a parameter: an unknown constant estimated as a random walk, so it \
             takes no dynamics; declare it with `state` if it evolves"
        ),
        Some((Binding::Input(_), _)) => {
            format!("`{name}` is an input: it is given each sample, not computed")
        }
        Some((Binding::Known(_), _)) => format!(
            "`{name}` is known at run time: it is given when the filter is made, not \
             computed; declare it with `state` if it evolves"
        ),
        Some((Binding::Const(_) | Binding::Local(_), _)) => {
            format!("`{name}` is not a state: only states take dynamics")
        }
        None => format!("unknown state `{name}`: declare it with `state {name};`"),
    };
    diag.error(target.span, message);
    None
}

/// The first entries of the rotation states, in order.
fn rotation_states(scope: &Scope) -> Vec<usize> {
    let mut firsts: Vec<usize> = scope
        .typed
        .iter()
        .filter_map(|value| match value {
            Value::Rot3 {
                q: [Expr::State(first), ..],
                ..
            } => Some(*first),
            _ => None,
        })
        .collect();
    firsts.sort_unstable();
    firsts.dedup();
    firsts
}

/// A typed name's type, and its entries' positions among the states if it is a state.
fn typed_entries(value: &Value) -> (Type, Option<Vec<usize>>) {
    let entries: Vec<&Expr> = match value {
        Value::Scalar(e) => vec![e],
        Value::Vec3(v) => v.iter().collect(),
        Value::Rot3 { q, .. } => q.iter().collect(),
    };
    let states = entries.into_iter().map(|e| match e {
        Expr::State(i) => Some(*i),
        _ => None,
    });
    (value.ty(), states.collect())
}

/// The right-hand sides of an equation's entries (each `None` after an error): its value
/// must have the target's type (a rotation's is renormalised by `f`, see
/// [`Dynamics::renormalised`]); a rotation state has no derivative (it is advanced on its
/// manifold).
fn equation_entries(
    (target, value, derivative): (&Name, &SurfaceExpr, bool),
    ty: Type,
    resolved: Option<Value>,
    locals: &mut Vec<Local>,
    diag: &mut Diagnostics,
) -> Vec<Option<Expr>> {
    let failed = vec![None; ty.entry_count()];
    let Some(resolved) = resolved else {
        return failed;
    };
    let name = &target.text;
    if ty == Type::Rot3 && derivative {
        diag.error(
            target.span,
            format!(
                "a rotation state is advanced on its manifold, not by a derivative: write \
                 `dynamics discrete {{ {name} = {name} * exp(omega * DT); }}`"
            ),
        );
        return failed;
    }
    let mut alg = ExprAlgebra {
        locals: Some(locals),
    };
    match (ty, resolved) {
        (Type::Scalar, Value::Scalar(e)) => vec![Some(e)],
        (Type::Vec3, Value::Vec3(v)) => v.map(Some).to_vec(),
        (Type::Rot3, rotation @ Value::Rot3 { .. }) => match materialise(&mut alg, rotation) {
            Some(q) => q.map(Some).to_vec(),
            None => failed,
        },
        (_, other) => {
            let next = match ty {
                Type::Rot3 => format!("a rotation, such as `{name} = {name} * exp(omega * DT)`"),
                Type::Vec3 => format!("a vector, such as `{name} = {name} + rate * DT`"),
                Type::Scalar => "a number: take a component (`v.x`) or a norm".to_owned(),
            };
            let what = article(ty);
            diag.error(
                value.span,
                format!(
                    "`{name}` is {what}, and this is {}: its next value is {next}",
                    article(other.ty())
                ),
            );
            failed
        }
    }
}

/// Continuous dynamics give derivatives, `der(x) = ..`; discrete ones the next sample.
fn check_equation_kind(target: &Name, derivative: bool, continuous: bool, diag: &mut Diagnostics) {
    if continuous && !derivative {
        diag.error(
            target.span,
            format!(
                "continuous dynamics give derivatives: write `der({}) = ...;`",
                target.text
            ),
        );
    } else if !continuous && derivative {
        diag.error(
            target.span,
            format!(
                "`der(..)` needs continuous dynamics: write `{} = ...;` for the next \
                 sample, or `dynamics continuous(euler, dt = TS)`",
                target.text
            ),
        );
    }
}

/// The right-hand sides in state order; a state without an equation is an error (once per
/// name: a second declaration is reported as declared twice).
fn complete_equations(
    rhs: Vec<Option<Option<Expr>>>,
    (states, state_spans): (&[Symbol], &[Span]),
    continuous: bool,
    diag: &mut Diagnostics,
) -> Vec<Expr> {
    let mut complete = Vec::with_capacity(states.len());
    // A state declared twice is reported as such; its second declaration needs no
    // equation of its own.
    let mut seen = std::collections::HashSet::new();
    for ((slot, state), span) in rhs.into_iter().zip(states).zip(state_spans) {
        let first = seen.insert(state.name.as_str());
        match slot {
            Some(Some(expr)) => complete.push(expr),
            Some(None) => {}
            None if !first => {}
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
    complete
}

/// How to write a discretisation, for the errors about a missing part.
const DISCRETISATION_HINT: &str = "write `dynamics continuous(euler, dt = TS)` or \
                                   `dynamics continuous(rk4, dt = TS, substeps = 2)`";

/// The discretisation of continuous dynamics: integration rule, step and sub-steps.
fn check_discretisation(
    span: Span,
    method: &Option<Name>,
    dt: &Option<SurfaceExpr>,
    substeps: &Option<(u64, Span)>,
    scope: &Scope,
    diag: &mut Diagnostics,
) -> Option<Discretisation> {
    let method = check_method(span, method, diag);
    let dt = match dt {
        None => {
            if method.is_some() {
                diag.error(
                    span,
                    format!("the discretisation needs a step `dt`: {DISCRETISATION_HINT}"),
                );
            }
            None
        }
        Some(expr) => check_step(expr, scope, diag),
    };
    let substeps = check_substeps(substeps, diag);
    Some(Discretisation::Continuous {
        method: method?,
        dt: dt?,
        substeps: substeps?,
    })
}

/// `euler` or `rk4`.
fn check_method(span: Span, method: &Option<Name>, diag: &mut Diagnostics) -> Option<Method> {
    let Some(name) = method else {
        diag.error(
            span,
            format!("continuous dynamics need a discretisation: {DISCRETISATION_HINT}"),
        );
        return None;
    };
    match name.text.as_str() {
        "euler" => Some(Method::Euler),
        "rk4" => Some(Method::Rk4),
        other => {
            diag.error(
                name.span,
                format!("unknown integration method `{other}`: use `euler` or `rk4`"),
            );
            None
        }
    }
}

/// The step `dt`: a constant expression, positive.
fn check_step(expr: &SurfaceExpr, scope: &Scope, diag: &mut Diagnostics) -> Option<Expr> {
    let e = resolve(expr, scope, None, Reader::Step, diag)?;
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
    // A step of zero would leave the state where it is, a negative one integrate
    // backwards.
    match e.fold(&|i| scope.const_value(i)) {
        Some(dt) if dt <= 0.0 || !dt.is_finite() => {
            diag.error(
                expr.span,
                format!("the step `dt`, a time in seconds, must be positive and finite, not {dt}"),
            );
            None
        }
        _ => Some(e),
    }
}

/// Sub-steps per sample: 1 unless given, at most [`crate::model::SUBSTEPS_MAX`].
fn check_substeps(substeps: &Option<(u64, Span)>, diag: &mut Diagnostics) -> Option<u32> {
    match substeps {
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
    }
}

/// Sub-steps past the unrolled limit run as a loop, which reads no run-time constant.
pub(super) fn check_known_substeps(decl: &ModelDecl, diag: &mut Diagnostics) {
    let Some(first) = decl.symbols.iter().find(|s| s.kind == SymbolKind::Known) else {
        return;
    };
    if let Some(DynamicsDecl {
        kind:
            DynamicsKind::Continuous {
                substeps: Some((n, span)),
                ..
            },
        ..
    }) = decl.dynamics.first()
    {
        if *n > u64::from(UNROLLED_SUBSTEPS_MAX) {
            diag.error(
                *span,
                format!(
                    "sub-steps past {UNROLLED_SUBSTEPS_MAX} run as a loop, which does not \
                     read `{}`, known at run time: use at most {UNROLLED_SUBSTEPS_MAX} \
                     sub-steps, or declare it with `const`",
                    first.name.text
                ),
            );
        }
    }
}
