//! The continuous-time EKF of Kulkarni and Purwar (Kulkarni and Purwar, "Nonlinear experimental
//! estimation and verification of a MIMO system through EKF", eq. 5): the estimate follows
//! `x' = f + K (z - h)`, `K = P H' R^-1`, and the covariance the Riccati equation
//! `P' = F P + P F' + Q - P H' R^-1 H P`, integrated over each sample with the model's rule
//! and sub-steps; optionally with a prescribed degree of stability `alpha` (Reif et al.,
//! the paper's eq. 26): `F + alpha I` in place of `F` in the Riccati equation.

use super::spec::ContinuousEkfSpec;
use crate::emit::continuous_filter::{integrates_whole, method, FilterMethod, FilterOptions};
use crate::emit::filter::{substeps_constant, FilterLayout};
use crate::emit::known::KnownItems;
use crate::emit::lower::{literal, OpCount};
use crate::emit::measurement;
use crate::emit::names::ident;
use crate::emit::recovery;
use crate::model::{Model, Scalar};
use crate::symbolic::ModelGraph;
use proc_macro2::TokenStream;
use quote::quote;

/// Generated continuous-time EKF code and its cost.
pub struct ContinuousEkfCode {
    /// The `ContinuousEkf` type and its methods.
    pub tokens: TokenStream,
    /// Arithmetic of one integration sub-step of state and Riccati equation.
    pub substep_ops: OpCount,
    /// Arithmetic of `step` (every sub-step): of the whole equations' step where the model
    /// has one (see [`integrates_whole`]), else of the split step.
    pub step_ops: OpCount,
    /// Arithmetic of the split step `step_split` a stiff sample takes, where `step` is the
    /// whole equations'.
    pub split_step_ops: Option<OpCount>,
}

