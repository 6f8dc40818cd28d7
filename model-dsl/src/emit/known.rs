//! The constants known only at run time (`known`), as a filter or controller holds them:
//! a field, a constructor argument, a setter and a getter. Each method reads the entries
//! it uses from the field, so a model without `known` generates exactly what it did.

use super::arguments::Arguments;
use super::names::ident;
use crate::model::Model;
use proc_macro2::{Literal, TokenStream};
use quote::quote;

/// What a generated type holding the model's known constants adds to its definition.
#[derive(Default)]
pub struct KnownItems {
    /// `known: [S; KNOWN_LEN],` in the struct.
    pub field: TokenStream,
    /// `known()` and `set_known(..)`.
    pub methods: TokenStream,
    /// The constants' names and the scalar type, if the model declares any.
    argument: Option<(Vec<proc_macro2::Ident>, proc_macro2::Ident)>,
}

impl KnownItems {
    /// Adds `known: &[S; KNOWN_LEN]` to a constructor's `arguments` (each entry bound to
    /// its constant's name and checked finite, as every argument is), and returns the
    /// field's initialisation, `known: [..],`; nothing if the model declares no `known`.
    pub fn argument(&self, arguments: &mut Arguments) -> TokenStream {
        let Some((names, ty)) = &self.argument else {
            return TokenStream::new();
        };
        arguments.array("known", names.clone(), ty);
        quote! { known: [#(#names),*], }
    }
}

/// The items for `model` in scalar type `ty`; empty if the model declares no `known`.
pub fn known_items(model: &Model, ty: &proc_macro2::Ident) -> KnownItems {
    if model.known.is_empty() {
        return KnownItems::default();
    }
    let len = Literal::usize_unsuffixed(model.known.len());
    let names: Vec<_> = model.known.iter().map(|s| ident(&s.name)).collect();
    KnownItems {
        field: quote! { known: [#ty; #len], },
        methods: quote! {
            /// The constants known at run time (`KNOWN_NAMES`, in that order) the model
            /// functions are evaluated with.
            #[must_use]
            pub fn known(&self) -> [#ty; #len] {
                self.known
            }

            /// Replaces the constants known at run time (a new calibration), keeping the
            /// estimate. Rejects a non-finite entry, leaving them as they were.
            pub fn set_known(&mut self, known: &[#ty; #len]) -> Status {
                let [#(#names),*] = *known;
                if !(#(#names.is_finite())&&*) {
                    return Status::RejectedInput;
                }
                self.known = *known;
                Status::Ok
            }
        },
        argument: Some((names, ty.clone())),
    }
}
