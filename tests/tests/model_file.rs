//! The TOML front end lowers to the same IR as the macro: the cantilever written both ways
//! generates the same code (documentation aside), and model-file mistakes are reported.

use tests::{demo_model_source, workspace_path};

/// Generated code without its documentation lines.
fn code_without_docs(tokens: proc_macro2::TokenStream) -> String {
    let text = model_dsl::format(tokens).expect("formats");
    text.lines()
        .filter(|l| !l.trim_start().starts_with("///") && !l.trim_start().starts_with("//!"))
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn cantilever_model_file_generates_the_macros_code() {
    let toml = std::fs::read_to_string(workspace_path("model-dsl/models/cantilever.toml"))
        .expect("model file exists");
    let from_file = model_dsl::expand_model_file(&toml).expect("model file expands");
    let from_macro =
        model_dsl::expand_macro_source(&demo_model_source("cantilever")).expect("macro expands");
    assert_eq!(code_without_docs(from_file), code_without_docs(from_macro));
}

fn errors_of(toml: &str) -> String {
    match model_dsl::expand_model_file(toml) {
        Ok(_) => panic!("expected errors for:\n{toml}"),
        Err(e) => e
            .into_iter()
            .map(|e| e.to_string())
            .collect::<Vec<_>>()
            .join("\n"),
    }
}

#[test]
fn model_file_mistakes_are_all_reported_with_their_field() {
    let errors = errors_of(
        r#"
        name = "broken"
        scalar = "f32"
        [[state]]
        name = "x1"
        [[state]]
        name = "x2"
        [dynamics]
        kind = "discrete"
        [dynamics.equations]
        x1 = "x1 + y9"
        x2 = "x2 * ("
        "#,
    );
    assert!(
        errors.contains("unknown symbol `y9` in the dynamics of `x1`"),
        "{errors}"
    );
    assert!(
        errors.contains("dynamics.equations.x2: cannot parse"),
        "{errors}"
    );
}

#[test]
fn model_file_piecewise_and_powers_are_understood() {
    let model = model_dsl::parse_model_file(
        r#"
        name = "spring"
        scalar = "f64"
        [[const]]
        name = "K"
        value = "2 * 3"
        [[state]]
        name = "x"
        [dynamics]
        kind = "continuous"
        method = "euler"
        dt = 0.01
        [dynamics.equations]
        x = "if_gt(x, 0, -K * x^3, 0)"
        "#,
    )
    .expect("valid model file");
    assert_eq!(model.constants[0].value, 6.0);
    let text = model_dsl::meval_text::to_meval(&model, &model.dynamics.rhs[0]);
    // meval binds unary minus tighter than `*`: `(-K) * x^3`, the same value.
    assert_eq!(text, "if_gt(x, (0e0), ((-K) * (x^(3))), (0e0))");
}
