//! Reference tracking of outputs (`tracked_outputs = [y, ..]`): `set_output_reference`
//! turns the outputs' reference `y_ref` into the state and input reference the MPC
//! regulates to, the steady state `(x_s, u_s)` that holds the outputs there:
//!
//! ```text
//! e(x_s, u_s) = 0,   C x_s = y_ref
//! ```
//!
//! `e` the regulated states' equilibrium residual (`f(x, u) - x` for discrete dynamics,
//! `dx/dt` for continuous ones), `C` the tracked outputs' rows over the regulated states.
//! With dynamics affine in the regulated states and the inputs (constant coefficients),
//! the equations are linear, `E z = (-e(0, 0), y_ref)`, and solved when the model is
//! compiled: the least-norm `z = E^+ (..)` (Moore-Penrose), so `x_s` and `u_s` are
//! literals times `y_ref` plus a literal offset, straight-line. Every `y_ref` must be
//! held by some steady state (the right-hand sides' columns leave `E`'s rank as it is);
//! when the steady states are many (more inputs than outputs, a free yaw), the least-norm
//! one is taken.

use super::affine::affine_at_points;
use super::limits::{output_rows, outputs_named};
use super::spec::{MpcSpec, Target};
use crate::diagnostics::Diagnostics;
use crate::emit::code::all_is_finite;
use crate::emit::lower::literal;
use crate::emit::names::ident;
use crate::generators::options::{Args, Context};
use crate::model::{Model, Scalar};
use crate::numerics::matrix::Mat;
use crate::numerics::svd::{pinv, rank};
use crate::symbolic::{ModelGraph, NodeId};
use proc_macro2::{Ident, Literal, Span, TokenStream};
use quote::quote;

/// The outputs named by `tracked_outputs`, with where each was named.
pub fn tracked(args: &mut Args, cx: &Context, diag: &mut Diagnostics) -> Vec<(usize, Span)> {
    let names = args.names(&["tracked_outputs"], diag);
    let mut tracked: Vec<(usize, Span)> = Vec::new();
    for (output, span) in outputs_named(&names, cx, diag) {
        if tracked.iter().any(|&(t, _)| t == output) {
            let name = &cx.decl.outputs[output].name.text;
            diag.error(span, format!("`{name}` is tracked twice: name it once"));
        } else {
            tracked.push((output, span));
        }
    }
    tracked
}

/// The steady state of `spec.tracked`, or errors under their names: an output that is
/// not linear in the regulated states, dynamics that are not affine in them and the
/// inputs, or outputs that no steady state holds at every reference.
pub fn design(model: &Model, mg: &ModelGraph, spec: &MpcSpec) -> syn::Result<Option<Target>> {
    if spec.tracked.is_empty() {
        return Ok(None);
    }
    let mut mg = mg.clone();
    let why = (
        "is tracked through a steady state",
        "track the states it reads with `set_reference`, or declare a linear output",
    );
    let c = output_rows(model, &mut mg, (&spec.tracked, &spec.states), why)?;
    let first = spec.tracked[0].1;
    let Some((e, offset)) = affine_residual(model, &mut mg, spec) else {
        return Err(syn::Error::new(
            first,
            "`tracked_outputs` holds the outputs at a steady state computed when the model \
             is compiled: the regulated states' dynamics must be affine in them and the \
             MPC's inputs, with constant coefficients (no branch, no other state or input; \
             track the states with `set_reference` otherwise)",
        ));
    };
    let (ns, nu) = (spec.states.len(), spec.inputs.len());
    let mut rows = e;
    rows.extend(c.iter().map(|row| {
        let mut row = row.clone();
        row.resize(ns + nu, 0.0);
        row
    }));
    steady_state(&Mat::from_rows(&rows), &offset, (ns, nu))
        .map(Some)
        .map_err(|message| syn::Error::new(first, message))
}

