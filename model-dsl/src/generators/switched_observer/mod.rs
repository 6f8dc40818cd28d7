//! The switched observers of a piecewise-linear model (a report on observers for a
//! piecewise-linear beam): per-regime gains designed at generation time, in three
//! designs (linear error dynamics, switched Kalman gains, one common gain):
//! `switched_observer(process_noise = [Q1, Q2], measurement_noise = [R1], k1 = [..])`.

pub mod design;
pub mod lower;
pub mod spec;

use super::options::{Args, Context};
use super::unit::{Code, Cost, Description, Generator, Kind, Lowering, Requirement};
use crate::ast::GenerateDecl;
use crate::diagnostics::Diagnostics;
use crate::model::{Model, Scalar};
use crate::symbolic::ModelGraph;
use design::{Culprit, Designs, Regimes};
pub use spec::SwitchedObserverSpec;
use std::any::Any;

/// The `switched_observer` generator.
pub struct SwitchedObserver;

/// What `switched_observer` is and what it requires of the model.
const DESCRIPTION: Description = Description {
    name: "switched_observer",
    usage: "`switched_observer(..)`",
    requirements: &[
        Requirement::Outputs,
        Requirement::UnrolledStep,
        Requirement::CoefficientsAtGeneration,
        Requirement::NoParameters,
        Requirement::EuclideanStates,
    ],
    items: &[
        "LinearErrorObserver",
        "SwitchedKalmanObserver",
        "CommonGainObserver",
        "REGIME_A",
        "REGIME_B",
        "REGIME_OFFSET",
        "OUTPUT_C",
        "in_regime_2",
    ],
    type_name_option: None,
};

impl Kind for SwitchedObserver {
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
        let span = item.name.span;
        let q = args.constants("process_noise", cx, diag);
        let r = args.constants("measurement_noise", cx, diag);
        let k1 = args.constants("k1", cx, diag);
        let given = |name: &str| item.args.iter().any(|a| a.name.text == name);
        // A value given but wrong has its own error already.
        if !given("process_noise") || !given("measurement_noise") {
            diag.error(
                span,
                "`switched_observer` needs the diagonals of the noise covariances: \
                 `switched_observer(process_noise = [Q1, Q2, ..], measurement_noise = [R1, ..])`",
            );
        }
        let ((q, q_span), (r, r_span)) = (q?, r?);
        let lists = [
            ("process_noise", &q, q_span),
            ("measurement_noise", &r, r_span),
        ];
        for (what, values, at) in lists {
            if let Some(bad) = values.iter().find(|v| !(v.is_finite() && **v >= 0.0)) {
                diag.error(
                    at,
                    format!("`{what}` holds {bad}: variances are finite and >= 0"),
                );
                return None;
            }
        }
        Some(Box::new(SwitchedObserverSpec {
            process_noise: q,
            measurement_noise: r,
            k1_span: k1.as_ref().map(|(_, s)| *s),
            k1: k1.map(|(v, _)| v),
            span,
            noise_span: q_span,
        }))
    }
}

/// The regimes read from the model and the gains designed for them.
struct Designed {
    regimes: Regimes,
    designs: Designs,
}

impl Generator for SwitchedObserverSpec {
    /// The regimes and observer designs, or a compile error at the option that failed: the
    /// noise covariances, `k1`, or the generator (the model's form).
    fn design(&self, model: &Model, mg: &ModelGraph) -> syn::Result<Box<dyn Lowering>> {
        let at =
            |span, reason: String| syn::Error::new(span, format!("`switched_observer`: {reason}"));
        let regimes = design::regimes(model, mg).map_err(|reason| at(self.span, reason))?;
        let designs = design::design(&regimes, self).map_err(|(culprit, reason)| {
            let span = match culprit {
                Culprit::Noise => self.noise_span,
                Culprit::K1 => self.k1_span.unwrap_or(self.span),
                Culprit::Generator => self.span,
            };
            at(span, reason)
        })?;
        Ok(Box::new(Designed { regimes, designs }))
    }

    fn as_any(&self) -> &dyn Any {
        self
    }
}

impl Lowering for Designed {
    fn lower(&self, model: &Model, _mg: &ModelGraph, scalar: Scalar) -> Code {
        let code = lower::emit_switched_observers(model, &self.regimes, &self.designs, scalar);
        Code {
            tokens: code.tokens,
            costs: vec![Cost::new(
                "SWITCHED_OBSERVER_STEP_OPS",
                "the switched observers' step",
                code.step_ops,
            )
            .of_call("step")
            .budgeted()],
        }
    }
}
