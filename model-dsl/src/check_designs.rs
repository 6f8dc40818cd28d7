//! The options of the generators whose designs are computed at generation time:
//! `polynomial_kf(..)` and `switched_observer(..)`. Values are numbers or names of model
//! constants; what the model itself must satisfy is checked where the design is made.

use crate::ast::{ArgValue, GenerateDecl, Name};
use crate::check::Args;
use crate::diagnostics::Diagnostics;
use crate::model::{PolynomialKfSpec, SwitchedObserverSpec};
use proc_macro2::Span;

/// A number, or the value of a model constant, with where it was written.
fn scalar(
    args: &mut Args,
    name: &str,
    constant: &dyn Fn(&Name) -> Option<f64>,
    diag: &mut Diagnostics,
) -> Option<(f64, Span)> {
    match &args.take(&[name])?.value {
        ArgValue::Number(v, span) => Some((*v, *span)),
        ArgValue::Name(n) => match constant(n) {
            Some(v) => Some((v, n.span)),
            None => {
                diag.error(
                    n.span,
                    format!("`{}` is not a constant of the model", n.text),
                );
                None
            }
        },
        ArgValue::Names(_, span) => {
            diag.error(*span, format!("`{name}` takes a number or a constant"));
            None
        }
    }
}

/// A list of model constants, with where it was written.
fn constants(
    args: &mut Args,
    name: &str,
    constant: &dyn Fn(&Name) -> Option<f64>,
    diag: &mut Diagnostics,
) -> Option<(Vec<f64>, Span)> {
    match &args.take(&[name])?.value {
        ArgValue::Names(list, span) => {
            let values: Vec<Option<f64>> = list
                .iter()
                .map(|n| {
                    let v = constant(n);
                    if v.is_none() {
                        diag.error(
                            n.span,
                            format!("`{}` is not a constant of the model", n.text),
                        );
                    }
                    v
                })
                .collect();
            values
                .into_iter()
                .collect::<Option<Vec<f64>>>()
                .map(|v| (v, *span))
        }
        other => {
            diag.error(
                other.span(),
                format!("`{name}` takes a list of model constants: `{name} = [A, B]`"),
            );
            None
        }
    }
}

/// `polynomial_kf(order = 3, dt = TS, fading = 1e-9, noise_variance = 1e-4,
/// reinit_every = 100, window = 20)`: every option is required (they are the design).
pub fn polynomial_kf(
    item: &GenerateDecl,
    args: &mut Args,
    constant: &dyn Fn(&Name) -> Option<f64>,
    diag: &mut Diagnostics,
) -> Option<PolynomialKfSpec> {
    let span = item.name.span;
    let mut get = |name: &str, diag: &mut Diagnostics| {
        let value = scalar(args, name, constant, diag);
        if value.is_none() {
            diag.error(
                span,
                format!(
                    "`polynomial_kf` needs `{name}`: write `polynomial_kf(order = 3, dt = TS, \
                     fading = 1e-9, noise_variance = 1e-4, reinit_every = 100, window = 20)`"
                ),
            );
        }
        value
    };
    let order = get("order", diag);
    let dt = get("dt", diag);
    let fading = get("fading", diag);
    let noise_variance = get("noise_variance", diag);
    let reinit_every = get("reinit_every", diag);
    let window = get("window", diag);
    let mut ok = true;
    let mut whole = |value: Option<(f64, Span)>, what: &str, low: f64, high: f64| {
        let (v, at) = value?;
        if v.fract() != 0.0 || !(low..=high).contains(&v) {
            diag.error(at, format!("{what} is a whole number from {low} to {high}"));
            ok = false;
            return None;
        }
        Some(v as usize)
    };
    let order = whole(order, "`order`", 0.0, 8.0);
    let reinit_every = whole(reinit_every, "`reinit_every`", 1.0, 1e6);
    let window = whole(window, "`window`", 1.0, 1000.0);
    let mut positive = |value: Option<(f64, Span)>, what: &str, zero_ok: bool| {
        let (v, at) = value?;
        let fine = v.is_finite() && (v > 0.0 || (zero_ok && v == 0.0));
        if !fine {
            let bound = if zero_ok { "at least 0" } else { "above 0" };
            diag.error(at, format!("{what} is {v}: it must be finite and {bound}"));
            return None;
        }
        Some(v)
    };
    let dt = positive(dt, "the sample period `dt`", false);
    let fading = positive(fading, "the fading factor `fading`", true);
    let noise_variance = positive(noise_variance, "`noise_variance`", false);
    let (order, window) = (order?, window?);
    if window < order + 1 {
        diag.error(
            span,
            format!(
                "a fit of order {order} needs at least {} samples: `window = {window}` is too short",
                order + 1
            ),
        );
        return None;
    }
    ok.then_some(PolynomialKfSpec {
        order,
        dt: dt?,
        fading: fading?,
        noise_variance: noise_variance?,
        reinit_every: u32::try_from(reinit_every?).ok()?,
        window,
        span,
    })
}

/// `switched_observer(process_noise = [Q1, ..], measurement_noise = [R1, ..], k1 = [..])`:
/// the diagonals of `Q` and `R` (required) and optionally the gain of regime 1, row-major.
pub fn switched_observer(
    item: &GenerateDecl,
    args: &mut Args,
    constant: &dyn Fn(&Name) -> Option<f64>,
    diag: &mut Diagnostics,
) -> Option<SwitchedObserverSpec> {
    let span = item.name.span;
    let q = constants(args, "process_noise", constant, diag);
    let r = constants(args, "measurement_noise", constant, diag);
    let k1 = constants(args, "k1", constant, diag);
    if q.is_none() || r.is_none() {
        diag.error(
            span,
            "`switched_observer` needs the diagonals of the noise covariances: \
             `switched_observer(process_noise = [Q1, Q2, ..], measurement_noise = [R1, ..])`",
        );
    }
    let ((q, q_span), (r, _)) = (q?, r?);
    for (what, values) in [("process_noise", &q), ("measurement_noise", &r)] {
        if let Some(bad) = values.iter().find(|v| !(v.is_finite() && **v >= 0.0)) {
            diag.error(
                q_span,
                format!("`{what}` holds {bad}: variances are finite and >= 0"),
            );
            return None;
        }
    }
    Some(SwitchedObserverSpec {
        process_noise: q,
        measurement_noise: r,
        k1_span: k1.as_ref().map(|(_, s)| *s),
        k1: k1.map(|(v, _)| v),
        span,
        noise_span: q_span,
    })
}