/// The least-norm solution of `E z = (-offset, y_ref)` as affine maps of `y_ref`, or why
/// there is none: `E`'s rows the regulated states' equilibrium residual, then the tracked
/// outputs'; solvable for every `y_ref` when appending the right-hand sides' columns
/// (`-offset` and each output's unit) leaves `E`'s rank as it is.
fn steady_state(
    equations: &Mat,
    offset: &[f64],
    (ns, nu): (usize, usize),
) -> Result<Target, &'static str> {
    let ny = equations.rows() - ns;
    let mut augmented = equations.to_rows();
    for (i, row) in augmented.iter_mut().enumerate() {
        row.push(if i < ns { -offset[i] } else { 0.0 });
        row.extend((0..ny).map(|j| if i == ns + j { 1.0 } else { 0.0 }));
    }
    if rank(&Mat::from_rows(&augmented)) > rank(equations) {
        return Err(
            "no steady state holds these outputs at every reference (the equations \
             `x = f(x, u)`, `y = y_ref` have no solution for some `y_ref`): track fewer \
             outputs, or outputs the inputs can hold apart",
        );
    }
    let inverse = pinv(equations);
    let solution = |i: usize| -> (Vec<f64>, f64) {
        let per_output = (0..ny).map(|j| inverse[(i, ns + j)]).collect();
        let at_zero = (0..ns).map(|k| -inverse[(i, k)] * offset[k]).sum();
        (per_output, at_zero)
    };
    let (x, x_offset): (Vec<_>, Vec<_>) = (0..ns).map(solution).unzip();
    let (u, u_offset): (Vec<_>, Vec<_>) = (ns..ns + nu).map(solution).unzip();
    let huge = |v: &f64| v.is_nan() || v.abs() >= f64::from(f32::MAX) / 1e6;
    let values = x
        .iter()
        .chain(&u)
        .flatten()
        .chain(&x_offset)
        .chain(&u_offset);
    if values.into_iter().any(huge) {
        return Err(
            "the steady state that holds these outputs is too large to be computed \
             in the model's scalar types (a coefficient beyond 1e32): track outputs the \
             inputs hold more firmly, or scale the model",
        );
    }
    Ok(Target {
        x: x.into_iter().map(snapped).collect(),
        x_offset: snapped(x_offset),
        u: u.into_iter().map(snapped).collect(),
        u_offset: snapped(u_offset),
    })
}

/// `values` with those within rounding of zero (relative to the largest) made zero, so
/// that the generated reference never multiplies by them.
fn snapped(values: Vec<f64>) -> Vec<f64> {
    let largest = values.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    values
        .into_iter()
        .map(|v| if v.abs() <= 1e-12 * largest { 0.0 } else { v })
        .collect()
}

/// The regulated states' equilibrium residual as `E = [e_x e_u]` (rows per regulated
/// state, columns the regulated states then the inputs) and `e(0, 0)`; `None` when a
/// coefficient is not constant, another state, input or the time enters, or a row is
/// not the affine map its coefficients define (a branch).
fn affine_residual(
    model: &Model,
    mg: &mut ModelGraph,
    spec: &MpcSpec,
) -> Option<(Vec<Vec<f64>>, Vec<f64>)> {
    let continuous = model.dynamics.discretisation.is_continuous();
    let residual: Vec<NodeId> = if continuous {
        let (t, x) = (mg.t, mg.x.clone());
        mg.derivative(model, t, &x)
    } else {
        let f = mg.f.clone();
        f.iter()
            .zip(&mg.x.clone())
            .map(|(&next, &x)| mg.graph.sub(next, x))
            .collect()
    };
    let rows: Vec<NodeId> = spec.states.iter().map(|&i| residual[i]).collect();
    let mut wrt: Vec<NodeId> = mg.x.iter().chain(&mg.u).copied().collect();
    wrt.push(mg.t);
    let jacobian = mg.jacobian(&rows, &wrt);
    let nx = mg.x.len();
    let kept: Vec<usize> = spec
        .states
        .iter()
        .copied()
        .chain(spec.inputs.iter().map(|&i| nx + i))
        .collect();
    let kept_vars: Vec<NodeId> = kept.iter().map(|&i| wrt[i]).collect();
    let mut e = Vec::new();
    let mut offset = Vec::new();
    for (&root, row) in rows.iter().zip(&jacobian) {
        let row: Vec<f64> = row
            .iter()
            .map(|&d| mg.graph.constant_value(d))
            .collect::<Option<_>>()?;
        let others = (0..wrt.len()).filter(|i| !kept.contains(i));
        if others.into_iter().any(|i| row[i] != 0.0) {
            return None;
        }
        let coefficients: Vec<f64> = kept.iter().map(|&i| row[i]).collect();
        let at_zero = mg.graph.eval(root, &|_| 0.0);
        if !(at_zero.is_finite() && affine_at_points(mg, root, &kept_vars, &coefficients, at_zero))
        {
            return None;
        }
        e.push(coefficients);
        offset.push(at_zero);
    }
    Some((e, offset))
}

