//! The typed views of a model with vectors or rotations: `State` and `Input`, a field per
//! declared symbol (an array for a vector or rotation, a number otherwise), converted to and
//! from the flat arrays the model functions and filters take. Each array is what nalgebra
//! builds its own types from: `Vector3::from(state.v)`, and for a rotation stored
//! `[x, y, z, w]`, `Quaternion::from(state.q)` (`interop::to_rotation` with the `nalgebra`
//! feature).

use crate::emit::names::ident;
use crate::model::{GroupRole, Model, Scalar, Symbol};
use proc_macro2::{Literal, TokenStream};
use quote::quote;

/// One field of a typed view: its name, documentation and entries' names.
struct Field {
    name: String,
    docs: Vec<String>,
    entries: Vec<String>,
}

/// The fields of the symbols of `list` (states then parameters, or inputs): a typed
/// group's entries gathered under its name, every other symbol alone.
fn fields(model: &Model, lists: &[(GroupRole, &[Symbol])]) -> Vec<Field> {
    let mut fields = Vec::new();
    for &(role, list) in lists {
        let mut i = 0;
        while i < list.len() {
            let group = model.groups.iter().find(|g| g.role == role && g.first == i);
            let (name, docs, len) = match group {
                Some(g) => (g.name.clone(), g.docs.clone(), g.ty.entry_count()),
                None => (list[i].name.clone(), list[i].docs.clone(), 1),
            };
            let entries = list[i..i + len].iter().map(|s| s.name.clone()).collect();
            fields.push(Field {
                name,
                docs,
                entries,
            });
            i += len;
        }
    }
    fields
}

/// A struct named `type_name` with a field per entry of `fields`, and its conversions
/// to and from the flat array of `len_name` entries.
fn view(
    type_name: &str,
    (len_name, what): (&str, &str),
    fields: &[Field],
    ty: &proc_macro2::Ident,
) -> TokenStream {
    let name = ident(type_name);
    let len = Literal::usize_unsuffixed(fields.iter().map(|f| f.entries.len()).sum());
    let declarations = fields.iter().map(|f| {
        let field = ident(&f.name);
        let docs = &f.docs;
        let count = Literal::usize_unsuffixed(f.entries.len());
        let field_ty = if f.entries.len() == 1 {
            quote! { #ty }
        } else {
            quote! { [#ty; #count] }
        };
        quote! { #(#[doc = #docs])* pub #field: #field_ty, }
    });
    let entries: Vec<_> = fields
        .iter()
        .flat_map(|f| f.entries.iter().map(|e| ident(e)))
        .collect();
    let patterns: Vec<TokenStream> = fields
        .iter()
        .map(|f| {
            let field = ident(&f.name);
            if f.entries.len() == 1 {
                // A number's one entry is named as its field.
                return quote! { #field };
            }
            let names = f.entries.iter().map(|e| ident(e));
            quote! { #field: [#(#names),*] }
        })
        .collect();
    let doc = format!(
        " The {what} by name: a vector's or rotation's entries in one array (a rotation's \
         `[x, y, z, w]`), the same values as the flat array `[S; {len_name}]`."
    );
    quote! {
        #[doc = #doc]
        #[derive(Clone, Copy, Debug, PartialEq)]
        pub struct #name {
            #(#declarations)*
        }

        impl #name {
            /// The named view of the flat array.
            #[must_use]
            pub fn from_array(array: &[#ty; #len]) -> #name {
                let [#(#entries),*] = *array;
                #name { #(#patterns),* }
            }

            /// The flat array, in the model functions' order.
            #[must_use]
            pub fn to_array(&self) -> [#ty; #len] {
                let #name { #(#patterns),* } = *self;
                [#(#entries),*]
            }
        }
    }
}

/// `State` and, where the model has inputs, `Input`, for a model that declares a vector or
/// rotation; nothing otherwise.
pub fn typed_views(model: &Model, scalar: Scalar) -> TokenStream {
    if model.groups.iter().all(|g| g.role == GroupRole::Output) {
        return TokenStream::new();
    }
    let ty = ident(scalar.type_name());
    let state = fields(
        model,
        &[
            (GroupRole::State, &model.states),
            (GroupRole::Param, &model.params),
        ],
    );
    let state = view("State", ("X_LEN", "state vector"), &state, &ty);
    let input = (!model.inputs.is_empty()).then(|| {
        let input = fields(model, &[(GroupRole::Input, &model.inputs)]);
        view("Input", ("U_LEN", "input"), &input, &ty)
    });
    quote! { #state #input }
}
