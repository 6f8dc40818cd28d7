//! The measurement stage of each declared sensor (`sensor gnss = [..]`): the innovation and
//! covariance of its last update, stored in fields of its own (`gnss_innovation`), what a
//! user reads of them (`gnss_innovation()`, `gnss_normalised_innovation_squared()`), and
//! its own innovation gate, so that a 6-output GNSS fix and a 3-axis magnetometer sample
//! are judged each by its own chi-square quantile; and its own block of the measurement
//! noise `R` ([`NoiseBlock`]), which every filter of the EKF family stores apart and a user
//! sets apart (`set_gnss_noise`). Built on the shared measurement stage.

use crate::emit::measurement::{self, Measured};
use crate::emit::names::ident;
use crate::emit::tuning::StoredNoise;
use crate::model::{Model, Scalar, Sensor};
use crate::symbolic::linalg::packed_len;
use proc_macro2::TokenStream;
use quote::quote;

/// The prefix of a sensor's fields and accessors: `gnss_`.
pub fn prefix(sensor: &Sensor) -> String {
    format!("{}_", sensor.name)
}

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

/// One block of the measurement noise `R` of a filter of the EKF family, stored in a field
/// of its own: a sensor's outputs, or the outputs no sensor measures. The noise of two
/// sensors is independent, so `R` is block diagonal and its entries between two blocks are
/// structural zeros, neither stored nor added.
#[derive(Clone, Debug)]
pub struct NoiseBlock {
    /// The field holding it, packed: `gnss_r` for the sensor `gnss`, `r` for the rest.
    pub field: String,
    /// Its outputs, in the order of its rows (a sensor's as it lists them, the rest in the
    /// model's order).
    pub outputs: Vec<usize>,
    /// The sensor it is the noise of, if it is one's.
    pub sensor: Option<usize>,
}

/// The blocks of a filter's `R`: each sensor's, then the outputs no sensor measures (all of
/// them, in one full block `r`, in a model without sensors: today's `R`).
pub fn noise_blocks(model: &Model) -> Vec<NoiseBlock> {
    let mut blocks: Vec<NoiseBlock> = model
        .sensors
        .iter()
        .enumerate()
        .map(|(s, sensor)| NoiseBlock {
            field: format!("{}r", prefix(sensor)),
            outputs: sensor.outputs.clone(),
            sensor: Some(s),
        })
        .collect();
    let rest: Vec<usize> = (0..model.outputs.len())
        .filter(|j| !model.sensors.iter().any(|s| s.outputs.contains(j)))
        .collect();
    if !rest.is_empty() {
        blocks.push(NoiseBlock {
            field: "r".to_owned(),
            outputs: rest,
            sensor: None,
        });
    }
    blocks
}

/// Whether a block is the whole `R` as the model orders its outputs (stored as
/// `pack_upper` stores a matrix).
fn whole(block: &NoiseBlock, m: usize) -> bool {
    block.outputs.iter().copied().eq(0..m)
}

/// `&[index::GNSS_V_X, ..]`: a block's outputs, by their places in `y`.
fn output_indices(model: &Model, outputs: &[usize]) -> TokenStream {
    let names = outputs
        .iter()
        .map(|&j| crate::emit::names::index_const(&model.outputs[j].name));
    quote! { &[#(index::#names),*] }
}

/// How a constructor or `set_measurement_noise` stores the whole `R` argument `r` (`m x
/// m`, a covariance): in each block's field (`gnss_r: .., magnetometer_r: ..`), tested
/// zero between the blocks when there are several; in `r`, as before sensors had blocks,
/// in a model without sensors.
pub fn stored_noise(model: &Model, ty: &proc_macro2::Ident) -> StoredNoise {
    let blocks = noise_blocks(model);
    let fields = blocks
        .iter()
        .map(|block| {
            let packed = if whole(block, model.outputs.len()) {
                quote! { stateforge_math::#ty::pack_upper(r) }
            } else {
                let rows = output_indices(model, &block.outputs);
                quote! { stateforge_math::#ty::pack_upper_of(r, #rows) }
            };
            (ident(&block.field), packed)
        })
        .collect();
    let condition = (blocks.len() > 1).then(|| {
        let lists = blocks.iter().map(|b| output_indices(model, &b.outputs));
        quote! { stateforge_math::#ty::is_block_diagonal(r, &[#(#lists),*]) }
    });
    StoredNoise { fields, condition }
}

/// The fields of the blocks, `gnss_r: [S; 21], magnetometer_r: [S; 6],`.
pub fn block_fields(model: &Model, ty: &proc_macro2::Ident) -> TokenStream {
    noise_blocks(model)
        .iter()
        .map(|block| {
            let field = ident(&block.field);
            let len = proc_macro2::Literal::usize_unsuffixed(packed_len(block.outputs.len()));
            quote! { #field: [#ty; #len], }
        })
        .collect()
}

/// Each sensor's measurement noise accessor and setter, `gnss_noise()` and
/// `set_gnss_noise(r)`: its own `R`, over its outputs in the order it lists them.
pub fn noise_methods(model: &Model, ty: &proc_macro2::Ident) -> TokenStream {
    noise_blocks(model)
        .iter()
        .filter_map(|block| {
            let sensor = &model.sensors[block.sensor?];
            Some(sensor_noise_methods(model, sensor, &block.field, ty))
        })
        .collect()
}

/// [`noise_methods`] of one sensor, whose block is the field `field`.
fn sensor_noise_methods(
    model: &Model,
    sensor: &Sensor,
    field: &str,
    ty: &proc_macro2::Ident,
) -> TokenStream {
    let k = proc_macro2::Literal::usize_unsuffixed(sensor.outputs.len());
    let outputs: Vec<String> = sensor
        .outputs
        .iter()
        .map(|&j| format!("`{}`", model.outputs[j].name))
        .collect();
    let name = &sensor.name;
    let over = format!(
        "over its outputs {} in this order (the measurement `update_{name}` takes)",
        crate::diagnostics::phrase(&outputs, "and")
    );
    let getter_doc = format!(
        " The measurement noise covariance `R` of the sensor `{name}`, {over}: its block of \
         the filter's `R`, whose entries between two sensors are zero."
    );
    let setter_doc = format!(
        " Replaces the measurement noise covariance `R` of the sensor `{name}` (its upper \
         triangle is read), {over}; the other sensors' are left as they are. Rejects a \
         non-finite entry with [`Status::RejectedInput`], and a matrix that is not \
         symmetric and positive semi-definite with [`Status::InvalidCovariance`], leaving \
         the filter unchanged."
    );
    let field_ident = ident(field);
    let getter = ident(&format!("{name}_noise"));
    let setter = crate::emit::tuning::noise_setter(
        (&format!("set_{name}_noise"), "r", field),
        sensor.outputs.len(),
        false,
        &setter_doc,
        ty,
    );
    quote! {
        #[doc = #getter_doc]
        #[must_use]
        pub fn #getter(&self) -> [[#ty; #k]; #k] {
            stateforge_math::#ty::unpack_symmetric(&self.#field_ident)
        }

        #setter
    }
}
