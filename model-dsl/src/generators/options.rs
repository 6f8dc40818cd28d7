//! Reading a `generate` item's options: every generator takes its options from [`Args`]
//! one by one (what is left is reported as unknown) with the readers here, so a number, a
//! whole number, a name list or a noise shape is checked and explained the same way in
//! every generator.

use crate::ast::{ArgValue, GenerateArg, GenerateDecl, ModelDecl, Name};
use crate::diagnostics::{closest, phrase, Diagnostics};
use crate::emit::filter::ProcessNoise;
use crate::model::{Expr, Value};
use crate::scope::{Binding, Scope};
use proc_macro2::Span;

/// What a generator's options may refer to: the declaration (its dynamics, say) and the
/// names declared in it.
pub struct Context<'a> {
    /// The model as written.
    pub decl: &'a ModelDecl,
    scope: &'a Scope,
    /// The cycle budget of the `generate` item whose options are read, if it gives one
    /// (`max_cycles = ..`): a generator whose work varies from call to call may bound it
    /// at run time to stay within its call's ([`super::budget::Budget::limit_of`]).
    pub cycle_budget: Option<super::budget::Budget>,
}

impl<'a> Context<'a> {
    /// The context of the model `decl` whose names are `scope`.
    pub(crate) fn new(decl: &'a ModelDecl, scope: &'a Scope) -> Context<'a> {
        Context {
            decl,
            scope,
            cycle_budget: None,
        }
    }

    /// The same context for a `generate` item with the cycle budget `cycle_budget`.
    pub(crate) fn with_budget(&self, cycle_budget: Option<super::budget::Budget>) -> Context<'a> {
        Context {
            decl: self.decl,
            scope: self.scope,
            cycle_budget,
        }
    }

    /// The value of the model constant `name`, if it names one.
    pub fn constant_value(&self, name: &Name) -> Option<f64> {
        match self.scope.get(&name.text) {
            Some((Binding::Const(i), _)) => self.scope.const_value(*i),
            _ => None,
        }
    }

    /// The index of the physical state `name` in the model's states, if it is one.
    pub fn state_index(&self, name: &str) -> Option<usize> {
        match self.scope.get(name) {
            Some((Binding::State(i), _)) => Some(*i),
            _ => None,
        }
    }

    /// The index of the state or parameter `name` in the state vector (physical states
    /// first, then parameters), if it is one.
    pub fn estimate_index(&self, name: &str) -> Option<usize> {
        match self.scope.get(name)? {
            (Binding::State(i), _) => Some(*i),
            (Binding::Param(i), _) => Some(self.scope.state_len + i),
            _ => None,
        }
    }

    /// The indices in the state vector of the state or parameter `name`: one for a number,
    /// its entries for a vector or rotation; `None` if it is neither.
    pub fn estimate_indices(&self, name: &str) -> Option<Vec<usize>> {
        let state_len = self.scope.state_len;
        self.entries(name, &|e| match e {
            Expr::State(i) => Some(*i),
            Expr::Param(i) => Some(state_len + i),
            _ => None,
        })
    }

    /// The indices among the physical states of `name`'s entries (one for a number).
    pub fn state_indices(&self, name: &str) -> Option<Vec<usize>> {
        self.entries(name, &|e| match e {
            Expr::State(i) => Some(*i),
            _ => None,
        })
    }

    /// The indices among the inputs of `name`'s entries (one for a number).
    pub fn input_indices(&self, name: &str) -> Option<Vec<usize>> {
        self.entries(name, &|e| match e {
            Expr::Input(i) => Some(*i),
            _ => None,
        })
    }

    /// `index` of each entry of the symbol `name` (itself if a number), if it has all.
    fn entries(&self, name: &str, index: &dyn Fn(&Expr) -> Option<usize>) -> Option<Vec<usize>> {
        let entries = match self.scope.get(name)? {
            (Binding::Typed(i), _) => match self.scope.typed(*i)? {
                Value::Vec3(v) => v.to_vec(),
                Value::Rot3 { q, .. } => q.to_vec(),
                Value::Scalar(e) => vec![e.clone()],
            },
            (Binding::State(i), _) => vec![Expr::State(*i)],
            (Binding::Param(i), _) => vec![Expr::Param(*i)],
            (Binding::Input(i), _) => vec![Expr::Input(*i)],
            _ => return None,
        };
        entries.iter().map(index).collect()
    }

    /// The names of the states and parameters, in declaration order.
    pub fn estimate_names(&self) -> impl Iterator<Item = &str> {
        let names = self.scope.names.iter();
        names
            .filter(|(name, _)| self.estimate_indices(name).is_some())
            .map(|(name, _)| name.as_str())
    }

    /// The names of the inputs, in declaration order (a vector's own, not its entries').
    pub fn input_names(&self) -> impl Iterator<Item = &str> {
        let names = self.scope.names.iter();
        names
            .filter(|(name, _)| self.input_indices(name).is_some())
            .map(|(name, _)| name.as_str())
    }

    /// Whether `name` is a rotation.
    pub fn is_rotation(&self, name: &str) -> bool {
        match self.scope.get(name) {
            Some((Binding::Typed(i), _)) => {
                matches!(self.scope.typed(*i), Some(Value::Rot3 { .. }))
            }
            _ => false,
        }
    }

    /// The index of the input `name` in the model's inputs, if it is one.
    pub fn input_index(&self, name: &str) -> Option<usize> {
        match self.scope.get(name) {
            Some((Binding::Input(i), _)) => Some(*i),
            _ => None,
        }
    }
}

