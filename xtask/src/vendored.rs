//! The check that vendored generated code is as clean as hand-written code: every demo
//! model and model file through `stateforge-codegen`, into one user crate outside the
//! workspace, which must pass `cargo fmt --check`, build with `-D warnings` and pass
//! clippy with `-D warnings` and its pedantic group, with no lint allowed by the crate.

use crate::scratch::{workspace_root, Scratch};
use std::path::{Path, PathBuf};

/// Test models whose generated code no demo model or model file covers: vectors and
/// rotations, the error-state EKF, input noise (with a sample interval too), the delayed
/// fusion horizon (with a delay given at run time too).
const TEST_MODELS: [&str; 7] = [
    "ahrs",
    "dead_reckoning",
    "dead_reckoning_timed",
    "vehicle_geometry",
    "delayed_fix",
    "varying_delay",
    "planar_limits",
];

/// The model sources vendored: the demo models (`model!` invocations), the model files and
/// [`TEST_MODELS`].
fn models(root: &Path) -> Result<Vec<(String, PathBuf)>, String> {
    let mut models = Vec::new();
    for (dir, prefix) in [
        ("generated-demo/models", "demo"),
        ("model-codegen/models", "file"),
    ] {
        let entries =
            std::fs::read_dir(root.join(dir)).map_err(|e| format!("cannot list {dir}: {e}"))?;
        for entry in entries {
            let path = entry.map_err(|e| format!("cannot list {dir}: {e}"))?.path();
            let is_model = path.extension().is_some_and(|e| e == "rs" || e == "toml");
            if let (true, Some(stem)) = (is_model, path.file_stem()) {
                models.push((format!("{prefix}_{}", stem.to_string_lossy()), path));
            }
        }
    }
    for name in TEST_MODELS {
        let path = root.join("tests/models").join(format!("{name}.rs"));
        models.push((format!("test_{name}"), path));
    }
    models.sort();
    Ok(models)
}

/// Vendors every model with `stateforge-codegen -o` and checks the crate they make.
pub fn check() -> Result<String, String> {
    let root = workspace_root();
    let models = models(&root)?;
    let lib = format!(
        "//! Every demo model and model file, vendored with `stateforge-codegen`.\n\
         #![no_std]\n#![forbid(unsafe_code)]\n\n{}",
        models
            .iter()
            .map(|(module, _)| format!("pub mod {module};\n"))
            .collect::<String>()
    );
    let vendored = Scratch::new(
        "vendored-models",
        // The workspace's minimum Rust version (xtask inherits it).
        Some(env!("CARGO_PKG_RUST_VERSION")),
        &format!(
            "stateforge-math = {{ path = {:?} }}",
            root.join("stateforge-math").display().to_string()
        ),
        &[("src/lib.rs", lib)],
        Some(&root.join("Cargo.lock")),
    )?;
    if let Err(message) = vendor_and_check(&root, &models, &vendored) {
        return Err(format!("{message}; {}", vendored.keep()));
    }
    Ok(format!(
        "{} vendored models pass rustfmt --check, -D warnings and clippy (pedantic too)",
        models.len()
    ))
}

/// Vendors `models` into the `vendored` crate, then formats, builds and lints it.
fn vendor_and_check(
    root: &Path,
    models: &[(String, PathBuf)],
    vendored: &Scratch,
) -> Result<(), String> {
    for (module, source) in models {
        crate::command::run(
            &format!("vendoring {}", source.display()),
            crate::command::cargo()
                .current_dir(root)
                .args(["run", "--quiet", "--package", "stateforge-cli", "--"])
                .arg(source)
                .arg("-o")
                .arg(vendored.dir.join("src").join(format!("{module}.rs"))),
        )?;
    }
    crate::command::run(
        "rustfmt --check on the vendored models",
        vendored.cargo().args(["fmt", "--", "--check"]),
    )?;
    crate::command::run(
        "the vendored models build with -D warnings",
        vendored
            .cargo()
            .args(["build", "--offline"])
            .env("RUSTFLAGS", "-D warnings"),
    )?;
    // A user's crate may deny clippy's pedantic group: the vendored code must pass it too
    // (the lints it trips by design are allowed in each file, by the tool).
    crate::command::run(
        "clippy -D warnings -W clippy::pedantic on the vendored models",
        vendored.cargo().args([
            "clippy",
            "--offline",
            "--",
            "-D",
            "warnings",
            "-W",
            "clippy::pedantic",
        ]),
    )?;
    Ok(())
}
