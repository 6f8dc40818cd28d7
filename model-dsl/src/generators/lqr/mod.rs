//! The adaptive finite-horizon LQR (Alg. 3 of the double Kalman filter paper): a Riccati
//! recursion at the estimate each sample: `lqr(horizon = 50, states = [x1, x2], input = u)`.

pub mod lower;
pub mod spec;
pub mod steady_state;

use super::options::{regulated, Args, Context};
use super::unit::{Code, Cost, Description, Generator, Kind, Lowering, Requirement};
use crate::ast::GenerateDecl;
use crate::diagnostics::Diagnostics;
use crate::model::{Model, Scalar};
use crate::symbolic::ModelGraph;
pub use spec::LqrSpec;
use std::any::Any;

/// The `lqr` generator.
pub struct Lqr;

/// What `lqr` is and what it requires of the model.
const DESCRIPTION: Description = Description {
    name: "lqr",
    usage: "`lqr(..)`",
    requirements: &[
        Requirement::Inputs,
        Requirement::UnrolledStep,
        Requirement::EuclideanStates,
    ],
    items: &["Lqr"],
    type_name_option: None,
};

impl Kind for Lqr {
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
        let horizon = args.whole(("horizon", "steps"), 50, 10_000, diag);
        let (states, inputs) = regulated(item, args, cx, diag, "lqr(horizon = 50, ");
        Some(Box::new(LqrSpec {
            horizon,
            states,
            inputs,
        }))
    }
}

impl Generator for LqrSpec {
    fn design(&self, _model: &Model, _mg: &ModelGraph) -> syn::Result<Box<dyn Lowering>> {
        Ok(Box::new(self.clone()))
    }

    fn as_any(&self) -> &dyn Any {
        self
    }
}

impl Lowering for LqrSpec {
    fn lower(&self, model: &Model, mg: &ModelGraph, scalar: Scalar) -> Code {
        let lqr = lower::emit_lqr(model, self, mg, scalar);
        Code {
            tokens: lqr.tokens,
            costs: vec![Cost::new("LQR_SOLVE_OPS", "Lqr::solve", lqr.solve_ops).budgeted()],
        }
    }
}
