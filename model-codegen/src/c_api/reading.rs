//! What the C API offers, read from the generated module's code: per scalar type (the
//! module's own, then each `in_<scalar>` module), the types that have a constructor, their
//! public methods whose arguments and results C can pass, and the constants. The generated
//! API's conventions (the language reference's "The generated API") make this a reading of
//! signatures: arrays by reference, a constructor `new(..) -> Result<Self, Status>`.

use super::records::{self, Enumeration, Known, Record};
use super::storage;
use super::values::array;
pub use super::values::{Scalar, Value};
use crate::generated_api::{self, doc, inline_items, type_text, Receiver, Signature};
use syn::{Item, Type as SynType};

/// An argument of a method.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Param {
    /// Passed by value (`s`) or by reference (`&[s; n]`).
    Required(String, Value),
    /// `Option<&[s; n]>`: a null pointer is `None`.
    Optional(String, Value),
}

/// What a method returns, and so how its C function returns it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Output {
    /// Nothing (`()`).
    Nothing,
    /// A `Status`, returned as it is.
    Status,
    /// A value, written through an output pointer.
    Value(Value),
    /// `Result<value, Status>`: the value written on `Ok`.
    Fallible(Value),
    /// A record with `Status` fields (`DkfStatus`, `MpcStatus`), by its Rust name: the
    /// first of them that is not `Ok` returned, the whole written through an optional
    /// output pointer.
    Outcome(String),
    /// `Self` or (`fallible`) `Result<Self, Status>`: the constructor, written into the
    /// storage.
    Constructed {
        /// Whether it returns a `Result`.
        fallible: bool,
    },
}

/// A method of a generated type.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Method {
    /// Its name.
    pub name: String,
    /// Its doc comment's lines.
    pub doc: Vec<String>,
    /// `None` for an associated function, `Some(true)` for `&mut self`.
    pub receiver: Option<bool>,
    /// Its arguments, `self` excluded.
    pub params: Vec<Param>,
    /// Its result.
    pub output: Output,
}

impl Scope {
    /// The status fields of the outcome record `name` (`akf`, `lkf`), which its C
    /// function returns the first of that is not `Ok`.
    pub fn outcome_statuses(&self, name: &str) -> Vec<&str> {
        self.records
            .iter()
            .find(|r| r.name == name)
            .map(Record::statuses)
            .unwrap_or_default()
    }
}

impl Method {
    /// Whether a type's function takes its storage: a method, or the constructor that
    /// writes it (an associated function that constructs nothing, `Mpc::prediction_model`,
    /// does not).
    pub fn takes_storage(&self) -> bool {
        self.receiver.is_some() || matches!(self.output, Output::Constructed { .. })
    }
}

/// A public constant C can hold: an integer or a float.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Constant {
    /// Its name in the C header's terms, without the prefix (`EKF_STEP_CYCLES`,
    /// `EKF_STEP_OPS_ADD`, `INDEX_X1`).
    pub name: String,
    /// Its doc comment's lines.
    pub doc: Vec<String>,
    /// Its value as C writes it (`418u`, `0.015f`).
    pub value: String,
}

/// A generated type (a filter or controller).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Type {
    /// Its Rust name (`GatedEkf`).
    pub name: String,
    /// Its doc comment's lines.
    pub doc: Vec<String>,
    /// The size of its storage (`storage::size`), `None` if a field's layout is unknown.
    pub storage: Option<usize>,
    /// The methods C can call, in the code's order, the constructor first.
    pub methods: Vec<Method>,
    /// The public methods C cannot call (an argument or result it cannot pass).
    pub left_out: Vec<String>,
}

/// The items of one scalar type.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Scope {
    /// The module's path from the file's root (`cantilever`, `cantilever::in_f64`).
    pub module: String,
    /// The scalar of its code.
    pub scalar: Scalar,
    /// Whether it is the model's first scalar type (its names carry no scalar).
    pub first: bool,
    /// Its types that have a constructor.
    pub types: Vec<Type>,
    /// Its free functions C can call (`f`, `h`, the Jacobians).
    pub functions: Vec<Method>,
    /// Its constants C can hold.
    pub constants: Vec<Constant>,
    /// The records its functions return, in the code's order.
    pub records: Vec<Record>,
    /// The enums those records hold, in the code's order.
    pub enums: Vec<Enumeration>,
}

/// What the C API offers.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Api {
    /// The model's name (`cantilever`).
    pub model: String,
    /// The model's doc comment's lines.
    pub doc: Vec<String>,
    /// The variants of `Status` and their docs, in order.
    pub statuses: Vec<(String, Vec<String>)>,
    /// Per scalar type.
    pub scopes: Vec<Scope>,
}

