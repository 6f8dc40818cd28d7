//! The continuous filters' methods. The hybrid (continuous-discrete) EKF of Takacs, Poloni and Rohal-Ilkiv
//! ("Adaptive predictive control of transient vibrations of cantilevers with changing
//! weight", sect. 3.2): between samples the estimate follows `x' = f(x, u)` and its
//! covariance `P' = F P + P F' + Q` (eq. 21), integrated together with the model's rule and
//! sub-steps (a loop when there are several); at each sample the discrete Joseph-form
//! update (eqs. 24-26), shared with the EKF. The continuous-time EKF of Kulkarni and Purwar
//! (eq. 5) adds the measurement terms `K (y - h)` and `- P H' R^-1 H P` to those equations;
//! it integrates the whole equations by RK4 while they are not stiff, else split
//! symmetrically: the measurement terms' exact flow (the discrete update with the noise
//! density over the time it covers) on either side of the same propagation without them
//! (see [`FilterMethod::Continuous`] and [`FilterMethod::ContinuousSplit`]).

use crate::emit::arguments::Arguments;
use crate::emit::code::{
    commit_or_non_finite_with, guard_pivots, innovation_pivot_failure, pivot_names, var_idents,
    INNOVATION,
};
use crate::emit::filter::{
    correction_reads_input, finiteness_probe, model_names, name_estimate, packed_vars,
    reads_variable, unclaimed_name, FilterVars, ProcessNoise, MEASUREMENT_INPUT_DOC,
};
use crate::emit::interval;
use crate::emit::lower::{Lowered, Lowerer, OpCount};
use crate::emit::measurement;
use crate::emit::names::{ident, TempNamer};
use crate::emit::substeps::{lower_loop, Carried, SubstepLoop, P_SUB, T_SUB, X_SUB};
use crate::model::{Method, Model, Scalar};
use crate::symbolic::continuous::{
    covariance_rate, euler_covariance_step, integrate_substep, join, split, AtPoint,
};
use crate::symbolic::euler_state::euler_state_step;
use crate::symbolic::linalg::{
    packed_len, packed_upper, symmetric_from_packed, Coefficients, Matrix,
};
use crate::symbolic::measurement_terms::{
    innovation_feedback, measurement_stiffness, riccati_measurement_terms,
};
use crate::symbolic::scaled_covariance::Scaling;
use crate::symbolic::{kalman, Graph, ModelGraph, NodeId, VarId};
use proc_macro2::TokenStream;
use quote::quote;
use std::collections::BTreeSet;

/// Which method to generate.
#[derive(Clone, Copy, PartialEq, Eq)]
pub enum FilterMethod {
    /// The hybrid EKF's propagation over one sample.
    Predict,
    /// The hybrid EKF's update at a sample.
    Update,
    /// Both.
    Step,
    /// The continuous-time EKF's step: state and Riccati equations with the measurement
    /// terms (Kulkarni and Purwar, eq. 5) over one sample, with `y` held; with `alpha`, a
    /// prescribed degree of stability (Reif et al.).
    ///
    /// The whole equations by RK4 (of the fourth order in `T`) while the measurement terms
    /// are not stiff: while `T tr(R^-1 H P H')`, at least `T` times the largest rate
    /// `P H' R^-1 H` pulls the estimate at, is within [`WHOLE_STEP_STIFFNESS`], well inside
    /// RK4's stability region (the covariance's rates are twice the estimate's). A stiffer
    /// sample (a precise sensor, an uncertain start: `P0 = 1`, `R = 5.5e-8` on the
    /// helicopter at 1 ms makes it 1.8e4), or an `R` that is not positive definite, takes
    /// [`FilterMethod::ContinuousSplit`]'s step (`step_split`), stable for any gain. Only
    /// for a model of one RK4 sub-step per sample (see [`integrates_whole`]).
    Continuous {
        /// Whether the filter has the field `alpha`.
        alpha: bool,
    },
    /// The continuous-time EKF's step integrated split, symmetrically (Strang): the
    /// measurement terms alone over half the sample, `x' = P H' R^-1 (y - h(x))`,
    /// `P' = -P H' R^-1 H P`, by their exact flow; then the equations without them over the
    /// sample, by the model's rule and sub-steps, as the hybrid EKF propagates; then the
    /// measurement terms' flow over the other half. With `H` held, `d(P^-1)/dt = H' R^-1 H`
    /// gives `P(t) = (P^-1 + t H' R^-1 H)^-1 = P - P H' (H P H' + R / t)^-1 H P`, and
    /// `d(P^-1 x)/dt = H' R^-1 y` gives `x(t) = x + K (y - H x)` with the same gain: the
    /// discrete Joseph-form update with the measurement noise `R / t`, here `2 R / T`. The
    /// exact flow is stable for any gain and keeps `P` positive definite; the splitting's
    /// error is of the second order in `T`. As the fallback of the whole equations' step
    /// (only stiff samples: an uncertain start) it takes two such sub-steps of `T / 2`, the
    /// propagation by one RK4 step each, the halves between them one flow over `T / 2`:
    /// a quarter of the error, where the first samples' error decides what follows.
    ContinuousSplit {
        /// Whether the filter has the field `alpha`.
        alpha: bool,
        /// Whether it is the private `step_split` that [`FilterMethod::Continuous`] falls
        /// back on, rather than the filter's `step`.
        fallback: bool,
    },
    /// The continuous-time EKF's step without the measurement terms: its propagation alone,
    /// for a sample without a measurement and for a gated step's outlier.
    ContinuousPredict {
        /// Whether the filter has the field `alpha`.
        alpha: bool,
    },
}

impl FilterMethod {
    /// Whether the method integrates over the sample.
    fn predicts(self) -> bool {
        self != FilterMethod::Update
    }

    /// Whether the method corrects with a measurement (the continuous-time EKF's through
    /// its measurement terms).
    fn updates(self) -> bool {
        !matches!(
            self,
            FilterMethod::Predict | FilterMethod::ContinuousPredict { .. }
        )
    }

    /// Whether the propagation has the prescribed degree of stability `alpha`.
    fn has_alpha(self) -> bool {
        matches!(
            self,
            FilterMethod::Continuous { alpha: true }
                | FilterMethod::ContinuousSplit { alpha: true, .. }
                | FilterMethod::ContinuousPredict { alpha: true }
        )
    }

    /// Whether it is one of the continuous-time EKF's steps.
    fn is_continuous(self) -> bool {
        matches!(
            self,
            FilterMethod::Continuous { .. } | FilterMethod::ContinuousSplit { .. }
        )
    }

