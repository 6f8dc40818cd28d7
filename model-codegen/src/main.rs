//! Prints the Rust that `stateforge-compiler` generates for a model file, formatted, so it
//! can be reviewed or vendored. The first line names the tool, its version and the model
//! file.
//!
//! ```text
//! stateforge-codegen models/cantilever.toml -o src/cantilever.rs
//! stateforge-codegen generated-demo/models/cantilever.rs
//! stateforge-codegen measure models/cantilever.toml
//! stateforge-codegen c-api models/cantilever.toml --out-dir cantilever-c
//! ```
//!
//! `measure` runs the model's generated calls on an emulated Cortex-M4F and prints what
//! each costs (`stateforge_cli::measure`); `c-api` writes a crate of `extern "C"`
//! functions and their header for a C program (`stateforge_cli::c_api`).

#![forbid(unsafe_code)]

use clap::Parser;
use stateforge_compiler::check::Checked;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// The tool's own allocator (the compiler library picks none): laying out a large model
/// allocates and frees millions of small syntax-tree nodes, where the system allocator
/// spent a third of the time (the 64-sub-step piecewise beam: about 8 s of CPU with it,
/// about 4 s with mimalloc; `cargo run --release -p tests --example build_scale --
/// --compiler`).
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// Generate the Rust code of a model (what the `model!` macro generates), formatted, to
/// vendor or review; or measure its calls on an emulated Cortex-M4F (`measure`).
#[derive(Parser)]
#[command(
    name = env!("CARGO_BIN_NAME"),
    version,
    args_conflicts_with_subcommands = true,
    subcommand_negates_reqs = true
)]
struct Args {
    #[command(subcommand)]
    command: Option<Command>,
    /// A TOML model file, or a Rust file holding one `model! { .. }` invocation.
    #[arg(required = true)]
    model: Option<PathBuf>,
    /// Write the code to FILE (replaced only if generation succeeds) instead of standard
    /// output.
    #[arg(short, long, value_name = "FILE")]
    output: Option<PathBuf>,
    /// How to lay out the code.
    #[arg(long, value_enum, default_value_t = Formatter::Rustfmt)]
    formatter: Formatter,
}

#[derive(clap::Subcommand)]
enum Command {
    /// Measure the model's calls on an emulated Cortex-M4F (QEMU).
    ///
    /// Builds the model's f32 code into a firmware that runs each generated call (`predict`,
    /// each sensor's update, `step`, `solve`, ..) on the model's own simulated run, and
    /// prints per call its instructions, its traced cycles beside the static estimate
    /// (`*_CYCLES`), its stack and its code size. Installs the thumbv7em-none-eabihf target,
    /// and with apt-get QEMU and the ARM binutils, when they are missing.
    Measure(Measure),
    /// Write a C API for the model's filters and controllers: a companion crate.
    ///
    /// DIR receives a crate that builds into a static library (`lib<model>_c.a`, `no_std`,
    /// `panic = "abort"`) of `extern "C"` functions, one per method of each generated type,
    /// and the header `include/<model>.h`. Build it with `cargo build --release` (add
    /// `--target thumbv7em-none-eabihf` for a Cortex-M4F) and link the library into the C
    /// program.
    CApi(CApi),
}

#[derive(clap::Args)]
struct CApi {
    /// A TOML model file, or a Rust file holding one `model! { .. }` invocation.
    model: PathBuf,
    /// The directory of the companion crate (created if missing; its files are rewritten
    /// where they changed).
    #[arg(short, long, value_name = "DIR")]
    out_dir: PathBuf,
}

#[derive(clap::Args)]
struct Measure {
    /// A TOML model file, or a Rust file holding one `model! { .. }` invocation.
    model: PathBuf,
    /// How many samples of the model's simulated run each call takes (1 to 1000).
    #[arg(long, default_value_t = 100)]
    samples: usize,
    /// Where to write and build the measuring firmware [default: a directory named
    /// after the model in the system's temporary directory].
    #[arg(long, value_name = "DIR")]
    work_dir: Option<PathBuf>,
}

/// The layout of the printed code.
#[derive(Clone, Copy, clap::ValueEnum)]
enum Formatter {
    /// What `cargo fmt` gives, so a vendored file passes `cargo fmt --check` (runs
    /// `RUSTFMT`, else `rustfmt` on the path).
    Rustfmt,
    /// `prettyplease`'s layout, without rustfmt.
    Prettyplease,
}

fn main() -> ExitCode {
    let args = Args::parse();
    match (args.command, args.model) {
        (Some(Command::Measure(measure)), _) => run_measure(&measure),
        (Some(Command::CApi(c_api)), _) => write_c_api(&c_api),
        (None, Some(model)) => generate(&model, args.output.as_deref(), args.formatter),
        (None, None) => {
            eprintln!("error: give a model file (see --help)");
            ExitCode::FAILURE
        }
    }
}

/// The model in `path`, checked, and its generated code laid out by `prettyplease`; its
/// warnings printed. `None` after printing its errors (or why it cannot be read).
fn load(path: &Path) -> Option<(Checked, String)> {
    let source = match std::fs::read_to_string(path) {
        Ok(source) => source,
        Err(e) => {
            eprintln!("error: cannot read {}: {e}", path.display());
            return None;
        }
    };
    let is_toml = path.extension().is_some_and(|e| e == "toml");
    let generated =
        stateforge_cli::checked_and_module(&source, is_toml).and_then(|(checked, module)| {
            for warning in &checked.warnings {
                let message = &warning.message;
                eprint!(
                    "{}",
                    report(path, &source, "warning", warning.span, message)
                );
            }
            stateforge_cli::format(module).map(|code| (checked, code))
        });
    match generated {
        Ok(generated) => Some(generated),
        Err(errors) => {
            for error in errors {
                let message = error.to_string();
                eprint!("{}", report(path, &source, "error", error.span(), &message));
            }
            None
        }
    }
}

