//! Reading a generated module's code as its API, after the generated API's conventions
//! (the language reference's "The generated API"): the model's module, an `in_<scalar>`
//! module per further scalar type, inherent `impl` blocks whose public methods pass arrays
//! by reference. One reader of that code for the two tools that read it, each keeping
//! what it needs: the C API (`c_api::reading`: what C can call) and the measuring
//! firmware (`measure::api`: the calls it measures).

use syn::{FnArg, ImplItem, Item};

/// The generated file, parsed.
pub fn parse(code: &str) -> Result<syn::File, String> {
    syn::parse_file(code).map_err(|e| format!("the generated code: {e}"))
}

/// The model's module: the file's first inline module.
pub fn model_module(file: &syn::File) -> Result<&syn::ItemMod, String> {
    file.items
        .iter()
        .find_map(|item| match item {
            Item::Mod(m) if m.content.is_some() => Some(m),
            _ => None,
        })
        .ok_or_else(|| "the generated code holds no module".to_owned())
}

/// An inline module's items.
pub fn inline_items(module: &syn::ItemMod) -> &[Item] {
    module.content.as_ref().map_or(&[], |(_, items)| items)
}

/// The inline modules among `items`.
pub fn modules(items: &[Item]) -> impl Iterator<Item = &syn::ItemMod> {
    items.iter().filter_map(|item| match item {
        Item::Mod(m) if m.content.is_some() => Some(m),
        _ => None,
    })
}

/// Whether an item is `pub`.
pub fn public(vis: &syn::Visibility) -> bool {
    matches!(vis, syn::Visibility::Public(_))
}

/// `GatedEkf` -> `gated_ekf`: a type's name as the generated functions and constants
/// spell it (`GATED_EKF_STEP_CYCLES`, `cantilever_gated_ekf_step`).
pub fn snake(name: &str) -> String {
    let mut out = String::new();
    let mut previous_lower = false;
    for c in name.chars() {
        if c.is_ascii_uppercase() && previous_lower {
            out.push('_');
        }
        previous_lower = c.is_ascii_lowercase() || c.is_ascii_digit();
        out.push(c.to_ascii_lowercase());
    }
    out
}

/// How a method takes `self`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Receiver {
    /// Not at all: an associated function (`new`).
    None,
    /// `&self`.
    Shared,
    /// `&mut self`.
    Mutable,
    /// `self`, by value.
    Value,
}

/// A function's signature as text: its name, doc, receiver, arguments and result.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Signature {
    /// Its name.
    pub name: String,
    /// Its doc comment's lines.
    pub doc: Vec<String>,
    /// How it takes `self`.
    pub receiver: Receiver,
    /// Its arguments, `self` excluded: each name (without the leading `_` of one the code
    /// does not read) and type, as the code writes it (`&[f32; 5]`).
    pub params: Vec<(String, String)>,
    /// Its result's type, as the code writes it; `None` for `()`.
    pub output: Option<String>,
}

/// The signature of `sig`, documented by `attrs`.
pub fn signature(sig: &syn::Signature, attrs: &[syn::Attribute]) -> Signature {
    let mut receiver = Receiver::None;
    let mut params = Vec::new();
    for input in &sig.inputs {
        match input {
            FnArg::Receiver(r) => {
                receiver = match &r.kind {
                    syn::ReceiverKind::Reference(_, _, Some(_)) => Receiver::Mutable,
                    syn::ReceiverKind::Reference(_, _, None) => Receiver::Shared,
                    _ => Receiver::Value,
                };
            }
            FnArg::Typed(t) => {
                let name = match &*t.pat {
                    syn::Pat::Ident(ident) => ident.ident.to_string(),
                    other => quote::quote!(#other).to_string(),
                };
                params.push((name.trim_start_matches('_').to_owned(), type_text(&t.ty)));
            }
        }
    }
    Signature {
        name: sig.ident.to_string(),
        doc: doc(attrs),
        receiver,
        params,
        output: match &sig.output {
            syn::ReturnType::Default => None,
            syn::ReturnType::Type(_, t) => Some(type_text(t)),
        },
    }
}

/// An inherent `impl` block: the type it is for, its public methods and constants.
pub struct Impl<'a> {
    /// The type's name (`Ekf`).
    pub name: String,
    /// Its public methods, in the code's order.
    pub methods: Vec<Signature>,
    /// Its public constants, in the code's order.
    pub constants: Vec<&'a syn::ImplItemConst>,
}

/// The block, if it is an inherent `impl` of a named type.
pub fn inherent_impl(block: &syn::ItemImpl) -> Option<Impl<'_>> {
    let syn::Type::Path(path) = &*block.self_ty else {
        return None;
    };
    if block.trait_.is_some() {
        return None;
    }
    let mut methods = Vec::new();
    let mut constants = Vec::new();
    for item in &block.items {
        match item {
            ImplItem::Fn(f) if public(&f.vis) => methods.push(signature(&f.sig, &f.attrs)),
            ImplItem::Const(c) if public(&c.vis) => constants.push(c),
            _ => {}
        }
    }
    Some(Impl {
        name: path.path.segments.last()?.ident.to_string(),
        methods,
        constants,
    })
}

/// The lines of the `///` comments among `attrs`.
pub fn doc(attrs: &[syn::Attribute]) -> Vec<String> {
    attrs
        .iter()
        .filter_map(|a| match &a.meta {
            syn::Meta::NameValue(nv) if nv.path.is_ident("doc") => match &nv.value {
                syn::Expr::Lit(syn::ExprLit {
                    lit: syn::Lit::Str(s),
                    ..
                }) => Some(s.value()),
                _ => None,
            },
            _ => None,
        })
        .flat_map(|text| {
            // An empty `///` line is a paragraph break: kept.
            let lines: Vec<String> = text
                .lines()
                .map(|l| l.strip_prefix(' ').unwrap_or(l).to_owned())
                .collect();
            if lines.is_empty() {
                vec![String::new()]
            } else {
                lines
            }
        })
        .collect()
}

/// A type as the code writes it, without the blanks `quote` puts around punctuation.
pub fn type_text(ty: &syn::Type) -> String {
    let text = quote::quote!(#ty).to_string();
    text.replace(" ;", ";")
        .replace("& ", "&")
        .replace("[ ", "[")
        .replace(" ]", "]")
        .replace(" <", "<")
        .replace("< ", "<")
        .replace(" >", ">")
        .replace(" ,", ",")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn type_names_spell_their_functions_and_constants() {
        assert_eq!(snake("Ekf"), "ekf");
        assert_eq!(snake("GatedEkf"), "gated_ekf");
        assert_eq!(snake("PolynomialKf"), "polynomial_kf");
        assert_eq!(snake("Ekf2"), "ekf2");
    }

    #[test]
    fn signatures_as_text() {
        let f: syn::ImplItemFn = syn::parse_quote! {
            /// One sample.
            pub fn step(&mut self, _u: &[f32; 1], y: Option<&[[f32; 2]; 3]>) -> Result<[f32; 2], Status> {}
        };
        let s = signature(&f.sig, &f.attrs);
        assert_eq!(s.receiver, Receiver::Mutable);
        assert_eq!(s.doc, ["One sample."]);
        assert_eq!(
            s.params,
            [
                ("u".to_owned(), "&[f32; 1]".to_owned()),
                ("y".to_owned(), "Option<&[[f32; 2]; 3]>".to_owned())
            ]
        );
        assert_eq!(s.output.as_deref(), Some("Result<[f32; 2], Status>"));
    }
}
