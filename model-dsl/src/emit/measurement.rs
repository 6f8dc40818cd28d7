//! The measurement stage every filter that corrects with all its outputs shares: the last
//! innovation `r = y - h(x)` and its covariance `S`, stored with the estimate, and what a
//! user reads of them (`innovation()`, `normalised_innovation_squared()`), `reset`, and
//! the optional innovation gate with its rejection of an outlier. Written once for the
//! EKF, the hybrid EKF, the continuous-time EKF and the DKF's two filters (whose AKF keeps
//! its own, under the prefix `akf_`).

use crate::emit::arguments::Arguments;
use crate::emit::code::{guard_pivots, pivot_names, INNOVATION};
use crate::emit::filter::{model_names, packed_vars, unclaimed_name, FilterLayout};
use crate::emit::lower::{Lowerer, OpCount};
use crate::emit::names::{ident, TempNamer};
use crate::model::{Model, Scalar};
use crate::symbolic::kalman;
use crate::symbolic::linalg::{packed_len, symmetric_from_packed};
use crate::symbolic::{Graph, NodeId};
use proc_macro2::TokenStream;
use quote::quote;

/// `stateforge_math`'s `DIVERGENCE_NIS`: the widest innovation gate, and the bound on the
/// NIS of a filter without one.
const DIVERGENCE_NIS: f64 = 1e8;

