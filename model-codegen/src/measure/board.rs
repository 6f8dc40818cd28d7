//! The emulated board every measurement runs on: the Rust target, QEMU's machine, and the
//! tools the host needs beside them.

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

/// QEMU's clock for measuring: one instruction per virtual nanosecond, which the
/// firmwares' SysTick counters need (40 instructions per tick).
pub const ICOUNT: [&str; 2] = ["-icount", "shift=0,align=off,sleep=off"];

/// The commands measuring runs, with the Debian packages that provide them.
pub const TOOLS: &[(&str, &str)] = &[
    ("qemu-system-arm", "qemu-system-arm"),
    ("arm-none-eabi-nm", "binutils-arm-none-eabi"),
    ("arm-none-eabi-objdump", "binutils-arm-none-eabi"),
];
