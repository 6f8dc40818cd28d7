//! TinyMPC as a peer: its code generated for the blade's QP (`peers/tinympc_codegen.py`,
//! a fixed model: see there), then built with `arm-none-eabi-g++ -O2` for the Cortex-M4F
//! into its own small firmware (`peers/firmware/`: startup, linker script and the
//! measuring harness, written by the project), not into the Rust `no_std` firmware:
//! TinyMPC's generated C++ needs a C/C++ runtime (heap-allocated Eigen matrices built by
//! static constructors), which newlib-nano gives it here (`--specs=nano.specs
//! --specs=rdimon.specs`: malloc, semihosting I/O and exit).
//!
//! Two documented edits of the generated code, made here on the copy in `target/peers`:
//! `typedef double tinytype` becomes `float` (TinyMPC 0.0.8's code generator always
//! writes double; the typedef is its only precision switch, and the FPU is single
//! precision), and the `std::cout` line its solve prints on convergence is removed, with
//! the `<iostream>` includes (nothing else uses them), so the measured solve does no I/O
//! and the build needs no exceptions (`-fno-exceptions -fno-rtti`).

use crate::peers_build;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

/// The clock of the Rust firmware's runner (`targets/.cargo/config.toml`), after the
/// board's machine (`stateforge_cli::measure::MACHINE`): one nanosecond per instruction;
/// then the image (`MACHINE` no longer ends with `-kernel`: without it QEMU takes the ELF
/// for a disk and runs nothing).
pub const ICOUNT: [&str; 3] = ["-icount", "shift=0,align=off,sleep=off", "-kernel"];

/// What TinyMPC was handed and how it was tuned, printed under the rows.
pub const TERMS: &str = "TinyMPC: a fixed model, the generated MPC's prediction model \
     (A, B) at the first estimate (the blade's mass changes at step 150; TinyMPC's \
     cached Riccati gain cannot follow), Q = diag(1, 0) and R = 1e-10 times 1/R, N = 11 \
     knot points (10 moves), +-100 V, x0 the estimate's regulated states; its terminal \
     weight its own cached Pinf (the DARE of Q + rho I, R + rho I); float (the generated \
     `tinytype` typedef edited from double), rho 1 (fixed, no adaptive rho), abs_pri_tol \
     = abs_dua_tol = 1e-3, max_iter 500, termination checked every iteration, warm start \
     from the last solve's iterates; its solve's std::cout line removed. d own: from the \
     exact solution of that fixed-model QP (desktop OSQP, f64, 1e-10, polished), its \
     accuracy apart from the model mismatch";

/// Generates, patches and links TinyMPC's firmware; the ELF.
pub fn build(root: &Path, python: &Path, problem: &Path, dir: &Path) -> Result<PathBuf, String> {
    let script = root.join("peers/tinympc_codegen.py");
    let generated = dir.join("tinympc");
    let _ = std::fs::remove_dir_all(&generated);
    // The script prints its own note when TinyMPC's codegen fails to build its Python
    // extension (cmake), after the sources are written: the sources decide.
    let codegen = peers_build::generate(python, &script, problem, dir);
    if !generated.join("src/tiny_data.cpp").exists() || !generated.join("peer_steps.h").exists() {
        return Err(format!(
            "its code generation failed: {}",
            codegen.err().unwrap_or_default()
        ));
    }
    // Its summary lines (the desktop OSQP of the reference solves prints notes of its own).
    for line in codegen.unwrap_or_default().lines() {
        if line.starts_with("tinympc") {
            println!("xtask: {line}");
        }
    }
    patch(&generated)?;
    let firmware = root.join("peers/firmware");
    let startup = peers_build::compile(
        "arm-none-eabi-gcc",
        &[firmware.join("startup.c")],
        &[],
        &dir.join("obj/firmware"),
    )?;
    let sources: Vec<PathBuf> = [
        "src/tiny_data.cpp",
        "tinympc/admm.cpp",
        "tinympc/rho_benchmark.cpp",
    ]
    .iter()
    .map(|f| generated.join(f))
    .chain([firmware.join("tinympc_main.cpp")])
    .collect();
    let mut options: Vec<String> = ["include", "include/Eigen", "tinympc", ""]
        .map(|sub| format!("-I{}", generated.join(sub).display()))
        .to_vec();
    options.extend(["-fno-exceptions".into(), "-fno-rtti".into()]);
    let mut objects = peers_build::compile(
        "arm-none-eabi-g++",
        &sources,
        &options,
        &dir.join("obj/tinympc"),
    )?;
    objects.extend(startup);
    let elf = dir.join("tinympc.elf");
    link(&firmware, &objects, &elf)?;
    Ok(elf)
}

