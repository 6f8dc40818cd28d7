//! The MPC's limits besides the inputs' bounds, as the model asks for them:
//! `rate_limits = [u]` (the change of an input between moves), `state_limits = [x]` (a
//! regulated state over the horizon), `output_limits = [y]` (an output linear in the
//! regulated states), and `soft_limits = [..]`, those of them that are soft (an exact
//! penalty on their violation) rather than hard. Their values are set at run time.

use super::affine::affine_at_points;
use super::spec::MpcLimits;
use crate::ast::Name;
use crate::diagnostics::Diagnostics;
use crate::generators::options::{Args, Context};
use crate::model::Model;
use crate::symbolic::ModelGraph;
use proc_macro2::Span;
use std::collections::HashSet;

/// The limits named in `args`, for the regulated `states` and the computed `inputs`
/// (indices into the model's).
pub fn limits(
    args: &mut Args,
    cx: &Context,
    (states, inputs): (&[usize], &[usize]),
    diag: &mut Diagnostics,
) -> MpcLimits {
    let position = |list: &[usize], found: Option<Vec<usize>>| {
        found.and_then(|indices| list.iter().position(|i| indices.contains(i)))
    };
    let rate_names = args.names(&["rate_limits"], diag);
    let rates = listed(
        &rate_names,
        diag,
        &|n| position(inputs, cx.input_indices(n)),
        "an input the MPC computes (`inputs = [..]`)",
    );
    let state_names = args.names(&["state_limits"], diag);
    let limited_states = listed(
        &state_names,
        diag,
        &|n| position(states, cx.state_indices(n)),
        "a state the MPC regulates (`states = [..]`)",
    );
    let output_names = args.names(&["output_limits"], diag);
    let outputs = outputs_named(&output_names, cx, diag);
    let limited: Vec<&Name> = rate_names
        .iter()
        .chain(&state_names)
        .chain(&output_names)
        .collect();
    twice(&limited, diag);
    let soft_names = args.names(&["soft_limits"], diag);
    let mut soft = vec![false; limited.len()];
    for name in &soft_names {
        match limited.iter().position(|l| l.text == name.text) {
            Some(i) => soft[i] = true,
            None => diag.error(
                name.span,
                format!(
                    "`{}` has no limit to soften: list it in `rate_limits`, `state_limits` or \
                     `output_limits` too",
                    name.text
                ),
            ),
        }
    }
    twice(&soft_names.iter().collect::<Vec<_>>(), diag);
    MpcLimits {
        rates,
        states: limited_states,
        outputs,
        soft,
        output_rows: Vec::new(),
    }
}

/// The outputs `names` name (indices into the model's, with where each was named), each
/// name that is not an output reported.
pub fn outputs_named(names: &[Name], cx: &Context, diag: &mut Diagnostics) -> Vec<(usize, Span)> {
    let output_index = |n: &str| cx.decl.outputs.iter().position(|o| o.name.text == n);
    names
        .iter()
        .filter_map(|name| match output_index(&name.text) {
            Some(i) => Some((i, name.span)),
            None => {
                diag.error(
                    name.span,
                    format!("`{}` is not an output (`output`)", name.text),
                );
                None
            }
        })
        .collect()
}

/// The positions `position` finds for `names`, each name it finds none for reported as
/// not `what`.
fn listed(
    names: &[Name],
    diag: &mut Diagnostics,
    position: &dyn Fn(&str) -> Option<usize>,
    what: &str,
) -> Vec<usize> {
    names
        .iter()
        .filter_map(|name| {
            let found = position(&name.text);
            if found.is_none() {
                diag.error(name.span, format!("`{}` is not {what}", name.text));
            }
            found
        })
        .collect()
}

/// An error under each name listed a second time.
fn twice(names: &[&Name], diag: &mut Diagnostics) {
    let mut seen = HashSet::new();
    for name in names {
        if !seen.insert(name.text.as_str()) {
            diag.error(
                name.span,
                format!("`{}` is limited twice: name it once", name.text),
            );
        }
    }
}

/// Each output's row `C` over the regulated states (`y = C x`), or an error under its
/// name when it is not linear in them (an offset, an input, another state, or a nonlinear
/// term); `role` says why it must be (`"is limited over the horizon"`), `remedy` what to
/// write instead.
pub fn output_rows(
    model: &Model,
    mg: &mut ModelGraph,
    (outputs, states): (&[(usize, Span)], &[usize]),
    (role, remedy): (&str, &str),
) -> syn::Result<Vec<Vec<f64>>> {
    let mut rows = Vec::new();
    let mut errors: Option<syn::Error> = None;
    for &(output, span) in outputs {
        let h = mg.h[output];
        let wrt: Vec<_> = mg.x.iter().chain(&mg.u).copied().collect();
        let jacobian = mg.jacobian(&[h], &wrt).remove(0);
        let literal: Option<Vec<f64>> = jacobian
            .iter()
            .map(|&d| mg.graph.constant_value(d))
            .collect();
        let at_zero = mg.graph.eval(h, &|_| 0.0);
        let row = literal.filter(|row| {
            let others = (0..wrt.len()).filter(|i| !states.contains(i));
            at_zero == 0.0
                && others.into_iter().all(|i| row[i] == 0.0)
                && affine_at_points(mg, h, &wrt, row, 0.0)
        });
        let Some(row) = row else {
            let error = syn::Error::new(
                span,
                format!(
                    "`{}` {role}, so it must be linear in the regulated states (`y = C x`: no \
                     offset, input or other state): {remedy}",
                    model.outputs[output].name
                ),
            );
            match &mut errors {
                Some(errors) => errors.combine(error),
                None => errors = Some(error),
            }
            continue;
        };
        rows.push(states.iter().map(|&i| row[i]).collect());
    }
    errors.map_or(Ok(rows), Err)
}
