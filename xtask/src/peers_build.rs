//! What the embedded-QP peers need, installed by the benchmark and never by the product's
//! build: the ARM compiler (`apt-get install gcc-arm-none-eabi ..` when missing), and the
//! peers' Python packages in a venv under `target/peers/venv`, pinned to the versions
//! this benchmark was written against; then their code generated into `target/peers` and
//! compiled with `arm-none-eabi-gcc -O2` for the Cortex-M4F into a static library.

use crate::command::run;
use stateforge_cli::measure::program::Program;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The peers' Python packages, pinned: their code generators' interfaces change between
/// versions.
pub const PACKAGES: [(&str, &str); 4] = [
    ("osqp", "1.1.3"),
    ("tinympc", "0.0.8"),
    ("symforce", "0.12.0"),
    ("daqp", "0.11.0"),
];

/// The compiler's options for the Cortex-M4F, as the issue states them (single-precision
/// FPU, hard-float ABI), plus Thumb code, a section per function (so the linker keeps only
/// what is called) and `-fno-math-errno` (so `sqrtf` is the FPU's `vsqrt.f32`, without the
/// C library's `errno`, which the firmware does not link).
pub const CFLAGS: &[&str] = &[
    "-O2",
    "-mcpu=cortex-m4",
    "-mfpu=fpv4-sp-d16",
    "-mfloat-abi=hard",
    "-mthumb",
    "-ffunction-sections",
    "-fdata-sections",
    "-fno-math-errno",
];

/// The ARM compiler, installed with apt-get if missing; its version line.
pub fn arm_gcc() -> Result<String, String> {
    stateforge_cli::measure::setup::debian_commands(&[
        ("arm-none-eabi-gcc", "gcc-arm-none-eabi"),
        ("arm-none-eabi-g++", "libstdc++-arm-none-eabi-newlib"),
        ("arm-none-eabi-ar", "binutils-arm-none-eabi"),
    ])
    .map_err(|e| format!("the peers need the ARM compiler: {e}"))?;
    version_line(Command::new("arm-none-eabi-gcc").arg("--version"))
}

/// The directory of the ARM toolchain's C math library (newlib's `libm.a`) for
/// [`CFLAGS`]' CPU and ABI, which the firmware links SymForce's code against.
pub fn c_math_library() -> Result<PathBuf, String> {
    let out = Command::new("arm-none-eabi-gcc")
        .args(CFLAGS)
        .arg("-print-file-name=libm.a")
        .output()
        .map_err(|e| format!("cannot run arm-none-eabi-gcc: {e}"))?;
    let path = PathBuf::from(String::from_utf8_lossy(&out.stdout).trim());
    match path.parent() {
        Some(dir) if path.is_absolute() && path.exists() => Ok(dir.to_owned()),
        _ => Err("arm-none-eabi-gcc knows no libm.a for the Cortex-M4F".into()),
    }
}

fn version_line(command: &mut Command) -> Result<String, String> {
    let out = command
        .output()
        .map_err(|e| format!("cannot run {command:?}: {e}"))?;
    Ok(String::from_utf8_lossy(&out.stdout)
        .lines()
        .next()
        .unwrap_or("?")
        .to_owned())
}

/// The venv's Python, with the peers' packages installed (pip, from PyPI) if missing.
pub fn python(dir: &Path) -> Result<PathBuf, String> {
    let venv = dir.join("venv");
    let python = venv.join("bin/python");
    if !python.exists() {
        run(
            "a Python venv for the peers' code generators",
            Command::new("python3").arg("-m").arg("venv").arg(&venv),
        )
        .map_err(|e| {
            format!("{e}: the peers need python3 with venv (apt-get install python3-venv)")
        })?;
    }
    let wanted: Vec<String> = PACKAGES
        .iter()
        .map(|(name, version)| format!("{name}=={version}"))
        .collect();
    let installed = PACKAGES
        .iter()
        .all(|(name, version)| package_version(&python, name).as_deref() == Ok(version));
    if !installed {
        run(
            &format!("pip install {}", wanted.join(" ")),
            Command::new(&python)
                .args(["-m", "pip", "install", "--quiet"])
                .args(&wanted),
        )
        .map_err(|e| {
            format!("{e}: the peers' Python packages could not be installed (PyPI reachable?)")
        })?;
    }
    Ok(python)
}

/// A package's installed version.
pub fn package_version(python: &Path, name: &str) -> Result<String, String> {
    let out = Command::new(python)
        .args([
            "-c",
            &format!("import importlib.metadata as m; print(m.version('{name}'))"),
        ])
        .output()
        .map_err(|e| format!("cannot run {}: {e}", python.display()))?;
    if !out.status.success() {
        return Err(format!("{name} is not installed"));
    }
    Ok(String::from_utf8_lossy(&out.stdout).trim().to_owned())
}

