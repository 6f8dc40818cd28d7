//! What the measuring firmware can call, read from the generated module's `f32` code: the
//! types that have a constructor and their calls, the model functions `f` and `h`, and the
//! static estimates (`*_CYCLES`). The generated API's conventions (the language
//! reference's "The generated API") make this a reading of signatures: every array is
//! passed by reference, every constructor is `new(..) -> Result<Self, Status>`.

use std::collections::BTreeMap;
use syn::{FnArg, ImplItem, Item, ReturnType, Type as SynType};

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
        let base = format!("{}_{}", screaming(type_name), call.to_ascii_uppercase());
        [format!("{base}_CYCLES"), format!("{base}_WORST_CYCLES")]
            .into_iter()
            .find_map(|name| Some((name.clone(), *self.cycles.get(&name)?)))
    }
}

/// `GatedEkf` -> `GATED_EKF`: a type's name as its constants spell it.
pub fn screaming(name: &str) -> String {
    let mut out = String::new();
    let mut previous_lower = false;
    for c in name.chars() {
        if c.is_ascii_uppercase() && previous_lower {
            out.push('_');
        }
        previous_lower = c.is_ascii_lowercase() || c.is_ascii_digit();
        out.push(c.to_ascii_uppercase());
    }
    out
}

/// The API of `code`, a generated file (`pub mod <name> { .. }`).
pub fn read(code: &str) -> Result<Api, String> {
    let file = syn::parse_file(code).map_err(|e| format!("the generated code: {e}"))?;
    let Some((name, items)) = file.items.iter().find_map(module) else {
        return Err("the generated code holds no module".into());
    };
    let (module, items) = match items.iter().find_map(module) {
        Some((inner, inner_items)) if inner == "in_f32" => (format!("{name}::in_f32"), inner_items),
        _ => (name, items),
    };
    let outcomes = outcomes(items);
    let function = |f: &syn::Signature| signature(f, &outcomes);
    let free = |wanted: &str| {
        items.iter().find_map(|item| match item {
            Item::Fn(f) if f.sig.ident == wanted => Some(function(&f.sig)),
            _ => None,
        })
    };
    let (f, h) = (free("f"), free("h"));
    let types = types(items, &function);
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
    let mut cycles = BTreeMap::new();
    for scope in [items, &file_module_items(&file)] {
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

/// The items of the file's top module (the static estimates are there, whichever module
/// holds the `f32` code).
fn file_module_items(file: &syn::File) -> Vec<Item> {
    file.items
        .iter()
        .find_map(module)
        .map(|(_, items)| items.to_vec())
        .unwrap_or_default()
}

/// An inline module's name and items.
fn module(item: &Item) -> Option<(String, &[Item])> {
    match item {
        Item::Mod(m) => Some((m.ident.to_string(), &m.content.as_ref()?.1)),
        _ => None,
    }
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
                    f.ident.as_ref().is_some_and(|i| i == "status") && type_text(&f.ty) == "Status"
                });
                if has_status {
                    outcomes.insert(s.ident.to_string(), Outcome::StatusField);
                }
            }
            Item::Impl(block) => {
                let has_is_ok = block.items.iter().any(
                    |i| matches!(i, ImplItem::Fn(f) if f.sig.ident == "is_ok" && f.sig.inputs.len() == 1),
                );
                if let (true, Some(name)) = (has_is_ok, self_type(block)) {
                    outcomes.insert(name, Outcome::IsOk);
                }
            }
            _ => {}
        }
    }
    outcomes
}

/// The name of the type an `impl` block is for.
fn self_type(block: &syn::ItemImpl) -> Option<String> {
    match &*block.self_ty {
        SynType::Path(p) => Some(p.path.segments.last()?.ident.to_string()),
        _ => None,
    }
}

