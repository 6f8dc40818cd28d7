//! The extended Kalman filter (Alg. 1), generated for the model: covariance stored once
//! (packed upper triangle), products that skip the Jacobians' structural zeros, a scalar
//! measurement handled with one guarded reciprocal, several with an unrolled `L D L'` solve,
//! and the Joseph-form covariance update.

use super::code::{
    commit_or_non_finite, destructure, guard_pivots, pack_upper, packed_names, reject_non_finite,
    unpack_symmetric, var_idents,
};
use super::lower::{Lowered, Lowerer, OpCount};
use super::names::{ident, TempNamer};
use crate::model::{Model, Scalar};
use crate::symbolic::kalman;
use crate::symbolic::linalg::{packed_len, packed_upper, symmetric_from_packed, Matrix};
use crate::symbolic::{Graph, ModelGraph, NodeId};
use proc_macro2::TokenStream;
use quote::quote;

/// Generated EKF code and the cost of its two halves.
pub struct EkfCode {
    /// The `Ekf` type and its methods.
    pub tokens: TokenStream,
    /// Arithmetic of `predict`.
    pub predict_ops: OpCount,
    /// Arithmetic of `update`.
    pub update_ops: OpCount,
}

/// Names already used by the model, which generated variables must avoid.
pub fn model_names(model: &Model) -> Vec<String> {
    model
        .constants
        .iter()
        .map(|c| c.name.clone())
        .chain(model.state_names().map(str::to_owned))
        .chain(model.inputs.iter().map(|s| s.name.clone()))
        .chain(model.outputs.iter().map(|o| o.name.clone()))
        .chain(["t", "x", "u", "y", "self", "status"].map(String::from))
        .collect()
}

/// Declares the packed variables of an `n x n` symmetric matrix and returns them.
pub fn packed_vars(graph: &mut Graph, prefix: &str, n: usize, avoid: &[String]) -> Vec<NodeId> {
    let taken = |name: &str| avoid.iter().any(|a| a == name);
    packed_names(prefix, n, &taken)
        .iter()
        .map(|name| graph.var(name))
        .collect()
}

/// The sum of a vector and of a matrix's diagonal: finite exactly when all of them are
/// (a NaN or infinity anywhere makes it non-finite), so one check guards a whole result.
pub fn finiteness_probe(graph: &mut Graph, vector: &[NodeId], matrix: &Matrix) -> NodeId {
    let mut sum = graph.zero();
    let diagonal = (0..matrix.len()).map(|i| matrix[i][i]);
    for v in vector.iter().copied().chain(diagonal) {
        sum = graph.add(sum, v);
    }
    sum
}

