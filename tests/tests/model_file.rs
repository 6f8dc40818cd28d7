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

/// The model of the TOML example in `codegen-macros/doc/model-files.md`, as the macro writes it.
const DOCUMENTED_MODEL: &str = r#"
stateforge::model! {
    /// A forced, damped oscillator.
    pub mod oscillator {
        scalar f32, f64;
        /// Sample time [s].
        const TS = 0.01;
        state x1, x2;
        input u;
        output y = x1, spring_force = spring;
        generate ekf(process_noise = diagonal), hybrid_ekf;
        dynamics continuous(rk4, dt = TS, substeps = 2) {
            let spring = -4.0 * x1;
            der(x1) = x2;
            der(x2) = spring - 0.2 * x2 + u;
        }
    }
}
"#;

#[test]
fn the_documented_model_file_generates_the_macros_code() {
    let doc = std::fs::read_to_string(workspace_path("codegen-macros/doc/model-files.md"))
        .expect("the model-file documentation exists");
    let toml = doc
        .split("```toml\n")
        .nth(1)
        .and_then(|rest| rest.split("```").next())
        .expect("the documentation has a TOML example");
    let from_file = stateforge_cli::expand_model_file(toml).expect("the example expands");
    let from_macro =
        stateforge_compiler::expand_macro_source(DOCUMENTED_MODEL).expect("macro expands");
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
        errors.contains("dynamics.equations.x2: `x2 * (` ends where a value belongs"),
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
    .expect("valid model file")
    .model;
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
    // Beyond f64 TOML itself cannot read it; the error says which number and what to do.
    assert_error(
        &file("-1e400"),
        "5:9: model file: `-1e400` is beyond the largest number a model can hold (about \
         1.8e308 in f64, 3.4e38 in f32): every number must be finite; rescale the model's units",
    );
    assert!(errors_of(&file("\"1 / 0\"")).contains("division by zero"));
    // TOML's own `nan` as an equation.
    let equation = small_model("m", "", "x").replace("x = \"x\"", "x = nan");
    assert!(errors_of(&equation).contains("finite"), "{equation}");
}

/// A small valid model file; each case below changes one thing in it. Its lines:
/// 1 `name`, 2 `scalar`, 3-5 the constant `TS`, 6-9 the states, 10-11 the input, 12-14 the
/// output, 15-16 `[dynamics]` and its `kind`, 17-19 the equations.
const SMALL: &str = r#"name = "m"
scalar = "f32"
[[const]]
name = "TS"
value = 0.01
[[state]]
name = "x1"
[[state]]
name = "x2"
[[input]]
name = "u"
[[output]]
name = "y"
value = "x1"
[dynamics]
kind = "discrete"
[dynamics.equations]
x1 = "x1 + TS * x2"
x2 = "x2 + TS * u"
"#;

/// `SMALL` with `from` (written once in it) replaced by `to`.
fn small_with(from: &str, to: &str) -> String {
    assert_eq!(SMALL.matches(from).count(), 1, "{from}");
    SMALL.replace(from, to)
}

/// Each error of the model file as `line:column: message`, the column counted in
/// characters from 1: where `model-codegen` prints it and puts the caret.
fn placed_errors_of(toml: &str) -> Vec<String> {
    match stateforge_cli::expand_model_file(toml) {
        Ok(_) => panic!("expected errors for:\n{toml}"),
        Err(errors) => errors
            .into_iter()
            .map(|e| {
                let at = e.span().start();
                format!("{}:{}: {e}", at.line, at.column + 1)
            })
            .collect(),
    }
}

/// Asserts that `toml` gives the error `expected` (`line:column: message`), and that no
/// error of it is written in the macro's syntax.
fn assert_error(toml: &str, expected: &str) {
    let errors = placed_errors_of(toml);
    assert!(
        errors.iter().any(|e| e == expected),
        "expected\n{expected}\namong\n{}",
        errors.join("\n")
    );
    for error in &errors {
        for macro_syntax in [
            "dynamics discrete",
            "dynamics continuous(",
            "der(",
            "...;",
            "(..)",
            "`state ",
            "`output ",
            "scalar f32;",
            "untagged enum",
        ] {
            assert!(
                !error.contains(macro_syntax),
                "{error}: `{macro_syntax}` is not how a model file says it"
            );
        }
    }
}

