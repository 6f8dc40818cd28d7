//! Errors of a model file say what to write in the model file's own syntax.
//!
//! The checks after the front ends are shared with the `model!` macro, and their hints
//! are written in the macro's syntax (`dynamics continuous(rk4, dt = TS)`, `state x3;`,
//! `lqr(states = [x1, x2], input = u)`). A model file's errors pass through
//! [`in_toml_terms`], which rewrites those hints in TOML. Each rule is tested with the
//! model-file mistake that produces it (`tests/tests/model_file.rs`), so a reworded hint in
//! the checks shows up there as a failing test, not as macro syntax shown to a TOML user.

use stateforge_compiler::diagnostics::Warning;

/// Whole hints of the checks and their TOML form, applied before the general rules.
const HINTS: [(&str, &str); 13] = [
    (
        "continuous dynamics need a discretisation: write `dynamics continuous(euler, dt = TS)` \
         or `dynamics continuous(rk4, dt = TS, substeps = 2)`",
        "continuous dynamics need an integration method: add `method = \"euler\"` or \
         `method = \"rk4\"` to `[dynamics]`, with the step, `dt = \"TS\"` (a number or a \
         constant's name), and optionally `substeps = 2`",
    ),
    (
        "the discretisation needs a step `dt`: write `dynamics continuous(euler, dt = TS)` or \
         `dynamics continuous(rk4, dt = TS, substeps = 2)`",
        "the discretisation needs a step: add `dt = \"TS\"` (a constant's name) or \
         `dt = 0.01` to `[dynamics]`",
    ),
    (
        "add `dynamics discrete { x1 = ...; }` or `dynamics continuous(rk4, dt = TS) { der(x1) \
         = ...; }`",
        "add a `[dynamics]` table with `kind = \"discrete\"` (or `kind = \"continuous\"`, \
         `method = \"rk4\"` and `dt = \"TS\"`), and a `[dynamics.equations]` table with one \
         `x1 = \"...\"` per state",
    ),
    (
        "declare them as `dynamics continuous(euler, dt = TS) { der(x) = ..; }`",
        "declare them continuous: `kind = \"continuous\"`, `method = \"euler\"` and \
         `dt = \"TS\"` in `[dynamics]`",
    ),
    (
        "declare them with `output y = ...;`",
        "declare them: `[[output]]` with `name = \"y\"` and `value = \"x1\"`",
    ),
    (
        "add a line such as `state x1, x2;`",
        "add a `[[state]]` table with `name = \"x1\"` for each state",
    ),
    (
        "add `scalar f32;` (or `scalar f32, f64;` to",
        "add `scalar = \"f32\"` (or `scalar = [\"f32\", \"f64\"]` to",
    ),
    (
        "declare it with `state` if it evolves",
        "declare it as a `[[state]]` if it evolves",
    ),
    (
        "declare it with `const`",
        "declare it as a `[[const]]` with its `value`",
    ),
    (
        "or `off` to set it at run time",
        "or `\"off\"` to set it at run time",
    ),
    (
        "`process_noise` is the covariance's shape: `diagonal` (only the variances) or `full`",
        "`process_noise` is `\"diagonal\"` (only the variances) or `\"full\"`",
    ),
    (
        "the exponent of `powi` must be an integer literal between -64 and 64",
        "the exponent of `^` (or `powi`) must be a whole number between -64 and 64, such as \
         `x^2`",
    ),
    (
        ", powi, atan2, min, max, clamp",
        ", powi, atan2, min, max, clamp, if_gt, if_ge, if_lt, if_le (`if_gt(a, b, then, \
         else)`), or `^` for a whole power (`x^2`)",
    ),
];

/// Short pieces of macro syntax and their TOML form.
const PIECES: [(&str, &str); 9] = [
    ("(`state`)", "(`[[state]]`)"),
    (
        "with `let` inside `dynamics`",
        "in a `[[dynamics.let]]` table",
    ),
    (
        "declare each value, `const A = 1e-6;`,",
        "declare each value as a `[[const]]` (`name = \"A\"`, `value = 1e-6`),",
    ),
    ("(`input`)", "(`[[input]]`)"),
    ("`discretisation` is `zoh`", "`discretisation` is `\"zoh\"`"),
    (") or `sample_step` (", ") or `\"sample_step\"` ("),
    ("(`if q_mid > 0.0 { .. }`)", "(`if_gt(q_mid, 0, .., ..)`)"),
    (
        "a new name is declared with `state`, `param`, `input` or `const`",
        "a new name is declared as a `[[state]]`, `[[param]]`, `[[input]]` or `[[const]]`",
    ),
    (
        "declare it with `state`, `param`, `input` or `const`",
        "declare it as a `[[state]]`, `[[param]]`, `[[input]]` or `[[const]]` with `name = \
         \"{name}\"`",
    ),
];

