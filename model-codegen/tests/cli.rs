//! The `stateforge-codegen` tool: its version, where its output goes, and its errors, which
//! it reports as rustc does: `file:line:column`, the offending line and a caret under the
//! column, for both kinds of input.

use std::process::Command;

/// Runs `stateforge-codegen` on `source` saved as `file_name` in a directory of the test's
/// own (`test`): whether it succeeded, and what it printed on standard error, with the
/// path shortened to the file name.
fn run(test: &str, file_name: &str, source: &str) -> (bool, String) {
    let dir =
        std::env::temp_dir().join(format!("stateforge-codegen-{test}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temporary directory");
    let path = dir.join(file_name);
    std::fs::write(&path, source).expect("model written");
    let output = Command::new(env!("CARGO_BIN_EXE_stateforge-codegen"))
        .arg(&path)
        .output()
        .expect("stateforge-codegen runs");
    let stderr = String::from_utf8_lossy(&output.stderr);
    let stderr = stderr.replace(&path.display().to_string(), file_name);
    (output.status.success(), stderr)
}

/// What `stateforge-codegen` printed for `source`, a bad model, which must fail.
fn errors_for(test: &str, file_name: &str, source: &str) -> String {
    let (succeeded, errors) = run(test, file_name, source);
    assert!(!succeeded, "a bad model must fail: {errors}");
    errors
}

#[test]
fn symbols_nothing_reads_are_warned_about_in_the_files_own_terms() {
    let model = |param_table: &str| {
        format!(
            "name = \"m\"\nscalar = \"f32\"\n[[state]]\nname = \"x\"\n{param_table}\
             [dynamics]\nkind = \"discrete\"\n[dynamics.equations]\nx = \"x\"\n"
        )
    };
    let (succeeded, warnings) = run(
        "unused-toml",
        "m.toml",
        &model("[[param]]\nname = \"spare\"\n"),
    );
    assert!(succeeded, "a warning is no error: {warnings}");
    assert!(
        warnings.starts_with(
            "m.toml:6:9: warning: the parameter `spare` is read by no expression and no \
             option; the filters carry it, but nothing moves its estimate: use it in the \
             dynamics or an output, remove it, or add `allow_unused = true` to its table if it \
             is kept on purpose\n"
        ),
        "{warnings}"
    );
    assert!(
        warnings.contains("6 | name = \"spare\"\n  |         ^"),
        "{warnings}"
    );
    let kept = model("[[param]]\nname = \"spare\"\nallow_unused = true\n");
    assert_eq!(run("unused-kept", "m.toml", &kept), (true, String::new()));
    let on_a_state = model("[[state]]\nname = \"x2\"\nallow_unused = true\n")
        .replace("x = \"x\"\n", "x = \"x\"\nx2 = \"x2\"\n");
    let errors = errors_for("unused-state", "m.toml", &on_a_state);
    assert!(
        errors.starts_with(
            "m.toml:7:16: error: `allow_unused` applies to a `[[param]]`, `[[input]]` or \
             `[[known]]`"
        ),
        "{errors}"
    );
    // The macro's form: the hint in its own syntax.
    let macro_model = "stateforge::model! {\n    pub mod m {\n        scalar f32;\n        \
                       state x;\n        input u;\n        dynamics discrete {\n            \
                       x = x;\n        }\n    }\n}\n";
    let (succeeded, warnings) = run("unused-macro", "m.rs", macro_model);
    assert!(succeeded, "{warnings}");
    assert!(
        warnings.starts_with("m.rs:5:15: warning: the input `u` is read by no expression"),
        "{warnings}"
    );
    assert!(
        warnings.contains("declare it `#[allow(unused)]`"),
        "{warnings}"
    );
}

#[test]
fn model_file_errors_give_line_column_and_the_line() {
    let errors = errors_for(
        "toml-field",
        "bad.toml",
        "name = \"m\"\nscalar = \"f32\"\n\n[[state]]\nname = \"x\"\n\n[dynamics]\n\
         kind = \"discrete\"\n\n[dynamics.equations]\nx = \"x + y9\"\n",
    );
    // The caret is under `y9` inside the string, not under its opening quote.
    assert!(
        errors.starts_with("bad.toml:11:10: error: unknown symbol `y9`"),
        "{errors}"
    );
    assert!(
        errors.contains("11 | x = \"x + y9\"\n   |          ^"),
        "{errors}"
    );
}

#[test]
fn model_file_option_errors_point_at_the_value_and_say_what_it_takes() {
    let errors = errors_for(
        "toml-option",
        "bad.toml",
        "name = \"m\"\nscalar = \"f32\"\n[[state]]\nname = \"x\"\n[[output]]\nname = \"y\"\n\
         value = \"x\"\n[dynamics]\nkind = \"discrete\"\n[dynamics.equations]\nx = \"x\"\n\
         [generate.ekf]\ngate = true\n",
    );
    assert!(
        errors.starts_with(
            "bad.toml:13:8: error: generate.ekf.gate: `true` is not a value of `gate`, which \
             takes a positive number"
        ),
        "{errors}"
    );
    assert!(
        errors.contains("13 | gate = true\n   |        ^"),
        "{errors}"
    );
}

#[test]
fn model_file_syntax_errors_are_placed_too() {
    let errors = errors_for(
        "toml-syntax",
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
        "// A model with a mistake.\nstateforge::model! {\n    pub mod m {\n        \
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

/// A crate's `lib.rs` around a model: inner docs and attributes, a `use`, other items.
const LIB_RS: &str = "//! The crate's model.\n#![no_std]\n#![forbid(unsafe_code)]\n\n\
                      use core::f32::consts::PI;\n\n/// Half a turn.\npub const HALF: f32 = PI;\n\n\
                      stateforge::model! {\n    pub mod m {\n        scalar f32;\n        \
                      state x1;\n        dynamics discrete {\n            x1 = 0.5 * x1;\n        \
                      }\n    }\n}\n\nmod tests {}\n";

#[test]
fn an_ordinary_lib_rs_around_the_model_is_read() {
    assert_eq!(run("lib-rs", "lib.rs", LIB_RS), (true, String::new()));
    // Its errors are placed on the file's own lines.
    let errors = errors_for(
        "lib-rs-error",
        "lib.rs",
        &LIB_RS.replace("0.5 * x1", "0.5 ^ x1"),
    );
    assert!(
        errors.starts_with("lib.rs:15:22: error: `^` is exclusive-or"),
        "{errors}"
    );
    // A file without a model, or with two, is told what the tool reads.
    let errors = errors_for("lib-rs-none", "lib.rs", "//! No model.\n#![no_std]\n");
    assert!(
        errors.starts_with(
            "lib.rs:1:1: error: no `model!` invocation found: the file is read as \
                            Rust source holding one `model! { .. }` invocation"
        ),
        "{errors}"
    );
    let twice = LIB_RS.replace("mod tests {}", "stateforge::model! { pub mod n {} }");
    let errors = errors_for("lib-rs-two", "lib.rs", &twice);
    assert!(
        errors.starts_with(
            "lib.rs:20:13: error: a second `model!` invocation: the tool \
                            generates one model per file"
        ),
        "{errors}"
    );
}

#[test]
fn version_names_the_tool() {
    let output = Command::new(env!("CARGO_BIN_EXE_stateforge-codegen"))
        .arg("--version")
        .output()
        .expect("stateforge-codegen runs");
    assert!(output.status.success());
    assert_eq!(
        String::from_utf8_lossy(&output.stdout),
        format!("stateforge-codegen {}\n", env!("CARGO_PKG_VERSION"))
    );
}

#[test]
fn output_file_gets_the_code_under_a_header_naming_tool_version_and_model() {
    let model = concat!(env!("CARGO_MANIFEST_DIR"), "/models/cantilever.toml");
    let dir =
        std::env::temp_dir().join(format!("stateforge-codegen-output-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temporary directory");
    let file = dir.join("cantilever.rs");
    let to_file = Command::new(env!("CARGO_BIN_EXE_stateforge-codegen"))
        .arg(model)
        .args(["-o", &file.display().to_string()])
        .output()
        .expect("stateforge-codegen runs");
    assert!(to_file.status.success(), "{to_file:?}");
    assert!(to_file.stdout.is_empty(), "the code goes to the file only");
    let written = std::fs::read_to_string(&file).expect("output file written");
    let header = format!(
        "// Generated by stateforge-codegen {} from {model}: edit the model, not this file.\n",
        env!("CARGO_PKG_VERSION")
    );
    assert!(written.starts_with(&header), "{}", &written[..200]);
    // Then the pedantic lints generated code trips by design, allowed in this file only,
    // then the model's module.
    let body = &written[header.len()..];
    assert!(body.starts_with("#![allow(\n"), "{}", &body[..100]);
    let (allowed, module) = body.split_once(")]\n").expect("the attribute closes");
    for lint in [
        "similar_names",
        "trivially_copy_pass_by_ref",
        "unreadable_literal",
    ] {
        assert!(allowed.contains(&format!("clippy::{lint},")), "{allowed}");
    }
    assert!(
        module.starts_with("/// Cantilever beam"),
        "{}",
        &module[..100]
    );
    let to_stdout = Command::new(env!("CARGO_BIN_EXE_stateforge-codegen"))
        .arg(model)
        .output()
        .expect("stateforge-codegen runs");
    assert_eq!(String::from_utf8_lossy(&to_stdout.stdout), written);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_failed_generation_leaves_the_output_file_alone() {
    let dir = std::env::temp_dir().join(format!("stateforge-codegen-keep-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temporary directory");
    let (model, file) = (dir.join("bad.toml"), dir.join("out.rs"));
    std::fs::write(&model, "name = \"m\"\n").expect("model written");
    std::fs::write(&file, "// vendored before\n").expect("file written");
    let output = Command::new(env!("CARGO_BIN_EXE_stateforge-codegen"))
        .arg(&model)
        .arg("-o")
        .arg(&file)
        .output()
        .expect("stateforge-codegen runs");
    assert!(!output.status.success());
    assert_eq!(
        std::fs::read_to_string(&file).expect("file kept"),
        "// vendored before\n"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_reader_that_stops_early_ends_the_output_quietly() {
    // `stateforge-codegen model | head`: the pipe closes before the code is written.
    let model = concat!(env!("CARGO_MANIFEST_DIR"), "/models/cantilever.toml");
    let mut child = Command::new(env!("CARGO_BIN_EXE_stateforge-codegen"))
        .arg(model)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("stateforge-codegen runs");
    drop(child.stdout.take());
    let output = child.wait_with_output().expect("stateforge-codegen ends");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{:?}: {stderr}", output.status);
    assert!(stderr.is_empty(), "{stderr}");
}

#[test]
fn c_api_writes_the_companion_crate_around_the_same_code() {
    let model = concat!(env!("CARGO_MANIFEST_DIR"), "/models/cantilever.toml");
    let dir = std::env::temp_dir().join(format!("stateforge-codegen-c-api-{}", std::process::id()));
    let c_api = |out: &std::path::Path| {
        Command::new(env!("CARGO_BIN_EXE_stateforge-codegen"))
            .args(["c-api", model, "--out-dir"])
            .arg(out)
            .output()
            .expect("stateforge-codegen runs")
    };
    let written = c_api(&dir);
    assert!(written.status.success(), "{written:?}");
    let read = |name: &str| std::fs::read_to_string(dir.join(name)).expect(name);
    // The generated module is the one `stateforge-codegen <model>` prints, its unsafe
    let printed = Command::new(env!("CARGO_BIN_EXE_stateforge-codegen"))
        .arg(model)
        .output()
        .expect("stateforge-codegen runs");
    let code = String::from_utf8_lossy(&printed.stdout).into_owned();
    // code forbidden, in a crate of its own which the wrapper's depends on.
    let generated = read("model/src/lib.rs");
    assert!(
        generated.starts_with("#![no_std]\n#![forbid(unsafe_code)]\n"),
        "{generated}"
    );
    assert!(generated.ends_with(&code), "{generated}");
    let model_manifest = read("model/Cargo.toml");
    assert!(
        model_manifest.contains("name = \"cantilever-model\""),
        "{model_manifest}"
    );
    let manifest = read("Cargo.toml");
    assert!(
        manifest.contains("cantilever-model = { path = \"model\" }"),
        "{manifest}"
    );
    assert!(
        manifest.contains("crate-type = [\"staticlib\"]"),
        "{manifest}"
    );
    assert!(manifest.contains("panic = \"abort\""), "{manifest}");
    let header = read("include/cantilever.h");
    for declaration in [
        "cantilever_status_t cantilever_ekf_step(cantilever_ekf_t *ekf, const float u_prev[1], const float y[1]);",
        "cantilever_status_t cantilever_lqr_new(cantilever_lqr_t *lqr, const float q[2][2], const float r[1][1], const float u_max[1]);",
        "cantilever_status_t cantilever_f64_ekf_state(const cantilever_f64_ekf_t *ekf, double out[5]);",
        "#define CANTILEVER_EKF_STEP_CYCLES 418u",
        "#define CANTILEVER_TS 0.015f",
        "    CANTILEVER_STATUS_NULL_POINTER = 100,",
    ] {
        assert!(header.contains(declaration), "no `{declaration}` in\n{header}");
    }
    let lib = read("src/lib.rs");
    assert!(
        lib.contains("pub unsafe extern \"C\" fn cantilever_gated_ekf_update("),
        "{lib}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn c_api_of_a_model_without_a_filter_says_what_to_add() {
    let dir = std::env::temp_dir().join(format!(
        "stateforge-codegen-c-api-none-{}",
        std::process::id()
    ));
    std::fs::create_dir_all(&dir).expect("temporary directory");
    let model = dir.join("plain.toml");
    let source = "name = \"plain\"\nscalar = \"f32\"\n\n[[state]]\nname = \"x\"\n\n\
                  [dynamics]\nkind = \"discrete\"\n\n[dynamics.equations]\nx = \"0.5*x\"\n";
    std::fs::write(&model, source).expect("model written");
    let output = Command::new(env!("CARGO_BIN_EXE_stateforge-codegen"))
        .arg("c-api")
        .arg(&model)
        .arg("--out-dir")
        .arg(dir.join("plain-c"))
        .output()
        .expect("stateforge-codegen runs");
    assert!(!output.status.success());
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(stderr.contains("add a `generate` item"), "{stderr}");
    std::fs::remove_dir_all(&dir).ok();
}