/// The arguments of one `generate` item, taken one by one; what is left is an error.
pub struct Args<'a> {
    item: &'a GenerateDecl,
    used: Vec<bool>,
    /// The options the generator asked for, by their first names: what an unknown one is
    /// told it could have been.
    options: Vec<String>,
    /// An option written under two of its names (`state` and `states`): where, and why.
    aliased: Vec<(Span, String)>,
}

impl<'a> Args<'a> {
    /// The arguments of `item`; one given twice is an error.
    pub fn new(item: &'a GenerateDecl, diag: &mut Diagnostics) -> Args<'a> {
        let mut names = std::collections::HashSet::new();
        for arg in &item.args {
            if !names.insert(arg.name.text.as_str()) {
                diag.error(arg.name.span, format!("`{}` is given twice", arg.name.text));
            }
        }
        Args {
            item,
            used: vec![false; item.args.len()],
            options: Vec::new(),
            aliased: Vec::new(),
        }
    }

    /// The argument written under one of `names`, the first if several were (the others
    /// are reported as given twice, not as unknown: all are marked as used).
    pub fn take(&mut self, names: &[&str]) -> Option<&'a GenerateArg> {
        if let Some(&name) = names.first() {
            if !self.options.iter().any(|o| o == name) {
                self.options.push(name.to_owned());
            }
        }
        let mut first: Option<&'a GenerateArg> = None;
        for (i, arg) in self.item.args.iter().enumerate() {
            if !names.contains(&arg.name.text.as_str()) {
                continue;
            }
            self.used[i] = true;
            match first {
                None => first = Some(arg),
                Some(earlier) if earlier.name.text != arg.name.text => self.aliased.push((
                    arg.name.span,
                    format!(
                        "`{}` and `{}` are the same option: give it once",
                        arg.name.text, earlier.name.text
                    ),
                )),
                // The same name twice is reported when the arguments are read.
                Some(_) => {}
            }
        }
        first
    }

    /// The number given as `name`, or `default`, with where to report a wrong value: the
    /// value, or the generator's name when the default is taken.
    pub fn number(&mut self, name: &str, default: f64, diag: &mut Diagnostics) -> (f64, Span) {
        match self.take(&[name]).map(|a| &a.value) {
            None => (default, self.item.name.span),
            Some(ArgValue::Number(v, span)) => (*v, *span),
            Some(other) => {
                diag.error(other.span(), format!("`{name}` takes a number"));
                (default, other.span())
            }
        }
    }

