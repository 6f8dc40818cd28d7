//! The double Kalman filter: the window transform derived from the model (an LTV model
//! whose coefficients a window of samples determines) and its two Kalman filters (AKF and
//! LKF): `dkf(eta = 0.5, gate = 10.83, process_noise = diagonal, window = 40)`.

pub mod filters;
pub mod lower;
pub mod ltv;
pub mod spec;
pub mod transform;
pub mod window;
pub mod window_noise;

use super::options::{Args, Context};
use super::unit::{Code, Cost, Description, Generator, Kind, Lowering, Requirement};
use crate::ast::GenerateDecl;
use crate::diagnostics::Diagnostics;
use crate::model::{Model, Scalar};
use crate::symbolic::ModelGraph;
pub use spec::DkfSpec;
use std::any::Any;

/// The `dkf` generator.
pub struct Dkf;

/// What `dkf` is and what it requires of the model.
const DESCRIPTION: Description = Description {
    name: "dkf",
    usage: "`dkf(eta = .., gate = .., window = ..)`",
    requirements: &[
        Requirement::Outputs,
        Requirement::UnrolledStep,
        Requirement::CoefficientsAtGeneration,
        Requirement::EuclideanStates,
    ],
    items: &[
        "Dkf",
        "DkfStatus",
        "WindowStatus",
        "ltv_model",
        "WINDOW_OUTPUTS",
        "WINDOW_INPUTS",
        "WINDOW_NOISE_GAIN",
    ],
    type_name_option: None,
};

impl Kind for Dkf {
    fn description(&self) -> &'static Description {
        &DESCRIPTION
    }

    fn options(
        &self,
        item: &GenerateDecl,
        args: &mut Args,
        _cx: &Context,
        diag: &mut Diagnostics,
    ) -> Option<Box<dyn Generator>> {
        let (eta, eta_span) = args.number("eta", 0.5, diag);
        let gate = args.gate(diag);
        let recover_after = args.recover_after(diag);
        let diagonal_noise = args.process_noise(diag);
        if !(0.0..=1.0).contains(&eta) {
            diag.error(eta_span, "`eta` weights a split: it lies in 0..=1");
        }
        let window = window_option(args, diag);
        Some(Box::new(DkfSpec {
            eta,
            gate,
            recover_after,
            diagonal_noise,
            window,
            span: item.name.span,
        }))
    }
}

/// `window = N`, the output samples the window holds: a whole number up to
/// [`window::MAX_WINDOW`] (the unrolled least-squares sums grow with it).
fn window_option(args: &mut Args, diag: &mut Diagnostics) -> Option<(usize, proc_macro2::Span)> {
    let (value, span) = args.optional_number("window", diag)?;
    let max = window::MAX_WINDOW;
    if value.fract() != 0.0 || !(1.0..=max as f64).contains(&value) {
        diag.error(
            span,
            format!(
                "`window` is the number of output samples the window holds, a whole number \
                 up to {max}"
            ),
        );
        return None;
    }
    Some((value as usize, span))
}

impl Generator for DkfSpec {
    /// The window transform, derived once for every scalar type; a model outside its
    /// class is one error under `dkf`, a window shorter than its minimum one under the
    /// window's length.
    fn design(&self, model: &Model, mg: &ModelGraph) -> syn::Result<Box<dyn Lowering>> {
        let mut graph = mg.clone();
        let samples = self.window.map(|(samples, _)| samples);
        let transform = window::derive(model, &mut graph, self.eta, samples)
            .map_err(|reason| syn::Error::new(self.span, format!("`dkf`: {reason}")))?;
        if let Some((samples, span)) = self.window {
            let minimum = transform.minimum_window;
            if samples < minimum {
                return Err(syn::Error::new(
                    span,
                    format!(
                        "`dkf`: the window transform of this model needs at least {minimum} \
                         output samples: write `window = {minimum}` or more, or leave \
                         `window` out for the minimum"
                    ),
                ));
            }
        }
        Ok(Box::new(Designed {
            spec: self.clone(),
            graph,
            transform,
        }))
    }

    fn as_any(&self) -> &dyn Any {
        self
    }
}

/// The DKF's options and its window transform, derived in `graph` (the model's graph with
/// the window's variables).
struct Designed {
    spec: DkfSpec,
    graph: ModelGraph,
    transform: window::WindowTransform,
}

impl Lowering for Designed {
    fn lower(&self, model: &Model, _mg: &ModelGraph, scalar: Scalar) -> Code {
        let design = (&self.graph, &self.transform);
        let dkf = lower::emit_dkf(model, &self.spec, design, scalar);
        Code {
            tokens: dkf.tokens,
            costs: vec![
                Cost::new(
                    "DKF_TRANSFORM_OPS",
                    "the window transform of Dkf::step",
                    dkf.transform_ops,
                )
                .part(),
                Cost::new(
                    "DKF_FILTERS_OPS",
                    "the two filters of Dkf::step",
                    dkf.filters_ops,
                )
                .part(),
                Cost::new(
                    "DKF_STEP_OPS",
                    "Dkf::step",
                    dkf.transform_ops.plus(dkf.filters_ops),
                )
                .budgeted(),
            ],
        }
    }
}