/// The continuous-time EKF of `model` (continuous dynamics) in `scalar`.
pub fn emit_continuous_ekf(
    model: &Model,
    spec: &ContinuousEkfSpec,
    mg: &ModelGraph,
    scalar: Scalar,
) -> ContinuousEkfCode {
    let options = FilterOptions::of(&spec.process_noise, spec.gate, spec.recover_after);
    let alpha = spec.alpha.is_some();
    let whole = integrates_whole(model, mg);
    let (step, step_ops, substep_ops, split_step, split_step_ops) =
        steps(model, mg, scalar, (alpha, whole), &options);
    let predict_kind = FilterMethod::ContinuousPredict { alpha };
    let (predict, ..) = method(model, mg, scalar, predict_kind, &options);
    let ty = ident(scalar.type_name());
    let recovery = recovery::filter_items(spec.recover_after, (true, &[]), scalar);
    let layout = FilterLayout::new(model, &spec.process_noise, &ty);
    let fields = layout.fields();
    let measurement_fields = recovery.after_fields(measurement::fields(model, spec.gate, &ty));
    let measurement_init =
        recovery.after_initial(measurement::initial_values(model, spec.gate, scalar));
    let cleared = (spec.gate, &recovery.clear);
    let measurement_methods =
        recovery.after_methods(measurement::methods(model, &layout, cleared, scalar));
    let FilterLayout {
        accessors, setters, ..
    } = &layout;
    let substeps = substeps_item(model, mg);
    let alpha_field = spec.alpha.map(|_| quote! { alpha: #ty, });
    let alpha_init = spec.alpha.map(|_| quote! { alpha: Self::ALPHA, });
    // The model has no `known` constants: the filter asks for every coefficient at
    // generation.
    let constructor = layout.constructor(
        &ident("ContinuousEkf"),
        &quote! {
            /// A filter from the initial estimate `x0` and covariance `p0` and the noise
            /// spectral densities `q` and `r` (covariances: checked symmetric, positive
            /// semi-definite).
        },
        &KnownItems::default(),
        &quote! { #measurement_init #alpha_init },
    );
    let alpha_items = spec.alpha.map(|alpha| alpha_items(alpha, scalar));
    let doc = type_doc(spec, whole);
    let tokens = quote! {
        #[doc = #doc]
        #[derive(Clone, Copy, Debug, PartialEq)]
        pub struct ContinuousEkf {
            #fields
            #measurement_fields
            #alpha_field
        }

        impl ContinuousEkf {
            #substeps

            #constructor

            #measurement_methods

            #accessors

            #alpha_items

            #setters

            #step

            #split_step

            #predict
        }
    };
    ContinuousEkfCode {
        tokens,
        substep_ops,
        step_ops,
        split_step_ops,
    }
}

/// A continuous-time EKF's steps: `step` (its tokens, its arithmetic and that of one
/// sub-step) and, where it integrates the whole equations, the `step_split` it falls back
/// on (its tokens and arithmetic).
type Steps = (TokenStream, OpCount, OpCount, TokenStream, Option<OpCount>);

/// The filter's steps ([`Steps`]): where it integrates the whole equations (`whole`),
/// `step` and `step_split`; else `step` is the split step.
fn steps(
    model: &Model,
    mg: &ModelGraph,
    scalar: Scalar,
    (alpha, whole): (bool, bool),
    options: &FilterOptions,
) -> Steps {
    let split_kind = FilterMethod::ContinuousSplit {
        alpha,
        fallback: whole,
    };
    let (split_step, split_ops, split_substep_ops) = method(model, mg, scalar, split_kind, options);
    if whole {
        let step_kind = FilterMethod::Continuous { alpha };
        let (step, ops, substep_ops) = method(model, mg, scalar, step_kind, options);
        (step, ops, substep_ops, split_step, Some(split_ops))
    } else {
        (
            split_step,
            split_ops,
            split_substep_ops,
            TokenStream::new(),
            None,
        )
    }
}

/// `SUBSTEPS`, the sub-steps of each sample's propagation.
fn substeps_item(model: &Model, mg: &ModelGraph) -> TokenStream {
    substeps_constant(
        model,
        mg,
        &quote! {
            /// Integration sub-steps per sample, for state and Riccati equation alike.
        },
    )
}

/// The prescribed degree of stability `alpha` (Reif et al.): its default, generated as
/// `alpha`, its getter and its setter.
fn alpha_items(alpha: f64, scalar: Scalar) -> TokenStream {
    let ty = ident(scalar.type_name());
    let value = literal(alpha, scalar);
    let zero = literal(0.0, scalar);
    quote! {
        /// The default prescribed degree of stability `alpha` (per second): the
        /// estimation error of a filter that converges decays at least as
        /// `exp(-alpha t)` (Reif et al.).
        pub const ALPHA: #ty = #value;

        /// The prescribed degree of stability in use.
        #[must_use]
        pub fn alpha(&self) -> #ty {
            self.alpha
        }

        /// Sets the prescribed degree of stability `alpha >= 0` (per second; `0` gives
        /// the standard continuous-time EKF). Rejects a negative or non-finite value
        /// with [`Status::RejectedInput`], leaving the filter unchanged.
        pub fn set_alpha(&mut self, alpha: #ty) -> Status {
            if !(alpha >= #zero && alpha.is_finite()) {
                return Status::RejectedInput;
            }
            self.alpha = alpha;
            Status::Ok
        }
    }
}

/// How the step integrates the equations, with a model of one RK4 sub-step per sample
/// (`whole`) or otherwise.
fn integration_doc(whole: bool) -> &'static str {
    if whole {
        "Integrated by RK4, the whole equations over the sample, while the measurement \
         terms are not stiff: while `T tr(R^-1 H P H')` (at least `T` times the largest rate \
         `P H' R^-1 H` pulls the estimate at) is at most 0.1, so that the error stays of \
         the fourth order in `T`. A stiffer sample (a precise sensor and an uncertain \
         start), or an `R` that is not positive definite, is integrated split, so that no \
         gain makes it unstable, in two sub-steps of Strang's splitting: the measurement \
         terms alone over a quarter of the sample by their exact flow, \
         `P = (P^-1 + t H' R^-1 H)^-1` over the time `t` (the Joseph-form update with the \
         measurement noise `R / t`), the equations without them over half the sample by \
         one RK4 step, the measurement terms' flow over half the sample, the equations \
         without them over the other half, their flow over the last quarter. An explicit \
         step of the whole equations diverges once `T` times the rate `P H' R^-1 H` leaves \
         its stability region."
    } else {
        "Integrated split, so that no gain makes it unstable, by Strang's splitting: the \
         measurement terms alone over half the sample by their exact flow, \
         `P = (P^-1 + t H' R^-1 H)^-1` over the time `t` (the Joseph-form update with the \
         measurement noise `2 R / T`), the equations without them over the sample by the \
         model's rule and [`ContinuousEkf::SUBSTEPS`] sub-steps, the measurement terms' flow \
         over the other half; the split's error is of the second order in `T`. An explicit \
         step of the whole equations diverges once `T` times the rate `P H' R^-1 H` leaves \
         its stability region (a precise sensor and an uncertain start)."
    }
}

/// The filter type's documentation: eq. 5, with `alpha` eq. 26.
fn type_doc(spec: &ContinuousEkfSpec, whole: bool) -> String {
    let riccati = if spec.alpha.is_some() {
        "`P' = (F + alpha I) P + P (F + alpha I)' + Q - P H' R^-1 H P` (eq. 26, with a \
         prescribed degree of stability `alpha`, Reif et al.)"
    } else {
        "`P' = F P + P F' + Q - P H' R^-1 H P`"
    };
    format!(
        " Continuous-time extended Kalman filter of this model (Kulkarni and Purwar, \
         \"Nonlinear experimental estimation and verification of a MIMO system through \
         EKF\", eq. 5): `x' = f(x, u) + K (y - h(x))`, `K = P H' R^-1`, and {riccati}, \
         `F = df/dx`, `H = dh/dx`, over each sample with input and measurement held. \
         `Q` and `R` are spectral densities. The covariance is stored once, as a packed \
         upper triangle.\n\n {integration}{gate}",
        integration = integration_doc(whole),
        gate = measurement::gate_doc(spec.gate)
    )
}