    /// The number given as `name`, if any.
    pub fn optional_number(&mut self, name: &str, diag: &mut Diagnostics) -> Option<(f64, Span)> {
        match self.take(&[name]).map(|a| &a.value) {
            None => None,
            Some(ArgValue::Number(v, span)) => Some((*v, *span)),
            Some(other) => {
                diag.error(other.span(), format!("`{name}` takes a number"));
                None
            }
        }
    }

    /// The whole number given as `name` (1 to `max`, counting `unit`), or `default`.
    pub fn whole(
        &mut self,
        (name, unit): (&str, &str),
        default: u32,
        max: u32,
        diag: &mut Diagnostics,
    ) -> u32 {
        let (value, span) = self.number(name, f64::from(default), diag);
        if value.fract() != 0.0 || !(1.0..=f64::from(max)).contains(&value) {
            diag.error(
                span,
                format!("`{name}` is a whole number of {unit}, 1 to {max}"),
            );
            return default;
        }
        value as u32
    }

    /// The name or list of names given under one of `names` (empty if none).
    pub fn names(&mut self, names: &[&str], diag: &mut Diagnostics) -> Vec<Name> {
        match self.take(names).map(|a| &a.value) {
            None => Vec::new(),
            Some(ArgValue::Name(n)) => vec![n.clone()],
            Some(ArgValue::Names(list, _)) => list.clone(),
            Some(
                ArgValue::Number(_, span) | ArgValue::Numbers(_, span) | ArgValue::Table(_, span),
            ) => {
                diag.error(
                    *span,
                    format!("`{}` takes a name or a list of names", names[0]),
                );
                Vec::new()
            }
        }
    }

    /// A number, or the value of a model constant, with where it was written.
    pub fn scalar(
        &mut self,
        name: &str,
        cx: &Context,
        diag: &mut Diagnostics,
    ) -> Option<(f64, Span)> {
        match &self.take(&[name])?.value {
            ArgValue::Number(v, span) => Some((*v, *span)),
            ArgValue::Name(n) => match cx.constant_value(n) {
                Some(v) => Some((v, n.span)),
                None => {
                    not_a_constant(n, diag);
                    None
                }
            },
            ArgValue::Names(_, span) | ArgValue::Numbers(_, span) | ArgValue::Table(_, span) => {
                diag.error(*span, format!("`{name}` takes a number or a constant"));
                None
            }
        }
    }

    /// A list of model constants, with where it was written.
    pub fn constants(
        &mut self,
        name: &str,
        cx: &Context,
        diag: &mut Diagnostics,
    ) -> Option<(Vec<f64>, Span)> {
        match &self.take(&[name])?.value {
            ArgValue::Names(list, span) => {
                let values: Vec<Option<f64>> = list
                    .iter()
                    .map(|n| {
                        let v = cx.constant_value(n);
                        if v.is_none() {
                            not_a_constant(n, diag);
                        }
                        v
                    })
                    .collect();
                let values: Option<Vec<f64>> = values.into_iter().collect();
                values.map(|v| (v, *span))
            }
            ArgValue::Numbers(_, span) => {
                diag.error(
                    *span,
                    format!(
                        "`{name}` takes a list of names of model constants: declare each \
                         value, `const A = 1e-6;`, and write `{name} = [A, B]`"
                    ),
                );
                None
            }
            other => {
                diag.error(
                    other.span(),
                    format!("`{name}` takes a list of model constants: `{name} = [A, B]`"),
                );
                None
            }
        }
    }

