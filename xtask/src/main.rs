//! Project automation, after the `cargo xtask` convention.
//!
//! `cargo xtask test` is the one command that checks everything CI checks: it installs what
//! the checks need (the `thumbv7em-none-eabihf` target, `qemu-system-arm` and the ARM
//! binutils), runs formatting, clippy and the whole test suite, builds the generated code
//! for the Cortex-M4F, runs the firmware under QEMU, fails if its f32 estimates disagree
//! with the host's f64 run, and prints the cost table (instructions counted by the firmware,
//! cycles estimated from a second, traced run). `cargo xtask cost` prints the table.

#![forbid(unsafe_code)]

mod accuracy;
mod compare;
mod compare_continuous;
mod compare_mpc;
mod compare_observers;
mod cost;
mod firmware;
mod program;
mod setup;
mod timing;
mod trace;

use clap::{Parser, Subcommand};
use std::path::Path;
use std::process::{Command, ExitCode};

/// The embedded target the generated code must build for.
const MCU_TARGET: &str = "thumbv7em-none-eabihf";
/// The firmware crate, and the image it builds.
const TARGETS: &str = "targets";
/// Samples in the firmware's embedded sequence (`targets/build.rs`).
const SEQUENCE_SAMPLES: usize = 1000;
/// Commands the firmware checks run, with the Debian packages that provide them.
const FIRMWARE_TOOLS: &[(&str, &str)] = &[
    ("qemu-system-arm", "qemu-system-arm"),
    ("arm-none-eabi-nm", "binutils-arm-none-eabi"),
    ("arm-none-eabi-objdump", "binutils-arm-none-eabi"),
];

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
    /// Run the firmware under QEMU and print what the generated filters cost on the
    /// Cortex-M4F, beside the nalgebra baseline.
    Cost,
    /// On the host, how far the f32 filters drift from f64 over many noise sequences.
    Accuracy {
        /// How many sequences (the first is the CI's).
        #[arg(default_value_t = 40)]
        sequences: u64,
    },
}

fn main() -> ExitCode {
    match Cli::parse().task {
        Task::Accuracy { sequences } => {
            print!("{}", accuracy::report(sequences));
            ExitCode::SUCCESS
        }
        Task::Cost => match cost() {
            Ok(table) => {
                print!("{table}");
                ExitCode::SUCCESS
            }
            Err(message) => {
                eprintln!("xtask: {message}");
                ExitCode::FAILURE
            }
        },
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
    setup::rust_target(MCU_TARGET)?;
    setup::debian_commands(FIRMWARE_TOOLS)?;
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
    run(
        "formatting of the firmware",
        cargo().args(["fmt", "--", "--check"]).current_dir(TARGETS),
    )?;
    run(
        "clippy on the firmware",
        cargo()
            .args(["clippy", "--release", "--", "-D", "warnings"])
            .current_dir(TARGETS),
    )?;
    let host = compare::host_run(SEQUENCE_SAMPLES);
    let mut tables = Vec::new();
    for build in firmware::BUILDS {
        println!(
            "xtask: the firmware {} under QEMU, against the host",
            build.name
        );
        let report = firmware::run(Path::new(TARGETS), build)?;
        println!("xtask: {}", compare::check(&report.estimates, &host)?);
        println!(
            "xtask: {}",
            compare_continuous::check(&report.continuous, &report.hybrid)?
        );
        println!("xtask: {}", compare_observers::check(&report)?);
        println!("xtask: {}", compare_mpc::check(&report.mpc)?);
        println!("xtask: {}", check_fused(&report, build)?);
        tables.push(cost_table(&report, build)?);
    }
    print!("{}", tables.join("\n"));
    Ok(())
}

/// Checks what the build does with `a * b + c`: in the FMA build, exactly what
/// `libm::fmaf` gives (one rounding); otherwise, not always (rounded after the multiply).
fn check_fused(report: &firmware::Report, build: firmware::Build) -> Result<String, String> {
    let (differing, of) = report
        .fused
        .ok_or("the firmware did not compare multiply-adds with libm::fmaf")?;
    match (build.fused, differing) {
        (true, 0) => Ok(format!(
            "all {of} multiply-adds equal libm::fmaf bit for bit (vfma.f32)"
        )),
        (false, d) if d > 0 => Ok(format!(
            "{d} of {of} multiply-adds differ from libm::fmaf (vmla.f32, two roundings)"
        )),
        _ => Err(format!(
            "the firmware {}: {differing} of {of} multiply-adds differ from libm::fmaf",
            build.name
        )),
    }
}

/// The firmware's checks and their cost table.
fn cost() -> Result<String, String> {
    setup::rust_target(MCU_TARGET)?;
    setup::debian_commands(FIRMWARE_TOOLS)?;
    let mut tables = Vec::new();
    for build in firmware::BUILDS {
        let report = firmware::run(Path::new(TARGETS), build)?;
        tables.push(cost_table(&report, build)?);
    }
    Ok(tables.join("\n"))
}

/// The cost table of a firmware run: its counts, and the cycles of a traced second run.
fn cost_table(report: &firmware::Report, build: firmware::Build) -> Result<String, String> {
    let elf = build.elf(Path::new(TARGETS));
    let program = program::Program::read(&elf)?;
    println!(
        "xtask: the firmware {} again, traced instruction by instruction (cycle estimates)",
        build.name
    );
    let wrappers = cost::wrappers(&report.costs, &program);
    let traced = trace::run(&elf, &program, &wrappers)?;
    // The default build in full; the others, their main table.
    cost::table(
        build.name,
        !build.fused,
        (&report.costs, &report.spreads),
        &program,
        &traced,
    )
}

fn cargo() -> Command {
    Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()))
}

/// Runs a command, naming it in progress and error messages.
pub fn run(what: &str, command: &mut Command) -> Result<(), String> {
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
