//! TOML model files: the same model as the macro, for tools and code review.
//!
//! ```toml
//! name = "cantilever"
//! doc = "Cantilever beam, first mode."
//! scalar = ["f32", "f64"]
//!
//! [[const]]
//! name = "TS"
//! value = 0.015
//! doc = "Sample time [s]."
//!
//! [[state]]
//! name = "x1"
//!
//! [[output]]
//! name = "y"
//! value = "x1"
//!
//! [dynamics]
//! kind = "discrete"            # or "continuous", with method = "euler" | "rk4",
//!                              # dt = "TS" and optionally substeps = 2
//! [dynamics.equations]         # x[k+1] (discrete) or dx/dt (continuous), per state
//! x1 = "x1 + TS * x2"
//! ```
//! Expressions are parsed by `meval`: `+ - * / ^` (integer powers), functions
//! `sin cos tan tanh exp ln sqrt abs`, `atan2(y, x)`, `min(a, b)`, `max(a, b)`,
//! `clamp(x, lo, hi)` (a saturation), and the piecewise functions `if_gt(a, b, then, else)`,
//! `if_ge`, `if_lt`, `if_le` for `if a > b { then } else { else }` and so on.
//! With `type = "Vec3"` or `"Rot3"` on a `[[state]]`, `[[param]]`, `[[input]]` or
//! `[[known]]`, expressions read vectors and rotations as the macro does: `vec3(a, b, c)`,
//! `v.x`, `q * v`, `q.inverse()`, `a.dot(b)`, `exp(theta)`, `log(q)` (`expression_dots`:
//! a `.` follows a name).
//! `[[known]]` entries (`name`, `doc`) declare constants known only at run time.
//! `interval = true` on a `[[const]]` declares it the model's sample interval, the macro's
//! `interval DT = 0.004;`: its value the nominal one, each prediction taking the actual.
//! `[[dynamics.let]]` entries (`name`, `value`) define intermediates, in order.
//! `[[sensor]]` entries (`name`, `outputs`, `doc`, and optionally `gate = 22.46` or
//! `gate = "off"` and `delay = 38`, the macro's `sensor gnss(gate = 22.46, delay = 38) =
//! [..]`) group outputs.

use crate::expression_places;
pub use crate::expression_text::comparison_of;
use crate::expression_text::parse_expression;
use crate::toml_hints::{self, TABLE_OPTIONS};
use proc_macro2::{Span, TokenStream};
use serde::de::{Deserializer, MapAccess, SeqAccess, Unexpected, Visitor};
use serde::Deserialize;
use stateforge_compiler::ast::{
    ArgValue, ConstDecl, DynamicsDecl, DynamicsKind, GenerateArg, GenerateDecl, ModelDecl, Name,
    OutputDecl, SensorDecl, Statement, SurfaceExpr, SurfaceKind, SymbolDecl, SymbolKind,
};
use stateforge_compiler::diagnostics::Diagnostics;
use std::fmt;
use std::marker::PhantomData;
use std::str::FromStr;
use toml::Spanned;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ModelFile {
    name: Spanned<String>,
    #[serde(default)]
    doc: String,
    #[serde(default)]
    visibility: Visibility,
    scalar: Spanned<OneOrMany>,
    #[serde(default, rename = "const")]
    constants: Vec<Constant>,
    #[serde(default, rename = "state")]
    states: Vec<Symbol>,
    #[serde(default, rename = "param")]
    params: Vec<Symbol>,
    #[serde(default, rename = "input")]
    inputs: Vec<Symbol>,
    #[serde(default, rename = "known")]
    known: Vec<Symbol>,
    #[serde(default, rename = "output")]
    outputs: Vec<Entry>,
    /// `[[sensor]] name = "gnss", outputs = ["gnss_pn", "gnss_pe"]`, optionally `gate = 22.46`.
    #[serde(default, rename = "sensor")]
    sensors: Vec<Sensor>,
    dynamics: Option<Dynamics>,
    /// `ekf = true`, `dkf = { eta = 0.5 }`, `lqr = { horizon = 50, states = ["x1"], input = "u" }`.
    generate: Option<InFileOrder<Spanned<Generator>>>,
}

