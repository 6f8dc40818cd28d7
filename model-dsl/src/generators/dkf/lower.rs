//! The double Kalman filter (Alg. 2): the window transform derived from the model
//! ([`crate::generators::dkf::window`]), a linear Kalman filter on the transformed model (AKF),
//! and a Kalman filter linearised about the AKF's estimate (LKF).

use super::window::{self, column_norms_product, cramer, WindowTransform};
use crate::emit::code::{
    destructure, guard_pivots, pack_upper, pivot_names, unpack_symmetric, var_idents, INNOVATION,
};
use crate::emit::filter::{finiteness_probe, model_names, noise_argument, noise_vars, packed_vars};
use crate::emit::lower::{literal, Lowered, Lowerer, OpCount};
use crate::emit::names::{ident, TempNamer};
use super::spec::DkfSpec;
use crate::model::{Model, Scalar};
use crate::symbolic::kalman;
use crate::symbolic::linalg::{matmul, packed_len, packed_upper, symmetric_from_packed, Matrix};
use crate::symbolic::substitute;
use crate::symbolic::{Graph, ModelGraph, NodeId, VarId};
use proc_macro2::{Ident, Literal, TokenStream};
use quote::quote;

/// Generated DKF code and its cost.
pub struct DkfCode {
    /// `WindowStatus`, `DkfStatus`, the window constants and the `Dkf` type.
    pub tokens: TokenStream,
    /// Arithmetic of the window transform (the full solve, the costliest branch).
    pub transform_ops: OpCount,
    /// Arithmetic of the two filters' step, after the transform.
    pub filters_ops: OpCount,
}