    /// `name = GatedEkf`: the generated type's name, or `default`. An UpperCamelCase
    /// identifier (that it names no other item is checked with all generators together).
    pub fn type_name(&mut self, default: &str, diag: &mut Diagnostics) -> String {
        match self.take(&["name"]).map(|a| &a.value) {
            None => default.to_owned(),
            Some(ArgValue::Name(n)) if is_type_name(&n.text) => n.text.clone(),
            Some(other) => {
                diag.error(
                    other.span(),
                    format!(
                        "`name` is the generated type's name, in UpperCamelCase: `name = \
                         Gated{default}`"
                    ),
                );
                default.to_owned()
            }
        }
    }

    /// `gate = 10.83` (the threshold on the normalised innovation squared) or `gate = off`
    /// (a gate that is open until set at run time); `None` without `gate`. Every filter
    /// that measures takes it (the shared measurement stage gates).
    pub fn gate(&mut self, diag: &mut Diagnostics) -> Option<f64> {
        match self.take(&["gate"]).map(|a| &a.value) {
            None => None,
            Some(ArgValue::Number(v, _)) if *v > 0.0 && v.is_finite() => Some(*v),
            Some(ArgValue::Name(n)) if n.text == "off" => Some(f64::INFINITY),
            Some(other) => {
                diag.error(
                    other.span(),
                    "`gate` is a threshold on the normalised innovation squared, a positive \
                     number (a chi-square quantile: 10.83 rejects one in a thousand \
                     consistent scalar measurements), or `off` to set it at run time",
                );
                None
            }
        }
    }

    /// `recover_after = 10` (consecutive refused measurements before a stage inflates its
    /// covariance, [`crate::emit::recovery`]) or `recover_after = off` (never: the filter
    /// refuses until it is reset); [`crate::emit::recovery::DEFAULT_RECOVER_AFTER`] without
    /// it. Every filter that measures through the measurement stage takes it.
    pub fn recover_after(&mut self, diag: &mut Diagnostics) -> Option<u32> {
        use crate::emit::recovery::{DEFAULT_RECOVER_AFTER, MAX_RECOVER_AFTER};
        match self.take(&["recover_after"]).map(|a| &a.value) {
            None => Some(DEFAULT_RECOVER_AFTER),
            Some(ArgValue::Number(v, _))
                if v.fract() == 0.0 && (1.0..=f64::from(MAX_RECOVER_AFTER)).contains(v) =>
            {
                Some(*v as u32)
            }
            Some(ArgValue::Name(n)) if n.text == "off" => None,
            Some(other) => {
                diag.error(
                    other.span(),
                    format!(
                        "`recover_after` is how many measurements in a row a filter refuses \
                         before it inflates its covariance and takes them again, a whole \
                         number from 1 to {MAX_RECOVER_AFTER} (10 unless given), or `off` to \
                         refuse until `reset`"
                    ),
                );
                Some(DEFAULT_RECOVER_AFTER)
            }
        }
    }

    /// `process_noise = diagonal` or `full` (the default).
    pub fn process_noise(&mut self, diag: &mut Diagnostics) -> bool {
        match self.take(&["process_noise"]).map(|a| &a.value) {
            None => false,
            Some(ArgValue::Name(n)) if n.text == "diagonal" => true,
            Some(ArgValue::Name(n)) if n.text == "full" => false,
            Some(other) => {
                let values = match other {
                    ArgValue::Names(..)
                    | ArgValue::Numbers(..)
                    | ArgValue::Number(..)
                    | ArgValue::Table(..) => {
                        "; the noise values themselves are given at run time, to `new` and \
                         `set_process_noise`"
                    }
                    ArgValue::Name(_) => "",
                };
                diag.error(
                    other.span(),
                    format!(
                        "`process_noise` is the covariance's shape: `diagonal` (only the \
                         variances) or `full` (a symmetric matrix){values}"
                    ),
                );
                false
            }
        }
    }

