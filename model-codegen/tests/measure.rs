//! `stateforge-codegen measure` as a user runs it: a model file of their own, outside this
//! workspace, measured call by call on the emulated Cortex-M4F. The firmware is built in
//! release for `thumbv7em-none-eabihf` and run under QEMU: the command installs the target,
//! and with apt-get QEMU and the ARM binutils, where they are missing (`cargo xtask test`
//! has installed them before), and fails saying what to install where it cannot.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A small user model: a pendulum with an encoder and a biased gyro, each its own sensor,
/// an EKF and an LQR.
const PENDULUM: &str = r#"
name = "pendulum"
scalar = "f32"
doc = "A damped pendulum driven by a torque, with an encoder and a biased gyro."

[[const]]
name = "DT"
value = 0.01

[[state]]
name = "theta"
[[state]]
name = "omega"
[[param]]
name = "bias"
[[input]]
name = "torque"

[[output]]
name = "angle"
value = "theta"
[[output]]
name = "rate"
value = "omega + bias"

[[sensor]]
name = "encoder"
outputs = ["angle"]
[[sensor]]
name = "gyro"
outputs = ["rate"]

[dynamics]
kind = "discrete"

[dynamics.equations]
theta = "theta + DT * omega"
omega = "omega + DT * (-9.81 * sin(theta) - 0.1 * omega + torque)"

[generate]
ekf = { process_noise = "diagonal" }
lqr = { horizon = 20, states = ["theta", "omega"], input = "torque" }
"#;

/// The pendulum's calls, as the table names them.
const CALLS: [&str; 6] = [
    "Ekf::predict",
    "Ekf::update",
    "Ekf::update_encoder",
    "Ekf::update_gyro",
    "Ekf::step",
    "Lqr::solve",
];

