//! Both front ends against mutated models: no input may panic the compiler or overflow its
//! stack, and an input it accepts must give code that parses as Rust.
//!
//! Each case takes a demo model (as a `model!` file or the TOML cantilever) and applies a
//! few random edits: deleting, duplicating or moving a span of text, or inserting a
//! fragment known to have troubled compilers (deep nesting, huge or non-finite numbers,
//! raw identifiers, stray keywords). The test command runs a modest number of cases;
//! `PROPTEST_CASES=20000 cargo test --release -p tests --test fuzz_front_ends` runs long.

use proc_macro2::TokenStream;
use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};
use std::panic::{catch_unwind, AssertUnwindSafe};
use tests::{demo_model_source, workspace_path, DEMO_MODELS};

/// Fragments inserted by the mutator.
const FRAGMENTS: &[&str] = &[
    "(",
    ")",
    "{",
    "}",
    "[",
    "]",
    ";",
    ",",
    "=",
    "-",
    "+",
    "*",
    "/",
    "^",
    ".",
    "::",
    "///",
    "//",
    "#",
    "!",
    "0.0",
    "1e300",
    "1e-300",
    "-1e39",
    "nan",
    "inf",
    "1.5",
    "0",
    "18446744073709551616",
    "r#type",
    "type",
    "fn",
    "mod",
    "pub",
    "let",
    "if",
    "else",
    "der(",
    "x1",
    "u",
    "t",
    "TS",
    "sin(",
    "powi(",
    "ln(0.0)",
    "\"",
    "'",
    "\\",
    "é",
    " ",
    "\n",
    "\t",
    "state",
    "param",
    "input",
    "output",
    "const",
    "generate ekf;",
    "generate dkf(eta = 2);",
    "generate lqr(horizon = 0);",
    "dynamics continuous(rk4, dt = 0.0, substeps = 1000)",
    "if_gt(",
    "x = \" \"",
    "name = \"\"",
    "visibility = \"fn f() {}\"",
    "[[state]]\nname = \"x1\"",
    "[generate]\nekf = true",
    "((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((",
];

#[derive(Clone, Debug)]
enum Edit {
    Delete {
        at: usize,
        len: usize,
    },
    Duplicate {
        at: usize,
        len: usize,
    },
    Move {
        from: usize,
        len: usize,
        to: usize,
    },
    Insert {
        at: usize,
        fragment: usize,
        times: usize,
    },
}

fn edit() -> impl Strategy<Value = Edit> {
    prop_oneof![
        (any::<usize>(), 1usize..40).prop_map(|(at, len)| Edit::Delete { at, len }),
        (any::<usize>(), 1usize..80).prop_map(|(at, len)| Edit::Duplicate { at, len }),
        (any::<usize>(), 1usize..40, any::<usize>()).prop_map(|(from, len, to)| Edit::Move {
            from,
            len,
            to
        }),
        (any::<usize>(), 0..FRAGMENTS.len(), 1usize..4).prop_map(|(at, fragment, times)| {
            Edit::Insert {
                at,
                fragment,
                times,
            }
        }),
        (any::<usize>(), 0..FRAGMENTS.len()).prop_map(|(at, fragment)| Edit::Insert {
            at,
            fragment,
            times: 300
        }),
    ]
}

/// The byte offset of `at` (reduced into the text) moved back to a character boundary.
fn boundary(text: &str, at: usize) -> usize {
    let mut i = at % (text.len() + 1);
    while !text.is_char_boundary(i) {
        i -= 1;
    }
    i
}

fn apply(text: &str, edit: &Edit) -> String {
    let span = |at: usize, len: usize| {
        let start = boundary(text, at);
        (start, boundary(text, start + len.min(text.len() - start)))
    };
    match *edit {
        Edit::Delete { at, len } => {
            let (a, b) = span(at, len);
            format!("{}{}", &text[..a], &text[b..])
        }
        Edit::Duplicate { at, len } => {
            let (a, b) = span(at, len);
            format!("{}{}", &text[..b], &text[a..])
        }
        Edit::Move { from, len, to } => {
            let (a, b) = span(from, len);
            let rest = format!("{}{}", &text[..a], &text[b..]);
            let to = boundary(&rest, to);
            format!("{}{}{}", &rest[..to], &text[a..b], &rest[to..])
        }
        Edit::Insert {
            at,
            fragment,
            times,
        } => {
            let at = boundary(text, at);
            let inserted = FRAGMENTS[fragment].repeat(times);
            format!("{}{inserted}{}", &text[..at], &text[at..])
        }
    }
}

fn runner(default_cases: u32) -> TestRunner {
    let cases = std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|c| c.parse().ok())
        .unwrap_or(default_cases);
    TestRunner::new(Config {
        cases,
        failure_persistence: None,
        ..Config::default()
    })
}

/// Expands `text` with `expand`: a panic fails the case, and so does accepted input whose
/// code does not parse as a Rust file; rejected input just returns its errors. A failure
/// shows the input, so proptest's minimal case reads as a model.
fn check(text: &str, expand: fn(&str) -> syn::Result<TokenStream>) -> Result<(), TestCaseError> {
    let fail = |what: String| TestCaseError::fail(format!("{what}\n--- input ---\n{text}\n---"));
    let generated = catch_unwind(AssertUnwindSafe(|| expand(text))).map_err(|payload| {
        let message = payload
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| payload.downcast_ref::<&str>().copied())
            .unwrap_or("(a panic without a message)");
        fail(format!("panicked: {message}"))
    })?;
    if let Ok(tokens) = generated {
        if let Err(e) = model_codegen::format(tokens) {
            return Err(fail(format!("accepted, but the code does not parse: {e}")));
        }
    }
    Ok(())
}

/// Whether the run is a long one (`PROPTEST_CASES` set), which also takes the models that
/// expand slowly in a debug build.
fn long_run() -> bool {
    std::env::var_os("PROPTEST_CASES").is_some()
}

#[test]
fn mutated_macro_models_never_panic_and_accepted_ones_parse() {
    // The demo models that expand quickly in a debug build; the piecewise beam is covered
    // by the long run.
    let sources: Vec<String> = DEMO_MODELS
        .iter()
        .filter(|m| **m != "piecewise_beam" || long_run())
        .map(|m| demo_model_source(m))
        .collect();
    let case = (0..sources.len(), prop::collection::vec(edit(), 1..4));
    runner(96)
        .run(&case, |(model, edits)| {
            let text = edits
                .iter()
                .fold(sources[model].clone(), |t, e| apply(&t, e));
            check(&text, model_dsl::expand_macro_source)
        })
        .unwrap();
}

#[test]
fn mutated_model_files_never_panic_and_accepted_ones_parse() {
    let toml = std::fs::read_to_string(workspace_path("model-codegen/models/cantilever.toml"))
        .expect("the cantilever model file");
    let case = prop::collection::vec(edit(), 1..4);
    runner(160)
        .run(&case, |edits| {
            let text = edits.iter().fold(toml.clone(), |t, e| apply(&t, e));
            check(&text, model_codegen::expand_model_file)
        })
        .unwrap();
}
