//! The C API (`stateforge-codegen c-api`) as a C program uses it: the cantilever's and
//! the mass-spring-damper's companion crates written, their headers compiled as C99 and
//! C++17 with every warning an error, their static libraries built, and
//! `tests/c/<model>.c` linked against each under AddressSanitizer and
//! UndefinedBehaviorSanitizer and run. The programs check every function of the EKF, the
//! gated EKF, the DKF, the LQR, the model functions and the f64 EKF (the cantilever's),
//! and of the MPC, the hybrid EKF and the f64 MPC (the mass-spring-damper's), their
//! refusals included; their results must be the generated Rust code's, bit for bit.
//! Needs the host's `gcc` and `g++`.

use generated_demo::{cantilever, mass_spring_damper};
use std::path::{Path, PathBuf};
use std::process::Command;
use tests::workspace_path;

/// The companion crate of the cantilever, written once for the tests of this file.
fn companion() -> PathBuf {
    companion_of("cantilever")
}

/// The companion crate of a demo model, written once for the tests of this file.
fn companion_of(model: &str) -> PathBuf {
    static WRITTEN: std::sync::Mutex<Vec<String>> = std::sync::Mutex::new(Vec::new());
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("c-api-{model}"));
    let mut written = WRITTEN
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    if !written.iter().any(|m| m == model) {
        let options = stateforge_cli::c_api::Options {
            math_dependency: stateforge_cli::math_dependency(),
            provenance: format!(
                "// Generated for the tests from generated-demo/models/{model}.rs."
            ),
        };
        let code = tests::demo_model_code(model);
        stateforge_cli::c_api::write(&code, &dir, &options).expect("the C API is written");
        written.push(model.to_owned());
    }
    dir
}

/// Runs `command`, panicking with its output unless it succeeds; its standard output.
fn run(command: &mut Command) -> String {
    let output = command
        .output()
        .unwrap_or_else(|e| panic!("cannot run {command:?}: {e} (install gcc and g++)"));
    let stdout = String::from_utf8_lossy(&output.stdout).into_owned();
    assert!(
        output.status.success(),
        "{command:?} failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&output.stderr)
    );
    stdout
}

#[test]
fn the_header_compiles_as_c99_and_cpp17_without_a_warning() {
    let header = companion().join("include/cantilever.h");
    for (compiler, standard, language) in [("gcc", "-std=c99", "c"), ("g++", "-std=c++17", "c++")] {
        run(Command::new(compiler)
            .args([
                standard,
                "-Wall",
                "-Wextra",
                "-Wpedantic",
                "-Werror",
                "-fsyntax-only",
                "-x",
            ])
            .arg(language)
            .arg(&header));
    }
}

#[test]
fn every_function_and_constant_of_the_header_is_documented() {
    let header = std::fs::read_to_string(companion().join("include/cantilever.h")).expect("header");
    let lines: Vec<&str> = header.lines().collect();
    let mut declarations = 0;
    for (i, line) in lines.iter().enumerate() {
        let declares = (line.starts_with("#define CANTILEVER_") && *line != "#define CANTILEVER_H")
            || line.starts_with("cantilever_status_t ");
        if declares {
            declarations += 1;
            assert!(
                i > 0 && lines[i - 1].trim_end().ends_with("*/"),
                "undocumented: {line}"
            );
        }
    }
    assert!(declarations > 100, "only {declarations} declarations");
}

#[test]
fn the_unsafe_code_is_in_the_wrapper_only_each_block_with_its_reason() {
    let dir = companion();
    // The generated code is a crate of its own, which forbids unsafe code.
    let model = std::fs::read_to_string(dir.join("model/src/lib.rs")).expect("model crate");
    assert!(model.starts_with("#![no_std]\n#![forbid(unsafe_code)]"));
    for file in ["src/lib.rs", "src/support.rs"] {
        let text = std::fs::read_to_string(dir.join(file)).expect("wrapper");
        let blocks = text.matches("unsafe {").count();
        assert!(blocks > 0);
        assert_eq!(
            text.matches("// SAFETY:").count(),
            blocks,
            "{file}: an unsafe block without its reason"
        );
    }
    // Clippy places each reason (the crate denies `clippy::undocumented_unsafe_blocks`).
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    run(Command::new(cargo)
        .args(["clippy", "--release", "--quiet", "--target-dir"])
        .arg(dir.join("target"))
        .args(["--", "-D", "warnings"])
        .current_dir(&dir)
        .env_remove("RUSTFLAGS")
        .env_remove("CARGO_ENCODED_RUSTFLAGS"));
}

