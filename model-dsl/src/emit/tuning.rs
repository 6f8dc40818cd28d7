//! Run-time tuning of the generated filters: setters for the process and measurement noise,
//! which reject a non-finite entry and leave the filter unchanged.

use super::code::pack_upper;
use super::names::ident;
use crate::symbolic::linalg::packed_len;
use proc_macro2::{Literal, TokenStream};
use quote::quote;

/// `set_process_noise` and `set_measurement_noise` for a filter whose fields `q` (packed,
/// or its `n` variances if `diagonal_q`) and `r` (packed, `m x m`) hold the noise.
pub fn noise_setters(n: usize, m: usize, diagonal_q: bool, ty: &proc_macro2::Ident) -> TokenStream {
    let n_len = Literal::usize_unsuffixed(n);
    let (q_param, q_packed, q_len) = if diagonal_q {
        (quote! { q: &[#ty; #n_len] }, quote! { *q }, n)
    } else {
        (
            quote! { q: &[[#ty; #n_len]; #n_len] },
            pack_upper("q", n),
            packed_len(n),
        )
    };
    let set_q = setter("q", &q_packed, q_len);
    let m_len = Literal::usize_unsuffixed(m);
    let set_r = setter("r", &pack_upper("r", m), packed_len(m));
    let q_doc = if diagonal_q {
        " Replaces the process noise variances (the diagonal of `Q`). Rejects a non-finite \
         entry with [`Status::RejectedInput`], leaving the filter unchanged."
    } else {
        " Replaces the process noise covariance `Q` (symmetric: its upper triangle is read). \
         Rejects a non-finite entry with [`Status::RejectedInput`], leaving the filter \
         unchanged."
    };
    quote! {
        #[doc = #q_doc]
        pub fn set_process_noise(&mut self, #q_param) -> Status {
            #set_q
        }

        /// Replaces the measurement noise covariance `R` (symmetric: its upper triangle is
        /// read). Rejects a non-finite entry with [`Status::RejectedInput`], leaving the
        /// filter unchanged.
        pub fn set_measurement_noise(&mut self, r: &[[#ty; #m_len]; #m_len]) -> Status {
            #set_r
        }
    }
}

/// `let packed = ..; let [c0, ..] = packed; if !(c0.is_finite() && ..) { reject } self.field = packed;`
fn setter(field: &str, packed: &TokenStream, len: usize) -> TokenStream {
    let field = ident(field);
    let names: Vec<proc_macro2::Ident> = (0..len).map(|k| ident(&format!("c{k}"))).collect();
    quote! {
        let packed = #packed;
        let [#(#names),*] = packed;
        if !(#(#names.is_finite())&&*) {
            return Status::RejectedInput;
        }
        self.#field = packed;
        Status::Ok
    }
}
