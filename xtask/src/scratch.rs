//! Scratch crates: a user's crate outside the workspace, written to a temporary directory
//! with its own target directory, for the checks and benchmarks that build code the way a
//! user's project does.

use std::path::{Path, PathBuf};
use std::process::Command;

/// A crate in a directory of its own, with its own workspace and target directory.
pub struct Scratch {
    /// The crate's root (`Cargo.toml`, `src/`).
    pub dir: PathBuf,
}

impl Scratch {
    /// Writes a crate named `name` with the given `[dependencies]` lines and files (paths
    /// relative to the crate root) into a fresh directory under the system's temporary
    /// directory. `lockfile`, if given, is copied in so the build resolves to the versions
    /// the workspace was tested with, without asking the registry. `rust_version`, if
    /// given, is declared, so clippy's `incompatible_msrv` holds the code to it.
    pub fn new(
        name: &str,
        rust_version: Option<&str>,
        dependencies: &str,
        files: &[(&str, String)],
        lockfile: Option<&Path>,
    ) -> Result<Self, String> {
        let dir = std::env::temp_dir().join(format!("xtask-{name}-{}", std::process::id()));
        if dir.exists() {
            std::fs::remove_dir_all(&dir)
                .map_err(|e| format!("cannot empty {}: {e}", dir.display()))?;
        }
        let rust_version = rust_version
            .map(|v| format!("rust-version = \"{v}\"\n"))
            .unwrap_or_default();
        let manifest = format!(
            "[package]\nname = \"{name}\"\nversion = \"0.1.0\"\nedition = \"2021\"\n\
             {rust_version}publish = false\n\n[dependencies]\n{dependencies}\n\n\
             # Its own workspace: not a member of the one it was written from.\n[workspace]\n"
        );
        let mut all = vec![("Cargo.toml", manifest)];
        all.extend(files.iter().cloned());
        for (path, text) in all {
            let path = dir.join(path);
            if let Some(parent) = path.parent() {
                std::fs::create_dir_all(parent)
                    .map_err(|e| format!("cannot create {}: {e}", parent.display()))?;
            }
            std::fs::write(&path, text)
                .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
        }
        if let Some(lockfile) = lockfile {
            std::fs::copy(lockfile, dir.join("Cargo.lock"))
                .map_err(|e| format!("cannot copy {}: {e}", lockfile.display()))?;
        }
        Ok(Scratch { dir })
    }

    /// `cargo` in the crate's directory, with the crate's own target directory and no
    /// flags inherited from the caller's environment.
    pub fn cargo(&self) -> Command {
        let mut cargo = crate::command::cargo();
        cargo
            .current_dir(&self.dir)
            .env("CARGO_TARGET_DIR", self.dir.join("target"))
            .env_remove("RUSTFLAGS")
            .env_remove("CARGO_ENCODED_RUSTFLAGS");
        cargo
    }
}

impl Scratch {
    /// Leaves the crate on disk (to look at after a failed check) and says where.
    pub fn keep(self) -> String {
        let dir = self.dir.clone();
        std::mem::forget(self);
        format!("the crate is kept in {}", dir.display())
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        // A leftover directory is only disk space; nothing to report.
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// The workspace's root directory (this crate lives in `xtask/`).
pub fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("xtask lives in the workspace")
        .to_path_buf()
}