/// The host's static library of the cantilever, built in release: its path.
fn host_library() -> PathBuf {
    host_library_of("cantilever")
}

/// The host's static library of a demo model, built in release: its path.
fn host_library_of(model: &str) -> PathBuf {
    let dir = companion_of(model);
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    run(Command::new(cargo)
        .args(["build", "--release", "--quiet", "--target-dir"])
        .arg(dir.join("target"))
        .current_dir(&dir)
        .env_remove("RUSTFLAGS")
        .env_remove("CARGO_ENCODED_RUSTFLAGS"));
    dir.join(format!("target/release/lib{model}_c.a"))
}

/// The program `tests/c/<model>.c` built against the model's static library, with the
/// sanitizers; its output.
fn c_program_output(model: &str) -> String {
    let library = host_library_of(model);
    let dir = companion_of(model);
    let program = dir.join(format!("{model}_test"));
    run(Command::new("gcc")
        .args([
            "-std=c99",
            "-Wall",
            "-Wextra",
            "-Wpedantic",
            "-Werror",
            "-g",
        ])
        .args(["-fsanitize=address,undefined", "-fno-sanitize-recover=all"])
        .arg("-I")
        .arg(dir.join("include"))
        .arg(workspace_path(&format!("tests/c/{model}.c")))
        .arg(library)
        .args(["-lm", "-o"])
        .arg(&program));
    run(&mut Command::new(&program))
}

/// The printed line `name bits..`, as floats.
fn printed_f32(output: &str, name: &str) -> Vec<u32> {
    printed(output, name)
        .iter()
        .map(|&b| u32::try_from(b).expect("32 bits"))
        .collect()
}

/// The printed line `name bits..`.
fn printed(output: &str, name: &str) -> Vec<u64> {
    let line = output
        .lines()
        .find(|l| l.split(' ').next() == Some(name))
        .unwrap_or_else(|| panic!("the program printed no `{name}`:\n{output}"));
    line.split(' ')
        .skip(1)
        .map(|hex| u64::from_str_radix(hex, 16).expect("hexadecimal bits"))
        .collect()
}

/// The run's input and measurement at sample `k`, as the C program computes them.
#[allow(clippy::cast_precision_loss)]
fn input_at(k: i32) -> f32 {
    0.25 * (k % 7) as f32 - 0.75
}

#[allow(clippy::cast_precision_loss)]
fn measurement_at(k: i32) -> f32 {
    0.01 * ((k * 37) % 19) as f32 - 0.09
}

const X0: [f32; 5] = [0.0, 0.0, -400.0, -1.0, 50.0];
const P0: [[f32; 5]; 5] = [
    [1.0, 0.0, 0.0, 0.0, 0.0],
    [0.0, 1.0, 0.0, 0.0, 0.0],
    [0.0, 0.0, 100.0, 0.0, 0.0],
    [0.0, 0.0, 0.0, 1.0, 0.0],
    [0.0, 0.0, 0.0, 0.0, 10.0],
];
const Q: [f32; 5] = [1e-6, 1e-4, 1e-2, 1e-4, 1e-3];
const R: [[f32; 1]; 1] = [[1e-4]];

fn bits(values: &[f32]) -> Vec<u32> {
    values.iter().map(|v| v.to_bits()).collect()
}

