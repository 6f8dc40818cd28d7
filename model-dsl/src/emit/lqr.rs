//! The adaptive finite-horizon LQR (Alg. 3, eq. 19, with `R` inside the inverse): the
//! physical sub-model is the Jacobian of `f` with respect to the chosen states and inputs
//! at the current estimate; the backward Riccati recursion runs as a loop over the horizon
//! whose body is generated straight-line code.

use super::code::{
    destructure, guard_pivots, pack_upper, pivot_names, reject_non_finite, var_idents,
};
use super::ekf::{model_names, packed_vars, time_param};
use super::lower::{literal, Lowered, Lowerer, OpCount};
use super::names::{ident, TempNamer};
use crate::model::{LqrSpec, Model, Scalar};
use crate::symbolic::linalg::{
    add, ldl_inverse, matmul, packed_len, packed_upper, sandwich_symmetric, sub,
    symmetric_from_packed, transpose, Matrix,
};
use crate::symbolic::{Graph, ModelGraph, Node, NodeId};
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
    let pb = matmul(graph, &p, &b);
    let btpb = matmul(graph, &transpose(&b), &pb);
    let weight = add(graph, &r, &btpb);
    let btpa = matmul(graph, &transpose(&pb), &a);
    const WEIGHT: (&str, &str) = ("weight", "inv_weight");
    let ldl = ldl_inverse(graph, &weight, |g, j| {
        g.var(&pivot_names(nu, j, WEIGHT, "").1)
    });
    let (pivots, reciprocals, weight_inv) = (ldl.pivots, ldl.reciprocals, ldl.inverse);
    let k = matmul(graph, &weight_inv, &btpa);
    let at = transpose(&a);
    let atpa = sandwich_symmetric(graph, &at, &p, &at);
    let correction = symmetric_product(graph, &transpose(&btpa), &k);
    let difference = sub(graph, &atpa, &correction);
    let p_next = add(graph, &difference, &q);
    let p_next = packed_upper(&p_next);
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
    let u_param = (!g.u.is_empty()).then(|| {
        let name = if u_idents.is_empty() {
            ident("_u")
        } else {
            ident("u")
        };
        let len = Literal::usize_unsuffixed(g.u.len());
        quote! { #name: &[#ty; #len] }
    });

    let n = Literal::usize_unsuffixed(model.state_len());
    let (ns_len, nu_len) = (Literal::usize_unsuffixed(ns), Literal::usize_unsuffixed(nu));
    let (nsp, nup) = (
        Literal::usize_unsuffixed(packed_len(ns)),
        Literal::usize_unsuffixed(packed_len(nu)),
    );
    let horizon = Literal::u32_unsuffixed(spec.horizon);
    let zero = literal(0.0, scalar);
    let state_names: Vec<&str> = spec
        .states
        .iter()
        .map(|&i| model.states[i].name.as_str())
        .collect();
    let input_names: Vec<&str> = spec
        .inputs
        .iter()
        .map(|&i| model.inputs[i].name.as_str())
        .collect();
    let doc = format!(
        " Adaptive finite-horizon LQR (Alg. 3) regulating `[{}]` with `[{}]`. At each \
         [`Lqr::solve`] the physical sub-model `A = df/d[{0}]`, `B = df/d[{1}]` is taken at \
         the current estimate, and the backward Riccati recursion (eq. 19, `R` inside the \
         inverse) runs over the horizon; [`Lqr::control`] then gives `u = -K x`, saturated.",
        state_names.join(", "),
        input_names.join(", ")
    );
    let (pack_q, pack_r) = (pack_upper("q", ns), pack_upper("r", nu));
    let regulated: Vec<proc_macro2::Ident> = state_names.iter().map(|n| ident(n)).collect();
    let regulated_pattern = model.state_names().map(|name| {
        if state_names.contains(&name) {
            let name = ident(name);
            quote! { #name }
        } else {
            quote! { _ }
        }
    });
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
        }

        impl Lqr {
            /// Steps of the backward Riccati recursion.
            pub const HORIZON: u32 = #horizon;

            /// A controller with state weight `q` and input weight `r` (symmetric: upper
            /// triangles are read) and, if given, the symmetric input limits `u_max`. The
            /// gain is zero until the first [`Lqr::solve`].
            #[must_use]
            pub fn new(q: &[[#ty; #ns_len]; #ns_len], r: &[[#ty; #nu_len]; #nu_len], u_max: Option<[#ty; #nu_len]>) -> Lqr {
                Lqr { q: #pack_q, r: #pack_r, u_max, gain: [[#zero; #ns_len]; #nu_len] }
            }

            /// The gain `K` of the last successful [`Lqr::solve`].
            #[must_use]
            pub fn gain(&self) -> [[#ty; #ns_len]; #nu_len] {
                self.gain
            }

            /// Recomputes the gain for the estimate `x` (and the operating input `u`):
            /// `HORIZON` Riccati steps from `P = Q`, then `K` from the final `P` (Alg. 3).
            /// Leaves the gain unchanged unless it returns [`Status::Ok`].
            pub fn solve(&mut self, #time #x_name: &[#ty; #n], #u_param) -> Status {
                #unpack_x
                #unpack_u
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

            /// The control `u = -K x` for the estimate `x`, saturated to the limits.
            #[must_use]
            pub fn control(&self, x: &[#ty; #n]) -> [#ty; #nu_len] {
                let [#(#regulated_pattern),*] = *x;
                let [#(#gain_pattern),*] = self.gain;
                #(#controls)*
                match self.u_max {
                    None => [#(#control_names),*],
                    Some([#(#limit_names),*]) => [#(#saturations),*],
                }
            }
        }
    };
    LqrCode { tokens, solve_ops }
}

/// The upper triangle (mirrored) of `a b` for a product known to be symmetric.
fn symmetric_product(g: &mut Graph, a: &Matrix, b: &Matrix) -> Matrix {
    let n = a.len();
    let full = matmul(g, a, b);
    let mut out = full.clone();
    for i in 0..n {
        for j in 0..i {
            out[i][j] = full[j][i];
        }
    }
    out
}

/// Nodes the loop body reads that do not change from one iteration to the next: operands
/// of loop-dependent nodes that depend on no loop variable, and are not leaves.
pub(crate) fn loop_invariant_operands(
    g: &Graph,
    roots: &[NodeId],
    loop_vars: &[NodeId],
) -> Vec<NodeId> {
    let mut varies = vec![false; g.len()];
    for id in g.ids() {
        varies[id.index()] =
            loop_vars.contains(&id) || g.node(id).children().iter().any(|c| varies[c.index()]);
    }
    let mut reached = vec![false; g.len()];
    let mut stack = roots.to_vec();
    let mut invariant = Vec::new();
    while let Some(id) = stack.pop() {
        if std::mem::replace(&mut reached[id.index()], true) {
            continue;
        }
        if !varies[id.index()] {
            if !matches!(g.node(id), Node::Num(_) | Node::Named(_) | Node::Var(_)) {
                invariant.push(id);
            }
            continue;
        }
        stack.extend(g.node(id).children());
    }
    invariant.sort();
    invariant
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
