//! The model compiler: a symbolic model of a dynamic system in, straight-line,
//! allocation-free Rust out.
//!
//! The flow runs one way: tokens -> [`ast::ModelDecl`] ->
//! [`check`] -> [`model::Model`] -> [`symbolic`] graph -> [`emit`] -> tokens.
//! [`expand`] is the whole pipeline for the `model!` macro; tests call it directly.
//!
//! This crate is what the `model!` macro (`codegen-macros`) builds, so it depends on
//! `syn`, `quote`, `proc-macro2` and `indexmap` only. Model files (TOML), formatting and
//! the command-line tool are in `model-codegen`, which produces a [`ast::ModelDecl`]
//! through the same [`check`].

#![forbid(unsafe_code)]

pub mod ast;
pub mod check;
mod check_controllers;
mod check_designs;
pub mod diagnostics;
pub mod emit;
pub mod front;
pub mod generators;
pub mod model;
pub mod numerics;
pub mod symbolic;

use proc_macro2::TokenStream;

/// Parses and checks the body of a `model!` invocation into the model IR.
pub fn parse_model(tokens: TokenStream) -> syn::Result<model::Model> {
    let (decl, diag) = front::macro_syntax::parse_model(tokens)?;
    check::check(&decl, diag)
}

/// The `model!` macro: the body of an invocation in, the generated module out.
pub fn expand(tokens: TokenStream) -> syn::Result<TokenStream> {
    expand_with(tokens, &emit::Options::default())
}

/// [`expand`], with the generated module's extras (`codegen-macros`' features).
pub fn expand_with(tokens: TokenStream, options: &emit::Options) -> syn::Result<TokenStream> {
    let model = parse_model(tokens)?;
    emit::emit_model_with(&model, options)
}

/// Parses and checks Rust source holding one `model! { .. }` invocation (a demo model
/// file) into the model IR.
pub fn parse_macro_source(source: &str) -> syn::Result<model::Model> {
    // Not trimmed: spans then give the file's own lines and columns.
    let invocation: syn::Macro = syn::parse_str(source)?;
    parse_model(invocation.tokens)
}

/// Expands Rust source holding one `model! { .. }` invocation (a demo model file).
pub fn expand_macro_source(source: &str) -> syn::Result<TokenStream> {
    emit::emit_model(&parse_macro_source(source)?)
}
