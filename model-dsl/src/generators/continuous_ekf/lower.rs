//! The continuous-time EKF of seed 004 (Kulkarni and Purwar, "Nonlinear experimental
//! estimation and verification of a MIMO system through EKF", eq. 5): the estimate follows
//! `x' = f + K (z - h)`, `K = P H' R^-1`, and the covariance the Riccati equation
//! `P' = F P + P F' + Q - P H' R^-1 H P`, integrated over each sample with the model's rule
//! and sub-steps; optionally with a prescribed degree of stability `alpha` (Reif et al.,
//! the paper's eq. 26): `F + alpha I` in place of `F` in the Riccati equation.

use crate::emit::code::pack_upper;
use crate::emit::continuous_filter::{method, Kind};
use crate::emit::filter::noise_argument;
use crate::emit::lower::{literal, OpCount};
use crate::emit::names::ident;
use super::spec::ContinuousEkfSpec;
use crate::model::{Model, Scalar};
use crate::symbolic::linalg::packed_len;
use crate::symbolic::ModelGraph;
use proc_macro2::{Literal, TokenStream};
use quote::quote;

/// Generated continuous-time EKF code and its cost.
pub struct ContinuousEkfCode {
    /// The `ContinuousEkf` type and its methods.
    pub tokens: TokenStream,
    /// Arithmetic of one integration sub-step of state and Riccati equation.
    pub substep_ops: OpCount,
    /// Arithmetic of `step` (every sub-step).
    pub step_ops: OpCount,
}

/// The continuous-time EKF of `model` (continuous dynamics) in `scalar`.
pub fn emit_continuous_ekf(
    model: &Model,
    spec: &ContinuousEkfSpec,
    mg: &ModelGraph,
    scalar: Scalar,
) -> ContinuousEkfCode {
    let diagonal = spec.diagonal_noise;
    let kind = Kind::Continuous {
        alpha: spec.alpha.is_some(),
    };
    let (step, step_ops, substep_ops) = method(model, mg, scalar, kind, diagonal);
    let ty = ident(scalar.type_name());
    let (n, m) = (model.state_len(), model.outputs.len());
    let [n_len, m_len, np, mp] =
        [n, m, packed_len(n), packed_len(m)].map(Literal::usize_unsuffixed);
    let (pack_p0, pack_r) = (pack_upper("p0", n), pack_upper("r", m));
    let (q_param, q_field, pack_q) = noise_argument("q", n, diagonal, &ty);
    let accessors = crate::emit::code::estimate_accessors(n, &ty);
    let setters = crate::emit::tuning::noise_setters(n, m, diagonal, &ty);
    let substeps = mg.clone().substep(model).map_or(1, |(_, _, n)| n);
    let substeps_lit = Literal::u32_unsuffixed(substeps);
    let alpha = spec.alpha.map(|a| literal(a, scalar));
    let alpha_field = alpha.as_ref().map(|_| quote! { alpha: #ty, });
    let alpha_init = alpha.as_ref().map(|_| quote! { alpha: Self::ALPHA, });
    let zero = literal(0.0, scalar);
    let alpha_items = alpha.as_ref().map(|value| {
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
    });
    let riccati = if spec.alpha.is_some() {
        "`P' = (F + alpha I) P + P (F + alpha I)' + Q - P H' R^-1 H P` (eq. 26, with a \
         prescribed degree of stability `alpha`, Reif et al.)"
    } else {
        "`P' = F P + P F' + Q - P H' R^-1 H P`"
    };
    let doc = format!(
        " Continuous-time extended Kalman filter of this model (Kulkarni and Purwar, \
         \"Nonlinear experimental estimation and verification of a MIMO system through \
         EKF\", eq. 5): `x' = f(x, u) + K (y - h(x))`, `K = P H' R^-1`, and {riccati}, \
         `F = df/dx`, `H = dh/dx`, integrated over each sample with the model's rule and \
         [`ContinuousEkf::SUBSTEPS`] sub-steps, input and measurement held. `Q` and `R` \
         are spectral densities. The covariance is stored once, as a packed upper triangle."
    );
    let tokens = quote! {
        #[doc = #doc]
        #[derive(Clone, Copy, Debug, PartialEq)]
        pub struct ContinuousEkf {
            x: [#ty; #n_len],
            p: [#ty; #np],
            q: #q_field,
            r: [#ty; #mp],
            #alpha_field
        }

        impl ContinuousEkf {
            /// Integration sub-steps per sample, for state and Riccati equation alike.
            pub const SUBSTEPS: u32 = #substeps_lit;

            /// A filter from the initial estimate `x0` and covariance `p0` and the noise
            /// spectral densities `q` and `r` (symmetric: upper triangles are read).
            #[must_use]
            pub fn new(x0: [#ty; #n_len], p0: &[[#ty; #n_len]; #n_len], #q_param, r: &[[#ty; #m_len]; #m_len]) -> ContinuousEkf {
                ContinuousEkf { x: x0, p: #pack_p0, q: #pack_q, r: #pack_r, #alpha_init }
            }

            #accessors

            #alpha_items

            #setters

            #step
        }
    };
    ContinuousEkfCode {
        tokens,
        substep_ops,
        step_ops,
    }
}
