//! The generator cases' changes: of what the generators require of the model (its outputs,
//! inputs, kind of dynamics, sub-steps, `known` and `param` declarations) and of the
//! `generate` items (options dropped, given twice, set to values out of range or of the
//! wrong kind, another generator's name, generators added and removed), applied to a
//! `model!` model or a model file as text.

use proptest::prelude::*;
use std::ops::Range;

/// Every generator, with options typical of a model of states `x1, x2`, input `u` and
/// constant `TS`.
const GENERATORS: &[&str] = &[
    "ekf(process_noise = diagonal, gate = 10.83, name = GatedEkf)",
    "dkf(eta = 0.5, process_noise = diagonal)",
    "polynomial_kf(order = 1, dt = TS, fading = 1e-6, noise_variance = 1e-4, reinit_every = 50, window = 10)",
    "switched_observer(process_noise = [TS, TS], measurement_noise = [TS])",
    "lqr(horizon = 50, states = [x1, x2], input = u)",
    "mpc(horizon = 8, states = [x1, x2], input = u, discretisation = zoh)",
    "hybrid_ekf(process_noise = diagonal)",
    "continuous_ekf(alpha = 0.5, process_noise = diagonal)",
];

/// Option names of every generator, and one of none.
const OPTION_NAMES: &[&str] = &[
    "eta",
    "process_noise",
    "measurement_noise",
    "gate",
    "name",
    "horizon",
    "states",
    "state",
    "inputs",
    "input",
    "discretisation",
    "max_iterations",
    "riccati_iterations",
    "alpha",
    "order",
    "dt",
    "fading",
    "noise_variance",
    "reinit_every",
    "window",
    "k1",
    "bogus",
];

/// Option values: in and out of every option's range, of every kind, and names that are
/// not declared or name the wrong kind of thing.
const OPTION_VALUES: &[&str] = &[
    "0",
    "1",
    "2",
    "-1",
    "0.5",
    "-0.0",
    "1e-6",
    "1e-320",
    "1e300",
    "-1e39",
    "8",
    "9",
    "32",
    "33",
    "64",
    "65",
    "1000",
    "10000",
    "1000001",
    "4294967296",
    "18446744073709551616",
    "x1",
    "x2",
    "u",
    "y",
    "k",
    "TS",
    "undeclared",
    "nan",
    "inf",
    "diagonal",
    "full",
    "off",
    "zoh",
    "sample_step",
    "GatedEkf",
    "Ekf",
    "Lqr",
    "Self",
    "ekf",
    "[]",
    "[x1]",
    "[x2, x1]",
    "[x1, x1]",
    "[u]",
    "[u, u]",
    "[y]",
    "[k]",
    "[TS]",
    "[TS, TS]",
    "[TS, TS, TS]",
    "[TS, TS, TS, TS]",
    "[undeclared]",
    "[1e-6, 1e-4]",
    "[x1, [x2]]",
];

/// Sub-step counts around the unrolled limit and the loop's.
const SUBSTEPS: &[&str] = &[
    "0",
    "1",
    "2",
    "64",
    "65",
    "500",
    "100000",
    "100001",
    "18446744073709551616",
];

/// Names a `known` or `param` declaration may take: new ones, and ones already declared.
const DECLARED_NAMES: &[&str] = &["k", "gain", "x1", "u", "TS", "y"];