/// `fn set_output_reference`, when the MPC tracks outputs: `x_ref` and `u_ref` from
/// `y_ref` by the steady state.
pub fn set_output_reference(model: &Model, spec: &MpcSpec, scalar: Scalar) -> TokenStream {
    let Some(target) = &spec.target else {
        return TokenStream::new();
    };
    let ty = ident(scalar.type_name());
    let names: Vec<String> = spec
        .tracked
        .iter()
        .map(|&(o, _)| model.outputs[o].name.clone())
        .collect();
    let references: Vec<_> = names.iter().map(|n| ident(&format!("{n}_ref"))).collect();
    let ny = Literal::usize_unsuffixed(names.len());
    let finite = all_is_finite(&references);
    let entry = |c: &[f64], offset: f64| affine(c, offset, &references, scalar);
    let x_ref = target
        .x
        .iter()
        .zip(&target.x_offset)
        .map(|(c, &o)| entry(c, o));
    let u_ref = target
        .u
        .iter()
        .zip(&target.u_offset)
        .map(|(c, &o)| entry(c, o));
    let listed = names
        .iter()
        .map(|n| format!("`{n}`"))
        .collect::<Vec<_>>()
        .join(", ");
    let doc = format!(
        " Tracks {listed} at `y_ref`: sets the reference (as `set_reference`) \
         to the steady state of the dynamics that holds them there (the least-norm one \
         when there are several), computed when the model was compiled: `x_ref` and \
         `u_ref` affine in `y_ref`. Rejects non-finite values, and a steady state that \
         is not finite in the scalar, leaving the reference as it was."
    );
    quote! {
        #[doc = #doc]
        pub fn set_output_reference(&mut self, y_ref: &[#ty; #ny]) -> Status {
            let [#(#references),*] = *y_ref;
            let finite = #finite;
            if !finite {
                return Status::RejectedInput;
            }
            // `set_reference` refuses a steady state too large for the scalar.
            self.set_reference(&[#(#x_ref),*], &[#(#u_ref),*])
        }
    }
}

/// `sum_j c_j y_j + offset`, its zero terms left out (a literal zero when all are), a
/// negative coefficient's term subtracted.
fn affine(coefficients: &[f64], offset: f64, y: &[Ident], scalar: Scalar) -> TokenStream {
    let mut terms: Vec<(bool, TokenStream)> = coefficients
        .iter()
        .zip(y)
        .filter(|(&c, _)| c != 0.0)
        .map(|(&c, y)| {
            let size = c.abs();
            let term = if size == 1.0 {
                quote! { #y }
            } else {
                let size = literal(size, scalar);
                quote! { #size * #y }
            };
            (c < 0.0, term)
        })
        .collect();
    if offset != 0.0 || terms.is_empty() {
        terms.push((offset < 0.0, literal(offset.abs(), scalar)));
    }
    let mut sum = TokenStream::new();
    for (i, (negative, term)) in terms.into_iter().enumerate() {
        sum.extend(match (i, negative) {
            (0, false) => term,
            (0, true) => quote! { -#term },
            (_, false) => quote! { + #term },
            (_, true) => quote! { - #term },
        });
    }
    sum
}