/// Who may use the generated module: a closed set, so nothing of the file becomes tokens
/// unchecked.
#[derive(Deserialize, Default, Clone, Copy)]
enum Visibility {
    #[default]
    #[serde(rename = "pub")]
    Public,
    #[serde(rename = "pub(crate)")]
    Crate,
    #[serde(rename = "pub(super)")]
    Super,
    #[serde(rename = "private")]
    Private,
}

impl Visibility {
    fn tokens(self) -> TokenStream {
        match self {
            Visibility::Public => quote::quote! { pub },
            Visibility::Crate => quote::quote! { pub(crate) },
            Visibility::Super => quote::quote! { pub(super) },
            Visibility::Private => TokenStream::new(),
        }
    }
}

/// `scalar = "f32"` or `scalar = ["f32", "f64"]`.
enum OneOrMany {
    One(String),
    Many(Vec<String>),
}

impl<'de> Deserialize<'de> for OneOrMany {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct Scalars;
        impl<'de> Visitor<'de> for Scalars {
            type Value = OneOrMany;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str(
                    "a scalar type as a string, `scalar = \"f32\"`, or a list of them, \
                     `scalar = [\"f32\", \"f64\"]`",
                )
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<OneOrMany, E> {
                Ok(OneOrMany::One(v.to_owned()))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<OneOrMany, A::Error> {
                let mut list = Vec::new();
                while let Some(scalar) = seq.next_element()? {
                    list.push(scalar);
                }
                Ok(OneOrMany::Many(list))
            }
        }
        deserializer.deserialize_any(Scalars)
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Symbol {
    name: Spanned<String>,
    #[serde(default)]
    doc: String,
    /// Read by no expression on purpose: no warning (the macro's `#[allow(unused)]`).
    #[serde(default)]
    allow_unused: Option<Spanned<bool>>,
    /// `"Vec3"` or `"Rot3"` (the macro's `name: Vec3`); a number if absent.
    #[serde(default, rename = "type")]
    ty: Option<Spanned<String>>,
}

/// Outputs measured together by one sensor, listed by name, and its options (the macro's
/// `sensor gnss(gate = 22.46) = [..]`).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Sensor {
    name: Spanned<String>,
    outputs: Vec<Spanned<String>>,
    #[serde(default)]
    doc: String,
    /// `gate = 22.46` or `gate = "off"`: the sensor's own innovation gate.
    #[serde(default)]
    gate: Option<Spanned<OptionValue>>,
    /// `delay = 38`: how many samples late its measurements arrive.
    #[serde(default)]
    delay: Option<Spanned<OptionValue>>,
}

/// A `[[const]]`: a named expression, or with `interval = true` the sample interval.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Constant {
    name: Spanned<String>,
    value: Spanned<Value>,
    #[serde(default)]
    doc: String,
    /// `interval = true`: the model's sample interval, given to each prediction.
    interval: Option<Spanned<bool>>,
}

/// A named expression: an output or intermediate.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Entry {
    name: Spanned<String>,
    value: Spanned<Value>,
    #[serde(default)]
    doc: String,
}

/// A number, or an expression in a string.
enum Value {
    Number(f64),
    Text(String),
}

impl<'de> Deserialize<'de> for Value {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct NumberOrExpression;
        impl Visitor<'_> for NumberOrExpression {
            type Value = Value;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str(
                    "a number, such as `0.015`, or an expression in a string, such as \
                     `\"2 * TS\"`",
                )
            }
            fn visit_i64<E>(self, v: i64) -> Result<Value, E> {
                Ok(Value::Number(v as f64))
            }
            fn visit_u64<E>(self, v: u64) -> Result<Value, E> {
                Ok(Value::Number(v as f64))
            }
            fn visit_f64<E>(self, v: f64) -> Result<Value, E> {
                Ok(Value::Number(v))
            }
            fn visit_str<E>(self, v: &str) -> Result<Value, E> {
                Ok(Value::Text(v.to_owned()))
            }
        }
        deserializer.deserialize_any(NumberOrExpression)
    }
}

/// `substeps = 2`: a whole number (checked to be at least 1 by the checks).
struct Substeps(u64);

