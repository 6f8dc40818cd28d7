//! A C API for a model's generated filters and controllers (`stateforge-codegen c-api`):
//! a companion crate the tool writes beside the C program, which builds into a static
//! library and holds the header.
//!
//! ```text
//! <dir>/Cargo.toml          staticlib, no_std, panic = "abort"
//! <dir>/src/lib.rs          the `extern "C"` functions: the only `unsafe` code
//! <dir>/src/support.rs      the pointer checks they share
//! <dir>/src/model.rs        the generated module, `forbid(unsafe_code)`
//! <dir>/include/<model>.h   the header
//! ```
//!
//! `reading` reads what C can call from the generated code, `names` names it in C,
//! `storage` sizes the storage a C program reserves, `wrapper` writes the Rust functions,
//! `header` the C declarations.

mod header;
mod names;
mod reading;
mod storage;
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
        (
            "Cargo.toml".to_owned(),
            manifest(&api.model, &options.math_dependency),
        ),
        (
            "src/lib.rs".to_owned(),
            crate::rustfmt(&wrapper::lib(&api, &options.provenance))?,
        ),
        ("src/support.rs".to_owned(), SUPPORT_RS.to_owned()),
        (
            "src/model.rs".to_owned(),
            format!("#![forbid(unsafe_code)]\n{code}"),
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
    Ok(())
}

/// The companion crate's manifest: a static library named after the model
/// (`lib<model>_c.a`), its own workspace, and profiles that abort on a panic, so that no
/// unwinding runtime is needed (the wrappers never panic: the generated code has no
/// indexing, and every check returns a status).
fn manifest(model: &str, math_dependency: &str) -> String {
    format!(
        "# Written by stateforge-codegen c-api: the C API of the `{model}` model.\n\
         [package]\nname = \"{}-c\"\nversion = \"0.1.0\"\nedition = \"2021\"\npublish = false\n\n\
         [lib]\nname = \"{model}_c\"\ncrate-type = [\"staticlib\"]\n\n\
         [dependencies]\nstateforge-math = {math_dependency}\n\n\
         [profile.dev]\npanic = \"abort\"\n\n\
         [profile.release]\npanic = \"abort\"\nopt-level = 3\nlto = \"fat\"\ncodegen-units = 1\n\n\
         # Its own workspace, wherever the C program keeps it.\n[workspace]\n",
        model.replace('_', "-")
    )
}
