//! Measuring generated code on an emulated Cortex-M4F: the host side of the harness, shared
//! with the project's `cargo xtask`: [`program`] (the image's functions and instructions),
//! [`trace`] (following calls through QEMU's log), [`timing`] (the cycles of an
//! instruction) and [`setup`] (installing the Rust target, QEMU and the ARM binutils). Its
//! firmware side is `firmware/measure.rs`.

pub mod program;
pub mod setup;
pub mod timing;
pub mod trace;

/// The Rust target of the Cortex-M4F with its FPU.
pub const TARGET: &str = "thumbv7em-none-eabihf";

/// QEMU's board and core, with semihosting for the firmware's output.
pub const MACHINE: [&str; 7] = [
    "-machine",
    "mps2-an386",
    "-cpu",
    "cortex-m4",
    "-nographic",
    "-semihosting-config",
    "enable=on,target=native",
];

/// The commands measuring runs, with the Debian packages that provide them.
pub const TOOLS: &[(&str, &str)] = &[
    ("qemu-system-arm", "qemu-system-arm"),
    ("arm-none-eabi-nm", "binutils-arm-none-eabi"),
    ("arm-none-eabi-objdump", "binutils-arm-none-eabi"),
];
