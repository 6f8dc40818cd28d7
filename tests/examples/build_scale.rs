//! What building a large model costs: an integrator chain of 20 to 100 states with an EKF,
//! declared with `model!` in a scratch `no_std` crate and built in a debug build (the one
//! a user iterates with) and in a release build for the Cortex-M4F
//! (`thumbv7em-none-eabihf`, what a user flashes), without incremental compilation.
//! Prints, per size, the generated code's size, the time `stateforge-codegen` takes to
//! lay it out with its default formatter (prettyplease, then rustfmt), each build's wall
//! time and the debug build's peak memory (the largest resident set of cargo, rustc and
//! the macro). A benchmark, not a test: the numbers depend on the machine.
//!
//! ```text
//! cargo run --release -p tests --example build_scale [-- 20 40 60 100]
//! ```

use nix::sys::resource::{getrusage, UsageWho};
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};
use std::time::Instant;
use tests::scale::integrator_chain;

/// The Cortex-M4F's target, the release build's (`rustup target add` it first).
const MCU_TARGET: &str = "thumbv7em-none-eabihf";

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if let [flag, dir] = args.as_slice() {
        if flag == "--build-once" {
            return build_once(Path::new(dir), &[]);
        }
        if flag == "--build-once-release" {
            return build_once(Path::new(dir), &["--release", "--target", MCU_TARGET]);
        }
    }
    let sizes: Vec<usize> = if args.is_empty() {
        vec![20, 40, 60, 100]
    } else {
        match args.iter().map(|a| a.parse()).collect() {
            Ok(sizes) => sizes,
            Err(_) => {
                eprintln!("usage: build_scale [STATES ...]");
                return ExitCode::FAILURE;
            }
        }
    };
    match run(&sizes) {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("build_scale: {message}");
            ExitCode::FAILURE
        }
    }
}

fn run(sizes: &[usize]) -> Result<(), String> {
    let workspace = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    let dir = workspace.join("target/build-scale");
    std::fs::create_dir_all(dir.join("src")).map_err(|e| e.to_string())?;
    let manifest = format!(
        "[package]\nname = \"build-scale\"\nversion = \"0.0.0\"\nedition = \"2021\"\n\
         publish = false\n\n[dependencies]\nstateforge = {{ path = {:?} }}\n\
         stateforge-math = {{ path = {:?} }}\n\n[workspace]\n",
        workspace
            .join("codegen-macros")
            .canonicalize()
            .map_err(|e| e.to_string())?,
        workspace
            .join("stateforge-math")
            .canonicalize()
            .map_err(|e| e.to_string())?
    );
    std::fs::write(dir.join("Cargo.toml"), manifest).map_err(|e| e.to_string())?;
    // Build the dependencies (and the macro) first, so each measured build is the model's.
    write_model(&dir, 2)?;
    measure(&dir, Profile::Debug)?;
    measure(&dir, Profile::Release)?;
    println!(
        "states  generated code   formatted (rustfmt)   build (debug)   peak memory   \
         build (release, thumbv7em)"
    );
    for &n in sizes {
        write_model(&dir, n)?;
        let tokens = stateforge_compiler::expand_macro_source(&integrator_chain(n, true))
            .map_err(|e| format!("{n} states: {e}"))?;
        let code_bytes = tokens.to_string().len();
        let formatting = format_seconds(tokens).map_err(|e| format!("{n} states: {e}"))?;
        let (seconds, peak_kib) = measure(&dir, Profile::Debug)?;
        let (release, _) = measure(&dir, Profile::Release)?;
        println!(
            "{n:>6}  {:>10.1} MB   {formatting:>17.1} s   {seconds:>11.1} s   {:>8.2} GB   \
             {release:>24.1} s",
            code_bytes as f64 / 1e6,
            peak_kib as f64 / (1024.0 * 1024.0)
        );
    }
    Ok(())
}

/// Seconds `stateforge-codegen`'s default layout of `tokens` takes: prettyplease, then
/// rustfmt (`RUSTFMT`, else `rustfmt` on the path).
fn format_seconds(tokens: proc_macro2::TokenStream) -> Result<f64, String> {
    let start = Instant::now();
    let code = stateforge_cli::format(tokens).map_err(|e| e.to_string())?;
    stateforge_cli::rustfmt(&code).map_err(|e| e.to_string())?;
    Ok(start.elapsed().as_secs_f64())
}

fn write_model(dir: &Path, n: usize) -> Result<(), String> {
    let source = format!(
        "//! Scratch crate of the build benchmark.\n#![no_std]\nuse stateforge::model;\n{}",
        integrator_chain(n, true)
    );
    std::fs::write(dir.join("src/lib.rs"), source).map_err(|e| e.to_string())
}

/// The two builds measured.
#[derive(Clone, Copy)]
enum Profile {
    /// `cargo build` on the host.
    Debug,
    /// `cargo build --release --target thumbv7em-none-eabihf`.
    Release,
}

/// Builds the scratch crate in a child of this program, so the peak memory it reports is
/// that build's alone. Returns seconds and KiB.
fn measure(dir: &Path, profile: Profile) -> Result<(f64, u64), String> {
    let me = std::env::current_exe().map_err(|e| e.to_string())?;
    let flag = match profile {
        Profile::Debug => "--build-once",
        Profile::Release => "--build-once-release",
    };
    let start = Instant::now();
    let output = Command::new(me)
        .arg(flag)
        .arg(dir)
        .output()
        .map_err(|e| e.to_string())?;
    let seconds = start.elapsed().as_secs_f64();
    if !output.status.success() {
        return Err(format!(
            "the scratch build failed:\n{}",
            String::from_utf8_lossy(&output.stderr)
        ));
    }
    let text = String::from_utf8_lossy(&output.stdout);
    let peak = text
        .trim()
        .parse()
        .map_err(|_| format!("unexpected output: {text}"))?;
    Ok((seconds, peak))
}

/// The child: builds once (with `flags`) and prints the largest resident set of what it
/// ran, in KiB.
fn build_once(dir: &Path, flags: &[&str]) -> ExitCode {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let status = Command::new(cargo)
        .args(["build", "--quiet"])
        .args(flags)
        .env("CARGO_INCREMENTAL", "0")
        .current_dir(dir)
        .status();
    match (status, getrusage(UsageWho::RUSAGE_CHILDREN)) {
        (Ok(s), Ok(usage)) if s.success() => {
            println!("{}", usage.max_rss());
            ExitCode::SUCCESS
        }
        _ => ExitCode::FAILURE,
    }
}
