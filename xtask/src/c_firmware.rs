//! The C firmware (`targets/c/main.c`): the cantilever's EKF and LQR and the navigation
//! EKF called from a C `main` through their C API, as a C team would build it: the
//! companion crates written by `stateforge-codegen c-api`, their static libraries built
//! for the Cortex-M4F, the firmware compiled with `arm-none-eabi-gcc` on the peers'
//! startup and linker script (`peers/firmware/`) and linked against them, then run under
//! QEMU as the Rust firmware is. Its `bits` lines must be the Rust firmware's, bit for
//! bit (the same runs, `targets/src/c_api.rs`), and its `capi` lines are the instructions
//! per call through the C API, for the cost table beside the Rust calls'.
//!
//! Everything is built under `target/c-firmware/`; the data both firmwares run on is
//! written as C from `targets/data.rs`, which the Rust firmware's build script embeds.

use crate::command::{cargo, run};
use crate::peers_build;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

/// The data both firmwares run on.
#[path = "../../targets/data.rs"]
mod data;

/// The models the firmware calls, each a companion crate and a static library.
const MODELS: [&str; 2] = ["cantilever", "navigation"];

/// What the C firmware needs beyond the Rust firmware's tools: the ARM compiler and
/// newlib (its `nano` and `rdimon` specs: `printf` and `exit` through semihosting).
const TOOLS: &[(&str, &str)] = &[
    ("arm-none-eabi-gcc", "gcc-arm-none-eabi"),
    ("arm-none-eabi-ar", "binutils-arm-none-eabi"),
];

/// What the C firmware printed.
#[derive(Debug, Default)]
pub struct Report {
    /// The `bits ..` lines, in order.
    pub bits: Vec<String>,
    /// `capi <kernel> <instructions>`: instructions per call through the C API.
    pub costs: Vec<(String, u32)>,
}

/// Installs the ARM compiler if it is missing (as the peers do); an error saying what to
/// install where that is impossible.
pub fn toolchain() -> Result<(), String> {
    stateforge_cli::measure::setup::debian_commands(TOOLS)
        .map_err(|e| format!("the C firmware needs the ARM compiler and newlib: {e}"))
}

/// Builds the C firmware and runs it under QEMU; what it printed.
pub fn run_firmware(root: &Path) -> Result<Report, String> {
    let dir = root.join("target/c-firmware");
    let mut libraries = Vec::new();
    for model in MODELS {
        libraries.push(static_library(root, &dir, model)?);
    }
    let elf = link(root, &dir, &libraries)?;
    println!("xtask: the C firmware under QEMU");
    let output = Command::new("qemu-system-arm")
        .args(stateforge_cli::measure::MACHINE)
        .args(stateforge_cli::measure::ICOUNT)
        .arg("-kernel")
        .arg(&elf)
        .stdin(Stdio::null())
        .output()
        .map_err(|e| format!("cannot start qemu-system-arm: {e}"))?;
    parse(&peers_build::firmware_lines(&output, "the C firmware")?)
}

/// The companion crate of `model` written by the CLI into `dir`, and its static library
/// built for the Cortex-M4F; the library's directory.
fn static_library(root: &Path, dir: &Path, model: &str) -> Result<PathBuf, String> {
    let crate_dir = dir.join(format!("{model}-c"));
    run(
        &format!("stateforge-codegen c-api {model}"),
        cargo()
            .args([
                "run",
                "--quiet",
                "--package",
                "stateforge-cli",
                "--",
                "c-api",
            ])
            .arg(root.join(format!("generated-demo/models/{model}.rs")))
            .arg("--out-dir")
            .arg(&crate_dir)
            .current_dir(root),
    )?;
    let target_dir = dir.join("target");
    run(
        &format!("the static library of {model} for the Cortex-M4F"),
        cargo()
            .args(["build", "--release", "--quiet", "--target"])
            .arg(stateforge_cli::measure::TARGET)
            .arg("--target-dir")
            .arg(&target_dir)
            .current_dir(&crate_dir)
            // The library as a C team builds it: none of this workspace's flags.
            .env_remove("RUSTFLAGS")
            .env_remove("CARGO_ENCODED_RUSTFLAGS")
            .env_remove("CARGO_TARGET_THUMBV7EM_NONE_EABIHF_RUSTFLAGS"),
    )?;
    Ok(target_dir.join(format!(
        "{}/release/lib{model}_c.a",
        stateforge_cli::measure::TARGET
    )))
}

