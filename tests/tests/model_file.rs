//! The TOML front end lowers to the same IR as the macro: the cantilever written both ways
//! generates the same code (documentation aside), and model-file mistakes are reported.

use tests::{demo_model_source, workspace_path};

/// Generated code without its documentation lines.
fn code_without_docs(tokens: proc_macro2::TokenStream) -> String {
    let text = stateforge_cli::format(tokens).expect("formats");
    text.lines()
        .filter(|l| !l.trim_start().starts_with("///") && !l.trim_start().starts_with("//!"))
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn cantilever_model_file_generates_the_macros_code() {
    let toml = std::fs::read_to_string(workspace_path("model-codegen/models/cantilever.toml"))
        .expect("model file exists");
    let from_file = stateforge_cli::expand_model_file(&toml).expect("model file expands");
    let from_macro = stateforge_compiler::expand_macro_source(&demo_model_source("cantilever"))
        .expect("macro expands");
    assert_eq!(code_without_docs(from_file), code_without_docs(from_macro));
}

fn errors_of(toml: &str) -> String {
    match stateforge_cli::expand_model_file(toml) {
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
    let model = stateforge_cli::parse_model_file(
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
    let text = stateforge_cli::meval_text::to_meval(&model, &model.dynamics.rhs[0]);
    // meval binds unary minus tighter than `*`: `(-K) * x^3`, the same value.
    assert_eq!(text, "if_gt(x, (0e0), ((-K) * (x^(3))), (0e0))");
}

/// A one-state model file with `name`, `visibility` and the state's equation given.
fn small_model(name: &str, visibility: &str, equation: &str) -> String {
    format!(
        "name = {name:?}\n{visibility}\nscalar = \"f32\"\n[[state]]\nname = \"x\"\n\
         [dynamics]\nkind = \"discrete\"\n[dynamics.equations]\nx = {equation:?}\n"
    )
}

#[test]
fn model_file_names_must_be_identifiers() {
    for bad in ["", "my model", "1st", "fn", "r#type", "m//comment", "x²"] {
        let errors = errors_of(&small_model(bad, "", "x"));
        assert!(
            errors.contains("not a Rust identifier") || errors.contains("raw identifiers"),
            "{bad:?}: {errors}"
        );
    }
}

#[test]
fn model_file_visibility_is_one_of_four_words_never_pasted() {
    for bad in ["fn evil() {} pub", "1", "pub(in crate::x)"] {
        let errors = errors_of(&small_model("m", &format!("visibility = {bad:?}"), "x"));
        assert!(
            errors.contains("unknown variant") && errors.contains("`pub(crate)`"),
            "{bad:?}: {errors}"
        );
    }
    for good in ["pub", "pub(crate)", "pub(super)", "private"] {
        let tokens = stateforge_cli::expand_model_file(&small_model(
            "m",
            &format!("visibility = {good:?}"),
            "x",
        ))
        .unwrap_or_else(|e| panic!("{good}: {e}"));
        let code = stateforge_cli::format(tokens).expect("parses");
        let expected = match good {
            "private" => "mod m {".to_string(),
            vis => format!("{vis} mod m {{"),
        };
        assert!(code.contains(&expected), "{good}: {code}");
    }
}

#[test]
fn model_file_expressions_are_checked_before_meval() {
    let cases = [
        (" ".to_string(), "empty"),
        ("".to_string(), "empty"),
        // meval reads `nan` and `inf` as names, not numbers.
        ("nan".to_string(), "unknown symbol `nan`"),
        ("x * inf".to_string(), "unknown symbol `inf`"),
        ("x % 2".to_string(), "`%`"),
        ("ln(0) * x".to_string(), "-inf"),
        (format!("{}x{}", "(".repeat(1000), ")".repeat(1000)), "nest"),
        (
            format!("{}x{}", "sin(".repeat(10_000), ")".repeat(10_000)),
            "long",
        ),
        (format!("x{}", "+x".repeat(5000)), "operators"),
        (format!("{}x", "-".repeat(10_000)), "operators"),
    ];
    for (equation, expected) in cases {
        let errors = errors_of(&small_model("m", "", &equation));
        assert!(
            errors.contains(expected),
            "{}: {errors}",
            &equation[..equation.len().min(40)]
        );
    }
}

#[test]
fn model_file_numbers_must_be_finite_in_the_scalar_type() {
    let file = |value: &str| {
        format!(
            "name = \"m\"\nscalar = \"f32\"\n[[const]]\nname = \"K\"\nvalue = {value}\n\
             [[state]]\nname = \"x\"\n[dynamics]\nkind = \"discrete\"\n\
             [dynamics.equations]\nx = \"K * x\"\n"
        )
    };
    assert!(errors_of(&file("nan")).contains("finite"));
    assert!(errors_of(&file("inf")).contains("finite"));
    assert!(errors_of(&file("1e300")).contains("overflows in f32"));
    assert!(errors_of(&file("\"1 / 0\"")).contains("division by zero"));
    // TOML's own `nan` as an equation.
    let equation = small_model("m", "", "x").replace("x = \"x\"", "x = nan");
    assert!(errors_of(&equation).contains("finite"), "{equation}");
}