/// The fields a filter that measures adds to its layout's: the last innovation and its
/// packed covariance, and the gate when it has one; each followed by a comma.
pub fn fields(model: &Model, gate: Option<f64>, ty: &proc_macro2::Ident) -> TokenStream {
    let innovation = innovation_fields(model, "", ty);
    let gate_field = gate_field(gate, ty);
    quote! { #innovation #gate_field }
}

/// `{prefix}innovation` and `{prefix}innovation_covariance` (packed), each followed by a
/// comma: the last measurement's innovation as one filter of the type saw it.
pub fn innovation_fields(model: &Model, prefix: &str, ty: &proc_macro2::Ident) -> TokenStream {
    innovation_fields_of(model.outputs.len(), prefix, ty)
}

/// [`innovation_fields`] for `m` outputs (a sensor's).
pub fn innovation_fields_of(m: usize, prefix: &str, ty: &proc_macro2::Ident) -> TokenStream {
    let (m_len, mp) = (
        proc_macro2::Literal::usize_unsuffixed(m),
        proc_macro2::Literal::usize_unsuffixed(packed_len(m)),
    );
    let (innovation, covariance) = field_names(prefix);
    quote! {
        #innovation: [#ty; #m_len],
        #covariance: [#ty; #mp],
    }
}

/// `gate: S,`, or nothing without a gate.
pub fn gate_field(gate: Option<f64>, ty: &proc_macro2::Ident) -> Option<TokenStream> {
    gate.map(|_| quote! { gate: #ty, })
}

/// The names of the fields that hold a filter's innovation and its packed covariance.
fn field_names(prefix: &str) -> (proc_macro2::Ident, proc_macro2::Ident) {
    (
        ident(&format!("{prefix}innovation")),
        ident(&format!("{prefix}innovation_covariance")),
    )
}

/// The constructor's initial values of [`fields`]: before any measurement a zero
/// innovation of unit covariance (a normalised square of 0), and the generated gate.
pub fn initial_values(model: &Model, gate: Option<f64>, scalar: Scalar) -> TokenStream {
    let innovation = cleared_values(model, "", scalar);
    let gate_init = gate_initial_value(gate, scalar);
    quote! { #innovation #gate_init }
}

/// `gate: <generated>,` (opened no further than the divergence bound), or nothing.
pub fn gate_initial_value(gate: Option<f64>, scalar: Scalar) -> Option<TokenStream> {
    gate.map(|gate| {
        let value = crate::emit::lower::literal(opened_at_most(gate), scalar);
        quote! { gate: #value, }
    })
}

/// A generated gate as it is stored: opened no further than the divergence bound.
pub fn opened_at_most(gate: f64) -> f64 {
    gate.min(DIVERGENCE_NIS)
}

/// The initial values of [`innovation_fields`], each followed by a comma.
pub fn cleared_values(model: &Model, prefix: &str, scalar: Scalar) -> TokenStream {
    cleared_values_of(model.outputs.len(), prefix, scalar)
}

/// [`cleared_values`] for `m` outputs (a sensor's).
pub fn cleared_values_of(m: usize, prefix: &str, scalar: Scalar) -> TokenStream {
    let (innovation, covariance) = cleared(m, scalar);
    let (innovation_field, covariance_field) = field_names(prefix);
    quote! {
        #innovation_field: #innovation,
        #covariance_field: #covariance,
    }
}

/// `self.{prefix}innovation = ..; ..`: clears the innovation as `reset` does.
pub fn clear_innovation(model: &Model, prefix: &str, scalar: Scalar) -> TokenStream {
    clear_innovation_of(model.outputs.len(), prefix, scalar)
}

/// [`clear_innovation`] for `m` outputs (a sensor's).
pub fn clear_innovation_of(m: usize, prefix: &str, scalar: Scalar) -> TokenStream {
    let (innovation, covariance) = cleared(m, scalar);
    let (innovation_field, covariance_field) = field_names(prefix);
    quote! {
        self.#innovation_field = #innovation;
        self.#covariance_field = #covariance;
    }
}

/// The innovation and its packed covariance before any measurement, and after `reset`: a
/// zero innovation of unit covariance, whose normalised square is 0.
fn cleared(m: usize, scalar: Scalar) -> (TokenStream, TokenStream) {
    let zero = crate::emit::lower::literal(0.0, scalar);
    let m_len = proc_macro2::Literal::usize_unsuffixed(m);
    (quote! { [#zero; #m_len] }, packed_identity(m, scalar))
}

/// The methods of the stage: `reset` (which also runs `also_cleared`, the clearing of
/// other stored innovations: the EKF's sensors'), `innovation`,
/// `normalised_innovation_squared`, and with a gate its getter and setter and the step's
/// cold answer to an outlier.
pub fn methods(
    model: &Model,
    layout: &FilterLayout,
    (gate, also_cleared): (Option<f64>, &TokenStream),
    scalar: Scalar,
) -> TokenStream {
    let reset = reset_method(model, layout, also_cleared, scalar);
    let innovation = accessors(model, "", scalar);
    let gate_methods = gate_methods(model, gate, scalar).map(|(accessors, keep)| {
        let keep = (!joint_update_in_turn(model)).then_some(keep);
        quote! { #accessors #keep }
    });
    quote! {
        #reset

        #innovation

        #gate_methods
    }
}

/// With a gate, its getter and setter, and the cold `keep_prediction` of a step that
/// calls `predict` (the EKF family's, the polynomial Kalman filter's); nothing without one.
pub fn gate_methods(
    model: &Model,
    gate: Option<f64>,
    scalar: Scalar,
) -> Option<(TokenStream, TokenStream)> {
    let ty = ident(scalar.type_name());
    gate.map(|gate| {
        let accessors = gate_items(gate, scalar);
        let keeper = prediction_keeper(model, &ty);
        (accessors, keep_prediction_method(model, &keeper, "", &ty))
    })
}

/// Whether a filter's joint update is its sensors' updates in turn, with no stage of its
/// own: on a delayed horizon whose sensors arrive with different delays (each
/// measurement fused at the sample it describes).
pub fn joint_update_in_turn(model: &Model) -> bool {
    let delay = model.delay();
    model.sensors.iter().any(|s| s.delay < delay)
}

/// What a filter type's documentation says of its gate: a sentence, or nothing without
/// one.
pub fn gate_doc(gate: Option<f64>) -> &'static str {
    if gate.is_some() {
        " A measurement whose normalised innovation squared exceeds the innovation gate is \
         rejected as an outlier."
    } else {
        ""
    }
}

/// [`gate_doc`] as a `#[doc]` attribute, or nothing without a gate.
pub fn gate_doc_attribute(gate: Option<f64>) -> Option<TokenStream> {
    let doc = gate_doc(gate);
    gate.map(|_| quote! { #[doc = #doc] })
}

/// Names the innovation's entries `<output>_innovation{suffix}` (`_bar` for the DKF's
/// AKF), before the update uses them.
pub fn name_innovation(lowerer: &mut Lowerer, model: &Model, innovation: &[NodeId], suffix: &str) {
    let all: Vec<usize> = (0..model.outputs.len()).collect();
    name_innovation_of(lowerer, model, &all, innovation, suffix);
}

/// [`name_innovation`] for the innovation of `outputs` alone (a sensor's).
pub fn name_innovation_of(
    lowerer: &mut Lowerer,
    model: &Model,
    outputs: &[usize],
    innovation: &[NodeId],
    suffix: &str,
) {
    for (&r, &i) in innovation.iter().zip(outputs) {
        let name = &model.outputs[i].name;
        lowerer.prefer_name(r, &format!("{name}_innovation{suffix}"));
    }
}

/// What a correction keeps of its measurement: the innovation, its packed covariance and
/// the normalised innovation squared it tests.
pub struct Kept<'a> {
    /// The prefix of the fields it is stored in (`akf_` for the DKF's AKF, else empty).
    pub prefix: &'a str,
    /// `y - h(x)`, every output's (an update with one output alone stores zero for the
    /// others).
    pub innovation: &'a [NodeId],
    /// `S`, packed (for one output alone, unit variances and no correlation for the
    /// others, so that the stored NIS is that output's).
    pub covariance: &'a [NodeId],
    /// `r' S^-1 r`; `None` in a method that does not correct (a prediction), which keeps
    /// nothing.
    pub nis: Option<NodeId>,
    /// Whether the filter has an innovation gate: the NIS is tested against it, else
    /// against the divergence bound, `DIVERGENCE_NIS`.
    pub gated: bool,
    /// The prefix of the gate's field: empty for the filter's `gate`, `gnss_` for a
    /// sensor's own `gnss_gate`.
    pub gate_prefix: &'a str,
    /// In a step (a prediction and the correction), the cold method that keeps the
    /// prediction when the gate rejects an outlier, and the arguments before the innovation
    /// it is passed; `None` in an update, which keeps the estimate it had.
    pub keep_prediction: Option<(proc_macro2::Ident, Vec<TokenStream>)>,
    /// Whether the stage recovers after a run of refusals ([`crate::emit::recovery`]): a
    /// refusal is passed to its `{prefix}refused`, a taken measurement ends the run.
    pub recovers: bool,
}

/// Lowers what `kept` stores, last, where it holds no register while the update runs, and
/// returns its assignments for the commit; and its test just before the commit (an outlier
/// costs a whole update, the usual sample one comparison). With a gate, an outlier is
/// rejected (`OutlierRejected`; a step keeps its prediction); without one, a NIS beyond
/// the divergence bound returns `Diverged`, the filter unchanged. NaN is within neither: a
/// measurement that gives it is rejected. Nothing for a method that does not correct.
pub fn store_and_gate(lowerer: &mut Lowerer, kept: &Kept<'_>) -> TokenStream {
    let Some(nis) = kept.nis else {
        return TokenStream::new();
    };
    let m = kept.innovation.len();
    lowerer.count_extra(OpCount::stores(m + packed_len(m)));
    let innovation_values = lowerer.segment(kept.innovation);
    let covariance_values = lowerer.segment(kept.covariance);
    let store = store_innovation_tokens(kept.prefix, &innovation_values, &covariance_values);
    let nis = lowerer.bind(nis, "nis");
    let ty = ident(lowerer.scalar().type_name());
    // With recovery, a refusal is passed to the stage's inlined `refused`.
    // What a recovery scales the covariance to pass: the gate, or without one (whose
    // bound, 1e4 standard deviations, says nothing of consistency) the innovation's
    // expected normalised square, its number of outputs.
    let threshold = if kept.gated {
        let gate = ident(&format!("{}gate", kept.gate_prefix));
        quote! { self.#gate }
    } else {
        crate::emit::lower::literal(m as f64, lowerer.scalar())
    };
    let refused = kept.recovers.then(|| {
        let method = crate::emit::recovery::method_name(kept.prefix);
        quote! { self.#method(#nis, #threshold, refusal) }
    });
    let refuse = |refusal: TokenStream| match &refused {
        Some(call) => quote! {
            let refusal = #refusal;
            return #call;
        },
        None => quote! { return #refusal; },
    };
    let test = if kept.gated {
        let keep_prediction = kept.keep_prediction.as_ref().map(|(method, args)| {
            quote! {
                self.#method(
                    #(#args,)* &[#(#innovation_values),*], &[#(#covariance_values),*],
                )
            }
        });
        let rejection = outlier_rejection(keep_prediction, &store, refuse);
        let gate = ident(&format!("{}gate", kept.gate_prefix));
        quote! {
            if !stateforge_math::#ty::within_gate(#nis, self.#gate) {
                #rejection
            }
        }
    } else {
        let diverged = refuse(quote! { Status::Diverged });
        quote! {
            if !stateforge_math::#ty::within_gate(#nis, stateforge_math::#ty::DIVERGENCE_NIS) {
                #diverged
            }
        }
    };
    lowerer.statement(test);
    lowerer.count_extra(OpCount {
        compare: 1,
        ..Default::default()
    });
    if kept.recovers {
        // A taken measurement ends a run of refusals.
        lowerer.count_extra(OpCount::stores(1));
        let clear = crate::emit::recovery::clear(kept.prefix);
        return quote! { #store #clear };
    }
    store
}

/// `reset(x0, p0)`: starting again, the innovation cleared.
fn reset_method(
    model: &Model,
    layout: &FilterLayout,
    also_cleared: &TokenStream,
    scalar: Scalar,
) -> TokenStream {
    let clear = clear_innovation(model, "", scalar);
    let mut arguments = Arguments::default();
    let (x0, p0) = layout.initial_estimate(&mut arguments);
    let unit = layout.unit_rotations(&quote! { Status::RejectedInput });
    arguments.method(
        &ident("reset"),
        &quote! {
            /// Starts the filter again from the estimate `x0` and covariance `p0`, keeping
            /// the noise covariances: the way back after a fault (a run of
            /// [`Status::Diverged`], [`Status::NonFinite`] or rejected outliers) or a
            /// restart of the plant.
            /// The innovation is cleared. Rejects a non-finite entry with
            /// [`Status::RejectedInput`] and a `p0` that is not symmetric and positive
            /// semi-definite with [`Status::InvalidCovariance`], leaving the filter
            /// unchanged.
        },
        quote! {
            #unit
            self.x = #x0;
            self.p = #p0;
            #clear
            #also_cleared
            Status::Ok
        },
    )
}

/// `{prefix}innovation` and `{prefix}normalised_innovation_squared`: what the last
/// measurement said to the filter whose fields carry `prefix`.
pub fn accessors(model: &Model, prefix: &str, scalar: Scalar) -> TokenStream {
    let all: Vec<usize> = (0..model.outputs.len()).collect();
    let measured = Measured {
        outputs: &all,
        prefix,
        of: &filter_phrase(prefix),
        len_doc: "`Y_LEN`",
    };
    accessors_of(model, &measured, scalar)
}

/// Whose innovation a set of fields holds: a filter's, of every output, or a sensor's, of
/// its own.
pub struct Measured<'a> {
    /// The outputs, in the order the innovation stores them.
    pub outputs: &'a [usize],
    /// The prefix of the fields and accessors (`akf_`, `gnss_`), or empty.
    pub prefix: &'a str,
    /// Whose measurement the documentation speaks of (` by the AKF`, ` of the sensor
    /// `gnss``), or empty.
    pub of: &'a str,
    /// How many outputs, as the documentation says it (`` `Y_LEN` ``, `6`).
    pub len_doc: &'a str,
}

/// [`accessors`] of the outputs and fields `measured` gives.
pub fn accessors_of(model: &Model, measured: &Measured<'_>, scalar: Scalar) -> TokenStream {
    let ty = ident(scalar.type_name());
    let m_len = proc_macro2::Literal::usize_unsuffixed(measured.outputs.len());
    let (field, _) = field_names(measured.prefix);
    let of = measured.of;
    let doc = format!(
        " The innovation `y - h(x)` of the last measurement used or rejected{of}: what the \
         measurement said that the prediction did not."
    );
    let doc = crate::emit::code::doc_attributes(&doc);
    let nis_method = nis_method(model, measured, scalar);
    quote! {
        #doc
        #[must_use]
        pub fn #field(&self) -> [#ty; #m_len] {
            self.#field
        }

        #nis_method
    }
}

/// Which filter a documentation sentence speaks of: ` by the AKF` for the prefix `akf_`.
fn filter_phrase(prefix: &str) -> String {
    match prefix.strip_suffix('_') {
        Some(filter) => format!(" by the {}", filter.to_uppercase()),
        None => String::new(),
    }
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
fn nis_method(model: &Model, measured: &Measured<'_>, scalar: Scalar) -> TokenStream {
    let (m, prefix) = (measured.outputs.len(), measured.prefix);
    let mut graph = Graph::new();
    let avoid = model_names(model);
    let innovation: Vec<NodeId> = measured
        .outputs
        .iter()
        .map(|&i| {
            let name = format!("{}_innovation", model.outputs[i].name);
            graph.var(&unclaimed_name(name, &avoid))
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
    let (innovation_field, covariance_field) = field_names(prefix);
    lowerer.read_lazily(&quote! { self.#innovation_field }, &innovation);
    lowerer.read_lazily(&quote! { self.#covariance_field }, &s_vars);
    let ty = ident(scalar.type_name());
    // The stored covariance passed this test when its measurement was used: a failure here
    // cannot happen, and would read as "inconsistent".
    let on_failure = quote! { return #ty::INFINITY; };
    guard_pivots(
        &mut lowerer,
        &ldl.pivots,
        &ldl.reciprocals,
        (INNOVATION, ""),
        &|_| on_failure.clone(),
        scalar,
    );
    let value = lowerer.segment(&[nis]).remove(0);
    let statements = lowerer.finish().statements;
    let doc = format!(
        " The normalised innovation squared `r' S^-1 r` of the last measurement used \
         or rejected{} (`r` its innovation, `S` the innovation covariance). While the \
         model and noise levels are right it is chi-square distributed with as many \
         degrees of freedom as measurements (mean {}); a run of large values says \
         the model, the tuning or the sensor is wrong. 0 before the first measurement.",
        measured.of, measured.len_doc
    );
    let doc = crate::emit::code::doc_attributes(&doc);
    let name = ident(&format!("{prefix}normalised_innovation_squared"));
    quote! {
        #doc
        #[must_use]
        pub fn #name(&self) -> #ty {
            #(#statements)*
            #value
        }
    }
}

/// The innovation gate's getter and setter; `gate` is its generated value.
pub fn gate_items(gate: f64, scalar: Scalar) -> TokenStream {
    let setter_doc = " Sets the innovation gate (a chi-square quantile for `Y_LEN` degrees \
        of freedom: 10.83 rejects one in a thousand consistent scalar measurements). One gate \
        serves every update of the filter but a sensor's: where it has updates with fewer \
        outputs (the EKF's `update_<output>`), they are judged by the same threshold, so they \
        reject less often than their own quantile would.";
    gate_items_of(gate, "", setter_doc, scalar)
}

/// The getter and setter of the gate in the field `{prefix}gate`:
/// `{prefix}innovation_gate` and `set_{prefix}innovation_gate`, whose documentation begins
/// with `setter_doc`.
pub fn gate_items_of(gate: f64, prefix: &str, setter_doc: &str, scalar: Scalar) -> TokenStream {
    let ty = ident(scalar.type_name());
    let zero = crate::emit::lower::literal(0.0, scalar);
    let generated = if gate < DIVERGENCE_NIS {
        format!("{gate}")
    } else {
        "open (at the divergence bound, 1e8)".to_owned()
    };
    let doc = format!(
        " The innovation gate: a measurement whose normalised innovation squared exceeds it \
         is rejected ([`Status::OutlierRejected`]). Generated {generated}."
    );
    let setter_doc = crate::emit::code::doc_attributes(&format!(
        "{setter_doc} The gate opens no further than the divergence bound, \
         `stateforge_math`'s `DIVERGENCE_NIS` (1e8): a larger threshold, infinity included, \
         sets that. Rejects a threshold that is not positive, leaving the gate as it was."
    ));
    let field = ident(&format!("{prefix}gate"));
    let getter = ident(&format!("{prefix}innovation_gate"));
    let setter = ident(&format!("set_{prefix}innovation_gate"));
    quote! {
        #[doc = #doc]
        #[must_use]
        pub fn #getter(&self) -> #ty {
            self.#field
        }

        #setter_doc
        pub fn #setter(&mut self, threshold: #ty) -> Status {
            if threshold > #zero {
                self.#field = if threshold < stateforge_math::#ty::DIVERGENCE_NIS {
                    threshold
                } else {
                    stateforge_math::#ty::DIVERGENCE_NIS
                };
                Status::Ok
            } else {
                Status::RejectedInput
            }
        }
    }
}

/// `self.innovation = [..]; self.innovation_covariance = [..];` (with `prefix`).
fn store_innovation_tokens(
    prefix: &str,
    innovation: &[TokenStream],
    covariance: &[TokenStream],
) -> TokenStream {
    let (innovation_field, covariance_field) = field_names(prefix);
    quote! {
        self.#innovation_field = [#(#innovation),*];
        self.#covariance_field = [#(#covariance),*];
    }
}

/// What a gated update does with an outlier: store its innovation and return
/// `OutlierRejected`. A step keeps its prediction, as `predict` alone would have, through
/// the cold, out-of-line `keep_prediction` (`keep_prediction`: its call), so the usual
/// sample pays only for the test; a prediction that fails returns its own status. `refuse`
/// returns the refusal (through the stage's recovery, where it has one).
fn outlier_rejection(
    keep_prediction: Option<TokenStream>,
    store_innovation: &TokenStream,
    refuse: impl Fn(TokenStream) -> TokenStream,
) -> TokenStream {
    match keep_prediction {
        Some(call) => {
            let refusal = refuse(quote! { Status::OutlierRejected });
            quote! {
                let kept = #call;
                // A prediction that failed (diverged, not finite) is its own answer, not
                // a refused measurement: the recovery counts only refusals.
                if kept != Status::OutlierRejected {
                    return kept;
                }
                #refusal
            }
        }
        None => {
            let refusal = refuse(quote! { Status::OutlierRejected });
            quote! {
                #store_innovation
                #refusal
            }
        }
    }
}

/// The EKF family's call of its keeper: `keep_prediction` and the arguments a step
/// passes on to `predict`, for [`Kept::keep_prediction`].
pub fn keep_prediction_call(model: &Model) -> (proc_macro2::Ident, Vec<TokenStream>) {
    (ident("keep_prediction"), prediction_arguments(model))
}

/// The arguments a step passes on to `predict`: `t_prev`, the sample interval (`dt`) and
/// `u_prev` where the model has them.
fn prediction_arguments(model: &Model) -> Vec<TokenStream> {
    let mut args = Vec::new();
    if model.uses_time() {
        args.push(quote! { t_prev });
    }
    if let Some(dt) = model.interval_parameter() {
        let dt = ident(&dt);
        args.push(quote! { #dt });
    }
    if !model.inputs.is_empty() {
        args.push(quote! { u_prev });
    }
    args
}

/// A step's cold answer to an outlier: the method's name, its parameters before the
/// innovation (which it takes by reference: a 9-output filter's `f64` covariance is 360
/// bytes), and the call of the prediction it keeps.
pub struct PredictionKeeper {
    /// `keep_prediction`, or `lkf_keep_prediction` for one of the DKF's filters.
    pub name: proc_macro2::Ident,
    /// `t_prev: S`, `u_prev: &[S; U_LEN]`, as the prediction takes them.
    pub params: Vec<TokenStream>,
    /// `self.predict(t_prev, u_prev)`: a call that returns a `Status`.
    pub predict: TokenStream,
}

/// The EKF family's keeper (and the polynomial Kalman filter's): `keep_prediction`, which
/// calls `predict` with the arguments of [`keep_prediction_call`].
fn prediction_keeper(model: &Model, ty: &proc_macro2::Ident) -> PredictionKeeper {
    let mut params = Vec::new();
    if model.uses_time() {
        params.push(quote! { t_prev: #ty });
    }
    if let Some(dt) = model.interval_parameter() {
        let dt = ident(&dt);
        params.push(quote! { #dt: #ty });
    }
    if !model.inputs.is_empty() {
        let u = proc_macro2::Literal::usize_unsuffixed(model.inputs.len());
        params.push(quote! { u_prev: &[#ty; #u] });
    }
    let (name, args) = keep_prediction_call(model);
    // On a delayed horizon, a step keeps the horizon's prediction: the public `predict`
    // would buffer its input a second time.
    let predict = if model.delay() > 0 {
        quote! { self.predict_at_horizon(#(#args),*) }
    } else {
        quote! { self.predict(#(#args),*) }
    };
    PredictionKeeper {
        name,
        params,
        predict,
    }
}

/// The keeper's method: a gated step's answer to an outlier, storing the innovation in
/// the fields of `prefix`.
pub fn keep_prediction_method(
    model: &Model,
    keeper: &PredictionKeeper,
    prefix: &str,
    ty: &proc_macro2::Ident,
) -> TokenStream {
    let m = proc_macro2::Literal::usize_unsuffixed(model.outputs.len());
    let mp = proc_macro2::Literal::usize_unsuffixed(packed_len(model.outputs.len()));
    let PredictionKeeper {
        name,
        params,
        predict,
    } = keeper;
    let (innovation_field, covariance_field) = field_names(prefix);
    quote! {
        /// A step's outlier: the prediction is kept, the measurement only recorded. Out of
        /// line and cold, so the usual sample does not pay for it.
        #[cold]
        #[inline(never)]
        fn #name(
            &mut self,
            #(#params,)*
            innovation: &[#ty; #m],
            innovation_covariance: &[#ty; #mp],
        ) -> Status {
            let predicted = #predict;
            if predicted != Status::Ok {
                return predicted;
            }
            self.#innovation_field = *innovation;
            self.#covariance_field = *innovation_covariance;
            Status::OutlierRejected
        }
    }
}