#[test]
fn a_generator_option_of_the_wrong_kind_says_what_it_takes_under_the_value() {
    let takes = "`true` is not a value of `gate`, which takes a positive number (a chi-square \
                 quantile), `gate = 10.83`, or `gate = \"off\"`";
    let table = format!("{SMALL}[generate.ekf]\ngate = true\n");
    assert_error(&table, &format!("21:8: generate.ekf.gate: {takes}"));
    let inline =
        format!("{SMALL}[generate]\nekf = {{ process_noise = \"diagonal\", gate = true }}\n");
    assert_error(&inline, &format!("21:44: generate.ekf.gate: {takes}"));
    // A table where a number belongs, a number where a name belongs in a list.
    let horizon = format!(
        "{SMALL}[generate.lqr]\nhorizon = {{ steps = 50 }}\nstates = [\"x1\", 2]\ninput = \"u\"\n"
    );
    assert_error(
        &horizon,
        "21:11: generate.lqr.horizon: a table is not a value of `horizon`, which takes a whole \
         number, `horizon = 50`",
    );
    assert_error(
        &horizon,
        "22:17: generate.lqr.states: `2` is not a name: a list holds names as strings, and \
         `states` takes a state's name as a string or a list of them, `states = [\"x1\", \"x2\"]`",
    );
    // The checks' own explanations of an option's value, in TOML.
    let name = format!("{SMALL}[generate]\nekf = {{ name = \"gated\" }}\n");
    assert_error(
        &name,
        "21:17: `name` is the generated type's name, in UpperCamelCase: `name = \"GatedEkf\"`",
    );
    let noise = format!("{SMALL}[generate]\nekf = {{ process_noise = \"diag\" }}\n");
    assert_error(
        &noise,
        "21:26: `process_noise` is `\"diagonal\"` (only the variances) or `\"full\"` (a \
         symmetric matrix)",
    );
    let noise_on = format!("{SMALL}[generate]\nekf = {{ process_noise_on = [\"x3\"] }}\n");
    assert_error(
        &noise_on,
        "21:30: `x3` is not a state or parameter: `process_noise_on` lists the states and \
         parameters the process noise enters, `process_noise_on = [\"x2\", \"k\"]`; it is zero \
         on the others (by default it enters every state)",
    );
}

#[test]
fn a_generator_entry_that_is_no_generator_says_how_to_ask_for_one() {
    assert_error(
        &format!("{SMALL}[generate]\nekf = \"yes\"\n"),
        "21:8: generate.ekf: `\"yes\"` does not ask for a generator: write `ekf = true`, a table \
         of its options (`ekf = { .. }` or a `[generate.ekf]` table), or a list of tables for \
         several (`ekf = [{ .. }, { .. }]`)",
    );
    assert_error(
        &format!("{SMALL}[generate]\nekff = true\n"),
        "21:1: unknown generator `ekff`: use `ekf`, `dkf`, `polynomial_kf`, \
         `switched_observer`, `lqr`, `mpc`, `hybrid_ekf` or `continuous_ekf` (`ekf = true`, or \
         a table of its options)",
    );
    assert_error(
        &format!("{SMALL}[generate]\nlqr = {{ horizon = 50 }}\n"),
        "21:1: `lqr` needs the states it regulates and the inputs it computes: `lqr = { horizon \
         = 50, states = [\"x1\", \"x2\"], input = \"u\" }`",
    );
    assert_error(
        &format!("{SMALL}[generate]\npolynomial_kf = {{ order = 1 }}\n"),
        "21:1: `polynomial_kf` needs `dt`: write `polynomial_kf = { order = 3, dt = \"TS\", \
         fading = 1e-9, noise_variance = 1e-4, reinit_every = 100, window = 20 }`",
    );
    assert_error(
        &format!("{SMALL}[generate]\nhybrid_ekf = true\n"),
        "21:1: `hybrid_ekf` integrates the continuous dynamics between samples: declare them \
         continuous: `kind = \"continuous\"`, `method = \"euler\"` and `dt = \"TS\"` in \
         `[dynamics]`",
    );
    let no_output = small_with("[[output]]\nname = \"y\"\nvalue = \"x1\"\n", "");
    assert_error(
        &format!("{no_output}[generate]\nekf = true\n"),
        "18:1: `ekf` corrects its estimate with measurements: declare them: `[[output]]` with \
         `name = \"y\"` and `value = \"x1\"`",
    );
}