/// `warnings` with the macro syntax of their hints written as TOML. A warning's only macro
/// syntax is the attribute that silences it; the rules for errors are not applied (they
/// would read `allow_unused = true` as an output's declaration).
pub(crate) fn warnings_in_toml_terms(warnings: Vec<Warning>) -> Vec<Warning> {
    warnings
        .into_iter()
        .map(|w| Warning {
            message: w.message.replace(
                "declare it `#[allow(unused)]`",
                "add `allow_unused = true` to its table",
            ),
            ..w
        })
        .collect()
}

/// Every message of `errors` with the macro syntax of its hint written as TOML.
pub(crate) fn in_toml_terms(errors: syn::Error) -> syn::Error {
    let mut rewritten = (&errors)
        .into_iter()
        .map(|e| syn::Error::new(e.span(), rewrite(&e.to_string())));
    match rewritten.next() {
        Some(mut all) => {
            all.extend(rewritten);
            all
        }
        None => errors,
    }
}

/// Options that take numbers by name, a table (`schedule = { predict = 250 }`), written
/// by the macro as a list (`schedule = [predict = 250]`).
pub(crate) const TABLE_OPTIONS: [&str; 3] = ["schedule", "max_cycles", "max_us"];

/// Options whose values the checks' hints write as bare names (`name = GatedEkf`).
const NAMED_OPTIONS: [&str; 11] = [
    "name",
    "gate",
    "process_noise",
    "process_noise_on",
    "measurement_noise",
    "k1",
    "discretisation",
    "states",
    "state",
    "inputs",
    "input",
];

/// `message` with its macro-syntax hints in TOML.
pub(crate) fn rewrite(message: &str) -> String {
    if let Some(unknown) = unknown_generator(message) {
        return unknown;
    }
    let mut text = message.to_owned();
    for (from, to) in HINTS {
        text = text.replace(from, to);
    }
    let first_name = first_quoted(message).unwrap_or("..").to_owned();
    for (from, to) in PIECES {
        text = text.replace(from, &to.replace("{name}", &first_name));
    }
    // `declare it with `state x3;``: one state's declaration.
    text = rewrite_quoted(&text, |code| {
        let name = code.strip_prefix("state ")?.strip_suffix(';')?;
        Some(format!("[[state]]` and `name = \"{name}\""))
    });
    // `move `let b = ..;` up`: an intermediate's table, among the `[[dynamics.let]]` ones.
    text = rewrite_quoted(&text, |code| {
        let name = code.strip_prefix("let ")?.strip_suffix(" = ..;")?;
        Some(format!("[[dynamics.let]]` table of `{name}"))
    });
    // `(q * vec3(1.0, 0.0, 0.0)).x`, `log(q).x`: a model file reads a component of a
    // name only, and projects a computed vector.
    text = rewrite_quoted(&text, component_as_projection);
    // `const k = ..;`: one constant's declaration.
    text = rewrite_quoted(&text, |code| {
        let name = code.strip_prefix("const ")?.strip_suffix(" = ..;")?;
        Some(format!(
            "[[const]]` with `name = \"{name}\"` and its `value"
        ))
    });
    // `add `x2 = ...;`` or `add `der(x2) = ...;``: a state's equation.
    text = rewrite_quoted(&text, |code| {
        let target = code.strip_suffix(" = ...;")?;
        let state = target
            .strip_prefix("der(")
            .and_then(|t| t.strip_suffix(')'))
            .unwrap_or(target);
        Some(format!("{state} = \"...\"` under `[dynamics.equations]"))
    });
    // `the model needs one output `y = z0``: an output's declaration.
    if message.contains("output") {
        text = rewrite_quoted(&text, |code| {
            let (output, value) = code.split_once(" = ")?;
            (is_identifier(output) && is_identifier(value))
                .then(|| format!("[[output]]` with `name = \"{output}\"` and `value = \"{value}\""))
        });
    }
    // `lqr(horizon = 50, states = [x1, x2], input = u)`: a generator with its options.
    text = rewrite_quoted(&text, |code| {
        let (generator, options) = code.strip_suffix(')')?.split_once('(')?;
        // A generator's call, not other text: its name is in the compiler's registry.
        let registered = stateforge_compiler::generators::REGISTRY
            .iter()
            .any(|k| k.name() == generator);
        registered.then_some(())?;
        Some(format!("{generator} = {{ {} }}", toml_options(options)?))
    });
    // `schedule = [predict = 250, update_gnss = 5]`: numbers by call, an inline table.
    text = rewrite_quoted(&text, |code| {
        let (option, value) = code.split_once(" = ")?;
        TABLE_OPTIONS.contains(&option).then_some(())?;
        let inside = value.strip_prefix('[')?.strip_suffix(']')?;
        inside
            .contains('=')
            .then(|| format!("{option} = {{ {inside} }}"))
    });
    // `name = GatedEkf`, `discretisation = zoh`, `k1 = [A, B]`: one option.
    text = rewrite_quoted(&text, |code| {
        let (option, value) = code.split_once(" = ")?;
        NAMED_OPTIONS.contains(&option).then_some(())?;
        Some(format!("{option} = {}", toml_value(value)?))
    });
    text
}

