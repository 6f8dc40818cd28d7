//! The cycle budget every generator takes, per call: `max_cycles = N`, or `max_us = T,
//! mhz = F` (a time at a clock), bounds each call the budget applies to; `max_cycles =
//! [predict = N, update_gnss = M]` gives each named call its own. And the rate schedule
//! of a multi-rate filter: `schedule = [predict = 250, update_gnss = 5], mhz = 168` (calls
//! per second at a clock, with `max_load = P` percent, 100 unless given) bounds the share
//! of the core its calls take together. When a call's static estimate ([`super::Cost`];
//! for the MPC its worst case) exceeds its budget, or the schedule's load exceeds its
//! bound, the model does not compile: the error, under the option, names the call or the
//! load, with what costs most, so the user knows what to change.
//!
//! Which calls a single budget bounds: those the schedule names when there is one (what
//! the filter's use runs), else the generator's budgeted call (a filter's `step`, a
//! controller's `solve`).

use super::cost::Cost;
use crate::ast::{ArgValue, Name};
use crate::diagnostics::{closest, phrase, Diagnostics};
use crate::emit::model_fns::code_spans;
use crate::timing::{Estimate, Target};
use proc_macro2::Span;

/// The largest budget a model may give: a billion cycles (6 s at 168 MHz).
const MAX_CYCLES: f64 = 1e9;

/// The highest rate a schedule may give a call: a million calls per second.
const MAX_RATE_HZ: f64 = 1e6;

/// A generator's budgets and schedule, as given.
#[derive(Clone, Debug)]
pub struct Budget {
    /// The cycles per call, if a budget is given.
    pub limit: Option<Limit>,
    /// The rate schedule, if one is given.
    pub schedule: Option<Schedule>,
    /// Where the first of them was given (for an error about them all).
    pub span: Span,
}

/// The cycles each call may take.
#[derive(Clone, Debug)]
pub enum Limit {
    /// One budget for each call it applies to (the scheduled calls, else the budgeted one).
    Each(CallLimit),
    /// A budget per call, by name.
    PerCall(Vec<(Name, CallLimit)>),
}

/// One budget in cycles, how it was written and where.
#[derive(Clone, Debug)]
pub struct CallLimit {
    /// Cycles per call.
    pub cycles: u64,
    /// How it was written (`max_cycles = 100`, `update_gnss = 5000`), for the error.
    pub written: String,
    /// Where to report a call over it.
    pub span: Span,
}

/// The calls a use runs per second, at a clock: `schedule = [predict = 250, ..]`.
#[derive(Clone, Debug)]
pub struct Schedule {
    /// Each call and its rate in hertz, with where it was written.
    pub rates: Vec<(Name, f64)>,
    /// The core's clock, in MHz.
    pub mhz: f64,
    /// The largest load allowed, in percent of the core (`max_load`, 100 unless given).
    pub max_load: f64,
    /// Where the schedule was given.
    pub span: Span,
}

impl Budget {
    /// The budget of a `generate` item whose options `take` gives by name (taking each),
    /// if it gives one; every wrong value is reported under itself.
    pub fn read(
        take: &mut dyn FnMut(&str) -> Option<ArgValue>,
        diag: &mut Diagnostics,
    ) -> Option<Budget> {
        let cycles = take("max_cycles");
        let micros = take("max_us");
        let mhz = positive(take("mhz"), "mhz", diag);
        let schedule = take("schedule");
        let max_load = positive(take("max_load"), "max_load", diag);
        let clock = match (&mhz, micros.is_some() || schedule.is_some()) {
            (Some(Ok((_, span))), false) => {
                diag.error(
                    *span,
                    "`mhz` is the core's clock, for `max_us` (a time in cycles) or a \
                     `schedule` (a load): give one with it, or drop it",
                );
                None
            }
            (Some(Ok((f, _))), true) => Some(*f),
            _ => None,
        };
        let limit = limit(cycles.as_ref(), micros.as_ref(), (clock, &mhz), diag);
        let scheduled = schedule.is_some();
        let schedule = schedule
            .and_then(|written| read_schedule(&written, (clock, mhz.is_some()), max_load, diag));
        if let (Some(Ok((_, span))), false) = (&max_load, scheduled) {
            diag.error(
                *span,
                "`max_load` bounds a `schedule`'s load: give the schedule, `schedule = \
                 [predict = 250, update_gnss = 5]`, or drop it",
            );
        }
        let span = match (&limit, &schedule) {
            (Some(Limit::Each(each)), _) => each.span,
            (Some(Limit::PerCall(calls)), _) => calls.first()?.1.span,
            (None, Some(schedule)) => schedule.span,
            (None, None) => return None,
        };
        Some(Budget {
            limit,
            schedule,
            span,
        })
    }

