//! The sample interval a prediction takes at run time (`interval DT = 0.004;`): the test
//! every such method makes of it before anything is computed, its cost, and what the
//! method's documentation says of it. The EKF and the continuous filters share it.

use super::lower::{literal, OpCount};
use super::names::ident;
use crate::model::Scalar;
use proc_macro2::TokenStream;
use quote::quote;

/// `if dt <= 0 { return Status::RejectedInput; }` for the parameter `parameter`: with the
/// finiteness test every argument passes (`Arguments::time`), an interval that is not
/// positive and finite is refused, the filter unchanged (a zero one would divide the
/// measurement noise density by zero, a negative one integrate backwards).
pub fn guard(parameter: &str, scalar: Scalar) -> TokenStream {
    let dt = ident(parameter);
    let zero = literal(0.0, scalar);
    quote! {
        if #dt <= #zero {
            return Status::RejectedInput;
        }
    }
}

/// What [`guard`] costs: one comparison (its branch is not taken).
pub fn guard_ops() -> OpCount {
    OpCount {
        compare: 1,
        ..OpCount::default()
    }
}

/// The documentation of a method that takes the interval `parameter`, after what the
/// method does over it (`over_it`: "the model's step is a function of it, and the process
/// noise `Q` is a density, the noise of the interval `Q dt`").
pub fn doc(parameter: &str, over_it: &str) -> String {
    format!(
        " `{parameter}` is the sample interval in seconds, the time since the previous \
         sample (an IMU sample's own, with its jitter): {over_it}. A `{parameter}` that is \
         not positive and finite is refused as [`Status::RejectedInput`]."
    )
}