#[test]
fn the_sanitised_c_program_passes_and_computes_what_rust_computes() {
    let output = c_program_output("cantilever");
    assert!(
        output.contains("failures 0\n"),
        "the C program's checks failed:\n{output}"
    );
    // The EKF's run.
    let mut ekf = cantilever::Ekf::new(&X0, &P0, &Q, &R).expect("a filter");
    for k in 1..=40 {
        assert_eq!(
            ekf.step(&[input_at(k - 1)], &[measurement_at(k)]),
            cantilever::Status::Ok
        );
    }
    assert_eq!(ekf.predict(&[input_at(40)]), cantilever::Status::Ok);
    assert_eq!(ekf.update(&[measurement_at(41)]), cantilever::Status::Ok);
    assert_eq!(printed_f32(&output, "ekf_state"), bits(&ekf.state()));
    assert_eq!(
        printed_f32(&output, "ekf_covariance"),
        bits(ekf.covariance().as_flattened())
    );
    assert_eq!(
        printed_f32(&output, "ekf_innovation"),
        bits(&ekf.innovation())
    );
    assert_eq!(
        printed_f32(&output, "ekf_nis"),
        bits(&[ekf.normalised_innovation_squared()])
    );
    // The LQR's.
    let (q, r, u_max) = ([[100.0, 0.0], [0.0, 1.0]], [[0.1]], [2.0]);
    let x = [0.5, -1.0, -400.0, -1.0, 50.0];
    let x_ref = [0.2, 0.0, -400.0, -1.0, 50.0];
    let mut unlimited = cantilever::Lqr::new(&q, &r, None).expect("an LQR");
    assert_eq!(unlimited.solve(&x, &[0.0]), cantilever::Status::Ok);
    assert_eq!(
        printed_f32(&output, "lqr_unlimited_control"),
        bits(&unlimited.control(&x))
    );
    let mut lqr = cantilever::Lqr::new(&q, &r, Some(&u_max)).expect("an LQR");
    assert_eq!(lqr.solve(&x, &[0.0]), cantilever::Status::Ok);
    let u_ref = lqr.steady_state_input(&x_ref, &[0.0]).expect("an input");
    assert_eq!(
        printed_f32(&output, "lqr_gain"),
        bits(lqr.gain().as_flattened())
    );
    assert_eq!(printed_f32(&output, "lqr_control"), bits(&lqr.control(&x)));
    assert_eq!(printed_f32(&output, "lqr_u_ref"), bits(&u_ref));
    assert_eq!(
        printed_f32(&output, "lqr_track"),
        bits(&lqr.track(&x, &x_ref, &u_ref))
    );
    model_functions_agree(&output);
    f64_ekf_agrees(&output);
    dkf_agrees(&output);
    let constants = format!(
        "constants {} {} {} {}\n",
        cantilever::X_LEN,
        cantilever::EKF_STEP_CYCLES,
        cantilever::Lqr::HORIZON,
        cantilever::EKF_STEP_OPS.mul
    );
    assert!(output.contains(&constants), "{constants} not in\n{output}");
    assert_eq!(printed_f32(&output, "ts"), bits(&[cantilever::TS]));
}

/// The DKF's run: each step's outcome (the window's status and each stage's, as their C
/// enums number them: the Rust variants' order), then the estimates after a predict.
fn dkf_agrees(output: &str) {
    let mut dkf = cantilever::Dkf::new(&X0, &P0, &Q, &P0, &Q, &R).expect("a filter");
    let mut outcomes = Vec::new();
    for k in 1..=40 {
        let outcome = dkf.step(&[input_at(k - 1)], &[measurement_at(k)]);
        outcomes.extend([
            outcome.window as u64,
            outcome.akf as u64,
            outcome.lkf as u64,
        ]);
    }
    assert_eq!(printed(output, "dkf_outcomes"), outcomes);
    assert!(dkf.predict(&[input_at(40)]).is_ok());
    assert_eq!(printed_f32(output, "dkf_state"), bits(&dkf.state()));
    assert_eq!(
        printed_f32(output, "dkf_covariance"),
        bits(dkf.covariance().as_flattened())
    );
    assert_eq!(printed_f32(output, "dkf_akf_state"), bits(&dkf.akf_state()));
    assert_eq!(
        printed_f32(output, "dkf_akf_covariance"),
        bits(dkf.akf_covariance().as_flattened())
    );
    assert_eq!(
        printed_f32(output, "dkf_innovation"),
        bits(&[dkf.innovation()[0], dkf.normalised_innovation_squared()])
    );
    assert_eq!(
        printed_f32(output, "dkf_akf_innovation"),
        bits(&[
            dkf.akf_innovation()[0],
            dkf.akf_normalised_innovation_squared()
        ])
    );
    let theta = dkf.window_parameters();
    let window = [
        dkf.window_equation_noise(),
        dkf.excitation(),
        theta[0],
        theta[1],
        theta[2],
    ];
    // A tight gate: the first step's measurement the LKF refuses and the AKF takes, so
    // the status returned is the LKF's; the second's the other way round.
    assert_eq!(dkf.set_innovation_gate(4.0), cantilever::Status::Ok);
    let first = dkf.step(&[input_at(41)], &[0.1]);
    let second = dkf.step(&[input_at(42)], &[0.0]);
    assert_eq!(first.akf, cantilever::Status::Ok);
    assert_eq!(first.lkf, cantilever::Status::OutlierRejected);
    assert_eq!(second.akf, cantilever::Status::OutlierRejected);
    assert_eq!(
        printed(output, "dkf_gated"),
        [
            first.lkf as u64,
            first.akf as u64,
            first.lkf as u64,
            second.akf as u64,
            second.akf as u64,
            second.lkf as u64
        ]
    );
    assert_eq!(printed_f32(output, "dkf_window"), bits(&window));
}

