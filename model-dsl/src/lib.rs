//! The model compiler: a symbolic model of a dynamic system in, straight-line,
//! allocation-free Rust out.
//!
//! The flow runs one way: tokens -> [`ast::ModelDecl`] ->
//! [`check`] -> [`model::Model`] and the [`generators`] it asks for -> [`symbolic`] graph
//! -> lowering ([`emit`] stages, each generator's own) -> tokens, assembled by [`pipeline`].
//! [`expand`] is the whole pipeline for the `model!` macro; tests call it directly.
//!
//! This crate (`stateforge-compiler`) is what the `model!` macro (`stateforge`) builds, so it depends on
//! `syn`, `quote`, `proc-macro2` and `indexmap` only. Model files (TOML), formatting and
//! the command-line tool are in `stateforge-cli`, which produces a [`ast::ModelDecl`]
//! through the same [`check`].

#![forbid(unsafe_code)]
// Functions fit on a screen: 80 lines of code (`clippy.toml`).
#![warn(clippy::too_many_lines)]

pub mod ast;
pub mod check;
pub mod diagnostics;
pub mod emit;
pub mod fast_hash;
pub mod front;
pub mod generators;
pub mod geometry;
pub mod model;
pub mod numerics;
pub mod pipeline;
pub mod scope;
pub mod symbolic;
pub mod timing;

use proc_macro2::TokenStream;

/// Parses and checks the body of a `model!` invocation into the model IR.
pub fn parse_model(tokens: TokenStream) -> syn::Result<check::Checked> {
    let (decl, diag) = front::macro_syntax::parse_model(tokens)?;
    check::check(&decl, diag)
}

/// The `model!` macro: the body of an invocation in, the generated module out.
pub fn expand(tokens: TokenStream) -> syn::Result<TokenStream> {
    expand_with(tokens, &pipeline::Options::default())
}

/// [`expand`], with the generated module's extras (the `stateforge` crate's features).
pub fn expand_with(tokens: TokenStream, options: &pipeline::Options) -> syn::Result<TokenStream> {
    expand_with_warnings(tokens, options).map(|(module, _)| module)
}

/// [`expand_with`], and the warnings about the model (declarations nothing reads), for the
/// macro to place under their tokens ([`diagnostics::Warning::to_tokens`]).
pub fn expand_with_warnings(
    tokens: TokenStream,
    options: &pipeline::Options,
) -> syn::Result<(TokenStream, Vec<diagnostics::Warning>)> {
    emit_with_warnings(parse_model(tokens)?, options)
}

/// The module generated for `model`, and its warnings.
fn emit_with_warnings(
    model: check::Checked,
    options: &pipeline::Options,
) -> syn::Result<(TokenStream, Vec<diagnostics::Warning>)> {
    let module = pipeline::emit_model_with(&model, options)?;
    Ok((module, model.warnings))
}

/// Parses and checks a Rust source file holding one `model! { .. }` invocation (a demo
/// model, a crate's `lib.rs` with its `//!` docs, attributes and other items) into the
/// model IR ([`front::source_file::model_invocation`]).
pub fn parse_macro_source(source: &str) -> syn::Result<check::Checked> {
    parse_model(front::source_file::model_invocation(source)?)
}

/// Expands a Rust source file holding one `model! { .. }` invocation (a demo model, a
/// crate's `lib.rs`).
pub fn expand_macro_source(source: &str) -> syn::Result<TokenStream> {
    expand_macro_source_with_warnings(source).map(|(module, _)| module)
}

/// [`expand_macro_source`], and the warnings about the model, for a tool to print.
pub fn expand_macro_source_with_warnings(
    source: &str,
) -> syn::Result<(TokenStream, Vec<diagnostics::Warning>)> {
    emit_with_warnings(parse_macro_source(source)?, &pipeline::Options::default())
}
