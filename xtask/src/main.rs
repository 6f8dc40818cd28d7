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
mod c_firmware;
mod cold_build;
mod command;
mod compare;
mod compare_continuous;
mod compare_math;
mod compare_mpc;
mod compare_observers;
mod cost;
mod firmware;
mod fuzz_inputs;
mod imports;
mod math_ulps;
mod msrv;
mod peers;
mod peers_build;
mod peers_problem;
mod peers_quadrotor;
mod peers_quadrotor_problem;
mod peers_symforce;
mod peers_table;
mod peers_tinympc;
mod scratch;
mod static_estimate;
mod vendored;

use clap::{Parser, Subcommand};
use command::{cargo, run};
// The measuring harness's host side (the image's instructions, the trace, installing what
// it needs), shared with `stateforge-codegen measure`.
use stateforge_cli::measure::{program, setup, trace};
use std::path::Path;
use std::process::ExitCode;

/// The embedded target the generated code must build for.
const MCU_TARGET: &str = "thumbv7em-none-eabihf";
/// The firmware crate, and the image it builds.
const TARGETS: &str = "targets";
/// Samples in the firmware's embedded sequence (`targets/build.rs`).
const SEQUENCE_SAMPLES: usize = 1000;
/// Users' crates, outside the workspace, built and tested like a user's project.
const EXAMPLES: &str = "examples";
/// The crates published to crates.io, in dependency order.
const PUBLISHED: [&str; 4] = [
    "stateforge-math",
    "stateforge-compiler",
    "stateforge",
    "stateforge-cli",
];
/// Commands the firmware checks run, with the Debian packages that provide them: those
/// of the shared measuring harness.
const FIRMWARE_TOOLS: &[(&str, &str)] = stateforge_cli::measure::TOOLS;

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
    /// Check the published crates' declared minimum Rust version (part of `test`).
    Msrv,
    /// Check that no source file imports a file that imports it back (part of `test`).
    Imports,
    /// Run the firmware under QEMU and print what the generated filters cost on the
    /// Cortex-M4F, beside the nalgebra baseline.
    Cost,
    /// The C firmware (`targets/c/main.c`, through the C API) beside the Rust firmware
    /// without FMA: results bit for bit and the calls' cost (part of `test` and `cost`).
    CApi,
    /// Benchmark: the blade's MPC QP solved by embedded-QP peers (OSQP's and TinyMPC's
    /// generated C/C++, built with arm-none-eabi-gcc) on the same emulated Cortex-M4F, beside
    /// the generated MPC; and SymForce's navigation EKF beside the generated one (part of
    /// `cost`; installs the peers' Python packages into `target/peers`, the ARM compiler and
    /// Eigen's headers when missing).
    Peers,
    /// Vendor every demo model with `stateforge-codegen` into a user crate and check it
    /// with rustfmt, `-D warnings` and clippy (part of `test`).
    Vendored,
    /// The largest error in ulps of each `stateforge_math::f32` function over every f32
    /// input (`atan2`: a grid and random pairs); builds and runs itself in release.
    MathUlps {
        /// Functions to measure (default: all).
        functions: Vec<String>,
    },
    /// On the host, how far the f32 filters drift from f64 over many noise sequences.
    Accuracy {
        /// How many sequences (the first is the CI's).
        #[arg(default_value_t = 40)]
        sequences: u64,
    },
    /// Benchmark: build a one-model user crate (outside the workspace, its own target
    /// directory) from nothing and report the time, the crates compiled and any warning.
    ColdBuild {
        /// The `stateforge` directory to depend on (default: this workspace's), to
        /// compare with another checkout.
        #[arg(long)]
        macros: Option<std::path::PathBuf>,
        /// Parallel jobs for cargo (default: cargo's).
        #[arg(long)]
        jobs: Option<u32>,
        /// Build the 24-state navigation model (`generated-demo/models/navigation.rs`)
        /// in release for the Cortex-M4F, as its firmware is, instead of the README's
        /// cantilever in a debug build.
        #[arg(long)]
        navigation: bool,
    },
}

fn main() -> ExitCode {
    let outcome = match Cli::parse().task {
        Task::Accuracy { sequences } => Ok(accuracy::report(sequences)),
        Task::ColdBuild {
            macros,
            jobs,
            navigation,
        } => {
            let build = if navigation {
                cold_build::navigation_firmware(MCU_TARGET)
            } else {
                Ok(cold_build::Build::readme_model())
            };
            build
                .and_then(|build| cold_build::measure(macros.as_deref(), jobs, &build))
                .map(|m| m.to_string())
        }
        Task::Imports => {
            imports::check(&scratch::workspace_root()).map(|summary| format!("xtask: {summary}\n"))
        }
        Task::Msrv => msrv::check(&PUBLISHED).map(|summary| format!("xtask: {summary}\n")),
        Task::Vendored => vendored::check().map(|summary| format!("xtask: {summary}\n")),
        Task::Cost => cost(),
        Task::CApi => c_api(),
        Task::Peers => peers::report(),
        Task::MathUlps { functions } => math_ulps(&functions),
        Task::Test => test().map(|()| "xtask: every check passed\n".to_string()),
    };
    match outcome {
        Ok(report) => {
            print!("{report}");
            ExitCode::SUCCESS
        }
        Err(message) => {
            eprintln!("xtask: {message}");
            ExitCode::FAILURE
        }
    }
}

/// `cargo xtask math-ulps`: measured in a release build (an unoptimised one takes far
/// longer), so a debug build runs its release self.
fn math_ulps(functions: &[String]) -> Result<String, String> {
    if cfg!(debug_assertions) {
        run(
            "math-ulps (release build)",
            cargo()
                .args([
                    "run",
                    "--quiet",
                    "--release",
                    "--package",
                    "xtask",
                    "--",
                    "math-ulps",
                ])
                .args(functions),
        )?;
        return Ok(String::new());
    }
    Ok(math_ulps::report(functions))
}