fn model_functions_agree(output: &str) {
    let (x, u) = ([0.5, -1.0, -400.0, -1.0, 50.0], [0.25]);
    assert_eq!(printed_f32(output, "f"), bits(&cantilever::f(&x, &u)));
    assert_eq!(printed_f32(output, "h"), bits(&cantilever::h(&x)));
    let a = cantilever::jacobian_f_wrt_x(&x, &u);
    assert_eq!(
        printed_f32(output, "jacobian_f_wrt_x"),
        bits(a.as_flattened())
    );
    let b = cantilever::jacobian_f_wrt_u(&x, &u);
    assert_eq!(
        printed_f32(output, "jacobian_f_wrt_u"),
        bits(b.as_flattened())
    );
    let c = cantilever::jacobian_h_wrt_x(&x);
    assert_eq!(
        printed_f32(output, "jacobian_h_wrt_x"),
        bits(c.as_flattened())
    );
}

fn f64_ekf_agrees(output: &str) {
    // The C program's double constants (not the f32 ones widened).
    let p0 = [
        [1.0, 0.0, 0.0, 0.0, 0.0],
        [0.0, 1.0, 0.0, 0.0, 0.0],
        [0.0, 0.0, 100.0, 0.0, 0.0],
        [0.0, 0.0, 0.0, 1.0, 0.0],
        [0.0, 0.0, 0.0, 0.0, 10.0],
    ];
    let (x0, q, r) = (
        [0.0, 0.0, -400.0, -1.0, 50.0],
        [1e-6, 1e-4, 1e-2, 1e-4, 1e-3],
        [[1e-4]],
    );
    let mut ekf = cantilever::in_f64::Ekf::new(&x0, &p0, &q, &r).expect("a filter");
    for k in 1..=40 {
        let status = ekf.step(
            &[f64::from(input_at(k - 1))],
            &[f64::from(measurement_at(k))],
        );
        assert_eq!(status, cantilever::Status::Ok);
    }
    assert_eq!(
        ekf.predict(&[f64::from(input_at(40))]),
        cantilever::Status::Ok
    );
    assert_eq!(
        ekf.update(&[f64::from(measurement_at(41))]),
        cantilever::Status::Ok
    );
    let state: Vec<u64> = ekf.state().iter().map(|v| v.to_bits()).collect();
    assert_eq!(printed(output, "f64_ekf_state"), state);
    let covariance: Vec<u64> = ekf
        .covariance()
        .as_flattened()
        .iter()
        .map(|v| v.to_bits())
        .collect();
    assert_eq!(printed(output, "f64_ekf_covariance"), covariance);
}

#[test]
fn the_c_programs_call_every_function_of_the_types_they_cover() {
    let covered = [
        "cantilever_ekf_",
        "cantilever_gated_ekf_",
        "cantilever_dkf_",
        "cantilever_lqr_",
        "cantilever_f64_ekf_",
    ];
    let free = ["cantilever_f(", "cantilever_h(", "cantilever_jacobian_"];
    assert!(calls_every_function("cantilever", &covered, &free) >= 60);
    let covered = [
        "mass_spring_damper_mpc_",
        "mass_spring_damper_hybrid_ekf_",
        "mass_spring_damper_f64_mpc_",
    ];
    let free = [
        "mass_spring_damper_f(",
        "mass_spring_damper_h(",
        "mass_spring_damper_jacobian_",
    ];
    assert!(calls_every_function("mass_spring_damper", &covered, &free) >= 35);
}