/// `(a).x` or `f(a).x` as `dot(a, vec3(1.0, 0.0, 0.0))` (and `.y`, `.z`).
fn component_as_projection(code: &str) -> Option<String> {
    let (value, component) = code.rsplit_once(").")?;
    let unit = match component {
        "x" => "1.0, 0.0, 0.0",
        "y" => "0.0, 1.0, 0.0",
        "z" => "0.0, 0.0, 1.0",
        _ => return None,
    };
    // `(a)` is the vector `a`; `f(a)`, a call, is the vector itself.
    let vector = match value.strip_prefix('(') {
        Some(inside) if balanced(inside) => inside.to_owned(),
        _ => format!("{value})"),
    };
    Some(format!("dot({vector}, vec3({unit}))"))
}

/// Whether `text` closes every parenthesis it opens, and none before.
fn balanced(text: &str) -> bool {
    let mut depth = 0usize;
    for c in text.chars() {
        match c {
            '(' => depth += 1,
            ')' => match depth.checked_sub(1) {
                Some(d) => depth = d,
                None => return false,
            },
            _ => {}
        }
    }
    depth == 0
}

/// The first name between backquotes in `message`.
fn first_quoted(message: &str) -> Option<&str> {
    let (_, rest) = message.split_once('`')?;
    let (name, _) = rest.split_once('`')?;
    is_identifier(name).then_some(name)
}

/// `unknown generator `x`: use ..`, with the registry's generators as TOML keys.
fn unknown_generator(message: &str) -> Option<String> {
    let rest = message.strip_prefix("unknown generator `")?;
    let (name, _) = rest.split_once("`: use ")?;
    let names: Vec<String> = stateforge_compiler::generators::REGISTRY
        .iter()
        .map(|kind| format!("`{}`", kind.name()))
        .collect();
    let (last, others) = names.split_last()?;
    Some(format!(
        "unknown generator `{name}`: use {} or {last} (`ekf = true`, or a table of its options)",
        others.join(", ")
    ))
}

/// `text` with each backquoted piece of code that `rule` rewrites replaced by its
/// rewriting (which may close and reopen backquotes).
fn rewrite_quoted(text: &str, rule: impl Fn(&str) -> Option<String>) -> String {
    let mut out = String::with_capacity(text.len());
    let mut pieces = text.split('`');
    // Pieces alternate: prose, code, prose, code, ..
    let mut code = false;
    let mut first = true;
    for piece in pieces.by_ref() {
        if !first {
            out.push('`');
        }
        first = false;
        match rule(piece).filter(|_| code) {
            Some(rewritten) => out.push_str(&rewritten),
            None => out.push_str(piece),
        }
        code = !code;
    }
    out
}

/// `horizon = 50, states = [x1, x2], input = u` as TOML options.
fn toml_options(options: &str) -> Option<String> {
    let mut written = Vec::new();
    for option in split_top_level(options) {
        let option = option.trim();
        if option == ".." {
            written.push("..".to_owned());
            continue;
        }
        let (name, value) = option.split_once(" = ")?;
        is_identifier(name).then_some(())?;
        written.push(format!("{name} = {}", toml_value(value)?));
    }
    Some(written.join(", "))
}

/// An option's value in the macro's syntax as TOML: numbers stay, names become strings,
/// lists of names lists of strings; `..` (an elision in a hint) stays.
fn toml_value(value: &str) -> Option<String> {
    let value = value.trim();
    if matches!(value, ".." | "true" | "false") || value.parse::<f64>().is_ok() {
        return Some(value.to_owned());
    }
    if is_identifier(value) {
        return Some(format!("\"{value}\""));
    }
    let list = value.strip_prefix('[')?.strip_suffix(']')?;
    let items: Option<Vec<String>> = list
        .split(',')
        .map(|item| {
            let item = item.trim();
            if item == ".." {
                Some(item.to_owned())
            } else {
                is_identifier(item).then(|| format!("\"{item}\""))
            }
        })
        .collect();
    Some(format!("[{}]", items?.join(", ")))
}