fn test() -> Result<(), String> {
    setup::rust_target(MCU_TARGET)?;
    setup::debian_commands(FIRMWARE_TOOLS)?;
    println!("xtask: {}", msrv::check(&PUBLISHED)?);
    println!("xtask: {}", imports::check(&scratch::workspace_root())?);
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
    let started = std::time::SystemTime::now();
    run("tests", cargo().args(["test", "--workspace"]))
        .map_err(|e| format!("{e}{}", fuzz_inputs::written_since(started)))?;
    run(
        "the docs, without a broken intra-doc link (generated docs included)",
        cargo()
            .env("RUSTDOCFLAGS", "-D warnings")
            .args(["doc", "--no-deps", "--quiet", "--package", "generated-demo"])
            .args(PUBLISHED.iter().flat_map(|name| ["--package", name])),
    )?;
    run(
        "packaging the published crates (manifests, versions of path dependencies)",
        cargo()
            .args(["package", "--no-verify", "--allow-dirty", "--quiet"])
            .args(PUBLISHED.iter().flat_map(|name| ["--package", name])),
    )?;
    println!("xtask: {}", vendored::check()?);
    user_examples()?;
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
        firmware_checks(&report, build, &host)?;
        tables.push(cost_table(&report, build)?);
        if !build.fused {
            tables.push(c_api_firmware(&report)?);
        }
    }
    print!("{}", tables.join("\n"));
    Ok(())
}

/// `cargo xtask c-api`: the Rust firmware without FMA, then the C firmware beside it.
fn c_api() -> Result<String, String> {
    setup::rust_target(MCU_TARGET)?;
    setup::debian_commands(FIRMWARE_TOOLS)?;
    let build = firmware::BUILDS[0];
    println!("xtask: the firmware {} under QEMU", build.name);
    c_api_firmware(&firmware::run(Path::new(TARGETS), build)?)
}

/// The C firmware (`targets/c/main.c`, through the C API) beside the Rust firmware's build
/// without FMA: its results checked against the Rust firmware's bit for bit, and its calls'
/// cost beside the Rust calls'. Where the ARM compiler cannot be installed, skipped with a
/// line saying why.
fn c_api_firmware(rust: &firmware::Report) -> Result<String, String> {
    if let Err(e) = c_firmware::toolchain() {
        println!("xtask: the C firmware is skipped: {e}");
        return Ok(format!("Through the C API: not run here: {e}\n"));
    }
    let c = c_firmware::run_firmware(&scratch::workspace_root())?;
    println!("xtask: {}", c_firmware::check(&c, &rust.bits)?);
    cost::c_api_table(&rust.costs, &c.costs)
}

/// The firmware's agreement checks: its estimates against the host's runs, its
/// multiply-adds and its `stateforge_math` values.
fn firmware_checks(
    report: &firmware::Report,
    build: firmware::Build,
    host: &[firmware::Estimate],
) -> Result<(), String> {
    println!("xtask: {}", compare::check(&report.estimates, host)?);
    println!(
        "xtask: {}",
        compare_continuous::check(&report.continuous, &report.hybrid)?
    );
    println!("xtask: {}", compare_observers::check(report)?);
    println!("xtask: {}", compare_mpc::check(&report.mpc)?);
    println!("xtask: {}", check_fused(report, build)?);
    println!("xtask: {}", compare_math::check(&report.math, build)?);
    Ok(())
}

/// The users' crates in `examples/`, each its own workspace with a committed lockfile:
/// formatted, clippy-clean, tested, and their libraries built for the MCU (`no_std`).
fn user_examples() -> Result<(), String> {
    let examples = scratch::workspace_root().join(EXAMPLES);
    let entries =
        std::fs::read_dir(&examples).map_err(|e| format!("cannot list {EXAMPLES}: {e}"))?;
    let mut crates: Vec<_> = entries
        .filter_map(|entry| Some(entry.ok()?.path()))
        .filter(|dir| dir.join("Cargo.toml").exists())
        .collect();
    crates.sort();
    for dir in crates {
        let name = dir.display();
        run(
            &format!("formatting of {name}"),
            cargo().args(["fmt", "--", "--check"]).current_dir(&dir),
        )?;
        run(
            &format!("clippy on {name}"),
            cargo()
                .args([
                    "clippy",
                    "--locked",
                    "--all-targets",
                    "--",
                    "-D",
                    "warnings",
                ])
                .current_dir(&dir),
        )?;
        run(
            &format!("tests of {name}"),
            cargo().args(["test", "--locked"]).current_dir(&dir),
        )?;
        run(
            &format!("the library of {name} for the Cortex-M4F"),
            cargo()
                .args(["build", "--locked", "--lib", "--target", MCU_TARGET])
                .current_dir(&dir),
        )?;
    }
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
    let host = compare::host_run(SEQUENCE_SAMPLES);
    let mut tables = Vec::new();
    for build in firmware::BUILDS {
        let report = firmware::run(Path::new(TARGETS), build)?;
        firmware_checks(&report, build, &host)?;
        tables.push(cost_table(&report, build)?);
        if !build.fused {
            tables.push(c_api_firmware(&report)?);
        }
    }
    // The embedded-QP peers: their packages and compiler are the benchmark's to install;
    // where that or their build is impossible, the table says why instead.
    tables.push(
        peers::report().unwrap_or_else(|e| format!("Embedded-QP peers: cannot run here: {e}\n")),
    );
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
    cost::table(build.name, !build.fused, report, &program, &traced)
}
