//! Run-time tuning of the generated filters: setters for the process and measurement noise,
//! which reject a non-finite entry or a matrix that is not a covariance and leave the
//! filter unchanged, and the process noise argument they share with the constructors.

use super::arguments::{covariance_test, reject_non_covariance};
use super::code::pack_upper;
use super::names::ident;
use crate::model::Model;
use crate::symbolic::linalg::packed_len;
use proc_macro2::{Literal, TokenStream};
use quote::quote;

/// `set_process_noise` and `set_measurement_noise` for a filter whose fields `q` (packed,
/// or its `k` variances if `diagonal_q`; `states_doc` says which states they are, see
/// [`ProcessNoise::states_doc`]) and `r` (`m x m`, stored as `stored` says) hold the noise.
pub fn noise_setters(
    (k, states_doc): (usize, &str),
    (m, stored): (usize, &StoredNoise),
    diagonal_q: bool,
    ty: &proc_macro2::Ident,
) -> TokenStream {
    let set_q = process_noise_setter("set_process_noise", "q", (k, states_doc), diagonal_q, ty);
    let set_r = stored_measurement_noise_setter(m, stored, ty);
    quote! { #set_q #set_r }
}

/// How a filter stores a whole measurement noise argument `r`: the fields it fills and
/// their values (`r: pack_upper(r)`, or a sensor's block each), and the test, besides
/// being a covariance, that `r` must pass to be stored so (zero between the sensors).
pub struct StoredNoise {
    /// Each field and its value, an expression of `r`.
    pub fields: Vec<(proc_macro2::Ident, TokenStream)>,
    /// The further test of `r`, if there is one.
    pub condition: Option<TokenStream>,
}

impl StoredNoise {
    /// The whole `r` in the one packed field `r`.
    fn whole(ty: &proc_macro2::Ident) -> StoredNoise {
        StoredNoise {
            fields: vec![(super::names::ident("r"), pack_upper("r", ty))],
            condition: None,
        }
    }
}

/// `fn <method>(&mut self, q) -> Status` replacing the process noise field `field` (packed,
/// or its `n` variances if `diagonal`), documented with `states_doc` after what it does.
pub fn process_noise_setter(
    method: &str,
    field: &str,
    (n, states_doc): (usize, &str),
    diagonal: bool,
    ty: &proc_macro2::Ident,
) -> TokenStream {
    let doc = if diagonal {
        format!(
            " Replaces the process noise variances `{field}` (a diagonal matrix). Rejects a \
             non-finite entry with [`Status::RejectedInput`] and a negative variance with \
             [`Status::InvalidCovariance`], leaving the filter unchanged."
        )
    } else {
        format!(
            " Replaces the process noise covariance `{field}` (its upper triangle is read). \
             Rejects a non-finite entry with [`Status::RejectedInput`], and a matrix that \
             is not symmetric and positive semi-definite with \
             [`Status::InvalidCovariance`], leaving the filter unchanged."
        )
    };
    let doc = format!("{doc}{states_doc}");
    noise_setter((method, "q", field), n, diagonal, &doc, ty)
}

/// `fn set_input_noise(&mut self, qu) -> Status` replacing the field `qu`, the variances
/// per sample (or densities) of the `k` input entries whose noise enters the state
/// (`entries_doc` names them, see [`input_noise_doc`]).
pub fn input_noise_setter(k: usize, entries_doc: &str, ty: &proc_macro2::Ident) -> TokenStream {
    let doc = format!(
        " Replaces the input noise `qu`.{entries_doc} Rejects a non-finite entry \
         with [`Status::RejectedInput`] and a negative entry with \
         [`Status::InvalidCovariance`], leaving the filter unchanged."
    );
    noise_setter(("set_input_noise", "qu", "qu"), k, true, &doc, ty)
}

/// What the input noise `qu` is, for the documentation of what takes or stores it,
/// starting with a space: the variance per sample of each entry of `inputs` (their names,
/// in order), which enters the state through the input Jacobian; or, with a sample
/// interval `dt` (`interval`), the density whose sample over `dt` has the variance `qu / dt`.
pub fn input_noise_doc(inputs: &[&str], interval: Option<&str>) -> String {
    let listed: Vec<String> = inputs.iter().map(|name| format!("`{name}`")).collect();
    let listed = crate::diagnostics::phrase(&listed, "and");
    if let Some(dt) = interval {
        // A white noise of density `s` averaged over `dt` has the variance `s^2 / dt`.
        return format!(
            " `qu` holds the noise densities of the inputs {listed} (in this order, in their \
             units squared times seconds): a sample held over the interval `{dt}` has the \
             variance `qu / {dt}`, and it enters the state through the input Jacobian \
             `G = df/du` as `G diag(qu) G' / {dt}`. A white noise of density `s` (per square \
             root of a hertz) has `qu = s^2`."
        );
    }
    format!(
        " `qu` holds the variances of one sample of the inputs {listed} (in this order, in \
         their units squared), whose noise enters the state through the input Jacobian \
         `G = df/du` as `G diag(qu) G'`. A white noise of density `s` (per square root of a \
         hertz) sampled every `dt` seconds has the variance `s^2 / dt` per sample."
    )
}

/// `fn <method>(&mut self, <param>) -> Status` replacing the noise field `field` (packed,
/// or its `n` variances if `diagonal`), documented by `doc`.
pub fn noise_setter(
    (method, param, field): (&str, &str, &str),
    n: usize,
    diagonal: bool,
    doc: &str,
    ty: &proc_macro2::Ident,
) -> TokenStream {
    let (arg, _, packed) = noise_argument(param, n, diagonal, ty);
    let param_ident = ident(param);
    let finite = if diagonal {
        quote! { stateforge_math::#ty::all_finite(*#param_ident) }
    } else {
        quote! { stateforge_math::#ty::upper_triangle_finite(#param_ident) }
    };
    let body = setter(
        field,
        &packed,
        &finite,
        &covariance_test(param, diagonal, ty),
    );
    let method = ident(method);
    quote! {
        #[doc = #doc]
        pub fn #method(&mut self, #arg) -> Status {
            #body
        }
    }
}

/// `fn set_measurement_noise(&mut self, r) -> Status` for the packed field `r` (`m x m`).
pub fn measurement_noise_setter(m: usize, ty: &proc_macro2::Ident) -> TokenStream {
    stored_measurement_noise_setter(m, &StoredNoise::whole(ty), ty)
}

/// `fn set_measurement_noise(&mut self, r) -> Status` storing `r` (`m x m`) as `stored`
/// says: whole, or each sensor's block apart (rejecting a covariance between two sensors).
fn stored_measurement_noise_setter(
    m: usize,
    stored: &StoredNoise,
    ty: &proc_macro2::Ident,
) -> TokenStream {
    let m_len = Literal::usize_unsuffixed(m);
    let mut tests = vec![covariance_test("r", false, ty)];
    tests.extend(stored.condition.clone());
    let covariance_check = reject_non_covariance(&tests, false);
    let stores = stored
        .fields
        .iter()
        .map(|(field, value)| quote! { self.#field = #value; });
    let independent = stored.condition.as_ref().map(|_| {
        quote! {
            ///
            /// The noise of two sensors is independent: each sensor keeps its own block of
            /// `R` (see its `set_<sensor>_noise`), and an `r` whose entries between two
            /// sensors are not zero is rejected with [`Status::InvalidCovariance`].
        }
    });
    quote! {
        /// Replaces the measurement noise covariance `R` (its upper triangle is read).
        /// Rejects a non-finite entry with [`Status::RejectedInput`], and a matrix that is
        /// not symmetric and positive semi-definite with [`Status::InvalidCovariance`],
        /// leaving the filter unchanged.
        #independent
        pub fn set_measurement_noise(&mut self, r: &[[#ty; #m_len]; #m_len]) -> Status {
            if !stateforge_math::#ty::upper_triangle_finite(r) {
                return Status::RejectedInput;
            }
            #covariance_check
            #(#stores)*
            Status::Ok
        }
    }
}

/// `if !<finite> { reject }`, then the `covariance` test, then `self.field = <packed>;`:
/// the argument's entries are tested finite (`finite`, a library call, whatever the
/// matrix's size) before it is tested a covariance.
fn setter(
    field: &str,
    packed: &TokenStream,
    finite: &TokenStream,
    covariance: &TokenStream,
) -> TokenStream {
    let field = ident(field);
    let covariance_check = reject_non_covariance(core::slice::from_ref(covariance), false);
    quote! {
        if !#finite {
            return Status::RejectedInput;
        }
        #covariance_check
        self.#field = #packed;
        Status::Ok
    }
}

/// The constructor argument, field type and stored value of a process noise covariance:
/// `q: &[[S; n]; n]` packed to its upper triangle, or `q: &[S; n]`, its variances.
pub fn noise_argument(
    name: &str,
    n: usize,
    diagonal: bool,
    ty: &proc_macro2::Ident,
) -> (TokenStream, TokenStream, TokenStream) {
    let arg = ident(name);
    let n_len = proc_macro2::Literal::usize_unsuffixed(n);
    if diagonal {
        (
            quote! { #arg: &[#ty; #n_len] },
            quote! { [#ty; #n_len] },
            quote! { *#arg },
        )
    } else {
        let packed = proc_macro2::Literal::usize_unsuffixed(packed_len(n));
        (
            quote! { #arg: &[[#ty; #n_len]; #n_len] },
            quote! { [#ty; #packed] },
            pack_upper(name, ty),
        )
    }
}

/// The process noise's shape: the states it enters (every state, or those a filter lists
/// with `process_noise_on`, the paper's noise input matrix as a selection) and whether it
/// is diagonal there (stored as its variances) or a full symmetric matrix.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ProcessNoise {
    /// Whether it is diagonal.
    pub diagonal: bool,
    /// The indices in the state vector of the states it enters, in the order its
    /// entries are given; `None` for every state.
    pub on: Option<Vec<usize>>,
}

impl ProcessNoise {
    /// How many states it enters, of `n`.
    pub fn len(&self, n: usize) -> usize {
        self.on.as_ref().map_or(n, Vec::len)
    }

    /// The state its `a`-th row and column are.
    pub fn state(&self, a: usize) -> usize {
        self.on.as_ref().map_or(a, |on| on[a])
    }

    /// The same noise over the tangent space of a state with rotations, where a filter
    /// keeps its covariance: the entries it enters become their tangent coordinates (a
    /// rotation's four, its three). Unchanged for a state without a rotation.
    #[must_use]
    pub fn in_tangent(&self, model: &Model) -> ProcessNoise {
        ProcessNoise {
            diagonal: self.diagonal,
            on: self.on.as_ref().map(|on| model.tangent_indices(on)),
        }
    }

    /// A sentence for the documentation of what takes or stores it: which states it
    /// enters, where it is not every state (empty otherwise), starting with a space.
    pub fn states_doc(&self, model: &Model) -> String {
        let Some(on) = &self.on else {
            return String::new();
        };
        let names = model.tangent_names();
        let listed: Vec<String> = on.iter().map(|&i| format!("`{}`", names[i])).collect();
        let listed = crate::diagnostics::phrase(&listed, "and");
        format!(
            " The process noise enters {listed} only (in this order; zero on the other states)."
        )
    }
}
