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
//! `sin cos tan exp ln sqrt abs`, and the piecewise functions `if_gt(a, b, then, else)`,
//! `if_ge`, `if_lt`, `if_le` for `if a > b { then } else { else }` and so on.
//! `[[dynamics.let]]` entries (`name`, `value`) define intermediates, in order.

use crate::ast::{
    ArgValue, BinaryOp, Comparison, ConstDecl, DynamicsDecl, DynamicsKind, GenerateArg,
    GenerateDecl, ModelDecl, Name, OutputDecl, Statement, SurfaceExpr, SurfaceKind, SymbolDecl,
    SymbolKind,
};
use crate::diagnostics::Diagnostics;
use indexmap::IndexMap;
use meval::tokenizer::{Operation, Token};
use proc_macro2::{Span, TokenStream};
use serde::Deserialize;
use std::str::FromStr;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ModelFile {
    name: String,
    #[serde(default)]
    doc: String,
    #[serde(default = "public")]
    visibility: String,
    scalar: OneOrMany,
    #[serde(default, rename = "const")]
    constants: Vec<Entry>,
    #[serde(default, rename = "state")]
    states: Vec<Symbol>,
    #[serde(default, rename = "param")]
    params: Vec<Symbol>,
    #[serde(default, rename = "input")]
    inputs: Vec<Symbol>,
    #[serde(default, rename = "output")]
    outputs: Vec<Entry>,
    dynamics: Option<Dynamics>,
    /// `ekf = true`, `dkf = { eta = 0.5 }`, `lqr = { horizon = 50, states = ["x1"], input = "u" }`.
    generate: Option<toml::Table>,
}

fn public() -> String {
    "pub".into()
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
    name: String,
    #[serde(default)]
    doc: String,
}

/// A named expression: a constant, output or intermediate.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Entry {
    name: String,
    value: Value,
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
    kind: String,
    method: Option<String>,
    dt: Option<Value>,
    substeps: Option<u64>,
    #[serde(default, rename = "let")]
    lets: Vec<Entry>,
    equations: IndexMap<String, Value>,
}

/// Reads a TOML model file into a [`ModelDecl`]. A file TOML cannot read is an error at
/// once; expression mistakes are collected, each naming its field.
pub fn parse_model_file(source: &str) -> syn::Result<(ModelDecl, Diagnostics)> {
    let file: ModelFile = toml::from_str(source)
        .map_err(|e| syn::Error::new(Span::call_site(), format!("model file: {e}")))?;
    let mut diag = Diagnostics::default();
    let here = Span::call_site();
    let name = |text: &str| Name {
        text: text.to_owned(),
        span: here,
    };
    let docs = |doc: &str| -> Vec<String> {
        doc.lines()
            .filter(|_| !doc.is_empty())
            .map(|l| format!(" {l}"))
            .collect()
    };
    let expr = |value: &Value, field: &str, diag: &mut Diagnostics| match value {
        Value::Number(v) => SurfaceExpr {
            kind: SurfaceKind::Number(*v),
            span: here,
        },
        Value::Text(text) => parse_expression(text, field, diag),
    };

    let vis = TokenStream::from_str(&file.visibility).unwrap_or_else(|_| {
        diag.error(
            here,
            format!("visibility: `{}` is not a Rust visibility", file.visibility),
        );
        TokenStream::new()
    });
    let scalars = match &file.scalar {
        OneOrMany::One(s) => vec![name(s)],
        OneOrMany::Many(list) => list.iter().map(|s| name(s)).collect(),
    };
    let constants = file
        .constants
        .iter()
        .map(|c| ConstDecl {
            docs: docs(&c.doc),
            name: name(&c.name),
            value: expr(&c.value, &format!("const `{}`", c.name), &mut diag),
        })
        .collect();
    let symbols = [
        (&file.states, SymbolKind::State),
        (&file.params, SymbolKind::Param),
        (&file.inputs, SymbolKind::Input),
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
            expr: expr(&o.value, &format!("output `{}`", o.name), &mut diag),
        })
        .collect();
    let dynamics = file
        .dynamics
        .iter()
        .map(|d| {
            let kind = match d.kind.as_str() {
                "discrete" => DynamicsKind::Discrete,
                "continuous" => DynamicsKind::Continuous {
                    method: d.method.as_deref().map(name),
                    dt: d.dt.as_ref().map(|v| expr(v, "dynamics.dt", &mut diag)),
                    substeps: d.substeps.map(|n| (n, here)),
                },
                other => {
                    diag.error(
                        here,
                        format!("dynamics.kind: `{other}` is neither `discrete` nor `continuous`"),
                    );
                    DynamicsKind::Discrete
                }
            };
            let derivative = matches!(kind, DynamicsKind::Continuous { .. });
            let lets = d.lets.iter().map(|l| Statement::Let {
                name: name(&l.name),
                value: expr(&l.value, &format!("dynamics.let `{}`", l.name), &mut diag),
            });
            let mut statements: Vec<Statement> = lets.collect();
            statements.extend(
                d.equations
                    .iter()
                    .map(|(state, value)| Statement::Equation {
                        target: name(state),
                        derivative,
                        value: expr(value, &format!("dynamics.equations.{state}"), &mut diag),
                    }),
            );
            DynamicsDecl {
                span: here,
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
        span: here,
        constants,
        symbols,
        outputs,
        dynamics,
        generate: generate_items(file.generate.as_ref(), &mut diag),
    };
    Ok((decl, diag))
}

/// Parses one `meval` expression into a surface expression.
fn parse_expression(text: &str, field: &str, diag: &mut Diagnostics) -> SurfaceExpr {
    let here = Span::call_site();
    let zero = SurfaceExpr {
        kind: SurfaceKind::Number(0.0),
        span: here,
    };
    if let Err(message) = super::limits::check_expression_text(text) {
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
                piecewise(f, &args).unwrap_or_else(|| {
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
fn piecewise(function: &str, args: &[SurfaceExpr]) -> Option<SurfaceExpr> {
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
        span: Span::call_site(),
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

/// The `[generate]` table as `generate` items.
fn generate_items(table: Option<&toml::Table>, diag: &mut Diagnostics) -> Vec<GenerateDecl> {
    let here = Span::call_site();
    let name = |text: &str| Name {
        text: text.to_owned(),
        span: here,
    };
    let mut items = Vec::new();
    for (generator, value) in table.into_iter().flatten() {
        let args = match value {
            toml::Value::Boolean(true) => Vec::new(),
            toml::Value::Boolean(false) => continue,
            toml::Value::Table(args) => args
                .iter()
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
                .collect(),
            _ => {
                diag.error(
                    here,
                    format!("generate.{generator}: write `true` or a table of arguments"),
                );
                continue;
            }
        };
        items.push(GenerateDecl {
            name: name(generator),
            args,
        });
    }
    items
}