    /// `process_noise = diagonal | full` and `process_noise_on = [eta2, inv_m]`: the
    /// process noise's shape, on every state or on the states and parameters listed (in
    /// the order given: the order of its entries).
    pub fn process_noise_shape(&mut self, cx: &Context, diag: &mut Diagnostics) -> ProcessNoise {
        let diagonal = self.process_noise(diag);
        let Some(arg) = self.take(&["process_noise_on"]) else {
            return ProcessNoise { diagonal, on: None };
        };
        let (names, span) = match &arg.value {
            ArgValue::Names(list, span) => (list.clone(), *span),
            ArgValue::Name(n) => (vec![n.clone()], n.span),
            other => {
                diag.error(other.span(), PROCESS_NOISE_ON_USAGE);
                return ProcessNoise { diagonal, on: None };
            }
        };
        if names.is_empty() {
            diag.error(span, PROCESS_NOISE_ON_USAGE);
        }
        let on = listed_entries(&names, diag, |name| {
            cx.estimate_indices(&name.text).ok_or_else(|| {
                let hint = did_you_mean(&name.text, cx.estimate_names());
                let text = &name.text;
                format!("`{text}` is not a state or parameter: {hint}{PROCESS_NOISE_ON_USAGE}")
            })
        });
        ProcessNoise {
            diagonal,
            on: on.filter(|_| !names.is_empty()),
        }
    }

    /// `input_noise = [gyro, accel]`: the inputs whose noise enters the state through the
    /// input Jacobian, each as its entries (a vector's three) in the order listed; empty
    /// without the option (or with a mistake in it, reported).
    pub fn input_noise(&mut self, cx: &Context, diag: &mut Diagnostics) -> Vec<usize> {
        let Some(arg) = self.take(&["input_noise"]) else {
            return Vec::new();
        };
        let names = match &arg.value {
            ArgValue::Names(list, _) if !list.is_empty() => list.clone(),
            ArgValue::Name(n) => vec![n.clone()],
            other => {
                diag.error(other.span(), INPUT_NOISE_USAGE);
                return Vec::new();
            }
        };
        let entries = listed_entries(&names, diag, |name| {
            let text = &name.text;
            match cx.input_indices(text) {
                Some(_) if cx.is_rotation(text) => Err(format!(
                    "`{text}` is a rotation: noise on a rotation input is not supported; \
                     {INPUT_NOISE_USAGE}"
                )),
                Some(found) => Ok(found),
                None if cx.estimate_indices(text).is_some() => Err(format!(
                    "`{text}` is a state or parameter, not an input (noise on it is \
                     `process_noise_on = [{text}]`); {INPUT_NOISE_USAGE}"
                )),
                None => {
                    let hint = did_you_mean(text, cx.input_names());
                    Err(format!(
                        "`{text}` is not an input: {hint}{INPUT_NOISE_USAGE}"
                    ))
                }
            }
        });
        entries.unwrap_or_default()
    }

    /// Reports every argument no reader took, and options written under two names.
    pub fn report_unused(&self, diag: &mut Diagnostics) {
        for (span, message) in &self.aliased {
            diag.error(*span, message);
        }
        for (arg, used) in self.item.args.iter().zip(&self.used) {
            if !used {
                diag.error(arg.name.span, self.unknown_option(&arg.name.text));
            }
        }
    }

    /// What an option the generator does not take is told: the one it may have meant, or
    /// the generator's options.
    fn unknown_option(&self, name: &str) -> String {
        let generator = &self.item.name.text;
        let options: Vec<String> = self.options.iter().map(|o| format!("`{o}`")).collect();
        match closest(name, self.options.iter().map(String::as_str)) {
            Some(near) => {
                format!("`{generator}` takes no argument `{name}`: did you mean `{near}`?")
            }
            None if options.is_empty() => format!("`{generator}` takes no arguments"),
            None => format!(
                "`{generator}` takes no argument `{name}`; its options are {}",
                phrase(&options, "and")
            ),
        }
    }
}

