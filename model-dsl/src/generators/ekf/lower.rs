//! The extended Kalman filter (Alg. 1), generated for the model: covariance stored once
//! (packed upper triangle), products that skip the Jacobians' structural zeros, a scalar
//! measurement handled with one guarded reciprocal, several with an unrolled `L D L'` solve,
//! and the Joseph-form covariance update.

use super::delay;
use super::horizon_calls::{self, Call};
use super::spec::EkfSpec;
use crate::emit::arguments::Arguments;
use crate::emit::code::{
    guard_pivots, innovation_pivot_failure, pivot_names, var_idents, INNOVATION,
};
use crate::emit::filter::{
    correction_reads_input, finiteness_probe_of_changes, interleaved_finiteness_probe, model_names,
    name_estimate, reads_variable, unclaimed_name, FilterLayout, FilterVars, MEASUREMENT_INPUT_DOC,
};
use crate::emit::in_place::{self, CovarianceSlots};
use crate::emit::interval;
use crate::emit::lower::{Lowered, Lowerer, OpCount};
use crate::emit::measurement;
use crate::emit::names::{ident, TempNamer};
use crate::emit::recovery;
use crate::emit::sensors;
use crate::model::{Model, Scalar};
use crate::symbolic::covariance_blocks::{Couplings, CovarianceBlocks};
use crate::symbolic::kalman;
use crate::symbolic::linalg::{packed_upper, symmetric_from_packed, Coefficients, Matrix};
use crate::symbolic::{ModelGraph, NodeId, VarId};
use proc_macro2::TokenStream;
use quote::quote;
use std::collections::BTreeSet;

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
    /// Arithmetic of each sensor's update, with the method's name (`update_gnss`).
    pub sensor_update_ops: Vec<(String, OpCount)>,
}

/// The EKF of `model` in `scalar`.
pub fn emit_ekf(model: &Model, spec: &EkfSpec, mg: &ModelGraph, scalar: Scalar) -> EkfCode {
    let mut blocks = covariance_blocks(model, spec, mg);
    loop {
        if let Some(code) = emit_with_blocks(model, spec, mg, scalar, &blocks) {
            return code;
        }
        // Not reached while the analysis holds (each method checks that its entries
        // between two blocks come out zero): the filter of one block, which always holds.
        blocks = CovarianceBlocks::one(model.tangent_len());
    }
}

/// The blocks of the filter's covariance (see [`CovarianceBlocks`]): what couples its
/// coordinates is the model's Jacobians, the process noise if it is a full matrix, the
/// noise on inputs, and each rotation's reset.
fn covariance_blocks(model: &Model, spec: &EkfSpec, mg: &ModelGraph) -> CovarianceBlocks {
    let n = model.tangent_len();
    let correlated_noise: Vec<usize> = match (&spec.process_noise.diagonal, &spec.process_noise.on)
    {
        (true, _) => Vec::new(),
        (false, Some(on)) => on.clone(),
        (false, None) => (0..n).collect(),
    };
    let together: Vec<std::ops::Range<usize>> = model
        .rotations()
        .iter()
        .map(|r| r.tangent..r.tangent + 3)
        .collect();
    CovarianceBlocks::of_ekf(
        mg,
        &Couplings {
            correlated_noise: &correlated_noise,
            noisy_inputs: &spec.input_noise,
            together: &together,
        },
    )
}

/// The EKF of `model` in `scalar` whose covariance is zero between the `blocks`; `None` if
/// a method would make an entry between two blocks non-zero.
fn emit_with_blocks(
    model: &Model,
    spec: &EkfSpec,
    mg: &ModelGraph,
    scalar: Scalar,
    blocks: &CovarianceBlocks,
) -> Option<EkfCode> {
    let method = |kind| method(model, mg, scalar, (kind, blocks), spec);
    let (predict, predict_ops) = method(EkfMethod::Predict)?;
    let (update, update_ops) = method(EkfMethod::Update)?;
    let (step, step_ops) = method(EkfMethod::Step)?;
    let mut sensor_update_ops = Vec::new();
    let mut partial = Vec::new();
    for kind in partial_updates(model) {
        let (tokens, ops) = method(kind)?;
        if let Some(sensor) = kind.sensor(model) {
            sensor_update_ops.push((format!("update_{}", sensor.name), ops));
        }
        partial.push(tokens);
    }
    // With a delayed horizon, the public calls around the steps.
    let ops = delay::CallOps {
        predict: predict_ops,
        update: update_ops,
        step: step_ops,
        sensors: sensor_update_ops,
    }
    .on_horizon(model, mg, scalar);
    let partial_updates = partial;
    let ty = ident(scalar.type_name());
    let noisy_inputs: Vec<&str> = spec
        .input_noise
        .iter()
        .map(|&j| model.inputs[j].name.as_str())
        .collect();
    let layout = FilterLayout::new(model, &spec.process_noise, &ty)
        .with_input_noise(&noisy_inputs, model.interval_parameter().as_deref())
        .with_covariance_blocks(blocks.is_split().then(|| blocks.ids()));
    let methods = quote! {
        #step

        #predict

        #update

        #(#partial_updates)*
    };
    Some(EkfCode {
        tokens: ekf_type(model, spec, scalar, &layout, &methods),
        predict_ops: ops.predict,
        update_ops: ops.update,
        step_ops: ops.step,
        sensor_update_ops: ops.sensors,
    })
}

