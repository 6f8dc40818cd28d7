//! Shared helpers of the integration tests: where the demo models are, and reading them.

#![forbid(unsafe_code)]

use std::path::PathBuf;

pub mod cantilever_sim;
pub mod compare;
pub mod continuous_reference;
pub mod error_state_reference;
pub mod plane;
pub mod predictive_reference;
pub mod reference;
pub mod rng;
pub mod scale;
pub mod tuning;

/// Names of the demo models, as their files in `generated-demo/models/` are named.
pub const DEMO_MODELS: [&str; 10] = [
    "cantilever",
    "mass_spring_damper",
    "polynomial",
    "piecewise_beam",
    "helicopter",
    "beam_two_actuators",
    "duffing_beam",
    "blade_identification",
    "cantilever_long_window",
    "navigation",
];

/// The demo models whose generated code is too large to review as a snapshot: the
/// 24-state navigation model's is 2 MB. The shape of its sensor updates is in the `rover`
/// test model's snapshot; its numbers are checked by `tests/navigation_sensors.rs`.
pub const UNSNAPSHOTTED_DEMO_MODELS: [&str; 1] = ["navigation"];

/// Names of the test models in `tests/models/` (`model! { .. }` invocations that exercise
/// parts of the language the demo models do not use).
pub const TEST_MODELS: [&str; 13] = [
    "rover",
    "rover_known",
    "ahrs",
    "vehicle_geometry",
    "dead_reckoning",
    "dead_reckoning_timed",
    "carried_state",
    "delayed_fix",
    "jittered",
    "jittered_late",
    "varying_delay",
    "jittered_pendulum",
    "planar_limits",
];

/// The generated code of a test model, formatted.
pub fn test_model_code(name: &str) -> String {
    let path = workspace_path(&format!("tests/models/{name}.rs"));
    let source = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
    let tokens = stateforge_compiler::expand_macro_source(&source)
        .unwrap_or_else(|e| panic!("test model {name} does not expand: {e}"));
    stateforge_cli::format(tokens).expect("generated code parses as a Rust file")
}

/// Path of a file of the workspace, given relative to its root.
pub fn workspace_path(relative: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join(relative)
}

/// Source of a demo model (`model! { .. }` invocation).
pub fn demo_model_source(name: &str) -> String {
    let path = workspace_path(&format!("generated-demo/models/{name}.rs"));
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()))
}

/// The generated code of a demo model, formatted.
pub fn demo_model_code(name: &str) -> String {
    let tokens = stateforge_compiler::expand_macro_source(&demo_model_source(name))
        .unwrap_or_else(|e| panic!("demo model {name} does not expand: {e}"));
    stateforge_cli::format(tokens).expect("generated code parses as a Rust file")
}
