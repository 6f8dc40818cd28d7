//! The adaptive model predictive controller with input bounds ("Adaptive predictive
//! control of transient vibrations of cantilevers with changing weight", Takacs, Poloni
//! and Rohal-Ilkiv, sect. 4): the prediction model at the estimate, a terminal weight by
//! Riccati steps, the condensed QP solved by an unrolled active-set method:
//! `mpc(horizon = 10, states = [q, qd], input = u, discretisation = zoh,
//! max_iterations = 20, riccati_iterations = 20)`.

pub mod affine;
pub mod cache;
pub mod dual;
pub mod limit_api;
pub mod limit_rows;
pub mod limits;
pub mod lower;
pub mod names;
pub mod newton;
pub mod predictive;
pub mod qp;
pub mod spec;
pub mod stage;
pub mod target;
pub mod work_bound;

use super::options::{regulated, Args, Context};
use super::unit::{looped, Code, Cost, Description, Generator, Kind, Lowering, Requirement};
use crate::ast::{ArgValue, DynamicsKind, GenerateDecl, ModelDecl};
use crate::diagnostics::Diagnostics;
use crate::model::{Model, Scalar, UNROLLED_SUBSTEPS_MAX};
use crate::symbolic::ModelGraph;
use crate::timing::CORTEX_M4F;
pub use spec::{MpcDiscretisation, MpcSolver, MpcSpec, MPC_UNKNOWNS_MAX, PRIMAL_MOVES_MAX};
use std::any::Any;
use work_bound::iterations_within;

/// The `mpc` generator.
pub struct Mpc;

/// What `mpc` is and what it requires of the model.
const DESCRIPTION: Description = Description {
    name: "mpc",
    usage: "`mpc(..)`",
    requirements: &[
        Requirement::Inputs,
        Requirement::CoefficientsAtGeneration,
        Requirement::EuclideanStates,
    ],
    items: &["Mpc", "MpcStatus", "MpcRebuild", "PredictionModel"],
    type_name_option: None,
};

impl Kind for Mpc {
    fn description(&self) -> &'static Description {
        &DESCRIPTION
    }

    fn options(
        &self,
        item: &GenerateDecl,
        args: &mut Args,
        cx: &Context,
        diag: &mut Diagnostics,
    ) -> Option<Box<dyn Generator>> {
        let horizon = args.whole(("horizon", "steps"), 10, 1000, diag);
        let (states, inputs) = regulated(item, args, cx, diag, "mpc(horizon = 10, ");
        let unknowns = u64::from(horizon) * inputs.len() as u64;
        if unknowns > u64::from(MPC_UNKNOWNS_MAX) {
            diag.error(
                item.name.span,
                format!(
                    "the MPC optimises horizon x inputs = {unknowns} moves; its unrolled solve \
                     allows at most {MPC_UNKNOWNS_MAX}: shorten the horizon"
                ),
            );
        }
        let discretisation = discretisation(cx.decl, args, diag);
        let limits = limits::limits(args, cx, (&states, &inputs), diag);
        let tracked = target::tracked(args, cx, diag);
        let rows = u64::from(horizon) * limits.per_step() as u64;
        let solver = solver(args, (unknowns, rows > 0), diag);
        // Clamped so that a horizon already reported as too long adds no error of its own.
        let default_iterations =
            2 * (unknowns.clamp(1, u64::from(MPC_UNKNOWNS_MAX)) + rows.min(1000)) as u32;
        let iterations = ("max_iterations", "iterations");
        let max_iterations = args.whole(iterations, default_iterations, 1000, diag);
        let riccati_iterations = args.whole(("riccati_iterations", "steps"), 20, 10_000, diag);
        let model_tolerance = model_tolerance(args, diag);
        Some(Box::new(MpcSpec {
            horizon,
            states,
            inputs,
            discretisation,
            solver,
            limits,
            tracked,
            target: None,
            max_iterations,
            riccati_iterations,
            model_tolerance,
            // Its solve's budget bounds the iterations (the MPC's one call).
            cycle_budget: cx
                .cycle_budget
                .as_ref()
                .and_then(|budget| budget.limit_of("solve", true))
                .map(|limit| (limit.cycles, limit.span)),
            iterations_within_budget: None,
        }))
    }
}

/// `model_tolerance` (`0`: the model is kept only while the values it reads are
/// unchanged, when rebuilding it would give it bit for bit): a fraction, `0 <= .. < 1`.
fn model_tolerance(args: &mut Args, diag: &mut Diagnostics) -> f64 {
    let (value, span) = args.number("model_tolerance", 0.0, diag);
    if (0.0..1.0).contains(&value) {
        value
    } else {
        diag.error(
            span,
            "`model_tolerance` is the relative change of the values the prediction model \
             reads under which it is kept, `0 <= model_tolerance < 1`",
        );
        0.0
    }
}

/// `solver = primal_active_set` (the default up to [`PRIMAL_MOVES_MAX`] moves without
/// limits besides the inputs' bounds) or `dual_active_set` (otherwise; the only solver
/// that takes those limits).
fn solver(args: &mut Args, (unknowns, limited): (u64, bool), diag: &mut Diagnostics) -> MpcSolver {
    let default = if unknowns <= u64::from(PRIMAL_MOVES_MAX) && !limited {
        MpcSolver::PrimalActiveSet
    } else {
        MpcSolver::DualActiveSet
    };
    let Some(arg) = args.take(&["solver"]) else {
        return default;
    };
    match &arg.value {
        ArgValue::Name(n) if n.text == "primal_active_set" && limited => {
            diag.error(
                n.span,
                "the primal active set takes the inputs' bounds only: with `rate_limits`, \
                 `state_limits` or `output_limits`, use `solver = dual_active_set` (or leave \
                 `solver` out)",
            );
            default
        }
        ArgValue::Name(n) if n.text == "primal_active_set" => MpcSolver::PrimalActiveSet,
        ArgValue::Name(n) if n.text == "dual_active_set" => MpcSolver::DualActiveSet,
        other => {
            diag.error(
                other.span(),
                format!(
                    "`solver` is `primal_active_set` (Newton steps on the free moves; the \
                     default up to {PRIMAL_MOVES_MAX} moves) or `dual_active_set` (from the \
                     unconstrained plan, holding violated limits; the default beyond, and \
                     with limits besides the inputs' bounds)"
                ),
            );
            default
        }
    }
}

