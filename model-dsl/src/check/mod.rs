//! Resolves a [`ModelDecl`] into the model IR, collecting every mistake on the way: the
//! model-level checks (names, constants, symbols, outputs, dynamics) here and in the
//! modules below; each generator's options and requirements through the registry
//! (`generate`).

mod dynamics;
mod expr;
mod generate;
mod names;
mod sensors;
mod unused;

use crate::ast::{ModelDecl, SymbolKind};
use crate::diagnostics::{Diagnostics, Warning};
use crate::generators::Generator;
use crate::model::{Constant, Model, Output, Scalar, Symbol};
use crate::scope::{Binding, Scope};
use dynamics::{check_dynamics, check_known_substeps};
use expr::{resolve, Reader};
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
    let symbols = check_symbols(decl, &mut scope, &mut diag);
    let sensors = check_sensors(decl, &mut diag);
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
    let outputs = check_outputs(decl, &scope, &locals, &mut diag);
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
    };
    let (generators, budgets) = generators.into_iter().unzip();
    diag.finish(Checked {
        model,
        generators,
        budgets,
        warnings: unused::unused_declarations(decl),
    })
}

/// The declared symbols by kind, in order.
struct Symbols {
    states: Vec<Symbol>,
    state_spans: Vec<Span>,
    params: Vec<Symbol>,
    inputs: Vec<Symbol>,
    known: Vec<Symbol>,
}

/// Declares the states, parameters, inputs and run-time constants; a model needs a state.
fn check_symbols(decl: &ModelDecl, scope: &mut Scope, diag: &mut Diagnostics) -> Symbols {
    let mut s = Symbols {
        states: Vec::new(),
        state_spans: Vec::new(),
        params: Vec::new(),
        inputs: Vec::new(),
        known: Vec::new(),
    };
    for sym in &decl.symbols {
        let symbol = Symbol {
            docs: sym.docs.clone(),
            name: sym.name.text.clone(),
        };
        let (list, binding): (&mut Vec<Symbol>, fn(usize) -> Binding) = match sym.kind {
            SymbolKind::State => {
                s.state_spans.push(sym.name.span);
                (&mut s.states, Binding::State)
            }
            SymbolKind::Param => (&mut s.params, Binding::Param),
            SymbolKind::Input => (&mut s.inputs, Binding::Input),
            SymbolKind::Known => (&mut s.known, Binding::Known),
        };
        list.push(symbol);
        let index = list.len() - 1;
        declare(scope, &sym.name, binding(index), diag);
    }
    if s.states.is_empty() {
        diag.error(
            decl.name.span,
            "the model declares no state: add a line such as `state x1, x2;`",
        );
    }
    s
}

/// Resolves the outputs `y = h(x, u)`, which may read the intermediates of the dynamics
/// (`locals`): each a function of the time, states, parameters and inputs, evaluated where
/// the output is. Each output needs a name of its own among the constants, symbols and
/// outputs (an intermediate's name is a temporary's: `output speed = speed;` reads one).
fn check_outputs(
    decl: &ModelDecl,
    scope: &Scope,
    locals: &[crate::model::Local],
    diag: &mut Diagnostics,
) -> Vec<Output> {
    let mut outputs = Vec::new();
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
        if let Some(expr) = resolve(&out.expr, scope, locals, context, diag) {
            outputs.push(Output {
                docs: out.docs.clone(),
                name: out.name.text.clone(),
                expr,
            });
        }
    }
    outputs
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
        let context = Reader::Constant(&c.name.text);
        let value = resolve(&c.value, scope, &[], context, diag).and_then(|expr| {
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