impl<'de> Deserialize<'de> for Substeps {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct Whole;
        impl Visitor<'_> for Whole {
            type Value = Substeps;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a whole number of sub-steps per sample, `substeps = 2`")
            }
            fn visit_u64<E>(self, v: u64) -> Result<Substeps, E> {
                Ok(Substeps(v))
            }
            fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<Substeps, E> {
                u64::try_from(v)
                    .map(Substeps)
                    .map_err(|_| E::invalid_value(Unexpected::Signed(v), &self))
            }
        }
        deserializer.deserialize_any(Whole)
    }
}

/// A generator's entry in `[generate]`: `true` (`false` leaves it out), a table of
/// options, or a list of such tables for several of one kind. Anything else is kept, to be
/// reported with the file's other mistakes.
enum Generator {
    Switch(bool),
    Options(InFileOrder<Spanned<OptionValue>>),
    Several(Vec<Spanned<Generator>>),
    Other(String),
}

impl<'de> Deserialize<'de> for Generator {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct Entry;
        impl<'de> Visitor<'de> for Entry {
            type Value = Generator;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("`true`, a table of options, or a list of tables")
            }
            fn visit_bool<E>(self, v: bool) -> Result<Generator, E> {
                Ok(Generator::Switch(v))
            }
            fn visit_i64<E>(self, v: i64) -> Result<Generator, E> {
                Ok(Generator::Other(format!("`{v}`")))
            }
            fn visit_u64<E>(self, v: u64) -> Result<Generator, E> {
                Ok(Generator::Other(format!("`{v}`")))
            }
            fn visit_f64<E>(self, v: f64) -> Result<Generator, E> {
                Ok(Generator::Other(format!("`{v}`")))
            }
            fn visit_str<E>(self, v: &str) -> Result<Generator, E> {
                Ok(Generator::Other(format!("`{v:?}`")))
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<Generator, A::Error> {
                Ok(Generator::Options(InFileOrder::read(map)?))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Generator, A::Error> {
                let mut list = Vec::new();
                while let Some(entry) = seq.next_element()? {
                    list.push(entry);
                }
                Ok(Generator::Several(list))
            }
        }
        deserializer.deserialize_any(Entry)
    }
}

/// A generator option's value as written: a number, a name (a string), a list, a table
/// (numbers by call: `schedule = { predict = 250 }`); or what the model language has no
/// reading of (`true`), described for the error.
enum OptionValue {
    Number(f64),
    Text(String),
    List(Vec<Spanned<OptionValue>>),
    Table(InFileOrder<Spanned<OptionValue>>),
    Other(String),
}

impl OptionValue {
    /// The value as the user wrote it, for an error message.
    fn describe(&self) -> String {
        match self {
            OptionValue::Number(v) => format!("`{v}`"),
            OptionValue::Text(s) => format!("`{s:?}`"),
            OptionValue::List(_) => "a list".to_owned(),
            OptionValue::Table(_) => "a table".to_owned(),
            OptionValue::Other(what) => what.clone(),
        }
    }
}

