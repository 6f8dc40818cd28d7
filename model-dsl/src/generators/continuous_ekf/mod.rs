//! The continuous-time EKF of "Nonlinear experimental estimation and verification of a
//! MIMO system through EKF" (Kulkarni and Purwar), with an optional prescribed degree of
//! stability (Reif et al.) and innovation gate:
//! `continuous_ekf(alpha = 0.5, gate = 13.8, process_noise = diagonal)`.

pub mod lower;
pub mod spec;

use super::options::{Args, Context};
use super::unit::{Code, Cost, Description, Generator, Kind, Lowering, Requirement};
use crate::ast::GenerateDecl;
use crate::diagnostics::Diagnostics;
use crate::model::{Model, Scalar};
use crate::symbolic::ModelGraph;
pub use spec::ContinuousEkfSpec;
use std::any::Any;

/// The `continuous_ekf` generator.
pub struct ContinuousEkf;

/// What `continuous_ekf` is and what it requires of the model.
const DESCRIPTION: Description = Description {
    name: "continuous_ekf",
    usage: "`continuous_ekf(alpha = .., gate = ..)`",
    requirements: &[
        Requirement::Outputs,
        Requirement::ContinuousDynamics,
        Requirement::CoefficientsAtGeneration,
        Requirement::EuclideanStates,
    ],
    items: &["ContinuousEkf"],
    type_name_option: None,
};

impl Kind for ContinuousEkf {
    fn description(&self) -> &'static Description {
        &DESCRIPTION
    }

    fn takes_interval(&self) -> bool {
        true
    }

    fn options(
        &self,
        _item: &GenerateDecl,
        args: &mut Args,
        cx: &Context,
        diag: &mut Diagnostics,
    ) -> Option<Box<dyn Generator>> {
        let alpha = args.optional_number("alpha", diag);
        if let Some((a, span)) = alpha.filter(|(a, _)| !(*a >= 0.0 && a.is_finite())) {
            diag.error(
                span,
                format!(
                    "`alpha`, the prescribed degree of stability, is finite and at least 0 \
                     (per second), not {a}"
                ),
            );
        }
        Some(Box::new(ContinuousEkfSpec {
            process_noise: args.process_noise_shape(cx, diag),
            alpha: alpha.map(|(a, _)| a),
            gate: args.gate(diag),
            recover_after: args.recover_after(diag),
        }))
    }
}

impl Generator for ContinuousEkfSpec {
    fn design(&self, _model: &Model, _mg: &ModelGraph) -> syn::Result<Box<dyn Lowering>> {
        Ok(Box::new(self.clone()))
    }

    fn as_any(&self) -> &dyn Any {
        self
    }
}

impl Lowering for ContinuousEkfSpec {
    fn lower(&self, model: &Model, mg: &ModelGraph, scalar: Scalar) -> Code {
        let ct = lower::emit_continuous_ekf(model, self, mg, scalar);
        let split = ct.split_step_ops.map(|ops| {
            Cost::new(
                "CONTINUOUS_EKF_SPLIT_STEP_OPS",
                "ContinuousEkf::step on a stiff sample (its split step)",
                ops,
            )
            .part()
        });
        Code {
            tokens: ct.tokens,
            costs: [
                Cost::new(
                    "CONTINUOUS_EKF_SUBSTEP_OPS",
                    "one sub-step of ContinuousEkf::step",
                    ct.substep_ops,
                )
                .part(),
                Cost::new(
                    "CONTINUOUS_EKF_STEP_OPS",
                    "ContinuousEkf::step",
                    ct.step_ops,
                )
                .budgeted(),
            ]
            .into_iter()
            .chain(split)
            .collect(),
        }
    }
}
