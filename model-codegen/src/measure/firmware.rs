//! The measuring firmware as a crate of its own in a work directory: written, built in
//! release for the Cortex-M4F, and run under QEMU with its instruction counter.

use super::board::{ICOUNT, MACHINE, TARGET};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The shared measuring harness (also `targets/`'s), embedded in the tool.
const MEASURE_RS: &str = include_str!("../../firmware/measure.rs");
/// The data, tuning and report lines of the tool's firmware.
const SUPPORT_RS: &str = include_str!("../../firmware/support.rs");
/// The board's memory map (mps2-an386), also `targets/`'s.
const MEMORY_X: &str = include_str!("../../firmware/memory.x");

/// The firmware crate's name, and its image's.
const NAME: &str = "stateforge-measure";

/// Longest a run may take before it counts as hung.
const TIMEOUT: Duration = Duration::from_secs(600);

/// What the firmware reported of one call: `call <index> <mean> <stack> <refused>
/// [<first refused result>]`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Counted {
    /// The call's index in the harness.
    pub index: usize,
    /// Mean instructions per call, counted.
    pub mean: u32,
    /// Deepest stack of one call, in bytes.
    pub stack: u32,
    /// Calls whose result said they did not take their data.
    pub refused: u32,
    /// The first such result, as its `Debug` prints it.
    pub first_refused: Option<String>,
}

/// The crate's manifest: the runtime crates, and the release profile the cost table's
/// firmware uses (opt-level 3, fat LTO, one codegen unit; symbols for the trace).
fn manifest() -> String {
    format!(
        "# Written by stateforge-codegen measure: the firmware that measures a model's calls.\n\
         [package]\nname = \"{NAME}\"\nversion = \"0.1.0\"\nedition = \"2021\"\npublish = false\n\n\
         [dependencies]\n\
         cortex-m = {{ version = \"0.7\", features = [\"critical-section-single-core\"] }}\n\
         cortex-m-rt = \"0.7\"\ncortex-m-semihosting = \"0.5\"\n\
         panic-semihosting = {{ version = \"0.6\", features = [\"exit\"] }}\n\
         stateforge-math = {}\n\n\
         [profile.release]\nopt-level = 3\nlto = \"fat\"\ncodegen-units = 1\ndebug = true\n\n\
         # Its own workspace, wherever the work directory is.\n[workspace]\n",
        crate::math_dependency()
    )
}

/// Where the linker finds `memory.x`.
const BUILD_RS: &str = "fn main() {\n    \
    let out = std::path::PathBuf::from(std::env::var_os(\"OUT_DIR\").expect(\"OUT_DIR\"));\n    \
    std::fs::copy(\"memory.x\", out.join(\"memory.x\")).expect(\"memory.x\");\n    \
    println!(\"cargo:rustc-link-search={}\", out.display());\n    \
    println!(\"cargo:rerun-if-changed=memory.x\");\n}\n";

/// Writes the crate into `dir` (a file only where its text changed, so that a second run
/// rebuilds only what did), with `generated` the model's code and `main` the harness.
pub fn write(dir: &Path, generated: &str, main: &str) -> Result<(), String> {
    let files = [
        ("Cargo.toml", manifest()),
        ("build.rs", BUILD_RS.to_owned()),
        ("memory.x", MEMORY_X.to_owned()),
        ("src/main.rs", main.to_owned()),
        ("src/measure.rs", MEASURE_RS.to_owned()),
        ("src/support.rs", SUPPORT_RS.to_owned()),
        ("src/generated.rs", generated.to_owned()),
    ];
    std::fs::create_dir_all(dir.join("src"))
        .map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    for (name, text) in files {
        let path = dir.join(name);
        if std::fs::read_to_string(&path).is_ok_and(|old| old == text) {
            continue;
        }
        std::fs::write(&path, text).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    }
    Ok(())
}

/// Builds the crate in `dir` in release for the Cortex-M4F; returns the image.
pub fn build(dir: &Path) -> Result<PathBuf, String> {
    let target_dir = dir.join("target");
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let mut command = Command::new(cargo);
    command
        .args(["build", "--release", "--target", TARGET, "--target-dir"])
        .arg(&target_dir)
        .current_dir(dir)
        // The firmware's flags are its own: the caller's would replace them.
        .env_remove("RUSTFLAGS")
        .env_remove("CARGO_ENCODED_RUSTFLAGS")
        .env(
            "CARGO_TARGET_THUMBV7EM_NONE_EABIHF_RUSTFLAGS",
            "-C link-arg=-Tlink.x",
        );
    super::setup::run(
        &format!("building the measuring firmware in {}", dir.display()),
        &mut command,
    )?;
    Ok(target_dir.join(TARGET).join("release").join(NAME))
}

/// Runs `elf` under QEMU with one instruction per virtual nanosecond (`-icount shift=0`,
/// which the harness's counter needs), and reads its `call` lines; fails on a non-zero
/// exit, a timeout, or a run that stopped before `done`.
pub fn run(elf: &Path) -> Result<Vec<Counted>, String> {
    let mut child = Command::new("qemu-system-arm")
        .args(MACHINE)
        .args(ICOUNT)
        .arg("-kernel")
        .arg(elf)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| format!("cannot start qemu-system-arm: {e}"))?;
    let read = |pipe: Option<Box<dyn std::io::Read + Send>>| {
        std::thread::spawn(move || {
            let mut text = String::new();
            if let Some(mut pipe) = pipe {
                let _ = pipe.read_to_string(&mut text);
            }
            text
        })
    };
    let stdout = read(child.stdout.take().map(|p| Box::new(p) as _));
    let stderr = read(child.stderr.take().map(|p| Box::new(p) as _));
    let started = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().map_err(|e| e.to_string())? {
            break status;
        }
        if started.elapsed() > TIMEOUT {
            let _ = child.kill();
            return Err(format!(
                "the measuring firmware did not finish within {TIMEOUT:?}"
            ));
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    let output = stdout.join().unwrap_or_default();
    let errors = stderr.join().unwrap_or_default();
    if !status.success() || !output.lines().any(|l| l == "done") {
        return Err(format!(
            "the measuring firmware failed ({status}); it printed:\n{output}{errors}"
        ));
    }
    output.lines().filter_map(counted).collect()
}

/// A `call ..` line, read; `None` for any other line.
fn counted(line: &str) -> Option<Result<Counted, String>> {
    let rest = line.strip_prefix("call ")?;
    let words: Vec<&str> = rest.splitn(5, ' ').collect();
    let numbers: Option<Vec<u32>> = words.iter().take(4).map(|w| w.parse().ok()).collect();
    Some(match numbers.as_deref() {
        Some(&[index, mean, stack, refused]) => Ok(Counted {
            index: index as usize,
            mean,
            stack,
            refused,
            first_refused: words.get(4).map(|w| (*w).to_owned()),
        }),
        _ => Err(format!("a bad line from the firmware: `{line}`")),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn call_lines_are_read() {
        let line = "call 2 415 232 3 DkfStatus { window: Filling, akf: Ok, lkf: Ok }";
        let c = counted(line).expect("a call line").expect("well formed");
        assert_eq!((c.index, c.mean, c.stack, c.refused), (2, 415, 232, 3));
        assert_eq!(
            c.first_refused.as_deref(),
            Some("DkfStatus { window: Filling, akf: Ok, lkf: Ok }")
        );
        let plain = counted("call 0 11 64 0").expect("a call line");
        assert_eq!(plain.expect("well formed").first_refused, None);
        assert!(counted("done").is_none());
        assert!(counted("call x").expect("a call line").is_err());
    }
}
