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
//! `[[known]]` entries (`name`, `doc`) declare constants known only at run time.
//! `[[dynamics.let]]` entries (`name`, `value`) define intermediates, in order.

use meval::tokenizer::{Operation, Token};
use proc_macro2::{Span, TokenStream};
use serde::de::{Deserializer, MapAccess, Visitor};
use serde::Deserialize;
use stateforge_compiler::ast::{
    ArgValue, BinaryOp, Comparison, ConstDecl, DynamicsDecl, DynamicsKind, GenerateArg,
    GenerateDecl, ModelDecl, Name, OutputDecl, Statement, SurfaceExpr, SurfaceKind, SymbolDecl,
    SymbolKind,
};
use stateforge_compiler::diagnostics::Diagnostics;
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
    constants: Vec<Entry>,
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
    dynamics: Option<Dynamics>,
    /// `ekf = true`, `dkf = { eta = 0.5 }`, `lqr = { horizon = 50, states = ["x1"], input = "u" }`.
    generate: Option<InFileOrder<Spanned<toml::Value>>>,
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

#[derive(Deserialize)]
#[serde(untagged)]
enum OneOrMany {
    One(String),
    Many(Vec<String>),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Symbol {
    name: Spanned<String>,
    #[serde(default)]
    doc: String,
}

/// A named expression: a constant, output or intermediate.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Entry {
    name: Spanned<String>,
    value: Spanned<Value>,
    #[serde(default)]
    doc: String,
}

