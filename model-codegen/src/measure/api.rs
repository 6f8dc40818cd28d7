//! What the measuring firmware can call, read from the generated module's `f32` code: the
//! types that have a constructor and their calls, the model functions `f` and `h`, and the
//! static estimates (`*_CYCLES`). The generated API's conventions (the language
//! reference's "The generated API") make this a reading of signatures: every array is
//! passed by reference, every constructor is `new(..) -> Result<Self, Status>`.

use crate::generated_api::{self, inline_items, Receiver, Signature};
use std::collections::BTreeMap;
use syn::Item;

/// The shape of an argument or a result, in `f32`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Shape {
    /// `f32`.
    Scalar,
    /// `&[f32; n]` (or `[f32; n]`, a result).
    Vector(usize),
    /// `&[[f32; cols]; rows]`.
    Matrix(usize, usize),
    /// `Option<&[f32; n]>`.
    OptionalVector(usize),
    /// Anything else, written as the code writes it.
    Other(String),
}

/// How to tell whether a call's result says it took its data.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// A `Status`: `Status::Ok`.
    Status,
    /// A struct with `is_ok(&self) -> bool` (`DkfStatus`).
    IsOk,
    /// A struct with a `status: Status` field (`MpcStatus`).
    StatusField,
    /// Nothing to tell (the call always takes its data).
    Always,
}

/// One argument of a function.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Arg {
    /// Its name, without the leading `_` of an argument the code does not read.
    pub name: String,
    /// Its type, as the code writes it (`&[f32; 5]`).
    pub ty: String,
    /// Its shape.
    pub shape: Shape,
}

/// A function or method: its name, arguments (without `self`) and result.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Function {
    /// Its name.
    pub name: String,
    /// Its arguments, `self` excluded.
    pub args: Vec<Arg>,
    /// Its result's type, as the code writes it, with the module's own types named
    /// through `model::` (`model::Status`); `None` for `()`.
    pub output: Option<String>,
    /// Its result's shape.
    pub output_shape: Option<Shape>,
    /// How to tell whether the call took its data.
    pub outcome: Outcome,
}

/// A type the firmware can build, with the calls it measures.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Type {
    /// Its name (`Ekf`).
    pub name: String,
    /// Its constructor, `new`, and whether it returns a `Result`.
    pub new: Function,
    /// Whether `new` returns `Result<Self, _>` rather than `Self`.
    pub new_is_fallible: bool,
    /// Its calls, in the order the code declares them: the methods that take `&mut self`,
    /// except `reset` and the setters (`set_*`), which configure it.
    pub calls: Vec<Function>,
}

/// What the measuring firmware can call.
#[derive(Clone, Debug)]
pub struct Api {
    /// The module of the `f32` items, from the file's root (`cantilever`, or
    /// `cantilever::in_f32` when `f32` is the model's second scalar type).
    pub module: String,
    /// The types with a constructor and at least one call.
    pub types: Vec<Type>,
    /// The model's one sample of the dynamics, `f`.
    pub f: Option<Function>,
    /// The model's measurement, `h`.
    pub h: Option<Function>,
    /// The static estimates: `*_CYCLES` constant -> cycles.
    pub cycles: BTreeMap<String, u32>,
}

impl Api {
    /// The static estimate of `Type::call` and its constant: `TYPE_CALL_CYCLES` (`Ekf::
    /// update_gnss`: `EKF_UPDATE_GNSS_CYCLES`), else `TYPE_CALL_WORST_CYCLES`, the estimate
    /// of its costliest call (the MPC's solve).
    pub fn static_estimate(&self, type_name: &str, call: &str) -> Option<(String, u32)> {
        let base = format!(
            "{}_{}",
            generated_api::snake(type_name).to_ascii_uppercase(),
            call.to_ascii_uppercase()
        );
        [format!("{base}_CYCLES"), format!("{base}_WORST_CYCLES")]
            .into_iter()
            .find_map(|name| Some((name.clone(), *self.cycles.get(&name)?)))
    }
}

/// The API of `code`, a generated file (`pub mod <name> { .. }`).
pub fn read(code: &str) -> Result<Api, String> {
    let file = generated_api::parse(code)?;
    let top = generated_api::model_module(&file)?;
    let name = top.ident.to_string();
    let top_items = inline_items(top);
    let (module, items) = match generated_api::modules(top_items).find(|m| m.ident == "in_f32") {
        Some(inner) => (format!("{name}::in_f32"), inline_items(inner)),
        None => (name, top_items),
    };
    let outcomes = outcomes(items);
    let free = |wanted: &str| {
        items.iter().find_map(|item| match item {
            Item::Fn(f) if f.sig.ident == wanted => Some(function(
                &generated_api::signature(&f.sig, &f.attrs),
                &outcomes,
            )),
            _ => None,
        })
    };
    let (f, h) = (free("f"), free("h"));
    let types = types(items, &outcomes);
    if types.is_empty() {
        return Err(
            "the model generates no filter or controller: nothing to measure (add a \
                    `generate` item)"
                .into(),
        );
    }
    let uses_f32 = types
        .iter()
        .flat_map(|t| t.calls.iter().chain([&t.new]))
        .flat_map(|c| &c.args)
        .any(|a| a.ty.contains("f32"));
    if !uses_f32 {
        return Err(
            "the Cortex-M4F runs the model's f32 code: add `f32` to its scalar types \
                    (`scalar = [\"f32\"]`, `scalar f32;`)"
                .into(),
        );
    }
    // The static estimates are in the model's module, whichever module holds the f32 code.
    let mut cycles = BTreeMap::new();
    for scope in [items, top_items] {
        cycles.extend(cycle_constants(scope));
    }
    Ok(Api {
        module,
        types,
        f,
        h,
        cycles,
    })
}