#[test]
fn continuous_dynamics_without_a_method_or_a_step_are_told_the_toml() {
    assert_error(
        &small_with("kind = \"discrete\"", "kind = \"continuous\""),
        "16:8: continuous dynamics need an integration method: add `method = \"euler\"` or \
         `method = \"rk4\"` to `[dynamics]`, with the step, `dt = \"TS\"` (a number or a \
         constant's name), and optionally `substeps = 2`",
    );
    assert_error(
        &small_with(
            "kind = \"discrete\"",
            "kind = \"continuous\"\nmethod = \"rk4\"",
        ),
        "16:8: the discretisation needs a step: add `dt = \"TS\"` (a constant's name) or \
         `dt = 0.01` to `[dynamics]`",
    );
    assert_error(
        &small_with(
            "kind = \"discrete\"",
            "kind = \"continuous\"\nmethod = \"rk4\"\ndt = \"0\"",
        ),
        "18:7: the step `dt`, a time in seconds, must be positive and finite, not 0",
    );
    assert_error(
        &small_with(
            "kind = \"discrete\"",
            "kind = \"continuous\"\nmethod = \"rk4\"\ndt = \"TS\"\nsubsteps = -1",
        ),
        "19:12: model file: invalid value: integer `-1`, expected a whole number of sub-steps \
         per sample, `substeps = 2`",
    );
    assert_error(
        &small_with("kind = \"discrete\"\n", ""),
        "15:1: model file: missing field `kind`: add `kind = \"discrete\"`, or `kind = \
         \"continuous\"` with `method = \"rk4\"` and `dt = \"TS\"`",
    );
    let no_dynamics = SMALL.split("[dynamics]").next().unwrap_or_default();
    assert_error(
        no_dynamics,
        "1:9: the model has no dynamics: add a `[dynamics]` table with `kind = \"discrete\"` (or \
         `kind = \"continuous\"`, `method = \"rk4\"` and `dt = \"TS\"`), and a \
         `[dynamics.equations]` table with one `x1 = \"...\"` per state",
    );
}

