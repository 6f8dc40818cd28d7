//! The main job names the papers it reproduces by title and authors (or, where our copy
//! has lost its title page, by subject), never by the number of the file it came in:
//! nothing it prints or writes to `out/` may say "seed 0..".
//!
//! It runs the real binary (about 3 s in a debug build) in a directory of its own, so
//! every string that reaches the output is checked, however it was put together.

use std::path::{Path, PathBuf};
use std::process::Command;

/// Every file under `dir`, recursively.
fn files(dir: &Path) -> Vec<PathBuf> {
    let mut found = Vec::new();
    for entry in std::fs::read_dir(dir).expect("output directory readable") {
        let path = entry.expect("directory entry").path();
        if path.is_dir() {
            found.extend(files(&path));
        } else {
            found.push(path);
        }
    }
    found
}

/// `where:line: text` for each line of `text` that names a paper by its file's number.
fn seed_numbers(place: &str, text: &str) -> Vec<String> {
    text.lines()
        .enumerate()
        .filter(|(_, line)| line.to_lowercase().contains("seed 0"))
        .map(|(i, line)| format!("{place}:{}: {line}", i + 1))
        .collect()
}

#[test]
fn the_main_job_names_papers_not_seed_numbers() {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("main_job_names_papers");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch directory");
    let output = Command::new(env!("CARGO_BIN_EXE_generated-demo"))
        .current_dir(&dir)
        .output()
        .expect("the main job runs");
    let stdout = String::from_utf8_lossy(&output.stdout);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "the main job failed:\n{stderr}");

    let mut found = seed_numbers("stdout", &stdout);
    found.extend(seed_numbers("stderr", &stderr));
    let written = files(&dir.join("out"));
    assert!(written.len() >= 20, "only {} files in out/", written.len());
    for file in &written {
        let text = String::from_utf8_lossy(&std::fs::read(file).expect("output file readable"))
            .into_owned();
        found.extend(seed_numbers(&file.display().to_string(), &text));
    }
    assert!(
        found.is_empty(),
        "papers named by seed number:\n{}",
        found.join("\n")
    );

    // And each paper is named: by its authors, or by its subject where they are unknown.
    for name in [
        "double Kalman filter (DKF) paper",
        "Takács, Polóni and Rohal-Ilkiv, \"Adaptive predictive control of transient",
        "Kulkarni and Purwar, \"Nonlinear experimental estimation and",
        "piecewise linear beam report",
        "Shults, Brubaker and Lee, \"A fast algorithm for control",
    ] {
        assert!(stdout.contains(name), "the output does not name {name:?}");
    }
}
