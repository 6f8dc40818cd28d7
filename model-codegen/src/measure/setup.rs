//! What measuring on the emulated Cortex-M4F needs on the machine (a Rust target, QEMU,
//! the ARM binutils), installed or reported clearly: shared by `stateforge-codegen
//! measure` and the project's `cargo xtask`.

use std::path::Path;
use std::process::Command;

/// Runs a command, naming it on standard error as it starts and in the error if it fails.
pub fn run(what: &str, command: &mut Command) -> Result<(), String> {
    run_announced("", what, command)
}

/// [`run`], its progress line after `prefix` (`cargo xtask`'s `"xtask: "`).
pub fn run_announced(prefix: &str, what: &str, command: &mut Command) -> Result<(), String> {
    eprintln!("{prefix}{what}");
    let status = command
        .status()
        .map_err(|e| format!("{what}: cannot start: {e}"))?;
    if status.success() {
        Ok(())
    } else {
        Err(format!("{what} failed ({status})"))
    }
}

/// Installs a rustup target if it is missing.
pub fn rust_target(target: &str) -> Result<(), String> {
    let installed = Command::new("rustup")
        .args(["target", "list", "--installed"])
        .output()
        .map_err(|e| {
            format!("cannot run rustup ({e}); install rustup, then `rustup target add {target}`")
        })?;
    if String::from_utf8_lossy(&installed.stdout)
        .lines()
        .any(|l| l.trim() == target)
    {
        return Ok(());
    }
    eprintln!("installing the Rust target {target}");
    run(
        &format!("`rustup target add {target}`"),
        Command::new("rustup").args(["target", "add", target]),
    )
}

/// Makes sure the commands exist, installing their Debian packages with apt-get if not.
pub fn debian_commands(needed: &[(&str, &str)]) -> Result<(), String> {
    let missing: Vec<&(&str, &str)> = needed.iter().filter(|(cmd, _)| !exists(cmd)).collect();
    if missing.is_empty() {
        return Ok(());
    }
    let packages: Vec<&str> = missing.iter().map(|(_, package)| *package).collect();
    let hint = format!(
        "measuring on the emulated Cortex-M4F needs {}: install them with `apt-get install {}`",
        missing
            .iter()
            .map(|(cmd, _)| *cmd)
            .collect::<Vec<_>>()
            .join(", "),
        packages.join(" ")
    );
    apt_install(&packages, &hint, || {
        missing.iter().all(|(cmd, _)| exists(cmd))
    })
}

/// Makes sure `file` exists (a library's header), installing the Debian `package` that
/// provides it with apt-get if not; `what` says who needs it.
pub fn debian_file(file: &Path, package: &str, what: &str) -> Result<(), String> {
    if file.exists() {
        return Ok(());
    }
    let hint = format!(
        "{what} needs {} (`apt-get install {package}`)",
        file.display()
    );
    apt_install(&[package], &hint, || file.exists())
}

/// `apt-get update` and `apt-get install packages`; `hint` as the error if apt-get is
/// missing or fails, or if `installed` is still false after it.
fn apt_install(packages: &[&str], hint: &str, installed: impl Fn() -> bool) -> Result<(), String> {
    if !exists("apt-get") {
        return Err(hint.to_owned());
    }
    eprintln!("installing {}", packages.join(" "));
    let update = run("`apt-get update`", Command::new("apt-get").arg("update"));
    let install = update.and_then(|()| {
        run(
            "`apt-get install`",
            Command::new("apt-get")
                .args(["install", "-y"])
                .args(packages),
        )
    });
    match install {
        Ok(()) if installed() => Ok(()),
        _ => Err(hint.to_owned()),
    }
}

fn exists(command: &str) -> bool {
    Command::new("sh")
        .args(["-c", &format!("command -v {command}")])
        .output()
        .is_ok_and(|o| o.status.success())
}