/// `pub const NAME_CYCLES: u32 = n;` items.
fn cycle_constants(items: &[Item]) -> Vec<(String, u32)> {
    items
        .iter()
        .filter_map(|item| {
            let Item::Const(c) = item else { return None };
            let name = c.ident.to_string();
            if !name.ends_with("_CYCLES") {
                return None;
            }
            let syn::Expr::Lit(syn::ExprLit {
                lit: syn::Lit::Int(value),
                ..
            }) = &*c.expr
            else {
                return None;
            };
            Some((name, value.base10_parse().ok()?))
        })
        .collect()
}

/// How each struct of the module tells whether it took its data.
fn outcomes(items: &[Item]) -> BTreeMap<String, Outcome> {
    let mut outcomes = BTreeMap::new();
    for item in items {
        match item {
            Item::Enum(e) if e.ident == "Status" => {
                outcomes.insert("Status".to_owned(), Outcome::Status);
            }
            Item::Struct(s) => {
                let has_status = s.fields.iter().any(|f| {
                    f.ident.as_ref().is_some_and(|i| i == "status")
                        && generated_api::type_text(&f.ty) == "Status"
                });
                if has_status {
                    outcomes.insert(s.ident.to_string(), Outcome::StatusField);
                }
            }
            Item::Impl(block) => {
                let Some(block) = generated_api::inherent_impl(block) else {
                    continue;
                };
                let has_is_ok = block.methods.iter().any(|m| {
                    m.name == "is_ok" && m.receiver == Receiver::Shared && m.params.is_empty()
                });
                if has_is_ok {
                    outcomes.insert(block.name, Outcome::IsOk);
                }
            }
            _ => {}
        }
    }
    outcomes
}

/// The types with a constructor and calls, in the order the code declares them.
fn types(items: &[Item], outcomes: &BTreeMap<String, Outcome>) -> Vec<Type> {
    let mut types = Vec::new();
    for item in items {
        let Item::Impl(block) = item else { continue };
        let Some(block) = generated_api::inherent_impl(block) else {
            continue;
        };
        let (mut new, mut fallible, mut calls) = (None, false, Vec::new());
        for signature in &block.methods {
            let method = signature.name.as_str();
            if method == "new" && signature.receiver == Receiver::None {
                fallible = signature
                    .output
                    .as_deref()
                    .is_some_and(|t| t.starts_with("Result"));
                new = Some(function(signature, outcomes));
            } else if signature.receiver == Receiver::Mutable
                && method != "reset"
                && !method.starts_with("set_")
            {
                calls.push(function(signature, outcomes));
            }
        }
        if let (Some(new), false) = (new, calls.is_empty()) {
            types.push(Type {
                name: block.name,
                new,
                new_is_fallible: fallible,
                calls,
            });
        }
    }
    types
}

/// A signature's arguments and result.
fn function(signature: &Signature, outcomes: &BTreeMap<String, Outcome>) -> Function {
    let args = signature
        .params
        .iter()
        .map(|(name, ty)| Arg {
            name: name.clone(),
            ty: ty.clone(),
            shape: shape(ty),
        })
        .collect();
    let (output, output_shape, outcome) = match &signature.output {
        None => (None, None, Outcome::Always),
        Some(text) => {
            let outcome = outcomes.get(text).copied().unwrap_or(Outcome::Always);
            // The module's own types, named through `model::` from the firmware's code.
            let qualified = if outcomes.contains_key(text) {
                format!("model::{text}")
            } else {
                text.clone()
            };
            (Some(qualified), Some(shape(text)), outcome)
        }
    };
    Function {
        name: signature.name.clone(),
        args,
        output,
        output_shape,
        outcome,
    }
}

/// The shape of an `f32` argument or result, from its type's text.
fn shape(text: &str) -> Shape {
    let inner = text.trim_start_matches('&');
    let length = |s: &str| s.trim().parse::<usize>().ok();
    let other = || Shape::Other(text.to_owned());
    if inner == "f32" {
        return Shape::Scalar;
    }
    if let Some(rest) = inner
        .strip_prefix("Option<&[f32;")
        .and_then(|r| r.strip_suffix("]>"))
    {
        return length(rest).map_or_else(other, Shape::OptionalVector);
    }
    if let Some(rest) = inner
        .strip_prefix("[f32;")
        .and_then(|r| r.strip_suffix(']'))
    {
        return length(rest).map_or_else(other, Shape::Vector);
    }
    if let Some(rest) = inner
        .strip_prefix("[[f32;")
        .and_then(|r| r.strip_suffix(']'))
    {
        if let Some((cols, rows)) = rest.split_once("];") {
            if let (Some(cols), Some(rows)) = (length(cols), length(rows)) {
                return Shape::Matrix(rows, cols);
            }
        }
    }
    other()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shapes_of_the_generated_arguments() {
        assert_eq!(shape("f32"), Shape::Scalar);
        assert_eq!(shape("&[f32; 5]"), Shape::Vector(5));
        assert_eq!(shape("[f32; 2]"), Shape::Vector(2));
        assert_eq!(shape("&[[f32; 3]; 2]"), Shape::Matrix(2, 3));
        assert_eq!(shape("Option<&[f32; 1]>"), Shape::OptionalVector(1));
        assert_eq!(shape("u32"), Shape::Other("u32".into()));
    }
}