/// The EKF of `model` in `scalar`.
pub fn emit_ekf(model: &Model, mg: &ModelGraph, scalar: Scalar) -> EkfCode {
    let (predict, predict_ops) = predict(model, mg, scalar);
    let (update, update_ops) = update(model, mg, scalar);
    let ty = ident(scalar.type_name());
    let (n, m) = (model.state_len(), model.outputs.len());
    let [n_len, m_len, np, mp, u_len] = [n, m, packed_len(n), packed_len(m), model.inputs.len()]
        .map(proc_macro2::Literal::usize_unsuffixed);
    let uses_time = model.uses_time();

    let (pack_p0, pack_q, pack_r) = (pack_upper("p0", n), pack_upper("q", n), pack_upper("r", m));
    let unpack_p = unpack_symmetric("p", n);

    let time_prev = uses_time.then(|| quote! { t_prev: #ty, });
    let time_now = uses_time.then(|| quote! { t: #ty, });
    let time_prev_arg = uses_time.then(|| quote! { t_prev, });
    let time_now_arg = uses_time.then(|| quote! { t, });
    let has_u = !model.inputs.is_empty();
    let u_param = has_u.then(|| quote! { u_prev: &[#ty; #u_len], });
    let u_arg = has_u.then(|| quote! { u_prev });
    let doc_step = format!(
        " One sample: predicts `x[k]` from `x[k-1]` with the input `u[k-1]` held over the \
         sample, then corrects it with the measurement `y[k]`. On any status but \
         [`Status::Ok`] the filter is left as it was. Cost: [`EKF_PREDICT_OPS`] plus \
         [`EKF_UPDATE_OPS`]{}.",
        if model.scalars.first() == Some(&scalar) {
            ""
        } else {
            " (in the parent module)"
        }
    );
    let tokens = quote! {
        /// Extended Kalman filter (Alg. 1) of this model: state estimate `x` (physical
        /// states, then parameters) and covariance `P`, stored once as a packed upper
        /// triangle; Joseph-form update.
        ///
        /// Index convention (all filters of this module): [`Ekf::step`] at sample `k` takes
        /// the input `u[k-1]` applied since the previous sample and the measurement `y[k]`.
        #[derive(Clone, Copy, Debug, PartialEq)]
        pub struct Ekf {
            x: [#ty; #n_len],
            p: [#ty; #np],
            q: [#ty; #np],
            r: [#ty; #mp],
        }

        impl Ekf {
            /// A filter from the initial estimate `x0` and covariance `p0`, the process
            /// noise covariance `q` and the measurement noise covariance `r`. The matrices
            /// are symmetric: only their upper triangles are read.
            #[must_use]
            pub fn new(x0: [#ty; #n_len], p0: &[[#ty; #n_len]; #n_len], q: &[[#ty; #n_len]; #n_len], r: &[[#ty; #m_len]; #m_len]) -> Ekf {
                Ekf { x: x0, p: #pack_p0, q: #pack_q, r: #pack_r }
            }

            /// The state estimate: physical states, then parameters.
            #[must_use]
            pub fn state(&self) -> [#ty; #n_len] {
                self.x
            }

            /// The estimate's covariance.
            #[must_use]
            pub fn covariance(&self) -> [[#ty; #n_len]; #n_len] {
                #unpack_p
            }

            #[doc = #doc_step]
            pub fn step(&mut self, #time_prev #time_now #u_param y: &[#ty; #m_len]) -> Status {
                let before = *self;
                let status = self.predict(#time_prev_arg #u_arg);
                if status != Status::Ok {
                    return status;
                }
                let status = self.update(#time_now_arg y);
                if status != Status::Ok {
                    *self = before;
                }
                status
            }

            #predict

            #update
        }
    };
    EkfCode {
        tokens,
        predict_ops,
        update_ops,
    }
}

/// `predict`: `P = A P A' + Q`, `x = f(x, u)`, with `A = df/dx` at the current estimate.
fn predict(model: &Model, mg: &ModelGraph, scalar: Scalar) -> (TokenStream, OpCount) {
    let mut g = mg.clone();
    let n = model.state_len();
    let avoid = model_names(model);
    let p_vars = packed_vars(&mut g.graph, "p", n, &avoid);
    let q_vars = packed_vars(&mut g.graph, "q", n, &avoid);
    let p = symmetric_from_packed(&p_vars, n);
    let q = symmetric_from_packed(&q_vars, n);
    let a = g.jacobian_f_wrt_x();
    let p_pred = kalman::predict_covariance(&mut g.graph, &a, &p, &q);
    let x_pred = g.f.clone();
    let probe = finiteness_probe(&mut g.graph, &x_pred, &p_pred);
    let p_pred = packed_upper(&p_pred);

    let results: Vec<NodeId> = x_pred.iter().chain(&p_pred).copied().collect();
    let mut all_roots = results.clone();
    all_roots.push(probe);
    let namer = TempNamer::new(avoid.iter().map(String::as_str));
    let mut lowerer = Lowerer::new(&g.graph, scalar, namer, &all_roots);
    name_results(&mut lowerer, model, &x_pred, &p_vars, &p_pred, "pred");
    let probe = lowerer.segment(&[probe]).remove(0);
    let values = lowerer.segment(&results);
    let Lowered {
        statements,
        used_vars,
        ops,
    } = lowerer.finish();
    let (x_values, p_values) = values.split_at(n);
    let commit = commit_or_non_finite(&probe, x_values, p_values);
    let graph = &g.graph;
    let u_idents = var_idents(graph, &g.u);
    let unpack_u = (!g.u.is_empty()).then(|| {
        let u = &u_idents;
        quote! { let [#(#u),*] = *u; }
    });
    let check_u = reject_non_finite(&u_idents);
    let unpack_x = destructure(graph, quote! { self.x }, &g.x, &used_vars);
    let unpack_p = destructure(graph, quote! { self.p }, &p_vars, &used_vars);
    let unpack_q = destructure(graph, quote! { self.q }, &q_vars, &used_vars);
    let ty = ident(scalar.type_name());
    let time = model.uses_time().then(|| {
        let t = time_param(graph, g.t, &used_vars, &ty);
        quote! { #t, }
    });
    let u_param = (!g.u.is_empty()).then(|| {
        let len = proc_macro2::Literal::usize_unsuffixed(g.u.len());
        quote! { u: &[#ty; #len] }
    });
    let tokens = quote! {
        /// Predicts the next sample: `x = f(x, u)`, `P = A P A' + Q` with `A = df/dx`
        /// at the current estimate (Alg. 1). Rejects a non-finite input and leaves the
        /// filter unchanged unless it returns [`Status::Ok`].
        pub fn predict(&mut self, #time #u_param) -> Status {
            #unpack_u
            #check_u
            #unpack_x
            #unpack_p
            #unpack_q
            #(#statements)*
            #commit
        }
    };
    (tokens, ops)
}

/// `update`: the Kalman gain from `S = C P C' + R` and the Joseph-form covariance
/// `P = (I - K C) P (I - K C)' + K R K'`, with `C = dh/dx` at the current estimate.
fn update(model: &Model, mg: &ModelGraph, scalar: Scalar) -> (TokenStream, OpCount) {
    let mut g = mg.clone();
    let n = model.state_len();
    let m = model.outputs.len();
    let avoid = model_names(model);
    let taken = |name: &str| avoid.iter().any(|a| a == name);
    let y_names: Vec<String> = model
        .outputs
        .iter()
        .map(|o| {
            let mut name = format!("{}_measured", o.name);
            while taken(&name) {
                name.push('_');
            }
            name
        })
        .collect();
    let y_vars: Vec<NodeId> = y_names.iter().map(|name| g.graph.var(name)).collect();
    let p_vars = packed_vars(&mut g.graph, "p", n, &avoid);
    let r_vars = packed_vars(&mut g.graph, "r", m, &avoid);
    let p = symmetric_from_packed(&p_vars, n);
    let r = symmetric_from_packed(&r_vars, m);
    let c = g.jacobian_h_wrt_x();
    let graph = &mut g.graph;
    let residual: Vec<NodeId> = y_vars
        .iter()
        .zip(&g.h)
        .map(|(&y, &h)| graph.sub(y, h))
        .collect();
    let reciprocal_name = |j: usize| {
        if m == 1 {
            "inv_s".to_owned()
        } else {
            format!("inv_d{}", j + 1)
        }
    };
    let kalman::Update {
        x: x_new,
        p: p_new_full,
        pivots,
        reciprocals,
    } = kalman::update(graph, &g.x, &p, &residual, &c, &r, |g, j| {
        g.var(&reciprocal_name(j))
    });
    let probe = finiteness_probe(graph, &x_new, &p_new_full);
    let p_new = packed_upper(&p_new_full);

    let results: Vec<NodeId> = x_new.iter().chain(&p_new).copied().collect();
    let mut all_roots = results.clone();
    all_roots.push(probe);
    all_roots.extend(&pivots);
    let namer = TempNamer::new(avoid.iter().map(String::as_str));
    let mut lowerer = Lowerer::new(&g.graph, scalar, namer, &all_roots);
    name_results(&mut lowerer, model, &x_new, &p_vars, &p_new, "new");
    let pivot_names: Vec<String> = (0..pivots.len())
        .map(|j| {
            if m == 1 {
                "innovation_variance".to_owned()
            } else {
                format!("d{}", j + 1)
            }
        })
        .collect();
    guard_pivots(
        &mut lowerer,
        &pivots,
        &reciprocals,
        &pivot_names,
        &quote! { return Status::NonPositiveInnovation; },
        scalar,
    );
    let probe = lowerer.segment(&[probe]).remove(0);
    let values = lowerer.segment(&results);
    let Lowered {
        statements,
        used_vars,
        ops,
    } = lowerer.finish();
    let (x_values, p_values) = values.split_at(n);
    let commit = commit_or_non_finite(&probe, x_values, p_values);
    let graph = &g.graph;
    let y_idents = var_idents(graph, &y_vars);
    let check_y = reject_non_finite(&y_idents);
    let unpack_x = destructure(graph, quote! { self.x }, &g.x, &used_vars);
    let unpack_p = destructure(graph, quote! { self.p }, &p_vars, &used_vars);
    let unpack_r = destructure(graph, quote! { self.r }, &r_vars, &used_vars);
    let ty = ident(scalar.type_name());
    let time = model.uses_time().then(|| {
        let t = time_param(graph, g.t, &used_vars, &ty);
        quote! { #t, }
    });
    let m_len = proc_macro2::Literal::usize_unsuffixed(m);
    let tokens = quote! {
        /// Corrects the estimate with the measurement `y` (Alg. 1, Joseph form). Rejects a
        /// non-finite measurement and a non-positive innovation variance (never divided
        /// by); leaves the filter unchanged unless it returns [`Status::Ok`].
        pub fn update(&mut self, #time y: &[#ty; #m_len]) -> Status {
            let [#(#y_idents),*] = *y;
            #check_y
            #unpack_x
            #unpack_p
            #unpack_r
            #(#statements)*
            #commit
        }
    };
    (tokens, ops)
}

/// `t: f32`, or `_t: f32` when the code does not read it.
pub fn time_param(
    graph: &Graph,
    t: NodeId,
    used: &std::collections::BTreeSet<crate::symbolic::VarId>,
    ty: &proc_macro2::Ident,
) -> TokenStream {
    let reads = matches!(graph.node(t), crate::symbolic::Node::Var(v) if used.contains(&v));
    let name = if reads { ident("t") } else { ident("_t") };
    quote! { #name: #ty }
}

/// Names the new state and covariance entries after what they are: `x1_pred`, `p11_pred`.
fn name_results(
    lowerer: &mut Lowerer,
    model: &Model,
    x: &[NodeId],
    p_vars: &[NodeId],
    p: &[NodeId],
    suffix: &str,
) {
    for (&node, name) in x.iter().zip(model.state_names()) {
        lowerer.prefer_name(node, &format!("{name}_{suffix}"));
    }
    let names: Vec<String> = var_idents_of(lowerer, p_vars);
    for (&node, name) in p.iter().zip(names) {
        lowerer.prefer_name(node, &format!("{name}_{suffix}"));
    }
}

fn var_idents_of(lowerer: &Lowerer, vars: &[NodeId]) -> Vec<String> {
    var_idents(lowerer.graph(), vars)
        .iter()
        .map(ToString::to_string)
        .collect()
}