/// The firmware compiled (its data written as C first) and linked against `libraries`
/// with newlib-nano and semihosting; the image.
fn link(root: &Path, dir: &Path, libraries: &[PathBuf]) -> Result<PathBuf, String> {
    let include = dir.join("include");
    std::fs::create_dir_all(&include).map_err(|e| format!("{}: {e}", include.display()))?;
    let header = include.join("firmware_data.h");
    std::fs::write(&header, data_header()).map_err(|e| format!("{}: {e}", header.display()))?;
    let peers = root.join("peers/firmware");
    let objects = dir.join("obj");
    let mut built = peers_build::compile(
        "arm-none-eabi-gcc",
        &[peers.join("startup.c")],
        &[],
        &objects,
    )?;
    // The firmware as strictly as the C API's header promises to compile.
    let mut options: Vec<String> = ["-std=c99", "-Wall", "-Wextra", "-Wpedantic", "-Werror"]
        .map(String::from)
        .to_vec();
    for path in [include, peers]
        .into_iter()
        .chain(MODELS.map(|m| dir.join(format!("{m}-c/include"))))
    {
        options.push(format!("-I{}", path.display()));
    }
    built.extend(peers_build::compile(
        "arm-none-eabi-gcc",
        &[root.join("targets/c/main.c")],
        &options,
        &objects,
    )?);
    let elf = dir.join("c-firmware.elf");
    let output = Command::new("arm-none-eabi-gcc")
        .args(peers_build::CFLAGS)
        .args([
            "-nostartfiles",
            "--specs=nano.specs",
            "--specs=rdimon.specs",
        ])
        .args(["-Wl,--gc-sections", "-T"])
        .arg(root.join("peers/firmware/link.ld"))
        .args(&built)
        .args(libraries)
        .args(["-lm", "-o"])
        .arg(&elf)
        .output()
        .map_err(|e| format!("cannot run arm-none-eabi-gcc: {e}"))?;
    if !output.status.success() {
        let error = String::from_utf8_lossy(&output.stderr);
        let lines: Vec<&str> = error.lines().take(6).collect();
        return Err(format!(
            "linking the C firmware (newlib-nano: apt-get install libnewlib-arm-none-eabi): {}",
            lines.join("\n  ")
        ));
    }
    Ok(elf)
}

/// `values` as a C initialiser of `float`: each the shortest decimal that reads back as
/// the same `f32` (Rust's `{:?}`), which the C compiler rounds to that `f32`.
fn floats(values: &[f32]) -> String {
    let items: Vec<String> = values.iter().map(|v| format!("{v:?}f")).collect();
    format!("{{{}}}", items.join(", "))
}

/// The data of `targets/data.rs` as C: the measured sequence, and the navigation flight
/// with the magnetometer's gate.
fn data_header() -> String {
    let mut c = String::from(
        "/* Written by `cargo xtask` from targets/data.rs: the data the Rust firmware runs on. */\n",
    );
    let (u, y): (Vec<f32>, Vec<f32>) = data::sequence().into_iter().unzip();
    let _ = writeln!(
        c,
        "#define SEQUENCE_SAMPLES {}\n\
         static const float sequence_u[SEQUENCE_SAMPLES] = {};\n\
         static const float sequence_y[SEQUENCE_SAMPLES] = {};",
        data::SAMPLES,
        floats(&u),
        floats(&y)
    );
    let flight = data::flight();
    let gate = generated_demo::flight::MAGNETOMETER_GATE as f32;
    let _ = writeln!(
        c,
        "#define FLIGHT_MAGNETOMETER_GATE {gate:?}f\n\
         static const float flight_x0[24] = {};\n\
         static const float flight_p0[23] = {};\n\
         static const float flight_q[23] = {};\n\
         static const float flight_r[9] = {};\n\
         #define FLIGHT_SAMPLES {}\n\
         static const float flight_interval[FLIGHT_SAMPLES] = {};\n\
         static const float flight_imu[FLIGHT_SAMPLES][6] = {{{}}};",
        floats(&flight.x0),
        floats(&flight.p0),
        floats(&flight.q),
        floats(&flight.r),
        data::NAVIGATION_SAMPLES,
        floats(&flight.interval),
        flight
            .imu
            .iter()
            .map(|s| floats(s))
            .collect::<Vec<_>>()
            .join(",\n")
    );
    for (name, readings, width) in [
        ("magnetometer", &flight.magnetometer, 3),
        ("gnss", &flight.gnss, 6),
    ] {
        let upper = if name == "gnss" {
            "GNSS_FIXES"
        } else {
            "MAGNETOMETER_READINGS"
        };
        let at: Vec<String> = readings.iter().map(|(k, _)| k.to_string()).collect();
        let values: Vec<String> = readings.iter().map(|(_, v)| floats(v)).collect();
        let _ = writeln!(
            c,
            "#define FLIGHT_{upper} {}\n\
             static const int flight_{name}_at[FLIGHT_{upper}] = {{{}}};\n\
             static const float flight_{name}[FLIGHT_{upper}][{width}] = {{{}}};",
            readings.len(),
            at.join(", "),
            values.join(",\n")
        );
    }
    c
}

