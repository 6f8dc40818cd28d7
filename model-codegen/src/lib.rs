//! Vendoring the code of the `model!` macro: the TOML model-file front end, formatting of
//! generated code, and the `model-codegen` command-line tool built on them.
//!
//! A model file reads into the same [`model_dsl::ast::ModelDecl`] as the macro's tokens and
//! goes through the same checks and emitters, so both give the same module. This crate
//! carries what the macro does not need (`serde`, `toml`, `meval`, `prettyplease`, `clap`),
//! which keeps `codegen-macros` light to build.

#![forbid(unsafe_code)]

pub mod meval_text;
pub mod model_file;

use model_dsl::model::Model;
use proc_macro2::TokenStream;

/// Formats generated tokens as a Rust source file (for snapshots and the CLI).
pub fn format(tokens: TokenStream) -> syn::Result<String> {
    let file: syn::File = syn::parse2(tokens)?;
    Ok(prettyplease::unparse(&file))
}

/// Reads and checks a TOML model file into the model IR.
pub fn parse_model_file(source: &str) -> syn::Result<Model> {
    let (decl, diag) = model_file::parse_model_file(source)?;
    model_dsl::check::check(&decl, diag)
}

/// Expands a TOML model file: the same module the macro would generate.
pub fn expand_model_file(source: &str) -> syn::Result<TokenStream> {
    model_dsl::emit::emit_model(&parse_model_file(source)?)
}