/// The types with a constructor and calls, in the order the code declares them.
fn types(items: &[Item], function: &dyn Fn(&syn::Signature) -> Function) -> Vec<Type> {
    let mut types = Vec::new();
    for item in items {
        let Item::Impl(block) = item else { continue };
        let (Some(name), None) = (self_type(block), &block.trait_) else {
            continue;
        };
        let methods = block.items.iter().filter_map(|i| match i {
            ImplItem::Fn(f) if matches!(f.vis, syn::Visibility::Public(_)) => Some(&f.sig),
            _ => None,
        });
        let (mut new, mut fallible, mut calls) = (None, false, Vec::new());
        for sig in methods {
            let receiver = sig.inputs.first().and_then(|a| match a {
                FnArg::Receiver(r) => Some(matches!(
                    r.kind,
                    syn::ReceiverKind::Reference(_, _, Some(_))
                )),
                FnArg::Typed(_) => None,
            });
            let method = sig.ident.to_string();
            if method == "new" && receiver.is_none() {
                fallible = matches!(&sig.output, ReturnType::Type(_, t) if type_text(t).starts_with("Result"));
                new = Some(function(sig));
            } else if receiver == Some(true) && method != "reset" && !method.starts_with("set_") {
                calls.push(function(sig));
            }
        }
        if let (Some(new), false) = (new, calls.is_empty()) {
            types.push(Type {
                name,
                new,
                new_is_fallible: fallible,
                calls,
            });
        }
    }
    types
}

/// A signature's arguments and result.
fn signature(sig: &syn::Signature, outcomes: &BTreeMap<String, Outcome>) -> Function {
    let args = sig
        .inputs
        .iter()
        .filter_map(|a| match a {
            FnArg::Typed(t) => Some(t),
            FnArg::Receiver(_) => None,
        })
        .map(|t| {
            let name = match &*t.pat {
                syn::Pat::Ident(i) => i.ident.to_string(),
                other => quote::quote!(#other).to_string(),
            };
            Arg {
                name: name.trim_start_matches('_').to_owned(),
                ty: type_text(&t.ty),
                shape: shape(&t.ty),
            }
        })
        .collect();
    let (output, output_shape, outcome) = match &sig.output {
        ReturnType::Default => (None, None, Outcome::Always),
        ReturnType::Type(_, t) => {
            let text = type_text(t);
            let outcome = outcomes.get(&text).copied().unwrap_or(Outcome::Always);
            let qualified = match &**t {
                SynType::Path(p) if p.path.segments.len() == 1 && outcomes.contains_key(&text) => {
                    format!("model::{text}")
                }
                _ => text,
            };
            (Some(qualified), Some(shape(t)), outcome)
        }
    };
    Function {
        name: sig.ident.to_string(),
        args,
        output,
        output_shape,
        outcome,
    }
}

/// A type as the code writes it, without the blanks `quote` puts around punctuation.
fn type_text(ty: &SynType) -> String {
    let text = quote::quote!(#ty).to_string();
    text.replace(" ;", ";")
        .replace("& ", "&")
        .replace("[ ", "[")
        .replace(" ]", "]")
        .replace(" <", "<")
        .replace("< ", "<")
        .replace(" >", ">")
}

/// The shape of an `f32` argument or result.
fn shape(ty: &SynType) -> Shape {
    let text = type_text(ty);
    let inner = text.trim_start_matches('&');
    let length = |s: &str| s.trim().parse::<usize>().ok();
    if inner == "f32" {
        return Shape::Scalar;
    }
    if let Some(rest) = inner
        .strip_prefix("Option<&[f32;")
        .and_then(|r| r.strip_suffix("]>"))
    {
        return length(rest).map_or(Shape::Other(text.clone()), Shape::OptionalVector);
    }
    if let Some(rest) = inner
        .strip_prefix("[f32;")
        .and_then(|r| r.strip_suffix(']'))
    {
        return length(rest).map_or(Shape::Other(text.clone()), Shape::Vector);
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
    Shape::Other(text)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn type_names_spell_their_constants() {
        assert_eq!(screaming("Ekf"), "EKF");
        assert_eq!(screaming("GatedEkf"), "GATED_EKF");
        assert_eq!(screaming("PolynomialKf"), "POLYNOMIAL_KF");
        assert_eq!(screaming("Ekf2"), "EKF2");
    }

    #[test]
    fn shapes_of_the_generated_arguments() {
        let of = |text: &str| shape(&syn::parse_str::<SynType>(text).expect("a type"));
        assert_eq!(of("f32"), Shape::Scalar);
        assert_eq!(of("&[f32; 5]"), Shape::Vector(5));
        assert_eq!(of("[f32; 2]"), Shape::Vector(2));
        assert_eq!(of("&[[f32; 3]; 2]"), Shape::Matrix(2, 3));
        assert_eq!(of("Option<&[f32; 1]>"), Shape::OptionalVector(1));
        assert_eq!(of("u32"), Shape::Other("u32".into()));
    }
}
