//! `model-codegen` reports a model's mistakes as rustc does: `file:line:column`, the
//! offending line and a caret under the column, for both kinds of input.

use std::process::Command;

/// Runs `model-codegen` on `source` saved as `file_name` in a directory of the test's own
/// (`test`), and returns what it printed, with the path shortened to the file name.
fn errors_for(test: &str, file_name: &str, source: &str) -> String {
    let dir = std::env::temp_dir().join(format!("model-codegen-{test}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temporary directory");
    let path = dir.join(file_name);
    std::fs::write(&path, source).expect("model written");
    let output = Command::new(env!("CARGO_BIN_EXE_model-codegen"))
        .arg(&path)
        .output()
        .expect("model-codegen runs");
    assert!(!output.status.success(), "a bad model must fail");
    let stderr = String::from_utf8_lossy(&output.stderr);
    stderr.replace(&path.display().to_string(), file_name)
}

#[test]
fn model_file_errors_give_line_column_and_the_line() {
    let errors = errors_for(
        "toml-field",
        "bad.toml",
        "name = \"m\"\nscalar = \"f32\"\n\n[[state]]\nname = \"x\"\n\n[dynamics]\n\
         kind = \"discrete\"\n\n[dynamics.equations]\nx = \"x + y9\"\n",
    );
    assert!(
        errors.starts_with("bad.toml:11:5: error: unknown symbol `y9`"),
        "{errors}"
    );
    assert!(
        errors.contains("11 | x = \"x + y9\"\n   |     ^"),
        "{errors}"
    );
}

#[test]
fn model_file_syntax_errors_are_placed_too() {
    let errors = errors_for(
        "toml-field",
        "bad.toml",
        "name = \"m\"\nscalar = \"f32\"\nvisibility = \"1\"\n",
    );
    assert!(
        errors.starts_with("bad.toml:3:14: error: model file: unknown variant `1`"),
        "{errors}"
    );
}

#[test]
fn macro_file_errors_give_line_column_and_the_line() {
    let errors = errors_for(
        "macro",
        "bad.rs",
        "// A model with a mistake.\ncodegen_macros::model! {\n    pub mod m {\n        \
         scalar f32;\n        state x1;\n        dynamics discrete {\n            \
         x1 = x1 ^ 2;\n        }\n    }\n}\n",
    );
    assert!(
        errors.starts_with("bad.rs:7:21: error: `^` is exclusive-or"),
        "{errors}"
    );
    assert!(
        errors.contains("7 |             x1 = x1 ^ 2;\n  |                     ^"),
        "{errors}"
    );
}
