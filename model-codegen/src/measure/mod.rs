//! Measuring a model's generated calls on an emulated Cortex-M4F, as the project's cost
//! table measures its own (`stateforge-codegen measure`): the model's `f32` code in a
//! small firmware that calls each of its types' calls on deterministic data, run under
//! QEMU (`mps2-an386`) once with an instruction counter and once traced instruction by
//! instruction; per call, the instructions (median, worst, mean), the traced cycles beside
//! the static estimate (`*_CYCLES`), the stack and the code size.
//!
//! The host side of the harness lives here, shared with the project's `cargo xtask`:
//! [`program`] (the image's functions and instructions), [`trace`] (following calls through
//! QEMU's log), [`timing`] (the cycles of an instruction) and [`setup`] (installing the
//! Rust target, QEMU and the ARM binutils). Its firmware side is `firmware/measure.rs`.

mod api;
pub mod board;
mod firmware;
mod harness;
pub mod program;
pub mod setup;
mod table;
pub mod timing;
pub mod trace;

pub use board::{ICOUNT, MACHINE, TARGET, TOOLS};
use stateforge_compiler::model::Model;
use std::path::PathBuf;

/// How to measure.
#[derive(Clone, Debug)]
pub struct Options {
    /// Samples of the run: each call is run and read this many times.
    pub samples: usize,
    /// Where the firmware crate is written and built (kept, so that a second run of the
    /// same model rebuilds little).
    pub work_dir: PathBuf,
}

/// The most samples a run may have: each call's readings are kept on the firmware's
/// stack (4 bytes a sample).
pub const MAX_SAMPLES: usize = 1000;

/// Measures the calls of `code`, the module generated for `model` (unformatted or
/// formatted Rust, as `stateforge_cli::format` writes it), and returns the table. Installs
/// the Rust target and, with apt-get, QEMU and the ARM binutils when they are missing; an
/// error says what is missing where it cannot.
pub fn measure(model: &Model, code: &str, options: &Options) -> Result<String, String> {
    if !(1..=MAX_SAMPLES).contains(&options.samples) {
        return Err(format!(
            "the samples are 1 to {MAX_SAMPLES}, not {}",
            options.samples
        ));
    }
    let api = api::read(code)?;
    let harness = harness::write(&api, model, options.samples)?;
    setup::rust_target(TARGET)?;
    setup::debian_commands(TOOLS)?;
    firmware::write(&options.work_dir, code, &harness.main)?;
    let elf = firmware::build(&options.work_dir)?;
    eprintln!("running it under QEMU");
    let counted = firmware::run(&elf)?;
    let program = program::Program::read(&elf)?;
    let wrappers = harness
        .calls
        .iter()
        .map(|c| {
            program
                .function(&c.wrapper)
                .ok_or_else(|| format!("no `{}` in the measuring firmware", c.wrapper))
        })
        .collect::<Result<Vec<_>, _>>()?;
    eprintln!("running it again, traced instruction by instruction (cycle estimates)");
    let traced = trace::run(&elf, &program, &wrappers)?;
    let subject = table::Subject {
        model: &model.name,
        samples: options.samples,
    };
    table::render(&subject, &api, &harness.calls, &counted, &program, &traced)
}