#[test]
fn an_error_inside_an_expression_points_at_its_token() {
    assert_error(
        &small_with("x1 = \"x1 + TS * x2\"", "x1 = \"x1 + * x2\""),
        "18:12: dynamics.equations.x1: `x1 + * x2` has `*` where a value belongs: write a \
         number, a name, a call such as `sin(x1)`, or `(` here",
    );
    let unknown = "unknown symbol `foo` in the dynamics of `x1`: declare it as a `[[state]]`, \
                   `[[param]]`, `[[input]]` or `[[const]]` with `name = \"foo\"`";
    assert_error(
        &small_with("x1 = \"x1 + TS * x2\"", "x1 = \"x1 + foo\""),
        &format!("18:12: {unknown}"),
    );
    assert_error(
        &small_with("x1 = \"x1 + TS * x2\"", "x1 = \"x1 + TS * x22\""),
        "18:17: unknown symbol `x22` in the dynamics of `x1`: did you mean `x2`? (a new name is \
         declared as a `[[state]]`, `[[param]]`, `[[input]]` or `[[const]]`)",
    );
    // Escapes, literal and multi-line strings: the caret still finds the token.
    assert_error(
        &small_with("x1 = \"x1 + TS * x2\"", "x1 = \"x1\\t+ foo\""),
        &format!("18:13: {unknown}"),
    );
    assert_error(
        &small_with("x1 = \"x1 + TS * x2\"", "x1 = 'x1 + foo'"),
        &format!("18:12: {unknown}"),
    );
    assert_error(
        &small_with("x1 = \"x1 + TS * x2\"", "x1 = \"\"\"\nx1 +\n    foo\"\"\""),
        &format!("20:5: {unknown}"),
    );
    let x2 = |expression: &str| small_with("x2 = \"x2 + TS * u\"", &format!("x2 = {expression:?}"));
    assert_error(
        &x2("x2 x1"),
        "19:10: dynamics.equations.x2: `x2 x1` has `x1` where an operator belongs: write `+ - * \
         / ^` between two values",
    );
    assert_error(
        &x2("(x2 + 1))"),
        "19:15: dynamics.equations.x2: `(x2 + 1))` has a `)` that closes no `(`: remove it, or \
         add the `(`",
    );
    assert_error(
        &x2("x2 * (x1 + 1"),
        "19:19: dynamics.equations.x2: `x2 * (x1 + 1` leaves a `(` open: add 1 `)`",
    );
    assert_error(
        &x2("x2 + (x1 > 0)"),
        "19:16: dynamics.equations.x2: `>` has no meaning in an expression: use numbers, names, \
         `+ - * / ^`, parentheses and function calls; a comparison is written as a piecewise \
         function, `if_gt(a, b, then, else)` (also `if_ge`, `if_lt`, `if_le`)",
    );
    assert_error(
        &x2("if_gt(x1, 0, x2)"),
        "19:7: dynamics.equations.x2: `if_gt(a, b, then, else)` takes 4 arguments, found 3",
    );
    assert_error(
        &x2("x2 + x1^2.5"),
        "19:15: the exponent of `^` (or `powi`) must be a whole number between -64 and 64, such \
         as `x^2`",
    );
    assert_error(
        &x2("x2 + foo(x1)"),
        "19:12: unsupported function `foo`: use one of sin, cos, tan, exp, ln, sqrt, abs, tanh, \
         powi, atan2, min, max, clamp, if_gt, if_ge, if_lt, if_le (`if_gt(a, b, then, else)`), \
         or `^` for a whole power (`x^2`)",
    );
}

#[test]
fn values_toml_reads_but_a_model_does_not_say_what_to_write() {
    assert_error(
        &small_with("value = 0.01", "value = true"),
        "5:9: model file: invalid type: boolean `true`, expected a number, such as `0.015`, or \
         an expression in a string, such as `\"2 * TS\"`",
    );
    assert_error(
        &small_with("scalar = \"f32\"", "scalar = 32"),
        "2:10: model file: invalid type: integer `32`, expected a scalar type as a string, \
         `scalar = \"f32\"`, or a list of them, `scalar = [\"f32\", \"f64\"]`",
    );
    assert_error(
        &small_with(
            "x2 = \"x2 + TS * u\"",
            "x2 = x2 + TS * u  # forgot the quotes",
        ),
        "19:6: model file: string values must be quoted: write `\"x2 + TS * u\"`",
    );
    assert_error(
        &format!("{SMALL}x2 = \"x1\"\n"),
        "20:1: model file: duplicate key `x2`: a table gives each key once; remove or rename one",
    );
    assert_error(
        &small_with("scalar = \"f32\"\n", ""),
        "1:1: model file: missing field `scalar`: add `scalar = \"f32\"` (or `scalar = [\"f32\", \
         \"f64\"]`)",
    );
}

