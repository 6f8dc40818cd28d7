//! The measurement stage of each declared sensor (`sensor gnss = [..]`): the innovation and
//! covariance of its last update, stored in fields of its own (`gnss_innovation`), what a
//! user reads of them (`gnss_innovation()`, `gnss_normalised_innovation_squared()`), and
//! its own innovation gate, so that a 6-output GNSS fix and a 3-axis magnetometer sample
//! are judged each by its own chi-square quantile (its block of the measurement noise `R`
//! is [`crate::emit::noise_blocks`]'s). Built on the shared measurement stage.

use crate::emit::measurement::{self, Measured};
use crate::model::{Model, Scalar, Sensor};
use proc_macro2::TokenStream;
use quote::quote;

pub use crate::emit::noise_blocks::prefix;

/// The gate a sensor's update is generated with: its own (`sensor gnss(gate = 22.46)`),
/// else the filter's (`gate`), if either is given; `None` for an update without a gate.
pub fn gate_of(sensor: &Sensor, filter_gate: Option<f64>) -> Option<f64> {
    sensor.gate.or(filter_gate)
}

/// Every sensor's fields: its innovation and packed covariance, and its gate when it or the
/// filter has one; each followed by a comma.
pub fn fields(model: &Model, gate: Option<f64>, ty: &proc_macro2::Ident) -> TokenStream {
    model
        .sensors
        .iter()
        .map(|sensor| {
            let prefix = prefix(sensor);
            let innovation = measurement::innovation_fields_of(sensor.outputs.len(), &prefix, ty);
            let gate = gate_of(sensor, gate).map(|_| {
                let field = crate::emit::names::ident(&format!("{prefix}gate"));
                quote! { #field: #ty, }
            });
            quote! { #innovation #gate }
        })
        .collect()
}

/// The constructor's values of [`fields`]: a zero innovation of unit covariance, and the
/// generated gate (the sensor's own, else the filter's).
pub fn initial_values(model: &Model, gate: Option<f64>, scalar: Scalar) -> TokenStream {
    model
        .sensors
        .iter()
        .map(|sensor| {
            let prefix = prefix(sensor);
            let cleared = measurement::cleared_values_of(sensor.outputs.len(), &prefix, scalar);
            let gate = gate_of(sensor, gate).map(|gate| {
                let field = crate::emit::names::ident(&format!("{prefix}gate"));
                let value = crate::emit::lower::literal(measurement::opened_at_most(gate), scalar);
                quote! { #field: #value, }
            });
            quote! { #cleared #gate }
        })
        .collect()
}

/// What `reset` does to the sensors: clears their innovations (their gates stay).
pub fn clear(model: &Model, scalar: Scalar) -> TokenStream {
    model
        .sensors
        .iter()
        .map(|sensor| {
            measurement::clear_innovation_of(sensor.outputs.len(), &prefix(sensor), scalar)
        })
        .collect()
}

/// Each sensor's accessors (`gnss_innovation`, `gnss_normalised_innovation_squared`) and,
/// with a gate (its own or the filter's), its getter and setter.
pub fn methods(model: &Model, gate: Option<f64>, scalar: Scalar) -> TokenStream {
    model
        .sensors
        .iter()
        .map(|sensor| {
            let prefix = prefix(sensor);
            let of = format!(" by the sensor `{}`", sensor.name);
            let len_usize = sensor.outputs.len();
            let len = len_usize.to_string();
            let measured = Measured {
                outputs: &sensor.outputs,
                prefix: &prefix,
                of: &of,
                len_doc: &len,
            };
            let accessors = measurement::accessors_of(model, &measured, scalar);
            let gate = gate_of(sensor, gate).map(|gate| {
                let quantile = match crate::model::CHI_SQUARE_999.get(len_usize.wrapping_sub(1)) {
                    Some(q) => format!(" (the 99.9 % quantile, {q}, rejects one in a thousand consistent measurements)"),
                    None => String::new(),
                };
                let setter_doc = format!(
                    " Sets the innovation gate of the sensor `{}`'s updates, apart from the \
                     filter's: a chi-square quantile for its {len} degrees of freedom, as \
                     many as it has outputs{quantile}.",
                    sensor.name
                );
                measurement::gate_items_of(gate, &prefix, &setter_doc, scalar)
            });
            quote! { #accessors #gate }
        })
        .collect()
}
