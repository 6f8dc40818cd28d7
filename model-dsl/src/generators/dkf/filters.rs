//! The DKF's two Kalman filters (Alg. 2) after the window transform: the AKF, a linear
//! Kalman filter on the transformed model `x[k+1] = F x[k] + G u[k] + d` (eq. 12), and
//! the LKF, a Kalman filter on `f` linearised about the AKF's previous estimate. Both
//! predict their covariance and take the Joseph-form update through the shared stage
//! ([`crate::symbolic::kalman`]); each is lowered into its own method.

use super::spec::DkfSpec;
use super::window::{self, WindowTransform};
use crate::emit::code::{
    guard_pivots, innovation_pivot_failure, packed_diagonal, pivot_names, reject_diverged,
    var_idents, INNOVATION,
};
use crate::emit::filter::{finiteness_probe, model_names, noise_vars, packed_vars, ProcessNoise};
use crate::emit::lower::{Lowered, Lowerer, OpCount};
use crate::emit::measurement;
use crate::emit::names::{ident, TempNamer};
use crate::model::{Model, Scalar};
use crate::symbolic::kalman;
use crate::symbolic::linalg::{matmul, packed_upper, symmetric_from_packed, Coefficients, Matrix};
use crate::symbolic::substitute;
use crate::symbolic::{Graph, ModelGraph, NodeId, VarId};
use proc_macro2::{Ident, Literal, TokenStream};
use quote::quote;

/// The DKF's filters after the transform, as [`step_fn`] lowers them.
pub struct FilterCode {
    /// The body of `step`.
    pub step: TokenStream,
    /// The body of `predict`.
    pub predict: TokenStream,
    /// The stage methods: each filter's step and prediction alone, and with a gate the
    /// cold keepers that call the predictions.
    pub methods: TokenStream,
    /// What the two filters' steps compute.
    pub ops: OpCount,
}

/// The DKF's step (Alg. 2) and prediction after the transform.
pub fn step_fn(
    model: &Model,
    mg: &mut ModelGraph,
    wt: &WindowTransform,
    scalar: Scalar,
    spec: &DkfSpec,
) -> FilterCode {
    let g = mg;
    let mut avoid = model_names(model);
    avoid.extend(["phi", "window", "excitation"].map(String::from));
    let least_squares = wt.least_squares();
    let vars = FilterVars::new(
        model,
        &mut g.graph,
        &avoid,
        spec.diagonal_noise,
        least_squares,
    );
    let x_vars: Vec<VarId> = g.x.iter().map(|&x| g.var_id(x)).collect();
    let c = g.jacobian_h_wrt_x();
    let a = g.jacobian_f_wrt_x();
    let linearised = Linearised {
        x_vars,
        x: &g.x,
        f: &g.f,
        a,
        h: &g.h,
        c,
        y: &vars.y,
        r: &vars.r,
    };
    let graph = &mut g.graph;
    let (xbar_pred, pbar_pred, akf_definitions) = akf_prediction(graph, wt, &vars, &g.u, &avoid);
    let akf = linearised.correct(graph, &xbar_pred, &pbar_pred, "_bar");
    let (x_pred, p_pred) = linearised.lkf_prediction(graph, &vars);
    let lkf = linearised.correct(graph, &x_pred, &p_pred, "");

    let g: &ModelGraph = g;
    let step = StepLowering {
        model,
        g,
        vars: &vars,
        avoid: &avoid,
        scalar,
        gate: spec.gate,
        recovers: spec.recover_after.is_some(),
        least_squares,
    };
    let (lkf_method, lkf_ops) = step.stage_method(step.lkf_stage(lkf));
    let akf_stage = step.akf_stage(wt, akf, akf_definitions.clone());
    let (akf_method, akf_ops) = step.stage_method(akf_stage);
    let lkf_prediction = step.lkf_stage(Corrected::prediction(x_pred, p_pred));
    let (lkf_predict, _) = step.stage_method(lkf_prediction);
    let akf_prediction = step.akf_stage(
        wt,
        Corrected::prediction(xbar_pred, pbar_pred),
        akf_definitions,
    );
    let (akf_predict, _) = step.stage_method(akf_prediction);
    let keepers = spec.gate.map(|_| step.keepers());
    let stages = [lkf_method, akf_method, lkf_predict, akf_predict];
    FilterCode {
        step: step.body(true),
        predict: step.body(false),
        methods: stage_methods(stages, keepers),
        ops: akf_ops.plus(lkf_ops),
    }
}

