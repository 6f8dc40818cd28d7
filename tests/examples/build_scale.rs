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
//!
//! With `--compiler`, what the compiler itself costs on the largest inputs instead: the
//! CPU time (user and system) and peak memory of expanding a 300-state chain's EKF (the
//! macro's work, `stateforge_compiler::expand_macro_source`, in a child of this program
//! that reports its own usage), and of running `stateforge-codegen --formatter
//! prettyplease` (expansion, then prettyplease's layout, with the tool's allocator) on
//! that chain and on the piecewise beam integrated by RK4 in 64 unrolled sub-steps
//! (`tests/models/piecewise_beam_substeps.rs`). The tool is built first (release), and
//! each run's usage is the kernel's account of that process (`getrusage` of its waiting
//! parent, a child of this program).
//!
//! ```text
//! cargo run --release -p tests --example build_scale -- --compiler [STATES]
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
    if let Some(code) = compiler::dispatch(&args) {
        return code;
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

/// `--compiler`: the compiler's own CPU time and peak memory on the largest inputs.
mod compiler {
    use nix::sys::resource::{getrusage, UsageWho};
    use std::path::{Path, PathBuf};
    use std::process::{Command, ExitCode};
    use tests::scale::integrator_chain;

    /// The chain's states when `--compiler` names none.
    const STATES: usize = 300;

    /// Runs `--compiler [STATES]` or one of its children; `None` for other arguments.
    pub fn dispatch(args: &[String]) -> Option<ExitCode> {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        match args.as_slice() {
            ["--compiler"] => Some(report(STATES)),
            ["--compiler", n] => Some(n.parse().map_or_else(|_| usage(), report)),
            ["--expand-once", n] => Some(n.parse().map_or_else(|_| usage(), expand_once)),
            ["--codegen-once", tool, model] => Some(codegen_once(Path::new(tool), model)),
            _ => None,
        }
    }

    fn usage() -> ExitCode {
        eprintln!("usage: build_scale --compiler [STATES]");
        ExitCode::FAILURE
    }

    fn workspace() -> PathBuf {
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
    }

    fn report(states: usize) -> ExitCode {
        match runs(states).and_then(|runs| print_runs(&runs)) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("build_scale: {e}");
                ExitCode::FAILURE
            }
        }
    }

    /// What is measured: each row's name and the arguments of the child that measures it.
    fn runs(states: usize) -> Result<Vec<(String, Vec<String>)>, String> {
        let tool = build_tool()?;
        let tool = tool.to_string_lossy().into_owned();
        let dir = workspace().join("target/build-scale");
        std::fs::create_dir_all(&dir).map_err(|e| e.to_string())?;
        let chain = dir.join(format!("chain_{states}.rs"));
        std::fs::write(&chain, integrator_chain(states, true)).map_err(|e| e.to_string())?;
        let beam = workspace().join("tests/models/piecewise_beam_substeps.rs");
        let codegen = |model: &Path| {
            let model = model.to_string_lossy().into_owned();
            vec!["--codegen-once".to_owned(), tool.clone(), model]
        };
        Ok(vec![
            (
                format!("{states}-state chain, EKF: expand"),
                vec!["--expand-once".to_owned(), states.to_string()],
            ),
            (
                format!("{states}-state chain, EKF: stateforge-codegen"),
                codegen(&chain),
            ),
            (
                "64-sub-step piecewise beam: stateforge-codegen".to_owned(),
                codegen(&beam),
            ),
        ])
    }

    fn print_runs(runs: &[(String, Vec<String>)]) -> Result<(), String> {
        println!("(stateforge-codegen runs with --formatter prettyplease)");
        println!("{:<52} {:>12} {:>12}", "input", "CPU", "peak memory");
        for (name, args) in runs {
            let (cpu, kib) = measure(args).map_err(|e| format!("{name}: {e}"))?;
            println!(
                "{name:<52} {cpu:>10.2} s {:>9.2} GB",
                kib as f64 / (1024.0 * 1024.0)
            );
        }
        Ok(())
    }

    /// Builds `stateforge-codegen` (release) and returns its path.
    fn build_tool() -> Result<PathBuf, String> {
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let status = Command::new(cargo)
            .args(["build", "--quiet", "--release", "-p", "stateforge-cli"])
            .args(["--bin", "stateforge-codegen"])
            .current_dir(workspace())
            .status()
            .map_err(|e| e.to_string())?;
        if !status.success() {
            return Err("building stateforge-codegen failed".into());
        }
        Ok(workspace().join("target/release/stateforge-codegen"))
    }

    /// Runs this program with `args` and reads the CPU seconds and peak KiB it reports.
    fn measure(args: &[String]) -> Result<(f64, u64), String> {
        let me = std::env::current_exe().map_err(|e| e.to_string())?;
        let output = Command::new(me)
            .args(args)
            .output()
            .map_err(|e| e.to_string())?;
        let text = String::from_utf8_lossy(&output.stdout);
        if !output.status.success() {
            return Err(String::from_utf8_lossy(&output.stderr).into_owned());
        }
        match text.split_whitespace().collect::<Vec<_>>().as_slice() {
            [cpu, kib] => Ok((
                cpu.parse()
                    .map_err(|_| format!("unexpected output: {text}"))?,
                kib.parse()
                    .map_err(|_| format!("unexpected output: {text}"))?,
            )),
            _ => Err(format!("unexpected output: {text}")),
        }
    }

    /// Prints the CPU seconds (user and system) and peak resident KiB of this process
    /// (`who` is `RUSAGE_SELF`) or of the children it waited for (`RUSAGE_CHILDREN`).
    fn print_usage(who: UsageWho) -> ExitCode {
        let Ok(usage) = getrusage(who) else {
            return ExitCode::FAILURE;
        };
        let seconds = |t: nix::sys::time::TimeVal| t.tv_sec() as f64 + t.tv_usec() as f64 * 1e-6;
        let cpu = seconds(usage.user_time()) + seconds(usage.system_time());
        println!("{cpu} {}", usage.max_rss());
        ExitCode::SUCCESS
    }

    /// The child: expands the chain of `n` states with its EKF, as the macro does.
    fn expand_once(n: usize) -> ExitCode {
        let source = integrator_chain(n, true);
        match stateforge_compiler::expand_macro_source(&source) {
            Ok(tokens) => {
                drop(tokens);
                print_usage(UsageWho::RUSAGE_SELF)
            }
            Err(e) => {
                eprintln!("{e}");
                ExitCode::FAILURE
            }
        }
    }

    /// The child: runs `stateforge-codegen --formatter prettyplease` (`tool`) on `model`,
    /// its code to the null device, and prints that run's usage: the only child it waits
    /// for.
    fn codegen_once(tool: &Path, model: &str) -> ExitCode {
        let status = Command::new(tool)
            .args(["--formatter", "prettyplease", model, "-o", "/dev/null"])
            .status();
        match status {
            Ok(s) if s.success() => print_usage(UsageWho::RUSAGE_CHILDREN),
            Ok(_) => ExitCode::FAILURE,
            Err(e) => {
                eprintln!("{e}");
                ExitCode::FAILURE
            }
        }
    }
}
