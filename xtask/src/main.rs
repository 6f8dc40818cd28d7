//! Project automation, after the `cargo xtask` convention.
//!
//! `cargo xtask test` is the one command that checks everything CI checks: it installs what
//! the checks need (the `thumbv7em-none-eabihf` target), then runs formatting, clippy, the
//! whole test suite, and the Cortex-M4F build of the generated code.

#![forbid(unsafe_code)]

use clap::{Parser, Subcommand};
use std::process::{Command, ExitCode};

/// The embedded target the generated code must build for.
const MCU_TARGET: &str = "thumbv7em-none-eabihf";

#[derive(Parser)]
#[command(about = "Project automation")]
struct Cli {
    #[command(subcommand)]
    task: Task,
}

#[derive(Subcommand)]
enum Task {
    /// Install what the checks need, then run formatting, clippy, all tests and the MCU build.
    Test,
}

fn main() -> ExitCode {
    match Cli::parse().task {
        Task::Test => match test() {
            Ok(()) => {
                println!("xtask: every check passed");
                ExitCode::SUCCESS
            }
            Err(message) => {
                eprintln!("xtask: {message}");
                ExitCode::FAILURE
            }
        },
    }
}

fn test() -> Result<(), String> {
    ensure_rust_target(MCU_TARGET)?;
    run(
        "formatting",
        cargo().args(["fmt", "--all", "--", "--check"]),
    )?;
    run(
        "clippy",
        cargo().args([
            "clippy",
            "--workspace",
            "--all-targets",
            "--",
            "-D",
            "warnings",
        ]),
    )?;
    run("tests", cargo().args(["test", "--workspace"]))?;
    run(
        "the Cortex-M4F build of the generated models",
        cargo().args([
            "build",
            "--release",
            "--package",
            "generated-demo",
            "--lib",
            "--target",
            MCU_TARGET,
        ]),
    )?;
    Ok(())
}

/// Installs a rustup target if it is missing, with a clear message if that cannot be done.
fn ensure_rust_target(target: &str) -> Result<(), String> {
    let installed = Command::new("rustup")
        .args(["target", "list", "--installed"])
        .output()
        .map_err(|e| {
            format!("cannot run rustup ({e}); install rustup, then `rustup target add {target}`")
        })?;
    if String::from_utf8_lossy(&installed.stdout)
        .lines()
        .any(|l| l.trim() == target)
    {
        return Ok(());
    }
    println!("xtask: installing the Rust target {target}");
    run(
        &format!("`rustup target add {target}`"),
        Command::new("rustup").args(["target", "add", target]),
    )
}

fn cargo() -> Command {
    Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()))
}

fn run(what: &str, command: &mut Command) -> Result<(), String> {
    println!("xtask: {what}");
    let status = command
        .status()
        .map_err(|e| format!("{what}: cannot start: {e}"))?;
    if status.success() {
        Ok(())
    } else {
        Err(format!("{what} failed ({status})"))
    }
}
