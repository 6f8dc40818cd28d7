//! Resolves a [`ModelDecl`] into the model IR, collecting every mistake on the way: the
//! model-level checks (names, constants, symbols, outputs, dynamics) here and in the
//! modules below; each generator's options and requirements through the registry
//! (`generate`).

mod dynamics;
mod expr;
mod expr_algebra;
mod generate;
mod geometry_calls;
mod interval;
mod names;
mod sensors;
mod typed;
mod unused;

use crate::ast::{ModelDecl, SymbolKind};
use crate::diagnostics::{Diagnostics, Warning};
use crate::generators::Generator;
use crate::model::{Constant, Expr, Group, GroupRole, Model, Output, Scalar, Symbol, Type, Value};
use crate::scope::{Binding, Scope};
use dynamics::{check_dynamics, check_known_substeps};
use expr::{resolve, resolve_value, Reader};
use generate::check_generate;
use names::{
    check_case_collisions, check_identifier, check_name_allowed, declare, duplicate_error,
};
use proc_macro2::Span;
use sensors::check_sensors;

/// A checked model and the generators it asks for, with their options checked.
#[derive(Debug)]
pub struct Checked {
    /// The model IR.
    pub model: Model,
    /// The generators, in the order their code appears in the generated module.
    pub generators: Vec<Box<dyn Generator>>,
    /// Each generator's cycle budget, if it gives one (`max_cycles = ..`).
    pub budgets: Vec<Option<crate::generators::Budget>>,
    /// Declarations nothing reads (see `unused`).
    pub warnings: Vec<Warning>,
}

impl Checked {
    /// The options of the first generator whose options are a `T` (tests read them).
    pub fn options<T: 'static>(&self) -> Option<&T> {
        self.generators
            .iter()
            .find_map(|g| g.as_any().downcast_ref::<T>())
    }
}

/// Checks a declaration and resolves it into a [`Model`] and its generators, reporting
/// every error found together with those the front end already recorded in `diag`.
pub fn check(decl: &ModelDecl, mut diag: Diagnostics) -> syn::Result<Checked> {
    let mut scope = Scope::new(decl);
    check_identifier(&decl.name, &mut diag);
    check_case_collisions(decl, &mut diag);
    let scalars = check_scalars(decl, &mut diag);
    scope.scalars = scalars.clone();
    let constants = check_constants(decl, &mut scope, &mut diag);
    let mut symbols = check_symbols(decl, &mut scope, &mut diag);
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
            let states = (&symbols.states[..], &symbols.state_spans[..]);
            check_dynamics(block, &mut scope, states, &mut locals, &mut diag)
        }
    };
    // After the dynamics: an output may read their intermediates.
    let (outputs, output_entries) =
        check_outputs(decl, &scope, &mut locals, &mut symbols.groups, &mut diag);
    let sensors = check_sensors(decl, &output_entries, &mut diag);
    check_known_substeps(decl, &mut diag);
    let generators = check_generate(decl, &scope, &mut diag);
    let Some(dynamics) = dynamics else {
        // `check_dynamics` only returns `None` after recording an error.
        debug_assert!(diag.has_errors());
        return diag.finish(()).and_then(|()| {
            Err(syn::Error::new(
                decl.span,
                "the model has no valid dynamics",
            ))
        });
    };
    let model = Model {
        docs: decl.docs.clone(),
        vis: decl.vis.clone(),
        name: decl.name.text.clone(),
        scalars,
        constants,
        states: symbols.states,
        params: symbols.params,
        inputs: symbols.inputs,
        known: symbols.known,
        outputs,
        sensors,
        dynamics,
        locals,
        groups: symbols.groups,
    };
    interval::check_interval_use(decl, &model, &mut diag);
    let (generators, budgets) = generators.into_iter().unzip();
    diag.finish(Checked {
        model,
        generators,
        budgets,
        warnings: unused::unused_declarations(decl),
    })
}

/// The declared symbols by kind, in order, a vector or rotation as its entries.
struct Symbols {
    states: Vec<Symbol>,
    state_spans: Vec<Span>,
    params: Vec<Symbol>,
    inputs: Vec<Symbol>,
    known: Vec<Symbol>,
    /// The vectors and rotations among them (and, once checked, among the outputs).
    groups: Vec<Group>,
}

/// Where a symbol of one kind goes: its list, how it is bound and read, its group role.
type SymbolList<'a> = (
    &'a mut Vec<Symbol>,
    fn(usize) -> Binding,
    GroupRole,
    fn(usize) -> Expr,
);