/// The updates with some of the outputs, for sensors sampled at different rates: one per
/// declared sensor, with its outputs, and, in a model of several outputs, one per output
/// that no sensor measures.
fn partial_updates(model: &Model) -> Vec<EkfMethod> {
    let sensors = (0..model.sensors.len()).map(EkfMethod::UpdateSensor);
    let in_sensor = |j: &usize| model.sensors.iter().any(|s| s.outputs.contains(j));
    let alone = (0..model.outputs.len())
        .filter(|j| model.outputs.len() > 1 && !in_sensor(j))
        .map(EkfMethod::UpdateOutput);
    sensors.chain(alone).collect()
}

/// The filter's type: the struct (estimate, covariance, noise, the last innovation and
/// its covariance, the gate, the known constants) and its methods, `methods` (the steps)
/// last.
fn ekf_type(
    model: &Model,
    spec: &EkfSpec,
    scalar: Scalar,
    layout: &FilterLayout,
    methods: &TokenStream,
) -> TokenStream {
    let FilterLayout {
        ty,
        accessors,
        setters,
        ..
    } = layout;
    let known = crate::emit::known::known_items(model, ty);
    let (known_field, known_methods) = (&known.field, &known.methods);
    let type_name = ident(&spec.type_name);
    let (type_doc, convention_doc) = type_doc(spec, model);
    let fields = layout.fields();
    let measurement_fields = measurement::fields(model, spec.gate, ty);
    let sensor_fields = sensors::fields(model, spec.gate, ty);
    let buffer_fields = delay::fields(model, ty);
    let buffer_items = delay::items(model, ty);
    let recovery = recovery_items(model, spec, scalar);
    let (recovery_fields, recovery_methods) = (&recovery.fields, &recovery.methods);
    let constructor = constructor_tokens(spec, layout, model, scalar, &known, &recovery.initial);
    let clear_sensors = sensors::clear(model, scalar);
    let recovery_clear = &recovery.clear;
    let clear_buffer = delay::clear(model);
    let also_cleared = quote! { #clear_sensors #recovery_clear #clear_buffer };
    let measurement_methods =
        measurement::methods(model, layout, (spec.gate, &also_cleared), scalar);
    let sensor_methods = sensors::methods(model, spec.gate, scalar);
    quote! {
        #[doc = #type_doc]
        ///
        #[doc = #convention_doc]
        #[derive(Clone, Copy, Debug, PartialEq)]
        pub struct #type_name {
            #fields
            #measurement_fields
            #sensor_fields
            #buffer_fields
            #recovery_fields
            #known_field
        }

        impl #type_name {
            #constructor

            #measurement_methods

            #sensor_methods

            #accessors

            #setters

            #known_methods

            #recovery_methods

            #buffer_items

            #methods
        }
    }
}

/// The filter's recovery after a run of refusals: its own stage and each sensor's update.
fn recovery_items(model: &Model, spec: &EkfSpec, scalar: Scalar) -> recovery::RecoveryItems {
    let sensor_stages: Vec<(String, String)> = model
        .sensors
        .iter()
        .map(|sensor| (sensors::prefix(sensor), sensor.name.clone()))
        .collect();
    let own = !measurement::joint_update_in_turn(model);
    recovery::filter_items(spec.recover_after, (own, &sensor_stages), scalar)
}