    /// What the method's documentation says of its times, for a model that reads `t`.
    fn time_doc(self) -> &'static str {
        match self {
            FilterMethod::Predict | FilterMethod::ContinuousPredict { .. } => {
                " The integration starts at `t_prev`, the previous sample's time."
            }
            FilterMethod::Update => " `h` is evaluated at `t`, the measurement's time.",
            FilterMethod::Step => {
                " The integration starts at `t_prev`, the previous sample's time, and `h` is \
                 evaluated a sample time `dt` later, at `t_prev + dt`."
            }
            FilterMethod::Continuous { .. } | FilterMethod::ContinuousSplit { .. } => {
                " The integration starts at `t_prev`, the previous sample's time, where the \
                 innovation is taken."
            }
        }
    }

    /// What the method does over the sample interval, where the model declares one (see
    /// [`crate::emit::interval::doc`]).
    fn interval_doc(self) -> &'static str {
        match self {
            FilterMethod::Predict | FilterMethod::Step | FilterMethod::Update => {
                "the estimate and its covariance are integrated over it, in \
                 [`Self::SUBSTEPS`] sub-steps of `dt / SUBSTEPS`, the process noise density \
                 `Q` with them"
            }
            FilterMethod::ContinuousPredict { .. } => {
                "the estimate and the Riccati equation are integrated over it, in \
                 [`Self::SUBSTEPS`] sub-steps of `dt / SUBSTEPS`, the process noise density \
                 `Q` with them"
            }
            FilterMethod::Continuous { .. } | FilterMethod::ContinuousSplit { .. } => {
                "the estimate and the Riccati equation are integrated over it with the \
                 measurement held (in [`Self::SUBSTEPS`] sub-steps of `dt / SUBSTEPS` between \
                 the measurement terms' flows), the noise densities `Q` and `R` with them, and \
                 the innovation's covariance is `H P H' + R / dt`"
            }
        }
    }

    /// The method's name and documentation.
    fn name_and_doc(self) -> (&'static str, &'static str) {
        match self {
            FilterMethod::Predict => (
                "predict",
                " Integrates the estimate and its covariance over one sample (eqs. 21-23) with \
                 the input `u_prev` held. Rejects a non-finite input; leaves the filter \
                 unchanged unless it returns [`Status::Ok`].",
            ),
            FilterMethod::Update => (
                "update",
                " Corrects the estimate with the measurement `y` (eqs. 24-26, Joseph form). \
                 Rejects a non-finite measurement and a non-positive innovation variance (never \
                 divided by); leaves the filter unchanged unless it returns [`Status::Ok`].",
            ),
            FilterMethod::Step => (
                "step",
                " One sample: integrates `x[k-1]` and its covariance to the sample `k` with the \
                 input `u[k-1]` held (eqs. 21-23), then corrects them with the measurement \
                 `y[k]` (eqs. 24-26). Leaves the filter unchanged unless it returns \
                 [`Status::Ok`].",
            ),
            FilterMethod::Continuous { .. } => (
                "step",
                " One sample: integrates the estimate and the Riccati equation (eq. 5) from \
                 `x[k-1]` to the sample `k` with the input `u[k-1]` and the measurement `y` \
                 (normally `y[k]`) held over the sample, the whole equations by RK4 while the \
                 measurement terms are not stiff (`T tr(R^-1 H P H')` at most 0.1), else \
                 split, stable for any gain (see the type's documentation). The innovation `y - h(x[k-1])` and its covariance \
                 `H P H' + R / T` are taken at the start of the sample. Rejects a non-finite \
                 input or measurement and a non-positive innovation variance (never divided \
                 by); leaves the filter unchanged unless it returns [`Status::Ok`].",
            ),
            FilterMethod::ContinuousSplit { fallback, .. } => (
                if fallback { "step_split" } else { "step" },
                " One sample: integrates the estimate and the Riccati equation (eq. 5) from \
                 `x[k-1]` to the sample `k` with the input `u[k-1]` and the measurement `y` \
                 (normally `y[k]`) held over the sample, split symmetrically (Strang): in each \
                 part of the sample, the exact flow of the measurement terms over half of it \
                 (the Joseph-form update with the measurement noise `R` over that time), the \
                 propagation without them over the part, their flow over the other half (one \
                 part, the whole sample, around a model's Euler or several sub-steps; two \
                 halves of the sample where it is the whole equations' fallback). The innovation `y - h(x[k-1])` and its covariance \
                 `H P H' + R / T` are taken at the start of the sample. Rejects a non-finite \
                 input or measurement and a non-positive innovation variance (never divided \
                 by); leaves the filter unchanged unless it returns [`Status::Ok`].",
            ),
            FilterMethod::ContinuousPredict { .. } => (
                "predict",
                " Integrates the estimate and the Riccati equation (eq. 5) over one sample \
                 without the measurement terms, with the input `u_prev` held: the sample \
                 without a measurement (a sensor dropout), and what a gated step keeps of an \
                 outlier. Rejects a non-finite input; leaves the filter unchanged unless it \
                 returns [`Status::Ok`].",
            ),
        }
    }
}

/// The options of a filter that shape each of its methods.
#[derive(Clone)]
pub struct FilterOptions {
    /// The process noise's shape.
    pub noise: ProcessNoise,
    /// Whether the filter has an innovation gate, which its corrections pass.
    pub gated: bool,
    /// Whether it recovers after a run of refusals (`recover_after`, see
    /// [`crate::emit::recovery`]).
    pub recovers: bool,
}

impl FilterOptions {
    /// The options of a filter with the process noise `noise`, the gate `gate` and the
    /// recovery after `recover_after` refusals, as its spec gives them.
    pub fn of(noise: &ProcessNoise, gate: Option<f64>, recover_after: Option<u32>) -> Self {
        FilterOptions {
            noise: noise.clone(),
            gated: gate.is_some(),
            recovers: recover_after.is_some(),
        }
    }
}