/// The report, read from the firmware's lines.
fn parse(text: &str) -> Result<Report, String> {
    let mut report = Report::default();
    for line in text.lines() {
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.as_slice() {
            ["bits", ..] => report.bits.push(line.to_owned()),
            ["capi", kernel, instructions] => report.costs.push((
                (*kernel).to_owned(),
                instructions
                    .parse()
                    .map_err(|_| format!("bad count in `{line}`"))?,
            )),
            _ => {}
        }
    }
    if report.bits.is_empty() || report.costs.is_empty() {
        return Err("the C firmware printed no `bits` or no `capi` lines".into());
    }
    Ok(report)
}

/// Checks the C firmware's `bits` lines against the Rust firmware's: the same lines, in
/// the same order, bit for bit; a summary.
pub fn check(c: &Report, rust: &[String]) -> Result<String, String> {
    if rust.is_empty() {
        return Err("the Rust firmware printed no `bits` lines".into());
    }
    if let Some((c_line, rust_line)) = c.bits.iter().zip(rust).find(|(c, r)| c != r) {
        return Err(format!(
            "the C firmware's results differ from the Rust firmware's: {}",
            first_difference(c_line, rust_line)
        ));
    }
    if c.bits.len() != rust.len() {
        return Err(format!(
            "the C firmware printed {} `bits` lines, the Rust firmware {}",
            c.bits.len(),
            rust.len()
        ));
    }
    let values: usize = rust
        .iter()
        .map(|l| l.split_whitespace().count().saturating_sub(3))
        .sum();
    Ok(format!(
        "the C firmware's {} results (cantilever EKF and LQR, navigation EKF) equal the Rust \
         firmware's bit for bit",
        values
    ))
}

/// Where two `bits <run> <k> ..` lines first differ: the run, the sample, which value,
/// and its bits in each.
fn first_difference(c: &str, rust: &str) -> String {
    let (c, rust): (Vec<&str>, Vec<&str>) = (
        c.split_whitespace().collect(),
        rust.split_whitespace().collect(),
    );
    let at = c.iter().zip(&rust).position(|(a, b)| a != b);
    match at {
        Some(i) if i >= 3 => format!(
            "`{} {}`, value {}: C {}, Rust {}",
            c[1],
            c[2],
            i - 3,
            c[i],
            rust[i]
        ),
        _ => format!(
            "C `{}`, Rust `{}`",
            c[..c.len().min(3)].join(" "),
            rust[..rust.len().min(3)].join(" ")
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn report(bits: &[&str]) -> Report {
        Report {
            bits: bits.iter().map(|l| (*l).to_owned()).collect(),
            costs: vec![("ekf_step".to_owned(), 238)],
        }
    }

    #[test]
    fn equal_lines_pass_and_a_differing_value_is_named() {
        let rust = ["bits cantilever 10 3c23d70a 00000000".to_owned()];
        assert!(check(&report(&["bits cantilever 10 3c23d70a 00000000"]), &rust).is_ok());
        let error = check(&report(&["bits cantilever 10 3c23d70a 80000000"]), &rust)
            .expect_err("-0 is not 0, bit for bit");
        assert!(
            error.contains("`cantilever 10`, value 1: C 80000000, Rust 00000000"),
            "{error}"
        );
        let error = check(&report(&[]), &rust).expect_err("a line missing");
        assert!(error.contains("0 `bits` lines"), "{error}");
    }

    #[test]
    fn the_data_reads_back_as_the_same_floats() {
        assert_eq!(floats(&[0.001, -400.0, 1e-10]), "{0.001f, -400.0f, 1e-10f}");
        let header = data_header();
        assert!(header.contains("#define SEQUENCE_SAMPLES 1000"));
        assert!(header.contains("#define FLIGHT_SAMPLES 1000"));
        assert!(header.contains("static const float flight_interval[FLIGHT_SAMPLES] = {0.00"));
    }

    #[test]
    fn the_firmware_lines_are_read() {
        let text = "bits navigation 100 3f800000\ncapi ekf_step 238\nprose\ndone\n";
        let report = parse(text).expect("a report");
        assert_eq!(report.bits, ["bits navigation 100 3f800000"]);
        assert_eq!(report.costs, [("ekf_step".to_owned(), 238)]);
        assert!(parse("done\n").is_err());
    }
}