/// The DKF's private methods: `reject_sample`, the stages' and the gate's keepers.
fn stage_methods(stages: [TokenStream; 4], keepers: Option<TokenStream>) -> TokenStream {
    let [lkf_method, akf_method, lkf_predict, akf_predict] = stages;
    quote! {
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

        #lkf_predict

        #akf_predict

        #keepers
    }
}

/// What a filter stage computes: its new estimate and covariance, the pivots its update
/// guards, and what it keeps of the measurement (none for a prediction alone).
struct Corrected {
    x: Vec<NodeId>,
    p: Matrix,
    pivots: Vec<NodeId>,
    reciprocals: Vec<NodeId>,
    /// The innovation, its packed covariance and its normalised square.
    measured: Option<(Vec<NodeId>, Vec<NodeId>, NodeId)>,
}

impl Corrected {
    /// A correction through the shared Kalman stage, with its innovation `residual`.
    fn update(update: kalman::Update, residual: Vec<NodeId>) -> Corrected {
        Corrected {
            measured: Some((residual, packed_upper(&update.s), update.nis)),
            x: update.x,
            p: update.p,
            pivots: update.pivots,
            reciprocals: update.reciprocals,
        }
    }

    /// A prediction alone: what a gated stage keeps when it rejects an outlier.
    fn prediction(x: Vec<NodeId>, p: Matrix) -> Corrected {
        Corrected {
            x,
            p,
            pivots: Vec::new(),
            reciprocals: Vec::new(),
            measured: None,
        }
    }
}

/// The variables of the two filters' state and tuning: the AKF's estimate, covariance
/// and process noise, the LKF's covariance and process noise, the shared measurement
/// noise, and the measurement.
struct FilterVars {
    xbar: Vec<NodeId>,
    y: Vec<NodeId>,
    pbar_vars: Vec<NodeId>,
    qbar_vars: Vec<NodeId>,
    p_vars: Vec<NodeId>,
    q_vars: Vec<NodeId>,
    r_vars: Vec<NodeId>,
    /// The least-squares window's packed parameter covariance (empty for the minimum
    /// window).
    window_covariance: Vec<NodeId>,
    pbar: Matrix,
    qbar: Matrix,
    p: Matrix,
    q: Matrix,
    r: Matrix,
}

impl FilterVars {
    /// Declares the variables, named apart from `avoid`.
    fn new(
        model: &Model,
        graph: &mut Graph,
        avoid: &[String],
        diagonal_noise: bool,
        least_squares: bool,
    ) -> Self {
        let n = model.state_len();
        let m = model.outputs.len();
        let xbar: Vec<NodeId> = model
            .state_names()
            .map(|s| graph.var(&format!("{s}_bar")))
            .collect();
        let y: Vec<NodeId> = model
            .outputs
            .iter()
            .map(|o| graph.var(&format!("{}_measured", o.name)))
            .collect();
        let pbar_vars = packed_vars(graph, "pbar", n, avoid);
        let noise = ProcessNoise {
            diagonal: diagonal_noise,
            on: None,
        };
        let (qbar_vars, qbar) = noise_vars(graph, "qbar", n, &noise, avoid);
        let p_vars = packed_vars(graph, "p", n, avoid);
        let (q_vars, q) = noise_vars(graph, "q", n, &noise, avoid);
        let r_vars = packed_vars(graph, "r", m, avoid);
        let window_covariance = if least_squares {
            packed_vars(graph, "phi_cov", model.params.len(), avoid)
        } else {
            Vec::new()
        };
        FilterVars {
            window_covariance,
            pbar: symmetric_from_packed(&pbar_vars, n),
            p: symmetric_from_packed(&p_vars, n),
            r: symmetric_from_packed(&r_vars, m),
            xbar,
            y,
            pbar_vars,
            qbar_vars,
            p_vars,
            q_vars,
            r_vars,
            qbar,
            q,
        }
    }
}