/// `fn new`: the shared layout's constructor, with the measurement stage's initial values
/// and the known constants.
fn constructor_tokens(
    spec: &EkfSpec,
    layout: &FilterLayout,
    model: &Model,
    scalar: Scalar,
    known: &crate::emit::known::KnownItems,
    recovery_init: &TokenStream,
) -> TokenStream {
    let new_doc = if spec.process_noise.diagonal {
        " A filter from the initial estimate `x0` and covariance `p0`, the process noise \
         variances `q` (a diagonal covariance) and the measurement noise covariance `r`. The \
         matrices must be covariances (symmetric, positive semi-definite): both are checked."
    } else {
        " A filter from the initial estimate `x0` and covariance `p0`, the process noise \
         covariance `q` and the measurement noise covariance `r`. The matrices must \
         be covariances (symmetric, positive semi-definite): both are checked."
    };
    let measurement = measurement::initial_values(model, spec.gate, scalar);
    let sensors = sensors::initial_values(model, spec.gate, scalar);
    let buffer = delay::initial_values(model, scalar);
    layout.constructor(
        &ident(&spec.type_name),
        &quote! { #[doc = #new_doc] },
        known,
        &quote! { #measurement #sensors #buffer #recovery_init },
    )
}

/// The filter type's documentation: what it is (with its gate), then the index convention.
fn type_doc(spec: &EkfSpec, model: &Model) -> (String, String) {
    let gate = measurement::gate_doc(spec.gate);
    let error_state = if model.rotations().is_empty() {
        ""
    } else {
        " The model has rotations, so this is an error-state filter (J. Solà, \"Quaternion \
         kinematics for the error-state Kalman filter\", section 7): `x` holds each rotation \
         as a unit quaternion `[x, y, z, w]`, `P` is over the tangent space \
         (`TANGENT_NAMES`: a rotation's error as a rotation vector `δθ` in the earth frame, \
         the true rotation `Exp(δθ) ⊗ q`), the Jacobians are those of the error, and each \
         update moves its estimated error into `x` by the exact retraction and resets `P` \
         around it."
    };
    let what = format!(
        " Extended Kalman filter of this model: state estimate `x` (the states, then the \
         parameters, each a constant the filter estimates as a random walk) and covariance \
         `P`, stored once as a packed upper triangle; prediction through `f` and its Jacobian, \
         Joseph-form update (the discrete EKF as Algorithm 1 of the double Kalman filter \
         paper states it).{gate}{error_state}"
    );
    let convention = format!(
        " Index convention (all filters of this module): [`{}::step`] at sample `k` takes \
         the input `u[k-1]` applied since the previous sample and the measurement `y[k]`.",
        spec.type_name
    );
    (what, convention)
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
    /// The correction with a declared sensor's outputs (`Model::sensors[s]`), storing its
    /// innovation in the sensor's own fields and judging it by the sensor's own gate.
    UpdateSensor(usize),
}

impl EkfMethod {
    /// Whether the method predicts the next sample.
    fn predicts(self) -> bool {
        matches!(self, EkfMethod::Predict | EkfMethod::Step)
    }

    /// Whether the method corrects with a measurement.
    fn updates(self) -> bool {
        self != EkfMethod::Predict
    }

    /// The outputs this method corrects with: one or a sensor's for a partial update,
    /// else all.
    fn outputs(self, model: &Model) -> Vec<usize> {
        match self {
            EkfMethod::UpdateOutput(j) => vec![j],
            EkfMethod::UpdateSensor(s) => model.sensors[s].outputs.clone(),
            _ => (0..model.outputs.len()).collect(),
        }
    }

    /// The sensor whose own fields and gate the method uses, if it is a sensor's update.
    fn sensor(self, model: &Model) -> Option<&crate::model::Sensor> {
        match self {
            EkfMethod::UpdateSensor(s) => Some(&model.sensors[s]),
            _ => None,
        }
    }

    /// The method's name and documentation.
    fn name_and_doc(self, model: &Model, spec: &EkfSpec) -> (proc_macro2::Ident, String) {
        let (name, doc) = match self {
            EkfMethod::UpdateSensor(s) => {
                let sensor = &model.sensors[s];
                return (
                    ident(&format!("update_{}", sensor.name)),
                    sensor_update_doc(model, sensor, spec) + self.time_doc(model),
                );
            }
            EkfMethod::UpdateOutput(j) => {
                let output = &model.outputs[j].name;
                let doc = format!(
                    " Corrects the estimate with the measurement `y` of the output `{output}` \
                     alone, for a sensor sampled at its own rate (Joseph form, its variance \
                     `R[{j}][{j}]`). With uncorrelated measurement noise (a diagonal `R`), \
                     updating with each output in turn equals [`{ty_name}::update`] with all of \
                     them. Stores its innovation (zero, of unit variance, for the other outputs) \
                     and passes the innovation gate, or the divergence bound, like \
                     [`{ty_name}::update`]. Rejects a non-finite measurement and a non-positive \
                     innovation variance; leaves the filter unchanged unless it returns \
                     [`Status::Ok`] (or [`Status::OutlierRejected`], which records the \
                     innovation).",
                    ty_name = spec.type_name
                );
                return (
                    ident(&format!("update_{output}")),
                    doc + self.time_doc(model),
                );
            }
            EkfMethod::Predict => (
                "predict",
                " Predicts the next sample: `x = f(x, u_prev)`, `P = A P A' + Q` with \
                 `A = df/dx` at the current estimate, `u_prev` the input applied since the \
                 previous sample. Rejects a non-finite input; leaves the filter unchanged \
                 unless it returns [`Status::Ok`].",
            ),
            EkfMethod::Update => (
                "update",
                " Corrects the estimate with the measurement `y` (Joseph form). Rejects \
                 a non-finite measurement and a non-positive innovation variance (never divided \
                 by); leaves the filter unchanged unless it returns [`Status::Ok`].",
            ),
            EkfMethod::Step => (
                "step",
                " One sample: predicts `x[k]` from `x[k-1]` with the input `u[k-1]` held \
                 over the sample, then corrects it with the measurement `y[k]`, in one pass that \
                 stores nothing in between. Leaves the filter unchanged unless it returns \
                 [`Status::Ok`].",
            ),
        };
        let input_noise = match (
            self.predicts() && !spec.input_noise.is_empty(),
            model.interval(),
        ) {
            (false, _) => "",
            (true, None) => {
                " The prediction's process noise includes the noise on the inputs \
                 `input_noise` lists, `G diag(qu) G'` with `G = df/du` at the current estimate."
            }
            (true, Some(_)) => {
                " The prediction's process noise includes the noise on the inputs \
                 `input_noise` lists, `G diag(qu) G' / dt` with `G = df/du` at the current \
                 estimate over the interval."
            }
        };
        (
            ident(name),
            doc.to_owned() + input_noise + self.time_doc(model),
        )
    }

    /// What the method's documentation says of its times, for a model that reads `t`.
    fn time_doc(self, model: &Model) -> &'static str {
        if !model.uses_time() {
            return "";
        }
        match self {
            EkfMethod::Predict => " `f` is evaluated at `t_prev`, the previous sample's time.",
            EkfMethod::Update | EkfMethod::UpdateOutput(_) | EkfMethod::UpdateSensor(_) => {
                " `h` is evaluated at `t`, the measurement's time."
            }
            EkfMethod::Step if model.dynamics.discretisation.is_continuous() => {
                " The prediction runs from `t_prev`, the previous sample's time, and `h` is \
                 evaluated a sample time `dt` later, at `t_prev + dt`."
            }
            EkfMethod::Step => {
                " The prediction runs from `t_prev`, the previous sample's time, and `h` is \
                 evaluated at `t`, the measurement's time."
            }
        }
    }
}

/// What `update_<sensor>` says of itself: the sensor's own documentation, then what the
/// update does.
fn sensor_update_doc(model: &Model, sensor: &crate::model::Sensor, spec: &EkfSpec) -> String {
    let outputs: Vec<String> = sensor
        .outputs
        .iter()
        .map(|&i| format!("`{}`", model.outputs[i].name))
        .collect();
    let own: String = sensor.docs.iter().map(|line| format!("{line}\n")).collect();
    let name = &sensor.name;
    let k = sensor.outputs.len();
    let gate = match (sensor.gate, spec.gate) {
        (Some(_), _) => format!(
            "its own innovation gate ([`{}::{name}_innovation_gate`], declared with the \
             sensor: a chi-square quantile for its {k} degrees of freedom)",
            spec.type_name
        ),
        (None, Some(_)) => format!(
            "its own innovation gate ([`{}::{name}_innovation_gate`], generated at the \
             filter's gate, a quantile for every output's degrees of freedom: set it to \
             one for {k})",
            spec.type_name
        ),
        (None, None) => "the divergence bound, `DIVERGENCE_NIS`".to_owned(),
    };
    format!(
        "{own}\n Corrects the estimate with the sensor `{name}`'s measurement `y` (of {}, in \
         that order; Joseph \
         form, one `L D L'` solve of its innovation covariance, with the sensor's own block \
         of `R`, [`{ty}::{name}_noise`]). Stores its innovation in the sensor's own fields \
         ([`{ty}::{name}_innovation`], [`{ty}::{name}_normalised_innovation_squared`]) and \
         tests its normalised square against {gate}. Rejects a non-finite measurement and an innovation covariance that is \
         not positive definite (never divided by); leaves the filter unchanged unless it \
         returns [`Status::Ok`] (or [`Status::OutlierRejected`], which records the \
         innovation). The noise of two sensors is independent, so updating with \
         each sensor in turn equals [`{ty}::update`] with all of them where `h` is linear; \
         a nonlinear sensor's update linearises `h` at the estimate it is given, so update \
         with it before the others to match the joint update, after them to use their \
         corrections.",
        outputs.join(", "),
        ty = spec.type_name
    )
}

/// One EKF method (Alg. 1): the prediction and/or the correction, built symbolically so
/// products skip the Jacobians' structural zeros, then lowered with its guards.
fn method(
    model: &Model,
    mg: &ModelGraph,
    scalar: Scalar,
    (kind, blocks): (EkfMethod, &CovarianceBlocks),
    spec: &EkfSpec,
) -> Option<(TokenStream, OpCount)> {
    let mut nodes = EkfNodes::build(model, mg, kind, spec, blocks)?;
    let (body, used_vars, ops) = lower(&mut nodes, model, scalar, kind);
    let ty = ident(scalar.type_name());
    let graph = &nodes.g.graph;
    let reads_input = correction_reads_input(graph, &nodes.g.u, kind.predicts(), &used_vars);
    let arguments = arguments(&nodes, model, kind, (&used_vars, reads_input), &ty);
    let (name, mut doc) = kind.name_and_doc(model, spec);
    if reads_input {
        doc.push_str(MEASUREMENT_INPUT_DOC);
    }
    let (body, ops) = match (nodes.g.interval, model.interval_parameter()) {
        (Some(dt), Some(parameter)) if kind.predicts() && reads_variable(graph, dt, &used_vars) => {
            doc.push_str(&interval::doc(
                &parameter,
                &format!(
                    "the model's step {}, and the process noise `Q` is a density, the noise \
                     of the interval `Q {parameter}`",
                    if model.dynamics.discretisation.is_continuous() {
                        "integrates its continuous dynamics over it"
                    } else {
                        "is a function of it"
                    }
                ),
            ));
            let guard = interval::guard(&parameter, scalar);
            (quote! { #guard #body }, ops.plus(interval::guard_ops()))
        }
        _ => (body, ops),
    };
    // A line per attribute: a sensor's own documentation comes before what the update does.
    let doc = doc.lines();
    let doc = quote! { #(#[doc = #doc])* };
    if model.delay() > 0 {
        let call = match kind {
            EkfMethod::Predict => Call::Predict,
            EkfMethod::Step => Call::Step,
            EkfMethod::Update | EkfMethod::UpdateOutput(_) => Call::Update,
            EkfMethod::UpdateSensor(s) => Call::Sensor(&model.sensors[s]),
        };
        let code = horizon_calls::wrap(call, (&name, &doc), arguments, body, (model, scalar));
        return Some((code, ops));
    }
    Some((arguments.method(&name, &doc, body), ops))
}

/// One EKF method before lowering: the model's graph with the method's variables, and
/// what the method computes (Alg. 1) through the shared Kalman stage.
struct EkfNodes {
    /// The model's graph, with the method's variables and nodes.
    g: ModelGraph,
    /// Names generated variables avoid.
    avoid: Vec<String>,
    /// The covariance, noise and measurement variables.
    vars: FilterVars,
    /// The variances of the input entries with noise (`spec.input_noise`), `qu1`, ...
    qu: Vec<NodeId>,
    /// In a prediction, when the model reads `t`: the previous sample's time, which the
    /// prediction runs from.
    t_prev: Option<NodeId>,
    /// In a correction, when the model reads `t`: the measurement's time, `t_prev + dt`
    /// in a step of continuous dynamics; `None` where it is the argument `t`.
    t_measured: Option<NodeId>,
    /// The new estimate.
    x: Vec<NodeId>,
    /// The new covariance.
    p: Matrix,
    /// In a step, the prediction it corrects (estimate and covariance), which it tests as
    /// `predict` does before the correction.
    predicted: Option<(Vec<NodeId>, Matrix)>,
    /// The innovation covariance's pivots, checked positive before their reciprocals.
    pivots: Vec<NodeId>,
    /// The pivots' reciprocals.
    reciprocals: Vec<NodeId>,
    /// The innovation a correction stores (every output's), else empty.
    innovation: Vec<NodeId>,
    /// Its covariance, packed.
    innovation_covariance: Vec<NodeId>,
    /// A correction's normalised innovation squared, tested against the gate or the
    /// divergence bound.
    nis: Option<NodeId>,
    /// Whether the filter has an innovation gate.
    gated: bool,
    /// Whether a refusal goes through the recovery stage (`recover_after`).
    recovers: bool,
    /// The Jacobians' entries bound to variables, each computed once.
    coefficients: Coefficients,
    /// The order the new covariance's entries are computed and stored in (positions in
    /// the packed triangle).
    order: Vec<usize>,
    /// The covariance's entries between two of its blocks (packed position, row and
    /// column; see [`CovarianceBlocks`]): read as zeros, left as they are.
    uncoupled: Vec<(usize, usize, usize)>,
}

impl EkfNodes {
    /// Declares the method's variables, then predicts (`x = f(x, u)`, `P = A P A' + Q`)
    /// and/or corrects (Joseph form) as `kind` asks.
    /// `None` if the method makes an entry between two of `blocks` non-zero (see
    /// [`CovarianceBlocks`]): such entries are read as zeros, and left as they are.
    fn build(
        model: &Model,
        mg: &ModelGraph,
        kind: EkfMethod,
        spec: &EkfSpec,
        blocks: &CovarianceBlocks,
    ) -> Option<EkfNodes> {
        let mut g = mg.clone();
        let outputs = kind.outputs(model);
        let avoid = model_names(model);
        let vars = FilterVars::declare(&mut g.graph, model, &outputs, &spec.process_noise, &avoid);
        let qu = (1..=spec.input_noise.len())
            .map(|i| g.graph.var(&unclaimed_name(format!("qu{i}"), &avoid)))
            .collect();
        let t_prev = (kind.predicts() && model.uses_time()).then(|| match kind {
            // A step evaluates `h` at another time than `f`: a variable of its own.
            EkfMethod::Step => g.graph.var("t_prev"),
            // `predict` evaluates the model at one time, the previous sample's.
            _ => g.name_time("t_prev"),
        });
        let t_measured = measurement_time(model, &mut g, kind, t_prev);
        let coefficients = Coefficients::new(&avoid);
        let uncoupled = blocks.uncoupled_entries();
        let mut p = symmetric_from_packed(&vars.p, model.tangent_len());
        let zero = g.graph.zero();
        for &(_, i, j) in &uncoupled {
            (p[i][j], p[j][i]) = (zero, zero);
        }
        let mut nodes = EkfNodes {
            x: g.x.clone(),
            p,
            g,
            avoid,
            vars,
            qu,
            t_prev,
            t_measured,
            predicted: None,
            pivots: Vec::new(),
            reciprocals: Vec::new(),
            innovation: Vec::new(),
            innovation_covariance: Vec::new(),
            nis: None,
            gated: match kind.sensor(model) {
                Some(sensor) => sensors::gate_of(sensor, spec.gate).is_some(),
                None => spec.gate.is_some(),
            },
            recovers: spec.recover_after.is_some(),
            coefficients,
            order: Vec::new(),
            uncoupled,
        };
        if kind.predicts() {
            nodes.predict(&spec.input_noise, kind.updates());
        }
        if kind.updates() {
            nodes.correct(model.outputs.len(), &outputs, kind.sensor(model).is_some());
            let rotations: Vec<_> = model
                .rotations()
                .iter()
                .map(|r| r.tangent..r.tangent + 3)
                .collect();
            nodes.order = in_place::update_order(model.tangent_len(), outputs.len(), &rotations);
        }
        let graph = &nodes.g.graph;
        let zero_between_blocks = |p: &Matrix| {
            let zero = |&(_, i, j): &(usize, usize, usize)| graph.is_zero(p[i][j]);
            nodes.uncoupled.iter().all(zero)
        };
        let predicted_holds = nodes
            .predicted
            .as_ref()
            .is_none_or(|(_, p)| zero_between_blocks(p));
        (predicted_holds && zero_between_blocks(&nodes.p)).then_some(nodes)
    }

    /// The prediction through the shared Kalman stage, the noise on the input entries
    /// `input_noise` included; kept as the prediction a step corrects if `corrected`.
    fn predict(&mut self, input_noise: &[usize], corrected: bool) {
        // With a sample interval, `Q` is a density: the noise of an interval `dt` is `Q dt`;
        // and `qu` too, a white noise's density, whose sample held over `dt` has the
        // variance `qu / dt`.
        let noisy: Vec<(usize, NodeId)> = match self.g.interval {
            Some(dt) => {
                let graph = &mut self.g.graph;
                // One division, whatever the number of noisy inputs.
                let one = graph.one();
                let per_second = graph.div(one, dt);
                let per_sample = self.qu.iter().map(|&qu| graph.mul(qu, per_second));
                input_noise.iter().copied().zip(per_sample).collect()
            }
            None => input_noise.iter().copied().zip(self.qu.clone()).collect(),
        };
        let q = match self.g.interval {
            Some(dt) => {
                let graph = &mut self.g.graph;
                let rows = self.vars.q_matrix.iter();
                rows.map(|row| row.iter().map(|&q| graph.mul(q, dt)).collect())
                    .collect()
            }
            None => self.vars.q_matrix.clone(),
        };
        let (x, p, a) = kalman::ekf_predict(
            &mut self.g,
            (&self.p, &q),
            &noisy,
            self.t_prev,
            &mut self.coefficients,
        );
        if corrected {
            self.predicted = Some((x.clone(), p.clone()));
        }
        (self.x, self.p) = (x, p);
        self.order = in_place::prediction_order(&self.g.graph, &a);
    }

    /// The Joseph-form correction with `outputs` (of `m`), through the shared Kalman
    /// stage, and what it stores: the innovation, its covariance and the normalised
    /// innovation squared; a sensor's (`own_fields`) in fields of their own size.
    fn correct(&mut self, m: usize, outputs: &[usize], own_fields: bool) {
        let r_all = &self.vars.r_matrix;
        let r: Matrix = outputs
            .iter()
            .map(|&i| outputs.iter().map(|&j| r_all[i][j]).collect())
            .collect();
        let mu = outputs.len();
        let correction = kalman::ekf_correct(
            &mut self.g,
            (self.t_measured, &self.x),
            &self.p,
            (&self.vars.y, outputs),
            &r,
            (
                &mut self.coefficients,
                |g: &mut crate::symbolic::Graph, j| g.var(&pivot_names(mu, j, INNOVATION, "").1),
            ),
        );
        let update = correction.update;
        (self.x, self.p) = (update.x, update.p);
        (self.pivots, self.reciprocals) = (update.pivots, update.reciprocals);
        let s = if mu == m || own_fields {
            self.innovation = correction.residual;
            update.s
        } else {
            // One output alone: the others' entries a zero innovation of unit variance,
            // uncorrelated, so that the stored NIS is this output's.
            let (zero, one) = (self.g.graph.zero(), self.g.graph.one());
            self.innovation = vec![zero; m];
            let mut s = vec![vec![zero; m]; m];
            for (i, row) in s.iter_mut().enumerate() {
                row[i] = one;
            }
            for (a, &i) in outputs.iter().enumerate() {
                self.innovation[i] = correction.residual[a];
                for (b, &j) in outputs.iter().enumerate() {
                    s[i][j] = update.s[a][b];
                }
            }
            s
        };
        self.innovation_covariance = packed_upper(&s);
        self.nis = Some(update.nis);
    }
}

/// The time a step's correction evaluates `h` at when the model reads `t` and its
/// dynamics are continuous: the measurement is a sample time `dt` after the previous
/// sample's `t_prev`. `None` otherwise: the correction is at the argument `t`.
fn measurement_time(
    model: &Model,
    g: &mut ModelGraph,
    kind: EkfMethod,
    t_prev: Option<NodeId>,
) -> Option<NodeId> {
    let t_prev = t_prev.filter(|_| kind == EkfMethod::Step)?;
    let dt = g.sample_time(model)?;
    Some(g.graph.add(t_prev, dt))
}

/// The sum the method's divergence test bounds: an update's of every new entry and
/// variance, each state's beside its own; a prediction's of those it changes.
fn divergence_probe(nodes: &mut EkfNodes, kind: EkfMethod) -> NodeId {
    if kind.updates() {
        interleaved_finiteness_probe(&mut nodes.g.graph, &nodes.x, &nodes.p)
    } else {
        let (x, p) = (nodes.x.clone(), nodes.p.clone());
        prediction_probe(nodes, &x, &p)
    }
}

/// A prediction's divergence probe: the sum of the entries and variances it changes.
fn prediction_probe(nodes: &mut EkfNodes, x: &[NodeId], p: &Matrix) -> NodeId {
    let stored: Vec<NodeId> = nodes.g.x.iter().chain(&nodes.vars.p).copied().collect();
    finiteness_probe_of_changes(&mut nodes.g.graph, x, p, &stored)
}

/// A step's test of its prediction (see [`in_place::test_prediction`]): its probe and
/// its variances, as roots to lower, then tested.
struct PredictionTest {
    probe: NodeId,
    variances: Vec<NodeId>,
}

impl PredictionTest {
    /// The test of a step's prediction; `None` in any other method.
    fn new(nodes: &mut EkfNodes) -> Option<PredictionTest> {
        let (x, p) = nodes.predicted.clone()?;
        let probe = prediction_probe(nodes, &x, &p);
        let variances = (0..p.len()).map(|i| p[i][i]).collect();
        Some(PredictionTest { probe, variances })
    }

    /// Names the prediction's entries (`x1_pred`, `p11_pred`; the correction's names,
    /// given after, win where they are the same values) and tests it, its variances
    /// that are sums of `known_variances` untested.
    fn lower(
        &self,
        lowerer: &mut Lowerer,
        (model, nodes): (&Model, &EkfNodes),
        known_variances: &[NodeId],
        scalar: Scalar,
    ) {
        if let Some((x, p)) = &nodes.predicted {
            name_results(lowerer, model, x, &nodes.vars.p, &packed_upper(p), "pred");
        }
        in_place::test_prediction(
            lowerer,
            self.probe,
            &self.variances,
            known_variances,
            scalar,
        );
    }
}

/// Every value an EKF method lowers: the new estimate and packed covariance `p_packed`,
/// the divergence `probe`, a step's test of its prediction, the pivots and what the
/// measurement stage keeps.
fn roots(
    nodes: &EkfNodes,
    p_packed: &[NodeId],
    probe: NodeId,
    prediction_test: Option<&PredictionTest>,
) -> Vec<NodeId> {
    let mut all_roots: Vec<NodeId> = nodes.x.iter().chain(p_packed).copied().collect();
    all_roots.push(probe);
    if let Some(test) = prediction_test {
        all_roots.push(test.probe);
        all_roots.extend(&test.variances);
    }
    all_roots.extend(&nodes.pivots);
    all_roots.extend(&nodes.innovation);
    all_roots.extend(&nodes.innovation_covariance);
    all_roots.extend(nodes.nis);
    all_roots
}

/// The new covariance as the method stores it, packed: an entry between two blocks (zero
/// before and after, see [`CovarianceBlocks`]) is its old variable, left as it is, neither
/// read nor written.
fn committed_covariance(nodes: &EkfNodes) -> Vec<NodeId> {
    let mut p_packed = packed_upper(&nodes.p);
    for &(k, _, _) in &nodes.uncoupled {
        p_packed[k] = nodes.vars.p[k];
    }
    p_packed
}

/// Lowers an EKF method: its statements, ending in the commit of the new estimate (with
/// the innovation when it stores one), the variables they read, and their arithmetic.
fn lower(
    nodes: &mut EkfNodes,
    model: &Model,
    scalar: Scalar,
    kind: EkfMethod,
) -> (TokenStream, BTreeSet<VarId>, OpCount) {
    let probe = divergence_probe(nodes, kind);
    let prediction_test = PredictionTest::new(nodes);
    let p_packed = committed_covariance(nodes);
    let all_roots = roots(nodes, &p_packed, probe, prediction_test.as_ref());
    let (g, vars) = (&nodes.g, &nodes.vars);
    let namer = TempNamer::new(nodes.avoid.iter().map(String::as_str));
    let mut lowerer = Lowerer::new(&g.graph, scalar, namer, &all_roots);
    lowerer.read_lazily(&quote! { self.x }, &g.x);
    // A covariance the registers hold is read once (see `Commit::reread`).
    let reread = vars.p.len() > crate::emit::registers::FPU_REGISTERS;
    let slots = CovarianceSlots::read(&mut lowerer, &vars.p, &nodes.avoid, reread);
    lowerer.read_lazily(&quote! { self.q }, &vars.q);
    lowerer.read_lazily(&quote! { self.qu }, &nodes.qu);
    vars.read_measurement_noise(&mut lowerer);
    lowerer.read_lazily(&quote! { self.known }, &g.known);
    for &(var, value) in &nodes.coefficients.definitions {
        lowerer.define(var, value);
    }
    let variances = nodes.vars.variances(model.tangent_len());
    if let Some(test) = &prediction_test {
        test.lower(&mut lowerer, (model, nodes), &variances, scalar);
    }
    let suffix = if kind.updates() { "new" } else { "pred" };
    name_results(&mut lowerer, model, &nodes.x, &vars.p, &p_packed, suffix);
    guard_pivots(
        &mut lowerer,
        &nodes.pivots,
        &nodes.reciprocals,
        (INNOVATION, ""),
        &innovation_pivot_failure,
        scalar,
    );
    let sensor = kind.sensor(model);
    let stored = match sensor {
        Some(sensor) => sensor.outputs.clone(),
        None => (0..model.outputs.len()).collect(),
    };
    measurement::name_innovation_of(&mut lowerer, model, &stored, &nodes.innovation, "");
    let probe = lowerer.bind(probe, "divergence_probe");
    let prefix = sensor.map(sensors::prefix).unwrap_or_default();
    let kept = measurement::Kept {
        prefix: &prefix,
        innovation: &nodes.innovation,
        covariance: &nodes.innovation_covariance,
        nis: nodes.nis,
        gated: nodes.gated,
        gate_prefix: &prefix,
        keep_prediction: (kind == EkfMethod::Step)
            .then(|| measurement::keep_prediction_call(model)),
        recovers: nodes.recovers,
    };
    let store_innovation = measurement::store_and_gate(&mut lowerer, &kept);
    let commit = in_place::Commit {
        probe: &probe,
        x: &nodes.x,
        x_vars: &g.x,
        p: &p_packed,
        slots: &slots,
        order: &nodes.order,
        known_variances: &variances,
        avoid: &nodes.avoid,
        reread,
    };
    let committed = in_place::commit(&mut lowerer, &commit, scalar);
    let Lowered {
        statements,
        used_vars,
        ops,
    } = in_place::finish(lowerer, &slots, &committed);
    let tail = quote! { #store_innovation Status::Ok };
    let statements = crate::emit::scopes::scoped(statements, &tail);
    (quote! { #(#statements)* #tail }, used_vars, ops)
}

/// The method's arguments: the times where the model reads `t` (the previous sample's
/// `t_prev` of a prediction, which a gated step passes on to `predict` when it rejects an
/// outlier, so always reads; the measurement's `t` of a correction, unless a step knows
/// it), the input `u_prev` of a prediction, the input `u` of a correction whose outputs
/// read it (`reads_input`), the measurement `y` of a correction (a scalar for one output
/// alone).
fn arguments(
    nodes: &EkfNodes,
    model: &Model,
    kind: EkfMethod,
    (used_vars, reads_input): (&BTreeSet<VarId>, bool),
    ty: &proc_macro2::Ident,
) -> Arguments {
    let g = &nodes.g;
    let graph = &g.graph;
    let mut arguments = Arguments::default();
    if let Some(t_prev) = nodes.t_prev {
        let passed_on = nodes.gated && kind == EkfMethod::Step;
        let read = passed_on || reads_variable(graph, t_prev, used_vars);
        arguments.time("t_prev", read, ty);
    }
    if model.uses_time() && kind.updates() && nodes.t_measured.is_none() {
        arguments.time("t", reads_variable(graph, g.t, used_vars), ty);
    }
    if let (true, Some(dt), Some(name)) = (kind.predicts(), g.interval, model.interval_parameter())
    {
        // A gated step passes it on to `predict` when it keeps the prediction.
        let passed_on = nodes.gated && kind == EkfMethod::Step;
        arguments.time(&name, passed_on || reads_variable(graph, dt, used_vars), ty);
    }
    if kind.predicts() && !g.u.is_empty() {
        arguments.array("u_prev", var_idents(graph, &g.u), ty);
    }
    if reads_input {
        arguments.array("u", var_idents(graph, &g.u), ty);
    }
    let y = var_idents(graph, &nodes.vars.y);
    match kind {
        EkfMethod::Predict => {}
        EkfMethod::UpdateOutput(_) => arguments.scalar("y", y[0].clone(), ty),
        EkfMethod::Update | EkfMethod::Step | EkfMethod::UpdateSensor(_) => {
            arguments.array("y", y, ty);
        }
    }
    arguments
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
    name_estimate(lowerer, model, x, suffix);
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