/// Declares the states, parameters, inputs and run-time constants; a model needs a state.
fn check_symbols(decl: &ModelDecl, scope: &mut Scope, diag: &mut Diagnostics) -> Symbols {
    let mut s = Symbols {
        states: Vec::new(),
        state_spans: Vec::new(),
        params: Vec::new(),
        inputs: Vec::new(),
        known: Vec::new(),
        groups: Vec::new(),
    };
    for sym in &decl.symbols {
        let ty = symbol_type(sym, diag);
        let (list, binding, role, read): SymbolList = match sym.kind {
            SymbolKind::State => (&mut s.states, Binding::State, GroupRole::State, Expr::State),
            SymbolKind::Param => (&mut s.params, Binding::Param, GroupRole::Param, Expr::Param),
            SymbolKind::Input => (&mut s.inputs, Binding::Input, GroupRole::Input, Expr::Input),
            SymbolKind::Known => (&mut s.known, Binding::Known, GroupRole::Known, Expr::Known),
        };
        let first = list.len();
        for name in entry_names(&sym.name.text, ty) {
            list.push(Symbol {
                docs: sym.docs.clone(),
                name,
            });
            if sym.kind == SymbolKind::State {
                s.state_spans.push(sym.name.span);
            }
        }
        if ty == Type::Scalar {
            declare(scope, &sym.name, binding(first), diag);
            continue;
        }
        check_entry_names(&sym.name, ty, scope, diag);
        let entries: Vec<Expr> = (first..first + ty.entry_count()).map(read).collect();
        scope.typed.push(typed_value(ty, entries));
        declare(
            scope,
            &sym.name,
            Binding::Typed(scope.typed.len() - 1),
            diag,
        );
        s.groups.push(Group {
            docs: sym.docs.clone(),
            name: sym.name.text.clone(),
            ty,
            role,
            first,
        });
    }
    scope.state_len = s.states.len();
    if s.states.is_empty() {
        diag.error(
            decl.name.span,
            "the model declares no state: add a line such as `state x1, x2;`",
        );
    }
    s
}

/// The type written after a symbol's name; a rotation known at run time is refused (a
/// known value is a number or a vector).
fn symbol_type(sym: &crate::ast::SymbolDecl, diag: &mut Diagnostics) -> Type {
    let Some(written) = &sym.ty else {
        return Type::Scalar;
    };
    match typed::written_type(written) {
        Ok(Type::Rot3) if sym.kind == SymbolKind::Known => {
            diag.error(
                written.span,
                "a rotation is not `known`: declare it as an `input`, given each sample",
            );
            Type::Rot3
        }
        Ok(ty) => ty,
        Err(message) => {
            diag.error(written.span, message);
            Type::Scalar
        }
    }
}

/// The names of the entries a symbol of type `ty` takes: its own for a number, `v_x`,
/// `v_y`, `v_z` for a vector and `q_x` .. `q_w` for a rotation.
fn entry_names(name: &str, ty: Type) -> Vec<String> {
    match ty {
        Type::Scalar => vec![name.to_owned()],
        _ => ty.entries().iter().map(|e| format!("{name}_{e}")).collect(),
    }
}

/// A typed value of the entries `entries`.
fn typed_value(ty: Type, entries: Vec<Expr>) -> Value {
    match (ty, <[Expr; 3]>::try_from(entries.clone())) {
        (Type::Vec3, Ok(v)) => Value::Vec3(v),
        _ => match <[Expr; 4]>::try_from(entries) {
            Ok(q) => Value::Rot3 { q, inverted: false },
            Err(mut entries) => Value::Scalar(entries.swap_remove(0)),
        },
    }
}

/// An entry's name (`v_x`) names it in the generated code (`X_NAMES`, `index::V_X`): no
/// other name of the model may be the same.
fn check_entry_names(name: &crate::ast::Name, ty: Type, scope: &Scope, diag: &mut Diagnostics) {
    for entry in entry_names(&name.text, ty) {
        if scope.contains_key(&entry) || scope.declared.contains_key(&entry) {
            diag.error(
                name.span,
                format!(
                    "`{entry}` names an entry of `{0}` in the generated code (`index::{1}`), \
                     and the model declares `{entry}` too: rename one",
                    name.text,
                    entry.to_uppercase()
                ),
            );
        }
    }
}