/// `model` written as `name` in a directory of the test's own, outside the workspace.
fn user_model(test: &str, name: &str, model: &str) -> PathBuf {
    let dir =
        std::env::temp_dir().join(format!("stateforge-measure-{test}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temporary directory");
    let path = dir.join(name);
    std::fs::write(&path, model).expect("model written");
    path
}

fn codegen(args: &[&std::ffi::OsStr]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_stateforge-codegen"))
        .args(args)
        .output()
        .expect("stateforge-codegen runs")
}

/// One row of the table: the call, then its figures.
#[derive(Debug)]
struct Row {
    call: String,
    /// Instructions: median, worst, mean.
    instructions: [f64; 3],
    /// Estimated cycles: median, worst, mean.
    cycles: [f64; 3],
    /// The static estimate, and the constant it is.
    estimate: (f64, String),
    stack: f64,
    text: f64,
}

/// The table's rows: the lines that start with a call (`Type::method`).
fn rows(table: &str) -> Vec<Row> {
    table
        .lines()
        .filter(|line| {
            line.split_whitespace()
                .next()
                .is_some_and(|w| w.contains("::"))
        })
        .map(|line| {
            let words: Vec<&str> = line.split_whitespace().collect();
            assert_eq!(words.len(), 12, "a row of twelve columns: {line}");
            let number = |i: usize| -> f64 {
                words[i]
                    .parse()
                    .unwrap_or_else(|_| panic!("column {i} of `{line}` is a number"))
            };
            Row {
                call: words[0].to_owned(),
                instructions: [number(1), number(2), number(3)],
                cycles: [number(4), number(5), number(6)],
                estimate: (number(7), words[11].to_owned()),
                stack: number(9),
                text: number(10),
            }
        })
        .collect()
}

/// The value of `pub const <name>: u32 = ..;` in the generated code.
fn constant(code: &str, name: &str) -> f64 {
    let start = format!("pub const {name}: u32 = ");
    let line = code
        .lines()
        .find_map(|l| l.trim().strip_prefix(start.as_str()))
        .unwrap_or_else(|| panic!("the generated code has no {name}"));
    line.trim_end_matches(';').parse().expect("a whole number")
}

#[test]
fn a_users_model_is_measured_call_by_call_on_the_emulated_cortex_m4f() {
    let model = user_model("pendulum", "pendulum.toml", PENDULUM);
    // Built beside this test's other outputs, so that a second run rebuilds little.
    let work = Path::new(env!("CARGO_TARGET_TMPDIR")).join("measure-pendulum");
    let output = codegen(&[
        "measure".as_ref(),
        model.as_os_str(),
        "--samples".as_ref(),
        "50".as_ref(),
        "--work-dir".as_ref(),
        work.as_os_str(),
    ]);
    let (table, progress) = (
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr),
    );
    assert!(output.status.success(), "measure failed:\n{progress}");
    assert!(
        table.contains("`pendulum` on an emulated Cortex-M4F"),
        "{table}"
    );
    assert!(table.contains("run 50 times"), "{table}");
    let code = codegen(&[model.as_os_str()]);
    let code = String::from_utf8_lossy(&code.stdout);

    let rows = rows(&table);
    let calls: Vec<&str> = rows.iter().map(|r| r.call.as_str()).collect();
    assert_eq!(calls, CALLS, "{table}");
    for row in &rows {
        let [median, worst, mean] = row.instructions;
        let [cycles_median, cycles_worst, cycles_mean] = row.cycles;
        let what = format!("{}: {row:?}\n{table}", row.call);
        // Straight-line code: every call the same, and the counter (the mean) agrees with
        // the trace (the median) to within the wrapper's few instructions.
        assert!(median > 20.0 && median <= worst, "{what}");
        assert!((median - mean).abs() <= 8.0, "{what}");
        assert!(cycles_median <= cycles_worst, "{what}");
        // A Cortex-M4F with its FPU: at least a cycle per instruction, and no call of
        // these made of divisions only.
        let per_instruction = cycles_mean / mean;
        assert!((1.0..4.0).contains(&per_instruction), "{what}");
        // The static estimate is the generated module's own constant, and estimates the
        // traced cycles as the project's cost table requires of its models.
        let (estimate, name) = &row.estimate;
        let (type_name, method) = row.call.split_once("::").expect("Type::method");
        let expected = format!(
            "{}_{}_CYCLES",
            type_name.to_uppercase(),
            method.to_uppercase()
        );
        assert_eq!(name, &expected, "{what}");
        assert_eq!(*estimate, constant(&code, name), "{what}");
        assert!(
            (estimate - cycles_mean).abs() <= 0.25 * cycles_mean,
            "{what}"
        );
        assert!(
            row.stack > 0.0 && row.stack <= 8192.0 && row.stack % 4.0 == 0.0,
            "{what}"
        );
        assert!(row.text > 0.0, "{what}");
    }
    // `step` predicts, then corrects with both outputs: about what `predict` and `update`
    // cost apart.
    let mean = |call: &str| {
        let row = rows.iter().find(|r| r.call == call).expect("a row");
        row.instructions[2]
    };
    let apart = mean("Ekf::predict") + mean("Ekf::update");
    assert!(
        (mean("Ekf::step") - apart).abs() <= 0.25 * apart,
        "step {} against predict + update {apart}\n{table}",
        mean("Ekf::step")
    );
}

#[test]
fn what_cannot_be_measured_is_said_before_anything_is_built() {
    let model = user_model("samples", "pendulum.toml", PENDULUM);
    let output = codegen(&[
        "measure".as_ref(),
        model.as_os_str(),
        "--samples".as_ref(),
        "0".as_ref(),
    ]);
    assert!(!output.status.success());
    let errors = String::from_utf8_lossy(&output.stderr);
    assert_eq!(errors, "error: the samples are 1 to 1000, not 0\n");

    let in_f64 = PENDULUM.replace("scalar = \"f32\"", "scalar = \"f64\"");
    let model = user_model("f64", "pendulum.toml", &in_f64);
    let output = codegen(&["measure".as_ref(), model.as_os_str()]);
    assert!(!output.status.success());
    let errors = String::from_utf8_lossy(&output.stderr);
    assert!(
        errors.starts_with("error: the Cortex-M4F runs the model's f32 code: add `f32`"),
        "{errors}"
    );

    let broken = PENDULUM.replace("theta + DT * omega", "theta + DT * speed");
    let model = user_model("broken", "pendulum.toml", &broken);
    let output = codegen(&["measure".as_ref(), model.as_os_str()]);
    assert!(!output.status.success());
    let errors = String::from_utf8_lossy(&output.stderr);
    assert!(
        errors.contains("pendulum.toml:"),
        "errors as rustc prints them: {errors}"
    );
}