/// Asserts that `tests/c/<model>.c` calls every function of the header whose name starts
/// with one of `covered` (or, followed by `(`, of `free`); how many there are.
fn calls_every_function(model: &str, covered: &[&str], free: &[&str]) -> usize {
    let header = std::fs::read_to_string(companion_of(model).join(format!("include/{model}.h")))
        .expect("header");
    let program =
        std::fs::read_to_string(workspace_path(&format!("tests/c/{model}.c"))).expect("program");
    let returns = format!("{model}_status_t ");
    let mut checked = 0;
    for line in header.lines().filter(|l| l.starts_with(&returns)) {
        let name = &line[returns.len()..line.find('(').expect("a declaration")];
        let is_covered = covered.iter().any(|p| name.starts_with(p))
            || free.iter().any(|p| format!("{name}(").starts_with(p));
        if is_covered {
            checked += 1;
            assert!(
                program.contains(&format!("{name}(")),
                "tests/c/{model}.c never calls {name}"
            );
        }
    }
    checked
}

/// The state `tests/c/mass_spring_damper.c` gives the MPC at sample `k`.
#[allow(clippy::cast_precision_loss)]
fn mpc_state_at(k: i32) -> [f32; 5] {
    [
        0.002 * ((k * 3) % 7) as f32 - 0.006,
        0.05 * ((k * 5) % 9) as f32 - 0.2,
        0.0,
        0.0,
        5.0 + 0.5 * (k / 10) as f32,
    ]
}

/// An MPC solve's outcome as the C program prints it: its fields, the enums numbered in
/// their variants' order (the f32 and f64 outcomes are two types).
macro_rules! outcome_fields {
    ($outcome:expr) => {{
        let outcome = $outcome;
        [
            outcome.status as u64,
            u64::from(outcome.optimal),
            outcome.iterations as u64,
            u64::from(outcome.terminal_weight_converged),
            outcome.rebuilt as u64,
        ]
    }};
}

#[test]
fn the_sanitised_mpc_program_passes_and_computes_what_rust_computes() {
    let output = c_program_output("mass_spring_damper");
    assert!(
        output.contains("failures 0\n"),
        "the C program's checks failed:\n{output}"
    );
    mpc_agrees(&output);
    hybrid_ekf_agrees(&output);
    let x = [0.01, -0.2, 0.5, -1.0, 5.0];
    assert_eq!(
        printed_f32(&output, "f"),
        bits(&mass_spring_damper::f(&x, &[10.0]))
    );
    assert_eq!(printed_f32(&output, "h"), bits(&mass_spring_damper::h(&x)));
    assert_eq!(
        printed_f32(&output, "jacobian_h_wrt_x"),
        bits(mass_spring_damper::jacobian_h_wrt_x(&x).as_flattened())
    );
    f64_mpc_agrees(&output);
}

fn mpc_agrees(output: &str) {
    use mass_spring_damper::{Mpc, Status};
    let (q, r) = ([[1e4, 0.0], [0.0, 1.0]], [[1e-4]]);
    let (u_min, u_max) = ([-3.0], [3.0]);
    let mut mpc = Mpc::new(&q, &r, &u_min, &u_max).expect("an MPC");
    assert_eq!(mpc.set_reference(&[0.0, 0.0], &[0.0]), Status::Ok);
    assert_eq!(mpc.set_weights(&q, &r), Status::Ok);
    assert_eq!(mpc.set_input_limits(&u_min, &u_max), Status::Ok);
    let mut u = [0.0];
    let refusals = [
        mpc.solve(&[0.0, f32::NAN, 0.0, 0.0, 5.0], &u).status as u64,
        mpc.set_weights(&[[f32::NAN, 0.0], [0.0, 1.0]], &r) as u64,
        mpc.set_input_limits(&[1.0], &[-1.0]) as u64,
    ];
    assert_eq!(printed(output, "mpc_refusals"), refusals);
    assert!(refusals.iter().all(|&s| s != Status::Ok as u64));
    let mut outcomes = Vec::new();
    for k in 0..30 {
        outcomes.extend(outcome_fields!(mpc.solve(&mpc_state_at(k), &u)));
        u = mpc.control();
    }
    assert_eq!(printed(output, "mpc_outcomes"), outcomes);
    // The model was rebuilt as the inverse mass moved, and some solves held a bound.
    assert!(outcomes.chunks(5).any(|o| o[4] == 2));
    assert!(outcomes.chunks(5).any(|o| o[2] > 1));
    assert_eq!(mpc.solve(&mpc_state_at(29), &u).status, Status::Ok);
    assert_eq!(printed_f32(output, "mpc_control"), bits(&mpc.control()));
    assert_eq!(
        printed_f32(output, "mpc_plan"),
        bits(mpc.plan().as_flattened())
    );
    let model = mpc.model();
    assert_eq!(
        printed_f32(output, "mpc_model"),
        bits(model.a.as_flattened())
    );
    assert_eq!(
        printed_f32(output, "mpc_model_b"),
        bits(model.b.as_flattened())
    );
    assert_eq!(
        printed_f32(output, "mpc_terminal_weight"),
        bits(mpc.terminal_weight().as_flattened())
    );
    assert_eq!(
        printed_f32(output, "mpc_terminal_gain"),
        bits(mpc.terminal_gain().as_flattened())
    );
    let predicted = Mpc::prediction_model(&mpc_state_at(29), &mpc.control()).expect("a model");
    assert_eq!(
        printed_f32(output, "mpc_prediction_model"),
        bits(predicted.a.as_flattened())
    );
}