impl<'de> Deserialize<'de> for OptionValue {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct Written;
        impl<'de> Visitor<'de> for Written {
            type Value = OptionValue;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a number, a name as a string, or a list of names")
            }
            fn visit_bool<E>(self, v: bool) -> Result<OptionValue, E> {
                Ok(OptionValue::Other(format!("`{v}`")))
            }
            fn visit_i64<E>(self, v: i64) -> Result<OptionValue, E> {
                Ok(OptionValue::Number(v as f64))
            }
            fn visit_u64<E>(self, v: u64) -> Result<OptionValue, E> {
                Ok(OptionValue::Number(v as f64))
            }
            fn visit_f64<E>(self, v: f64) -> Result<OptionValue, E> {
                Ok(OptionValue::Number(v))
            }
            fn visit_str<E>(self, v: &str) -> Result<OptionValue, E> {
                Ok(OptionValue::Text(v.to_owned()))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<OptionValue, A::Error> {
                let mut list = Vec::new();
                while let Some(item) = seq.next_element()? {
                    list.push(item);
                }
                Ok(OptionValue::List(list))
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<OptionValue, A::Error> {
                Ok(OptionValue::Table(InFileOrder::read(map)?))
            }
        }
        deserializer.deserialize_any(Written)
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Dynamics {
    kind: Spanned<String>,
    method: Option<Spanned<String>>,
    dt: Option<Spanned<Value>>,
    substeps: Option<Spanned<Substeps>>,
    #[serde(default, rename = "let")]
    lets: Vec<Entry>,
    equations: InFileOrder<Spanned<Value>>,
}

/// A TOML table's entries in the order of the file, so generated code follows the file.
/// (`indexmap`'s serde support would do it, but would build `indexmap` differently from the
/// `model!` macro's, and the compiler with it, twice in a workspace holding both.)
/// Keys keep their place in the file, for errors about them.
struct InFileOrder<V>(Vec<(Spanned<String>, V)>);

impl<V> InFileOrder<V> {
    fn iter(&self) -> impl Iterator<Item = (&Spanned<String>, &V)> {
        self.0.iter().map(|(key, value)| (key, value))
    }

    fn read<'de, A: MapAccess<'de>>(mut map: A) -> Result<Self, A::Error>
    where
        V: Deserialize<'de>,
    {
        let mut entries = Vec::new();
        while let Some(entry) = map.next_entry()? {
            entries.push(entry);
        }
        Ok(InFileOrder(entries))
    }
}

impl<'de, V: Deserialize<'de>> Deserialize<'de> for InFileOrder<V> {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct Entries<V>(PhantomData<V>);
        impl<'de, V: Deserialize<'de>> Visitor<'de> for Entries<V> {
            type Value = InFileOrder<V>;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a table")
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<Self::Value, A::Error> {
                InFileOrder::read(map)
            }
        }
        deserializer.deserialize_map(Entries(PhantomData))
    }
}

/// Spans for places in a model file, so its errors point at line and column as the
/// macro's do. Each character of the file becomes one punctuation token of a synthetic
/// token stream with the file's line structure; the token's span is that place.
/// (Outside a procedural macro proc-macro2 records line and column for parsed text.)
struct Places {
    /// The span of each character, and the byte offset where it starts.
    spans: Vec<(usize, Span)>,
}

impl Places {
    fn of(source: &str) -> Places {
        let shadow: String = source
            .chars()
            .map(|c| if c == '\n' { '\n' } else { '.' })
            .collect();
        let spans = match TokenStream::from_str(&shadow) {
            Ok(tokens) => tokens.into_iter().map(|t| t.span()).collect(),
            Err(_) => Vec::new(),
        };
        let starts = source
            .char_indices()
            .filter(|(_, c)| *c != '\n')
            .map(|(i, _)| i);
        Places {
            spans: starts.zip(spans).collect(),
        }
    }

    /// The span of the character at (or last before) byte `offset`.
    fn at(&self, offset: usize) -> Span {
        let i = self.spans.partition_point(|(start, _)| *start <= offset);
        i.checked_sub(1)
            .and_then(|i| self.spans.get(i))
            .map_or_else(Span::call_site, |(_, span)| *span)
    }

    fn of_field<T>(&self, field: &Spanned<T>) -> Span {
        self.at(field.span().start)
    }

    /// The span of a string field's first character inside its quotes (of the field, if
    /// it is not a string).
    fn inside<T>(&self, source: &str, field: &Spanned<T>) -> Span {
        let start = field.span().start;
        let rest = source.get(start..).unwrap_or("");
        let quotes = ["\"\"\"", "'''", "\"", "'"];
        let delimiter = quotes.iter().find(|q| rest.starts_with(**q));
        self.at(start + delimiter.map_or(0, |q| q.len()))
    }
}

