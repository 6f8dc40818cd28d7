//! The polynomial Kalman filter with a fading factor and periodic re-initialisation from
//! a least-squares window fit (Shults, Brubaker and Lee, "A fast algorithm for control and
//! estimation using a polynomial state-space structure"): `polynomial_kf(order = 3,
//! dt = TS, fading = 1e-9, noise_variance = 1e-4, reinit_every = 100, window = 20)`.

pub mod design;
pub mod lower;
pub mod spec;

use super::options::{Args, Context};
use super::unit::{Code, Cost, Description, Generator, Kind, Lowering, Requirement};
use crate::ast::GenerateDecl;
use crate::diagnostics::Diagnostics;
use crate::model::{Model, Scalar};
use crate::symbolic::ModelGraph;
use proc_macro2::Span;
pub use spec::PolynomialKfSpec;
use std::any::Any;

/// The `polynomial_kf` generator.
pub struct PolynomialKf;

/// The usage shown when an option is missing: every option is required (they are the
/// design).
const USAGE: &str = "polynomial_kf(order = 3, dt = TS, fading = 1e-9, noise_variance = 1e-4, \
                     reinit_every = 100, window = 20)";

/// What `polynomial_kf` is and what it requires of the model.
const DESCRIPTION: Description = Description {
    name: "polynomial_kf",
    usage: "`polynomial_kf(..)`",
    requirements: &[
        Requirement::Outputs,
        Requirement::CoefficientsAtGeneration,
        Requirement::EuclideanStates,
    ],
    items: &["PolynomialKf"],
    type_name_option: None,
};

impl Kind for PolynomialKf {
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
        let mut get = |name: &str, diag: &mut Diagnostics| {
            let given = item.args.iter().any(|a| a.name.text == name);
            let value = args.scalar(name, cx, diag);
            // A value given but wrong has its own error already.
            if !given {
                diag.error(
                    span,
                    format!("`polynomial_kf` needs `{name}`: write `{USAGE}`"),
                );
            }
            value
        };
        let [order, dt, fading, noise_variance, reinit_every, window] = [
            "order",
            "dt",
            "fading",
            "noise_variance",
            "reinit_every",
            "window",
        ]
        .map(|name| get(name, diag));
        let gate = args.gate(diag);
        let mut ok = true;
        let order = whole(order, "`order`", (0.0, 8.0), &mut ok, diag);
        let reinit_every = whole(reinit_every, "`reinit_every`", (1.0, 1e6), &mut ok, diag);
        let window = whole(window, "`window`", (1.0, 1000.0), &mut ok, diag);
        let dt = positive(dt, "the sample period `dt`", false, diag);
        let fading = positive(fading, "the fading factor `fading`", true, diag);
        let noise_variance = positive(noise_variance, "`noise_variance`", false, diag);
        let (order, window) = (order?, window?);
        if window < order + 1 {
            let needed = order + 1;
            diag.error(
                span,
                format!(
                    "a fit of order {order} needs at least {needed} samples: `window = \
                     {window}` is too short"
                ),
            );
            return None;
        }
        let spec = PolynomialKfSpec {
            order,
            dt: dt?,
            fading: fading?,
            noise_variance: noise_variance?,
            reinit_every: u32::try_from(reinit_every?).ok()?,
            window,
            gate,
            span,
        };
        ok.then(|| Box::new(spec) as Box<dyn Generator>)
    }
}

/// A whole number in `low..=high`; `ok` turns false after reporting one that is not.
fn whole(
    value: Option<(f64, Span)>,
    what: &str,
    (low, high): (f64, f64),
    ok: &mut bool,
    diag: &mut Diagnostics,
) -> Option<usize> {
    let (v, at) = value?;
    if v.fract() != 0.0 || !(low..=high).contains(&v) {
        diag.error(at, format!("{what} is a whole number from {low} to {high}"));
        *ok = false;
        return None;
    }
    Some(v as usize)
}

/// A finite number above 0 (or at least 0, if `zero_ok`).
fn positive(
    value: Option<(f64, Span)>,
    what: &str,
    zero_ok: bool,
    diag: &mut Diagnostics,
) -> Option<f64> {
    let (v, at) = value?;
    let fine = v.is_finite() && (v > 0.0 || (zero_ok && v == 0.0));
    if !fine {
        let bound = if zero_ok { "at least 0" } else { "above 0" };
        diag.error(at, format!("{what} is {v}: it must be finite and {bound}"));
        return None;
    }
    Some(v)
}

impl Generator for PolynomialKfSpec {
    fn design(&self, model: &Model, mg: &ModelGraph) -> syn::Result<Box<dyn Lowering>> {
        let mut probe = mg.clone();
        if let Err(reason) = design::check_family(model, self, &mut probe) {
            let message = format!("`polynomial_kf`: {reason}");
            return Err(syn::Error::new(self.span, message));
        }
        Ok(Box::new(self.clone()))
    }

    fn as_any(&self) -> &dyn Any {
        self
    }
}

impl Lowering for PolynomialKfSpec {
    fn lower(&self, model: &Model, _mg: &ModelGraph, scalar: Scalar) -> Code {
        let kf = lower::emit_polynomial_kf(model, self, scalar);
        Code {
            tokens: kf.tokens,
            costs: vec![
                Cost::new(
                    "POLYNOMIAL_KF_STEP_OPS",
                    "PolynomialKf::step (recursive)",
                    kf.step_ops,
                )
                .of_call("step")
                .budgeted(),
                Cost::new(
                    "POLYNOMIAL_KF_FIT_OPS",
                    "PolynomialKf::step (re-initialising)",
                    kf.fit_ops,
                )
                .of_call("step")
                .budgeted(),
            ],
        }
    }
}
