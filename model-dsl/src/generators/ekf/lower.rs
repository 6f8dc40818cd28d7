//! The extended Kalman filter (Alg. 1), generated for the model: covariance stored once
//! (packed upper triangle), products that skip the Jacobians' structural zeros, a scalar
//! measurement handled with one guarded reciprocal, several with an unrolled `L D L'` solve,
//! and the Joseph-form covariance update.

use crate::emit::code::{
    commit_or_non_finite_with, guard_pivots, pack_upper, pivot_names, reject_non_finite,
    var_idents, INNOVATION,
};
use crate::emit::filter::{
    finiteness_probe, model_names, noise_argument, noise_vars, packed_vars, time_param,
};
use crate::emit::lower::{Lowered, Lowerer, OpCount};
use crate::emit::names::{ident, TempNamer};
use super::spec::EkfSpec;
use crate::model::{Model, Scalar};
use crate::symbolic::kalman;
use crate::symbolic::linalg::{packed_len, packed_upper, symmetric_from_packed, Matrix};
use crate::symbolic::substitute;
use crate::symbolic::{Graph, ModelGraph, NodeId, VarId};
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
    /// Arithmetic of `step`.
    pub step_ops: OpCount,
}

/// The EKF of `model` in `scalar`.
pub fn emit_ekf(model: &Model, spec: &EkfSpec, mg: &ModelGraph, scalar: Scalar) -> EkfCode {
    let diagonal = spec.diagonal_noise;
    let (predict, predict_ops) = method(model, mg, scalar, EkfMethod::Predict, spec);
    let (update, update_ops) = method(model, mg, scalar, EkfMethod::Update, spec);
    let (step, step_ops) = method(model, mg, scalar, EkfMethod::Step, spec);
    // Several outputs: an update per output as well, for sensors at different rates.
    let partial_updates: Vec<TokenStream> = if model.outputs.len() > 1 {
        (0..model.outputs.len())
            .map(|j| method(model, mg, scalar, EkfMethod::UpdateOutput(j), spec).0)
            .collect()
    } else {
        Vec::new()
    };
    let ty = ident(scalar.type_name());
    let (n, m) = (model.state_len(), model.outputs.len());
    let [n_len, m_len, np, mp] =
        [n, m, packed_len(n), packed_len(m)].map(proc_macro2::Literal::usize_unsuffixed);

    let (pack_p0, pack_r) = (pack_upper("p0", n), pack_upper("r", m));
    let (q_param, q_field, pack_q) = noise_argument("q", n, diagonal, &ty);
    let accessors = crate::emit::code::estimate_accessors(n, &ty);
    let zero = crate::emit::lower::literal(0.0, scalar);
    let (gate_field, gate_init, mut gate_methods) = gate_items(spec.gate, &ty, scalar);
    if spec.gate.is_some() {
        gate_methods.extend(keep_prediction_method(model, &ty));
    }
    let setters = crate::emit::tuning::noise_setters(n, m, diagonal, &ty);
    let type_name = ident(&spec.type_name);
    let (type_doc, convention_doc) = type_doc(spec);
    let identity = packed_identity(m, scalar);
    let nis_method = nis_method(model, scalar);
    let known = crate::emit::known::known_items(model, &ty);
    let (known_field, known_param, known_init, known_methods) =
        (known.field, known.param, known.init, known.methods);

    let new_doc = if diagonal {
        " A filter from the initial estimate `x0` and covariance `p0`, the process noise \
         variances `q` (a diagonal covariance) and the measurement noise covariance `r`. The \
         matrices are symmetric: only their upper triangles are read."
    } else {
        " A filter from the initial estimate `x0` and covariance `p0`, the process noise \
         covariance `q` and the measurement noise covariance `r`. The matrices are \
         symmetric: only their upper triangles are read."
    };
    let tokens = quote! {
        #[doc = #type_doc]
        ///
        #[doc = #convention_doc]
        #[derive(Clone, Copy, Debug, PartialEq)]
        pub struct #type_name {
            x: [#ty; #n_len],
            p: [#ty; #np],
            q: #q_field,
            r: [#ty; #mp],
            innovation: [#ty; #m_len],
            innovation_covariance: [#ty; #mp],
            #gate_field
            #known_field
        }

        impl #type_name {
            #[doc = #new_doc]
            #[must_use]
            pub fn new(x0: [#ty; #n_len], p0: &[[#ty; #n_len]; #n_len], #q_param, r: &[[#ty; #m_len]; #m_len] #known_param) -> #type_name {
                #type_name {
                    x: x0,
                    p: #pack_p0,
                    q: #pack_q,
                    r: #pack_r,
                    innovation: [#zero; #m_len],
                    innovation_covariance: #identity,
                    #gate_init
                    #known_init
                }
            }

            /// Starts the filter again from the estimate `x0` and covariance `p0` (only its
            /// upper triangle is read), keeping the noise covariances: the way back after
            /// a fault (a run of [`Status::NonFinite`] or of rejected outliers) or a
            /// restart of the plant. The innovation is cleared.
            pub fn reset(&mut self, x0: [#ty; #n_len], p0: &[[#ty; #n_len]; #n_len]) {
                self.x = x0;
                self.p = #pack_p0;
                self.innovation = [#zero; #m_len];
                self.innovation_covariance = #identity;
            }

            /// The innovation `y - h(x)` of the last measurement used or rejected: what
            /// the measurement said that the prediction did not.
            #[must_use]
            pub fn innovation(&self) -> [#ty; #m_len] {
                self.innovation
            }

            #nis_method

            #gate_methods

            #accessors

            #setters

            #known_methods

            #step

            #predict

            #update

            #(#partial_updates)*
        }
    };
    EkfCode {
        tokens,
        predict_ops,
        update_ops,
        step_ops,
    }
}

/// The filter type's documentation: what it is (with its gate), then the index convention.
fn type_doc(spec: &EkfSpec) -> (String, String) {
    let gate = if spec.gate.is_some() {
        " A measurement whose normalised innovation squared exceeds the innovation gate is \
         rejected as an outlier."
    } else {
        ""
    };
    let what = format!(
        " Extended Kalman filter of this model (Algorithm 1 of the double Kalman filter paper, \
         which compares the EKF with the DKF on a vibrating cantilever beam): state estimate `x` (physical states, \
         then parameters) and covariance `P`, stored once as a packed upper triangle; \
         Joseph-form update.{gate}"
    );
    let convention = format!(
        " Index convention (all filters of this module): [`{}::step`] at sample `k` takes \
         the input `u[k-1]` applied since the previous sample and the measurement `y[k]`.",
        spec.type_name
    );
    (what, convention)
}

/// `[1.0, 0.0, .., 1.0]`: the packed `m x m` identity, the innovation covariance before any
/// measurement (with a zero innovation, a normalised square of 0).
fn packed_identity(m: usize, scalar: Scalar) -> TokenStream {
    let entries = (0..m).flat_map(|i| {
        (i..m).map(move |j| crate::emit::lower::literal(if i == j { 1.0 } else { 0.0 }, scalar))
    });
    quote! { [#(#entries),*] }
}

/// `fn normalised_innovation_squared(&self)`: `r' S^-1 r` from the stored innovation `r`
/// and its covariance `S`, through the same guarded `L D L'` inverse as the update. Computed
/// when asked, so a step that does not gate pays only for storing `S`.
fn nis_method(model: &Model, scalar: Scalar) -> TokenStream {
    let m = model.outputs.len();
    let mut graph = Graph::new();
    let avoid = model_names(model);
    let innovation: Vec<NodeId> = model
        .outputs
        .iter()
        .map(|o| {
            let mut name = format!("{}_innovation", o.name);
            while avoid.contains(&name) {
                name.push('_');
            }
            graph.var(&name)
        })
        .collect();
    let s_vars = packed_vars(&mut graph, "s", m, &avoid);
    let s = symmetric_from_packed(&s_vars, m);
    let ldl = crate::symbolic::linalg::ldl_inverse(&mut graph, &s, |g, j| {
        g.var(&pivot_names(m, j, INNOVATION, "").1)
    });
    let nis = kalman::normalised_innovation_squared(&mut graph, &innovation, &ldl.inverse);
    let mut roots = ldl.pivots.clone();
    roots.push(nis);
    let namer = TempNamer::new(avoid.iter().map(String::as_str));
    let mut lowerer = Lowerer::new(&graph, scalar, namer, &roots);
    lowerer.read_lazily(&quote! { self.innovation }, &innovation);
    lowerer.read_lazily(&quote! { self.innovation_covariance }, &s_vars);
    let ty = ident(scalar.type_name());
    // The stored covariance passed this test when its measurement was used: a failure here
    // cannot happen, and would read as "inconsistent".
    let on_failure = quote! { return #ty::INFINITY; };
    guard_pivots(
        &mut lowerer,
        &ldl.pivots,
        &ldl.reciprocals,
        (INNOVATION, ""),
        &on_failure,
        scalar,
    );
    let value = lowerer.segment(&[nis]).remove(0);
    let statements = lowerer.finish().statements;
    quote! {
        /// The normalised innovation squared `r' S^-1 r` of the last measurement used
        /// or rejected (`r` its innovation, `S` the innovation covariance). While the
        /// model and noise levels are right it is chi-square distributed with as many
        /// degrees of freedom as measurements (mean `Y_LEN`); a run of large values says
        /// the model, the tuning or the sensor is wrong. 0 before the first measurement.
        #[must_use]
        pub fn normalised_innovation_squared(&self) -> #ty {
            #(#statements)*
            #value
        }
    }
}

/// The innovation gate's field, its initial value and its methods, when it is asked for.
fn gate_items(
    gate: Option<f64>,
    ty: &proc_macro2::Ident,
    scalar: Scalar,
) -> (TokenStream, TokenStream, TokenStream) {
    let Some(gate) = gate else {
        return Default::default();
    };
    let default = crate::emit::lower::literal(gate, scalar);
    let zero = crate::emit::lower::literal(0.0, scalar);
    let generated = if gate.is_finite() {
        format!("{gate}")
    } else {
        "infinity (open)".to_owned()
    };
    let doc = format!(
        " The innovation gate: a measurement whose normalised innovation squared exceeds it \
         is rejected ([`Status::OutlierRejected`]). Generated as {generated}."
    );
    (
        quote! { gate: #ty, },
        quote! { gate: #default, },
        quote! {
            #[doc = #doc]
            #[must_use]
            pub fn innovation_gate(&self) -> #ty {
                self.gate
            }

            /// Sets the innovation gate (a chi-square quantile for `Y_LEN` degrees of
            /// freedom: 10.83 rejects one in a thousand consistent scalar measurements;
            /// infinity opens it). Rejects a threshold that is not positive, leaving the
            /// gate as it was.
            pub fn set_innovation_gate(&mut self, threshold: #ty) -> Status {
                if threshold > #zero {
                    self.gate = threshold;
                    Status::Ok
                } else {
                    Status::RejectedInput
                }
            }
        },
    )
}

/// Which of the EKF's methods to generate.
#[derive(Clone, Copy, PartialEq, Eq)]
enum EkfMethod {
    /// `P = A P A' + Q`, `x = f(x, u)`.
    Predict,
    /// The Joseph-form correction with `y`.
    Update,
    /// Both in one straight-line function: nothing stored between them, nothing to undo.
    Step,
    /// The correction with one output alone (a sensor of its own rate).
    UpdateOutput(usize),
}

/// One EKF method (Alg. 1): the prediction and/or the correction, built symbolically so
/// products skip the Jacobians' structural zeros, then lowered with its guards.
fn method(
    model: &Model,
    mg: &ModelGraph,
    scalar: Scalar,
    kind: EkfMethod,
    spec: &EkfSpec,
) -> (TokenStream, OpCount) {
    let diagonal_noise = spec.diagonal_noise;
    let mut g = mg.clone();
    let n = model.state_len();
    let m = model.outputs.len();
    let predicts = matches!(kind, EkfMethod::Predict | EkfMethod::Step);
    let updates = kind != EkfMethod::Predict;
    // The outputs this method corrects with: one for a partial update, else all.
    let used_outputs: Vec<usize> = match kind {
        EkfMethod::UpdateOutput(j) => vec![j],
        _ => (0..m).collect(),
    };
    let partial = used_outputs.len() < m;
    let avoid = model_names(model);
    let p_vars = packed_vars(&mut g.graph, "p", n, &avoid);
    let (q_vars, q) = noise_vars(&mut g.graph, "q", n, diagonal_noise, &avoid);
    let r_vars = packed_vars(&mut g.graph, "r", m, &avoid);
    let taken = |name: &str| avoid.iter().any(|a| a == name);
    let y_vars: Vec<NodeId> = used_outputs
        .iter()
        .map(|&j| &model.outputs[j])
        .map(|o| {
            let mut name = format!("{}_measured", o.name);
            while taken(&name) {
                name.push('_');
            }
            g.graph.var(&name)
        })
        .collect();
    // In a step the prediction runs from the previous sample's time, the correction at
    // the measurement's.
    let t_prev = (kind == EkfMethod::Step && model.uses_time()).then(|| g.graph.var("t_prev"));

    let mut x = g.x.clone();
    let mut p = symmetric_from_packed(&p_vars, n);
    if predicts {
        let a = g.jacobian_f_wrt_x();
        let mut f = g.f.clone();
        let mut a = a;
        if let Some(t_prev) = t_prev {
            let at_prev = [(g.var_id(g.t), t_prev)];
            f = f
                .iter()
                .map(|&e| substitute(&mut g.graph, e, &at_prev))
                .collect();
            a = a
                .iter()
                .map(|row| {
                    row.iter()
                        .map(|&e| substitute(&mut g.graph, e, &at_prev))
                        .collect()
                })
                .collect();
        }
        p = kalman::predict_covariance(&mut g.graph, &a, &p, &q);
        x = f;
    }
    let mut pivots = Vec::new();
    let mut reciprocals = Vec::new();
    let mut innovation = Vec::new();
    let mut innovation_covariance = Vec::new();
    let mut nis = None;
    if updates {
        let r_all = symmetric_from_packed(&r_vars, m);
        let r: Matrix = used_outputs
            .iter()
            .map(|&i| used_outputs.iter().map(|&j| r_all[i][j]).collect())
            .collect();
        // h and its Jacobian at the estimate being corrected.
        let at_x: Vec<(VarId, NodeId)> =
            g.x.iter()
                .map(|&v| g.var_id(v))
                .zip(x.iter().copied())
                .collect();
        let c = g.jacobian_h_wrt_x();
        let c: Matrix = used_outputs
            .iter()
            .map(|&i| &c[i])
            .map(|row| {
                row.iter()
                    .map(|&e| substitute(&mut g.graph, e, &at_x))
                    .collect()
            })
            .collect();
        let h: Vec<NodeId> = used_outputs
            .iter()
            .map(|&i| substitute(&mut g.graph, g.h[i], &at_x))
            .collect();
        let graph = &mut g.graph;
        let residual: Vec<NodeId> = y_vars
            .iter()
            .zip(&h)
            .map(|(&y, &h)| graph.sub(y, h))
            .collect();
        let mu = used_outputs.len();
        let update = kalman::update(graph, &x, &p, &residual, &c, &r, |g, j| {
            g.var(&pivot_names(mu, j, INNOVATION, "").1)
        });
        x = update.x;
        p = update.p;
        pivots = update.pivots;
        reciprocals = update.reciprocals;
        // A partial update neither stores its innovation (the stored one is that of
        // every output) nor passes the gate (a threshold for `Y_LEN` degrees of freedom).
        if !partial {
            innovation = residual;
            innovation_covariance = packed_upper(&update.s);
            // Only the gate needs it at once; otherwise `normalised_innovation_squared()`
            // computes it from the stored innovation and its covariance when asked.
            nis = spec.gate.is_some().then_some(update.nis);
        }
    }
    let probe = finiteness_probe(&mut g.graph, &x, &p);
    let p_packed = packed_upper(&p);
    let gated = updates && !partial && spec.gate.is_some();

    let results: Vec<NodeId> = x.iter().chain(&p_packed).copied().collect();
    let mut all_roots = results.clone();
    all_roots.push(probe);
    all_roots.extend(&pivots);
    all_roots.extend(&innovation);
    all_roots.extend(&innovation_covariance);
    all_roots.extend(nis);
    let namer = TempNamer::new(avoid.iter().map(String::as_str));
    let mut lowerer = Lowerer::new(&g.graph, scalar, namer, &all_roots);
    lowerer.read_lazily(&quote! { self.x }, &g.x);
    lowerer.read_lazily(&quote! { self.p }, &p_vars);
    lowerer.read_lazily(&quote! { self.q }, &q_vars);
    lowerer.read_lazily(&quote! { self.r }, &r_vars);
    lowerer.read_lazily(&quote! { self.known }, &g.known);
    let suffix = if updates { "new" } else { "pred" };
    name_results(&mut lowerer, model, &x, &p_vars, &p_packed, suffix);
    guard_pivots(
        &mut lowerer,
        &pivots,
        &reciprocals,
        (INNOVATION, ""),
        &quote! { return Status::NonPositiveInnovation; },
        scalar,
    );
    let innovation_names: Vec<String> = model
        .outputs
        .iter()
        .map(|o| format!("{}_innovation", o.name))
        .collect();
    for (&r, name) in innovation.iter().zip(&innovation_names) {
        lowerer.prefer_name(r, name);
    }
    let probe = lowerer.segment(&[probe]).remove(0);
    let values = lowerer.segment(&results);
    // The innovation and its normalised square come last, where they hold no register
    // while the update runs; so does the gate's test, just before the commit (an outlier
    // costs a whole update, the usual sample nothing more).
    let mut store_innovation = TokenStream::new();
    if updates && !partial {
        let innovation_values = lowerer.segment(&innovation);
        let covariance_values = lowerer.segment(&innovation_covariance);
        store_innovation = store_innovation_tokens(&innovation_values, &covariance_values);
        if let Some(nis) = nis {
            let nis = lowerer.bind(nis, "nis");
            let keep_prediction = (kind == EkfMethod::Step).then(|| {
                let args = prediction_arguments(model);
                quote! {
                    self.keep_prediction(
                        #(#args,)* [#(#innovation_values),*], [#(#covariance_values),*],
                    )
                }
            });
            let rejection = outlier_rejection(keep_prediction, &store_innovation);
            // NaN is not within the gate: a measurement that gives it is rejected.
            let within_gate = lowerer.fresh_name("within_gate");
            lowerer.statement(quote! {
                let #within_gate = #nis <= self.gate;
                if !#within_gate {
                    #rejection
                }
            });
            lowerer.count_extra(OpCount {
                compare: 1,
                ..Default::default()
            });
        }
    }
    let Lowered {
        statements,
        used_vars,
        ops,
    } = lowerer.finish();
    let (x_values, p_values) = values.split_at(n);
    let commit = commit_or_non_finite_with(&probe, x_values, p_values, &store_innovation);
    let statements = crate::emit::scopes::scoped(statements, &commit);

    let graph = &g.graph;
    let ty = ident(scalar.type_name());
    let u_idents = var_idents(graph, &g.u);
    let y_idents = var_idents(graph, &y_vars);
    let mut checked = Vec::new();
    let mut params = Vec::new();
    let mut unpack_inputs = Vec::new();
    if model.uses_time() {
        if let Some(t_prev) = t_prev {
            // A gated step passes it on to `predict` when it rejects an outlier.
            let t_prev = if gated {
                quote! { t_prev: #ty }
            } else {
                time_param(graph, t_prev, &used_vars, &ty, "t_prev")
            };
            params.push(quote! { #t_prev });
        }
        let t = time_param(graph, g.t, &used_vars, &ty, "t");
        params.push(quote! { #t });
    }
    if predicts && !g.u.is_empty() {
        let len = proc_macro2::Literal::usize_unsuffixed(g.u.len());
        let arg = if kind == EkfMethod::Step {
            ident("u_prev")
        } else {
            ident("u")
        };
        params.push(quote! { #arg: &[#ty; #len] });
        unpack_inputs.push(quote! { let [#(#u_idents),*] = *#arg; });
        checked.extend(u_idents.iter().cloned());
    }
    if updates && partial {
        let y_ident = &y_idents[0];
        params.push(quote! { y: #ty });
        unpack_inputs.push(quote! { let #y_ident = y; });
        checked.extend(y_idents.iter().cloned());
    } else if updates {
        let len = proc_macro2::Literal::usize_unsuffixed(m);
        params.push(quote! { y: &[#ty; #len] });
        unpack_inputs.push(quote! { let [#(#y_idents),*] = *y; });
        checked.extend(y_idents.iter().cloned());
    }
    let check = reject_non_finite(&checked);
    let partial_doc;
    let (name, doc) = match kind {
        EkfMethod::UpdateOutput(j) => {
            let output = &model.outputs[j].name;
            partial_doc = format!(
                " Corrects the estimate with the measurement `y` of the output `{output}` \
                 alone, for a sensor sampled at its own rate (Joseph form, its variance \
                 `R[{j}][{j}]`). With uncorrelated measurement noise (a diagonal `R`), \
                 updating with each output in turn equals [`{ty_name}::update`] with all of \
                 them. Neither stores an innovation nor passes an innovation gate. Rejects a \
                 non-finite measurement and a non-positive innovation variance; leaves the \
                 filter unchanged unless it returns [`Status::Ok`].",
                ty_name = spec.type_name
            );
            (ident(&format!("update_{output}")), partial_doc.as_str())
        }
        EkfMethod::Predict => (
            ident("predict"),
            " Predicts the next sample: `x = f(x, u)`, `P = A P A' + Q` with \
             `A = df/dx` at the current estimate. Rejects a non-finite input; leaves the \
             filter unchanged unless it returns [`Status::Ok`].",
        ),
        EkfMethod::Update => (
            ident("update"),
            " Corrects the estimate with the measurement `y` (Joseph form). Rejects \
             a non-finite measurement and a non-positive innovation variance (never divided \
             by); leaves the filter unchanged unless it returns [`Status::Ok`].",
        ),
        EkfMethod::Step => (
            ident("step"),
            " One sample: predicts `x[k]` from `x[k-1]` with the input `u[k-1]` held \
             over the sample, then corrects it with the measurement `y[k]`, in one pass that \
             stores nothing in between. Leaves the filter unchanged unless it returns \
             [`Status::Ok`].",
        ),
    };
    let tokens = quote! {
        #[doc = #doc]
        pub fn #name(&mut self, #(#params),*) -> Status {
            #(#unpack_inputs)*
            #check
            #(#statements)*
            #commit
        }
    };
    (tokens, ops)
}

/// `self.innovation = [..]; self.innovation_covariance = [..];`
fn store_innovation_tokens(innovation: &[TokenStream], covariance: &[TokenStream]) -> TokenStream {
    quote! {
        self.innovation = [#(#innovation),*];
        self.innovation_covariance = [#(#covariance),*];
    }
}

/// What a gated update does with an outlier: store its innovation and return
/// `OutlierRejected`. A step keeps its prediction, as `predict` alone would have, through
/// the cold, out-of-line `keep_prediction` (`keep_prediction`: its call), so the usual
/// sample pays only for the test.
fn outlier_rejection(
    keep_prediction: Option<TokenStream>,
    store_innovation: &TokenStream,
) -> TokenStream {
    match keep_prediction {
        Some(call) => quote! { return #call; },
        None => quote! {
            #store_innovation
            return Status::OutlierRejected;
        },
    }
}

/// The arguments a step passes on to `predict`: `t_prev` and `u_prev` where the model has
/// them.
fn prediction_arguments(model: &Model) -> Vec<TokenStream> {
    let mut args = Vec::new();
    if model.uses_time() {
        args.push(quote! { t_prev });
    }
    if !model.inputs.is_empty() {
        args.push(quote! { u_prev });
    }
    args
}

/// `fn keep_prediction`: a gated step's answer to an outlier.
fn keep_prediction_method(model: &Model, ty: &proc_macro2::Ident) -> TokenStream {
    let m = proc_macro2::Literal::usize_unsuffixed(model.outputs.len());
    let mp = proc_macro2::Literal::usize_unsuffixed(packed_len(model.outputs.len()));
    let mut params = Vec::new();
    if model.uses_time() {
        params.push(quote! { t_prev: #ty });
    }
    if !model.inputs.is_empty() {
        let u = proc_macro2::Literal::usize_unsuffixed(model.inputs.len());
        params.push(quote! { u_prev: &[#ty; #u] });
    }
    let args = prediction_arguments(model);
    quote! {
        /// A step's outlier: the prediction is kept, the measurement only recorded. Out of
        /// line and cold, so the usual sample does not pay for it.
        #[cold]
        #[inline(never)]
        fn keep_prediction(
            &mut self,
            #(#params,)*
            innovation: [#ty; #m],
            innovation_covariance: [#ty; #mp],
        ) -> Status {
            let predicted = self.predict(#(#args),*);
            if predicted != Status::Ok {
                return predicted;
            }
            self.innovation = innovation;
            self.innovation_covariance = innovation_covariance;
            Status::OutlierRejected
        }
    }
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
