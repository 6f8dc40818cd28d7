//! The measurement stage of each declared sensor (`sensor gnss = [..]`): the innovation and
//! covariance of its last update, stored in fields of its own (`gnss_innovation`), what a
//! user reads of them (`gnss_innovation()`, `gnss_normalised_innovation_squared()`), and
//! its own innovation gate, so that a 6-output GNSS fix and a 3-axis magnetometer sample
//! are judged each by its own chi-square quantile. Built on the shared measurement stage.

use crate::emit::measurement::{self, Measured};
use crate::model::{Model, Scalar, Sensor};
use proc_macro2::TokenStream;
use quote::quote;

/// The prefix of a sensor's fields and accessors: `gnss_`.
pub fn prefix(sensor: &Sensor) -> String {
    format!("{}_", sensor.name)
}

/// Every sensor's fields: its innovation and packed covariance, and its gate when the
/// filter has one; each followed by a comma.
pub fn fields(model: &Model, gate: Option<f64>, ty: &proc_macro2::Ident) -> TokenStream {
    model
        .sensors
        .iter()
        .map(|sensor| {
            let prefix = prefix(sensor);
            let innovation = measurement::innovation_fields_of(sensor.outputs.len(), &prefix, ty);
            let gate = gate.map(|_| {
                let field = crate::emit::names::ident(&format!("{prefix}gate"));
                quote! { #field: #ty, }
            });
            quote! { #innovation #gate }
        })
        .collect()
}

/// The constructor's values of [`fields`]: a zero innovation of unit covariance, and the
/// generated gate.
pub fn initial_values(model: &Model, gate: Option<f64>, scalar: Scalar) -> TokenStream {
    model
        .sensors
        .iter()
        .map(|sensor| {
            let prefix = prefix(sensor);
            let cleared = measurement::cleared_values_of(sensor.outputs.len(), &prefix, scalar);
            let gate = gate.map(|gate| {
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
/// with a gate, its getter and setter.
pub fn methods(model: &Model, gate: Option<f64>, scalar: Scalar) -> TokenStream {
    model
        .sensors
        .iter()
        .map(|sensor| {
            let prefix = prefix(sensor);
            let of = format!(" by the sensor `{}`", sensor.name);
            let len = sensor.outputs.len().to_string();
            let measured = Measured {
                outputs: &sensor.outputs,
                prefix: &prefix,
                of: &of,
                len_doc: &len,
            };
            let accessors = measurement::accessors_of(model, &measured, scalar);
            let gate = gate.map(|gate| {
                let setter_doc = format!(
                    " Sets the innovation gate of the sensor `{}`'s updates (a chi-square \
                     quantile for {len} degrees of freedom), apart from the filter's.",
                    sensor.name
                );
                measurement::gate_items_of(gate, &prefix, &setter_doc, scalar)
            });
            quote! { #accessors #gate }
        })
        .collect()
}
