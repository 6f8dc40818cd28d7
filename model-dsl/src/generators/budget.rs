//! The cycle budget every generator takes: `max_cycles = N`, or `max_us = T, mhz = F`
//! (a time at a clock). When the static estimate of the generator's call ([`super::Cost::budgeted`],
//! for the MPC its worst case) exceeds it, the model does not compile: the error, under
//! the option, gives the estimate and what costs most, so the user knows what to change.

use super::options::Args;
use crate::ast::ArgValue;
use crate::diagnostics::Diagnostics;
use crate::emit::model_fns::code_spans;
use crate::timing::{Estimate, Target};
use proc_macro2::Span;

/// The largest budget a model may give: a billion cycles (6 s at 168 MHz).
const MAX_CYCLES: f64 = 1e9;

/// A generator's budget, in cycles per call, and where it was given.
#[derive(Clone, Debug)]
pub struct Budget {
    /// Cycles per call.
    pub cycles: u64,
    /// How it was written (`max_cycles = 100`), for the error.
    pub written: String,
    /// Where to report a call over it.
    pub span: Span,
}

impl Budget {
    /// The budget of a `generate` item, if it gives one; every wrong value is reported
    /// under itself.
    pub fn read(args: &mut Args, diag: &mut Diagnostics) -> Option<Budget> {
        let cycles = positive(args, "max_cycles", diag);
        let micros = positive(args, "max_us", diag);
        let mhz = positive(args, "mhz", diag);
        match (cycles, micros, mhz) {
            (Some(Ok((n, span))), None, None) => {
                whole_cycles(n, format!("max_cycles = {n}"), span, diag)
            }
            (Some(Ok((_, span))), Some(_), _) => {
                diag.error(
                    span,
                    "give the budget once: `max_cycles = ..` or `max_us = .., mhz = ..`",
                );
                None
            }
            (_, None, Some(Ok((_, span)))) => {
                diag.error(
                    span,
                    "`mhz` converts `max_us` to cycles: give `max_us` with it, or drop it",
                );
                None
            }
            (None, Some(Ok((us, span))), Some(Ok((f, _)))) => whole_cycles(
                (us * f).floor(),
                format!("max_us = {us}, mhz = {f}"),
                span,
                diag,
            ),
            (None, Some(Ok((_, span))), None) => {
                diag.error(
                    span,
                    "`max_us` needs the core's clock to be a number of cycles: add `mhz = 168` \
                     (say), or give `max_cycles = ..`",
                );
                None
            }
            _ => None,
        }
    }

    /// The error of a budget on a model whose code for the microcontroller is not `f32`.
    pub fn needs_f32(&self) -> syn::Error {
        syn::Error::new(
            self.span,
            "the cycle estimate is of `f32` code on a Cortex-M4F, whose FPU is \
             single-precision: declare `scalar f32;` (first) to give a budget",
        )
    }

    /// An error under the option if `estimate`, of a call of `what` on `target`, exceeds
    /// the budget; it names the largest kinds of work and the call's `parts` (each with
    /// its estimated cycles), the stages the user can change.
    pub fn check(
        &self,
        what: &str,
        estimate: &Estimate,
        parts: &[(&str, u64)],
        target: &Target,
    ) -> Option<syn::Error> {
        let parts: Vec<String> = parts
            .iter()
            .map(|&(part, cycles)| format!("{} {cycles} cycles", code_spans(part)))
            .collect();
        let parts = match parts.is_empty() {
            true => String::new(),
            false => format!("; its parts: {}", parts.join(", ")),
        };
        (estimate.cycles > self.cycles).then(|| {
            syn::Error::new(
                self.span,
                format!(
                    "{} is estimated at {} cycles per call on a {}, over the budget `{}` \
                     ({} cycles); what costs most: {}{parts}. Make the model cheaper there \
                     (fewer states or outputs, fewer library calls, a lighter option), or \
                     raise the budget",
                    code_spans(what),
                    estimate.cycles,
                    target.description,
                    self.written,
                    self.cycles,
                    estimate.largest(3)
                ),
            )
        })
    }
}

/// The positive number given as `name`: `Err` (reported) if it is not one.
fn positive(
    args: &mut Args,
    name: &str,
    diag: &mut Diagnostics,
) -> Option<Result<(f64, Span), ()>> {
    let arg = args.take(&[name])?;
    match &arg.value {
        ArgValue::Number(v, span) if v.is_finite() && *v > 0.0 => Some(Ok((*v, *span))),
        ArgValue::Number(_, span) => {
            diag.error(*span, format!("`{name}` takes a positive number"));
            Some(Err(()))
        }
        other => {
            diag.error(other.span(), format!("`{name}` takes a positive number"));
            Some(Err(()))
        }
    }
}

/// A budget of `n` cycles, if it is a whole number in range.
fn whole_cycles(n: f64, written: String, span: Span, diag: &mut Diagnostics) -> Option<Budget> {
    if n.fract() != 0.0 || !(1.0..=MAX_CYCLES).contains(&n) {
        diag.error(
            span,
            format!(
                "the budget is a whole number of cycles, 1 to {MAX_CYCLES:e}: {written} is not"
            ),
        );
        return None;
    }
    Some(Budget {
        cycles: n as u64,
        written,
        span,
    })
}