/// `discretisation = zoh` (exact hold of the continuous linearisation; the default for
/// continuous dynamics and the only choice when their sub-steps run as a loop) or
/// `sample_step` (the Jacobians of the model's step `f`; the only choice for discrete
/// dynamics).
fn discretisation(decl: &ModelDecl, args: &mut Args, diag: &mut Diagnostics) -> MpcDiscretisation {
    // `Some(looped)` for continuous dynamics, `None` for discrete ones.
    let continuous = decl
        .dynamics
        .iter()
        .any(|d| matches!(d.kind, DynamicsKind::Continuous { .. }))
        .then(|| looped(decl));
    let default = match continuous {
        Some(_) => MpcDiscretisation::ZeroOrderHold,
        None => MpcDiscretisation::SampleStep,
    };
    let Some(arg) = args.take(&["discretisation"]) else {
        return default;
    };
    let chosen = match &arg.value {
        ArgValue::Name(n) if n.text == "zoh" => MpcDiscretisation::ZeroOrderHold,
        ArgValue::Name(n) if n.text == "sample_step" => MpcDiscretisation::SampleStep,
        other => {
            diag.error(
                other.span(),
                "`discretisation` is `zoh` (the exact zero-order hold of the continuous \
                 dynamics linearised at the estimate) or `sample_step` (the Jacobians of the \
                 model's own sample step)",
            );
            return default;
        }
    };
    match (chosen, continuous) {
        (MpcDiscretisation::ZeroOrderHold, None) => diag.error(
            arg.value.span(),
            "`zoh` holds continuous dynamics over a sample; these are discrete: use \
             `discretisation = sample_step`, or leave it out",
        ),
        (MpcDiscretisation::SampleStep, Some(true)) => diag.error(
            arg.value.span(),
            format!(
                "the sample step runs more than {UNROLLED_SUBSTEPS_MAX} sub-steps as a loop \
                 and has no Jacobian: use `discretisation = zoh`"
            ),
        ),
        _ => {}
    }
    chosen
}

impl Generator for MpcSpec {
    fn design(&self, model: &Model, mg: &ModelGraph) -> syn::Result<Box<dyn Lowering>> {
        let mut spec = self.clone();
        if !spec.limits.outputs.is_empty() {
            let outputs = (&spec.limits.outputs[..], &spec.states[..]);
            let why = (
                "is limited over the horizon",
                "limit the states it reads with `state_limits`, or declare a linear output",
            );
            let rows = limits::output_rows(model, &mut mg.clone(), outputs, why);
            spec.limits.output_rows = rows?;
        }
        spec.target = target::design(model, mg, &spec)?;
        if let Some(budget) = self.cycle_budget {
            // The bound is of the microcontroller's `f32` code; the `f64` code takes the
            // same bounds, so a host run is limited as the target's is.
            let ops = lower::emit_mpc(model, &spec, mg, Scalar::F32).ops;
            let limits = iterations_within(&ops, self.max_iterations, budget, &CORTEX_M4F)?;
            spec.iterations_within_budget = Some(limits);
        }
        Ok(Box::new(spec))
    }

    fn as_any(&self) -> &dyn Any {
        self
    }
}

impl Lowering for MpcSpec {
    fn lower(&self, model: &Model, mg: &ModelGraph, scalar: Scalar) -> Code {
        let mpc = lower::emit_mpc(model, self, mg, scalar);
        let ops = mpc.ops;
        // Every solve runs its plan and its iterations; without a budget the worst
        // rebuilds the model and the problem and runs them all, within one the costliest
        // kind of solve at its bound.
        let limits = self
            .iterations_within_budget
            .unwrap_or([self.max_iterations; 3]);
        let worst = ops.worst(limits, &CORTEX_M4F);
        let worst_what = match self.iterations_within_budget {
            None => "Mpc::solve at its worst (the model and problem rebuilt, every iteration run)",
            Some(_) => {
                "Mpc::solve at its worst (the costliest kind of solve, with the iterations \
                 `ITERATIONS_WITHIN_BUDGET` allows it)"
            }
        };
        let costs = vec![
            Cost::new("MPC_PLAN_OPS", "the plan of every Mpc::solve", ops.plan),
            Cost::new(
                "MPC_PREDICTION_OPS",
                "the prediction model of Mpc::solve (when rebuilt)",
                ops.prediction,
            )
            .part(),
            Cost::new(
                "MPC_RICCATI_OPS",
                "the Riccati steps of Mpc::solve (when rebuilt)",
                ops.riccati,
            )
            .part(),
            Cost::new(
                "MPC_CONDENSE_OPS",
                "the condensed problem of Mpc::solve (when rebuilt: H, or G = H^-1 and the gain)",
                ops.condense,
            )
            .part(),
            Cost::new(
                "MPC_ITERATION_OPS",
                "one active-set iteration of Mpc::solve",
                ops.iteration,
            )
            .part(),
            Cost::new("MPC_SOLVE_WORST_OPS", worst_what, worst)
                .of_call("solve")
                .budgeted(),
        ];
        Code {
            tokens: mpc.tokens,
            costs,
        }
    }
}