/// The AKF's prediction on the transformed model (eq. 12): `xbar = F xbar + G u + d`, and
/// `Pbar = F Pbar F' + Qbar`. `F`'s and `G`'s computed entries are variables the stage
/// defines once (see `Lowerer::define`), returned with their values.
fn akf_prediction(
    graph: &mut Graph,
    wt: &WindowTransform,
    vars: &FilterVars,
    u: &[NodeId],
    avoid: &[String],
) -> (Vec<NodeId>, Matrix, Vec<(NodeId, NodeId)>) {
    let mut coefficients = Coefficients::new(avoid);
    let f = coefficients.bind(graph, &wt.f, "f");
    let g_matrix = coefficients.bind(graph, &wt.g, "g");
    let xbar_pred = transformed_prediction(graph, (&f, &g_matrix, &wt.d), &vars.xbar, u);
    let qbar = with_window_uncertainty(graph, wt, vars, u);
    let pbar_pred = kalman::predict_covariance(graph, &f, &vars.pbar, &qbar);
    (xbar_pred, pbar_pred, coefficients.definitions)
}

/// The transformed model's prediction `F x + G u + d` (eq. 12).
fn transformed_prediction(
    graph: &mut Graph,
    (f, g, d): (&Matrix, &Matrix, &[NodeId]),
    x: &[NodeId],
    u: &[NodeId],
) -> Vec<NodeId> {
    let x_col: Matrix = x.iter().map(|&v| vec![v]).collect();
    let u_col: Matrix = u.iter().map(|&v| vec![v]).collect();
    let fx = matmul(graph, f, &x_col);
    let gu = matmul(graph, g, &u_col);
    (0..x.len())
        .map(|i| {
            let mut sum = graph.add(fx[i][0], d[i]);
            if let Some(row) = gu.get(i).filter(|row| !row.is_empty()) {
                sum = graph.add(sum, row[0]);
            }
            sum
        })
        .collect()
}

/// The AKF's process noise with a least-squares window's uncertainty carried in:
/// `Qbar + J C J'`, with `C` the window's parameter covariance and `J` the derivative of
/// the transformed model's prediction `F xbar + G u + d` (eq. 12) with respect to the
/// window's parameters, the reconstructed states held (first order in the parameters'
/// error). `Qbar` itself for the minimum window.
fn with_window_uncertainty(
    graph: &mut Graph,
    wt: &WindowTransform,
    vars: &FilterVars,
    u: &[NodeId],
) -> Matrix {
    if vars.window_covariance.is_empty() {
        return vars.qbar.clone();
    }
    let n = vars.xbar.len();
    let np = wt.phi_params.len();
    let covariance = symmetric_from_packed(&vars.window_covariance, np);
    let prediction = transformed_prediction(graph, (&wt.f, &wt.g, &wt.d), &vars.xbar, u);
    let jacobian: Matrix = prediction
        .iter()
        .map(|&row| {
            wt.phi[n - np..]
                .iter()
                .map(|&phi| match graph.node(phi) {
                    crate::symbolic::Node::Var(v) => {
                        crate::symbolic::diff::Differentiator::new(v).diff(graph, row)
                    }
                    _ => graph.zero(),
                })
                .collect()
        })
        .collect();
    kalman::predict_covariance(graph, &jacobian, &covariance, &vars.qbar)
}