/// Reads a TOML model file into a [`ModelDecl`]. A file TOML cannot read is an error at
/// once; expression mistakes are collected, each naming its field. Every error points at
/// its line and column: a value, a key, or inside an expression string the token it is
/// about; and says what to write, in TOML.
pub fn parse_model_file(source: &str) -> syn::Result<(ModelDecl, Diagnostics)> {
    let places = Places::of(source);
    let file: ModelFile = toml::from_str(source).map_err(|e| {
        let span = e
            .span()
            .map_or_else(Span::call_site, |r| places.at(r.start));
        let at = e.span().and_then(|r| source.get(r.start..)).unwrap_or("");
        syn::Error::new(span, format!("model file: {}", with_fix(e.message(), at)))
    })?;
    let mut reader = Reader {
        source,
        places,
        diag: Diagnostics::default(),
    };
    // Fields in the order the macro's grammar reads them, which is the order of the errors.
    let decl = ModelDecl {
        docs: docs(&file.doc),
        vis: file.visibility.tokens(),
        name: reader.name(&file.name),
        scalars: reader.scalars(&file.scalar),
        span: reader.places.at(0),
        constants: reader.constants(&file.constants),
        symbols: reader.symbols(&file),
        outputs: reader.outputs(&file.outputs),
        sensors: reader.sensors(&file.sensors),
        dynamics: file.dynamics.iter().map(|d| reader.dynamics(d)).collect(),
        generate: generate_items(
            file.generate.as_ref(),
            source,
            &reader.places,
            &mut reader.diag,
        ),
    };
    Ok((decl, reader.diag))
}

/// The lines of a `doc` field, each led by a space as a `///` comment's are.
fn docs(doc: &str) -> Vec<String> {
    doc.lines()
        .filter(|_| !doc.is_empty())
        .map(|l| format!(" {l}"))
        .collect()
}

/// A model file read into the declarations of a [`ModelDecl`], its mistakes collected.
struct Reader<'a> {
    source: &'a str,
    places: Places,
    diag: Diagnostics,
}

