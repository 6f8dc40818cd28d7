//! The hybrid (continuous-discrete) EKF of "Adaptive predictive control of transient
//! vibrations of cantilevers with changing weight" (Takacs, Poloni and Rohal-Ilkiv):
//! `hybrid_ekf(gate = 10.83, process_noise = diagonal)`.

pub mod lower;
pub mod spec;

use super::options::{Args, Context};
use super::unit::{Code, Cost, Description, Generator, Kind, Lowering, Requirement};
use crate::ast::GenerateDecl;
use crate::diagnostics::Diagnostics;
use crate::model::{Model, Scalar};
use crate::symbolic::ModelGraph;
pub use spec::HybridEkfSpec;
use std::any::Any;

/// The `hybrid_ekf` generator.
pub struct HybridEkf;

/// What `hybrid_ekf` is and what it requires of the model.
const DESCRIPTION: Description = Description {
    name: "hybrid_ekf",
    usage: "`hybrid_ekf(gate = ..)`",
    requirements: &[
        Requirement::Outputs,
        Requirement::ContinuousDynamics,
        Requirement::CoefficientsAtGeneration,
        Requirement::EuclideanStates,
    ],
    items: &["HybridEkf"],
    type_name_option: None,
};

impl Kind for HybridEkf {
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
        Some(Box::new(HybridEkfSpec {
            process_noise: args.process_noise_shape(cx, diag),
            gate: args.gate(diag),
            recover_after: args.recover_after(diag),
        }))
    }
}

impl Generator for HybridEkfSpec {
    fn design(&self, _model: &Model, _mg: &ModelGraph) -> syn::Result<Box<dyn Lowering>> {
        Ok(Box::new(self.clone()))
    }

    fn as_any(&self) -> &dyn Any {
        self
    }
}

impl Lowering for HybridEkfSpec {
    fn lower(&self, model: &Model, mg: &ModelGraph, scalar: Scalar) -> Code {
        let hybrid = lower::emit_hybrid_ekf(model, self, mg, scalar);
        Code {
            tokens: hybrid.tokens,
            costs: vec![
                Cost::new(
                    "HYBRID_EKF_SUBSTEP_OPS",
                    "one sub-step of HybridEkf::step",
                    hybrid.substep_ops,
                )
                .part(),
                Cost::new("HYBRID_EKF_STEP_OPS", "HybridEkf::step", hybrid.step_ops).budgeted(),
            ],
        }
    }
}
