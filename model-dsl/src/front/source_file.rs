//! A Rust source file holding a `model!` invocation (a crate's `lib.rs`, a demo model):
//! the invocation's tokens, wherever it stands among the file's items.

use proc_macro2::{Span, TokenStream};
use syn::{Item, Macro, Stmt};

/// What the tool reads, for the errors that find no model or more than one.
const EXPECTED: &str = "the file is read as Rust source holding one `model! { .. }` \
                        invocation (`stateforge::model! { pub mod m { .. } }`), among any \
                        other items, at the top level, in an inline `mod` or in a function";

/// The body of the one `model!` invocation in `source`: a whole Rust file, with its inner
/// doc comments and attributes (`//!`, `#![no_std]`), `use` items and other items around
/// it. An error if the file is not Rust, holds no invocation or more than one.
pub fn model_invocation(source: &str) -> syn::Result<TokenStream> {
    // Not trimmed: spans then give the file's own lines and columns.
    let file = syn::parse_file(source)
        .map_err(|e| syn::Error::new(e.span(), format!("{e}: {EXPECTED}")))?;
    let mut found = Vec::new();
    invocations(&file.items, &mut found);
    match found.as_slice() {
        [] => Err(syn::Error::new(
            Span::call_site(),
            format!("no `model!` invocation found: {EXPECTED}"),
        )),
        [only] => Ok(only.tokens.clone()),
        [_, second, ..] => Err(syn::Error::new(
            path_span(second),
            format!(
                "a second `model!` invocation: the tool generates one model per file, so put \
                 each in a file of its own ({} found)",
                found.len()
            ),
        )),
    }
}

/// The `model!` invocations among `items`, in inline modules and function bodies too.
fn invocations<'a>(items: &'a [Item], found: &mut Vec<&'a Macro>) {
    for item in items {
        match item {
            Item::Macro(item) if is_model(&item.mac) => found.push(&item.mac),
            Item::Mod(module) => {
                if let Some((_, items)) = &module.content {
                    invocations(items, found);
                }
            }
            Item::Fn(function) => {
                for stmt in &function.block.stmts {
                    match stmt {
                        Stmt::Item(item) => invocations(std::slice::from_ref(item), found),
                        Stmt::Macro(stmt) if is_model(&stmt.mac) => found.push(&stmt.mac),
                        _ => {}
                    }
                }
            }
            _ => {}
        }
    }
}

/// Whether `mac` calls `model!`, by any path (`model!`, `stateforge::model!`).
fn is_model(mac: &Macro) -> bool {
    mac.path.segments.last().is_some_and(|s| s.ident == "model")
}

/// Where the invocation's macro name stands.
fn path_span(mac: &Macro) -> Span {
    mac.path
        .segments
        .last()
        .map_or_else(Span::call_site, |s| s.ident.span())
}