#[allow(clippy::cast_precision_loss)]
fn hybrid_ekf_agrees(output: &str) {
    use mass_spring_damper::HybridEkf;
    let x0 = [0.0, 0.0, 0.0, 0.0, 2.0];
    let mut p0 = [[0.0; 5]; 5];
    for (i, variance) in [1e-6, 1e-4, 1e-4, 1e-2, 1.0].into_iter().enumerate() {
        p0[i][i] = variance;
    }
    let mut ekf = HybridEkf::new(&x0, &p0, &[1e-2, 1e-3], &[[1e-8]]).expect("a filter");
    let statuses: Vec<u64> = (1..=20)
        .map(|k| {
            let u_prev = (k % 5) as f32 - 2.0;
            let y = 1e-4 * ((k * 7) % 11) as f32 - 5e-4;
            ekf.step(&[u_prev], &[y]) as u64
        })
        .collect();
    assert_eq!(printed(output, "hybrid_statuses"), statuses);
    assert_eq!(ekf.predict(&[1.0]), mass_spring_damper::Status::Ok);
    assert_eq!(ekf.update(&[2e-4]), mass_spring_damper::Status::Ok);
    assert_eq!(printed_f32(output, "hybrid_state"), bits(&ekf.state()));
    assert_eq!(
        printed_f32(output, "hybrid_covariance"),
        bits(ekf.covariance().as_flattened())
    );
    assert_eq!(
        printed_f32(output, "hybrid_innovation"),
        bits(&[ekf.innovation()[0], ekf.normalised_innovation_squared()])
    );
    assert_eq!(
        printed(output, "hybrid_refusals"),
        [u64::from(ekf.refusals())]
    );
}

fn f64_mpc_agrees(output: &str) {
    use mass_spring_damper::in_f64::Mpc;
    let mut mpc =
        Mpc::new(&[[1e4, 0.0], [0.0, 1.0]], &[[1e-4]], &[-100.0], &[100.0]).expect("an MPC");
    let mut u = [0.0];
    let mut outcomes = Vec::new();
    for k in 0..10 {
        let x = mpc_state_at(k).map(f64::from);
        outcomes.extend(outcome_fields!(mpc.solve(&x, &u)));
        u = mpc.control();
    }
    assert_eq!(printed(output, "f64_mpc_outcomes"), outcomes);
    let f64_bits = |values: &[f64]| values.iter().map(|v| v.to_bits()).collect::<Vec<u64>>();
    assert_eq!(printed(output, "f64_mpc_control"), f64_bits(&u));
    assert_eq!(
        printed(output, "f64_mpc_plan"),
        f64_bits(mpc.plan().as_flattened())
    );
    assert_eq!(
        printed(output, "f64_mpc_model"),
        f64_bits(mpc.model().a.as_flattened())
    );
    let (weight, gain) = (mpc.terminal_weight(), mpc.terminal_gain());
    assert_eq!(
        printed(output, "f64_mpc_terminal"),
        f64_bits(&[weight[0][0], weight[1][1], gain[0][0], gain[0][1]])
    );
}

/// The symbols of an object file or image, as `nm` lists them.
fn symbols(nm: &str, file: &Path) -> String {
    run(Command::new(nm).arg(file))
}