#[test]
fn outputs_share_intermediates_and_their_mistakes_are_told_in_toml() {
    // An output reads a `[[dynamics.let]]`: the output of the intermediate, 2 x1 + u.
    let shared = small_with("value = \"x1\"\n", "value = \"drive\"\n").replace(
        "[dynamics.equations]\n",
        "[[dynamics.let]]\nname = \"drive\"\nvalue = \"2 * x1 + u\"\n[dynamics.equations]\n",
    );
    let checked = stateforge_cli::parse_model_file(&shared).expect("the model file checks");
    let model = &checked.model;
    assert!(matches!(
        model.outputs[0].expr,
        stateforge_compiler::model::Expr::Local(0)
    ));
    stateforge_cli::expand_model_file(&shared).expect("the model file expands");
    // An output cannot read another output; the hint says how to share the value.
    let second = small_with(
        "value = \"x1\"\n",
        "value = \"x1\"\n[[output]]\nname = \"y2\"\nvalue = \"2 * y\"\n",
    );
    assert_error(
        &second,
        "17:14: the output `y2` cannot use `y`, an output: an expression reads the model's \
         variables, not its outputs; to share a value, name it in a `[[dynamics.let]]` table \
         and read that (an output may read it too)",
    );
    // The intermediates are read in order.
    let later = small_with(
        "[dynamics.equations]\n",
        "[[dynamics.let]]\nname = \"a\"\nvalue = \"b\"\n[[dynamics.let]]\nname = \"b\"\n\
         value = \"x1\"\n[dynamics.equations]\n",
    );
    assert_error(
        &later,
        "19:10: the intermediate `a` cannot use `b`, an intermediate not defined above this \
         line: a line of `dynamics` reads the intermediates above it; move `[[dynamics.let]]` \
         table of `b` up",
    );
}

#[test]
fn declarations_a_model_file_lacks_are_told_in_toml() {
    assert_error(
        &format!("{SMALL}x3 = \"x1\"\n"),
        "20:1: unknown state `x3`: declare it with `[[state]]` and `name = \"x3\"`",
    );
    assert_error(
        &small_with("x2 = \"x2 + TS * u\"\n", ""),
        "9:9: state `x2` has no dynamics: add `x2 = \"...\"` under `[dynamics.equations]`",
    );
    assert_error(
        &small_with("[[state]]\nname = \"x1\"\n[[state]]\nname = \"x2\"\n", ""),
        "1:9: the model declares no state: add a `[[state]]` table with `name = \"x1\"` for each \
         state",
    );
    assert_error(
        &small_with("scalar = \"f32\"", "scalar = []"),
        "1:9: the model names no scalar type: add `scalar = \"f32\"` (or `scalar = [\"f32\", \
         \"f64\"]` to also generate an f64 version for host checks)",
    );
}

#[test]
fn noise_values_in_generate_say_what_the_option_takes() {
    assert_error(
        &format!("{SMALL}[generate.ekf]\nprocess_noise = [1e-6, 1e-4]\n"),
        "21:17: `process_noise` is `\"diagonal\"` (only the variances) or `\"full\"` (a \
         symmetric matrix); the noise values themselves are given at run time, to `new` and \
         `set_process_noise`",
    );
    assert_error(
        &format!(
            "{SMALL}[generate.switched_observer]\nprocess_noise = [1e-6, 1e-4]\n\
             measurement_noise = [\"TS\"]\n"
        ),
        "21:17: `process_noise` takes a list of names of model constants: declare each value \
         as a `[[const]]` (`name = \"A\"`, `value = 1e-6`), and write `process_noise = [\"A\", \
         \"B\"]`",
    );
}

#[test]
fn a_requirement_names_the_parameter_to_declare_as_a_constant_in_toml() {
    let toml = small_with("[[input]]\nname = \"u\"\n", "[[param]]\nname = \"k\"\n")
        .replace("x2 + TS * u", "x2 - TS * k * x1")
        .replace(
            "x1 + TS * x2\"",
            "x1 + TS * x2 - if_gt(x1, 0, 0.1 * x1, 0)\"",
        );
    assert_error(
        &format!(
            "{toml}[generate.switched_observer]\nprocess_noise = [\"TS\", \"TS\"]\n\
             measurement_noise = [\"TS\"]\n"
        ),
        "20:11: `switched_observer` is designed for a known system, and `k` is a parameter \
         (an unknown estimated as a state): declare it as a constant, `[[const]]` with \
         `name = \"k\"` and its `value`, or estimate it with `ekf`",
    );
}

#[test]
fn vectors_and_rotations_in_a_model_file_generate_the_macros_code() {
    // Components, methods (also chained after a component), functions, typed
    // intermediates read by outputs, and decimals: the macro's model, written as TOML.
    let read = |name: &str| std::fs::read_to_string(workspace_path(name)).expect("test model");
    let from_file = stateforge_cli::expand_model_file(&read("tests/models/vehicle_geometry.toml"))
        .expect("model file expands");
    let from_macro =
        stateforge_compiler::expand_macro_source(&read("tests/models/vehicle_geometry.rs"))
            .expect("macro expands");
    assert_eq!(code_without_docs(from_file), code_without_docs(from_macro));
}