/// The model's step and measurement as the filters linearise them: `f` and its Jacobian
/// `A`, `h` and its Jacobian `C`, over the state variables, each evaluated at a point by
/// substitution.
struct Linearised<'a> {
    x_vars: Vec<VarId>,
    x: &'a [NodeId],
    f: &'a [NodeId],
    a: Matrix,
    h: &'a [NodeId],
    c: Matrix,
    /// The measurement, `y[k]`.
    y: &'a [NodeId],
    /// Its noise covariance.
    r: &'a Matrix,
}

impl Linearised<'_> {
    /// `node` with the state at `point`.
    fn at(&self, graph: &mut Graph, node: NodeId, point: &[NodeId]) -> NodeId {
        let map: Vec<(VarId, NodeId)> = self
            .x_vars
            .iter()
            .copied()
            .zip(point.iter().copied())
            .collect();
        substitute(graph, node, &map)
    }

    /// The measurement update of the prediction `x`, `p` with `y`, `h` and `C` taken at
    /// `x` (the shared Joseph-form update); `suffix` names its pivots apart.
    fn correct(&self, graph: &mut Graph, x: &[NodeId], p: &Matrix, suffix: &str) -> Corrected {
        let residual: Vec<NodeId> = self
            .y
            .iter()
            .zip(self.h)
            .map(|(&y, &h)| {
                let h = self.at(graph, h, x);
                graph.sub(y, h)
            })
            .collect();
        let c_at: Matrix = self
            .c
            .iter()
            .map(|row| row.iter().map(|&e| self.at(graph, e, x)).collect())
            .collect();
        let m = self.y.len();
        let update = kalman::update(graph, x, p, &residual, &c_at, self.r, |g, j| {
            g.var(&pivot_names(m, j, INNOVATION, suffix).1)
        });
        Corrected::update(update, residual)
    }

    /// The LKF's prediction: `f` linearised about the AKF's previous estimate `xbar` with
    /// the actual input, `x = f(xbar) + A(xbar) (x - xbar)`, and `P = A P A' + Q`.
    fn lkf_prediction(&self, graph: &mut Graph, vars: &FilterVars) -> (Vec<NodeId>, Matrix) {
        let xbar = &vars.xbar;
        let f_at_bar: Vec<NodeId> = self.f.iter().map(|&f| self.at(graph, f, xbar)).collect();
        let a_bar: Matrix = self
            .a
            .iter()
            .map(|row| row.iter().map(|&e| self.at(graph, e, xbar)).collect())
            .collect();
        let deviation: Matrix = self
            .x
            .iter()
            .zip(xbar)
            .map(|(&x, &xb)| vec![graph.sub(x, xb)])
            .collect();
        let a_dev = matmul(graph, &a_bar, &deviation);
        // A row of `f` affine in the state has a Jacobian row free of the state, and then
        // f(xbar) + A (x - xbar) is exactly f(x): that is computed instead, with fewer roundings.
        let x_pred: Vec<NodeId> = (0..self.f.len())
            .map(|i| {
                let mut read = std::collections::BTreeSet::new();
                for &entry in &self.a[i] {
                    window::free_vars(graph, entry, &mut read);
                }
                if self.x_vars.iter().any(|x| read.contains(x)) {
                    graph.add(f_at_bar[i], a_dev[i][0])
                } else {
                    self.f[i]
                }
            })
            .collect();
        let p_pred = kalman::predict_covariance(graph, &a_bar, &vars.p, &vars.q);
        (x_pred, p_pred)
    }
}

