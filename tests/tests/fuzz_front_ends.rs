//! Both front ends against mutated models: no input may panic the compiler or overflow its
//! stack, and an input it accepts must give code that parses as Rust.
//!
//! Each case takes a demo model (as a `model!` file or the TOML cantilever) and applies a
//! few random edits: deleting, duplicating or moving a span of text, or inserting a
//! fragment known to have troubled compilers (deep nesting, huge or non-finite numbers,
//! raw identifiers, stray keywords). The generator cases take a small model valid for one
//! generator (or a demo model), in either front end, and change what the generators
//! require of it (no outputs, no inputs, the other kind of dynamics, a `known` or a
//! `param`, sub-steps past the unrolled limit) and their options (dropped, given twice,
//! out of range, of the wrong kind, naming what is not declared, another generator's),
//! then maybe a random edit. The test command runs a modest number of cases;
//! `PROPTEST_CASES=20000 cargo test --release -p tests --test fuzz_front_ends` runs long.

use proc_macro2::TokenStream;
use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};
use std::panic::{catch_unwind, AssertUnwindSafe};
use tests::{demo_model_source, workspace_path, DEMO_MODELS, TEST_MODELS};

#[path = "fuzz_front_ends/generators.rs"]
mod generators;
use generators::{changed_macro_model, changed_model_file, changes, Changes};

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
    ".x",
    ".w",
    ").x",
    ".norm()",
    ".dot(",
    ".inverse()",
    "vec3(",
    "exp(",
    "log(",
    "type = \"Vec3\"",
    "type = \"Rot3\"",
    ": Vec3",
    ": Rot3",
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

/// Mostly no edit, else one: after a generator case's changes an edit mostly breaks the
/// syntax, which the other tests try.
fn rare_edits() -> impl Strategy<Value = Vec<Edit>> {
    prop_oneof![3 => Just(Vec::new()), 1 => prop::collection::vec(edit(), 1..2)]
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

/// Where each test writes the case it is about to expand ([`LAST_INPUTS`], one file per
/// test): a run that a memory limit or a signal ends leaves no failure for proptest to
/// shrink and show, only these, which `cargo xtask test` prints when the tests fail.
const LAST_INPUTS: &str = "fuzz-last-input";

/// Writes `text` as the running test's last input; best effort (a case that cannot be
/// written is still expanded).
fn record(text: &str) {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join(LAST_INPUTS);
    let test = std::thread::current()
        .name()
        .unwrap_or("main")
        .replace("::", "-");
    let _ = std::fs::create_dir_all(&dir)
        .and_then(|()| std::fs::write(dir.join(format!("{test}.txt")), text));
}

/// Expands `text` with `expand`: a panic fails the case, and so does accepted input whose
/// code does not parse as a Rust file; rejected input just returns its errors. A failure
/// shows the input, so proptest's minimal case reads as a model.
fn check(text: &str, expand: fn(&str) -> syn::Result<TokenStream>) -> Result<(), TestCaseError> {
    record(text);
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
        if let Err(e) = stateforge_cli::format(tokens) {
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
            check(&text, stateforge_compiler::expand_macro_source)
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
            check(&text, stateforge_cli::expand_model_file)
        })
        .unwrap();
}

/// A small model with vectors and a rotation, as a model file: components, methods (also
/// after a component), functions, a typed intermediate an output reads.
const TYPED_FILE: &str = r#"name = "typed"
scalar = ["f32"]

[[const]]
name = "DT"
value = 0.01

[[state]]
name = "v"
type = "Vec3"

[[input]]
name = "q"
type = "Rot3"

[[input]]
name = "w"
type = "Vec3"

[[output]]
name = "y"
value = "v.x + v.norm() * 1.5"

[[output]]
name = "b"
value = "q.inverse() * v"

[[output]]
name = "heading"
value = "turn.z + dot(turn, v.cross(w))"

[dynamics]
kind = "discrete"

[[dynamics.let]]
name = "turn"
value = "log(q * exp(w * DT))"

[dynamics.equations]
v = "v + (q * w - v.normalize() * v.y.abs()) * DT"

[generate]
ekf = true
"#;

/// `TYPED_FILE` as the macro writes it.
const TYPED_MACRO: &str = "stateforge::model! {
    pub mod typed {
        scalar f32;
        const DT = 0.01;
        state v: Vec3;
        input q: Rot3, w: Vec3;
        output y = v.x + v.norm() * 1.5, b = q.inverse() * v,
            heading = turn.z + dot(turn, v.cross(w)), r = (q * v).y + log(q).norm();
        dynamics discrete {
            let turn = log(q * exp(w * DT));
            v = v + (q * w - v.normalize() * v.y.abs()) * DT;
        }
        generate ekf;
    }
}";

#[test]
fn mutated_typed_models_never_panic_and_accepted_ones_parse() {
    stateforge_cli::expand_model_file(TYPED_FILE).expect("the typed model file expands");
    stateforge_compiler::expand_macro_source(TYPED_MACRO).expect("the typed model expands");
    let case = (any::<bool>(), prop::collection::vec(edit(), 1..4));
    runner(128)
        .run(&case, |(file, edits)| {
            let base = if file { TYPED_FILE } else { TYPED_MACRO };
            let text = edits.iter().fold(base.to_owned(), |t, e| apply(&t, e));
            if file {
                check(&text, stateforge_cli::expand_model_file)
            } else {
                check(&text, stateforge_compiler::expand_macro_source)
            }
        })
        .unwrap();
}

