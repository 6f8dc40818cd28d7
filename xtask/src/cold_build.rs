//! `cargo xtask cold-build`: how long a user's crate with one model takes to build from
//! nothing, and what that build prints. A benchmark, not a check: it reports, never fails
//! on a time.

use crate::scratch::{workspace_root, Scratch};
use std::path::{Path, PathBuf};
use std::process::Stdio;
use std::time::Instant;

/// The user's crate: one small model with an EKF, as the README shows it.
const MODEL: &str = r#"//! One model, built the way a user's crate builds it.
#![no_std]
#![forbid(unsafe_code)]

stateforge::model! {
    /// Cantilever beam, first mode, with unknown stiffness, damping and input gain.
    pub mod cantilever {
        scalar f32;
        /// Sample time [s].
        const TS = 0.015;
        state x1, x2;
        param x3, x4, x5;
        input u;
        output y = x1;
        generate ekf(process_noise = diagonal);
        dynamics discrete {
            x1 = x1 + TS * x2;
            x2 = TS * x1 * x3 + (1.0 + TS * x4) * x2 + TS * x5 * u;
        }
    }
}
"#;

/// What a cold build builds: the user crate's `src/lib.rs`, and how.
pub struct Build {
    /// The crate's source.
    source: String,
    /// Cargo's arguments after `build`, besides `--offline`.
    flags: Vec<&'static str>,
    /// What it is, for the report.
    what: &'static str,
}

impl Build {
    /// The README's one-model crate (the cantilever), in a debug build.
    pub fn readme_model() -> Build {
        Build {
            source: MODEL.to_string(),
            flags: Vec::new(),
            what: "a one-model crate (debug)",
        }
    }
}

/// The 24-state navigation model alone in a `no_std` crate, in a release build for the
/// Cortex-M4F (`target`) as firmware is built.
pub fn navigation_firmware(target: &'static str) -> Result<Build, String> {
    let path = workspace_root().join("generated-demo/models/navigation.rs");
    let model = std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?;
    stateforge_cli::measure::setup::rust_target(target)?;
    Ok(Build {
        source: format!(
            "//! The navigation model, built as firmware builds it.\n#![no_std]\n\
             #![forbid(unsafe_code)]\n\n{model}"
        ),
        flags: vec!["--release", "--target", target],
        what: "the 24-state navigation model's crate (release, thumbv7em-none-eabihf)",
    })
}

/// What one cold build measured.
pub struct Measurement {
    /// Wall-clock seconds of `cargo build`.
    pub seconds: f64,
    /// The crates compiled, in cargo's order.
    pub compiled: Vec<String>,
    /// Every `warning` line cargo and rustc printed.
    pub warnings: Vec<String>,
}

/// Builds the one-model crate against the macro crate at `macros` (this workspace's
/// `stateforge` by default) in a fresh directory with an empty target directory, `jobs`
/// parallel jobs.
pub fn measure(
    macros: Option<&Path>,
    jobs: Option<u32>,
    what: &Build,
) -> Result<Measurement, String> {
    let macros = macros.map_or_else(
        || workspace_root().join("codegen-macros"),
        Path::to_path_buf,
    );
    let macros = macros
        .canonicalize()
        .map_err(|e| format!("{}: {e}", macros.display()))?;
    let user = user_crate(&macros, what)?;
    let mut build = user.cargo();
    build.args(["build", "--offline"]).args(&what.flags);
    if let Some(jobs) = jobs {
        build.arg(format!("--jobs={jobs}"));
    }
    println!(
        "xtask: cold build of {} using {}",
        what.what,
        macros.display()
    );
    let start = Instant::now();
    let output = build
        .stdout(Stdio::null())
        .output()
        .map_err(|e| format!("cannot run cargo: {e}"))?;
    let seconds = start.elapsed().as_secs_f64();
    let stderr = String::from_utf8_lossy(&output.stderr);
    if !output.status.success() {
        return Err(format!("the one-model crate does not build:\n{stderr}"));
    }
    Ok(Measurement::read(seconds, &stderr))
}

/// The user crate of `what` on the macros at `macros`, in a fresh directory, sources fetched.
fn user_crate(macros: &Path, what: &Build) -> Result<Scratch, String> {
    let lockfile: Option<PathBuf> = macros
        .parent()
        .map(|root| root.join("Cargo.lock"))
        .filter(|lock| lock.exists());
    let dependencies = user_dependencies(macros)?;
    let user = Scratch::new(
        "cold-build-user",
        None,
        &dependencies,
        &[("src/lib.rs", what.source.clone())],
        lockfile.as_deref(),
    )?;
    // Sources are fetched first, so the time is compiling, not downloading.
    crate::command::run(
        "fetching the user crate's dependencies",
        user.cargo().args(["fetch"]),
    )?;
    Ok(user)
}

impl Measurement {
    /// A build of `seconds` whose cargo printed `stderr`: the crates it compiled, its warnings.
    fn read(seconds: f64, stderr: &str) -> Measurement {
        let compiled = stderr
            .lines()
            .filter_map(|l| l.trim().strip_prefix("Compiling "))
            .map(str::to_string)
            .collect();
        let warnings = stderr
            .lines()
            .filter(|l| l.trim_start().starts_with("warning"))
            .map(str::to_string)
            .collect();
        Measurement {
            seconds,
            compiled,
            warnings,
        }
    }
}

/// The one-model crate's dependencies on the macro crate at `macros`: under its package
/// name, which an older checkout may spell otherwise (`codegen-macros`), and imported as
/// `stateforge`, the name the model uses; and the runtime crate the generated code calls,
/// `stateforge-math` beside the macros, or `libm` for a checkout from before it.
fn user_dependencies(macros: &Path) -> Result<String, String> {
    let runtime = macros
        .parent()
        .map(|root| root.join("stateforge-math"))
        .filter(|math| math.exists())
        .map_or("libm = \"0.2\"".to_owned(), |math| {
            format!(
                "stateforge-math = {{ path = {:?} }}",
                math.display().to_string()
            )
        });
    Ok(format!(
        "stateforge = {{ package = {:?}, path = {:?} }}\n{runtime}",
        package_name(macros)?,
        macros.display().to_string()
    ))
}

/// The `name` of the package whose directory is `dir`, read from its `Cargo.toml`.
fn package_name(dir: &Path) -> Result<String, String> {
    let manifest = dir.join("Cargo.toml");
    let text =
        std::fs::read_to_string(&manifest).map_err(|e| format!("{}: {e}", manifest.display()))?;
    text.lines()
        .skip_while(|line| line.trim() != "[package]")
        .find_map(|line| {
            let (key, value) = line.split_once('=')?;
            (key.trim() == "name").then(|| value.trim().trim_matches('"').to_string())
        })
        .ok_or_else(|| format!("{}: no package name", manifest.display()))
}

impl std::fmt::Display for Measurement {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "cold build: {:.1} s, {} crates compiled",
            self.seconds,
            self.compiled.len()
        )?;
        for crate_ in &self.compiled {
            writeln!(f, "  {crate_}")?;
        }
        if self.warnings.is_empty() {
            writeln!(f, "warnings: none")
        } else {
            writeln!(f, "warnings:")?;
            self.warnings.iter().try_for_each(|w| writeln!(f, "  {w}"))
        }
    }
}
