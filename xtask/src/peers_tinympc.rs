//! TinyMPC as a peer: its code generated for the blade's QP (`peers/tinympc_codegen.py`,
//! a fixed model: see there) and compiled with `arm-none-eabi-g++ -O2` for the
//! Cortex-M4F. Whether it can then be linked into the firmware is decided from the
//! compiled objects themselves: every symbol they leave undefined must be one the
//! firmware provides (the Rust `no_std` image has no heap, no C++ runtime, exceptions or
//! iostreams, and cortex-m-rt runs no static constructors). TinyMPC 0.0.8's generated
//! code needs all of those (its matrices are heap-allocated Eigen matrices built by
//! static constructors, and its solve prints through `std::cout`), so it is reported as
//! not buildable here, with the symbols and the compiler's evidence.

use crate::peers_build;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Symbols the firmware provides to linked C code (compiler-builtins' memory routines and
/// the ARM EABI's floating-point helpers).
fn provided(symbol: &str) -> bool {
    matches!(symbol, "memcpy" | "memset" | "memmove" | "memcmp")
        || symbol.starts_with("__aeabi_d")
        || symbol.starts_with("__aeabi_f")
        || symbol.starts_with("__aeabi_mem")
}

/// Why the generated TinyMPC cannot run here (see the module's doc).
pub fn build(root: &Path, python: &Path, problem: &Path, dir: &Path) -> Result<(), String> {
    let script = root.join("peers/tinympc_codegen.py");
    let generated = dir.join("tinympc");
    let _ = std::fs::remove_dir_all(&generated);
    // TinyMPC's codegen writes the C++ sources, then builds a Python extension of them
    // with cmake; only the sources are needed, so that step's failure is noted, not fatal.
    let codegen = peers_build::generate(python, &script, problem, dir);
    let data = generated.join("src/tiny_data.cpp");
    if !data.exists() {
        return Err(format!(
            "its code generation failed: {}",
            codegen.err().unwrap_or_default()
        ));
    }
    let sources: Vec<PathBuf> = [
        "src/tiny_data.cpp",
        "tinympc/admm.cpp",
        "tinympc/rho_benchmark.cpp",
    ]
    .iter()
    .map(|f| generated.join(f))
    .collect();
    let includes = ["include", "include/Eigen", "tinympc", ""]
        .map(|sub| format!("-I{}", generated.join(sub).display()));
    let objects = peers_build::compile(
        "arm-none-eabi-g++",
        &sources,
        &includes,
        &dir.join("obj/tinympc"),
    )?;
    let missing = undefined(&objects)?;
    let precision = std::fs::read_to_string(generated.join("tinympc/types.hpp"))
        .unwrap_or_default()
        .contains("typedef double tinytype");
    if missing.is_empty() {
        return Err(format!(
            "compiled ({} objects) and nothing it needs is missing, but the firmware has no \
             call into this version's API yet (no glue in peers/)",
            objects.len()
        ));
    }
    Err(format!(
        "compiled with arm-none-eabi-g++ -O2 ({} objects), but they need what the no_std \
         firmware does not have: {} (heap-allocated Eigen matrices built by static \
         constructors, C++ exceptions, std::cout in its solve; cortex-m-rt runs no static \
         constructors){}",
        objects.len(),
        missing.join(", "),
        if precision {
            "; and its generated tinytype is double (no single precision in this version)"
        } else {
            ""
        }
    ))
}

/// The symbols `objects` leave undefined, among each other, that the firmware lacks.
fn undefined(objects: &[PathBuf]) -> Result<Vec<String>, String> {
    let symbols = |flag: &str| -> Result<Vec<String>, String> {
        let out = Command::new("arm-none-eabi-nm")
            .args([flag, "--demangle"])
            .args(objects)
            .output()
            .map_err(|e| format!("cannot run arm-none-eabi-nm: {e}"))?;
        Ok(String::from_utf8_lossy(&out.stdout)
            .lines()
            .filter_map(|l| {
                l.trim()
                    .split_once(' ')
                    .map(|(_, name)| name.trim().to_owned())
            })
            .collect())
    };
    let defined: Vec<String> = symbols("--defined-only")?
        .into_iter()
        .filter_map(|l| l.split_once(' ').map(|(_, n)| n.to_owned()))
        .collect();
    let mut missing: Vec<String> = symbols("--undefined-only")?
        .into_iter()
        .filter(|s| !defined.contains(s) && !provided(s))
        .map(|s| s.split('(').next().unwrap_or(&s).to_owned())
        .collect();
    missing.sort();
    missing.dedup();
    Ok(missing)
}
