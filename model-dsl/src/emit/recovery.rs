//! Recovery after a run of refused measurements, written once for every filter that
//! corrects through the measurement stage (the EKF and its partial and sensors' updates,
//! the hybrid and the continuous-time EKF, both stages of the DKF).
//!
//! A refused measurement (an outlier beyond the gate, `OutlierRejected`, or without a
//! gate one beyond the divergence bound on the normalised innovation squared, `Diverged`)
//! leaves the filter's estimate as it was, or at its prediction. A filter whose estimate
//! has drifted from the measurements while its covariance says it is sure refuses every
//! measurement after: nothing it does brings its covariance back to the size of its error
//! (a gated step's prediction grows it by `Q` only, an ungated refusal not at all), and the
//! DKF empties its window at each refusal, so that the window does not refill. It has
//! locked itself out until the caller resets it.
//!
//! The rule: each stage counts its consecutive refusals (`refusals()`, zeroed by a
//! measurement it takes, and by `reset`). At the `RECOVER_AFTER`-th in a row it scales its
//! covariance by the refused measurement's normalised innovation squared over its target,
//! `P <- (nis / target) P`, the target being the gate, or without one the number of
//! outputs `m` (the expected normalised square: the divergence bound without a gate, 1e4
//! standard deviations, says nothing of consistency), when that scale is above 1 and the
//! scaled variances stay within the divergence bound; starts counting again; and returns
//! `Status::Recovering` instead of the refusal. When the prediction's uncertainty
//! dominates `S` (the case of an overconfident filter) that is the smallest common scale
//! of `P` under which the refused innovation would have reached its target: the next
//! measurements are judged by a covariance as wide as the error the filter showed, and
//! taken; where it is not enough (`R` dominates, or the estimate keeps drifting), the next
//! run scales again. A common scale keeps `P` positive semi-definite and its correlations.
//! A genuine outlier is refused as before: only a run of `RECOVER_AFTER` refusals
//! inflates (with a gate at the chi-square 99.9 % quantile, ten consistent measurements in
//! a row beyond it have a probability of 1e-30). The polynomial Kalman filter has a
//! recovery of its own, its window's re-initialisation every `REINIT_EVERY` samples; the
//! switched observers refuse no measurement.

use crate::emit::names::ident;
use crate::model::Scalar;
use proc_macro2::{Literal, TokenStream};
use quote::quote;

/// `recover_after`'s default: consecutive refusals before a stage inflates its covariance.
pub const DEFAULT_RECOVER_AFTER: u32 = 10;

/// The largest `recover_after` accepted.
pub const MAX_RECOVER_AFTER: u32 = 1_000_000;

/// One measuring stage's recovery: where its fields are and what it inflates.
pub struct Recovery<'a> {
    /// The prefix of the stage's fields and method: empty for the filter's own, `akf_`
    /// for the DKF's AKF, `gnss_` for a sensor's update.
    pub prefix: &'a str,
    /// The packed covariance field it inflates: `p`, or `pbar` for the DKF's AKF.
    pub covariance: &'a str,
    /// What its accessor's documentation calls it: `the filter`, `the AKF`.
    pub what: &'a str,
}

/// What a filter type adds for its stages' recovery: the counts' fields, their initial
/// values, their clearing in `reset`, and the methods (the constant, the accessors, the
/// inlined answers to a refusal). All empty with `recover_after = off`.
#[derive(Default)]
pub struct RecoveryItems {
    /// The counts' fields, each followed by a comma.
    pub fields: TokenStream,
    /// Their values in the constructor, each followed by a comma.
    pub initial: TokenStream,
    /// Their clearing, for `reset`.
    pub clear: TokenStream,
    /// `RECOVER_AFTER`, `refusals()` and `refused` of each stage.
    pub methods: TokenStream,
}