/// `stateforge-codegen <MODEL>`: the code, to standard output or `output`.
fn generate(model: &Path, output: Option<&Path>, formatter: Formatter) -> ExitCode {
    let Some((_, code)) = load(model) else {
        return ExitCode::FAILURE;
    };
    let code = format!("{}{code}", header(model));
    let code = match formatter {
        Formatter::Prettyplease => code,
        Formatter::Rustfmt => match stateforge_cli::rustfmt(&code) {
            Ok(code) => code,
            Err(e) => {
                eprintln!("error: {e} (`--formatter prettyplease` does without)");
                return ExitCode::FAILURE;
            }
        },
    };
    match output {
        None => print_code(&code),
        Some(path) => {
            if let Err(e) = std::fs::write(path, code) {
                eprintln!("error: cannot write {}: {e}", path.display());
                return ExitCode::FAILURE;
            }
            ExitCode::SUCCESS
        }
    }
}

/// `stateforge-codegen c-api <MODEL> --out-dir DIR`: the companion crate, in DIR.
fn write_c_api(args: &CApi) -> ExitCode {
    let Some((_, code)) = load(&args.model) else {
        return ExitCode::FAILURE;
    };
    let code = match stateforge_cli::rustfmt(&format!("{}{code}", header(&args.model))) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    };
    let options = stateforge_cli::c_api::Options {
        math_dependency: stateforge_cli::math_dependency(),
        provenance: format!(
            "// Generated by {} {} from {}: edit the model, not this file.",
            env!("CARGO_BIN_NAME"),
            env!("CARGO_PKG_VERSION"),
            args.model.display()
        ),
    };
    match stateforge_cli::c_api::write(&code, &args.out_dir, &options) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// `stateforge-codegen measure <MODEL>`: the table to standard output, the progress to
/// standard error.
fn run_measure(args: &Measure) -> ExitCode {
    let Some((checked, code)) = load(&args.model) else {
        return ExitCode::FAILURE;
    };
    let work_dir = args.work_dir.clone().unwrap_or_else(|| {
        std::env::temp_dir()
            .join("stateforge-measure")
            .join(&checked.model.name)
    });
    let options = stateforge_cli::measure::Options {
        samples: args.samples,
        work_dir,
    };
    match stateforge_cli::measure::measure(&checked.model, &code, &options) {
        Ok(table) => print_code(&table),
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// Writes `code` to standard output. A reader that stops early (`| head`) closes the pipe:
/// that ends the output quietly, as it does other command-line tools, instead of a panic.
fn print_code(code: &str) -> ExitCode {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    match out.write_all(code.as_bytes()).and_then(|()| out.flush()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: cannot write the code: {e}");
            ExitCode::FAILURE
        }
    }
}

/// The generated file's first line: which tool, which version, from which model, so a
/// vendored file says how to regenerate it; then the lints of clippy's pedantic group that
/// generated code trips by design, allowed in this file only, so a crate that denies the
/// group stays clean.
fn header(model: &std::path::Path) -> String {
    format!(
        "// Generated by {} {} from {}: edit the model, not this file.\n{PEDANTIC_BY_DESIGN}",
        env!("CARGO_BIN_NAME"),
        env!("CARGO_PKG_VERSION"),
        model.display()
    )
}

/// Why each pedantic lint is allowed: literals are exact values printed in full
/// (`unreadable_literal`); packed entries are named by index, `p12` beside `p13`
/// (`similar_names`), and vectors are named as in the papers, `x`, `u`, `y`, `p`
/// (`many_single_char_names`); vectors and matrices are passed by reference whatever
/// their size, the generated API's convention (`trivially_copy_pass_by_ref`); a filter's
/// step is one straight-line function (`too_many_lines`); the model's doc comments are
/// the user's prose (`doc_markdown`).
const PEDANTIC_BY_DESIGN: &str = "#![allow(\n    clippy::unreadable_literal,\n    \
    clippy::similar_names,\n    clippy::many_single_char_names,\n    \
    clippy::trivially_copy_pass_by_ref,\n    clippy::too_many_lines,\n    \
    clippy::doc_markdown\n)]\n";

/// `file:line:column: error: message` (or `warning`, the `level`), then the offending line
/// with a caret under the column, as rustc prints them; just `file: error: message` where
/// the error has no place.
fn report(
    path: &std::path::Path,
    source: &str,
    level: &str,
    span: proc_macro2::Span,
    message: &str,
) -> String {
    let start = span.start();
    let Some(line) = start
        .line
        .checked_sub(1)
        .and_then(|i| source.lines().nth(i))
    else {
        // syn places "unexpected end of input" nowhere: it is the end of the model.
        let place = if message.contains("end of input") {
            " (at the end of the model's braces)"
        } else {
            ""
        };
        return format!("{}: {level}: {message}{place}\n", path.display());
    };
    let gutter = " ".repeat(start.line.to_string().len());
    format!(
        "{}:{}:{}: {level}: {message}\n{gutter} |\n{} | {line}\n{gutter} | {}^\n",
        path.display(),
        start.line,
        start.column + 1,
        start.line,
        " ".repeat(start.column)
    )
}