impl Reader<'_> {
    /// A name, placed inside its quotes.
    fn name(&self, field: &Spanned<String>) -> Name {
        Name {
            text: field.get_ref().clone(),
            span: self.places.inside(self.source, field),
        }
    }

    /// A number, or an expression in a string, each token placed where it is written.
    fn expr(&mut self, value: &Spanned<Value>, field: &str) -> SurfaceExpr {
        let span = self.places.of_field(value);
        match value.get_ref() {
            Value::Number(v) => SurfaceExpr {
                kind: SurfaceKind::Number(*v),
                span,
            },
            Value::Text(text) => {
                // Byte `i` of the expression is at `offsets[i]` in the string's source text.
                let start = value.span().start;
                let offsets = self
                    .source
                    .get(value.span())
                    .and_then(|raw| expression_places::string_offsets(raw, text));
                let places = &self.places;
                let at = |i: usize| {
                    offsets
                        .as_ref()
                        .and_then(|o| o.get(i))
                        .map_or(span, |o| places.at(start + o))
                };
                parse_expression(text, field, &at, &mut self.diag)
            }
        }
    }

    /// `scalar = "f32"` or `scalar = ["f32", "f64"]`, each placed at the field.
    fn scalars(&self, scalar: &Spanned<OneOrMany>) -> Vec<Name> {
        let span = self.places.of_field(scalar);
        let scalar_name = |text: &String| Name {
            text: text.clone(),
            span,
        };
        match scalar.get_ref() {
            OneOrMany::One(s) => vec![scalar_name(s)],
            OneOrMany::Many(list) => list.iter().map(scalar_name).collect(),
        }
    }

    fn constants(&mut self, constants: &[Constant]) -> Vec<ConstDecl> {
        constants
            .iter()
            .map(|c| ConstDecl {
                interval: c
                    .interval
                    .as_ref()
                    .filter(|declared| *declared.get_ref())
                    .map(|declared| self.places.of_field(declared)),
                docs: docs(&c.doc),
                name: self.name(&c.name),
                value: self.expr(&c.value, &format!("const `{}`", c.name.get_ref())),
            })
            .collect()
    }

    /// States, parameters, inputs and known values, in that order.
    /// `allow_unused` applies to the others only: a state is never warned about.
    fn symbols(&mut self, file: &ModelFile) -> Vec<SymbolDecl> {
        let lists = [
            (&file.states, SymbolKind::State),
            (&file.params, SymbolKind::Param),
            (&file.inputs, SymbolKind::Input),
            (&file.known, SymbolKind::Known),
        ];
        let mut symbols = Vec::new();
        for (list, kind) in lists {
            for symbol in list {
                let allow_unused = symbol.allow_unused.as_ref();
                if let (Some(key), SymbolKind::State) = (allow_unused, kind) {
                    self.diag.error(
                        self.places.of_field(key),
                        "`allow_unused` applies to a `[[param]]`, `[[input]]` or `[[known]]`",
                    );
                }
                symbols.push(SymbolDecl {
                    docs: docs(&symbol.doc),
                    name: self.name(&symbol.name),
                    kind,
                    ty: symbol.ty.as_ref().map(|ty| self.name(ty)),
                    allow_unused: allow_unused.is_some_and(|a| *a.get_ref()),
                });
            }
        }
        symbols
    }

    fn outputs(&mut self, outputs: &[Entry]) -> Vec<OutputDecl> {
        outputs
            .iter()
            .map(|o| OutputDecl {
                docs: docs(&o.doc),
                name: self.name(&o.name),
                expr: self.expr(&o.value, &format!("output `{}`", o.name.get_ref())),
            })
            .collect()
    }

    fn sensors(&mut self, sensors: &[Sensor]) -> Vec<SensorDecl> {
        let mut decls = Vec::new();
        for s in sensors {
            let gate = s.gate.as_ref().and_then(|g| self.sensor_gate(g));
            let delay = s.delay.as_ref().and_then(|d| self.sensor_delay(d));
            decls.push(SensorDecl {
                docs: docs(&s.doc),
                name: self.name(&s.name),
                options: gate.into_iter().chain(delay).collect(),
                outputs: s.outputs.iter().map(|o| self.name(o)).collect(),
            });
        }
        decls
    }

    /// A sensor's `gate`, as the macro's option `gate = ..` (checked with it): a number,
    /// or a name (`"off"`); anything else is an error here.
    fn sensor_gate(&mut self, gate: &Spanned<OptionValue>) -> Option<GenerateArg> {
        let here = self.places.inside(self.source, gate);
        let value = match gate.get_ref() {
            OptionValue::Number(v) => ArgValue::Number(*v, here),
            OptionValue::Text(text) => ArgValue::Name(Name {
                text: text.clone(),
                span: here,
            }),
            other => {
                self.diag.error(
                    here,
                    format!(
                        "sensor.gate: {} is not a gate, which is a positive number (a \
                         chi-square quantile, `gate = 16.27`) or `\"off\"`",
                        other.describe()
                    ),
                );
                return None;
            }
        };
        Some(GenerateArg {
            name: Name {
                text: "gate".to_owned(),
                span: here,
            },
            value,
        })
    }

    /// A sensor's `delay`, as the macro's option `delay = ..` (checked with it): a number;
    /// anything else is an error here.
    fn sensor_delay(&mut self, delay: &Spanned<OptionValue>) -> Option<GenerateArg> {
        let here = self.places.inside(self.source, delay);
        let OptionValue::Number(v) = delay.get_ref() else {
            self.diag.error(
                here,
                format!(
                    "sensor.delay: {} is not a delay, which is how many samples late the \
                     sensor's measurements arrive (`delay = 38`)",
                    delay.get_ref().describe()
                ),
            );
            return None;
        };
        Some(GenerateArg {
            name: Name {
                text: "delay".to_owned(),
                span: here,
            },
            value: ArgValue::Number(*v, here),
        })
    }

    /// `[dynamics]`: its kind, its `[[dynamics.let]]` intermediates in order, then one
    /// equation per state, in the file's order.
    fn dynamics(&mut self, d: &Dynamics) -> DynamicsDecl {
        let kind = self.dynamics_kind(d);
        let derivative = matches!(kind, DynamicsKind::Continuous { .. });
        let mut statements: Vec<Statement> = Vec::new();
        for l in &d.lets {
            statements.push(Statement::Let {
                name: self.name(&l.name),
                value: self.expr(&l.value, &format!("dynamics.let `{}`", l.name.get_ref())),
            });
        }
        for (state, value) in d.equations.iter() {
            statements.push(Statement::Equation {
                target: self.name(state),
                derivative,
                value: self.expr(value, &format!("dynamics.equations.{}", state.get_ref())),
            });
        }
        DynamicsDecl {
            span: self.places.of_field(&d.kind),
            kind,
            statements,
        }
    }

    /// `kind = "discrete"`, or `kind = "continuous"` with its method, step and sub-steps.
    fn dynamics_kind(&mut self, d: &Dynamics) -> DynamicsKind {
        match d.kind.get_ref().as_str() {
            "discrete" => DynamicsKind::Discrete,
            "continuous" => DynamicsKind::Continuous {
                method: d.method.as_ref().map(|m| self.name(m)),
                dt: d.dt.as_ref().map(|v| self.expr(v, "dynamics.dt")),
                substeps: d
                    .substeps
                    .as_ref()
                    .map(|n| (n.get_ref().0, self.places.of_field(n))),
            },
            other => {
                self.diag.error(
                    self.places.of_field(&d.kind),
                    format!("dynamics.kind: `{other}` is neither `discrete` nor `continuous`"),
                );
                DynamicsKind::Discrete
            }
        }
    }
}

