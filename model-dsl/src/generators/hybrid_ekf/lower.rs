//! The hybrid (continuous-discrete) EKF (Takacs, Poloni and Rohal-Ilkiv, "Adaptive
//! predictive control of transient vibrations of cantilevers with changing weight",
//! sect. 3.2): the shared continuous stage between samples and the EKF's Joseph-form
//! update at each sample, assembled into the `HybridEkf` type.

use super::spec::HybridEkfSpec;
use crate::emit::continuous_filter::{method, FilterMethod, FilterOptions};
use crate::emit::filter::{substeps_constant, FilterLayout};
use crate::emit::known::KnownItems;
use crate::emit::lower::OpCount;
use crate::emit::measurement;
use crate::emit::names::ident;
use crate::emit::recovery;
use crate::model::{Model, Scalar};
use crate::symbolic::ModelGraph;
use proc_macro2::TokenStream;
use quote::quote;

/// Generated hybrid EKF code and its cost.
pub struct HybridEkfCode {
    /// The `HybridEkf` type and its methods.
    pub tokens: TokenStream,
    /// Arithmetic of one integration sub-step of state and covariance.
    pub substep_ops: OpCount,
    /// Arithmetic of `step` (every sub-step and the update).
    pub step_ops: OpCount,
}

/// The hybrid EKF of `model` (continuous dynamics) in `scalar`.
pub fn emit_hybrid_ekf(
    model: &Model,
    spec: &HybridEkfSpec,
    mg: &ModelGraph,
    scalar: Scalar,
) -> HybridEkfCode {
    let options = FilterOptions::of(&spec.process_noise, spec.gate, spec.recover_after);
    let (step, step_ops, substep_ops) = method(model, mg, scalar, FilterMethod::Step, &options);
    let (predict, ..) = method(model, mg, scalar, FilterMethod::Predict, &options);
    let (update, ..) = method(model, mg, scalar, FilterMethod::Update, &options);
    let recovery = recovery::filter_items(spec.recover_after, (true, &[]), scalar);
    let layout = FilterLayout::new(model, &spec.process_noise, &ident(scalar.type_name()));
    let fields = layout.fields();
    let measurement_fields =
        recovery.after_fields(measurement::fields(model, spec.gate, &layout.ty));
    let cleared = (spec.gate, &recovery.clear);
    let measurement_methods =
        recovery.after_methods(measurement::methods(model, &layout, cleared, scalar));
    let FilterLayout {
        accessors, setters, ..
    } = &layout;
    let substeps = substeps_constant(
        model,
        mg,
        &quote! {
            /// Integration sub-steps per sample, for state and covariance alike.
        },
    );
    let constructor = constructor_tokens(
        &layout,
        spec.process_noise.diagonal,
        &recovery.after_initial(measurement::initial_values(model, spec.gate, scalar)),
    );
    let gate_doc = measurement::gate_doc_attribute(spec.gate);
    let tokens = quote! {
        /// Hybrid (continuous-discrete) extended Kalman filter of this model (Takacs,
        /// Poloni, Rohal-Ilkiv, "Adaptive predictive control of transient vibrations of
        /// cantilevers with changing weight", sect. 3.2): between samples the estimate
        /// follows `x' = f(x, u)` and its covariance `P' = F P + P F' + Q`, `F = df/dx`
        /// (eq. 21), integrated together with the model's rule over [`HybridEkf::SUBSTEPS`]
        /// sub-steps; at each sample the Joseph-form update (eqs. 24-26). The covariance is
        /// stored once, as a packed upper triangle.
        #gate_doc
        ///
        /// Index convention (all filters of this module): [`HybridEkf::step`] at sample `k`
        /// takes the input `u[k-1]` applied since the previous sample and the measurement
        /// `y[k]`.
        #[derive(Clone, Copy, Debug, PartialEq)]
        pub struct HybridEkf {
            #fields
            #measurement_fields
        }

        impl HybridEkf {
            #substeps

            #constructor

            #measurement_methods

            #accessors

            #setters

            #step

            #predict

            #update
        }
    };
    HybridEkfCode {
        tokens,
        substep_ops,
        step_ops,
    }
}

/// `fn new`: the shared layout's constructor, `Q` a spectral density (the model has no
/// `known` constants: the hybrid EKF asks for every coefficient at generation).
fn constructor_tokens(
    layout: &FilterLayout,
    diagonal: bool,
    measurement_init: &TokenStream,
) -> TokenStream {
    let q_words = if diagonal {
        "the process noise spectral densities `q` (a diagonal `Q`)"
    } else {
        "the process noise spectral density `q`"
    };
    let new_doc = format!(
        " A filter from the initial estimate `x0` and covariance `p0`, {q_words} and the \
         measurement noise covariance `r`. `Q` is a density (per second: a discrete \
         covariance divided by the sample time, the paper's `Q = Q~ / T`). The matrices \
         must be covariances (symmetric, positive semi-definite): both are checked."
    );
    layout.constructor(
        &ident("HybridEkf"),
        &quote! { #[doc = #new_doc] },
        &KnownItems::default(),
        measurement_init,
    )
}