/// Runs a peer's generator script (`peers/<script>`) on the problem, writing into `out`;
/// its output, or its error.
pub fn generate(
    python: &Path,
    script: &Path,
    problem: &Path,
    out: &Path,
) -> Result<String, String> {
    let output = Command::new(python)
        .arg(script)
        .arg(problem)
        .arg(out)
        .output()
        .map_err(|e| format!("cannot run {}: {e}", script.display()))?;
    let text = String::from_utf8_lossy(&output.stdout).into_owned();
    if output.status.success() {
        Ok(text)
    } else {
        Err(format!(
            "{} failed:\n{text}{}",
            script.display(),
            String::from_utf8_lossy(&output.stderr)
        ))
    }
}

/// Compiles `sources` with `compiler` and [`CFLAGS`] (plus `extra` options) into objects
/// under `objects`; the objects, or the compiler's error.
pub fn compile(
    compiler: &str,
    sources: &[PathBuf],
    extra: &[String],
    objects: &Path,
) -> Result<Vec<PathBuf>, String> {
    std::fs::create_dir_all(objects).map_err(|e| format!("{}: {e}", objects.display()))?;
    let mut built = Vec::new();
    for source in sources {
        let stem = source
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or("source");
        let object = objects.join(format!("{stem}.o"));
        let output = Command::new(compiler)
            .args(CFLAGS)
            .args(extra)
            .arg("-c")
            .arg(source)
            .arg("-o")
            .arg(&object)
            .output()
            .map_err(|e| format!("cannot run {compiler}: {e}"))?;
        if !output.status.success() {
            let error = String::from_utf8_lossy(&output.stderr);
            let first: Vec<&str> = error
                .lines()
                .filter(|l| l.contains("error"))
                .take(5)
                .collect();
            return Err(format!(
                "{compiler} {}: {}",
                source.display(),
                first.join("\n  ")
            ));
        }
        built.push(object);
    }
    Ok(built)
}

/// `libpeers.a` in `dir` from `objects`.
pub fn archive(dir: &Path, objects: &[PathBuf]) -> Result<(), String> {
    let lib = dir.join("libpeers.a");
    let _ = std::fs::remove_file(&lib);
    run(
        "arm-none-eabi-ar: libpeers.a",
        Command::new("arm-none-eabi-ar")
            .arg("rcs")
            .arg(&lib)
            .args(objects),
    )
}

/// The `.c` files directly in `dir`.
pub fn sources(dir: &Path, extension: &str) -> Result<Vec<PathBuf>, String> {
    let mut found: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| format!("{}: {e}", dir.display()))?
        .filter_map(|entry| Some(entry.ok()?.path()))
        .filter(|p| p.extension().is_some_and(|e| e == extension))
        .collect();
    found.sort();
    Ok(found)
}

/// The functions a static library or an object defines (`arm-none-eabi-nm`).
pub fn defined_functions(lib: &Path) -> Result<Vec<String>, String> {
    let out = Command::new("arm-none-eabi-nm")
        .args(["--defined-only", "--demangle"])
        .arg(lib)
        .output()
        .map_err(|e| format!("cannot run arm-none-eabi-nm: {e}"))?;
    Ok(String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|l| {
            let mut words = l.splitn(3, ' ');
            let (_, kind, name) = (words.next()?, words.next()?, words.next()?);
            kind.eq_ignore_ascii_case("t").then(|| name.to_owned())
        })
        .collect())
}

/// OSQP's wrapper (`peers_osqp_solve`, when `program` has it) made to reach every
/// function of OSQP's `objects` the program holds: OSQP dispatches to its linear-system
/// solver through function pointers, which the disassembly's call graph does not follow.
pub fn osqp_reaches_its_objects(program: &mut Program, objects: &[PathBuf]) -> Result<(), String> {
    let Some(wrapper) = program.function("peers_osqp_solve") else {
        return Ok(());
    };
    let mut linked = Vec::new();
    for object in objects {
        linked.extend(
            defined_functions(object)?
                .into_iter()
                .filter(|f| program.functions.contains_key(f)),
        );
    }
    program.add_calls(&wrapper, linked);
    Ok(())
}

/// The printed lines of a firmware run under QEMU, if it exited cleanly and printed `done`;
/// else an error naming `what` with its last lines.
pub fn firmware_lines(output: &std::process::Output, what: &str) -> Result<String, String> {
    let text = String::from_utf8_lossy(&output.stdout).into_owned();
    if !output.status.success() || !text.lines().any(|l| l == "done") {
        let tail: Vec<&str> = text.lines().rev().take(5).collect();
        return Err(format!(
            "{what} failed ({}); its last lines: {tail:?}",
            output.status
        ));
    }
    Ok(text)
}