#[test]
fn a_sample_interval_in_a_model_file_generates_the_macros_code() {
    // `interval = true` on a `[[const]]` is the macro's `interval DT = 0.1;`.
    let read = |name: &str| std::fs::read_to_string(workspace_path(name)).expect("test model");
    let from_file = stateforge_cli::expand_model_file(&read("tests/models/jittered.toml"))
        .expect("model file expands");
    let from_macro = stateforge_compiler::expand_macro_source(&read("tests/models/jittered.rs"))
        .expect("macro expands");
    let code = code_without_docs(from_file);
    assert!(
        code.contains("dt: f32"),
        "the predictions take the interval"
    );
    assert_eq!(code, code_without_docs(from_macro));
}

#[test]
fn a_second_sample_interval_is_refused_under_its_name() {
    let toml = small_with(
        "value = 0.01\n",
        "value = 0.01\ninterval = true\n[[const]]\nname = \"DT\"\nvalue = 0.02\ninterval = true\n",
    );
    assert_error(
        &toml,
        "8:9: the sample interval is `TS` already: a model has one, given to each prediction",
    );
}

#[test]
fn a_sample_interval_that_is_not_positive_is_refused_under_its_value() {
    let toml = small_with("value = 0.01\n", "value = -0.01\ninterval = true\n");
    assert_error(
        &toml,
        "5:9: the sample interval's nominal value is positive and finite, in seconds, not \
         -0.01: `0.004` for 4 ms",
    );
    // `interval = false` is a constant like any other.
    let toml = small_with("value = 0.01\n", "value = -0.01\ninterval = false\n");
    assert!(stateforge_cli::expand_model_file(&toml).is_ok());
}

/// A small model file with vectors and a rotation; its output's value, on line 11 from
/// column 10, is what each case below changes.
const GEOMETRY: &str = r#"name = "g"
scalar = "f64"
[[state]]
name = "v"
type = "Vec3"
[[input]]
name = "q"
type = "Rot3"
[[output]]
name = "y"
value = "v.x"
[dynamics]
kind = "discrete"
[dynamics.equations]
v = "q * v"
"#;

/// `GEOMETRY` with its output's value `value`.
fn geometry_output(value: &str) -> String {
    GEOMETRY.replace("value = \"v.x\"", &format!("value = {value:?}"))
}

#[test]
fn a_dot_after_a_parenthesis_says_what_to_write_under_the_dot() {
    stateforge_cli::expand_model_file(GEOMETRY).expect("the base model expands");
    assert_error(
        &geometry_output("2 * (q * v).x"),
        "11:21: output `y`: in a model file a component is read from a name, as in `v.x`, not \
         after a `)`: write `dot(q * v, vec3(1.0, 0.0, 0.0))`, or name the vector in a \
         `[[dynamics.let]]` table and read `.x` of that name (an output may read it too)",
    );
    assert_error(
        &geometry_output("log(q).norm()"),
        "11:16: output `y`: in a model file a method is called on a name, as in `a.norm()`, not \
         after a `)`: write the function, `norm(log(q))`",
    );
    assert_error(
        &geometry_output("(v + v).dot(q * v)"),
        "11:17: output `y`: in a model file a method is called on a name, as in `a.dot(b)`, not \
         after a `)`: write the function, `dot(v + v, q * v)`",
    );
    // What the checks suggest for a rotation's component is written as a model file reads it.
    assert_error(
        &geometry_output("q.x"),
        "11:12: a rotation has no components in a model: measure a vector it rotates, \
         `dot(q * vec3(1.0, 0.0, 0.0), vec3(1.0, 0.0, 0.0))`, or its rotation vector, \
         `dot(log(q), vec3(1.0, 0.0, 0.0))`",
    );
}

