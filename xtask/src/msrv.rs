//! The minimum supported Rust version, checked as far as this machine can.
//!
//! What is checked, for each published crate: its declared `rust-version` is at least
//! every locked dependency's (normal and build dependencies; a dependency that needs a
//! newer compiler would make the declaration false), and the installed compiler is at
//! least the declared version. Standard-library items newer than the declaration are
//! refused by clippy's `incompatible_msrv` lint, which `clippy -D warnings` runs with
//! each crate's `rust-version` (and the vendored-models check runs on generated code).
//! Only a compiler of the declared version checks the language itself: if rustup has one
//! installed, the crates are checked with it; otherwise the report says so.

use std::collections::{BTreeMap, BTreeSet};
use std::process::Command;

/// A version `major.minor` (a patch number, if any, does not matter here).
type Version = (u32, u32);

fn parse_version(text: &str) -> Option<Version> {
    let mut parts = text.trim().split('.');
    let major = parts.next()?.parse().ok()?;
    let minor = parts.next()?.parse().ok()?;
    Some((major, minor))
}

fn show((major, minor): Version) -> String {
    format!("{major}.{minor}")
}

/// Checks the `published` crates' `rust-version`; a summary of what was checked.
pub fn check(published: &[&str]) -> Result<String, String> {
    let metadata = workspace_metadata()?;
    let packages = packages_by_id(&metadata)?;
    let installed = installed_rustc()?;
    let mut declared_versions = BTreeSet::new();
    for name in published {
        declared_versions.insert(checked_declaration(&metadata, &packages, name, installed)?);
    }
    let mut summary = Vec::new();
    for declared in declared_versions {
        summary.push(check_language(published, declared, installed)?);
    }
    Ok(format!("rust-version {}", summary.join("; ")))
}

/// The workspace's packages in `metadata`, by package id.
fn packages_by_id(
    metadata: &serde_json::Value,
) -> Result<BTreeMap<&str, &serde_json::Value>, String> {
    Ok(metadata["packages"]
        .as_array()
        .ok_or("cargo metadata: no packages")?
        .iter()
        .filter_map(|p| Some((p["id"].as_str()?, p)))
        .collect())
}

/// Crate `name`'s declared `rust-version`, checked against its dependencies' and `installed`.
fn checked_declaration(
    metadata: &serde_json::Value,
    packages: &BTreeMap<&str, &serde_json::Value>,
    name: &str,
    installed: Version,
) -> Result<Version, String> {
    let (id, package) = packages
        .iter()
        .find(|(_, p)| p["name"] == *name)
        .ok_or_else(|| format!("no package {name} in the workspace"))?;
    let declared = package["rust_version"]
        .as_str()
        .and_then(parse_version)
        .ok_or_else(|| format!("{name} declares no rust-version"))?;
    for dependency in dependency_closure(metadata, id) {
        let Some(dep) = packages.get(dependency.as_str()) else {
            continue;
        };
        if let Some(needed) = dep["rust_version"].as_str().and_then(parse_version) {
            if needed > declared {
                return Err(format!(
                    "{name} declares rust-version {} but its dependency {} {} needs {}",
                    show(declared),
                    dep["name"].as_str().unwrap_or("?"),
                    dep["version"].as_str().unwrap_or("?"),
                    show(needed)
                ));
            }
        }
    }
    if installed < declared {
        return Err(format!(
            "{name} declares rust-version {} but the installed rustc is {}",
            show(declared),
            show(installed)
        ));
    }
    Ok(declared)
}

/// The summary's entry for `declared`: the crates checked with its toolchain if rustup has it.
fn check_language(
    published: &[&str],
    declared: Version,
    installed: Version,
) -> Result<String, String> {
    let version = show(declared);
    if let Some(toolchain) = installed_toolchain(&version) {
        // Through rustup's `cargo`, not `$CARGO`: the toolchain override needs the proxy.
        let mut check = Command::new("cargo");
        check.arg(format!("+{toolchain}")).arg("check");
        for name in published {
            check.args(["--package", name]);
        }
        crate::command::run(&format!("cargo +{toolchain} check"), &mut check)?;
        Ok(format!("{version}: checked with {toolchain}"))
    } else {
        let toolchain = version;
        Ok(format!(
            "{toolchain}: at least every dependency's, at most the installed {}; \
             Rust {toolchain} is not installed, so the language is checked on {} only \
             (std items by clippy's incompatible_msrv)",
            show(installed),
            show(installed)
        ))
    }
}

/// `cargo metadata` of the workspace, as locked.
fn workspace_metadata() -> Result<serde_json::Value, String> {
    let output = crate::command::cargo()
        .args(["metadata", "--format-version", "1", "--locked"])
        .output()
        .map_err(|e| format!("cannot run cargo metadata: {e}"))?;
    if !output.status.success() {
        return Err(format!(
            "cargo metadata failed: {}",
            String::from_utf8_lossy(&output.stderr)
        ));
    }
    serde_json::from_slice(&output.stdout).map_err(|e| format!("cargo metadata: {e}"))
}

/// Every package `root` needs to build: normal and build dependencies, transitively.
fn dependency_closure(metadata: &serde_json::Value, root: &str) -> BTreeSet<String> {
    let nodes: BTreeMap<&str, &serde_json::Value> = metadata["resolve"]["nodes"]
        .as_array()
        .map(|nodes| {
            nodes
                .iter()
                .filter_map(|n| Some((n["id"].as_str()?, n)))
                .collect()
        })
        .unwrap_or_default();
    let mut seen = BTreeSet::new();
    let mut stack = vec![root.to_string()];
    while let Some(id) = stack.pop() {
        let Some(node) = nodes.get(id.as_str()) else {
            continue;
        };
        for dep in node["deps"].as_array().into_iter().flatten() {
            let needed_to_build = dep["dep_kinds"]
                .as_array()
                .into_iter()
                .flatten()
                .any(|k| k["kind"].as_str() != Some("dev"));
            if let (true, Some(pkg)) = (needed_to_build, dep["pkg"].as_str()) {
                if seen.insert(pkg.to_string()) {
                    stack.push(pkg.to_string());
                }
            }
        }
    }
    seen
}

/// The version of the `rustc` cargo uses.
fn installed_rustc() -> Result<Version, String> {
    let rustc = std::env::var("RUSTC").unwrap_or_else(|_| "rustc".into());
    let output = Command::new(&rustc)
        .arg("--version")
        .output()
        .map_err(|e| format!("cannot run {rustc}: {e}"))?;
    let text = String::from_utf8_lossy(&output.stdout);
    text.split_whitespace()
        .nth(1)
        .and_then(parse_version)
        .ok_or_else(|| format!("cannot read the version of `{}`", text.trim()))
}

/// The name of an installed rustup toolchain of `version` (for example `1.89` finds
/// `1.89.0-x86_64-unknown-linux-gnu`), if there is one.
fn installed_toolchain(version: &str) -> Option<String> {
    let list = Command::new("rustup")
        .args(["toolchain", "list"])
        .output()
        .ok()?;
    String::from_utf8_lossy(&list.stdout)
        .lines()
        .filter_map(|l| l.split_whitespace().next())
        .find(|name| {
            name.strip_prefix(version)
                .is_some_and(|rest| rest.starts_with('.') || rest.starts_with('-'))
        })
        .map(str::to_string)
}
