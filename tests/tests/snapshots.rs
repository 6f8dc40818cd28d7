//! Snapshots of the generated code of every demo and test model, formatted with
//! prettyplease. Review changes with `cargo insta review`; CI never writes snapshots, so a
//! missing or changed one fails.

use tests::{
    demo_model_code, test_model_code, DEMO_MODELS, TEST_MODELS, UNSNAPSHOTTED_DEMO_MODELS,
};

#[test]
fn generated_code_of_every_demo_model() {
    for name in DEMO_MODELS {
        if UNSNAPSHOTTED_DEMO_MODELS.contains(&name) {
            continue;
        }
        insta::assert_snapshot!(name, demo_model_code(name));
    }
}

#[test]
fn generated_code_of_every_test_model() {
    for name in TEST_MODELS {
        insta::assert_snapshot!(format!("test_model_{name}"), test_model_code(name));
    }
}
