//! The items every generated module has whatever the model asks for: the operation-count
//! type, the dimensions and names of the vectors, the `index` module and the constants.

use crate::emit::lower::literal;
use crate::emit::names::{ident, index_const};
use crate::model::{Model, Scalar, Symbol};
use proc_macro2::{Literal, TokenStream};
use quote::quote;

/// The generated twin of [`crate::emit::lower::OpCount`], so generated code needs no support
/// crate; its counts are `usize`, as every count in generated code.
pub fn op_count_struct() -> TokenStream {
    quote! {
        /// Arithmetic one call of a generated function performs, counted from its code.
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        pub struct OpCount {
            /// Additions, subtractions and negations.
            pub add: usize,
            /// Multiplications.
            pub mul: usize,
            /// Divisions.
            pub div: usize,
            /// Library calls (`sin cos sin_cos tan tanh exp ln sqrt abs atan2`, through
            /// `stateforge_math`; a `sin_cos` counts once).
            pub call: usize,
            /// Comparisons of piecewise terms.
            pub compare: usize,
        }
    }
}

/// The lengths and names of `x`, `u`, `y` (and `known`).
pub fn dimensions(model: &Model) -> TokenStream {
    let [x_len, state_len, param_len, u_len, y_len] = [
        model.state_len(),
        model.states.len(),
        model.params.len(),
        model.inputs.len(),
        model.outputs.len(),
    ]
    .map(Literal::usize_unsuffixed);
    let x_names = model.state_names();
    let u_names = model.inputs.iter().map(|s| &s.name);
    let y_names = model.outputs.iter().map(|o| &o.name);
    let known = (!model.known.is_empty()).then(|| {
        let len = Literal::usize_unsuffixed(model.known.len());
        let names = model.known.iter().map(|s| &s.name);
        quote! {
            /// Number of constants known at run time (`known`): the model functions take
            /// them as `known`, the filters and the controller store them.
            pub const KNOWN_LEN: usize = #len;
            /// Names of the entries of `known`, in order.
            pub const KNOWN_NAMES: [&str; #len] = [#(#names),*];
        }
    });
    let tangent = (!model.rotations().is_empty()).then(|| {
        let len = Literal::usize_unsuffixed(model.tangent_len());
        let names = model.tangent_names();
        quote! {
            /// Dimension of the tangent space of `x`, the filters' covariance: `X_LEN` less
            /// one per rotation (four entries, three degrees of freedom).
            pub const TANGENT_LEN: usize = #len;
            /// Names of the tangent space's coordinates, in order: a rotation `q`'s are
            /// `q_theta_x`, `q_theta_y`, `q_theta_z`, its error as a rotation vector in the
            /// earth frame; the other entries' their own.
            pub const TANGENT_NAMES: [&str; #len] = [#(#names),*];
        }
    });
    quote! {
        /// Length of the state vector `x`: the physical states, then the parameters.
        pub const X_LEN: usize = #x_len;
        /// Number of physical states, at the front of `x`.
        pub const STATE_LEN: usize = #state_len;
        /// Number of parameters (augmented random-walk states), at the back of `x`.
        pub const PARAM_LEN: usize = #param_len;
        /// Number of inputs `u`.
        pub const U_LEN: usize = #u_len;
        /// Number of outputs `y`.
        pub const Y_LEN: usize = #y_len;
        /// Names of the entries of `x`, in order.
        pub const X_NAMES: [&str; #x_len] = [#(#x_names),*];
        /// Names of the entries of `u`, in order.
        pub const U_NAMES: [&str; #u_len] = [#(#u_names),*];
        /// Names of the entries of `y`, in order.
        pub const Y_NAMES: [&str; #y_len] = [#(#y_names),*];
        #known
        #tangent
    }
}

/// The `index` module: the position of every named entry, with its docs.
pub fn index_module(model: &Model) -> TokenStream {
    let entry = |symbol: &Symbol, position: usize, vector: &str| {
        let position = Literal::usize_unsuffixed(position);
        let name = index_const(&symbol.name);
        let docs = &symbol.docs;
        let place = format!(" Position of `{}` in `{vector}`.", symbol.name);
        let separator = (!docs.is_empty()).then(|| quote! { #[doc = ""] });
        quote! {
            #(#[doc = #docs])*
            #separator
            #[doc = #place]
            pub const #name: usize = #position;
        }
    };
    let states = model
        .states
        .iter()
        .chain(&model.params)
        .enumerate()
        .map(|(i, s)| entry(s, i, "x"));
    let inputs = model
        .inputs
        .iter()
        .enumerate()
        .map(|(i, s)| entry(s, i, "u"));
    let outputs = model.outputs.iter().enumerate().map(|(i, o)| {
        let symbol = Symbol {
            docs: o.docs.clone(),
            name: o.name.clone(),
        };
        entry(&symbol, i, "y")
    });
    let known = model
        .known
        .iter()
        .enumerate()
        .map(|(i, s)| entry(s, i, "known"));
    quote! {
        /// Positions of the named entries of `x`, `u` and `y`, with their documentation.
        pub mod index {
            #(#states)*
            #(#inputs)*
            #(#outputs)*
            #(#known)*
        }
    }
}

/// The model's constants as typed literals.
pub fn constants(model: &Model, scalar: Scalar) -> TokenStream {
    let ty = ident(scalar.type_name());
    let items = model.constants.iter().map(|c| {
        let name = ident(&c.name);
        let value = literal(c.value, scalar);
        let fallback = format!(" Model constant `{}`.", c.name);
        let docs = if c.docs.is_empty() {
            vec![fallback]
        } else {
            c.docs.clone()
        };
        quote! {
            #(#[doc = #docs])*
            pub const #name: #ty = #value;
        }
    });
    quote! { #(#items)* }
}
