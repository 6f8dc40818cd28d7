//! Prints the Rust that `model-dsl` generates for a model file, formatted, so it can be
//! reviewed or vendored.
//!
//! ```text
//! model-codegen models/cantilever.toml > src/cantilever.rs
//! model-codegen generated-demo/models/cantilever.rs
//! ```

#![forbid(unsafe_code)]

use clap::Parser;
use std::path::PathBuf;
use std::process::ExitCode;

/// Generate Rust model functions and Jacobians from a model file.
#[derive(Parser)]
#[command(version, about)]
struct Args {
    /// A TOML model file, or a Rust file holding one `model! { .. }` invocation.
    model: PathBuf,
}

fn main() -> ExitCode {
    let args = Args::parse();
    let source = match std::fs::read_to_string(&args.model) {
        Ok(source) => source,
        Err(e) => {
            eprintln!("error: cannot read {}: {e}", args.model.display());
            return ExitCode::FAILURE;
        }
    };
    let is_toml = args.model.extension().is_some_and(|e| e == "toml");
    let generated = if is_toml {
        model_dsl::expand_model_file(&source)
    } else {
        model_dsl::expand_macro_source(&source)
    };
    match generated.and_then(model_dsl::format) {
        Ok(code) => {
            print!("{code}");
            ExitCode::SUCCESS
        }
        Err(errors) => {
            for error in errors {
                eprint!("{}", report(&args.model, &source, &error));
            }
            ExitCode::FAILURE
        }
    }
}

/// `file:line:column: error: message`, then the offending line with a caret under the
/// column, as rustc prints them; just `file: error: message` where the error has no place.
fn report(path: &std::path::Path, source: &str, error: &syn::Error) -> String {
    let start = error.span().start();
    let Some(line) = start
        .line
        .checked_sub(1)
        .and_then(|i| source.lines().nth(i))
    else {
        // syn places "unexpected end of input" nowhere: it is the end of the model.
        let place = if error.to_string().contains("end of input") {
            " (at the end of the model's braces)"
        } else {
            ""
        };
        return format!("{}: error: {error}{place}\n", path.display());
    };
    let gutter = " ".repeat(start.line.to_string().len());
    format!(
        "{}:{}:{}: error: {error}\n{gutter} |\n{} | {line}\n{gutter} | {}^\n",
        path.display(),
        start.line,
        start.column + 1,
        start.line,
        " ".repeat(start.column)
    )
}