/// The DKF of `model` in `scalar`, or why the model is outside the transform's class.
pub fn emit_dkf(
    model: &Model,
    spec: &DkfSpec,
    mg: &ModelGraph,
    scalar: Scalar,
) -> Result<DkfCode, String> {
    let mut g = mg.clone();
    let wt = window::derive(model, &mut g, spec.eta)?;
    let (transform, transform_ops) = transform_fn(model, &g, &wt, scalar);
    let (step, stages, filters_ops) = step_fn(model, &mut g, &wt, scalar, spec.diagonal_noise);
    let push = push_fn(model, &g, &wt, scalar);
    let ltv = ltv_fn(model, &g, &wt, scalar);
    let sqrt = ident(match scalar {
        Scalar::F32 => "sqrtf",
        Scalar::F64 => "sqrt",
    });

    let ty = ident(scalar.type_name());
    let lit = Literal::usize_unsuffixed;
    let (n, m, np) = (model.state_len(), model.outputs.len(), model.params.len());
    let window_outputs = wt.output_delays + 1;
    let window_inputs = wt.input_delays;
    let [n_len, m_len, p_len, u_len] = [n, m, np, model.inputs.len()].map(lit);
    let (nn, mm) = (lit(packed_len(n)), lit(packed_len(m)));
    let outputs_len = lit(m * window_outputs);
    let inputs_len = lit(model.inputs.len() * window_inputs);
    let window_outputs_lit = lit(window_outputs);
    let window_inputs_lit = lit(window_inputs);
    let zero = literal(0.0, scalar);
    let default_excitation = literal(
        match scalar {
            Scalar::F32 => 1e-6,
            Scalar::F64 => 1e-9,
        },
        scalar,
    );
    let (pack_p0, pack_pbar0, pack_r) = (
        pack_upper("p0", n),
        pack_upper("pbar0", n),
        pack_upper("r", m),
    );
    let (q_param, q_field, pack_q) = noise_argument("q", n, spec.diagonal_noise, &ty);
    let (qbar_param, qbar_field, pack_qbar) = noise_argument("qbar", n, spec.diagonal_noise, &ty);
    let params_of_x0 = {
        let params: Vec<Ident> = model.params.iter().map(|p| ident(&p.name)).collect();
        quote! {{
            let [.., #(#params),*] = x0;
            [#(#params),*]
        }}
    };
    let (unpack_p, unpack_pbar) = (unpack_symmetric("p", n), unpack_symmetric("pbar", n));
    // Run-time tuning: the LKF's `q`, the AKF's `qbar`, the shared `r`.
    let setters = {
        let diagonal = spec.diagonal_noise;
        let tuning = |method, field| {
            crate::emit::tuning::process_noise_setter(method, field, n, diagonal, &ty)
        };
        let (set_q, set_qbar) = (
            tuning("set_process_noise", "q"),
            tuning("set_akf_process_noise", "qbar"),
        );
        let set_r = crate::emit::tuning::measurement_noise_setter(m, &ty);
        quote! { #set_q #set_qbar #set_r }
    };
    let derivation: Vec<String> = wt.description.iter().map(|l| format!(" - {l}")).collect();
    let has_u = !model.inputs.is_empty();
    let u_param = has_u.then(|| quote! { u_prev: &[#ty; #u_len], });
    let u_param_plain = has_u.then(|| quote! { u: &[#ty; #u_len] });
    let u_arg_plain = has_u.then(|| quote! { u });
    let step_doc = format!(
        " One sample (Algorithm 2 of the double Kalman filter paper): runs the LKF linearised about the AKF's previous estimate \
         with the input `u[k-1]`, builds `F`, `G`, `d` from the window ending at the \
         previous sample and the same input, runs the AKF on them, each filter corrected \
         with `y[k]`; then pushes `y[k]` and `u[k-1]` into the window. Cost: \
         [`DKF_TRANSFORM_OPS`] plus [`DKF_FILTERS_OPS`]{}.",
        if model.scalars.first() == Some(&scalar) {
            ""
        } else {
            " (parent module)"
        }
    );
    let new_doc = if spec.diagonal_noise {
        " A filter starting from `x0` for both stages, with the LKF's covariance `p0` and \
         process noise variances `q` (diagonal), the AKF's `pbar0` and `qbar`, and the \
         measurement noise `r`. Symmetric matrices: only upper triangles are read."
    } else {
        " A filter starting from `x0` for both stages, with the LKF's covariance `p0` and \
         process noise `q`, the AKF's `pbar0` and `qbar`, and the measurement noise `r`. \
         Symmetric matrices: only upper triangles are read."
    };
    let tokens = quote! {
        /// Double Kalman filter (Alg. 2) of this model.
        ///
        /// Stage one, the window transform derived from the model:
        #(#[doc = #derivation])*
        ///
        /// Stage two: a linear Kalman filter (AKF) on `x[k+1] = F x[k] + G u[k] + d`, with
        /// its own covariance and process noise, then a Kalman filter (LKF) on `f`
        /// linearised about the AKF's estimate. Until the window is full the transform is
        /// taken about the AKF's own estimate. A window whose excitation is below the
        /// threshold keeps the last solved parameters (Case 1); an input that is zero over
        /// the window freezes the parameters it multiplies (Case 2).
        #[derive(Clone, Copy, Debug, PartialEq)]
        pub struct Dkf {
            outputs: [#ty; #outputs_len],
            inputs: [#ty; #inputs_len],
            filled: [bool; #window_outputs_lit],
            phi_params: [#ty; #p_len],
            window_det_sq: #ty,
            window_column_norms: #ty,
            min_excitation_sq: #ty,
            xbar: [#ty; #n_len],
            pbar: [#ty; #nn],
            qbar: #qbar_field,
            x: [#ty; #n_len],
            p: [#ty; #nn],
            q: #q_field,
            r: [#ty; #mm],
        }

        impl Dkf {
            /// Default threshold of the window's excitation measure (Case 1).
            pub const DEFAULT_MIN_EXCITATION: #ty = #default_excitation;

            #[doc = #new_doc]
            #[must_use]
            pub fn new(
                x0: [#ty; #n_len],
                p0: &[[#ty; #n_len]; #n_len],
                #q_param,
                pbar0: &[[#ty; #n_len]; #n_len],
                #qbar_param,
                r: &[[#ty; #m_len]; #m_len],
            ) -> Dkf {
                Dkf {
                    outputs: [#zero; #outputs_len],
                    inputs: [#zero; #inputs_len],
                    filled: [false; #window_outputs_lit],
                    phi_params: #params_of_x0,
                    window_det_sq: #zero,
                    window_column_norms: #zero,
                    min_excitation_sq: Self::DEFAULT_MIN_EXCITATION
                        * Self::DEFAULT_MIN_EXCITATION,
                    xbar: x0,
                    pbar: #pack_pbar0,
                    qbar: #pack_qbar,
                    x: x0,
                    p: #pack_p0,
                    q: #pack_q,
                    r: #pack_r,
                }
            }

            /// The same filter with another excitation threshold (Case 1): windows whose
            /// excitation measure is not above it keep the last solved parameters.
            #[must_use]
            pub fn with_min_excitation(mut self, min_excitation: #ty) -> Dkf {
                self.min_excitation_sq = min_excitation * min_excitation;
                self
            }

            /// The DKF's estimate (the LKF's): physical states, then parameters.
            #[must_use]
            pub fn state(&self) -> [#ty; #n_len] {
                self.x
            }

            /// The AKF's estimate.
            #[must_use]
            pub fn akf_state(&self) -> [#ty; #n_len] {
                self.xbar
            }

            /// The LKF's covariance.
            #[must_use]
            pub fn covariance(&self) -> [[#ty; #n_len]; #n_len] {
                #unpack_p
            }

            /// The AKF's covariance.
            #[must_use]
            pub fn akf_covariance(&self) -> [[#ty; #n_len]; #n_len] {
                #unpack_pbar
            }

            /// The parameters the last well-excited window gave (or those of `x0`).
            #[must_use]
            pub fn window_parameters(&self) -> [#ty; #p_len] {
                self.phi_params
            }

            /// The last window's excitation measure, `|det| / prod |column|` of its
            /// parameter system, in `0..=1` (0 while the window fills). An application can
            /// pause adaptation while it is low.
            #[must_use]
            pub fn excitation(&self) -> #ty {
                // Stored as its two squared terms: the step itself never divides them.
                if self.window_column_norms > #zero {
                    libm::#sqrt(self.window_det_sq / self.window_column_norms)
                } else {
                    #zero
                }
            }

            /// What the window holds now says of the state: `phi` (states, then
            /// parameters) reconstructed from the window that ends at the latest
            /// measurement, with `u` the input applied from then on, and the window's status.
            #[must_use]
            pub fn window_estimate(&self, #u_param_plain) -> ([#ty; #n_len], WindowStatus) {
                let (phi, window, ..) = self.transform(#u_arg_plain);
                (phi, window)
            }

            #setters

            #[doc = #step_doc]
            pub fn step(&mut self, #u_param y: &[#ty; #m_len]) -> DkfStatus {
                #step
            }

            #stages

            #transform

            #push
        }

        /// How the window transform went in a DKF step.
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        pub enum WindowStatus {
            /// The step was rejected before the window was read.
            Skipped,
            /// Too few samples yet: the transform was taken about the AKF's own estimate.
            Filling,
            /// The window determined every parameter.
            Solved,
            /// An input was zero over the window: the parameters it multiplies kept their
            /// last values and the others were solved from the reduced system (Case 2).
            InputFree,
            /// The window's excitation was below the threshold: the last solved parameters
            /// were kept (Case 1).
            Degenerate,
        }

        /// Outcome of [`Dkf::step`]: the window's, and each filter stage's.
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        #[must_use = "a filter stage that did not return `Status::Ok` left its estimate unchanged"]
        pub struct DkfStatus {
            /// What the window transform did.
            pub window: WindowStatus,
            /// What the AKF did; on anything but [`Status::Ok`] its estimate and covariance
            /// are unchanged.
            pub akf: Status,
            /// What the LKF (the DKF's estimate) did; likewise.
            pub lkf: Status,
        }

        impl DkfStatus {
            /// Whether both filter stages were applied.
            #[must_use]
            pub fn is_ok(&self) -> bool {
                self.akf == Status::Ok && self.lkf == Status::Ok
            }
        }

        #ltv

        /// Outputs the DKF's window holds, the latest included.
        pub const WINDOW_OUTPUTS: usize = #window_outputs_lit;
        /// Past inputs the DKF's window holds.
        pub const WINDOW_INPUTS: usize = #window_inputs_lit;
    };
    Ok(DkfCode {
        tokens,
        transform_ops,
        filters_ops,
    })
}

/// The window variables as `let` patterns over the stored history.
fn window_unpack(
    graph: &Graph,
    wt: &WindowTransform,
    used: &std::collections::BTreeSet<VarId>,
) -> TokenStream {
    let outputs: Vec<NodeId> = wt.outputs.iter().flatten().copied().collect();
    let inputs: Vec<NodeId> = wt.inputs.iter().flatten().copied().collect();
    let y = destructure(graph, quote! { self.outputs }, &outputs, used);
    let u = destructure(graph, quote! { self.inputs }, &inputs, used);
    quote! { #y #u }
}

/// `fn transform(&self, u) -> (phi, WindowStatus, [det_sq, column_norms], parameters)`:
/// eqs. (8)-(12).
fn transform_fn(
    model: &Model,
    mg: &ModelGraph,
    wt: &WindowTransform,
    scalar: Scalar,
) -> (TokenStream, OpCount) {
    let mut g = mg.clone();
    let np = model.params.len();
    let graph = &mut g.graph;
    let (det, numerators) = cramer(graph, &wt.matrix, &wt.rhs);
    let norms = column_norms_product(graph, &wt.matrix);
    let det_sq = graph.mul(det, det);

    // Case 2 variants: frozen subsets of the input-only parameters, largest first.
    let input_only: Vec<usize> = (0..np).filter(|&p| wt.input_only[p].is_some()).collect();
    let mut subsets: Vec<Vec<usize>> = (1..(1u32 << input_only.len()))
        .map(|mask| {
            input_only
                .iter()
                .enumerate()
                .filter(|(bit, _)| mask & (1 << bit) != 0)
                .map(|(_, &p)| p)
                .collect()
        })
        .collect();
    subsets.sort_by_key(|s: &Vec<usize>| std::cmp::Reverse(s.len()));
    struct Reduced {
        frozen: Vec<usize>,
        free: Vec<usize>,
        det: NodeId,
        det_sq: NodeId,
        norms: NodeId,
        numerators: Vec<NodeId>,
    }
    let reduced: Vec<Reduced> = subsets
        .into_iter()
        .map(|frozen| {
            let free: Vec<usize> = (0..np).filter(|p| !frozen.contains(p)).collect();
            let matrix: Matrix = wt.matrix[..free.len()]
                .iter()
                .map(|row| free.iter().map(|&p| row[p]).collect())
                .collect();
            let (det, numerators) = cramer(graph, &matrix, &wt.rhs[..free.len()]);
            let norms = column_norms_product(graph, &matrix);
            let det_sq = graph.mul(det, det);
            Reduced {
                frozen,
                free,
                det,
                det_sq,
                norms,
                numerators,
            }
        })
        .collect();

    let inv_det = graph.var("inv_det");
    let solution: Vec<NodeId> = numerators
        .iter()
        .map(|&num| graph.mul(num, inv_det))
        .collect();
    let reduced_solutions: Vec<Vec<NodeId>> = reduced
        .iter()
        .map(|r| {
            r.numerators
                .iter()
                .map(|&num| graph.mul(num, inv_det))
                .collect()
        })
        .collect();

    let mut all_roots = vec![det, det_sq, norms];
    all_roots.extend(&solution);
    for (r, sol) in reduced.iter().zip(&reduced_solutions) {
        all_roots.extend([r.det, r.det_sq, r.norms]);
        all_roots.extend(sol);
    }
    all_roots.extend(&wt.phi_states);
    let avoid = model_names(model);
    let namer = TempNamer::new(avoid.iter().map(String::as_str));
    let mut base = Lowerer::new(&g.graph, scalar, namer, &all_roots);
    let det_e = base.bind(det, "det");
    let det_sq_e = base.bind(det_sq, "det_sq");
    let norms_e = base.bind(norms, "column_norms");
    let (zero, one) = (literal(0.0, scalar), literal(1.0, scalar));
    base.count_extra(OpCount {
        div: 1,
        compare: 1,
        mul: 1,
        ..OpCount::default()
    });
    let head = base.take_statements();
    let at_fork = base.ops();

    let phi_param_idents = var_idents(&g.graph, &wt.phi_params);
    let last: Vec<Ident> = model
        .params
        .iter()
        .map(|p| ident(&format!("last_{}", p.name)))
        .collect();

    // Full solve, in a fork of the lowering so its temporaries stay in its branch.
    let mut full = base.clone();
    let full_values = full.segment(&solution);
    let full_body = full.take_statements();
    let full_ops = full.ops();

    let mut case2_branches = Vec::new();
    for (r, sol) in reduced.iter().zip(&reduced_solutions) {
        let mut fork = base.clone();
        let conditions: Vec<Ident> = r
            .frozen
            .iter()
            .flat_map(|&p| wt.input_only[p].clone().unwrap_or_default())
            .map(|node| var_idents(&g.graph, &[node]).remove(0))
            .collect();
        let det_r = fork.bind(r.det, "reduced_det");
        let det_sq_r = fork.bind(r.det_sq, "reduced_det_sq");
        let norms_r = fork.bind(r.norms, "reduced_column_norms");
        let guard = fork.take_statements();
        let values = fork.segment(sol);
        let body = fork.take_statements();
        let mut entries: Vec<TokenStream> = last.iter().map(|l| quote! { #l }).collect();
        for (&p, v) in r.free.iter().zip(values) {
            entries[p] = v;
        }
        case2_branches.push(quote! {
            else if #(#conditions == #zero)&&* {
                #(#guard)*
                if #det_sq_r > threshold * #norms_r {
                    let inv_det = #one / #det_r;
                    #(#body)*
                    ([#(#entries),*], WindowStatus::InputFree)
                } else {
                    (self.phi_params, WindowStatus::Degenerate)
                }
            }
        });
    }

    let phi_values = base.segment(&wt.phi_states);
    let tail = base.take_statements();
    let Lowered { used_vars, ops, .. } = base.finish();
    let mut used = used_vars;
    // The branches read window variables too; unpack every window variable they use.
    for node in wt
        .outputs
        .iter()
        .flatten()
        .chain(wt.inputs.iter().flatten())
    {
        if let crate::symbolic::Node::Var(v) = g.graph.node(*node) {
            used.insert(v);
        }
    }
    let unpack_window = window_unpack(&g.graph, wt, &used);
    let unpack_u = destructure(&g.graph, quote! { *u }, &g.u, &used);
    let ty = ident(scalar.type_name());
    let u_param = (!g.u.is_empty()).then(|| {
        let len = Literal::usize_unsuffixed(g.u.len());
        let name = if unpack_u.is_some() {
            ident("u")
        } else {
            ident("_u")
        };
        quote! { #name: &[#ty; #len] }
    });
    let n = Literal::usize_unsuffixed(model.state_len());
    let np_len = Literal::usize_unsuffixed(np);
    let phi_states = phi_values;
    let tokens = quote! {
        /// The window transform: the reconstructed `phi` (states, then parameters), the
        /// window's status, the squared determinant and product of squared column norms
        /// of its parameter system (whose ratio is the squared excitation measure), and
        /// the parameters to keep: those solved, else the last solved (eqs. 8-12).
        #[allow(clippy::type_complexity)]
        fn transform(&self, #u_param) -> ([#ty; #n], WindowStatus, [#ty; 2], [#ty; #np_len]) {
            let [.., full] = self.filled;
            if !full {
                return (self.xbar, WindowStatus::Filling, [#zero, #zero], self.phi_params);
            }
            #unpack_u
            #unpack_window
            #(#head)*
            let threshold = self.min_excitation_sq;
            let [#(#last),*] = self.phi_params;
            let ([#(#phi_param_idents),*], window) = if #det_sq_e > threshold * #norms_e {
                let inv_det = #one / #det_e;
                #(#full_body)*
                ([#(#full_values),*], WindowStatus::Solved)
            }
            #(#case2_branches)*
            else {
                ([#(#last),*], WindowStatus::Degenerate)
            };
            #(#tail)*
            (
                [#(#phi_states,)* #(#phi_param_idents),*],
                window,
                [#det_sq_e, #norms_e],
                [#(#phi_param_idents),*],
            )
        }
    };
    // The costliest path: the common code plus the full solve's branch.
    (tokens, ops.plus(full_ops.minus(at_fork)))
}

/// One stage of the DKF's filtering, lowered into its own method: it reads what it needs
/// where it first needs it and commits its own estimate and covariance, so the two stages
/// never hold their results at once.
struct Stage<'a> {
    /// Method name (`akf_step`, `lkf_step`).
    name: &'static str,
    /// Its documentation.
    doc: &'static str,
    /// Extra parameters before `u_prev` and `y` (the AKF's `phi`).
    params: TokenStream,
    /// Arrays read lazily, with the variables they hold.
    reads: Vec<(TokenStream, &'a [NodeId])>,
    /// The stage's measurement update.
    update: kalman::Update,
    /// Suffix of its pivot names (`_bar` for the AKF).
    suffix: &'static str,
    /// Fields it stores into: estimate, packed covariance.
    fields: (TokenStream, TokenStream),
    /// Names of its new estimate's entries.
    result_names: Vec<String>,
    /// Variables the stage computes before use, with their values.
    definitions: Vec<(NodeId, NodeId)>,
}

fn stage_method(
    g: &ModelGraph,
    avoid: &[String],
    scalar: Scalar,
    stage: Stage,
) -> (TokenStream, OpCount) {
    let Stage {
        name,
        doc,
        params,
        reads,
        update,
        suffix,
        fields: (x_field, p_field),
        result_names,
        definitions,
    } = stage;
    let n = update.x.len();
    let mut graph = g.graph.clone();
    let probe = finiteness_probe(&mut graph, &update.x, &update.p);
    let p_new = packed_upper(&update.p);
    let results: Vec<NodeId> = update.x.iter().chain(&p_new).copied().collect();
    let mut all_roots = results.clone();
    all_roots.push(probe);
    all_roots.extend(&update.pivots);
    let namer = TempNamer::new(avoid.iter().map(String::as_str));
    let mut lowerer = Lowerer::new(&graph, scalar, namer, &all_roots);
    for (source, vars) in &reads {
        lowerer.read_lazily(source, vars);
    }
    for (var, value) in definitions {
        lowerer.define(var, value);
    }
    for (&node, result) in update.x.iter().zip(&result_names) {
        lowerer.prefer_name(node, result);
    }
    guard_pivots(
        &mut lowerer,
        &update.pivots,
        &update.reciprocals,
        (INNOVATION, suffix),
        &quote! { return Status::NonPositiveInnovation; },
        scalar,
    );
    let probe = lowerer.segment(&[probe]).remove(0);
    let values = lowerer.segment(&results);
    let Lowered {
        statements, ops, ..
    } = lowerer.finish();
    let (x_values, p_values) = values.split_at(n);
    let name = ident(name);
    let doc = format!(" {doc}");
    let tokens = quote! {
        #[doc = #doc]
        fn #name(&mut self, #params) -> Status {
            #(#statements)*
            if !(#probe).is_finite() {
                return Status::NonFinite;
            }
            self.#x_field = [#(#x_values),*];
            self.#p_field = [#(#p_values),*];
            Status::Ok
        }
    };
    (tokens, ops)
}

/// The DKF's step (Alg. 2) after the transform: its body, the two stage methods, and
/// what the stages compute.
fn step_fn(
    model: &Model,
    mg: &mut ModelGraph,
    wt: &WindowTransform,
    scalar: Scalar,
    diagonal_noise: bool,
) -> (TokenStream, TokenStream, OpCount) {
    let g = mg;
    let n = model.state_len();
    let m = model.outputs.len();
    let mut avoid = model_names(model);
    avoid.extend(["phi", "window", "excitation"].map(String::from));
    let graph = &mut g.graph;
    let xbar: Vec<NodeId> = model
        .state_names()
        .map(|s| graph.var(&format!("{s}_bar")))
        .collect();
    let y_vars: Vec<NodeId> = model
        .outputs
        .iter()
        .map(|o| graph.var(&format!("{}_measured", o.name)))
        .collect();
    let pbar_vars = packed_vars(graph, "pbar", n, &avoid);
    let (qbar_vars, qbar) = noise_vars(graph, "qbar", n, diagonal_noise, &avoid);
    let p_vars = packed_vars(graph, "p", n, &avoid);
    let (q_vars, q) = noise_vars(graph, "q", n, diagonal_noise, &avoid);
    let r_vars = packed_vars(graph, "r", m, &avoid);
    let pbar = symmetric_from_packed(&pbar_vars, n);
    let p = symmetric_from_packed(&p_vars, n);
    let r = symmetric_from_packed(&r_vars, m);
    let x_vars: Vec<VarId> = g.x.iter().map(|&x| g.var_id(x)).collect();
    let c = g.jacobian_h_wrt_x();
    let a = g.jacobian_f_wrt_x();
    let graph = &mut g.graph;
    let at = |graph: &mut Graph, node: NodeId, point: &[NodeId]| {
        let map: Vec<(VarId, NodeId)> = x_vars.iter().copied().zip(point.iter().copied()).collect();
        substitute(graph, node, &map)
    };
    let correct = |graph: &mut Graph, x: &[NodeId], p: &Matrix, suffix: &str| {
        let residual: Vec<NodeId> = y_vars
            .iter()
            .zip(&g.h)
            .map(|(&y, &h)| {
                let h = at(graph, h, x);
                graph.sub(y, h)
            })
            .collect();
        let c_at: Matrix = c
            .iter()
            .map(|row| row.iter().map(|&e| at(graph, e, x)).collect())
            .collect();
        kalman::update(graph, x, p, &residual, &c_at, &r, |g, j| {
            g.var(&pivot_names(m, j, INNOVATION, suffix).1)
        })
    };

    // AKF: x = F x + G u + d; P = F P F' + Qbar; update with y. F and G's computed
    // entries are variables the stage defines once (see `Lowerer::define`).
    let mut akf_definitions = Vec::new();
    let f = entry_vars(graph, &wt.f, "f", &avoid, &mut akf_definitions);
    let g_matrix = entry_vars(graph, &wt.g, "g", &avoid, &mut akf_definitions);
    let xbar_col: Matrix = xbar.iter().map(|&v| vec![v]).collect();
    let u_col: Matrix = g.u.iter().map(|&v| vec![v]).collect();
    let fx = matmul(graph, &f, &xbar_col);
    let gu = matmul(graph, &g_matrix, &u_col);
    let xbar_pred: Vec<NodeId> = (0..n)
        .map(|i| {
            let mut sum = graph.add(fx[i][0], wt.d[i]);
            if let Some(row) = gu.get(i).filter(|row| !row.is_empty()) {
                sum = graph.add(sum, row[0]);
            }
            sum
        })
        .collect();
    let pbar_pred = kalman::predict_covariance(graph, &f, &pbar, &qbar);
    let akf = correct(graph, &xbar_pred, &pbar_pred, "_bar");

    // LKF: linearise f about the AKF's previous estimate with the actual input.
    let f_at_bar: Vec<NodeId> = g.f.iter().map(|&f| at(graph, f, &xbar)).collect();
    let a_bar: Matrix = a
        .iter()
        .map(|row| row.iter().map(|&e| at(graph, e, &xbar)).collect())
        .collect();
    let deviation: Matrix =
        g.x.iter()
            .zip(&xbar)
            .map(|(&x, &xb)| vec![graph.sub(x, xb)])
            .collect();
    let a_dev = matmul(graph, &a_bar, &deviation);
    // A row of `f` affine in the state has a Jacobian row free of the state, and then
    // f(xbar) + A (x - xbar) is exactly f(x): that is computed instead, with fewer roundings.
    let x_pred: Vec<NodeId> = (0..n)
        .map(|i| {
            let mut read = std::collections::BTreeSet::new();
            for &entry in &a[i] {
                window::free_vars(graph, entry, &mut read);
            }
            if x_vars.iter().any(|x| read.contains(x)) {
                graph.add(f_at_bar[i], a_dev[i][0])
            } else {
                g.f[i]
            }
        })
        .collect();
    let p_pred = kalman::predict_covariance(graph, &a_bar, &p, &q);
    let lkf = correct(graph, &x_pred, &p_pred, "");

    let ty = ident(scalar.type_name());
    let (u_len, y_len, n_len) = (
        Literal::usize_unsuffixed(model.inputs.len()),
        Literal::usize_unsuffixed(m),
        Literal::usize_unsuffixed(n),
    );
    let u_param = (!g.u.is_empty()).then(|| quote! { u_prev: &[#ty; #u_len], });
    let g: &ModelGraph = g;
    let lkf_reads = vec![
        (quote! { self.xbar }, &xbar[..]),
        (quote! { self.x }, &g.x[..]),
        (quote! { self.p }, &p_vars[..]),
        (quote! { self.q }, &q_vars[..]),
        (quote! { self.r }, &r_vars[..]),
        (quote! { *u_prev }, &g.u[..]),
        (quote! { *y }, &y_vars[..]),
    ];
    let akf_reads = vec![
        (quote! { *phi }, &wt.phi[..]),
        (quote! { self.xbar }, &xbar[..]),
        (quote! { self.pbar }, &pbar_vars[..]),
        (quote! { self.qbar }, &qbar_vars[..]),
        (quote! { self.r }, &r_vars[..]),
        (quote! { *u_prev }, &g.u[..]),
        (quote! { *y }, &y_vars[..]),
    ];
    let names = |suffix: &str| -> Vec<String> {
        model
            .state_names()
            .map(|s| format!("{s}{suffix}_new"))
            .collect()
    };
    let (lkf_method, lkf_ops) = stage_method(
        g,
        &avoid,
        scalar,
        Stage {
            name: "lkf_step",
            doc: "The LKF (Algorithm 2 of the double Kalman filter paper): `f` linearised about the AKF's estimate of the previous \
                  sample with the input `u[k-1]`, then corrected with `y[k]` (Joseph form).",
            params: quote! { #u_param y: &[#ty; #y_len] },
            reads: lkf_reads,
            update: lkf,
            suffix: "",
            fields: (quote! { x }, quote! { p }),
            result_names: names(""),
            definitions: Vec::new(),
        },
    );
    let (akf_method, akf_ops) = stage_method(
        g,
        &avoid,
        scalar,
        Stage {
            name: "akf_step",
            doc: "The AKF (Algorithm 2 of the double Kalman filter paper): a linear Kalman filter on the transformed model at `phi`, \
                  then corrected with `y[k]` (Joseph form).",
            params: quote! { phi: &[#ty; #n_len], #u_param y: &[#ty; #y_len] },
            reads: akf_reads,
            update: akf,
            suffix: "_bar",
            fields: (quote! { xbar }, quote! { pbar }),
            result_names: names("_bar"),
            definitions: akf_definitions,
        },
    );

    let graph = &g.graph;
    let u_idents = var_idents(graph, &g.u);
    let y_idents = var_idents(graph, &y_vars);
    let checked: Vec<Ident> = u_idents.iter().chain(&y_idents).cloned().collect();
    // One test and branch per value: joined by `&&`, the tests are combined into flags
    // before one branch, which costs more on the target.
    let reject_non_finite = checked.iter().map(|v| {
        quote! {
            if !#v.is_finite() {
                return self.reject_sample();
            }
        }
    });
    let unpack_u = (!g.u.is_empty()).then(|| quote! { let [#(#u_idents),*] = *u_prev; });
    let u_arg = (!g.u.is_empty()).then(|| quote! { u_prev, });
    let body = quote! {
        #unpack_u
        let [#(#y_idents),*] = *y;
        #(#reject_non_finite)*
        // The LKF linearises about the AKF's estimate of the previous sample: it runs
        // first, and before the transform, so that `phi` is not held across it.
        let lkf = self.lkf_step(#u_arg y);
        let (phi, window, [det_sq, column_norms], parameters) = self.transform(#u_arg);
        // The window's findings stand whatever the filters do with this sample.
        self.window_det_sq = det_sq;
        self.window_column_norms = column_norms;
        self.phi_params = parameters;
        let akf = self.akf_step(&phi, #u_arg y);
        self.push(#u_arg y);
        DkfStatus { window, akf, lkf }
    };
    let methods = quote! {
        /// A missing sample breaks the window's sequence: empties the window (it refills)
        /// and rejects the sample, leaving both filters as they were.
        fn reject_sample(&mut self) -> DkfStatus {
            self.filled = [false; WINDOW_OUTPUTS];
            DkfStatus {
                window: WindowStatus::Skipped,
                akf: Status::RejectedInput,
                lkf: Status::RejectedInput,
            }
        }

        #lkf_method

        #akf_method
    };
    (body, methods, akf_ops.plus(lkf_ops))
}

/// `matrix` with each computed entry (not a literal, constant or variable) replaced by a
/// variable `{prefix}{row}{column}` (1-based), recorded in `definitions` with its value.
fn entry_vars(
    graph: &mut Graph,
    matrix: &Matrix,
    prefix: &str,
    avoid: &[String],
    definitions: &mut Vec<(NodeId, NodeId)>,
) -> Matrix {
    let wide = matrix.len() >= 10 || matrix.first().is_some_and(|row| row.len() >= 10);
    let mut entry = |graph: &mut Graph, i: usize, j: usize, value: NodeId| {
        if graph.is_leaf(value) {
            return value;
        }
        let mut name = if wide {
            format!("{prefix}_{}_{}", i + 1, j + 1)
        } else {
            format!("{prefix}{}{}", i + 1, j + 1)
        };
        while avoid.contains(&name) {
            name.push('_');
        }
        let var = graph.var(&name);
        definitions.push((var, value));
        var
    };
    matrix
        .iter()
        .enumerate()
        .map(|(i, row)| {
            row.iter()
                .enumerate()
                .map(|(j, &value)| entry(graph, i, j, value))
                .collect()
        })
        .collect()
}

/// `fn push(&mut self, u, y)`: shifts the latest output and input into the window.
fn push_fn(model: &Model, g: &ModelGraph, wt: &WindowTransform, scalar: Scalar) -> TokenStream {
    let shift = |vars: &[Vec<NodeId>], new: &[Ident]| {
        let mut keep_pattern = Vec::new();
        let mut rebuilt = Vec::new();
        for (row, new) in vars.iter().zip(new) {
            let names = var_idents(&g.graph, row);
            rebuilt.push(quote! { #new });
            for (d, name) in names.iter().enumerate() {
                if d + 1 < names.len() {
                    keep_pattern.push(quote! { #name });
                    rebuilt.push(quote! { #name });
                } else {
                    keep_pattern.push(quote! { _ });
                }
            }
        }
        (keep_pattern, rebuilt)
    };
    let y_new: Vec<Ident> = model
        .outputs
        .iter()
        .map(|o| ident(&format!("{}_new", o.name)))
        .collect();
    let u_new: Vec<Ident> = model
        .inputs
        .iter()
        .map(|i| ident(&format!("{}_new", i.name)))
        .collect();
    let (y_keep, y_rebuilt) = shift(&wt.outputs, &y_new);
    let (u_keep, u_rebuilt) = shift(&wt.inputs, &u_new);
    let filled: Vec<Ident> = (0..=wt.output_delays)
        .map(|d| ident(&format!("f{d}")))
        .collect();
    let filled_keep: Vec<TokenStream> = filled
        .iter()
        .enumerate()
        .map(|(d, f)| {
            if d < wt.output_delays {
                quote! { #f }
            } else {
                quote! { _ }
            }
        })
        .collect();
    let filled_new = &filled[..wt.output_delays];
    let ty = ident(scalar.type_name());
    let (u_len, y_len) = (
        Literal::usize_unsuffixed(model.inputs.len()),
        Literal::usize_unsuffixed(model.outputs.len()),
    );
    let has_inputs = !model.inputs.is_empty() && wt.input_delays > 0;
    let u_param = (!model.inputs.is_empty()).then(|| {
        let name = if has_inputs { ident("u") } else { ident("_u") };
        quote! { #name: &[#ty; #u_len], }
    });
    let inputs = has_inputs.then(|| {
        quote! {
            let [#(#u_new),*] = *u;
            let [#(#u_keep),*] = self.inputs;
            self.inputs = [#(#u_rebuilt),*];
        }
    });
    quote! {
        /// Shifts `y[k]` and `u[k-1]` into the window, dropping the oldest.
        fn push(&mut self, #u_param y: &[#ty; #y_len]) {
            let [#(#y_new),*] = *y;
            let [#(#y_keep),*] = self.outputs;
            self.outputs = [#(#y_rebuilt),*];
            #inputs
            let [#(#filled_keep),*] = self.filled;
            self.filled = [true, #(#filled_new),*];
        }
    }
}

/// `pub fn ltv_model(phi, u) -> (F, G, d)`: eq. (12) at a reconstructed point.
fn ltv_fn(model: &Model, mg: &ModelGraph, wt: &WindowTransform, scalar: Scalar) -> TokenStream {
    let n = model.state_len();
    let nu = model.inputs.len();
    let roots: Vec<NodeId> =
        wt.f.iter()
            .flatten()
            .chain(wt.g.iter().flatten())
            .chain(&wt.d)
            .copied()
            .collect();
    let avoid = model_names(model);
    let namer = TempNamer::new(avoid.iter().map(String::as_str));
    let mut lowerer = Lowerer::new(&mg.graph, scalar, namer, &roots);
    let values = lowerer.segment(&roots);
    let Lowered {
        statements,
        used_vars,
        ..
    } = lowerer.finish();
    let (f_values, rest) = values.split_at(n * n);
    let (g_values, d_values) = rest.split_at(n * nu);
    let f_rows = f_values.chunks(n).map(|row| quote! { [#(#row),*] });
    let g_rows: Vec<TokenStream> = if nu == 0 {
        (0..n).map(|_| quote! { [] }).collect()
    } else {
        g_values
            .chunks(nu)
            .map(|row| quote! { [#(#row),*] })
            .collect()
    };
    let ty = ident(scalar.type_name());
    let (n_len, u_len) = (Literal::usize_unsuffixed(n), Literal::usize_unsuffixed(nu));
    let phi_name = if wt.phi.iter().any(|&v| reads(&mg.graph, v, &used_vars)) {
        ident("phi")
    } else {
        ident("_phi")
    };
    let u_name = if mg.u.iter().any(|&v| reads(&mg.graph, v, &used_vars)) {
        ident("u")
    } else {
        ident("_u")
    };
    let unpack_phi = destructure(&mg.graph, quote! { *#phi_name }, &wt.phi, &used_vars);
    let unpack_u = destructure(&mg.graph, quote! { *#u_name }, &mg.u, &used_vars);
    quote! {
        /// The window transform's model at the reconstructed point `phi` with input `u`
        /// (eq. 12): `(F, G, d)` with `x[k+1] = F x[k] + G u[k] + d`, exact at `x = phi`.
        #[must_use]
        pub fn ltv_model(#phi_name: &[#ty; #n_len], #u_name: &[#ty; #u_len]) -> ([[#ty; #n_len]; #n_len], [[#ty; #u_len]; #n_len], [#ty; #n_len]) {
            #unpack_phi
            #unpack_u
            #(#statements)*
            ([#(#f_rows),*], [#(#g_rows),*], [#(#d_values),*])
        }
    }
}

fn reads(graph: &Graph, node: NodeId, used: &std::collections::BTreeSet<VarId>) -> bool {
    matches!(graph.node(node), crate::symbolic::Node::Var(v) if used.contains(&v))
}
