//! The hybrid (continuous-discrete) EKF of "Adaptive predictive control of transient
//! vibrations of cantilevers with changing weight" (Takacs, Poloni and Rohal-Ilkiv):
//! `hybrid_ekf(process_noise = diagonal)`.

pub mod lower;
pub mod spec;

pub use spec::HybridEkfSpec;
use super::options::{Args, Context};
use super::unit::{Cost, Generator, Kind, Code, Lowering, Requirement};
use crate::ast::GenerateDecl;
use crate::diagnostics::Diagnostics;
use crate::model::{Model, Scalar};
use crate::symbolic::ModelGraph;
use std::any::Any;

/// The `hybrid_ekf` generator.
pub struct HybridEkf;

impl Kind for HybridEkf {
    fn name(&self) -> &'static str {
        "hybrid_ekf"
    }

    fn usage(&self) -> &'static str {
        "`hybrid_ekf`"
    }

    fn requirements(&self) -> &'static [Requirement] {
        &[
            Requirement::Outputs,
            Requirement::ContinuousDynamics,
            Requirement::CoefficientsAtGeneration,
        ]
    }

    fn items(&self) -> &'static [&'static str] {
        &["HybridEkf"]
    }

    fn options(
        &self,
        _item: &GenerateDecl,
        args: &mut Args,
        _cx: &Context,
        diag: &mut Diagnostics,
    ) -> Option<Box<dyn Generator>> {
        Some(Box::new(HybridEkfSpec {
            diagonal_noise: args.process_noise(diag),
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
                ),
                Cost::new("HYBRID_EKF_STEP_OPS", "HybridEkf::step", hybrid.step_ops),
            ],
        }
    }
}