/// One stage of the DKF's filtering, lowered into its own method: it reads what it needs
/// where it first needs it and commits its own estimate and covariance, so the two stages
/// never hold their results at once.
struct Stage<'a> {
    /// Method name (`akf_step`, `lkf_step`; `akf_predict`, `lkf_predict`).
    name: String,
    /// Its documentation.
    doc: String,
    /// Its parameters: the AKF's `phi`, `u_prev`, and `y` for a correction.
    params: TokenStream,
    /// Arrays read lazily, with the variables they hold.
    reads: Vec<(TokenStream, &'a [NodeId])>,
    /// What the stage computes.
    corrected: Corrected,
    /// The filter, which names its methods and innovation fields.
    filter: Filter,
    /// Suffix of its pivot names (`_bar` for the AKF).
    suffix: &'static str,
    /// Fields it stores into: estimate, packed covariance.
    fields: (TokenStream, TokenStream),
    /// Names of its new estimate's entries.
    result_names: Vec<String>,
    /// Variables the stage computes before use, with their values.
    definitions: Vec<(NodeId, NodeId)>,
    /// The arguments its prediction takes (`phi`, `u_prev`), which a gated step passes on
    /// to its keeper.
    prediction_args: Vec<TokenStream>,
}

/// What the step's lowering shares: the model, its graph with both filters' updates, the
/// filters' variables and the names to avoid.
struct StepLowering<'a> {
    model: &'a Model,
    g: &'a ModelGraph,
    vars: &'a FilterVars,
    avoid: &'a [String],
    scalar: Scalar,
    gate: Option<f64>,
    /// Whether a filter's refusal goes through its recovery (`recover_after`).
    recovers: bool,
    /// Whether the window is solved by least squares, with a parameter covariance.
    least_squares: bool,
}

