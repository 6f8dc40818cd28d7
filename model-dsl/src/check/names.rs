//! The rules for the names a model declares: each is a plain Rust identifier, declared
//! once, not one the generated module uses, and not differing from another only in case.

use crate::ast::{ModelDecl, Name};
use crate::diagnostics::Diagnostics;
use crate::scope::{Binding, Scope};

/// Items the generated module defines whatever the model asks for; a constant (also an
/// item) may not take their names, nor those of the generators' items
/// ([`crate::generators::Description::items`]).
const MODEL_ITEMS: &[&str] = &[
    "f",
    "F_SUBSTEPS",
    "F_SUBSTEP_PAIRS",
    "h",
    "jacobian_f_wrt_x",
    "jacobian_f_wrt_u",
    "jacobian_h_wrt_x",
    "index",
    "in_f32",
    "in_f64",
    "OpCount",
    "X_LEN",
    "STATE_LEN",
    "PARAM_LEN",
    "U_LEN",
    "Y_LEN",
    "X_NAMES",
    "U_NAMES",
    "Y_NAMES",
    "KNOWN_LEN",
    "KNOWN_NAMES",
    "TANGENT_LEN",
    "State",
    "Input",
    "TANGENT_NAMES",
    "Status",
];

/// Whether the generated module defines, or may define, an item named `text`.
pub fn generated_item(text: &str) -> bool {
    MODEL_ITEMS.contains(&text)
        || crate::generators::REGISTRY
            .iter()
            .any(|kind| kind.description().items.contains(&text))
}

pub(super) fn declare(scope: &mut Scope, name: &Name, binding: Binding, diag: &mut Diagnostics) {
    if scope.contains_key(&name.text) || scope.failed.contains(&name.text) {
        duplicate_error(diag, name);
        return;
    }
    check_name_allowed(name, matches!(binding, Binding::Const(_)), diag);
    scope.names.insert(name.text.clone(), (binding, name.span));
}

pub(super) fn duplicate_error(diag: &mut Diagnostics, name: &Name) {
    diag.error(
        name.span,
        format!(
            "`{}` is declared twice: every constant, symbol and output needs its own name",
            name.text
        ),
    );
}

pub(super) fn check_name_allowed(name: &Name, is_item: bool, diag: &mut Diagnostics) {
    let generated = generated_item(&name.text)
        || name.text.ends_with("_OPS")
        || name.text.ends_with("_NONZERO");
    if name.text == "t" {
        diag.error(name.span, "`t` is the time in seconds: choose another name");
    } else if is_item && generated {
        diag.error(
            name.span,
            format!(
                "`{}` is a name the generated module uses: choose another",
                name.text
            ),
        );
    } else {
        check_identifier(name, diag);
    }
}

/// A name that becomes an identifier of the generated code must be a plain Rust
/// identifier: model files can hold any text, and a raw identifier (`r#type`) would need
/// its `r#` at every use, in every name derived from it (`index::R#TYPE` is none).
pub(super) fn check_identifier(name: &Name, diag: &mut Diagnostics) {
    if let Some(keyword) = name.text.strip_prefix("r#") {
        diag.error(
            name.span,
            format!("raw identifiers are not supported: choose a name that is not the keyword `{keyword}`"),
        );
    } else if !is_identifier(&name.text) {
        diag.error(
            name.span,
            format!(
                "`{}` is not a Rust identifier: use letters, digits and `_`, starting with a \
                 letter, and no keyword",
                name.text
            ),
        );
    }
}

/// Whether `text` is one Rust identifier, character by character (a parser would skip a
/// trailing comment, `x // y`), and not a keyword.
fn is_identifier(text: &str) -> bool {
    let mut chars = text.chars();
    let starts = chars
        .next()
        .is_some_and(|c| c == '_' || unicode_ident::is_xid_start(c));
    starts
        && chars.all(unicode_ident::is_xid_continue)
        && syn::parse_str::<syn::Ident>(text).is_ok()
}

/// Names that differ only in case would give the same constant in the generated `index`
/// module (`x2` and `X2` are both `index::X2`).
pub(super) fn check_case_collisions(decl: &ModelDecl, diag: &mut Diagnostics) {
    let mut seen: std::collections::HashMap<String, &Name> = std::collections::HashMap::new();
    let names = decl.symbols.iter().map(|s| &s.name);
    for name in names.chain(decl.outputs.iter().map(|o| &o.name)) {
        match seen.get(&name.text.to_uppercase()) {
            Some(first) if first.text != name.text => diag.error(
                name.span,
                format!(
                    "`{}` and `{}` differ only in case: both would be `index::{}` in the \
                     generated code; choose names that differ in their letters",
                    name.text,
                    first.text,
                    name.text.to_uppercase()
                ),
            ),
            _ => {
                seen.insert(name.text.to_uppercase(), name);
            }
        }
    }
}
