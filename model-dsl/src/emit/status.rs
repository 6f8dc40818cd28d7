//! The status every generated filter and controller step returns.

use crate::model::Model;
use proc_macro2::TokenStream;
use quote::quote;

/// The `Status` type of `model`'s filters.
pub fn status_enum(model: &Model) -> TokenStream {
    let rejected_input = rejected_input_doc(model);
    quote! {
        /// What a filter or controller step did. On anything but [`Status::Ok`] the filter
        /// or controller is left exactly as it was, except as
        /// [`Status::OutlierRejected`] and [`Status::Recovering`] say, and that a filter
        /// counts the measurements it refuses in a row (`refusals()`, see `RECOVER_AFTER`).
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        #[must_use = "a step that did not return `Status::Ok` did not apply its measurement"]
        pub enum Status {
            /// The step was applied.
            Ok,
            #[doc = #rejected_input]
            RejectedInput,
            /// A covariance argument (initial, process or measurement noise) was not a
            /// covariance: not symmetric, or not positive semi-definite (a negative
            /// variance, a correlation beyond 1). It was not used.
            InvalidCovariance,
            /// The innovation covariance was not positive definite; it is never divided by.
            NonPositiveInnovation,
            /// The step would have produced a non-finite estimate or covariance.
            NonFinite,
            /// The step would have diverged: its new estimate and variances summed beyond
            /// 1e18 in magnitude, or a variance turned negative (`stateforge_math`'s
            /// `DIVERGENCE_BOUND`); or, in a filter without an innovation gate, the
            /// measurement's normalised innovation squared exceeded 1e8 (`DIVERGENCE_NIS`),
            /// a change of the estimate by up to 1e4 standard deviations, or was NaN. Nothing was
            /// applied (a refused measurement is counted: a run of them ends in
            /// [`Status::Recovering`]); a filter whose results keep leaving the bound
            /// needs a `reset`.
            Diverged,
            /// The Riccati recursion met a non-positive `R + B' P B`; it is never divided by.
            NonPositiveControlWeight,
            /// The measurement's normalised innovation squared exceeded the innovation gate:
            /// it was not used. An update leaves the estimate as it was; a step keeps the
            /// prediction. The filter's innovation describes the rejected measurement.
            OutlierRejected,
            /// The measurement was refused (as `OutlierRejected` or, without a gate,
            /// `Diverged` says), the filter's `RECOVER_AFTER`-th in a row: the filter scaled
            /// its covariance by the measurement's normalised innovation squared over the
            /// gate (without one, over its number of outputs), so that it takes the next
            /// measurements instead of refusing them for good. Its estimate is as the
            /// refusal left it.
            Recovering,
            /// A weight argument of a controller (its state or input weight) was not
            /// positive semi-definite, as its upper triangle reads: a negative weight, or a
            /// cross weight beyond the geometric mean of its two diagonal weights. It was
            /// not used.
            InvalidWeight,
        }
    }
}

/// What `Status::RejectedInput` says was refused: a non-finite argument, in every
/// filter; a sample interval that is not positive, where the model's predictions take one
/// (`interval DT = ..;`); and where a sensor's measurements come with their delay
/// (`max_delay`), a delay beyond the maximum and a second measurement for a sample one
/// already waits for.
fn rejected_input_doc(model: &Model) -> String {
    let interval = model
        .interval_parameter()
        .map(|dt| format!(", or the sample interval `{dt}` was not positive"))
        .unwrap_or_default();
    let delay = if model.sensors.iter().any(|s| s.delay_at_run_time) {
        " The update of a sensor that takes each measurement's `delay` (`max_delay`) also \
         refuses a `delay` beyond the sensor's `max_delay`, and a second measurement of the \
         sensor for a sample one already waits for (the first is kept)."
    } else {
        ""
    };
    format!(" An input or measurement was NaN or infinite{interval}.{delay}")
}