/// Pieces of model-file expressions around `.`: names, components, methods, numbers.
const DOT_PIECES: &[&str] = &[
    "v", "q", "w", ".", "x", "z", "(", ")", ",", " ", "*", "+", "-", "1", "2.", "5e-3", "e", "_",
    "norm", "dot", "inverse", "abs", "vec3", "log", "pi",
];

#[test]
fn model_file_expressions_of_dots_never_panic() {
    let expression = prop::collection::vec(0..DOT_PIECES.len(), 0..24)
        .prop_map(|pieces| pieces.iter().map(|&i| DOT_PIECES[i]).collect::<String>());
    runner(512)
        .run(&expression, |expression| {
            let text = TYPED_FILE.replace("v.x + v.norm() * 1.5", &expression);
            check(&text, stateforge_cli::expand_model_file)
        })
        .unwrap();
}

// ---------------------------------------------------------------------------------------
// Generators: their requirements and their options.

/// Small `model!` models, each valid for the generators it asks for; together they ask for
/// every generator, with names (`x1`, `x2`, `u`, `y`, `TS`) that the option edits reuse.
const MACRO_MODELS: &[&str] = &[
    // ekf, twice
    "stateforge::model! {
    pub mod m {
        scalar f32;
        const TS = 0.01;
        state x1, x2;
        param k;
        input u;
        output y = x1;
        generate ekf(process_noise = diagonal), ekf(gate = 10.83, name = GatedEkf);
        dynamics discrete {
            x1 = x1 + TS * x2;
            x2 = x2 - TS * k * x1 + TS * u;
        }
    }
}",
    // dkf
    "stateforge::model! {
    pub mod m {
        scalar f32;
        const TS = 0.015;
        state x1, x2;
        param x3, x4, x5;
        input u;
        output y = x1;
        generate dkf(eta = 0.5, process_noise = diagonal);
        dynamics discrete {
            x1 = x1 + TS * x2;
            x2 = TS * x1 * x3 + (1.0 + TS * x4) * x2 + TS * x5 * u;
        }
    }
}",
    // polynomial_kf
    "stateforge::model! {
    pub mod m {
        scalar f64;
        const TS = 0.01;
        state x1, x2;
        output y = x1;
        generate polynomial_kf(order = 1, dt = TS, fading = 1e-6, noise_variance = 1e-4,
            reinit_every = 50, window = 10);
        dynamics discrete {
            x1 = x1 + x2;
            x2 = x2;
        }
    }
}",
    // switched_observer
    "stateforge::model! {
    pub mod m {
        scalar f64;
        const TS = 0.001;
        const Q_POS = 1e-8;
        const Q_VEL = 1e-4;
        const R_POS = 1e-6;
        state x1, x2;
        input u;
        output y = x1;
        generate switched_observer(process_noise = [Q_POS, Q_VEL], measurement_noise = [R_POS]);
        dynamics discrete {
            let spring = if x1 > 0.0 { 400.0 * x1 } else { 100.0 * x1 };
            x2 = x2 + TS * (u - spring - 0.5 * x2);
            x1 = x1 + TS * x2;
        }
    }
}",
    // lqr
    "stateforge::model! {
    pub mod m {
        scalar f32;
        const TS = 0.01;
        state x1, x2;
        input u;
        output y = x1;
        generate lqr(horizon = 50, states = [x1, x2], input = u);
        dynamics discrete {
            x1 = x1 + TS * x2;
            x2 = x2 + TS * (sin(x1) + u);
        }
    }
}",
    // mpc
    "stateforge::model! {
    pub mod m {
        scalar f64;
        const TS = 0.1;
        state x1, x2;
        input u;
        output y = x1;
        generate mpc(horizon = 8, states = [x1, x2], input = u);
        dynamics discrete {
            x1 = x1 + TS * x2 + 0.5 * TS * TS * u;
            x2 = x2 + TS * u;
        }
    }
}",
    // hybrid_ekf
    "stateforge::model! {
    pub mod m {
        scalar f64;
        const TS = 0.01;
        state x1, x2;
        param k;
        input u;
        output y = x1;
        generate hybrid_ekf(process_noise = diagonal);
        dynamics continuous(euler, dt = TS, substeps = 100) {
            der(x1) = x2;
            der(x2) = k * (u - 500.0 * x1 - 0.1 * x2);
        }
    }
}",
    // continuous_ekf
    "stateforge::model! {
    pub mod m {
        scalar f32;
        const TS = 0.001;
        state x1, x2;
        input u;
        output y = x1;
        generate continuous_ekf(alpha = 0.5, process_noise = diagonal);
        dynamics continuous(rk4, dt = TS) {
            der(x1) = x2;
            der(x2) = -4.0 * x1.sin() - 0.5 * x2 + u;
        }
    }
}",
];