/// Links the peers' C/C++ firmware from `objects` with newlib-nano and the firmware's
/// linker script (`firmware`/link.ld) into `elf`.
pub fn link(firmware: &Path, objects: &[PathBuf], elf: &Path) -> Result<(), String> {
    let output = Command::new("arm-none-eabi-g++")
        .args(peers_build::CFLAGS)
        .args([
            "-nostartfiles",
            "--specs=nano.specs",
            "--specs=rdimon.specs",
        ])
        .args(["-Wl,--gc-sections", "-u", "_printf_float", "-T"])
        .arg(firmware.join("link.ld"))
        .args(objects)
        .arg("-o")
        .arg(elf)
        .output()
        .map_err(|e| format!("cannot run arm-none-eabi-g++: {e}"))?;
    if !output.status.success() {
        let error = String::from_utf8_lossy(&output.stderr);
        let lines: Vec<&str> = error.lines().take(6).collect();
        return Err(format!(
            "linking its firmware (newlib-nano: apt-get install libnewlib-arm-none-eabi \
             libstdc++-arm-none-eabi-newlib): {}",
            lines.join("\n  ")
        ));
    }
    Ok(())
}

/// The two edits of the generated code (see the module's doc).
pub fn patch(generated: &Path) -> Result<(), String> {
    let edit = |file: &Path, from: &str, to: &str| -> Result<(), String> {
        let text = std::fs::read_to_string(file).map_err(|e| format!("{}: {e}", file.display()))?;
        if !text.contains(from) {
            return Err(format!(
                "{}: no `{from}` to edit (another TinyMPC version?)",
                file.display()
            ));
        }
        std::fs::write(file, text.replace(from, to)).map_err(|e| format!("{}: {e}", file.display()))
    };
    for types in ["tinympc/types.hpp", "include/tinympc/types.hpp"] {
        edit(
            &generated.join(types),
            "typedef double tinytype;",
            "typedef float tinytype;",
        )?;
    }
    let admm = generated.join("tinympc/admm.cpp");
    edit(
        &admm,
        "std::cout << \"Solver converged in \" << solver->work->iter << \" iterations\" << std::endl;",
        "",
    )?;
    edit(&admm, "#include <iostream>", "")?;
    edit(
        &generated.join("tinympc/rho_benchmark.cpp"),
        "#include <iostream>",
        "",
    )
}

/// Runs TinyMPC's firmware under QEMU as the Rust firmware runs; its output.
pub fn run(elf: &Path) -> Result<String, String> {
    println!("xtask: TinyMPC's firmware under QEMU");
    let output = Command::new("qemu-system-arm")
        .args(stateforge_cli::measure::MACHINE)
        .args(ICOUNT)
        .arg(elf)
        .stdin(Stdio::null())
        .output()
        .map_err(|e| format!("cannot start qemu-system-arm: {e}"))?;
    peers_build::firmware_lines(&output, "its firmware under QEMU")
}

/// The exact plans of TinyMPC's own fixed-model QP (`tinympc_reference.json`).
pub fn reference(dir: &Path) -> Result<Vec<Vec<f64>>, String> {
    let path = dir.join("tinympc_reference.json");
    crate::peers_table::plans(&crate::peers_table::json(&path)?, "plans", &path)
}