/// The `[generate]` table as `generate` items. A generator's value is `true`, a table of
/// options, or a list of tables for several of its kind (`ekf = [{ .. }, { name =
/// "GatedEkf", .. }]`). An item is named where its key is written, an option placed where
/// its value is.
fn generate_items(
    table: Option<&InFileOrder<Spanned<Generator>>>,
    source: &str,
    places: &Places,
    diag: &mut Diagnostics,
) -> Vec<GenerateDecl> {
    let mut items = Vec::new();
    for (key, value) in table.into_iter().flat_map(InFileOrder::iter) {
        let generator = key.get_ref();
        let name = Name {
            text: generator.clone(),
            span: places.of_field(key),
        };
        let entries: Vec<&Spanned<Generator>> = match value.get_ref() {
            Generator::Several(list) => list.iter().collect(),
            _ => vec![value],
        };
        for entry in entries {
            let what = match entry.get_ref() {
                Generator::Switch(true) => {
                    items.push(GenerateDecl {
                        name: name.clone(),
                        args: Vec::new(),
                    });
                    continue;
                }
                Generator::Switch(false) => continue,
                Generator::Options(options) => {
                    items.push(GenerateDecl {
                        name: name.clone(),
                        args: generate_args(generator, options, source, places, diag),
                    });
                    continue;
                }
                Generator::Several(_) => "a list".to_owned(),
                Generator::Other(what) => what.clone(),
            };
            diag.error(
                places.inside(source, entry),
                format!(
                    "generate.{generator}: {what} does not ask for a generator: write \
                     `{generator} = true`, a table of its options (`{generator} = {{ .. }}` or \
                     a `[generate.{generator}]` table), or a list of tables for several \
                     (`{generator} = [{{ .. }}, {{ .. }}]`)"
                ),
            );
        }
    }
    items
}