#[derive(Deserialize)]
#[serde(untagged)]
enum Value {
    Number(f64),
    Text(String),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Dynamics {
    kind: Spanned<String>,
    method: Option<Spanned<String>>,
    dt: Option<Spanned<Value>>,
    substeps: Option<Spanned<u64>>,
    #[serde(default, rename = "let")]
    lets: Vec<Entry>,
    equations: InFileOrder<Spanned<Value>>,
}

/// A TOML table's entries in the order of the file, so generated code follows the file.
/// (`indexmap`'s serde support would do it, but would build `indexmap` differently from the
/// `model!` macro's, and the compiler with it, twice in a workspace holding both.)
struct InFileOrder<V>(Vec<(String, V)>);

impl<V> InFileOrder<V> {
    fn iter(&self) -> impl Iterator<Item = (&String, &V)> {
        self.0.iter().map(|(key, value)| (key, value))
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
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Self::Value, A::Error> {
                let mut entries = Vec::new();
                while let Some(entry) = map.next_entry()? {
                    entries.push(entry);
                }
                Ok(InFileOrder(entries))
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
}

/// Reads a TOML model file into a [`ModelDecl`]. A file TOML cannot read is an error at
/// once; expression mistakes are collected, each naming its field. Every error points at
/// the field's line and column.
pub fn parse_model_file(source: &str) -> syn::Result<(ModelDecl, Diagnostics)> {
    let places = Places::of(source);
    let file: ModelFile = toml::from_str(source).map_err(|e| {
        let span = e
            .span()
            .map_or_else(Span::call_site, |r| places.at(r.start));
        syn::Error::new(span, format!("model file: {}", e.message()))
    })?;
    let mut diag = Diagnostics::default();
    let top = places.at(0);
    let name = |field: &Spanned<String>| Name {
        text: field.get_ref().clone(),
        span: places.of_field(field),
    };
    let docs = |doc: &str| -> Vec<String> {
        doc.lines()
            .filter(|_| !doc.is_empty())
            .map(|l| format!(" {l}"))
            .collect()
    };
    let expr = |value: &Spanned<Value>, field: &str, diag: &mut Diagnostics| {
        let span = places.of_field(value);
        match value.get_ref() {
            Value::Number(v) => SurfaceExpr {
                kind: SurfaceKind::Number(*v),
                span,
            },
            Value::Text(text) => parse_expression(text, field, span, diag),
        }
    };

    let vis = file.visibility.tokens();
    let scalar_span = places.of_field(&file.scalar);
    let scalar_name = |text: &String| Name {
        text: text.clone(),
        span: scalar_span,
    };
    let scalars = match file.scalar.get_ref() {
        OneOrMany::One(s) => vec![scalar_name(s)],
        OneOrMany::Many(list) => list.iter().map(scalar_name).collect(),
    };
    let constants = file
        .constants
        .iter()
        .map(|c| ConstDecl {
            docs: docs(&c.doc),
            name: name(&c.name),
            value: expr(
                &c.value,
                &format!("const `{}`", c.name.get_ref()),
                &mut diag,
            ),
        })
        .collect();
    let symbols = [
        (&file.states, SymbolKind::State),
        (&file.params, SymbolKind::Param),
        (&file.inputs, SymbolKind::Input),
        (&file.known, SymbolKind::Known),
    ]
    .into_iter()
    .flat_map(|(list, kind)| {
        list.iter().map(move |s| SymbolDecl {
            docs: docs(&s.doc),
            name: name(&s.name),
            kind,
        })
    })
    .collect();
    let outputs = file
        .outputs
        .iter()
        .map(|o| OutputDecl {
            docs: docs(&o.doc),
            name: name(&o.name),
            expr: expr(
                &o.value,
                &format!("output `{}`", o.name.get_ref()),
                &mut diag,
            ),
        })
        .collect();
    let dynamics = file
        .dynamics
        .iter()
        .map(|d| {
            let kind_span = places.of_field(&d.kind);
            let kind = match d.kind.get_ref().as_str() {
                "discrete" => DynamicsKind::Discrete,
                "continuous" => DynamicsKind::Continuous {
                    method: d.method.as_ref().map(name),
                    dt: d.dt.as_ref().map(|v| expr(v, "dynamics.dt", &mut diag)),
                    substeps: d
                        .substeps
                        .as_ref()
                        .map(|n| (*n.get_ref(), places.of_field(n))),
                },
                other => {
                    diag.error(
                        kind_span,
                        format!("dynamics.kind: `{other}` is neither `discrete` nor `continuous`"),
                    );
                    DynamicsKind::Discrete
                }
            };
            let derivative = matches!(kind, DynamicsKind::Continuous { .. });
            let lets = d.lets.iter().map(|l| Statement::Let {
                name: name(&l.name),
                value: expr(
                    &l.value,
                    &format!("dynamics.let `{}`", l.name.get_ref()),
                    &mut diag,
                ),
            });
            let mut statements: Vec<Statement> = lets.collect();
            statements.extend(d.equations.iter().map(|(state, value)| {
                Statement::Equation {
                    // The state's name is a key: its place is taken to be the value's.
                    target: Name {
                        text: state.clone(),
                        span: places.of_field(value),
                    },
                    derivative,
                    value: expr(value, &format!("dynamics.equations.{state}"), &mut diag),
                }
            }));
            DynamicsDecl {
                span: kind_span,
                kind,
                statements,
            }
        })
        .collect();
    let decl = ModelDecl {
        docs: docs(&file.doc),
        vis,
        name: name(&file.name),
        scalars,
        span: top,
        constants,
        symbols,
        outputs,
        dynamics,
        generate: generate_items(file.generate.as_ref(), &places, &mut diag),
    };
    Ok((decl, diag))
}

/// Parses one `meval` expression into a surface expression.
fn parse_expression(text: &str, field: &str, here: Span, diag: &mut Diagnostics) -> SurfaceExpr {
    let zero = SurfaceExpr {
        kind: SurfaceKind::Number(0.0),
        span: here,
    };
    if let Err(message) = stateforge_compiler::front::limits::check_expression_text(text) {
        diag.error(here, format!("{field}: {message}"));
        return zero;
    }
    let parsed = match meval::Expr::from_str(text) {
        Ok(parsed) => parsed,
        Err(e) => {
            diag.error(here, format!("{field}: cannot parse `{text}`: {e}"));
            return zero;
        }
    };
    let node = |kind| SurfaceExpr { kind, span: here };
    // `meval` gives reverse Polish notation: operands come before their operator.
    let mut stack: Vec<SurfaceExpr> = Vec::new();
    for token in parsed.iter() {
        let made = match token {
            Token::Number(v) if !v.is_finite() => {
                diag.error(
                    here,
                    format!("{field}: `{text}` holds {v}: every number must be finite"),
                );
                return zero;
            }
            Token::Number(v) => node(SurfaceKind::Number(*v)),
            Token::Var(v) if v == "pi" => node(SurfaceKind::Number(std::f64::consts::PI)),
            Token::Var(v) => node(SurfaceKind::Name(v.clone())),
            Token::Unary(Operation::Minus) => match stack.pop() {
                Some(a) => node(SurfaceKind::Neg(Box::new(a))),
                None => break,
            },
            Token::Unary(Operation::Plus) => continue,
            Token::Binary(op) => {
                let (Some(b), Some(a)) = (stack.pop(), stack.pop()) else {
                    break;
                };
                match op {
                    Operation::Plus => {
                        node(SurfaceKind::Binary(BinaryOp::Add, Box::new(a), Box::new(b)))
                    }
                    Operation::Minus => {
                        node(SurfaceKind::Binary(BinaryOp::Sub, Box::new(a), Box::new(b)))
                    }
                    Operation::Times => {
                        node(SurfaceKind::Binary(BinaryOp::Mul, Box::new(a), Box::new(b)))
                    }
                    Operation::Div => {
                        node(SurfaceKind::Binary(BinaryOp::Div, Box::new(a), Box::new(b)))
                    }
                    Operation::Pow => node(SurfaceKind::Call(
                        Name {
                            text: "powi".into(),
                            span: here,
                        },
                        vec![a, b],
                    )),
                    _ => {
                        diag.error(here, format!("{field}: `%` is not supported in `{text}`"));
                        return zero;
                    }
                }
            }
            Token::Func(f, arity) => {
                let n = arity.unwrap_or(0);
                if stack.len() < n {
                    break;
                }
                let args = stack.split_off(stack.len() - n);
                piecewise(f, &args, here).unwrap_or_else(|| {
                    node(SurfaceKind::Call(
                        Name {
                            text: f.clone(),
                            span: here,
                        },
                        args,
                    ))
                })
            }
            _ => break,
        };
        stack.push(made);
    }
    match (stack.pop(), stack.is_empty()) {
        (Some(e), true) => e,
        _ => {
            diag.error(
                here,
                format!("{field}: cannot read `{text}` as one expression"),
            );
            zero
        }
    }
}

/// `if_gt(a, b, then, else)` and its siblings as a piecewise term.
fn piecewise(function: &str, args: &[SurfaceExpr], here: Span) -> Option<SurfaceExpr> {
    let cmp = comparison_of(function)?;
    let [lhs, rhs, then, otherwise] = args else {
        return None;
    };
    Some(SurfaceExpr {
        kind: SurfaceKind::If {
            cmp,
            lhs: Box::new(lhs.clone()),
            rhs: Box::new(rhs.clone()),
            then: Box::new(then.clone()),
            otherwise: Box::new(otherwise.clone()),
        },
        span: here,
    })
}

/// The comparison a piecewise function of the model-file language stands for.
pub fn comparison_of(function: &str) -> Option<Comparison> {
    Some(match function {
        "if_gt" => Comparison::Gt,
        "if_ge" => Comparison::Ge,
        "if_lt" => Comparison::Lt,
        "if_le" => Comparison::Le,
        _ => return None,
    })
}

/// The `[generate]` table as `generate` items; everything of one item points at its value.
/// A generator's value is `true`, a table of arguments, or a list of tables for several
/// of its kind (`ekf = [{ .. }, { name = "GatedEkf", .. }]`).
fn generate_items(
    table: Option<&InFileOrder<Spanned<toml::Value>>>,
    places: &Places,
    diag: &mut Diagnostics,
) -> Vec<GenerateDecl> {
    let mut items = Vec::new();
    for (generator, value) in table.into_iter().flat_map(InFileOrder::iter) {
        let here = places.of_field(value);
        let item = |args| GenerateDecl {
            name: Name {
                text: generator.clone(),
                span: here,
            },
            args,
        };
        match value.get_ref() {
            toml::Value::Boolean(true) => items.push(item(Vec::new())),
            toml::Value::Boolean(false) => {}
            toml::Value::Table(args) => {
                items.push(item(generate_args(generator, args, here, diag)))
            }
            toml::Value::Array(list) if list.iter().all(toml::Value::is_table) => {
                for args in list.iter().filter_map(toml::Value::as_table) {
                    items.push(item(generate_args(generator, args, here, diag)));
                }
            }
            _ => diag.error(
                here,
                format!(
                    "generate.{generator}: write `true`, a table of arguments, or a list of \
                     tables for several"
                ),
            ),
        }
    }
    items
}

/// One generator's arguments: numbers, names (strings) and lists of names.
fn generate_args(
    generator: &str,
    args: &toml::Table,
    here: Span,
    diag: &mut Diagnostics,
) -> Vec<GenerateArg> {
    let name = |text: &str| Name {
        text: text.to_owned(),
        span: here,
    };
    args.iter()
        .filter_map(|(arg, v)| {
            let value = match v {
                toml::Value::Integer(i) => ArgValue::Number(*i as f64, here),
                toml::Value::Float(f) => ArgValue::Number(*f, here),
                toml::Value::String(s) => ArgValue::Name(name(s)),
                toml::Value::Array(list) => ArgValue::Names(
                    list.iter().filter_map(|n| n.as_str().map(name)).collect(),
                    here,
                ),
                _ => {
                    diag.error(
                        here,
                        format!("generate.{generator}.{arg}: unsupported value"),
                    );
                    return None;
                }
            };
            Some(GenerateArg {
                name: name(arg),
                value,
            })
        })
        .collect()
}
