//! The adaptive finite-horizon LQR (Alg. 3, eq. 19, with `R` inside the inverse): the
//! physical sub-model is the Jacobian of `f` with respect to the chosen states and inputs
//! at the current estimate; the backward Riccati recursion runs as a loop over the horizon
//! whose body is generated straight-line code.

use crate::emit::code::{
    destructure, guard_pivots, pack_upper, pivot_names, reject_non_finite, var_idents,
};
use crate::emit::filter::{model_names, packed_vars, time_param};
use crate::emit::lower::{literal, Lowered, Lowerer, OpCount};
use crate::emit::names::{ident, TempNamer};
use super::spec::LqrSpec;
use crate::model::{Model, Scalar};
use crate::symbolic::linalg::{
    ldl_inverse, matmul, packed_len, symmetric_from_packed, transpose, Matrix,
};
use crate::symbolic::riccati::riccati_step;
use crate::symbolic::{loop_invariant_operands, Graph, ModelGraph, Node, NodeId};
use proc_macro2::{Literal, TokenStream};
use quote::quote;

/// Generated LQR code and its cost.
pub struct LqrCode {
    /// The `Lqr` type and its methods.
    pub tokens: TokenStream,
    /// Arithmetic of one `solve`, the whole horizon included.
    pub solve_ops: OpCount,
}

