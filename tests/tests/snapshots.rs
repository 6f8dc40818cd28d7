//! Snapshots of the generated code of every demo model, formatted with prettyplease.
//! Review changes with `cargo insta review`; CI never writes snapshots, so a missing or
//! changed one fails.

use tests::{demo_model_code, DEMO_MODELS};

#[test]
fn generated_code_of_every_demo_model() {
    for name in DEMO_MODELS {
        insta::assert_snapshot!(name, demo_model_code(name));
    }
}