#[test]
fn no_panic_is_reachable_from_the_host_library() {
    let library = symbols("nm", &host_library());
    assert!(library.contains(" T cantilever_ekf_step\n"), "{library}");
    // The handler is linked only if a call can reach it; release builds with LTO drop it.
    assert!(
        !library.to_lowercase().contains("panic"),
        "a panic is reachable:\n{library}"
    );
}

#[test]
fn the_cortex_m4f_library_links_into_a_c_program_without_a_rust_runtime() {
    use stateforge_cli::measure::{setup, TARGET};
    setup::rust_target(TARGET).expect("the Cortex-M4F target");
    setup::debian_commands(&[
        ("arm-none-eabi-gcc", "gcc-arm-none-eabi"),
        ("arm-none-eabi-nm", "binutils-arm-none-eabi"),
    ])
    .expect("the ARM compiler");
    let dir = companion();
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    run(Command::new(cargo)
        .args([
            "build",
            "--release",
            "--quiet",
            "--target",
            TARGET,
            "--target-dir",
        ])
        .arg(dir.join("target"))
        .current_dir(&dir)
        .env_remove("RUSTFLAGS")
        .env_remove("CARGO_ENCODED_RUSTFLAGS"));
    let image = dir.join("cantilever_m4f.elf");
    // The whole test program, against newlib without an operating system: every symbol
    // the library needs is the C library's (`memcpy` and friends) or its own.
    run(Command::new("arm-none-eabi-gcc")
        .args([
            "-std=c99",
            "-Wall",
            "-Wextra",
            "-Wpedantic",
            "-Werror",
            "-O2",
        ])
        .args([
            "-mcpu=cortex-m4",
            "-mthumb",
            "-mfloat-abi=hard",
            "-mfpu=fpv4-sp-d16",
        ])
        .arg("-I")
        .arg(dir.join("include"))
        .arg(workspace_path("tests/c/cantilever.c"))
        .arg(dir.join(format!("target/{TARGET}/release/libcantilever_c.a")))
        .args(["--specs=nosys.specs", "-lm", "-o"])
        .arg(&image));
    let linked = symbols("arm-none-eabi-nm", &image);
    assert!(linked.contains(" T cantilever_lqr_solve\n"), "{linked}");
    assert!(
        !linked.to_lowercase().contains("panic"),
        "a panic is reachable:\n{linked}"
    );
}

#[test]
fn every_demo_models_companion_crate_type_checks_with_its_size_assertions() {
    // A check evaluates each crate's assertions that its storage types and outcome structs
    // have the sizes the header states, and compiles every wrapper; the limited
    // quadrotor's MPC (the dual active set) holds `stateforge_math::HeldLimits` and a
    // nested struct. One target directory for all: `stateforge-math` is checked once.
    let target = Path::new(env!("CARGO_TARGET_TMPDIR")).join("c-api-check");
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    for name in tests::DEMO_MODELS.into_iter().chain(["quadrotor_limited"]) {
        let dir = companion_of(name);
        run(Command::new(&cargo)
            .args(["check", "--quiet", "--target-dir"])
            .arg(&target)
            .current_dir(&dir)
            .env_remove("RUSTFLAGS")
            .env_remove("CARGO_ENCODED_RUSTFLAGS"));
        let header =
            std::fs::read_to_string(dir.join(format!("include/{name}.h"))).expect("header");
        assert!(
            !header.contains("not in the C API (the Rust type"),
            "{name}: a type the tool cannot size"
        );
    }
}

#[test]
fn every_demo_models_header_compiles_as_c99_and_cpp17() {
    for name in tests::DEMO_MODELS {
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("c-api-header-{name}"));
        let options = stateforge_cli::c_api::Options {
            math_dependency: stateforge_cli::math_dependency(),
            provenance: format!("// Generated for the tests from {name}."),
        };
        stateforge_cli::c_api::write(&tests::demo_model_code(name), &dir, &options)
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        let header = dir.join(format!("include/{name}.h"));
        let text = std::fs::read_to_string(&header).expect("header");
        assert!(
            text.contains(&format!("{name}_status_t {name}_")),
            "{name}: no function"
        );
        for (compiler, standard, language) in
            [("gcc", "-std=c99", "c"), ("g++", "-std=c++17", "c++")]
        {
            run(Command::new(compiler)
                .args([standard, "-Wall", "-Wextra", "-Wpedantic", "-Werror"])
                .args(["-fsyntax-only", "-x", language])
                .arg(&header));
        }
    }
}
