//! The measurement noise `R` of the EKF family by sensor: one block per sensor (a GNSS
//! fix's, a magnetometer's), stored in a field of its own, which a user reads and sets apart
//! (`gnss_noise`, `set_gnss_noise`); the noise of two sensors is independent, so the zeros
//! between blocks are neither stored nor added. A model without sensors keeps one full `R`.

use crate::emit::names::ident;
use crate::emit::tuning::StoredNoise;
use crate::model::{Model, Sensor};
use crate::symbolic::linalg::packed_len;
use proc_macro2::TokenStream;
use quote::quote;

/// The prefix of a sensor's fields and accessors: `gnss_`.
pub fn prefix(sensor: &Sensor) -> String {
    format!("{}_", sensor.name)
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