#[test]
fn components_and_methods_are_placed_and_checked_as_in_the_macro() {
    assert_error(
        &geometry_output("v.w"),
        "11:12: a vector's components are `x`, `y` and `z`, not `w`",
    );
    // A chain reads a component of a component: the second is under its own name.
    assert_error(
        &geometry_output("v.x.y"),
        "11:14: this is a scalar: it has no component `y` (only vectors do)",
    );
    // A method call is placed at its receiver.
    assert_error(
        &geometry_output("1.5 * q.norm()"),
        "11:16: `q` is a rotation: rotate a vector, `q * v`, or take its rotation vector, \
         `log(q)`",
    );
    let dot = "a `.` follows a name, with no blank between, and a component (`v.x`, `v.y`, \
               `v.z`) or a method (`q.inverse()`, `a.dot(b)`) follows it";
    assert_error(
        &geometry_output("v .x"),
        &format!("11:12: output `y`: `v .x` has `.x`: {dot}"),
    );
    assert_error(
        &geometry_output("v.0"),
        &format!("11:11: output `y`: `v.0` has `.0`: {dot}"),
    );
    assert_error(
        &geometry_output("v.x.abs("),
        "11:18: output `y`: `v.x.abs(` leaves a `(` open: add 1 `)`",
    );
    // Numbers keep their `.`: `2.` and `1.5e-3` are numbers, and `x1.5` no component.
    let checked = stateforge_cli::parse_model_file(&geometry_output("2. * v.x.abs() + 1.5e-3"))
        .expect("numbers and a chained method");
    assert_eq!(checked.model.outputs.len(), 1);
}

#[test]
fn dots_past_the_language_limits_are_refused() {
    // The macro counts a `.` as an operator, and a model file too.
    let sum = vec!["v.x"; 300].join(" + ");
    let errors = errors_of(&geometry_output(&sum));
    assert!(
        errors.contains(
            "more than 512 operators and `.`s in one expression: name parts of it \
                         in `[[dynamics.let]]`"
        ),
        "{errors}"
    );
    // A chain nests as parentheses do, within the same limit.
    let errors = errors_of(&geometry_output(&format!("v{}", ".x".repeat(65))));
    assert!(
        errors.contains("this chain of `.`s nests deeper than 64 levels"),
        "{errors}"
    );
    let errors = errors_of(&geometry_output(&format!("v{}", ".x".repeat(64))));
    assert!(errors.contains("this is a scalar"), "{errors}");
}

#[test]
fn a_mistake_after_leading_blanks_is_reported_not_a_panic() {
    // `meval`'s tokenizer panics on blanks alone, which is what precedes the `)` here.
    assert_error(
        &small_with("x2 = \"x2 + TS * u\"", "x2 = \" )\""),
        "19:8: dynamics.equations.x2: ` )` has a `)` that closes no `(`: remove it, or add the \
         `(`",
    );
}

/// `SMALL` as the macro writes it, with `generate` items `generate`.
fn small_macro(generate: &str) -> String {
    format!(
        "stateforge::model! {{ pub mod m {{ scalar f32; const TS = 0.01; state x1, x2; \
         input u; output y = x1; generate {generate}; dynamics discrete {{ \
         x1 = x1 + TS * x2; x2 = x2 + TS * u; }} }} }}"
    )
}

#[test]
fn a_schedule_and_budgets_per_call_are_tables_in_a_model_file() {
    let toml = format!(
        "{SMALL}[generate.ekf]\nmax_cycles = {{ predict = 4000, update = 5000 }}\n\
         schedule = {{ predict = 100, update = 10 }}\nmhz = 168\nmax_load = 50\n"
    );
    let from_file = stateforge_cli::expand_model_file(&toml).expect("model file expands");
    let from_macro = stateforge_compiler::expand_macro_source(&small_macro(
        "ekf(max_cycles = [predict = 4000, update = 5000], \
         schedule = [predict = 100, update = 10], mhz = 168, max_load = 50)",
    ))
    .expect("macro expands");
    assert_eq!(code_without_docs(from_file), code_without_docs(from_macro));
    // A table of other than numbers, a table where none belongs, and the checks' hints in
    // TOML's form.
    let text = format!("{SMALL}[generate.ekf]\nschedule = {{ predict = \"fast\" }}\nmhz = 168\n");
    assert_error(
        &text,
        "21:12: generate.ekf.schedule: a table of numbers, one per call: `schedule` takes a \
         table of each call's rate in hertz, `schedule = { predict = 250, update_gnss = 5 }`",
    );
    let gate = format!("{SMALL}[generate.ekf]\ngate = {{ predict = 2 }}\n");
    assert_error(
        &gate,
        "21:8: generate.ekf.gate: a table is not a value of `gate`, which takes a positive \
         number (a chi-square quantile), `gate = 10.83`, or `gate = \"off\"`",
    );
    let load = format!("{SMALL}[generate.ekf]\nmax_load = 50\n");
    assert_error(
        &load,
        "21:12: `max_load` bounds a `schedule`'s load: give the schedule, `schedule = { \
         predict = 250, update_gnss = 5 }`, or drop it",
    );
}

