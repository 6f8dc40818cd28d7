//! Vendoring the code of the `model!` macro: the TOML model-file front end, formatting of
//! generated code, and the `stateforge-codegen` command-line tool built on them.
//!
//! A model file reads into the same [`stateforge_compiler::ast::ModelDecl`] as the macro's
//! tokens and goes through the same checks and emitters, so both give the same module.
//! This crate carries what the macro does not need (`serde`, `toml`, `meval`,
//! `prettyplease`, `clap`), which keeps `stateforge` light to build, and [`measure`]: a
//! model's calls run on an emulated Cortex-M4F (`stateforge-codegen measure`).

#![forbid(unsafe_code)]

pub mod c_api;
mod expression_dots;
mod expression_places;
mod expression_text;
mod generated_api;
mod layout;
pub mod measure;
pub mod meval_text;
pub mod model_file;
mod toml_hints;

use proc_macro2::TokenStream;
use stateforge_compiler::check::Checked;
use stateforge_compiler::diagnostics::Warning;

/// Formats generated tokens as a Rust source file with `prettyplease` (for snapshots; the
/// tool then passes the file through [`rustfmt`]). The text is `prettyplease::unparse`'s
/// of the whole file, laid out one item at a time so that a large module's syntax tree is
/// never held whole.
pub fn format(tokens: TokenStream) -> syn::Result<String> {
    layout::format(tokens)
}

/// Formats a Rust source file with `rustfmt` (the `RUSTFMT` variable, else `rustfmt` on
/// the path; edition 2021, and the `rustfmt.toml` of the current directory if there is
/// one), as `cargo fmt` will format it once vendored. `prettyplease` alone does not: its
/// layout differs from rustfmt's, and a vendored file would fail `cargo fmt --check`.
/// An error if rustfmt cannot be run or refuses the file.
pub fn rustfmt(code: &str) -> Result<String, String> {
    use std::io::Write;
    use std::process::{Command, Stdio};
    let program = std::env::var_os("RUSTFMT").unwrap_or_else(|| "rustfmt".into());
    let mut child = Command::new(&program)
        .args(["--edition", "2021", "--emit", "stdout"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| format!("cannot run {}: {e}", program.to_string_lossy()))?;
    // Written from another thread: rustfmt may fill its output pipe before reading all.
    let mut stdin = child.stdin.take().ok_or("rustfmt has no standard input")?;
    let input = code.to_owned();
    let writer = std::thread::spawn(move || stdin.write_all(input.as_bytes()));
    let output = child
        .wait_with_output()
        .map_err(|e| format!("rustfmt: {e}"))?;
    let written = writer
        .join()
        .map_err(|_| "rustfmt: input thread panicked")?;
    match (output.status.success(), written) {
        (true, Ok(())) => String::from_utf8(output.stdout).map_err(|e| format!("rustfmt: {e}")),
        (_, Err(e)) => Err(format!("rustfmt: {e}")),
        (false, _) => Err(format!(
            "rustfmt failed: {}",
            String::from_utf8_lossy(&output.stderr).trim()
        )),
    }
}

/// The `stateforge-math` the generated code calls: this checkout's, when the tool was
/// built from one (`cargo install --path model-codegen`, a test), else the release of the
/// tool's own version.
pub fn math_dependency() -> String {
    let checkout = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../stateforge-math");
    match checkout.join("Cargo.toml").exists() {
        true => format!(
            "{{ path = {:?} }}",
            checkout.canonicalize().unwrap_or(checkout).display()
        ),
        false => {
            let version = env!("CARGO_PKG_VERSION");
            let minor = version.rsplit_once('.').map_or(version, |(m, _)| m);
            format!("\"{minor}\"")
        }
    }
}

/// Reads and checks a TOML model file into the model IR and the generators it asks for.
/// The checks are the macro's; their hints are rewritten in the model file's syntax.
pub fn parse_model_file(source: &str) -> syn::Result<Checked> {
    let (decl, diag) = model_file::parse_model_file(source)?;
    let mut checked =
        stateforge_compiler::check::check(&decl, diag).map_err(toml_hints::in_toml_terms)?;
    checked.warnings = toml_hints::warnings_in_toml_terms(checked.warnings);
    Ok(checked)
}

/// Expands a TOML model file: the same module the macro would generate.
pub fn expand_model_file(source: &str) -> syn::Result<TokenStream> {
    expand_model_file_with_warnings(source).map(|(module, _)| module)
}

/// [`expand_model_file`], and the warnings about the model (declarations nothing reads),
/// their hints in the model file's syntax.
pub fn expand_model_file_with_warnings(source: &str) -> syn::Result<(TokenStream, Vec<Warning>)> {
    let checked = parse_model_file(source)?;
    let module =
        stateforge_compiler::pipeline::emit_model(&checked).map_err(toml_hints::in_toml_terms)?;
    Ok((module, checked.warnings))
}

/// A model's checked IR and its generated module, from a TOML model file (`is_toml`, its
/// errors' hints in the file's syntax) or a Rust source holding one `model! { .. }`.
pub fn checked_and_module(source: &str, is_toml: bool) -> syn::Result<(Checked, TokenStream)> {
    if is_toml {
        let checked = parse_model_file(source)?;
        let module = stateforge_compiler::pipeline::emit_model(&checked)
            .map_err(toml_hints::in_toml_terms)?;
        Ok((checked, module))
    } else {
        let checked = stateforge_compiler::parse_macro_source(source)?;
        let module = stateforge_compiler::pipeline::emit_model(&checked)?;
        Ok((checked, module))
    }
}