impl<'a> StepLowering<'a> {
    /// `[u_prev: &[S; U_LEN]]`, or nothing for a model without inputs.
    fn u_param(&self) -> Vec<TokenStream> {
        let ty = ident(self.scalar.type_name());
        let u_len = Literal::usize_unsuffixed(self.model.inputs.len());
        (!self.g.u.is_empty())
            .then(|| quote! { u_prev: &[#ty; #u_len] })
            .into_iter()
            .collect()
    }

    /// `y: &[S; Y_LEN]` for a correction; nothing for a prediction alone.
    fn y_param(&self, corrected: &Corrected) -> Option<TokenStream> {
        let ty = ident(self.scalar.type_name());
        let y_len = Literal::usize_unsuffixed(self.model.outputs.len());
        corrected
            .measured
            .is_some()
            .then(|| quote! { y: &[#ty; #y_len] })
    }

    /// `u_prev` where the model has inputs.
    fn u_arg(&self) -> Vec<TokenStream> {
        if self.g.u.is_empty() {
            Vec::new()
        } else {
            vec![quote! { u_prev }]
        }
    }

    /// The names of a stage's new estimate's entries (`x1_new`, `x1_bar_new`; `_pred`
    /// for a prediction alone).
    fn result_names(&self, suffix: &str, corrected: &Corrected) -> Vec<String> {
        let end = if corrected.measured.is_some() {
            "new"
        } else {
            "pred"
        };
        self.model
            .state_names()
            .map(|s| format!("{s}{suffix}_{end}"))
            .collect()
    }

    /// The LKF's method, `lkf_step` (or `lkf_predict`).
    fn lkf_stage(&self, corrected: Corrected) -> Stage<'a> {
        let (g, vars) = (self.g, self.vars);
        let (u_param, y_param) = (self.u_param(), self.y_param(&corrected));
        let doc = "The LKF (Algorithm 2 of the double Kalman filter paper): `f` linearised about the AKF's estimate of the \
                   previous sample with the input `u[k-1]`";
        Stage {
            name: stage_name(Filter::Lkf, &corrected),
            doc: stage_doc(doc, &corrected),
            params: quote! { #(#u_param,)* #y_param },
            reads: vec![
                (quote! { self.xbar }, &vars.xbar[..]),
                (quote! { self.x }, &g.x[..]),
                (quote! { self.p }, &vars.p_vars[..]),
                (quote! { self.q }, &vars.q_vars[..]),
                (quote! { self.r }, &vars.r_vars[..]),
                (quote! { *u_prev }, &g.u[..]),
                (quote! { *y }, &vars.y[..]),
            ],
            result_names: self.result_names("", &corrected),
            corrected,
            filter: Filter::Lkf,
            suffix: "",
            fields: (quote! { x }, quote! { p }),
            definitions: Vec::new(),
            prediction_args: self.u_arg(),
        }
    }

    /// The AKF's method, `akf_step` (or `akf_predict`), which reads the transform's `phi`.
    fn akf_stage(
        &self,
        wt: &'a WindowTransform,
        corrected: Corrected,
        definitions: Vec<(NodeId, NodeId)>,
    ) -> Stage<'a> {
        let (g, vars) = (self.g, self.vars);
        let ty = ident(self.scalar.type_name());
        let n_len = Literal::usize_unsuffixed(self.model.state_len());
        let (u_param, y_param) = (self.u_param(), self.y_param(&corrected));
        let doc = "The AKF (Algorithm 2 of the double Kalman filter paper): a linear Kalman filter on the transformed \
                   model at `phi`";
        let mut prediction_args = vec![quote! { phi }];
        prediction_args.extend(self.u_arg());
        Stage {
            name: stage_name(Filter::Akf, &corrected),
            doc: stage_doc(doc, &corrected),
            params: quote! { phi: &[#ty; #n_len], #(#u_param,)* #y_param },
            reads: vec![
                (quote! { *phi }, &wt.phi[..]),
                (quote! { self.xbar }, &vars.xbar[..]),
                (quote! { self.pbar }, &vars.pbar_vars[..]),
                (quote! { self.qbar }, &vars.qbar_vars[..]),
                (quote! { self.phi_covariance }, &vars.window_covariance[..]),
                (quote! { self.r }, &vars.r_vars[..]),
                (quote! { *u_prev }, &g.u[..]),
                (quote! { *y }, &vars.y[..]),
            ],
            result_names: self.result_names("_bar", &corrected),
            corrected,
            filter: Filter::Akf,
            suffix: "_bar",
            fields: (quote! { xbar }, quote! { pbar }),
            definitions,
            prediction_args,
        }
    }

    /// The cold methods a gated step calls on an outlier, `lkf_keep_prediction` and
    /// `akf_keep_prediction`: each runs its filter's prediction alone and records the
    /// innovation in its own fields (`akf_innovation` for the AKF).
    fn keepers(&self) -> TokenStream {
        let ty = ident(self.scalar.type_name());
        let n_len = Literal::usize_unsuffixed(self.model.state_len());
        let u_param = self.u_param();
        let u_arg = self.u_arg();
        let lkf = measurement::PredictionKeeper {
            name: Filter::Lkf.keeper(),
            params: u_param.clone(),
            predict: quote! { self.lkf_predict(#(#u_arg),*) },
        };
        let mut akf_params = vec![quote! { phi: &[#ty; #n_len] }];
        akf_params.extend(u_param);
        let akf = measurement::PredictionKeeper {
            name: Filter::Akf.keeper(),
            params: akf_params,
            predict: quote! { self.akf_predict(phi, #(#u_arg),*) },
        };
        let lkf = measurement::keep_prediction_method(self.model, &lkf, Filter::Lkf.prefix(), &ty);
        let akf = measurement::keep_prediction_method(self.model, &akf, Filter::Akf.prefix(), &ty);
        quote! { #lkf #akf }
    }

    /// A filter stage lowered into its own method: the update's pivots guarded, the
    /// innovation's test (the gate or the divergence bound), then the new estimate and
    /// covariance stored, with the innovation, if they pass [`reject_diverged`].
    fn stage_method(&self, stage: Stage) -> (TokenStream, OpCount) {
        let n = stage.corrected.x.len();
        let mut graph = self.g.graph.clone();
        let corrected = &stage.corrected;
        let probe = finiteness_probe(&mut graph, &corrected.x, &corrected.p);
        let p_new = packed_upper(&corrected.p);
        let results: Vec<NodeId> = corrected.x.iter().chain(&p_new).copied().collect();
        let mut all_roots = results.clone();
        all_roots.push(probe);
        all_roots.extend(&corrected.pivots);
        if let Some((innovation, covariance, nis)) = &corrected.measured {
            all_roots.extend(innovation.iter().chain(covariance));
            all_roots.push(*nis);
        }
        let namer = TempNamer::new(self.avoid.iter().map(String::as_str));
        let mut lowerer = Lowerer::new(&graph, self.scalar, namer, &all_roots);
        self.prepare(&mut lowerer, &stage);
        let probe = lowerer.bind(probe, "divergence_probe");
        let values = lowerer.segment(&results);
        lowerer.count_extra(OpCount::stores(values.len()));
        lowerer.count_extra(crate::emit::code::divergence_test_ops(n));
        let store_innovation = self.innovation_test(&mut lowerer, &stage);
        let Lowered {
            statements, ops, ..
        } = lowerer.finish();
        let (x_values, p_values) = values.split_at(n);
        let Stage {
            name,
            doc,
            params,
            fields: (x_field, p_field),
            ..
        } = stage;
        let name = ident(&name);
        let doc = crate::emit::code::doc_attributes(&doc);
        let check = reject_diverged(&probe, &packed_diagonal(p_values, n), self.scalar);
        let tokens = quote! {
            #doc
            fn #name(&mut self, #params) -> Status {
                #(#statements)*
                #check
                self.#x_field = [#(#x_values),*];
                self.#p_field = [#(#p_values),*];
                #store_innovation
                Status::Ok
            }
        };
        (tokens, ops)
    }

    /// Before the stage's arithmetic: its lazy reads and definitions, its results' names,
    /// its pivots' guards and its innovation's names.
    fn prepare(&self, lowerer: &mut Lowerer, stage: &Stage) {
        for (source, vars) in &stage.reads {
            lowerer.read_lazily(source, vars);
        }
        for &(var, value) in &stage.definitions {
            lowerer.define(var, value);
        }
        for (&node, result) in stage.corrected.x.iter().zip(&stage.result_names) {
            lowerer.prefer_name(node, result);
        }
        guard_pivots(
            lowerer,
            &stage.corrected.pivots,
            &stage.corrected.reciprocals,
            (INNOVATION, stage.suffix),
            &innovation_pivot_failure,
            self.scalar,
        );
        if let Some((innovation, ..)) = &stage.corrected.measured {
            measurement::name_innovation(lowerer, self.model, innovation, stage.suffix);
        }
    }

    /// The shared measurement stage's test of a correcting stage's innovation, and the
    /// assignments that store it; nothing for a prediction alone.
    fn innovation_test(&self, lowerer: &mut Lowerer, stage: &Stage) -> TokenStream {
        let Some((innovation, covariance, nis)) = &stage.corrected.measured else {
            return TokenStream::new();
        };
        let kept = measurement::Kept {
            prefix: stage.filter.prefix(),
            innovation,
            covariance,
            nis: Some(*nis),
            gated: self.gate.is_some(),
            gate_prefix: "",
            keep_prediction: Some((stage.filter.keeper(), stage.prediction_args.clone())),
            recovers: self.recovers,
        };
        measurement::store_and_gate(lowerer, &kept)
    }

    /// The body of `step` (`corrects`) or of `predict`: rejects a non-finite input or
    /// measurement, runs the LKF, the transform and the AKF; a step pushes the sample into
    /// the window unless a filter refused it, a prediction (no measurement) empties it.
    fn body(&self, corrects: bool) -> TokenStream {
        let g = self.g;
        let u_idents = var_idents(&g.graph, &g.u);
        let y_idents = if corrects {
            var_idents(&g.graph, &self.vars.y)
        } else {
            Vec::new()
        };
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
        let unpack_y = corrects.then(|| quote! { let [#(#y_idents),*] = *y; });
        let u_arg = (!g.u.is_empty()).then(|| quote! { u_prev, });
        let covariance = self.least_squares.then(|| quote! { , covariance });
        let store_covariance = self
            .least_squares
            .then(|| quote! { self.phi_covariance = covariance; });
        let (lkf, akf, window) = if corrects {
            (
                quote! { self.lkf_step(#u_arg y) },
                quote! { self.akf_step(&phi, #u_arg y) },
                quote! {
                    // A measurement either filter refused (an outlier, or a result beyond
                    // the divergence bound; also the refusal a filter recovers at) stays
                    // out of the window: it empties, as for a missing sample, and refills.
                    if lkf == Status::OutlierRejected
                        || lkf == Status::Diverged
                        || lkf == Status::Recovering
                        || akf == Status::OutlierRejected
                        || akf == Status::Diverged
                        || akf == Status::Recovering
                    {
                        self.filled = [false; WINDOW_OUTPUTS];
                    } else {
                        self.push(#u_arg y);
                    }
                },
            )
        } else {
            (
                quote! { self.lkf_predict(#u_arg) },
                quote! { self.akf_predict(&phi, #u_arg) },
                quote! {
                    // Without its measurement the sample breaks the window's sequence.
                    self.filled = [false; WINDOW_OUTPUTS];
                },
            )
        };
        quote! {
            #unpack_u
            #unpack_y
            #(#reject_non_finite)*
            // The LKF linearises about the AKF's estimate of the previous sample: it runs
            // first, and before the transform, so that `phi` is not held across it.
            let lkf = #lkf;
            let (phi, window, [det_sq, column_norms], parameters #covariance) = self.transform(#u_arg);
            // The window's findings stand whatever the filters do with this sample.
            self.window_det_sq = det_sq;
            self.window_column_norms = column_norms;
            self.phi_params = parameters;
            #store_covariance
            let akf = #akf;
            #window
            DkfStatus { window, akf, lkf }
        }
    }
}

/// The DKF's two filters.
#[derive(Clone, Copy)]
pub enum Filter {
    /// The Kalman filter linearised about the AKF's estimate: the DKF's estimate.
    Lkf,
    /// The linear Kalman filter on the window transform's model.
    Akf,
}

impl Filter {
    /// `lkf`, `akf`: what the filter's methods start with.
    fn name(self) -> &'static str {
        match self {
            Filter::Lkf => "lkf",
            Filter::Akf => "akf",
        }
    }

    /// What its innovation fields and accessors start with: nothing for the LKF, whose
    /// are the DKF's, `akf_` for the AKF.
    pub fn prefix(self) -> &'static str {
        match self {
            Filter::Lkf => "",
            Filter::Akf => "akf_",
        }
    }

    /// Its cold keeper of a prediction, `lkf_keep_prediction`.
    fn keeper(self) -> Ident {
        ident(&format!("{}_keep_prediction", self.name()))
    }
}

/// `lkf_step` for a correction, `lkf_predict` for a prediction alone.
fn stage_name(filter: Filter, corrected: &Corrected) -> String {
    let filter = filter.name();
    if corrected.measured.is_some() {
        format!("{filter}_step")
    } else {
        format!("{filter}_predict")
    }
}

/// A stage's documentation from the sentence that says what its filter predicts with.
fn stage_doc(prediction: &str, corrected: &Corrected) -> String {
    if corrected.measured.is_some() {
        format!(" {prediction}, then corrected with `y[k]` (Joseph form).")
    } else {
        format!(
            " {prediction}, without a correction: what a gated step keeps when it rejects an \
             outlier."
        )
    }
}