#[test]
fn a_sensors_gate_is_a_key_of_its_table() {
    sensor_code_both_ways("gate = 10.83");
    assert_error(
        &sensor("gate = -1"),
        "18:8: a sensor's `gate` is a threshold on its normalised innovation squared, a \
         positive number: the chi-square quantile for as many degrees of freedom as it has \
         outputs (for this sensor's 1 output, 10.83 rejects one in a thousand consistent \
         measurements), or `\"off\"` to set it at run time",
    );
    assert_error(
        &sensor("gate = [1, 2]"),
        "18:8: sensor.gate: a list is not a gate, which is a positive number (a chi-square \
         quantile, `gate = 16.27`) or `\"off\"`",
    );
}

/// `SMALL` with its output `y` in a sensor `position` whose table adds `keys`, and an EKF.
fn sensor(keys: &str) -> String {
    SMALL.replace(
        "[dynamics]",
        &format!("[[sensor]]\nname = \"position\"\noutputs = [\"y\"]\n{keys}\n[dynamics]"),
    ) + "[generate]\nekf = true\n"
}

/// The code of [`sensor`]`(option)` (a `key = value` line), asserted equal to the macro's
/// with `sensor position(option) = [y];`, without its docs.
fn sensor_code_both_ways(option: &str) -> String {
    let from_file = stateforge_cli::expand_model_file(&sensor(option)).expect("model file expands");
    let from_macro = stateforge_compiler::expand_macro_source(&small_macro("ekf").replace(
        "output y = x1;",
        &format!("output y = x1; sensor position({option}) = [y];"),
    ))
    .expect("macro expands");
    let from_file = code_without_docs(from_file);
    assert_eq!(from_file, code_without_docs(from_macro));
    from_file
}

#[test]
fn a_sensors_delay_is_a_key_of_its_table() {
    let code = sensor_code_both_ways("delay = 4");
    assert!(code.contains("inputs_buffered"), "no buffer in {code}");
    assert_error(
        &sensor("delay = 0.15"),
        "18:9: a sensor's `delay` is how many samples (calls of `predict`) late its \
         measurements arrive, a whole number from 1 to 1000: a GNSS fix 150 ms late in a \
         filter sampled at 250 Hz is `delay = 38` (0.15 s times 250 Hz, rounded)",
    );
    assert_error(
        &sensor("delay = \"150 ms\""),
        "18:10: sensor.delay: `\"150 ms\"` is not a delay, which is how many samples late the \
         sensor's measurements arrive (`delay = 38`)",
    );
}

#[test]
fn a_sensors_max_delay_is_a_key_of_its_table() {
    let code = sensor_code_both_ways("max_delay = 4");
    assert!(code.contains("pending_position"), "no slots in {code}");
    assert_error(
        &sensor("max_delay = \"100 ms\""),
        "18:14: sensor.max_delay: `\"100 ms\"` is not a delay, which is the most samples late \
         the sensor's measurements may arrive, each one's delay given at run time \
         (`max_delay = 25`)",
    );
    assert_error(
        &sensor("delay = 2\nmax_delay = 4"),
        "19:13: a sensor's delay is fixed, `delay = 38` (every measurement that many samples \
         late), or given with each measurement up to a maximum, `max_delay = 25` \
         (`update_position(delay, y)`): keep one",
    );
}
