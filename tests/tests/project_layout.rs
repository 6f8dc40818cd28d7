//! The repository as the project's specification lays it out, and its text self-contained:
//! what a reader needs is in the project's own docs, never in notes they do not have.

use std::path::{Path, PathBuf};

fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("tests/ has a parent")
        .to_path_buf()
}

/// The top level the specification gives (`Cargo.toml, model-dsl, codegen-macros,
/// generated-demo, targets, tests`), with the macro crate, published as `stateforge`, in
/// `codegen-macros/`.
#[test]
fn the_top_level_is_the_specifications() {
    let root = workspace_root();
    for entry in [
        "Cargo.toml",
        "model-dsl",
        "codegen-macros",
        "generated-demo",
        "targets",
        "tests",
    ] {
        assert!(
            root.join(entry).exists(),
            "{entry} is missing at the top level"
        );
    }
    let manifest = std::fs::read_to_string(root.join("codegen-macros/Cargo.toml"))
        .expect("codegen-macros/Cargo.toml");
    assert!(
        manifest.contains("name = \"stateforge\""),
        "codegen-macros/ is the `stateforge` crate"
    );
    assert!(
        manifest.contains("proc-macro = true"),
        "codegen-macros/ is the proc-macro crate"
    );
    let workspace = std::fs::read_to_string(root.join("Cargo.toml")).expect("Cargo.toml");
    assert!(workspace.contains("\"codegen-macros\""));
}

/// Text files of the repository that git tracks, with their contents.
fn tracked_text_files(root: &Path) -> Vec<(String, String)> {
    let listing = std::process::Command::new("git")
        .args(["ls-files", "-z"])
        .current_dir(root)
        .output()
        .expect("git ls-files runs");
    assert!(listing.status.success(), "git ls-files failed");
    String::from_utf8(listing.stdout)
        .expect("paths are UTF-8")
        .split('\0')
        .filter(|path| {
            [".rs", ".md", ".toml", ".snap", ".stderr"]
                .iter()
                .any(|ending| path.ends_with(ending))
        })
        .filter_map(|path| {
            let text = std::fs::read_to_string(root.join(path)).ok()?;
            Some((path.to_string(), text))
        })
        .collect()
}

/// The notes and papers the team was given live beside the repository, not in it: code,
/// docs and generated docs that point there send a reader to files they do not have.
#[test]
fn nothing_cites_notes_outside_the_repository() {
    let root = workspace_root();
    // Spelt in pieces so that this file does not match itself.
    let outside = [
        ["shared", "/reference"].concat(),
        ["shared", "/seeds"].concat(),
        ["reference", "/dkf-equations"].concat(),
        ["simulating", "-the-paper"].concat(),
        ["cortex-m4", "-measurement.md"].concat(),
        ["reference", " note"].concat(),
        // The papers by their file numbers: a reader has the papers by their titles.
        ["seed", " 00"].concat(),
    ];
    let mut citing = Vec::new();
    for (path, text) in tracked_text_files(&root) {
        // The changelog records history, including where notes used to be cited.
        if path.ends_with("CHANGELOG.md") {
            continue;
        }
        for (number, line) in text.lines().enumerate() {
            if outside.iter().any(|cited| line.contains(cited.as_str())) {
                citing.push(format!("{path}:{}: {}", number + 1, line.trim()));
            }
        }
    }
    assert!(
        citing.is_empty(),
        "these lines cite notes outside the repository; say what the reader needs in the \
         project's own docs:\n{}",
        citing.join("\n")
    );
}