/// Resolves the outputs `y = h(x, u)`, which may read the intermediates of the dynamics
/// (`locals`): each a function of the time, states, parameters and inputs, evaluated where
/// the output is. Each output needs a name of its own among the constants, symbols and
/// outputs (an intermediate's name is a temporary's: `output speed = speed;` reads one).
/// A vector output is three outputs, its entries (`mag_x`, ..), recorded in `groups`.
/// Returns the outputs and, for each declared one, the positions of its entries.
fn check_outputs(
    decl: &ModelDecl,
    scope: &Scope,
    locals: &mut Vec<crate::model::Local>,
    groups: &mut Vec<Group>,
    diag: &mut Diagnostics,
) -> (Vec<Output>, Vec<std::ops::Range<usize>>) {
    let mut outputs = Vec::new();
    let mut entries = Vec::new();
    let mut output_names = std::collections::HashSet::new();
    for out in &decl.outputs {
        let taken = match scope.get(&out.name.text) {
            Some((Binding::Local(_), _)) | None => false,
            Some(_) => true,
        };
        if output_names.contains(out.name.text.as_str()) || taken {
            duplicate_error(diag, &out.name);
        } else {
            check_name_allowed(&out.name, false, diag);
            output_names.insert(out.name.text.as_str());
        }
        let context = Reader::Output(&out.name.text);
        let first = outputs.len();
        let value = resolve_value(&out.expr, scope, Some(&mut *locals), context, diag);
        let measured = match value {
            Some(Value::Scalar(e)) => vec![e],
            Some(Value::Vec3(v)) => {
                check_entry_names(&out.name, Type::Vec3, scope, diag);
                groups.push(Group {
                    docs: out.docs.clone(),
                    name: out.name.text.clone(),
                    ty: Type::Vec3,
                    role: GroupRole::Output,
                    first,
                });
                v.to_vec()
            }
            Some(Value::Rot3 { .. }) => {
                diag.error(out.expr.span, ROTATION_OUTPUT);
                Vec::new()
            }
            None => Vec::new(),
        };
        let ty = if measured.len() == 3 {
            Type::Vec3
        } else {
            Type::Scalar
        };
        for (name, expr) in entry_names(&out.name.text, ty).into_iter().zip(measured) {
            outputs.push(Output {
                docs: out.docs.clone(),
                name,
                expr,
            });
        }
        entries.push(first..outputs.len());
    }
    (outputs, entries)
}

/// Why a rotation is not an output.
const ROTATION_OUTPUT: &str = "an output is a number or a vector: measure a vector the \
     rotation turns, `q.inverse() * vec3(0.0, 0.0, 1.0)`, or its rotation vector, `log(q)`";

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
    let mut constants: Vec<Constant> = Vec::new();
    for c in &decl.constants {
        let context = Reader::Constant(&c.name.text);
        let reads_interval = |expr: &Expr| {
            expr.any(
                &|e| matches!(e, Expr::Const(j) if constants.get(*j).is_some_and(|c| c.interval)),
            )
        };
        let value = resolve(&c.value, scope, None, context, diag).and_then(|expr| {
            if reads_interval(&expr) {
                diag.error(c.value.span, INTERVAL_IN_A_CONSTANT);
                return None;
            }
            let value = expr.fold(&|i| scope.const_values.get(i).copied());
            if value.is_none() {
                diag.error(
                    c.value.span,
                    format!("{context} must be computed from literals and earlier constants only"),
                );
            }
            value
        });
        let value =
            value.filter(|&v| c.interval.is_none() || check_interval(c, v, &constants, diag));
        constants.push(Constant {
            docs: c.docs.clone(),
            name: c.name.text.clone(),
            value: value.unwrap_or(0.0),
            interval: c.interval.is_some(),
        });
        scope.const_values.push(value.unwrap_or(0.0));
        let fresh = !scope.contains_key(&c.name.text) && !scope.failed.contains(&c.name.text);
        declare(scope, &c.name, Binding::Const(constants.len() - 1), diag);
        // Its error is reported: what reads it reports none of its own (a stand-in
        // value would make `1.0 / K` a division by zero).
        if value.is_none() && fresh {
            scope.failed.insert(c.name.text.clone());
        }
    }
    constants
}

/// What a constant that reads the sample interval is told.
const INTERVAL_IN_A_CONSTANT: &str = "a constant is fixed, and the sample interval is given to \
     each prediction at run time: write the expression where it is used, in `dynamics`";

/// The sample interval `c` of nominal value `value`: one per model, positive. Whether it
/// holds.
fn check_interval(
    c: &crate::ast::ConstDecl,
    value: f64,
    earlier: &[Constant],
    diag: &mut Diagnostics,
) -> bool {
    if let Some(first) = earlier.iter().find(|e| e.interval) {
        diag.error(
            c.name.span,
            format!(
                "the sample interval is `{}` already: a model has one, given to each prediction",
                first.name
            ),
        );
        return false;
    }
    if !(value > 0.0 && value.is_finite()) {
        diag.error(
            c.value.span,
            format!(
                "the sample interval's nominal value is positive and finite, in seconds, not \
                 {value}: `0.004` for 4 ms"
            ),
        );
        return false;
    }
    true
}