/// The entries (`entries` of each name, or the error to report under it) of a list of
/// names, in the order listed; a name whose entries were listed before is an error.
/// `None` if any name was in error.
fn listed_entries(
    names: &[Name],
    diag: &mut Diagnostics,
    entries: impl Fn(&Name) -> Result<Vec<usize>, String>,
) -> Option<Vec<usize>> {
    let mut listed = Vec::new();
    let mut complete = true;
    for name in names {
        match entries(name) {
            Ok(found) if found.iter().any(|i| listed.contains(i)) => {
                diag.error(name.span, format!("`{}` is listed twice", name.text));
                complete = false;
            }
            Ok(found) => listed.extend(found),
            Err(message) => {
                diag.error(name.span, message);
                complete = false;
            }
        }
    }
    complete.then_some(listed)
}

/// `did you mean `meant`? ` for the name among `names` closest to `text`, if one is.
fn did_you_mean<'n>(text: &str, names: impl Iterator<Item = &'n str>) -> String {
    match closest(text, names) {
        Some(meant) => format!("did you mean `{meant}`? "),
        None => String::new(),
    }
}

fn not_a_constant(name: &Name, diag: &mut Diagnostics) {
    diag.error(
        name.span,
        format!("`{}` is not a constant of the model", name.text),
    );
}

/// An UpperCamelCase identifier (`GatedEkf`): a capital first, then letters and digits.
fn is_type_name(text: &str) -> bool {
    text.chars().next().is_some_and(|c| c.is_ascii_uppercase())
        && text.chars().all(|c| c.is_ascii_alphanumeric())
        && text.chars().any(|c| c.is_ascii_lowercase())
}

/// What `process_noise_on` takes.
const PROCESS_NOISE_ON_USAGE: &str = "`process_noise_on` lists the states and parameters \
     the process noise enters, `process_noise_on = [x2, k]`; it is zero on the others (by \
     default it enters every state)";

/// What `input_noise` takes.
const INPUT_NOISE_USAGE: &str = "`input_noise` lists the inputs (numbers or vectors) whose \
     noise enters the state through the input Jacobian, `input_noise = [gyro, accel]`; their \
     variances per sample are given at run time, to `new` and `set_input_noise`";

/// The physical states a controller regulates and the inputs it computes, by index
/// (`states = [x1, x2], input = u`); `example` opens the usage shown when either is missing.
pub fn regulated(
    item: &GenerateDecl,
    args: &mut Args,
    cx: &Context,
    diag: &mut Diagnostics,
    example: &str,
) -> (Vec<usize>, Vec<usize>) {
    let states = args.names(&["states", "state"], diag);
    let inputs = args.names(&["inputs", "input"], diag);
    let lookup = |names: Vec<Name>,
                  index: &dyn Fn(&str) -> Option<Vec<usize>>,
                  what: &str,
                  diag: &mut Diagnostics| {
        names
            .iter()
            .filter_map(|name| {
                let found = index(&name.text);
                if found.is_none() {
                    diag.error(name.span, format!("`{}` is not {what}", name.text));
                }
                found
            })
            .flatten()
            .collect::<Vec<usize>>()
    };
    // Names given but not states or inputs have their own errors.
    let missing = states.is_empty() || inputs.is_empty();
    let states = lookup(
        states,
        &|n| cx.state_indices(n),
        "a physical state (`state`)",
        diag,
    );
    let inputs = lookup(inputs, &|n| cx.input_indices(n), "an input (`input`)", diag);
    for (list, what) in [(&states, "state"), (&inputs, "input")] {
        let mut seen = std::collections::HashSet::new();
        if list.iter().any(|i| !seen.insert(*i)) {
            diag.error(
                item.name.span,
                format!(
                    "`{}` lists a regulated {what} twice: name each once",
                    item.name.text
                ),
            );
        }
    }
    if missing {
        diag.error(
            item.name.span,
            format!(
                "`{}` needs the states it regulates and the inputs it computes: \
                 `{example}states = [x1, x2], input = u)`",
                item.name.text
            ),
        );
    }
    (states, inputs)
}