/// `text` split at the commas outside brackets.
fn split_top_level(text: &str) -> Vec<&str> {
    let mut parts = Vec::new();
    let (mut depth, mut start) = (0usize, 0);
    for (i, c) in text.char_indices() {
        match c {
            '[' | '(' => depth += 1,
            ']' | ')' => depth = depth.saturating_sub(1),
            ',' if depth == 0 => {
                parts.push(&text[start..i]);
                start = i + 1;
            }
            _ => {}
        }
    }
    parts.push(&text[start..]);
    parts
}

fn is_identifier(text: &str) -> bool {
    let mut chars = text.chars();
    chars
        .next()
        .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// What a generator's option takes, in TOML, for a value the model language has no reading
/// of (`true`, a table, a list holding numbers). Numbers, names and lists of names out of
/// place are explained by the checks, per option.
pub(crate) fn option_takes(generator: &str, option: &str) -> &'static str {
    match (generator, option) {
        ("ekf", "gate") => {
            "a positive number (a chi-square quantile), `gate = 10.83`, or `gate = \"off\"`"
        }
        ("ekf", "name") => "a type name in UpperCamelCase as a string, `name = \"GatedEkf\"`",
        (_, "schedule") => {
            "a table of each call's rate in hertz, `schedule = { predict = 250, update_gnss = 5 }`"
        }
        (_, "max_cycles" | "max_us") => {
            "a positive number, or a table of one per call, `max_cycles = { predict = 2000 }`"
        }
        ("switched_observer", _) => {
            "a list of the model's constants' names, `process_noise = [\"Q1\", \"Q2\"]`"
        }
        (_, "process_noise") => "`process_noise = \"diagonal\"` or `process_noise = \"full\"`",
        (_, "process_noise_on") => {
            "a list of the states and parameters the process noise enters, as strings: \
             `process_noise_on = [\"x2\", \"k\"]`"
        }
        ("dkf", "eta") => "a number from 0 to 1, `eta = 0.5`",
        ("continuous_ekf", "alpha") => "a number of at least 0, `alpha = 0.5`",
        ("lqr" | "mpc", "states" | "state") => {
            "a state's name as a string or a list of them, `states = [\"x1\", \"x2\"]`"
        }
        ("lqr" | "mpc", "inputs" | "input") => {
            "an input's name as a string or a list of them, `input = \"u\"`"
        }
        ("mpc", "discretisation") => {
            "`discretisation = \"zoh\"` or `discretisation = \"sample_step\"`"
        }
        ("lqr" | "mpc", _) => "a whole number, `horizon = 50`",
        ("polynomial_kf", _) => "a number, or a constant's name as a string: `dt = \"TS\"`",
        _ => {
            "a number (`horizon = 50`), a name as a string (`input = \"u\"`) or a list of \
             names (`states = [\"x1\", \"x2\"]`)"
        }
    }
}

#[cfg(test)]
mod tests {
    use super::rewrite;

    #[test]
    fn generator_calls_and_options_become_toml() {
        assert_eq!(
            rewrite(
                "`lqr` needs the states it regulates and the inputs it computes: \
                 `lqr(horizon = 50, states = [x1, x2], input = u)`"
            ),
            "`lqr` needs the states it regulates and the inputs it computes: \
             `lqr = { horizon = 50, states = [\"x1\", \"x2\"], input = \"u\" }`"
        );
        assert_eq!(
            rewrite("`process_noise` takes a list of model constants: `process_noise = [A, B]`"),
            "`process_noise` takes a list of model constants: `process_noise = [\"A\", \"B\"]`"
        );
        assert_eq!(
            rewrite("use `discretisation = sample_step`, or leave it out"),
            "use `discretisation = \"sample_step\"`, or leave it out"
        );
    }

    #[test]
    fn declarations_and_equations_become_toml() {
        assert_eq!(
            rewrite("unknown state `x3`: declare it with `state x3;`"),
            "unknown state `x3`: declare it with `[[state]]` and `name = \"x3\"`"
        );
        assert_eq!(
            rewrite("state `x2` has no dynamics: add `der(x2) = ...;`"),
            "state `x2` has no dynamics: add `x2 = \"...\"` under `[dynamics.equations]`"
        );
        // Numbers and prose are left alone.
        let plain = "`window = 20` is too short; `horizon` is a whole number of steps";
        assert_eq!(rewrite(plain), plain);
    }
}
