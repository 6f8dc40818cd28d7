//! A C API for a model's generated filters and controllers (`stateforge-codegen c-api`):
//! a companion crate the tool writes beside the C program, which builds into a static
//! library and holds the header.
//!
//! ```text
//! <dir>/Cargo.toml          staticlib, no_std, panic = "abort"
//! <dir>/src/lib.rs          the `extern "C"` functions: the only `unsafe` code
//! <dir>/src/support.rs      the pointer checks they share
//! <dir>/model/Cargo.toml    the generated code's own crate, `<model>-model`
//! <dir>/model/src/lib.rs    the generated module, `no_std`, `forbid(unsafe_code)`
//! <dir>/include/<model>.h   the header
//! ```
//!
//! The generated code is a crate of its own, as it is in a Rust firmware (the model's
//! crate beside the firmware's), so that it is compiled as there, instruction for
//! instruction: each C function checks its pointers and ends in a jump to a function
//! that makes the Rust call (`wrapper`), and costs its checks and no more. Compiled as a
//! module of the wrapper's crate instead, the same filter step was given its registers
//! differently, at a dozen instructions more per call.
//!
//! `reading` reads what C can call from the generated code (`values`: the shapes of the
//! values it passes; `records`: the structs and enums it receives), `names` names it in
//! C, `storage` sizes the storage a C program reserves, `wrapper` writes the Rust
//! functions (`mirrors`: the `repr(C)` forms of the records), `header` the C
//! declarations.

mod header;
mod mirrors;
mod names;
mod reading;
mod records;
mod storage;
mod values;
mod wrapper;

use std::path::Path;

/// The pointer checks of every companion crate.
const SUPPORT_RS: &str = include_str!("../../c-api/support.rs");

/// How to write the companion crate.
#[derive(Clone, Debug)]
pub struct Options {
    /// The `stateforge-math` dependency as `Cargo.toml` writes it (`"0.1"`, `{ path =
    /// ".." }`).
    pub math_dependency: String,
    /// The first line of each file: which tool wrote it, from which model.
    pub provenance: String,
}

/// Writes the companion crate of `code` (the model's generated file, formatted, as the
/// tool prints it: its first line says where it came from) into
/// `dir`: its manifest, the wrapper, the generated module and the header. A file is
/// rewritten only where its text changed, so that a build after a second run rebuilds
/// only what did.
pub fn write(code: &str, dir: &Path, options: &Options) -> Result<(), String> {
    let api = reading::read(code)?;
    let files = [
        ("Cargo.toml".to_owned(), manifest(&api.model)),
        (
            "model/Cargo.toml".to_owned(),
            model_manifest(&api.model, &options.math_dependency),
        ),
        (
            "src/lib.rs".to_owned(),
            crate::rustfmt(&wrapper::lib(&api, &options.provenance))?,
        ),
        ("src/support.rs".to_owned(), SUPPORT_RS.to_owned()),
        (
            "model/src/lib.rs".to_owned(),
            format!(
                "#![no_std]\n#![forbid(unsafe_code)]\n//! The `{}` model's generated code, \
                 which the C API in `../src` wraps.\n{code}",
                api.model
            ),
        ),
        (
            format!("include/{}.h", api.model),
            header::header(&api, &options.provenance),
        ),
    ];
    for (name, text) in files {
        let path = dir.join(name);
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent)
                .map_err(|e| format!("cannot create {}: {e}", parent.display()))?;
        }
        if std::fs::read_to_string(&path).is_ok_and(|old| old == text) {
            continue;
        }
        std::fs::write(&path, text).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    }
    remove_former_model_module(dir)
}

/// Removes `src/model.rs`, where the tool wrote the generated code before it became a
/// crate of its own, if that is what the file holds: the wrapper no longer declares it.
fn remove_former_model_module(dir: &Path) -> Result<(), String> {
    let former = dir.join("src/model.rs");
    match std::fs::read_to_string(&former) {
        Ok(text) if text.starts_with("#![forbid(unsafe_code)]\n") => std::fs::remove_file(&former)
            .map_err(|e| format!("cannot remove {}: {e}", former.display())),
        _ => Ok(()),
    }
}

/// The companion crate's package name: the model's, with dashes.
fn package(model: &str) -> String {
    model.replace('_', "-")
}

/// The companion crate's manifest: a static library named after the model
/// (`lib<model>_c.a`) over the model's crate, their own workspace, and profiles that
/// abort on a panic, so that no unwinding runtime is needed (no panic is reachable from
/// the wrappers: every check returns a status).
fn manifest(model: &str) -> String {
    let package = package(model);
    format!(
        "# Written by stateforge-codegen c-api: the C API of the `{model}` model.\n\
         [package]\nname = \"{package}-c\"\nversion = \"0.1.0\"\nedition = \"2021\"\npublish = false\n\n\
         [lib]\nname = \"{model}_c\"\ncrate-type = [\"staticlib\"]\n\n\
         [dependencies]\n{package}-model = {{ path = \"model\" }}\n\n\
         [profile.dev]\npanic = \"abort\"\n\n\
         [profile.release]\npanic = \"abort\"\nopt-level = 3\nlto = \"fat\"\ncodegen-units = 1\n\n\
         # Its own workspace (the model's crate a member), wherever the C program keeps it.\n[workspace]\n"
    )
}

/// The manifest of the model's crate: the generated code and the math it calls.
fn model_manifest(model: &str, math_dependency: &str) -> String {
    format!(
        "# Written by stateforge-codegen c-api: the generated code of the `{model}` model.\n\
         [package]\nname = \"{}-model\"\nversion = \"0.1.0\"\nedition = \"2021\"\npublish = false\n\n\
         [dependencies]\nstateforge-math = {math_dependency}\n",
        package(model)
    )
}