    /// The budget of `call`, with where it was given: its own, or the one for each call
    /// when it applies to it (`default`: whether it is the generator's budgeted call,
    /// bounded when no schedule names the calls).
    pub fn limit_of(&self, call: &str, default: bool) -> Option<&CallLimit> {
        match self.limit.as_ref()? {
            Limit::PerCall(calls) => calls
                .iter()
                .find(|(name, _)| name.text == call)
                .map(|(_, limit)| limit),
            Limit::Each(each) => {
                let applies = match &self.schedule {
                    Some(schedule) => schedule.rates.iter().any(|(name, _)| name.text == call),
                    None => default,
                };
                applies.then_some(each)
            }
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

    /// The errors of a generator's `costs` (each with its estimate on `target`) against
    /// the budget: a call over its budget (naming the generator's other costs as its parts
    /// when it is the budgeted call), a schedule over its load, a call named that the
    /// generator does not have.
    pub fn check(&self, costs: &[(&Cost, &Estimate)], target: &Target) -> Vec<syn::Error> {
        let mut errors = self.unknown_calls(costs);
        let parts: Vec<(&str, u64)> = costs
            .iter()
            .filter(|(cost, estimate)| !cost.is_budgeted && estimate.cycles > 0)
            .map(|(cost, estimate)| (cost.what.as_str(), estimate.cycles))
            .collect();
        for &(cost, estimate) in costs {
            let Some(limit) = cost
                .call
                .as_deref()
                .and_then(|call| self.limit_of(call, cost.is_budgeted))
            else {
                continue;
            };
            let parts: &[(&str, u64)] = if cost.is_budgeted { &parts } else { &[] };
            errors.extend(limit.check(&cost.what, estimate, parts, target));
        }
        if let Some(schedule) = &self.schedule {
            errors.extend(schedule.check(costs, target));
        }
        errors
    }

    /// An error under each call a per-call budget or the schedule names that `costs` do
    /// not have.
    fn unknown_calls(&self, costs: &[(&Cost, &Estimate)]) -> Vec<syn::Error> {
        let calls: Vec<&str> = costs
            .iter()
            .filter_map(|(c, _)| c.call.as_deref())
            .collect();
        let mut calls_listed: Vec<&str> = Vec::new();
        for call in &calls {
            if !calls_listed.contains(call) {
                calls_listed.push(call);
            }
        }
        let named = match &self.limit {
            Some(Limit::PerCall(limits)) => limits.iter().map(|(name, _)| name).collect(),
            _ => Vec::new(),
        };
        let scheduled = self
            .schedule
            .iter()
            .flat_map(|s| s.rates.iter().map(|(n, _)| n));
        let type_name = costs
            .iter()
            .find_map(|(c, _)| c.what.split_once("::").map(|(ty, _)| ty.to_owned()))
            .unwrap_or_default();
        named
            .into_iter()
            .chain(scheduled)
            .filter(|name| !calls.contains(&name.text.as_str()))
            .map(|name| {
                let listed: Vec<String> = calls_listed.iter().map(|c| format!("`{c}`")).collect();
                let hint = match closest(&name.text, calls_listed.iter().copied()) {
                    Some(near) => format!("did you mean `{near}`? "),
                    None => String::new(),
                };
                syn::Error::new(
                    name.span,
                    format!(
                        "`{type_name}` has no call `{}`: {hint}a budget or a schedule names \
                         its calls, {}",
                        name.text,
                        phrase(&listed, "and")
                    ),
                )
            })
            .collect()
    }
}

impl CallLimit {
    /// An error under the budget if `estimate`, of a call of `what` on `target`, exceeds
    /// it; it names the largest kinds of work and the call's `parts` (each with its
    /// estimated cycles), the stages the user can change.
    fn check(
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

impl Schedule {
    /// An error under the schedule if its calls, each at its rate and its estimate on
    /// `target` (the costliest of a call's paths), load the core beyond `max_load`.
    fn check(&self, costs: &[(&Cost, &Estimate)], target: &Target) -> Option<syn::Error> {
        let cycles_per_second = self.mhz * 1e6;
        let mut load = 0.0;
        let mut terms = Vec::new();
        for (name, rate) in &self.rates {
            let (what, cycles) = costs
                .iter()
                .filter(|(cost, _)| cost.call.as_deref() == Some(name.text.as_str()))
                .map(|(cost, estimate)| (cost.what.as_str(), estimate.cycles))
                .max_by_key(|&(_, cycles)| cycles)?;
            let share = rate * cycles as f64 / cycles_per_second * 100.0;
            load += share;
            terms.push(format!(
                "{} {} Hz x {cycles} cycles ({})",
                code_spans(what.split(' ').next().unwrap_or(what)),
                number(*rate),
                percent(share)
            ));
        }
        (load > self.max_load).then(|| {
            syn::Error::new(
                self.span,
                format!(
                    "the schedule loads the CPU to {} at {} MHz, over `max_load = {}` %: {} \
                     (the static estimates on a {}). Lower a rate, make the costliest call \
                     cheaper, or give a faster clock",
                    percent(load),
                    number(self.mhz),
                    number(self.max_load),
                    terms.join(" + "),
                    target.description
                ),
            )
        })
    }
}

/// A rate or a clock as written: `250`, `0.5`.
fn number(v: f64) -> String {
    format!("{v}")
}

/// A share of the core: `131 %`, `1.8 %`, `0.02 %`.
fn percent(share: f64) -> String {
    if share >= 10.0 {
        format!("{share:.0} %")
    } else if share >= 0.1 {
        format!("{share:.1} %")
    } else {
        format!("{share:.2} %")
    }
}

/// The budget per call given by `max_cycles` (a number, or a number per call) or
/// `max_us` (the same in microseconds, at the clock `mhz`); reported if both are given,
/// or `max_us` without a clock.
fn limit(
    cycles: Option<&ArgValue>,
    micros: Option<&ArgValue>,
    (clock, mhz): (Option<f64>, &Given),
    diag: &mut Diagnostics,
) -> Option<Limit> {
    match (cycles, micros) {
        (Some(value), None) => read_limit("max_cycles", value, 1.0, diag),
        (Some(value), Some(_)) => {
            diag.error(
                value.span(),
                "give the budget once: `max_cycles = ..` or `max_us = .., mhz = ..`",
            );
            None
        }
        (None, Some(value)) => match (clock, mhz) {
            (Some(f), _) => read_limit("max_us", value, f, diag),
            (None, Some(Err(()))) => None,
            _ => {
                diag.error(
                    value.span(),
                    "`max_us` needs the core's clock to be a number of cycles: add `mhz = 168` \
                     (say), or give `max_cycles = ..`",
                );
                None
            }
        },
        (None, None) => None,
    }
}

/// `name = N` (one budget, times `scale` cycles) or `name = [call = N, ..]` (one per call).
fn read_limit(name: &str, value: &ArgValue, scale: f64, diag: &mut Diagnostics) -> Option<Limit> {
    let unit = if name == "max_us" {
        format!(", mhz = {scale}")
    } else {
        String::new()
    };
    // A time at a clock is the whole cycles within it.
    let cycles = |n: f64| {
        if name == "max_us" {
            (n * scale).floor()
        } else {
            n
        }
    };
    match value {
        ArgValue::Number(n, span) if n.is_finite() && *n > 0.0 => {
            whole_cycles(cycles(*n), format!("{name} = {n}{unit}"), *span, diag).map(Limit::Each)
        }
        ArgValue::Table(entries, _) => {
            let mut limits = Vec::new();
            for (call, n, span) in distinct(entries, name, diag) {
                if !(n.is_finite() && n > 0.0) {
                    diag.error(span, format!("`{name}` takes a positive number per call"));
                    continue;
                }
                let written = format!("{} = {n}{unit}", call.text);
                if let Some(limit) = whole_cycles(cycles(n), written, span, diag) {
                    limits.push((call.clone(), limit));
                }
            }
            (!limits.is_empty()).then_some(Limit::PerCall(limits))
        }
        other => {
            diag.error(
                other.span(),
                format!(
                    "`{name}` takes a positive number, or one per call: `{name} = [predict = \
                     2000, update_gnss = 9000]`"
                ),
            );
            None
        }
    }
}

/// `schedule = [predict = 250, ..]` at the clock `clock` (`None` when `mhz` is missing,
/// reported here, or wrong, reported already: `mhz_given`), bounded by `max_load`.
fn read_schedule(
    value: &ArgValue,
    (clock, mhz_given): (Option<f64>, bool),
    max_load: Given,
    diag: &mut Diagnostics,
) -> Option<Schedule> {
    let ArgValue::Table(entries, span) = value else {
        diag.error(
            value.span(),
            "`schedule` gives each call's rate in hertz, `schedule = [predict = 250, \
             update_gnss = 5]`, with the core's clock, `mhz = 168`",
        );
        return None;
    };
    let mut rates = Vec::new();
    for (call, hz, at) in distinct(entries, "schedule", diag) {
        if hz.is_finite() && hz > 0.0 && hz <= MAX_RATE_HZ {
            rates.push((call.clone(), hz));
        } else {
            diag.error(
                at,
                format!("a rate is a positive number of calls per second, at most {MAX_RATE_HZ:e}"),
            );
        }
    }
    let max_load = match max_load {
        None => 100.0,
        Some(Ok((p, _))) if p <= 100.0 => p,
        Some(Ok((_, at))) => {
            diag.error(
                at,
                "`max_load` is a share of the core in percent, at most 100",
            );
            return None;
        }
        Some(Err(())) => return None,
    };
    if clock.is_none() && !mhz_given {
        diag.error(
            *span,
            "a schedule's load is a share of the core's clock: add `mhz = 168` (say)",
        );
    }
    Some(Schedule {
        rates,
        mhz: clock?,
        max_load,
        span: *span,
    })
}

/// The entries of a `name = [call = value, ..]` list, a call named twice reported (and
/// its second value left out).
fn distinct<'a>(
    entries: &'a [(Name, f64, Span)],
    option: &str,
    diag: &mut Diagnostics,
) -> Vec<(&'a Name, f64, Span)> {
    let mut seen: Vec<&str> = Vec::new();
    let mut kept = Vec::new();
    for (call, value, span) in entries {
        if seen.contains(&call.text.as_str()) {
            diag.error(
                call.span,
                format!("`{}` is named twice in `{option}`", call.text),
            );
            continue;
        }
        seen.push(&call.text);
        kept.push((call, *value, *span));
    }
    kept
}

/// An option's positive number and where it was written: `None` if not given, `Err` if
/// given wrong (reported).
type Given = Option<Result<(f64, Span), ()>>;

/// The positive number given as `name`, `value`: `Err` (reported) if it is not one.
fn positive(value: Option<ArgValue>, name: &str, diag: &mut Diagnostics) -> Given {
    match &value? {
        ArgValue::Number(v, span) if v.is_finite() && *v > 0.0 => Some(Ok((*v, *span))),
        other => {
            diag.error(other.span(), format!("`{name}` takes a positive number"));
            Some(Err(()))
        }
    }
}

/// A budget of `n` cycles, if it is a whole number in range.
fn whole_cycles(n: f64, written: String, span: Span, diag: &mut Diagnostics) -> Option<CallLimit> {
    if n.fract() != 0.0 || !(1.0..=MAX_CYCLES).contains(&n) {
        diag.error(
            span,
            format!(
                "the budget is a whole number of cycles, 1 to {MAX_CYCLES:e}: {written} is not"
            ),
        );
        return None;
    }
    Some(CallLimit {
        cycles: n as u64,
        written,
        span,
    })
}