/// Small model files (without their `[generate]` table) and the generators each is valid
/// for, written as in a `model!`; together they ask for every generator.
const FILE_MODELS: &[(&str, &str)] = &[
    (
        r#"name = "oscillator"
scalar = ["f64"]

[[const]]
name = "TS"
value = 0.01

[[state]]
name = "x1"

[[state]]
name = "x2"

[[param]]
name = "k"

[[input]]
name = "u"

[[output]]
name = "y"
value = "x1"

[dynamics]
kind = "continuous"
method = "euler"
dt = "TS"
substeps = 10

[dynamics.equations]
x1 = "x2"
x2 = "-k * x1 - 0.5 * x2 + u"
"#,
        "hybrid_ekf(process_noise = diagonal), continuous_ekf(alpha = 0.5), \
         mpc(horizon = 8, states = [x1, x2], input = u)",
    ),
    (
        r#"name = "stop"
scalar = ["f64"]

[[const]]
name = "TS"
value = 0.001

[[const]]
name = "Q_POS"
value = 1e-8

[[const]]
name = "Q_VEL"
value = 1e-4

[[const]]
name = "R_POS"
value = 1e-6

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
x2 = "x2 + TS * (u - if_gt(x1, 0, 400 * x1, 100 * x1) - 0.5 * x2)"
"#,
        "switched_observer(process_noise = [Q_POS, Q_VEL], measurement_noise = [R_POS])",
    ),
    (
        r#"name = "track"
scalar = ["f64"]

[[const]]
name = "TS"
value = 0.01

[[state]]
name = "x1"

[[state]]
name = "x2"

[[output]]
name = "y"
value = "x1"

[dynamics]
kind = "discrete"

[dynamics.equations]
x1 = "x1 + x2"
x2 = "x2"
"#,
        "polynomial_kf(order = 1, dt = TS, fading = 1e-6, noise_variance = 1e-4, \
         reinit_every = 50, window = 10)",
    ),
];

/// The cantilever's model file's generators, as in a `model!`.
const CANTILEVER_FILE_GENERATORS: &str = "ekf(process_noise = diagonal), \
    ekf(process_noise = diagonal, gate = 10.83, name = GatedEkf), \
    dkf(eta = 0.5, process_noise = diagonal), lqr(horizon = 50, states = [x1, x2], input = u)";

/// The cantilever's model file without its `[generate]` table.
fn cantilever_file_without_generators() -> String {
    let toml = std::fs::read_to_string(workspace_path("model-codegen/models/cantilever.toml"))
        .expect("the cantilever model file");
    let at = toml
        .find("[generate]")
        .expect("the cantilever file generates");
    toml[..at].to_owned()
}

#[test]
fn generator_base_models_are_valid() {
    // A requirement removed from a valid model leaves the requirement's error alone; a
    // base model that is already wrong would test less than it seems to.
    let unchanged = Changes::none();
    for base in MACRO_MODELS {
        let text = changed_macro_model(base, &unchanged);
        if let Err(e) = stateforge_compiler::expand_macro_source(&text) {
            panic!("{e}\n{text}");
        }
    }
    let cantilever = cantilever_file_without_generators();
    let files = FILE_MODELS
        .iter()
        .copied()
        .chain([(cantilever.as_str(), CANTILEVER_FILE_GENERATORS)]);
    for base in files {
        let text = changed_model_file(base, &unchanged);
        if let Err(e) = stateforge_cli::expand_model_file(&text) {
            panic!("{e}\n{text}");
        }
    }
}

#[test]
fn macro_models_with_changed_generators_never_panic_and_accepted_ones_parse() {
    let mut sources: Vec<String> = MACRO_MODELS.iter().map(|m| m.to_string()).collect();
    sources.extend(
        DEMO_MODELS
            .iter()
            .filter(|m| **m != "piecewise_beam" || long_run())
            .map(|m| demo_model_source(m)),
    );
    sources.extend(TEST_MODELS.iter().map(|m| {
        std::fs::read_to_string(workspace_path(&format!("tests/models/{m}.rs")))
            .expect("the test model")
    }));
    let case = (0..sources.len(), changes(), rare_edits());
    runner(256)
        .run(&case, |(model, changes, edits)| {
            let text = changed_macro_model(&sources[model], &changes);
            let text = edits.iter().fold(text, |t, e| apply(&t, e));
            check(&text, stateforge_compiler::expand_macro_source)
        })
        .unwrap();
}

#[test]
fn model_files_with_changed_generators_never_panic_and_accepted_ones_parse() {
    let cantilever = cantilever_file_without_generators();
    let mut files: Vec<(&str, &str)> = FILE_MODELS.to_vec();
    files.push((&cantilever, CANTILEVER_FILE_GENERATORS));
    let case = (0..files.len(), changes(), rare_edits());
    runner(256)
        .run(&case, |(model, changes, edits)| {
            let text = changed_model_file(files[model], &changes);
            let text = edits.iter().fold(text, |t, e| apply(&t, e));
            check(&text, stateforge_cli::expand_model_file)
        })
        .unwrap();
}
