//! The options of the controllers, `lqr(..)` and `mpc(..)`: which physical states they
//! regulate with which inputs, horizons and iteration bounds.

use crate::ast::{ArgValue, DynamicsKind, GenerateDecl, ModelDecl, Name, SymbolKind};
use crate::check::{Args, Binding, Scope};
use crate::diagnostics::Diagnostics;
use crate::model::{LqrSpec, MpcDiscretisation, MpcSpec, MPC_UNKNOWNS_MAX, UNROLLED_SUBSTEPS_MAX};

/// `lqr(horizon = 50, states = [x1, x2], input = u)`.
pub fn lqr(item: &GenerateDecl, args: &mut Args, scope: &Scope, diag: &mut Diagnostics) -> LqrSpec {
    let horizon = whole(args, ("horizon", "steps"), 50, 10_000, diag);
    let (states, inputs) = regulated(item, args, scope, diag, "lqr(horizon = 50, ");
    LqrSpec {
        horizon,
        states,
        inputs,
    }
}

/// `mpc(horizon = 10, states = [q, qd], input = u, discretisation = zoh,
/// max_iterations = 20, riccati_iterations = 20)`.
pub fn mpc(
    decl: &ModelDecl,
    item: &GenerateDecl,
    args: &mut Args,
    scope: &Scope,
    diag: &mut Diagnostics,
) -> MpcSpec {
    let horizon = whole(args, ("horizon", "steps"), 10, 1000, diag);
    let (states, inputs) = regulated(item, args, scope, diag, "mpc(horizon = 10, ");
    let unknowns = u64::from(horizon) * inputs.len() as u64;
    if unknowns > u64::from(MPC_UNKNOWNS_MAX) {
        diag.error(
            item.name.span,
            format!(
                "the MPC optimises horizon x inputs = {unknowns} moves; its unrolled solve \
                 allows at most {MPC_UNKNOWNS_MAX}: shorten the horizon"
            ),
        );
    }
    let discretisation = discretisation(decl, args, diag);
    let max_iterations = whole(
        args,
        ("max_iterations", "iterations"),
        2 * unknowns.max(1) as u32,
        1000,
        diag,
    );
    let riccati_iterations = whole(args, ("riccati_iterations", "steps"), 20, 10_000, diag);
    MpcSpec {
        horizon,
        states,
        inputs,
        discretisation,
        max_iterations,
        riccati_iterations,
    }
}

/// `discretisation = zoh` (exact hold of the continuous linearisation; the default for
/// continuous dynamics and the only choice when their sub-steps run as a loop) or
/// `sample_step` (the Jacobians of the model's step `f`; the only choice for discrete
/// dynamics).
fn discretisation(decl: &ModelDecl, args: &mut Args, diag: &mut Diagnostics) -> MpcDiscretisation {
    let continuous = decl.dynamics.iter().find_map(|d| match &d.kind {
        DynamicsKind::Continuous { substeps, .. } => Some(
            substeps
                .as_ref()
                .is_some_and(|(n, _)| *n > u64::from(UNROLLED_SUBSTEPS_MAX)),
        ),
        DynamicsKind::Discrete => None,
    });
    let default = match continuous {
        Some(_) => MpcDiscretisation::ZeroOrderHold,
        None => MpcDiscretisation::SampleStep,
    };
    let Some(arg) = args.take(&["discretisation"]) else {
        return default;
    };
    let chosen = match &arg.value {
        ArgValue::Name(n) if n.text == "zoh" => MpcDiscretisation::ZeroOrderHold,
        ArgValue::Name(n) if n.text == "sample_step" => MpcDiscretisation::SampleStep,
        other => {
            diag.error(
                other.span(),
                "`discretisation` is `zoh` (the exact zero-order hold of the continuous \
                 dynamics linearised at the estimate) or `sample_step` (the Jacobians of the \
                 model's own sample step)",
            );
            return default;
        }
    };
    match (chosen, continuous) {
        (MpcDiscretisation::ZeroOrderHold, None) => diag.error(
            arg.value.span(),
            "`zoh` holds continuous dynamics over a sample; these are discrete: use \
             `discretisation = sample_step`, or leave it out",
        ),
        (MpcDiscretisation::SampleStep, Some(true)) => diag.error(
            arg.value.span(),
            format!(
                "the sample step runs more than {UNROLLED_SUBSTEPS_MAX} sub-steps as a loop \
                 and has no Jacobian: use `discretisation = zoh`"
            ),
        ),
        _ => {}
    }
    chosen
}

/// The whole number given as `name` (1 to `max`), or `default`.
fn whole(
    args: &mut Args,
    (name, unit): (&str, &str),
    default: u32,
    max: u32,
    diag: &mut Diagnostics,
) -> u32 {
    let (value, span) = args.number(name, f64::from(default), diag);
    if value.fract() != 0.0 || !(1.0..=f64::from(max)).contains(&value) {
        diag.error(
            span,
            format!("`{name}` is a whole number of {unit}, 1 to {max}"),
        );
        return default;
    }
    value as u32
}

/// The physical states a controller regulates and the inputs it computes, by index.
fn regulated(
    item: &GenerateDecl,
    args: &mut Args,
    scope: &Scope,
    diag: &mut Diagnostics,
    example: &str,
) -> (Vec<usize>, Vec<usize>) {
    let states = args.names(&["states", "state"], diag);
    let inputs = args.names(&["inputs", "input"], diag);
    let lookup = |names: Vec<Name>, want: SymbolKind, diag: &mut Diagnostics| -> Vec<usize> {
        names
            .iter()
            .filter_map(|name| match (scope.get(&name.text), want) {
                (Some((Binding::State(i), _)), SymbolKind::State) => Some(*i),
                (Some((Binding::Input(i), _)), SymbolKind::Input) => Some(*i),
                _ => {
                    let what = match want {
                        SymbolKind::State => "a physical state (`state`)",
                        _ => "an input (`input`)",
                    };
                    diag.error(name.span, format!("`{}` is not {what}", name.text));
                    None
                }
            })
            .collect()
    };
    let states = lookup(states, SymbolKind::State, diag);
    let inputs = lookup(inputs, SymbolKind::Input, diag);
    if states.is_empty() || inputs.is_empty() {
        diag.error(
            item.name.span,
            format!(
                "`{}` needs the states it regulates and the inputs it computes: \
                 `{example}states = [x1, x2], input = u)`",
                item.name.text
            ),
        );
    }
    (states, inputs)
}