/// A change of what the generators require of the model.
#[derive(Clone, Debug)]
pub enum ModelChange {
    /// Delete every output declaration.
    DeleteOutputs,
    /// Delete every input declaration, the dynamics reading 0 for the inputs.
    DeleteInputs,
    /// Continuous dynamics become discrete, `der(x) = e` becoming `x = e`.
    ToDiscrete,
    /// Discrete dynamics become continuous, `x = e` becoming `der(x) = e`.
    ToContinuous { rk4: bool },
    /// The dynamics (made continuous) take `substeps`.
    Substeps(&'static str),
    /// Declare `kind name` (`known` or `param`), maybe multiplying the first equation's
    /// right-hand side by it.
    Declare {
        kind: &'static str,
        name: &'static str,
        used: bool,
    },
}

/// A change of the `generate` items (indices are reduced into what is there).
#[derive(Clone, Debug)]
pub enum ItemChange {
    DropOption {
        item: usize,
        option: usize,
    },
    DuplicateOption {
        item: usize,
        option: usize,
    },
    SetOption {
        item: usize,
        option: usize,
        value: &'static str,
    },
    AddOption {
        item: usize,
        name: &'static str,
        value: &'static str,
    },
    /// Another generator's name, keeping the options.
    Rename {
        item: usize,
        to: usize,
    },
    /// Another generator, bare or with typical options.
    AddGenerator {
        generator: usize,
        options: bool,
    },
    DeleteGenerator {
        item: usize,
    },
}

fn model_change() -> impl Strategy<Value = ModelChange> {
    prop_oneof![
        Just(ModelChange::DeleteOutputs),
        Just(ModelChange::DeleteInputs),
        Just(ModelChange::ToDiscrete),
        any::<bool>().prop_map(|rk4| ModelChange::ToContinuous { rk4 }),
        prop::sample::select(SUBSTEPS).prop_map(ModelChange::Substeps),
        (
            prop::sample::select(&["known", "param"][..]),
            prop::sample::select(DECLARED_NAMES),
            any::<bool>()
        )
            .prop_map(|(kind, name, used)| ModelChange::Declare { kind, name, used }),
    ]
}

fn item_change() -> impl Strategy<Value = ItemChange> {
    let (item, option) = (0usize..8, 0usize..8);
    prop_oneof![
        1 => (item.clone(), option.clone())
            .prop_map(|(item, option)| ItemChange::DropOption { item, option }),
        1 => (item.clone(), option.clone())
            .prop_map(|(item, option)| ItemChange::DuplicateOption { item, option }),
        3 => (item.clone(), option, prop::sample::select(OPTION_VALUES)).prop_map(
            |(item, option, value)| ItemChange::SetOption {
                item,
                option,
                value
            }
        ),
        2 => (
            item.clone(),
            prop::sample::select(OPTION_NAMES),
            prop::sample::select(OPTION_VALUES)
        )
            .prop_map(|(item, name, value)| ItemChange::AddOption { item, name, value }),
        1 => (item.clone(), 0..GENERATORS.len())
            .prop_map(|(item, to)| ItemChange::Rename { item, to }),
        1 => (0..GENERATORS.len(), any::<bool>()).prop_map(|(generator, options)| {
            ItemChange::AddGenerator { generator, options }
        }),
        1 => item.prop_map(|item| ItemChange::DeleteGenerator { item }),
    ]
}

/// What a generator case changes: the model, then its `generate` items.
#[derive(Clone, Debug)]
pub struct Changes {
    pub model: Vec<ModelChange>,
    pub items: Vec<ItemChange>,
}

impl Changes {
    /// No change: the base model as it is.
    pub fn none() -> Changes {
        Changes {
            model: Vec::new(),
            items: Vec::new(),
        }
    }
}

pub fn changes() -> impl Strategy<Value = Changes> {
    (
        prop::collection::vec(model_change(), 0..3),
        prop::collection::vec(item_change(), 0..4),
    )
        .prop_map(|(model, items)| Changes { model, items })
}

/// One `generate` item: the generator's name and its options, as written.
#[derive(Clone, Debug)]
struct Item {
    name: String,
    options: Vec<(String, String)>,
}

/// `text` split at the commas outside brackets, each part trimmed (none if blank).
fn split_top(text: &str) -> Vec<String> {
    let (mut parts, mut depth, mut start) = (Vec::new(), 0i32, 0);
    for (i, c) in text.char_indices() {
        match c {
            '(' | '[' | '{' => depth += 1,
            ')' | ']' | '}' => depth -= 1,
            ',' if depth == 0 => {
                parts.push(text[start..i].trim().to_owned());
                start = i + 1;
            }
            _ => {}
        }
    }
    parts.push(text[start..].trim().to_owned());
    parts.retain(|p| !p.is_empty());
    parts
}

/// The `generate` items of a list written as in a `model!` (`ekf, lqr(horizon = 5)`).
fn parse_items(list: &str) -> Vec<Item> {
    split_top(list)
        .into_iter()
        .map(|item| match item.split_once('(') {
            None => Item {
                name: item,
                options: Vec::new(),
            },
            Some((name, rest)) => Item {
                name: name.trim().to_owned(),
                options: split_top(rest.strip_suffix(')').unwrap_or(rest))
                    .into_iter()
                    .map(|o| match o.split_once('=') {
                        Some((k, v)) => (k.trim().to_owned(), v.trim().to_owned()),
                        None => (o, String::new()),
                    })
                    .collect(),
            },
        })
        .collect()
}

fn render_item(item: &Item) -> String {
    if item.options.is_empty() {
        return item.name.clone();
    }
    let options: Vec<String> = item
        .options
        .iter()
        .map(|(k, v)| format!("{k} = {v}"))
        .collect();
    format!("{}({})", item.name, options.join(", "))
}

/// The items as a model file's `[generate]` table: a name as a string, a number as
/// itself, several of one generator as a list of tables.
fn render_table(items: &[Item]) -> String {
    fn scalar(v: &str) -> String {
        let numeric = v.starts_with(|c: char| c.is_ascii_digit() || "+-.".contains(c));
        if numeric {
            v.to_owned()
        } else {
            format!("\"{v}\"")
        }
    }
    fn value(v: &str) -> String {
        match v.strip_prefix('[').and_then(|v| v.strip_suffix(']')) {
            Some(list) => {
                let items: Vec<String> = split_top(list).iter().map(|i| value(i)).collect();
                format!("[{}]", items.join(", "))
            }
            None => scalar(v),
        }
    }
    fn table(item: &Item) -> String {
        let options: Vec<String> = item
            .options
            .iter()
            .map(|(k, v)| format!("{k} = {}", value(v)))
            .collect();
        format!("{{ {} }}", options.join(", "))
    }
    let mut names: Vec<&str> = Vec::new();
    for item in items {
        if !names.contains(&item.name.as_str()) {
            names.push(&item.name);
        }
    }
    let mut out = String::from("\n[generate]\n");
    for name in names {
        let of: Vec<&Item> = items.iter().filter(|i| i.name == name).collect();
        let rendered = match of.as_slice() {
            [one] if one.options.is_empty() => "true".to_owned(),
            [one] => table(one),
            several => {
                let tables: Vec<String> = several.iter().map(|i| table(i)).collect();
                format!("[{}]", tables.join(", "))
            }
        };
        out.push_str(&format!("{name} = {rendered}\n"));
    }
    out
}

fn change_items(items: &mut Vec<Item>, change: &ItemChange) {
    let n = items.len();
    match *change {
        ItemChange::AddGenerator { generator, options } => {
            let mut added = parse_items(GENERATORS[generator]);
            if !options {
                added[0].options.clear();
            }
            items.extend(added);
        }
        _ if n == 0 => {}
        ItemChange::DeleteGenerator { item } => {
            items.remove(item % n);
        }
        ItemChange::Rename { item, to } => {
            items[item % n].name = parse_items(GENERATORS[to])[0].name.clone();
        }
        ItemChange::AddOption { item, name, value } => {
            items[item % n]
                .options
                .push((name.to_owned(), value.to_owned()));
        }
        ItemChange::DropOption { item, option }
        | ItemChange::DuplicateOption { item, option }
        | ItemChange::SetOption { item, option, .. } => {
            let options = &mut items[item % n].options;
            if options.is_empty() {
                return;
            }
            let i = option % options.len();
            match *change {
                ItemChange::DropOption { .. } => {
                    options.remove(i);
                }
                ItemChange::DuplicateOption { .. } => options.push(options[i].clone()),
                ItemChange::SetOption { value, .. } => options[i].1 = value.to_owned(),
                _ => unreachable!(),
            }
        }
    }
}

/// The byte ranges of the statements opened by `keyword` at the start of a line, each up
/// to its `;` outside brackets.
fn statements(text: &str, keyword: &str) -> Vec<Range<usize>> {
    let mut found = Vec::new();
    let mut line_start = 0;
    for line in text.split_inclusive('\n') {
        let indent = line.len() - line.trim_start().len();
        let rest = &line[indent..];
        let opens = rest.strip_prefix(keyword).is_some_and(|after| {
            after.is_empty() || after.starts_with(|c: char| c.is_whitespace())
        });
        let start = line_start + indent;
        if opens && found.last().is_none_or(|r: &Range<usize>| r.end <= start) {
            if let Some(end) = top_level(&text[start..], ';') {
                found.push(start..start + end + 1);
            }
        }
        line_start += line.len();
    }
    found
}

/// The offset of the first `c` outside brackets.
fn top_level(text: &str, c: char) -> Option<usize> {
    let mut depth = 0i32;
    for (i, ch) in text.char_indices() {
        match ch {
            '(' | '[' => depth += 1,
            ')' | ']' => depth -= 1,
            _ if ch == c && depth <= 0 => return Some(i),
            _ => {}
        }
    }
    None
}

/// The offset just past the bracket that closes the one opening `text`.
fn closing(text: &str) -> Option<usize> {
    let mut depth = 0i32;
    for (i, ch) in text.char_indices() {
        match ch {
            '(' | '[' | '{' => depth += 1,
            ')' | ']' | '}' => {
                depth -= 1;
                if depth == 0 {
                    return Some(i + 1);
                }
            }
            _ => {}
        }
    }
    None
}

/// `text` with the identifier `word` replaced by `by` wherever it stands alone.
fn replace_word(text: &str, word: &str, by: &str) -> String {
    if word.is_empty() {
        return text.to_owned();
    }
    let is_ident = |c: char| c.is_alphanumeric() || c == '_';
    let mut out = String::new();
    let mut rest = text;
    while let Some(i) = rest.find(word) {
        let before = rest[..i].chars().next_back();
        let after = rest[i + word.len()..].chars().next();
        out.push_str(&rest[..i]);
        if before.is_some_and(is_ident) || after.is_some_and(is_ident) {
            out.push_str(word);
        } else {
            out.push_str(by);
        }
        rest = &rest[i + word.len()..];
    }
    out.push_str(rest);
    out
}

fn remove_ranges(text: &str, ranges: &[Range<usize>]) -> String {
    let mut out = text.to_owned();
    for r in ranges.iter().rev() {
        out.replace_range(r.clone(), "");
    }
    out
}

/// The left-hand name of an equation line (`x1 = ..`, not `let`, `==` or a comment).
fn equation_target(line: &str) -> Option<&str> {
    let t = line.trim_start();
    let name_len = t
        .find(|c: char| !(c.is_alphanumeric() || c == '_'))
        .unwrap_or(t.len());
    let (name, rest) = t.split_at(name_len);
    let rest = rest.trim_start();
    let is_equation =
        !name.is_empty() && name != "let" && rest.starts_with('=') && !rest.starts_with("==");
    is_equation.then_some(name)
}

/// The range of the body of the `dynamics` block (between its braces).
fn dynamics_body(text: &str) -> Option<Range<usize>> {
    let at = text.find("dynamics ")?;
    let open = at + text[at..].find('{')?;
    let close = open + closing(&text[open..])?;
    Some(open + 1..close - 1)
}

/// `change` applied to a `model!` model.
fn change_macro_model(text: &str, change: &ModelChange) -> String {
    match *change {
        ModelChange::DeleteOutputs => remove_ranges(text, &statements(text, "output")),
        ModelChange::DeleteInputs => macro_without_inputs(text),
        ModelChange::ToDiscrete => macro_to_discrete(text),
        ModelChange::ToContinuous { rk4 } => macro_to_continuous(text, rk4),
        ModelChange::Substeps(n) => macro_with_substeps(text, n),
        ModelChange::Declare { kind, name, used } => macro_declaring(text, kind, name, used),
    }
}

/// A `model!` model without its `input` statements, its dynamics reading 0.0 for them.
fn macro_without_inputs(text: &str) -> String {
    let found = statements(text, "input");
    let names: Vec<String> = found
        .iter()
        .flat_map(|r| split_top(&text[r.start + "input".len()..r.end - 1]))
        .map(|name| name.lines().last().unwrap_or("").trim().to_owned())
        .collect();
    let mut out = remove_ranges(text, &found);
    if let Some(body) = dynamics_body(&out) {
        let zeroed = names.iter().fold(out[body.clone()].to_owned(), |t, n| {
            replace_word(&t, n, "0.0")
        });
        out.replace_range(body, &zeroed);
    }
    out
}

/// A `model!` model's continuous dynamics made discrete, `der(x) = e` becoming `x = e`.
fn macro_to_discrete(text: &str) -> String {
    let Some(at) = text.find("dynamics continuous") else {
        return text.to_owned();
    };
    let open = at + "dynamics continuous".len();
    let Some(close) = closing(&text[open..]) else {
        return text.to_owned();
    };
    let mut out = format!("{}dynamics discrete{}", &text[..at], &text[open + close..]);
    while let Some(der) = out.find("der(") {
        let Some(close) = out[der..].find(')') else {
            break;
        };
        out.replace_range(der + close..der + close + 1, "");
        out.replace_range(der..der + 4, "");
    }
    out
}

/// A `model!` model's discrete dynamics made continuous (RK4 or Euler at `TS`), `x = e`
/// becoming `der(x) = e`.
fn macro_to_continuous(text: &str, rk4: bool) -> String {
    let Some(at) = text.find("dynamics discrete") else {
        return text.to_owned();
    };
    let method = if rk4 { "rk4" } else { "euler" };
    let mut out = text.to_owned();
    out.replace_range(
        at..at + "dynamics discrete".len(),
        &format!("dynamics continuous({method}, dt = TS)"),
    );
    let Some(body) = dynamics_body(&out) else {
        return out;
    };
    let lines: Vec<String> = out[body.clone()]
        .split_inclusive('\n')
        .map(|line| match equation_target(line) {
            Some(name) => line.replacen(name, &format!("der({name})"), 1),
            None => line.to_owned(),
        })
        .collect();
    out.replace_range(body, &lines.concat());
    out
}

/// A `model!` model's dynamics made continuous (Euler if they were discrete) with
/// `substeps = n` in place of any it had.
fn macro_with_substeps(text: &str, n: &str) -> String {
    let text = change_macro_model(text, &ModelChange::ToContinuous { rk4: false });
    let Some(at) = text.find("dynamics continuous") else {
        return text;
    };
    let open = at + "dynamics continuous".len();
    let Some(close) = closing(&text[open..]) else {
        return text;
    };
    let mut args = split_top(&text[open + 1..open + close - 1]);
    args.retain(|a| !a.starts_with("substeps"));
    args.push(format!("substeps = {n}"));
    format!(
        "{}({}){}",
        &text[..open],
        args.join(", "),
        &text[open + close..]
    )
}

/// A `model!` model with `kind name;` declared after `scalar`, the first equation's
/// right-hand side multiplied by `name` if `used`.
fn macro_declaring(text: &str, kind: &str, name: &str, used: bool) -> String {
    let mut out = text.to_owned();
    if used {
        multiply_first_macro_equation(&mut out, name);
    }
    match statements(&out, "scalar").first() {
        Some(r) => {
            out.insert_str(r.end, &format!("\n        {kind} {name};"));
            out
        }
        None => out,
    }
}

/// Multiplies the right-hand side of the first one-line equation of a `model!` model's
/// dynamics by `name`.
fn multiply_first_macro_equation(out: &mut String, name: &str) {
    let Some(body) = dynamics_body(out) else {
        return;
    };
    let lines: Vec<&str> = out[body.clone()].split_inclusive('\n').collect();
    let first = lines.iter().position(|l| {
        equation_target(l.trim_start().trim_start_matches("der(")).is_some()
            && l.trim_end().ends_with(';')
    });
    if let Some(i) = first {
        let line = lines[i];
        let eq = line.find('=').unwrap_or(0);
        let semi = line.rfind(';').unwrap_or(line.len());
        let wrapped = format!(
            "{}= {name} * ({}){}",
            &line[..eq],
            line[eq + 1..semi].trim(),
            &line[semi..]
        );
        let mut new = lines.clone();
        new[i] = &wrapped;
        let body_text = new.concat();
        out.replace_range(body, &body_text);
    }
}

/// The entries of a model file's array of tables `header`, each up to the next header.
fn file_entries(text: &str, header: &str) -> Vec<Range<usize>> {
    let mut found = Vec::new();
    let mut from = 0;
    while let Some(at) = text[from..].find(header).map(|i| i + from) {
        let end = text[at + header.len()..]
            .find("\n[")
            .map_or(text.len(), |i| at + header.len() + i + 1);
        found.push(at..end);
        from = end;
    }
    found
}

/// `text` without the lines that start with any of `keys`.
fn without_lines(text: &str, keys: &[&str]) -> String {
    text.split_inclusive('\n')
        .filter(|l| !keys.iter().any(|k| l.starts_with(k)))
        .collect()
}

/// `change` applied to a model file (without its `[generate]` table).
fn change_model_file(text: &str, change: &ModelChange) -> String {
    match *change {
        ModelChange::DeleteOutputs => remove_ranges(text, &file_entries(text, "[[output]]")),
        ModelChange::DeleteInputs => file_without_inputs(text),
        ModelChange::ToDiscrete => without_lines(
            &text.replace("kind = \"continuous\"", "kind = \"discrete\""),
            &["method =", "dt =", "substeps ="],
        ),
        ModelChange::ToContinuous { rk4 } => {
            let method = if rk4 { "rk4" } else { "euler" };
            text.replace(
                "kind = \"discrete\"",
                &format!("kind = \"continuous\"\nmethod = \"{method}\"\ndt = \"TS\""),
            )
        }
        ModelChange::Substeps(n) => {
            let text = change_model_file(text, &ModelChange::ToContinuous { rk4: false });
            without_lines(&text, &["substeps ="]).replace(
                "kind = \"continuous\"",
                &format!("kind = \"continuous\"\nsubsteps = {n}"),
            )
        }
        ModelChange::Declare { kind, name, used } => file_declaring(text, kind, name, used),
    }
}

/// A model file without its `[[input]]` entries, its equations reading 0 for them.
fn file_without_inputs(text: &str) -> String {
    let found = file_entries(text, "[[input]]");
    let names: Vec<String> = found
        .iter()
        .filter_map(|r| {
            let at = r.start + text[r.clone()].find("name = \"")? + "name = \"".len();
            Some(text[at..at + text[at..].find('"')?].to_owned())
        })
        .collect();
    let out = remove_ranges(text, &found);
    match out.find("[dynamics.equations]") {
        Some(at) => {
            let zeroed = names
                .iter()
                .fold(out[at..].to_owned(), |t, n| replace_word(&t, n, "0"));
            format!("{}{zeroed}", &out[..at])
        }
        None => out,
    }
}

/// A model file with a `[[kind]]` entry `name` before `[dynamics]`, the first equation's
/// right-hand side multiplied by `name` if `used`.
fn file_declaring(text: &str, kind: &str, name: &str, used: bool) -> String {
    let mut out = text.to_owned();
    if used {
        if let Some(at) = out.find("[dynamics.equations]\n") {
            let line_start = at + "[dynamics.equations]\n".len();
            let line_end = out[line_start..]
                .find('\n')
                .map_or(out.len(), |i| line_start + i);
            let line = out[line_start..line_end].to_owned();
            if let Some((lhs, rhs)) = line.split_once("= \"") {
                let rhs = rhs.trim_end_matches('"');
                let wrapped = format!("{lhs}= \"{name} * ({rhs})\"");
                out.replace_range(line_start..line_end, &wrapped);
            }
        }
    }
    let entry = format!("[[{kind}]]\nname = \"{name}\"\n\n");
    match out.find("[dynamics]") {
        Some(at) => out.insert_str(at, &entry),
        None => out.push_str(&format!("\n{entry}")),
    }
    out
}

/// A `model!` model after `changes`.
pub fn changed_macro_model(base: &str, changes: &Changes) -> String {
    let text = changes
        .model
        .iter()
        .fold(base.to_owned(), |t, c| change_macro_model(&t, c));
    // The `generate` statements become one, at the first, with the items changed.
    let found = statements(&text, "generate");
    let mut items: Vec<Item> = found
        .iter()
        .flat_map(|r| parse_items(&text[r.start + "generate".len()..r.end - 1]))
        .collect();
    for change in &changes.items {
        change_items(&mut items, change);
    }
    let at = match (found.first(), statements(&text, "scalar").first()) {
        (Some(r), _) => r.start,
        (None, Some(r)) => r.end + 1,
        (None, None) => 0,
    };
    let mut text = remove_ranges(&text, &found);
    if !items.is_empty() {
        let list: Vec<String> = items.iter().map(render_item).collect();
        text.insert_str(at, &format!("generate {};", list.join(", ")));
    }
    text
}

/// A model file (without its `[generate]` table) and its generators, written as in a
/// `model!`, after `changes`.
pub fn changed_model_file((base, generators): (&str, &str), changes: &Changes) -> String {
    let text = changes
        .model
        .iter()
        .fold(base.to_owned(), |t, c| change_model_file(&t, c));
    let mut items = parse_items(generators);
    for change in &changes.items {
        change_items(&mut items, change);
    }
    format!("{text}{}", render_table(&items))
}
