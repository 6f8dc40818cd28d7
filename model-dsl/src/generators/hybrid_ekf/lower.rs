//! The hybrid (continuous-discrete) EKF (Takacs, Poloni and Rohal-Ilkiv, "Adaptive
//! predictive control of transient vibrations of cantilevers with changing weight",
//! sect. 3.2): the shared continuous stage between samples and the EKF's Joseph-form
//! update at each sample, assembled into the `HybridEkf` type.

use crate::emit::code::{estimate_accessors, pack_upper};
use crate::emit::continuous_filter::{method, Kind};
use crate::emit::filter::noise_argument;
use crate::emit::lower::OpCount;
use crate::emit::names::ident;
use crate::emit::tuning::noise_setters;
use super::spec::HybridEkfSpec;
use crate::model::{Model, Scalar};
use crate::symbolic::linalg::packed_len;
use crate::symbolic::ModelGraph;
use proc_macro2::{Literal, TokenStream};
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
    let diagonal = spec.diagonal_noise;
    let (step, step_ops, substep_ops) = method(model, mg, scalar, Kind::Step, diagonal);
    let (predict, ..) = method(model, mg, scalar, Kind::Predict, diagonal);
    let (update, ..) = method(model, mg, scalar, Kind::Update, diagonal);
    let ty = ident(scalar.type_name());
    let (n, m) = (model.state_len(), model.outputs.len());
    let [n_len, m_len, np, mp] =
        [n, m, packed_len(n), packed_len(m)].map(Literal::usize_unsuffixed);
    let (pack_p0, pack_r) = (pack_upper("p0", n), pack_upper("r", m));
    let (q_param, q_field, pack_q) = noise_argument("q", n, diagonal, &ty);
    let accessors = estimate_accessors(n, &ty);
    let setters = noise_setters(n, m, diagonal, &ty);
    let substeps = mg.clone().substep(model).map_or(1, |(_, _, n)| n);
    let substeps_lit = Literal::u32_unsuffixed(substeps);
    let q_words = if diagonal {
        "the process noise spectral densities `q` (a diagonal `Q`)"
    } else {
        "the process noise spectral density `q`"
    };
    let new_doc = format!(
        " A filter from the initial estimate `x0` and covariance `p0`, {q_words} and the \
         measurement noise covariance `r`. `Q` is a density (per second: a discrete \
         covariance divided by the sample time, the paper's `Q = Q~ / T`). The matrices \
         are symmetric: only their upper triangles are read."
    );
    let tokens = quote! {
        /// Hybrid (continuous-discrete) extended Kalman filter of this model (Takacs,
        /// Poloni, Rohal-Ilkiv, "Adaptive predictive control of transient vibrations of
        /// cantilevers with changing weight", sect. 3.2): between samples the estimate
        /// follows `x' = f(x, u)` and its covariance `P' = F P + P F' + Q`, `F = df/dx`
        /// (eq. 21), integrated together with the model's rule over [`HybridEkf::SUBSTEPS`]
        /// sub-steps; at each sample the Joseph-form update (eqs. 24-26). The covariance is
        /// stored once, as a packed upper triangle.
        ///
        /// Index convention (all filters of this module): [`HybridEkf::step`] at sample `k`
        /// takes the input `u[k-1]` applied since the previous sample and the measurement
        /// `y[k]`.
        #[derive(Clone, Copy, Debug, PartialEq)]
        pub struct HybridEkf {
            x: [#ty; #n_len],
            p: [#ty; #np],
            q: #q_field,
            r: [#ty; #mp],
        }

        impl HybridEkf {
            /// Integration sub-steps per sample, for state and covariance alike.
            pub const SUBSTEPS: u32 = #substeps_lit;

            #[doc = #new_doc]
            #[must_use]
            pub fn new(x0: [#ty; #n_len], p0: &[[#ty; #n_len]; #n_len], #q_param, r: &[[#ty; #m_len]; #m_len]) -> HybridEkf {
                HybridEkf { x: x0, p: #pack_p0, q: #pack_q, r: #pack_r }
            }

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