/// The C API of `code`, a generated file (`pub mod <name> { .. }`).
pub fn read(code: &str) -> Result<Api, String> {
    let file = generated_api::parse(code)?;
    let top = generated_api::model_module(&file)?;
    let model = top.ident.to_string();
    let items = inline_items(top);
    let statuses = items
        .iter()
        .find_map(|item| match item {
            Item::Enum(e) if e.ident == "Status" => Some(
                e.variants
                    .iter()
                    .map(|v| (v.ident.to_string(), doc(&v.attrs)))
                    .collect::<Vec<_>>(),
            ),
            _ => None,
        })
        .ok_or("the generated code has no `Status`: the model generates no filter or controller (add a `generate` item)")?;
    let inner = generated_api::modules(items).filter(|m| m.ident.to_string().starts_with("in_f"));
    let second: Vec<_> = inner
        .map(|m| {
            let scalar = scalar_named(&m.ident.to_string()["in_".len()..])?;
            Some((format!("{model}::{}", m.ident), scalar, inline_items(m)))
        })
        .collect::<Option<_>>()
        .ok_or("an `in_*` module of an unknown scalar")?;
    let first_scalar = match second.first() {
        Some((_, Scalar::F64, _)) => Scalar::F32,
        Some((_, Scalar::F32, _)) => Scalar::F64,
        None => scalar_of(items).ok_or("the generated code has no floating-point type")?,
    };
    let mut scopes = vec![scope(model.clone(), first_scalar, true, items)];
    for (module, scalar, inner_items) in second {
        scopes.push(scope(module, scalar, false, inner_items));
    }
    if scopes.iter().all(|s| s.types.is_empty()) {
        return Err("the model generates no filter or controller (add a `generate` item)".into());
    }
    Ok(Api {
        model,
        doc: doc(&top.attrs),
        statuses,
        scopes,
    })
}

/// `f32` or `f64`.
fn scalar_named(name: &str) -> Option<Scalar> {
    match name {
        "f32" => Some(Scalar::F32),
        "f64" => Some(Scalar::F64),
        _ => None,
    }
}