impl RecoveryItems {
    /// `fields`, then the counts' fields.
    pub fn after_fields(&self, fields: TokenStream) -> TokenStream {
        let own = &self.fields;
        quote! { #fields #own }
    }

    /// `initial`, then the counts' initial values.
    pub fn after_initial(&self, initial: TokenStream) -> TokenStream {
        let own = &self.initial;
        quote! { #initial #own }
    }

    /// `methods`, then the recovery's.
    pub fn after_methods(&self, methods: TokenStream) -> TokenStream {
        let own = &self.methods;
        quote! { #methods #own }
    }
}

/// The items of a filter type whose measuring stages are `stages`, recovering after
/// `recover_after` refusals (nothing for `None`, `recover_after = off`).
pub fn items(recover_after: Option<u32>, stages: &[Recovery<'_>], scalar: Scalar) -> RecoveryItems {
    let Some(recover_after) = recover_after else {
        return RecoveryItems::default();
    };
    let prefixes = stages.iter().map(|stage| stage.prefix);
    let constant = constant(recover_after);
    let accessors = stages
        .iter()
        .map(|stage| accessor(stage.prefix, stage.what));
    let methods = stages.iter().map(|stage| method(stage, scalar));
    RecoveryItems {
        fields: prefixes.clone().map(field).collect(),
        initial: prefixes.clone().map(initial_value).collect(),
        clear: prefixes.map(clear).collect(),
        methods: quote! { #constant #(#accessors)* #(#methods)* },
    }
}

/// The name of a stage's count of consecutive refusals, `{prefix}refusals`.
fn count_field(prefix: &str) -> proc_macro2::Ident {
    ident(&format!("{prefix}refusals"))
}

/// The name of a stage's inlined answer to a refusal, `{prefix}refused`.
pub fn method_name(prefix: &str) -> proc_macro2::Ident {
    ident(&format!("{prefix}refused"))
}

/// The recovery of an EKF-family filter (covariance `p`): its own stage (unless `own` is
/// false: a joint update that is its sensors' in turn has none), and each sensor's update
/// in `sensors` (its fields' prefix, `gnss_`, and its name), which counts its own
/// refusals.
pub fn filter_items(
    recover_after: Option<u32>,
    (own, sensors): (bool, &[(String, String)]),
    scalar: Scalar,
) -> RecoveryItems {
    let what: Vec<String> = sensors
        .iter()
        .map(|(_, name)| format!("the sensor `{name}`'s update"))
        .collect();
    let own = own.then_some(Recovery {
        prefix: "",
        covariance: "p",
        what: "the filter",
    });
    let of_sensors = sensors
        .iter()
        .zip(&what)
        .map(|((prefix, _), what)| Recovery {
            prefix,
            covariance: "p",
            what,
        });
    let stages: Vec<Recovery<'_>> = own.into_iter().chain(of_sensors).collect();
    items(recover_after, &stages, scalar)
}

/// `{prefix}refusals: u32,`: the stage's count of consecutive refusals.
pub fn field(prefix: &str) -> TokenStream {
    let name = count_field(prefix);
    quote! { #name: u32, }
}

/// `{prefix}refusals: 0,`: the count in a constructor.
pub fn initial_value(prefix: &str) -> TokenStream {
    let name = count_field(prefix);
    quote! { #name: 0, }
}

/// `self.{prefix}refusals = stateforge_math::NO_REFUSALS;`: a taken measurement, or
/// `reset`, ends a run of refusals (no integer literal in code: see the generated code's
/// allow-list).
pub fn clear(prefix: &str) -> TokenStream {
    let name = count_field(prefix);
    quote! { self.#name = stateforge_math::NO_REFUSALS; }
}

/// `pub const RECOVER_AFTER: u32`, the type's rule, documented.
pub fn constant(recover_after: u32) -> TokenStream {
    let value = Literal::u32_unsuffixed(recover_after);
    quote! {
        /// Consecutive refused measurements (`OutlierRejected`, or `Diverged` at the bound
        /// on the normalised innovation squared) after which a stage recovers on its own:
        /// it scales its covariance by the last one's normalised innovation squared over
        /// the gate (without a gate, over its number of outputs) and returns
        /// [`Status::Recovering`] (`recover_after = N`, 10 unless given).
        pub const RECOVER_AFTER: u32 = #value;
    }
}

/// `{prefix}refusals()`: the stage's current run of refused measurements.
pub fn accessor(prefix: &str, what: &str) -> TokenStream {
    let name = count_field(prefix);
    let doc = format!(
        " How many measurements in a row {what} has refused since it last took one \
         (or recovered, or was reset): at `RECOVER_AFTER` it recovers."
    );
    quote! {
        #[doc = #doc]
        #[must_use]
        pub fn #name(&self) -> u32 {
            self.#name
        }
    }
}

/// The stage's inlined answer to a refused measurement of normalised innovation squared
/// `nis` (which it scales to `target`): counts it, and at the `RECOVER_AFTER`-th in a row inflates the covariance (see
/// the module's documentation) and returns `Recovering`; otherwise returns the refusal.
pub fn method(recovery: &Recovery<'_>, scalar: Scalar) -> TokenStream {
    let (name, count) = (method_name(recovery.prefix), count_field(recovery.prefix));
    let covariance = ident(recovery.covariance);
    let ty = ident(scalar.type_name());
    // Inlined, as what it calls: a call on the refusal path cost the navigation EKF's
    // GNSS update 116 instructions on its usual path (5436 -> 5552; inlined, 5464).
    quote! {
        /// A refused measurement: counted, and the `RECOVER_AFTER`-th in a row inflates
        /// the covariance by its normalised innovation squared over `target` (the gate,
        /// or the number of outputs), when above 1 and within the divergence bound.
        /// Always inlined: a call on the refusal path slows the update's usual path.
        #[allow(clippy::inline_always)]
        #[inline(always)]
        fn #name(&mut self, nis: #ty, target: #ty, refusal: Status) -> Status {
            if !stateforge_math::refusal_run_complete(&mut self.#count, Self::RECOVER_AFTER) {
                return refusal;
            }
            if stateforge_math::#ty::inflate_covariance(&mut self.#covariance, nis / target) {
                return Status::Recovering;
            }
            refusal
        }
    }
}