/// One generator's options: numbers, names (strings) and lists of names. A value the model
/// language has no reading of is an error under it that says what the option takes.
fn generate_args(
    generator: &str,
    options: &InFileOrder<Spanned<OptionValue>>,
    source: &str,
    places: &Places,
    diag: &mut Diagnostics,
) -> Vec<GenerateArg> {
    let mut args = Vec::new();
    'options: for (option, value) in options.iter() {
        let option_name = option.get_ref();
        let takes = toml_hints::option_takes(generator, option_name);
        let here = places.inside(source, value);
        let value = match value.get_ref() {
            OptionValue::Number(v) => ArgValue::Number(*v, here),
            OptionValue::Text(text) => ArgValue::Name(Name {
                text: text.clone(),
                span: here,
            }),
            OptionValue::List(list)
                if list
                    .iter()
                    .all(|i| matches!(i.get_ref(), OptionValue::Number(_)))
                    && !list.is_empty() =>
            {
                // A list of numbers: the option's reader says what it takes instead.
                let numbers = list
                    .iter()
                    .filter_map(|i| match i.get_ref() {
                        OptionValue::Number(v) => Some(*v),
                        _ => None,
                    })
                    .collect();
                ArgValue::Numbers(numbers, here)
            }
            OptionValue::List(list) => {
                let mut names = Vec::new();
                for item in list {
                    match item.get_ref() {
                        OptionValue::Text(text) => names.push(Name {
                            text: text.clone(),
                            span: places.inside(source, item),
                        }),
                        other => {
                            diag.error(
                                places.inside(source, item),
                                format!(
                                    "generate.{generator}.{option_name}: {} is not a name: a \
                                     list holds names as strings, and `{option_name}` takes \
                                     {takes}",
                                    other.describe()
                                ),
                            );
                            continue 'options;
                        }
                    }
                }
                ArgValue::Names(names, here)
            }
            OptionValue::Table(entries) if TABLE_OPTIONS.contains(&option_name.as_str()) => {
                let Some(table) = numbers_by_name(entries, source, places) else {
                    diag.error(
                        here,
                        format!(
                            "generate.{generator}.{option_name}: a table of numbers, one per \
                             call: `{option_name}` takes {takes}"
                        ),
                    );
                    continue;
                };
                ArgValue::Table(table, here)
            }
            other @ (OptionValue::Other(_) | OptionValue::Table(_)) => {
                diag.error(
                    here,
                    format!(
                        "generate.{generator}.{option_name}: {} is not a value of \
                         `{option_name}`, which takes {takes}",
                        other.describe()
                    ),
                );
                continue;
            }
        };
        args.push(GenerateArg {
            name: Name {
                text: option_name.clone(),
                span: places.of_field(option),
            },
            value,
        });
    }
    args
}

/// A table of numbers by name (`{ predict = 250, update_gnss = 5 }`) as the macro's
/// `[predict = 250, update_gnss = 5]`, each key and number placed; `None` if a value is no
/// number.
fn numbers_by_name(
    entries: &InFileOrder<Spanned<OptionValue>>,
    source: &str,
    places: &Places,
) -> Option<Vec<(Name, f64, Span)>> {
    entries
        .iter()
        .map(|(key, value)| match value.get_ref() {
            OptionValue::Number(v) => Some((
                Name {
                    text: key.get_ref().clone(),
                    span: places.of_field(key),
                },
                *v,
                places.inside(source, value),
            )),
            _ => None,
        })
        .collect()
}

/// The `toml` crate's `message` about the file from `at` on, with what to write.
fn with_fix(message: &str, at: &str) -> String {
    let message = message.trim_end();
    if let Some(field) = message
        .strip_prefix("missing field `")
        .and_then(|rest| rest.strip_suffix('`'))
    {
        let fix = match field {
            "name" => "add `name = \"...\"`",
            "scalar" => "add `scalar = \"f32\"` (or `scalar = [\"f32\", \"f64\"]`)",
            "kind" => {
                "add `kind = \"discrete\"`, or `kind = \"continuous\"` with `method = \"rk4\"` \
                 and `dt = \"TS\"`"
            }
            "equations" => "add a `[dynamics.equations]` table with one `x1 = \"...\"` per state",
            "value" => "add `value = ...`: a number, or an expression in a string",
            _ => return message.to_owned(),
        };
        return format!("{message}: {fix}");
    }
    if message.starts_with("string values must be quoted") {
        let written = at.lines().next().unwrap_or("");
        let written = written.split('#').next().unwrap_or("").trim();
        if !written.is_empty() {
            return format!("string values must be quoted: write `{written:?}`");
        }
    }
    if message == "duplicate key" {
        let key: String = at
            .chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_' || *c == '-')
            .collect();
        return format!("duplicate key `{key}`: a table gives each key once; remove or rename one");
    }
    if message == "floating-point number overflowed" {
        let written: String = at
            .chars()
            .take_while(|c| c.is_ascii_alphanumeric() || matches!(c, '.' | '+' | '-' | '_'))
            .collect();
        return format!(
            "`{written}` is beyond the largest number a model can hold (about 1.8e308 in f64, \
             3.4e38 in f32): every number must be finite; rescale the model's units"
        );
    }
    if message.ends_with("expected a string") {
        return format!("{message}: write it in quotes, `\"...\"`");
    }
    message.to_owned()
}