/// The scalar of a module with one: the first one its functions' signatures name.
fn scalar_of(items: &[Item]) -> Option<Scalar> {
    let text = items
        .iter()
        .filter_map(|item| match item {
            Item::Fn(f) => Some(signature_text(&f.sig)),
            Item::Impl(block) => Some(quote::quote!(#block).to_string()),
            _ => None,
        })
        .collect::<String>();
    match (text.find("f32"), text.find("f64")) {
        (Some(a), Some(b)) => Some(if a < b { Scalar::F32 } else { Scalar::F64 }),
        (Some(_), None) => Some(Scalar::F32),
        (None, Some(_)) => Some(Scalar::F64),
        (None, None) => None,
    }
}

/// A signature's text.
fn signature_text(sig: &syn::Signature) -> String {
    quote::quote!(#sig).to_string()
}

/// The items of one module as the C API offers them.
fn scope(module: String, scalar: Scalar, first: bool, items: &[Item]) -> Scope {
    let known = records::read(items, scalar);
    let mut constants = Vec::new();
    let mut types = Vec::new();
    let mut functions = Vec::new();
    for item in items {
        match item {
            Item::Const(c) if matches!(c.vis, syn::Visibility::Public(_)) => {
                constants.extend(constant(
                    &c.ident.to_string(),
                    &doc(&c.attrs),
                    &c.ty,
                    &c.expr,
                    scalar,
                ));
            }
            Item::Mod(m) if m.ident == "index" => {
                for inner in inline_items(m) {
                    if let Item::Const(c) = inner {
                        let name = format!("INDEX_{}", c.ident);
                        constants.extend(constant(&name, &doc(&c.attrs), &c.ty, &c.expr, scalar));
                    }
                }
            }
            Item::Fn(f) if generated_api::public(&f.vis) => {
                let signature = generated_api::signature(&f.sig, &f.attrs);
                if let Some(method) = method(&signature, scalar, &known) {
                    functions.push(method);
                }
            }
            Item::Impl(block) => {
                if let Some(block) = generated_api::inherent_impl(block) {
                    types.extend(generated_type(&block, items, &known, &mut constants));
                }
            }
            _ => {}
        }
    }
    let (records, enums) = returned(&known, &types, &functions);
    Scope {
        module,
        scalar,
        first,
        types,
        functions,
        constants,
        records,
        enums,
    }
}

/// The records the functions of `types` and `functions` return, and the enums they hold,
/// in the code's order.
fn returned(
    known: &Known,
    types: &[Type],
    functions: &[Method],
) -> (Vec<Record>, Vec<Enumeration>) {
    let methods = types
        .iter()
        .filter(|ty| ty.storage.is_some())
        .flat_map(|ty| &ty.methods)
        .chain(functions);
    let names: Vec<&str> = methods
        .filter_map(|m| match &m.output {
            Output::Outcome(name)
            | Output::Value(Value::Record(name))
            | Output::Fallible(Value::Record(name)) => Some(name.as_str()),
            _ => None,
        })
        .collect();
    let records: Vec<Record> = known
        .records
        .iter()
        .filter(|r| names.contains(&r.name.as_str()))
        .cloned()
        .collect();
    let held = |e: &&Enumeration| {
        records.iter().any(|r| {
            r.fields
                .iter()
                .any(|(_, f, _)| *f == records::Field::Enum(e.name.clone()))
        })
    };
    let enums = known.enums.iter().filter(held).cloned().collect();
    (records, enums)
}

/// The type an `impl` block is for, with its methods, if it has a constructor; its
/// constants join `constants`.
fn generated_type(
    block: &generated_api::Impl,
    items: &[Item],
    known: &Known,
    constants: &mut Vec<Constant>,
) -> Option<Type> {
    let name = block.name.clone();
    let definition = items.iter().find_map(|item| match item {
        Item::Struct(s) if s.ident == name => Some(s),
        _ => None,
    })?;
    let scalar = known.scalar;
    let mut methods = Vec::new();
    let mut left_out = Vec::new();
    for signature in &block.methods {
        match method(signature, scalar, known) {
            Some(m) => methods.push(m),
            None => left_out.push(signature.name.clone()),
        }
    }
    for c in &block.constants {
        let constant_name = format!(
            "{}_{}",
            generated_api::snake(&name).to_ascii_uppercase(),
            c.ident
        );
        constants.extend(constant(
            &constant_name,
            &doc(&c.attrs),
            &c.ty,
            &c.expr,
            scalar,
        ));
    }
    let new = methods
        .iter()
        .position(|m| m.name == "new" && matches!(m.output, Output::Constructed { .. }))?;
    let constructor = methods.remove(new);
    methods.insert(0, constructor);
    Some(Type {
        doc: doc(&definition.attrs),
        storage: storage::size(known.struct_fields(&name)?, known),
        name,
        methods,
        left_out,
    })
}

/// A method or function C can call, `None` if it takes `self` by value or an argument or
/// its result is of a kind C cannot pass.
fn method(signature: &Signature, scalar: Scalar, known: &Known) -> Option<Method> {
    let receiver = match signature.receiver {
        Receiver::None => None,
        Receiver::Shared => Some(false),
        Receiver::Mutable => Some(true),
        Receiver::Value => return None,
    };
    let params = signature
        .params
        .iter()
        .map(|(name, ty)| param(name.clone(), ty, scalar))
        .collect::<Option<Vec<_>>>()?;
    let output = match &signature.output {
        None => Output::Nothing,
        Some(t) => output(t, scalar, known)?,
    };
    if matches!(output, Output::Constructed { .. }) && receiver.is_some() {
        return None;
    }
    Some(Method {
        name: signature.name.clone(),
        doc: signature.doc.clone(),
        receiver,
        params,
        output,
    })
}

/// An argument's kind, from its type's text.
fn param(name: String, ty: &str, scalar: Scalar) -> Option<Param> {
    if let Some(inner) = ty
        .strip_prefix("Option<&")
        .and_then(|t| t.strip_suffix('>'))
    {
        return Some(Param::Optional(name, array(inner, scalar)?));
    }
    match ty.strip_prefix('&') {
        Some(inner) => Some(Param::Required(name, array(inner, scalar)?)),
        None if ty == scalar.rust() => Some(Param::Required(name, Value::Scalar)),
        None => None,
    }
}

/// A result's kind, from its type's text.
fn output(ty: &str, scalar: Scalar, known: &Known) -> Option<Output> {
    if let Some(record) = known.record(ty) {
        return Some(match record.statuses().is_empty() {
            true => Output::Value(Value::Record(ty.to_owned())),
            false => Output::Outcome(ty.to_owned()),
        });
    }
    if ty == "Status" {
        return Some(Output::Status);
    }
    if ty == "Self" || ty == "Result<Self, Status>" {
        return Some(Output::Constructed {
            fallible: ty != "Self",
        });
    }
    if let Some(inner) = ty
        .strip_prefix("Result<")
        .and_then(|t| t.strip_suffix(", Status>"))
    {
        return Some(Output::Fallible(match known.record(inner) {
            Some(_) => Value::Record(inner.to_owned()),
            None => value(inner, scalar)?,
        }));
    }
    Some(Output::Value(value(ty, scalar)?))
}

/// A value's shape: the scalar, `u32`, or an array of the scalar.
fn value(ty: &str, scalar: Scalar) -> Option<Value> {
    match ty {
        "u32" => Some(Value::Count),
        _ if ty == scalar.rust() => Some(Value::Scalar),
        _ => array(ty, scalar),
    }
}

/// A constant C can hold: an integer (`usize`, `u32`) or the scalar; an `OpCount`, one
/// constant per field (`EKF_STEP_OPS_ADD`). Other constants (names, sparsity patterns)
/// have no C form here.
fn constant(
    name: &str,
    doc: &[String],
    ty: &SynType,
    expr: &syn::Expr,
    scalar: Scalar,
) -> Vec<Constant> {
    let ty = type_text(ty);
    let one = |value: String| {
        vec![Constant {
            name: name.to_owned(),
            doc: doc.to_vec(),
            value,
        }]
    };
    match (ty.as_str(), expr) {
        (
            "usize" | "u32",
            syn::Expr::Lit(syn::ExprLit {
                lit: syn::Lit::Int(i),
                ..
            }),
        ) => one(format!("{}u", i.base10_digits())),
        (
            _,
            syn::Expr::Lit(syn::ExprLit {
                lit: syn::Lit::Float(f),
                ..
            }),
        ) if ty == scalar.rust() => one(c_float(f.base10_digits(), scalar)),
        ("OpCount", syn::Expr::Struct(s)) => s
            .fields
            .iter()
            .filter_map(|field| {
                let syn::Member::Named(member) = &field.member else {
                    return None;
                };
                let syn::Expr::Lit(syn::ExprLit {
                    lit: syn::Lit::Int(i),
                    ..
                }) = &field.expr
                else {
                    return None;
                };
                let what = member.to_string();
                Some(Constant {
                    name: format!("{name}_{}", what.to_ascii_uppercase()),
                    doc: vec![format!("The `{what}` count of `{name}`: {}", doc.join(" "))],
                    value: format!("{}u", i.base10_digits()),
                })
            })
            .collect(),
        _ => Vec::new(),
    }
}

/// A float literal's digits as C writes a constant of the scalar (`0.015f`, `1e-6`).
fn c_float(digits: &str, scalar: Scalar) -> String {
    let digits = if digits.contains(['.', 'e', 'E']) {
        digits.to_owned()
    } else {
        format!("{digits}.0")
    };
    match scalar {
        Scalar::F32 => format!("{digits}f"),
        Scalar::F64 => digits,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kinds_of_arguments_and_results() {
        let s = Scalar::F32;
        let file: syn::File = syn::parse_str(
            "pub enum MpcRebuild { Nothing }
             pub struct MpcStatus { pub status: Status, pub rebuilt: MpcRebuild }
             pub struct PredictionModel { pub a: [[f32; 2]; 2] }",
        )
        .expect("parses");
        let known = records::read(&file.items, s);
        let output = |ty: &str, s: Scalar| output(ty, s, &known);
        assert_eq!(
            param("x".into(), "&[f32; 5]", s),
            Some(Param::Required("x".into(), Value::Vector(5)))
        );
        assert_eq!(
            param("p".into(), "&[[f32; 3]; 2]", s),
            Some(Param::Required("p".into(), Value::Matrix(2, 3)))
        );
        assert_eq!(
            param("u".into(), "Option<&[f32; 1]>", s),
            Some(Param::Optional("u".into(), Value::Vector(1)))
        );
        assert_eq!(
            param("g".into(), "f32", s),
            Some(Param::Required("g".into(), Value::Scalar))
        );
        assert_eq!(param("g".into(), "f64", s), None);
        assert_eq!(
            output("Result<Self, Status>", s),
            Some(Output::Constructed { fallible: true })
        );
        assert_eq!(
            output("Result<[f32; 1], Status>", s),
            Some(Output::Fallible(Value::Vector(1)))
        );
        assert_eq!(output("u32", s), Some(Output::Value(Value::Count)));
        assert_eq!(output("([f32; 5], WindowStatus)", s), None);
        assert_eq!(output("Option<usize>", s), None);
        assert_eq!(
            output("MpcStatus", s),
            Some(Output::Outcome("MpcStatus".into()))
        );
        assert_eq!(
            output("Result<PredictionModel, Status>", s),
            Some(Output::Fallible(Value::Record("PredictionModel".into())))
        );
        assert_eq!(
            output("PredictionModel", s),
            Some(Output::Value(Value::Record("PredictionModel".into())))
        );
        assert_eq!(c_float("0.015", Scalar::F32), "0.015f");
        assert_eq!(c_float("1e-6", Scalar::F64), "1e-6");
        assert_eq!(c_float("2", Scalar::F64), "2.0");
    }
}