/// The LQR of `model` in `scalar`.
pub fn emit_lqr(model: &Model, spec: &LqrSpec, mg: &ModelGraph, scalar: Scalar) -> LqrCode {
    let mut g = mg.clone();
    let (ns, nu) = (spec.states.len(), spec.inputs.len());
    let avoid = model_names(model);

    // The physical sub-model at the estimate: A = df_s/ds, B = df_s/du (Alg. 3).
    let rows: Vec<NodeId> = spec.states.iter().map(|&i| g.f[i]).collect();
    let states: Vec<NodeId> = spec.states.iter().map(|&i| g.x[i]).collect();
    let inputs: Vec<NodeId> = spec.inputs.iter().map(|&i| g.u[i]).collect();
    let a = g.jacobian(&rows, &states);
    let b = g.jacobian(&rows, &inputs);

    let graph = &mut g.graph;
    let p_vars = packed_vars(graph, "p", ns, &avoid);
    let q_vars = packed_vars(graph, "q", ns, &avoid);
    let r_vars = packed_vars(graph, "r", nu, &avoid);
    let p = symmetric_from_packed(&p_vars, ns);
    let q = symmetric_from_packed(&q_vars, ns);
    let r = symmetric_from_packed(&r_vars, nu);
    // eq. (19): K = (R + B'PB)^-1 B'PA; P = A'PA - A'PB K + Q.
    // eq. (19): K = (R + B'PB)^-1 B'PA; P = A'PA - A'PB K + Q.
    const WEIGHT: (&str, &str) = ("weight", "inv_weight");
    let step = riccati_step(graph, (&a, &b), &p, (&q, &r), |g, j| {
        g.var(&pivot_names(nu, j, WEIGHT, "").1)
    });
    let (pivots, reciprocals, k, p_next) = (step.pivots, step.reciprocals, step.gain, step.p_next);
    let k_flat: Vec<NodeId> = k.iter().flatten().copied().collect();

    // What the loop body computes; the rest of what it needs is hoisted before the loop.
    let loop_vars: Vec<NodeId> = p_vars.iter().chain(&reciprocals).copied().collect();
    let body_roots: Vec<NodeId> = k_flat
        .iter()
        .chain(&p_next)
        .chain(&pivots)
        .copied()
        .collect();
    let invariant = loop_invariant_operands(graph, &body_roots, &loop_vars);

    let mut all_roots = body_roots.clone();
    all_roots.extend(&invariant);
    let namer = TempNamer::new(avoid.iter().map(String::as_str));
    let mut lowerer = Lowerer::new(&g.graph, scalar, namer, &all_roots);
    for (row, name) in a.iter().zip(spec.states.iter()) {
        for (&entry, col) in row.iter().zip(&spec.states) {
            let name = format!("a_{}_{}", model.states[*name].name, model.states[*col].name);
            lowerer.prefer_name(entry, &name);
        }
    }
    for (row, state) in b.iter().zip(&spec.states) {
        for (&entry, input) in row.iter().zip(&spec.inputs) {
            let name = format!(
                "b_{}_{}",
                model.states[*state].name, model.inputs[*input].name
            );
            lowerer.prefer_name(entry, &name);
        }
    }
    for &node in &invariant {
        lowerer.force_let(node);
    }
    let before_loop = lowerer.ops();
    let outside = lowerer.take_statements();
    // The gain after the loop comes from a fork taken here, so it does not rely on
    // temporaries scoped inside the loop body.
    let mut after = lowerer.clone();
    let failure = quote! { return Status::NonPositiveControlWeight; };
    // Loop body: P <- A'PA - A'PB K + Q (eq. 19), N times from P = Q.
    guard_pivots(
        &mut lowerer,
        &pivots,
        &reciprocals,
        (WEIGHT, ""),
        &failure,
        scalar,
    );
    let p_values = lowerer.segment(&p_next);
    let body = lowerer.take_statements();
    let per_step = lowerer.ops().minus(before_loop);
    let Lowered { used_vars, .. } = lowerer.finish();
    // After the loop: F = (R + B'PB)^-1 B'PA from the final P (Alg. 3).
    guard_pivots(
        &mut after,
        &pivots,
        &reciprocals,
        (WEIGHT, ""),
        &failure,
        scalar,
    );
    let k_values = after.segment(&k_flat);
    let gain_statements = after.take_statements();
    let gain_ops = after.ops().minus(before_loop);
    let Lowered {
        used_vars: used_after,
        ..
    } = after.finish();
    let used_vars: std::collections::BTreeSet<_> = used_vars.union(&used_after).copied().collect();
    let solve_ops = before_loop
        .plus(per_step.times(spec.horizon))
        .plus(gain_ops);

    let graph = &g.graph;
    let ty = ident(scalar.type_name());
    let unpack_x = destructure(graph, quote! { *x }, &g.x, &used_vars);
    let unpack_u = destructure(graph, quote! { *u }, &g.u, &used_vars);
    let unpack_known = destructure(graph, quote! { self.known }, &g.known, &used_vars);
    let x_idents: Vec<_> = used_idents(graph, &g.x, &used_vars);
    let u_idents: Vec<_> = used_idents(graph, &g.u, &used_vars);
    let checked: Vec<_> = x_idents.iter().chain(&u_idents).cloned().collect();
    let check = reject_non_finite(&checked);
    let unpack_p = destructure(graph, quote! { p }, &p_vars, &used_vars);
    // The gain reads fewer entries of the final `P` than a Riccati step does.
    let unpack_p_for_gain = destructure(graph, quote! { p }, &p_vars, &used_after);
    let unpack_q = destructure(graph, quote! { self.q }, &q_vars, &used_vars);
    let unpack_r = destructure(graph, quote! { self.r }, &r_vars, &used_vars);
    let k_rows = k_values.chunks(ns).map(|row| quote! { [#(#row),*] });
    let time = model.uses_time().then(|| {
        let t = time_param(graph, g.t, &used_vars, &ty, "t");
        quote! { #t, }
    });
    let x_name = if x_idents.is_empty() {
        ident("_x")
    } else {
        ident("x")
    };
    // The linearisation's input: an argument only where `A` or `B` depend on it.
    let u_param = (!u_idents.is_empty()).then(|| {
        let len = Literal::usize_unsuffixed(g.u.len());
        quote! { u: &[#ty; #len] }
    });
    let solve_doc = if u_param.is_some() {
        " Recomputes the gain for the estimate `x` and the input `u` the model is \
         linearised at (the operating input: `A` and `B` depend on it): `HORIZON` Riccati \
         steps from `P = Q`, then `K` from the final `P`. Leaves the gain \
         unchanged unless it returns [`Status::Ok`]."
    } else {
        " Recomputes the gain for the estimate `x` (`A` and `B` do not depend on the input): \
         `HORIZON` Riccati steps from `P = Q`, then `K` from the final `P`. Leaves \
         the gain unchanged unless it returns [`Status::Ok`]."
    };
    let known = crate::emit::known::known_items(model, &ty);
    let (known_field, known_param, known_init, known_methods) =
        (known.field, known.param, known.init, known.methods);
    let steady_state = steady_state_input(model, spec, mg, scalar);

    let n = Literal::usize_unsuffixed(model.state_len());
    let (ns_len, nu_len) = (Literal::usize_unsuffixed(ns), Literal::usize_unsuffixed(nu));
    let (nsp, nup) = (
        Literal::usize_unsuffixed(packed_len(ns)),
        Literal::usize_unsuffixed(packed_len(nu)),
    );
    let horizon = Literal::u32_unsuffixed(spec.horizon);
    let zero = literal(0.0, scalar);
    let state_names = model.states_named(&spec.states);
    let input_names = model.inputs_named(&spec.inputs);
    let doc = format!(
        " Adaptive finite-horizon LQR (Algorithm 3 of the double Kalman filter paper) regulating `[{}]` with `[{}]`. At each \
         [`Lqr::solve`] the physical sub-model `A = df/d[{0}]`, `B = df/d[{1}]` is taken at \
         the current estimate, and the backward Riccati recursion (eq. (19) of that paper, `R` inside the \
         inverse) runs over the horizon; [`Lqr::control`] then gives `u = -K x`, saturated.",
        state_names.join(", "),
        input_names.join(", ")
    );
    let (pack_q, pack_r) = (pack_upper("q", ns), pack_upper("r", nu));
    let regulated: Vec<proc_macro2::Ident> = state_names.iter().map(|n| ident(n)).collect();
    let regulated_pattern: Vec<TokenStream> = model
        .state_names()
        .map(|name| {
            if state_names.contains(&name) {
                let name = ident(name);
                quote! { #name }
            } else {
                quote! { _ }
            }
        })
        .collect();
    let gain_rows: Vec<Vec<proc_macro2::Ident>> = (0..nu)
        .map(|i| {
            (0..ns)
                .map(|j| ident(&format!("k{}{}", i + 1, j + 1)))
                .collect()
        })
        .collect();
    let gain_pattern: Vec<TokenStream> =
        gain_rows.iter().map(|row| quote! { [#(#row),*] }).collect();
    let gain_rows_flat: Vec<proc_macro2::Ident> = gain_rows.iter().flatten().cloned().collect();
    let control_names: Vec<proc_macro2::Ident> = input_names.iter().map(|n| ident(n)).collect();
    let limit_names: Vec<proc_macro2::Ident> = input_names
        .iter()
        .map(|n| ident(&format!("{n}_limit")))
        .collect();
    let controls = gain_rows.iter().zip(&control_names).map(|(row, u)| {
        quote! { let #u = -(#(#row * #regulated)+*); }
    });
    let reference_pattern: Vec<TokenStream> = model
        .state_names()
        .map(|name| {
            if state_names.contains(&name) {
                let name = ident(&format!("{name}_ref"));
                quote! { #name }
            } else {
                quote! { _ }
            }
        })
        .collect();
    let reference_inputs: Vec<proc_macro2::Ident> = input_names
        .iter()
        .map(|n| ident(&format!("{n}_ref")))
        .collect();
    let tracking = gain_rows
        .iter()
        .zip(&control_names)
        .zip(&reference_inputs)
        .map(|((row, u), u_ref)| {
            let errors = regulated.iter().map(|s| {
                let s_ref = ident(&format!("{s}_ref"));
                quote! { (#s - #s_ref) }
            });
            quote! { let #u = #u_ref - (#(#row * #errors)+*); }
        });
    let saturations = control_names.iter().zip(&limit_names).map(|(u, limit)| {
        quote! {
            if #u > #limit {
                #limit
            } else if #u < -#limit {
                -#limit
            } else {
                #u
            }
        }
    });
    let tokens = quote! {
        #[doc = #doc]
        #[derive(Clone, Copy, Debug, PartialEq)]
        pub struct Lqr {
            q: [#ty; #nsp],
            r: [#ty; #nup],
            u_max: Option<[#ty; #nu_len]>,
            gain: [[#ty; #ns_len]; #nu_len],
            #known_field
        }

        impl Lqr {
            /// Steps of the backward Riccati recursion.
            pub const HORIZON: u32 = #horizon;

            /// A controller with state weight `q` and input weight `r` (symmetric: upper
            /// triangles are read) and, if given, the symmetric input limits `u_max`. The
            /// gain is zero until the first [`Lqr::solve`].
            #[must_use]
            pub fn new(q: &[[#ty; #ns_len]; #ns_len], r: &[[#ty; #nu_len]; #nu_len], u_max: Option<[#ty; #nu_len]> #known_param) -> Lqr {
                Lqr { q: #pack_q, r: #pack_r, u_max, gain: [[#zero; #ns_len]; #nu_len], #known_init }
            }

            #known_methods

            #steady_state

            /// The gain `K` of the last successful [`Lqr::solve`].
            #[must_use]
            pub fn gain(&self) -> [[#ty; #ns_len]; #nu_len] {
                self.gain
            }

            #[doc = #solve_doc]
            pub fn solve(&mut self, #time #x_name: &[#ty; #n], #u_param) -> Status {
                #unpack_x
                #unpack_u
                #unpack_known
                #check
                #unpack_q
                #unpack_r
                #(#outside)*
                let mut p = self.q;
                for _ in 0..Self::HORIZON {
                    #unpack_p
                    #(#body)*
                    p = [#(#p_values),*];
                }
                #unpack_p_for_gain
                #(#gain_statements)*
                let gain = [#(#k_rows),*];
                let [#(#gain_pattern),*] = gain;
                if !(#(#gain_rows_flat)+*).is_finite() {
                    return Status::NonFinite;
                }
                self.gain = gain;
                Status::Ok
            }

            /// The control `u = -K x` for the estimate `x`, saturated to the limits: the
            /// regulator to zero ([`Lqr::track`] with a zero reference).
            #[must_use]
            pub fn control(&self, x: &[#ty; #n]) -> [#ty; #nu_len] {
                let [#(#regulated_pattern),*] = *x;
                let [#(#gain_pattern),*] = self.gain;
                #(#controls)*
                self.saturate([#(#control_names),*])
            }

            /// The control tracking a reference, `u = u_ref - K (x - x_ref)`, saturated to
            /// the limits: `x` the estimate, `x_ref` the set-point (only the regulated
            /// states are read), `u_ref` the input that holds the plant there, such as
            /// [`Lqr::steady_state_input`] gives.
            #[must_use]
            pub fn track(&self, x: &[#ty; #n], x_ref: &[#ty; #n], u_ref: &[#ty; #nu_len]) -> [#ty; #nu_len] {
                let [#(#regulated_pattern),*] = *x;
                let [#(#reference_pattern),*] = *x_ref;
                let [#(#reference_inputs),*] = *u_ref;
                let [#(#gain_pattern),*] = self.gain;
                #(#tracking)*
                self.saturate([#(#control_names),*])
            }

            /// `u` limited to `u_max`, if limits were given.
            fn saturate(&self, unsaturated: [#ty; #nu_len]) -> [#ty; #nu_len] {
                let [#(#control_names),*] = unsaturated;
                match self.u_max {
                    None => unsaturated,
                    Some([#(#limit_names),*]) => [#(#saturations),*],
                }
            }
        }
    };
    LqrCode { tokens, solve_ops }
}

fn used_idents(
    g: &Graph,
    vars: &[NodeId],
    used: &std::collections::BTreeSet<crate::symbolic::VarId>,
) -> Vec<proc_macro2::Ident> {
    vars.iter()
        .filter(|&&v| matches!(g.node(v), Node::Var(id) if used.contains(&id)))
        .map(|&v| var_idents(g, &[v]).remove(0))
        .collect()
}

/// `fn steady_state_input(&self, x_ref, u)`: the input holding the regulated states at a
/// set-point, `u_ref = u + (B'B)^-1 B' (x_ref - f(x_ref, u))` over the regulated states and
/// inputs, with `B = df/d[inputs]` at `(x_ref, u)`: one Gauss-Newton step on the fixed
/// point `f(x_ref, u_ref) = x_ref`, exact for a model affine in its inputs (the least-
/// squares input when the set-point is not an equilibrium any input reaches).
fn steady_state_input(
    model: &Model,
    spec: &LqrSpec,
    mg: &ModelGraph,
    scalar: Scalar,
) -> TokenStream {
    let mut g = mg.clone();
    let avoid = model_names(model);
    let rows: Vec<NodeId> = spec.states.iter().map(|&i| g.f[i]).collect();
    let inputs: Vec<NodeId> = spec.inputs.iter().map(|&i| g.u[i]).collect();
    let b = g.jacobian(&rows, &inputs);
    let graph = &mut g.graph;
    let residual: Matrix = spec
        .states
        .iter()
        .zip(&rows)
        .map(|(&i, &f)| vec![graph.sub(mg.x[i], f)])
        .collect();
    let bt = transpose(&b);
    let gram = matmul(graph, &bt, &b);
    const GRAM: (&str, &str) = ("gram", "inv_gram");
    let nu = spec.inputs.len();
    let ldl = ldl_inverse(graph, &gram, |g, j| g.var(&pivot_names(nu, j, GRAM, "").1));
    let bt_residual = matmul(graph, &bt, &residual);
    let delta = matmul(graph, &ldl.inverse, &bt_residual);
    let u_ref: Vec<NodeId> = inputs
        .iter()
        .zip(&delta)
        .map(|(&u, d)| graph.add(u, d[0]))
        .collect();
    let mut roots = u_ref.clone();
    roots.extend(&ldl.pivots);
    let namer = TempNamer::new(avoid.iter().map(String::as_str));
    let mut lowerer = Lowerer::new(&g.graph, scalar, namer, &roots);
    lowerer.read_lazily(&quote! { self.known }, &g.known);
    guard_pivots(
        &mut lowerer,
        &ldl.pivots,
        &ldl.reciprocals,
        (GRAM, ""),
        &quote! { return None; },
        scalar,
    );
    let values = lowerer.segment(&u_ref);
    let Lowered {
        statements,
        used_vars,
        ..
    } = lowerer.finish();
    let graph = &g.graph;
    let ty = ident(scalar.type_name());
    let n = Literal::usize_unsuffixed(model.state_len());
    let nu_len = Literal::usize_unsuffixed(nu);
    let x_idents = used_idents(graph, &g.x, &used_vars);
    let u_idents = used_idents(graph, &g.u, &used_vars);
    let unpack_x = destructure(graph, quote! { *x_ref }, &g.x, &used_vars);
    let unpack_u = destructure(graph, quote! { *u }, &g.u, &used_vars);
    let checked: Vec<_> = x_idents.iter().chain(&u_idents).cloned().collect();
    let finite = crate::emit::code::all_finite(&checked);
    let check = (!checked.is_empty()).then(|| quote! { if !(#finite) { return None; } });
    let time = model.uses_time().then(|| {
        let t = time_param(graph, g.t, &used_vars, &ty, "t");
        quote! { #t, }
    });
    let x_name = if x_idents.is_empty() {
        ident("_x_ref")
    } else {
        ident("x_ref")
    };
    let u_len = Literal::usize_unsuffixed(g.u.len());
    let u_name = if u_idents.is_empty() {
        ident("_u")
    } else {
        ident("u")
    };
    let result: Vec<proc_macro2::Ident> = spec
        .inputs
        .iter()
        .map(|&i| ident(&format!("{}_ref", model.inputs[i].name)))
        .collect();
    let finite_result = crate::emit::code::all_finite(&result);
    quote! {
        /// The input `u_ref` that holds the regulated states at the set-point `x_ref` (a
        /// whole state vector: the other states and the parameters at the values to
        /// linearise at, such as the estimate's), for [`Lqr::track`]: `u_ref = u + (B'B)^-1
        /// B' (x_ref - f(x_ref, u))` over the regulated states and inputs, `B = df/du` at
        /// `(x_ref, u)`, starting from the input `u` (the inputs not computed by the LQR
        /// stay as given). Exact for a model affine in its inputs; otherwise one
        /// Gauss-Newton step, repeated from its result to converge. `None` if an argument
        /// is not finite, or the inputs cannot move the regulated states (`B'B` singular).
        #[must_use]
        pub fn steady_state_input(&self, #time #x_name: &[#ty; #n], #u_name: &[#ty; #u_len]) -> Option<[#ty; #nu_len]> {
            #unpack_x
            #unpack_u
            #check
            #(#statements)*
            let [#(#result),*] = [#(#values),*];
            if !(#finite_result) {
                return None;
            }
            Some([#(#result),*])
        }
    }
}