/// One method: the propagation between samples and/or the update at the sample, built
/// symbolically, then lowered (the sub-steps as a loop when there are several). Returns
/// the method, the arithmetic of all of it and that of one sub-step.
pub fn method(
    model: &Model,
    mg: &ModelGraph,
    scalar: Scalar,
    kind: FilterMethod,
    options: &FilterOptions,
) -> (TokenStream, OpCount, OpCount) {
    let mut nodes = MethodNodes::build(model, mg, kind, options);
    let lowered = lower(&mut nodes, model, scalar, kind);
    let ty = ident(scalar.type_name());
    let (graph, used_vars) = (&nodes.g.graph, &lowered.used_vars);
    let reads_input = correction_reads_input(graph, &nodes.g.u, kind.predicts(), used_vars);
    let arguments = arguments(&nodes, model, kind, (used_vars, reads_input), &ty);
    let (name, doc) = kind.name_and_doc();
    let time_doc = if model.uses_time() {
        kind.time_doc()
    } else {
        ""
    };
    let input_doc = if reads_input {
        MEASUREMENT_INPUT_DOC
    } else {
        ""
    };
    let mut doc = format!("{doc}{time_doc}{input_doc}");
    let (mut body, mut total) = (lowered.body, lowered.total);
    if let (Some(dt), Some(parameter)) = (nodes.g.interval, model.interval_parameter()) {
        if reads_variable(graph, dt, used_vars) {
            doc.push_str(&interval::doc(&parameter, kind.interval_doc()));
            let guard = interval::guard(&parameter, scalar);
            body = quote! { #guard #body };
            total = total.plus(interval::guard_ops());
        }
    }
    let doc = quote! { #[doc = #doc] };
    let tokens = if matches!(kind, FilterMethod::ContinuousSplit { fallback: true, .. }) {
        arguments.private_method(&ident(name), &doc, body)
    } else {
        arguments.method(&ident(name), &doc, body)
    };
    (tokens, total, lowered.per_substep)
}

/// The continuous dynamics a propagation integrates, built once over the variables
/// `t_sub` and `x` and evaluated at each stage by substitution: `dx/dt = f(t, x, u)`,
/// `F = df/dx`, the process noise density `Q` and the prescribed degree of stability.
struct Dynamics {
    /// The state's length.
    n: usize,
    /// `dx/dt` over the variables.
    rate_x: Vec<NodeId>,
    /// `F = df/dx` over the variables.
    jacobian: Matrix,
    /// Evaluation at a point `[t, x..]`.
    at: AtPoint,
    /// The process noise density.
    q: Matrix,
    /// The variable `alpha`, when the filter has the field.
    alpha: Option<NodeId>,
    /// The variable `2 alpha` and its value.
    two_alpha: Option<(NodeId, NodeId)>,
    /// The measurement terms, where the whole equations are integrated.
    measurement: Option<MeasurementTerms>,
}

/// Whether the continuous-time EKF of `model` integrates its whole equations while they are
/// not stiff ([`FilterMethod::Continuous`]): a model of one RK4 sub-step per sample. With
/// Euler's rule, whose error is of the first order, or several sub-steps, it integrates
/// them split ([`FilterMethod::ContinuousSplit`]) always.
pub fn integrates_whole(model: &Model, mg: &ModelGraph) -> bool {
    let mut g = mg.clone();
    matches!(g.substep(model), Some((Method::Rk4, _, 1)))
}

/// The largest `T tr(R^-1 H P H')` at which the continuous-time EKF's step integrates the
/// whole equations by RK4 (see [`FilterMethod::Continuous`]): the rates it pulls the
/// covariance at, at most twice that, stay well inside RK4's stability interval (2.78).
/// RK4's local error of a decaying mode `exp(z)` is `z^5 / 120` of it: 1e-7 at `z = -0.1`,
/// 3e-6 at the bound's `z = -0.2`, so a filter that stays near the bound sample after sample
/// follows its equations less closely than 1e-6 (the helicopter's samples, past the stiff
/// start, sit far below it).
pub const WHOLE_STEP_STIFFNESS: f64 = 0.1;

/// The measurement terms of the continuous-time EKF's whole equations (Kulkarni and Purwar,
/// eq. 5): `R^-1` through guarded pivots, `h` and `H` over the point `[t, x..]`.
struct MeasurementTerms {
    /// `R^-1`, over the reciprocals of its pivots.
    r_inv: Matrix,
    /// `R`'s pivots, checked positive (else the step falls back on the split).
    r_pivots: Vec<NodeId>,
    /// Their reciprocals.
    r_reciprocals: Vec<NodeId>,
    /// `h` over the point.
    h: Vec<NodeId>,
    /// `H = dh/dx` over the point.
    jacobian_h: Matrix,
    /// Evaluation at a point `[t, x..]`.
    at: AtPoint,
    /// The measurement's variables.
    y: Vec<NodeId>,
}

/// The names of `R`'s pivots and their reciprocals in the whole equations' step.
const NOISE_PIVOTS: ((&str, &str), &str) = (("measurement_variance", "inv_r"), "_r");

impl MeasurementTerms {
    /// `R^-1` of the measurement noise density's variables and `h`, `H` over `[t, x..]`.
    fn new(g: &mut ModelGraph, vars: &FilterVars, m: usize) -> MeasurementTerms {
        let r = vars.r_matrix.clone();
        let (prefixes, suffix) = NOISE_PIVOTS;
        let ldl = crate::symbolic::linalg::ldl_inverse(&mut g.graph, &r, |gr, j| {
            gr.var(&pivot_names(m, j, prefixes, suffix).1)
        });
        let jacobian_h = g.jacobian_h_wrt_x();
        let at = AtPoint::new(
            std::iter::once(g.t)
                .chain(g.x.iter().copied())
                .map(|v| g.var_id(v))
                .collect(),
        );
        MeasurementTerms {
            r_inv: ldl.inverse,
            r_pivots: ldl.pivots,
            r_reciprocals: ldl.reciprocals,
            h: g.h.clone(),
            jacobian_h,
            at,
            y: vars.y.clone(),
        }
    }

    /// `dx + K (y - h(x))` and `dp - P H' R^-1 H P` at `point = [t, x..]`.
    fn apply(
        &self,
        g: &mut Graph,
        point: &[NodeId],
        (dx, dp): (&[NodeId], &Matrix),
        p: &Matrix,
    ) -> (Vec<NodeId>, Matrix) {
        let h = self.at.eval(g, point, &self.h);
        let jacobian_h = self.at.eval_matrix(g, point, &self.jacobian_h);
        let (gain, dp) = riccati_measurement_terms(g, dp, p, &jacobian_h, &self.r_inv);
        (innovation_feedback(g, dx, &gain, &self.y, &h), dp)
    }

    /// `T tr(R^-1 H P H')` at `point = [t, x..]` with the covariance `p`.
    fn stiffness(&self, g: &mut Graph, duration: NodeId, point: &[NodeId], p: &Matrix) -> NodeId {
        let jacobian_h = self.at.eval_matrix(g, point, &self.jacobian_h);
        measurement_stiffness(g, duration, p, &jacobian_h, &self.r_inv)
    }
}

impl Dynamics {
    /// The dynamics of `model` over the variables `t_sub` and the state, for `kind`.
    fn new(
        g: &mut ModelGraph,
        model: &Model,
        kind: FilterMethod,
        vars: &FilterVars,
        t_sub: NodeId,
        avoid: &[String],
    ) -> Dynamics {
        let x_vars = g.x.clone();
        let rate_x = g.derivative(model, t_sub, &x_vars);
        let jacobian = g.jacobian(&rate_x, &x_vars);
        let at = AtPoint::new(
            std::iter::once(t_sub)
                .chain(x_vars.iter().copied())
                .map(|v| g.var_id(v))
                .collect(),
        );
        // A model symbol may be called `alpha`: the local must not shadow it.
        let alpha = kind
            .has_alpha()
            .then(|| g.graph.var(&unclaimed_name(String::from("alpha"), avoid)));
        // `2 alpha` under a name of its own, computed once: the Riccati equation's
        // `2 alpha P_ij` is then one multiply-add per entry and stage, where the simplifier
        // would write `2 (P_ij alpha)`, two multiplications and an addition.
        let two_alpha = alpha.map(|alpha| {
            let two = g.graph.num(2.0);
            let value = g.graph.mul(two, alpha);
            let var = g
                .graph
                .var(&unclaimed_name(String::from("two_alpha"), avoid));
            (var, value)
        });
        let measurement = matches!(kind, FilterMethod::Continuous { .. })
            .then(|| MeasurementTerms::new(g, vars, model.outputs.len()));
        Dynamics {
            n: model.state_len(),
            rate_x,
            jacobian,
            at,
            q: vars.q_matrix.clone(),
            alpha,
            two_alpha,
            measurement,
        }
    }

    /// `dz/dt` of the joined estimate and covariance `z` at time `t`: `f` and
    /// `F P + P F' + Q` (eq. 21, with `alpha` eq. 26), with the measurement terms of the
    /// continuous-time EKF's whole equations (eq. 5).
    fn rate(&self, g: &mut Graph, t: NodeId, z: &[NodeId]) -> Vec<NodeId> {
        let (xs, ps) = split(z, self.n);
        let point: Vec<NodeId> = std::iter::once(t).chain(xs.iter().copied()).collect();
        let mut dx = self.at.eval(g, &point, &self.rate_x);
        let f = self.at.eval_matrix(g, &point, &self.jacobian);
        let two_alpha = self.two_alpha.map(|(var, _)| var);
        let mut dp = covariance_rate(g, &f, &ps, &self.q, two_alpha);
        if let Some(terms) = &self.measurement {
            (dx, dp) = terms.apply(g, &point, (&dx, &dp), &ps);
        }
        join(&dx, &dp)
    }

    /// One sub-step of length `h` from time `t0` of the estimate `x` and covariance `p`,
    /// joined: the model's rule on [`Dynamics::rate`], except that an Euler sub-step takes
    /// the covariance of the Euler step itself (see `euler_covariance_step`), with
    /// `scaling` of the covariance `D p D` scaled (see `scaled_covariance`).
    fn substep(
        &self,
        g: &mut Graph,
        (rule, h): (Method, NodeId),
        t0: NodeId,
        (x, p): (&[NodeId], &Matrix),
        scaling: Option<&Scaling>,
    ) -> Vec<NodeId> {
        if rule == Method::Rk4 {
            let mut rate = |g: &mut Graph, t: NodeId, z: &[NodeId]| self.rate(g, t, z);
            return integrate_substep(g, rule, h, t0, &join(x, p), &mut rate);
        }
        debug_assert!(
            self.measurement.is_none(),
            "the whole equations are integrated by RK4 only"
        );
        let point: Vec<NodeId> = std::iter::once(t0).chain(x.iter().copied()).collect();
        let dx = self.at.eval(g, &point, &self.rate_x);
        let f = self.at.eval_matrix(g, &point, &self.jacobian);
        let p_next = match scaling {
            Some(scaling) => scaling.covariance_step(g, &f, self.alpha, p, &self.q),
            None => euler_covariance_step(g, h, &f, self.alpha, p, &self.q),
        };
        let x_next = euler_state_step(g, h, x, &dx, &f, scaling);
        join(&x_next, &p_next)
    }
}

/// One method before lowering: the model's graph with the method's variables, and what
/// it computes: the propagation (one sub-step, carried by a loop, or the sub-steps
/// unrolled) and/or the update at the sample.
struct MethodNodes {
    /// The model's graph, with the method's variables and nodes.
    g: ModelGraph,
    /// In the hybrid EKF's step, its prediction's divergence probe and variances, tested
    /// as `predict` tests them, before the update.
    prediction_test: Option<(NodeId, Vec<NodeId>)>,
    /// Names generated variables avoid.
    avoid: Vec<String>,
    /// The covariance, noise and measurement variables.
    vars: FilterVars,
    /// The dynamics integrated.
    dynamics: Dynamics,
    /// Sub-steps per sample.
    substeps: u32,
    /// Whether the sub-steps run as a loop (a propagation of several).
    looped: bool,
    /// The scaling of the covariance the loop carries, if any (see `scaled_covariance`).
    scaling: Option<Scaling>,
    /// The packed covariance's variables in the loop: `p`'s, or the scaled ones.
    p_loop: Vec<NodeId>,
    /// The value the loop starts them from: `P`, or `D P D` (packed).
    p_initial: Vec<NodeId>,
    /// The estimate the loop starts from: `x`, or a split step's after the first half of
    /// its measurement terms.
    x_initial: Vec<NodeId>,
    /// The estimate's variables in the loop: `x`'s, or (a split step's) their own.
    x_loop: Vec<NodeId>,
    /// The time the integration starts at: `t_prev` where the model reads time.
    t_start: NodeId,
    /// A step's measurement time, `t_prev + dt`, where the model reads time.
    t_measured: Option<NodeId>,
    /// The loop's running time.
    t_sub: NodeId,
    /// The new estimate (after the loop, over the carried variables).
    x: Vec<NodeId>,
    /// The new covariance.
    p: Matrix,
    /// The loop's carried values after one sub-step: state, packed covariance, time.
    loop_next: Vec<NodeId>,
    /// The innovation covariance's pivots, checked positive before their reciprocals.
    pivots: Vec<NodeId>,
    /// The pivots' reciprocals.
    reciprocals: Vec<NodeId>,
    /// The innovation of an update (every output), else empty.
    innovation: Vec<NodeId>,
    /// Its covariance, packed.
    innovation_covariance: Vec<NodeId>,
    /// An update's normalised innovation squared, tested against the gate or the
    /// divergence bound.
    nis: Option<NodeId>,
    /// Whether the filter has an innovation gate.
    gated: bool,
    /// Whether a refusal goes through the recovery stage.
    recovers: bool,
    /// The measurement Jacobian's entries bound to variables, each computed once.
    coefficients: Coefficients,
    /// The whole equations' `T tr(R^-1 H P H')` at the start, tested before they are
    /// integrated.
    stiffness: Option<NodeId>,
    /// The split step's exact flows of the measurement terms: the pivots of each update,
    /// their reciprocals and the suffix of their names.
    flows: Vec<(Vec<NodeId>, Vec<NodeId>, &'static str)>,
}

/// The time the method's model starts from: the model's `t` where it reads none or in an
/// update; `predict`'s previous sample's time, under the name `t_prev`; a variable of its
/// own, `t_prev`, in a step (whose update is at another time) and the continuous-time EKF
/// (whose running time is).
fn start_time(g: &mut ModelGraph, model: &Model, kind: FilterMethod) -> NodeId {
    match kind {
        _ if !model.uses_time() => g.t,
        FilterMethod::Predict | FilterMethod::ContinuousPredict { .. } => g.name_time("t_prev"),
        FilterMethod::Step
        | FilterMethod::Continuous { .. }
        | FilterMethod::ContinuousSplit { .. } => g.graph.var("t_prev"),
        FilterMethod::Update => g.t,
    }
}

/// A sub-step's rule, its step and the sample time.
type Rule = (Method, NodeId, NodeId);

/// The variables of a split step's loop: it starts after the first half of the measurement
/// terms, so it runs over variables of its own (which name its values after it too): the
/// estimate's, `psi_sub..`, and the covariance's, `ps11..` (already its own where it is
/// scaled).
fn split_loop_vars(
    g: &mut ModelGraph,
    model: &Model,
    avoid: &[String],
    (scaling, p_loop): (&Option<Scaling>, Vec<NodeId>),
) -> (Vec<NodeId>, Vec<NodeId>) {
    let x_loop = model
        .state_names()
        .map(|name| g.graph.var(&unclaimed_name(format!("{name}_sub"), avoid)))
        .collect();
    let p_loop = match scaling {
        Some(_) => p_loop,
        None => packed_vars(&mut g.graph, "ps", model.state_len(), avoid),
    };
    (x_loop, p_loop)
}

/// The covariance a loop of Euler sub-steps (`scaled`, with the sub-step `h`) carries:
/// scaled (`D P D`, [`Scaling::for_unit_couplings`]) where the sub-step is a known constant
/// and a scaling is taken, with the loop's variables `ps..` and their initial values from
/// `P`; else `P`'s own variables (`p`, packed) for both.
fn loop_covariance(
    g: &mut ModelGraph,
    (scaled, h): (bool, NodeId),
    jacobian: &Matrix,
    p: &[NodeId],
    avoid: &[String],
) -> (Option<Scaling>, Vec<NodeId>, Vec<NodeId>) {
    let scaling = scaled
        .then(|| g.graph.constant_value(h))
        .flatten()
        .and_then(|h| Scaling::for_unit_couplings(&g.graph, jacobian, h));
    let Some(scaling) = scaling else {
        return (None, p.to_vec(), p.to_vec());
    };
    let n = jacobian.len();
    let full = symmetric_from_packed(p, n);
    let initial = packed_upper(&scaling.apply(&mut g.graph, &full, 1));
    let p_loop = packed_vars(&mut g.graph, "ps", n, avoid);
    (Some(scaling), p_loop, initial)
}

impl MethodNodes {
    /// Declares the method's variables, then integrates and/or updates as `kind` asks.
    fn build(
        model: &Model,
        mg: &ModelGraph,
        kind: FilterMethod,
        options: &FilterOptions,
    ) -> MethodNodes {
        let mut g = mg.clone();
        let (n, m) = (model.state_len(), model.outputs.len());
        let mut avoid = model_names(model);
        avoid.extend([X_SUB, P_SUB, T_SUB, "t_prev"].map(String::from));
        let all: Vec<usize> = (0..m).collect();
        let vars = FilterVars::declare(&mut g.graph, model, &all, &options.noise, &avoid);
        let (rule, h, substeps) = g
            .substep(model)
            .expect("the checker admits the hybrid EKF on continuous dynamics only");
        let dt = g
            .sample_time(model)
            .expect("continuous dynamics state their sample time");
        let t_start = start_time(&mut g, model, kind);
        let t_measured = (kind.predicts() && kind.updates() && model.uses_time())
            .then(|| g.graph.add(t_start, dt));
        let t_sub = g.graph.var(T_SUB);
        let dynamics = Dynamics::new(&mut g, model, kind, &vars, t_sub, &avoid);
        let coefficients = Coefficients::new(&avoid);
        let looped = kind.predicts() && substeps > 1;
        let scaled = looped && rule == Method::Euler;
        let (scaling, mut p_loop, p_initial) =
            loop_covariance(&mut g, (scaled, h), &dynamics.jacobian, &vars.p, &avoid);
        let mut x_loop = g.x.clone();
        if looped && matches!(kind, FilterMethod::ContinuousSplit { .. }) {
            (x_loop, p_loop) = split_loop_vars(&mut g, model, &avoid, (&scaling, p_loop));
        }
        let mut nodes = MethodNodes {
            prediction_test: None,
            x: g.x.clone(),
            p: symmetric_from_packed(&vars.p, n),
            g,
            avoid,
            vars,
            dynamics,
            substeps,
            looped,
            scaling,
            p_loop,
            p_initial,
            x_loop,
            x_initial: Vec::new(),
            t_start,
            t_measured,
            t_sub,
            loop_next: Vec::new(),
            pivots: Vec::new(),
            reciprocals: Vec::new(),
            innovation: Vec::new(),
            innovation_covariance: Vec::new(),
            nis: None,
            gated: options.gated,
            recovers: options.recovers,
            coefficients,
            stiffness: None,
            flows: Vec::new(),
        };
        nodes.integrate(model, kind, (rule, h, dt));
        nodes
    }

    /// What the method computes after its variables: a continuous-time EKF's innovation
    /// at the start of the sample `dt`, then the propagation (sub-step rule `rule`, step
    /// `h`) with the measurement terms as `kind` integrates them, or the hybrid EKF's
    /// propagation and/or update.
    fn integrate(&mut self, model: &Model, kind: FilterMethod, (rule, h, dt): Rule) {
        let nodes = self;
        let m = model.outputs.len();
        let start = model.uses_time().then_some(nodes.t_start);
        if kind.is_continuous() {
            // The sample's innovation, at its start, against `H P H' + R / T`.
            nodes.sample_innovation(m, (start, dt));
        }
        match kind {
            FilterMethod::Continuous { .. } => {
                nodes.stiffness = Some(nodes.stiffness_at_start(dt));
                nodes.propagate((rule, h), nodes.t_start, model.uses_time());
            }
            FilterMethod::ContinuousSplit { fallback, .. } => {
                // The fallback of the whole equations' step takes two sub-steps (see
                // `FilterMethod::ContinuousSplit`).
                let parts = if fallback { 2 } else { 1 };
                nodes.strang(m, (rule, h, parts), (start, dt), model.uses_time());
            }
            _ => {
                if kind.predicts() {
                    nodes.propagate((rule, h), nodes.t_start, model.uses_time());
                }
                if kind == FilterMethod::Step {
                    // The step tests its prediction as `predict` does, before correcting.
                    let n = nodes.x.len();
                    let probe = finiteness_probe(&mut nodes.g.graph, &nodes.x, &nodes.p);
                    let variances = (0..n).map(|i| nodes.p[i][i]).collect();
                    nodes.prediction_test = Some((probe, variances));
                }
                if kind.updates() {
                    nodes.correct(m);
                }
            }
        }
    }

    /// The split step over the sample `dt` from the time `start` (where the model reads
    /// it) in `parts` sub-steps of Strang's splitting, each the measurement terms' flow
    /// over half of it, the propagation (the model's rule and step `h / parts`), their
    /// flow over the other half; the halves of neighbouring sub-steps are one flow.
    fn strang(
        &mut self,
        m: usize,
        (rule, h, parts): (Method, NodeId, u32),
        (start, dt): (Option<NodeId>, NodeId),
        uses_time: bool,
    ) {
        let graph = &mut self.g.graph;
        let share = graph.num(1.0 / f64::from(parts));
        let (sub, h) = (graph.mul(share, dt), graph.mul(share, h));
        let one_half = graph.num(0.5);
        let half = graph.mul(one_half, sub);
        self.measurement_flow(m, (start, half), "_start");
        let mut t0 = self.t_start;
        for part in 1..=parts {
            self.propagate((rule, h), t0, uses_time);
            t0 = self.g.graph.add(t0, sub);
            if part < parts {
                let t = uses_time.then_some(t0);
                self.measurement_flow(m, (t, sub), "_mid");
            }
        }
        self.measurement_flow(m, (self.t_measured, half), "_end");
    }

    /// The whole equations' stiffness at the start of the sample `dt`,
    /// `T tr(R^-1 H P H')` (see [`MeasurementTerms::stiffness`]).
    fn stiffness_at_start(&mut self, dt: NodeId) -> NodeId {
        let terms = self
            .dynamics
            .measurement
            .as_ref()
            .expect("the whole equations have measurement terms");
        let point: Vec<NodeId> = std::iter::once(self.t_start)
            .chain(self.x.iter().copied())
            .collect();
        terms.stiffness(&mut self.g.graph, dt, &point, &self.p)
    }

    /// The propagation over the sample: one sub-step from the loop's variables, which the
    /// loop carries (with the running time when the model reads it), or the only one, of
    /// the step `h` from the time `start`.
    fn propagate(&mut self, (rule, h): (Method, NodeId), start: NodeId, uses_time: bool) {
        let t0 = if self.looped { self.t_sub } else { start };
        let graph = &mut self.g.graph;
        let scaling = self.scaling.as_ref();
        let (x, p) = if self.looped {
            // The loop starts from the estimate so far (a split step's, after the first
            // half of its measurement terms), its sub-steps run over the loop's variables.
            self.x_initial.clone_from(&self.x);
            self.p_initial = match scaling {
                Some(scaling) => packed_upper(&scaling.apply(graph, &self.p, 1)),
                None => packed_upper(&self.p),
            };
            let p = symmetric_from_packed(&self.p_loop, self.dynamics.n);
            (self.x_loop.clone(), p)
        } else {
            (self.x.clone(), self.p.clone())
        };
        let z = self
            .dynamics
            .substep(graph, (rule, h), t0, (&x, &p), scaling);
        if self.looped {
            self.loop_next = z;
            if uses_time {
                self.loop_next.push(graph.add(self.t_sub, h));
            }
            // After the loop, the carried values; with a scaling, `P = D^-1 P~ D^-1`.
            self.x = x;
            self.p = match scaling {
                Some(scaling) => scaling.apply(graph, &p, -1),
                None => p,
            };
        } else {
            (self.x, self.p) = split(&z, self.dynamics.n);
        }
    }

    /// The Joseph-form update at the sample (Takacs et al., eqs. 24-26) with every one of the
    /// `m` outputs: the shared Kalman stage, with `h` and its Jacobian at the estimate (and
    /// at a step's measurement time). With the gate (`gated`), the normalised innovation
    /// squared, tested against the gate or the divergence bound.
    fn correct(&mut self, m: usize) {
        let correction = self.correction(m, (self.t_measured, None), "");
        self.keep_innovation(&correction);
        let update = correction.update;
        (self.x, self.p) = (update.x, update.p);
    }

    /// The continuous-time EKF's innovation over the sample `dt`, kept and tested but not
    /// applied: `y - h(x)` at the start of the sample (at the time `start` where the model
    /// reads it) against `H P H' + R / T`, the covariance of the sample's measurement.
    fn sample_innovation(&mut self, m: usize, (start, dt): (Option<NodeId>, NodeId)) {
        let correction = self.correction(m, (start, Some(dt)), "");
        self.keep_innovation(&correction);
    }

    /// The exact flow of the measurement terms over `duration` from the estimate (at the
    /// time `t` where the model reads it): the update with `R / duration`, its pivots named
    /// with `suffix`.
    fn measurement_flow(
        &mut self,
        m: usize,
        (t, duration): (Option<NodeId>, NodeId),
        suffix: &'static str,
    ) {
        let update = self.correction(m, (t, Some(duration)), suffix).update;
        (self.x, self.p) = (update.x, update.p);
        self.flows.push((update.pivots, update.reciprocals, suffix));
    }

    /// The shared Kalman stage at the estimate with every one of the `m` outputs, `h` and
    /// its Jacobian at time `t` where given. With `noise_duration` `T`, the measurement
    /// noise is the density `R` over it, `R / T`. Its pivots' reciprocals are named with
    /// `suffix`.
    fn correction(
        &mut self,
        m: usize,
        (t, noise_duration): (Option<NodeId>, Option<NodeId>),
        suffix: &'static str,
    ) -> kalman::Correction {
        let mut r = self.vars.r_matrix.clone();
        if let Some(duration) = noise_duration {
            let graph = &mut self.g.graph;
            r = r
                .iter()
                .map(|row| row.iter().map(|&v| graph.div(v, duration)).collect())
                .collect();
        }
        let all: Vec<usize> = (0..m).collect();
        kalman::ekf_correct(
            &mut self.g,
            (t, &self.x),
            &self.p,
            (&self.vars.y, &all),
            &r,
            (&mut self.coefficients, |g: &mut Graph, j| {
                g.var(&pivot_names(m, j, INNOVATION, suffix).1)
            }),
        )
    }

    /// Keeps a correction's innovation, its covariance (packed), normalised square and
    /// pivots, to store, test and guard.
    fn keep_innovation(&mut self, correction: &kalman::Correction) {
        let update = &correction.update;
        self.innovation = correction.residual.clone();
        self.innovation_covariance = packed_upper(&update.s);
        self.nis = Some(update.nis);
        (self.pivots, self.reciprocals) = (update.pivots.clone(), update.reciprocals.clone());
    }
}

impl MethodNodes {
    /// In the hybrid EKF's step, the tests `predict` makes, of the prediction, before the
    /// update (see `in_place::test_prediction`); nothing in another method.
    fn test_prediction(&self, lowerer: &mut Lowerer, scalar: Scalar) {
        if let Some((probe, variances)) = &self.prediction_test {
            crate::emit::in_place::test_prediction(lowerer, *probe, variances, &[], scalar);
        }
    }

    /// Every value the method lowers: the new estimate and covariance (`results`), the
    /// finiteness `probe`, the pivots, the loop's next values, and what the measurement
    /// stage keeps.
    fn roots(&self, results: &[NodeId], probe: NodeId) -> Vec<NodeId> {
        let mut roots = results.to_vec();
        roots.push(probe);
        if let Some((probe, variances)) = &self.prediction_test {
            roots.push(*probe);
            roots.extend(variances);
        }
        roots.extend(&self.pivots);
        roots.extend(&self.loop_next);
        if self.scaling.is_some() {
            roots.extend(&self.p_initial);
        }
        roots.extend(&self.innovation);
        roots.extend(&self.innovation_covariance);
        roots.extend(self.nis);
        roots.extend(self.stiffness);
        if self.x_loop != self.g.x {
            roots.extend(&self.x_initial);
            roots.extend(&self.p_initial);
        }
        if let Some(terms) = &self.dynamics.measurement {
            roots.extend(&terms.r_pivots);
        }
        for (pivots, ..) in &self.flows {
            roots.extend(pivots);
        }
        roots
    }
}

/// A method lowered: its body (the sub-step loop, the statements, the commit), the
/// variables it reads, and the arithmetic of all of it and of one sub-step.
struct LoweredMethod {
    body: TokenStream,
    used_vars: BTreeSet<VarId>,
    total: OpCount,
    per_substep: OpCount,
}

/// Lowers a method: the noise and `alpha` read, `R`'s pivots guarded, the sub-step loop
/// (or the sub-step, unrolled), the update's guards, and the commit.
fn lower(
    nodes: &mut MethodNodes,
    model: &Model,
    scalar: Scalar,
    kind: FilterMethod,
) -> LoweredMethod {
    let n = model.state_len();
    let probe = finiteness_probe(&mut nodes.g.graph, &nodes.x, &nodes.p);
    let p_packed = packed_upper(&nodes.p);
    let results: Vec<NodeId> = nodes.x.iter().chain(&p_packed).copied().collect();
    let all_roots = nodes.roots(&results, probe);
    let namer = TempNamer::new(nodes.avoid.iter().map(String::as_str));
    let mut lowerer = Lowerer::new(&nodes.g.graph, scalar, namer, &all_roots);
    read_noise_and_alpha(&mut lowerer, nodes);
    let substep_loop = lower_start(&mut lowerer, nodes, model, kind);
    nodes.test_prediction(&mut lowerer, scalar);
    let suffix = if kind.updates() { "new" } else { "pred" };
    name_estimate(&mut lowerer, model, &nodes.x, suffix);
    guard_after_propagation(&mut lowerer, nodes, kind);
    measurement::name_innovation(&mut lowerer, model, &nodes.innovation, "");
    let probe = lowerer.bind(probe, "divergence_probe");
    let values = lowerer.segment(&results);
    lowerer.count_extra(OpCount::stores(values.len()));
    lowerer.count_extra(crate::emit::code::divergence_test_ops(n));
    let kept = measurement::Kept {
        prefix: "",
        innovation: &nodes.innovation,
        covariance: &nodes.innovation_covariance,
        nis: nodes.nis,
        gated: nodes.gated,
        gate_prefix: "",
        keep_prediction: (kind.predicts()).then(|| measurement::keep_prediction_call(model)),
        recovers: nodes.recovers,
    };
    let store_innovation = measurement::store_and_gate(&mut lowerer, &kept);
    let Lowered {
        statements,
        mut used_vars,
        ops,
    } = lowerer.finish();
    let (x_values, p_values) = values.split_at(n);
    let commit = commit_or_non_finite_with(&probe, x_values, p_values, &store_innovation, scalar);
    let (loop_code, per_substep, total) = match substep_loop {
        Some(l) => {
            used_vars.extend(l.used_vars);
            let total = ops
                .plus(l.per_substep.times(nodes.substeps))
                .plus(OpCount::branches(nodes.substeps.div_ceil(2)));
            (l.code, l.per_substep, total)
        }
        // With one sub-step, unrolled, the step is that sub-step (and the update).
        None => (TokenStream::new(), ops, ops),
    };
    if kind.predicts() && model.uses_time() {
        // The running time starts from it.
        used_vars.insert(nodes.g.var_id(nodes.t_start));
    }
    LoweredMethod {
        body: quote! { #loop_code #(#statements)* #commit },
        used_vars,
        total,
        per_substep,
    }
}

/// Guards the pivots of what follows the propagation: the hybrid EKF's update, or the split
/// step's measurement terms after its first (the continuous-time EKF's innovation and that
/// first flow are guarded before, see [`lower_start`]).
fn guard_after_propagation(lowerer: &mut Lowerer, nodes: &MethodNodes, kind: FilterMethod) {
    let scalar = lowerer.scalar();
    let after = if kind.is_continuous() {
        nodes.flows.get(1..).unwrap_or_default()
    } else {
        guard_innovation_pivots(lowerer, (&nodes.pivots, &nodes.reciprocals), "", scalar);
        &nodes.flows[..]
    };
    for (pivots, reciprocals, suffix) in after {
        guard_innovation_pivots(lowerer, (pivots, reciprocals), suffix, scalar);
    }
}

/// Guards an update's innovation pivots, named `INNOVATION` with `suffix`: a non-positive
/// one returns `NonPositiveInnovation` before anything is divided by it.
fn guard_innovation_pivots(
    lowerer: &mut Lowerer,
    (pivots, reciprocals): (&[NodeId], &[NodeId]),
    suffix: &str,
    scalar: Scalar,
) {
    guard_pivots(
        lowerer,
        pivots,
        reciprocals,
        (INNOVATION, suffix),
        &innovation_pivot_failure,
        scalar,
    );
}

/// The code before the propagation: the estimate and covariance read from the fields, the
/// whole equations' test of their stiffness, and a continuous-time EKF's values at the start
/// of the sample (its innovation, checked, and a split step's first half of its measurement
/// terms); then the loop of sub-steps, if the propagation has one.
fn lower_start(
    lowerer: &mut Lowerer,
    nodes: &MethodNodes,
    model: &Model,
    kind: FilterMethod,
) -> Option<SubstepLoop> {
    let scalar = lowerer.scalar();
    if !nodes.looped || kind.is_continuous() {
        lowerer.read_lazily(&quote! { self.x }, &nodes.g.x);
        lowerer.read_lazily(&quote! { self.p }, &nodes.vars.p);
    }
    // The whole equations' step (never looped) tests them first.
    fall_back_when_stiff(lowerer, nodes, model);
    if kind.is_continuous() {
        guard_innovation_pivots(lowerer, (&nodes.pivots, &nodes.reciprocals), "", scalar);
        for &value in nodes.innovation.iter().chain(&nodes.innovation_covariance) {
            lowerer.force_let(value);
        }
        if let Some(nis) = nodes.nis {
            lowerer.bind(nis, "nis");
        }
        if let Some((pivots, reciprocals, suffix)) = nodes.flows.first() {
            guard_innovation_pivots(lowerer, (pivots, reciprocals), suffix, scalar);
        }
    }
    nodes
        .looped
        .then(|| substep_loop(lowerer, nodes, model.uses_time()))
}

/// The whole equations' step falls back on `step_split` (see [`FilterMethod::Continuous`])
/// where `R` is not positive definite (a pivot of its inverse is not positive) or the
/// measurement terms are stiff, `T tr(R^-1 H P H')` beyond [`WHOLE_STEP_STIFFNESS`] (or
/// not a number): checked before anything else is computed.
fn fall_back_when_stiff(lowerer: &mut Lowerer, nodes: &MethodNodes, model: &Model) {
    let (Some(terms), Some(stiffness)) = (&nodes.dynamics.measurement, nodes.stiffness) else {
        return;
    };
    let mut arguments = measurement::keep_prediction_call(model).1;
    arguments.push(quote! { y });
    let fall_back = quote! { return self.step_split(#(#arguments),*); };
    let scalar = lowerer.scalar();
    let (prefixes, suffix) = NOISE_PIVOTS;
    guard_pivots(
        lowerer,
        &terms.r_pivots,
        &terms.r_reciprocals,
        (prefixes, suffix),
        &|_| fall_back.clone(),
        scalar,
    );
    let stiffness = lowerer.bind(stiffness, "measurement_stiffness");
    let limit = crate::emit::lower::literal(WHOLE_STEP_STIFFNESS, scalar);
    let ty = ident(scalar.type_name());
    lowerer.statement(quote! {
        if !stateforge_math::#ty::at_most(#stiffness, #limit) {
            #fall_back
        }
    });
    lowerer.count_extra(OpCount {
        compare: 1,
        ..OpCount::default()
    });
}

/// Reads the noise from the fields and `alpha` from its field, before the sub-steps; the
/// variables that stand for a value computed once (the measurement Jacobian's entries,
/// `2 alpha`) compute it where first used.
fn read_noise_and_alpha(lowerer: &mut Lowerer, nodes: &MethodNodes) {
    for &(var, value) in &nodes.coefficients.definitions {
        lowerer.define(var, value);
    }
    if let Some((var, value)) = nodes.dynamics.two_alpha {
        lowerer.define(var, value);
    }
    lowerer.read_lazily(&quote! { self.q }, &nodes.vars.q);
    nodes.vars.read_measurement_noise(lowerer);
    if let Some(alpha) = nodes.dynamics.alpha {
        let name = var_idents(&nodes.g.graph, &[alpha]).remove(0);
        lowerer.statement(quote! { let #name = self.alpha; });
    }
}

/// The loop of sub-steps, carrying the estimate from `self.x`, the covariance from
/// `self.p` and (when the model reads it) the time from the start; after it, the code
/// reads the carried arrays.
fn substep_loop(lowerer: &mut Lowerer, nodes: &MethodNodes, uses_time: bool) -> SubstepLoop {
    let n = nodes.dynamics.n;
    let (x_vars, p_vars) = (&nodes.x_loop, &nodes.p_loop);
    // The fields themselves, unless the loop starts from values computed before it (a
    // scaled covariance, a split step's first half of its measurement terms).
    let x_initial = if nodes.x_initial == nodes.g.x {
        quote! { self.x }
    } else {
        lowerer.read_lazily(&quote! { self.x }, &nodes.g.x);
        let values = lowerer.segment(&nodes.x_initial);
        quote! { [#(#values),*] }
    };
    let p_initial = if nodes.p_initial == nodes.vars.p {
        quote! { self.p }
    } else {
        lowerer.read_lazily(&quote! { self.p }, &nodes.vars.p);
        let values = lowerer.segment(&nodes.p_initial);
        quote! { [#(#values),*] }
    };
    let (x_next, rest) = nodes.loop_next.split_at(n);
    let (p_next, t_next) = rest.split_at(packed_len(n));
    let mut carried = vec![
        Carried {
            name: X_SUB,
            initial: x_initial,
            vars: x_vars,
            next: x_next,
            scalar: false,
        },
        Carried {
            name: P_SUB,
            initial: p_initial,
            vars: p_vars,
            next: p_next,
            scalar: false,
        },
    ];
    let t_sub_vars = [nodes.t_sub];
    if uses_time {
        let t_start = var_idents(&nodes.g.graph, &[nodes.t_start]).remove(0);
        carried.push(Carried {
            name: T_SUB,
            initial: quote! { #t_start },
            vars: &t_sub_vars,
            next: t_next,
            scalar: true,
        });
    }
    let odd = nodes.substeps % 2 == 1;
    let lowered = lower_loop(lowerer, &carried, (&quote! { Self::SUBSTEP_PAIRS }, odd));
    let (x_sub, p_sub) = (ident(X_SUB), ident(P_SUB));
    lowerer.read_lazily(&quote! { #x_sub }, x_vars);
    lowerer.read_lazily(&quote! { #p_sub }, p_vars);
    lowered
}

/// The method's arguments: the times where the model reads `t` (the start `t_prev` of a
/// propagation, the measurement's time `t` of the hybrid EKF's update), the input
/// `u_prev` of a propagation, the input `u` of an update whose outputs read it
/// (`reads_input`), the measurement of an update or of the continuous-time EKF.
fn arguments(
    nodes: &MethodNodes,
    model: &Model,
    kind: FilterMethod,
    (used_vars, reads_input): (&BTreeSet<VarId>, bool),
    ty: &proc_macro2::Ident,
) -> Arguments {
    let g = &nodes.g;
    let graph = &g.graph;
    let mut arguments = Arguments::default();
    if model.uses_time() {
        if kind.predicts() {
            // A gated step passes it on to `predict` when it rejects an outlier.
            let passed_on = nodes.nis.is_some() && nodes.gated;
            let read = passed_on || reads_variable(graph, nodes.t_start, used_vars);
            arguments.time("t_prev", read, ty);
        } else {
            arguments.time("t", reads_variable(graph, g.t, used_vars), ty);
        }
    }
    if let (true, Some(dt), Some(name)) = (kind.predicts(), g.interval, model.interval_parameter())
    {
        // A gated step passes it on to `predict` when it rejects an outlier.
        let passed_on = nodes.nis.is_some() && nodes.gated;
        arguments.time(&name, passed_on || reads_variable(graph, dt, used_vars), ty);
    }
    if kind.predicts() && !g.u.is_empty() {
        arguments.array("u_prev", var_idents(graph, &g.u), ty);
    }
    if reads_input {
        arguments.array("u", var_idents(graph, &g.u), ty);
    }
    if kind.updates() {
        arguments.array("y", var_idents(graph, &nodes.vars.y), ty);
    }
    arguments
}
