//! The wrapper's `repr(C)` mirrors of the records and enums C receives (`DkfStatus` as
//! `CantileverDkfStatus`, `cantilever_dkf_status_t` in C), each with its conversion from
//! the generated type: a status and an enum as a `u8` (its C enum's value), a `usize` as
//! a `u32`; each record's size asserted equal to what the header states.

use super::names::{camel, prefix, record};
use super::reading::{Api, Scope};
use super::records::{Enumeration, Field, Record};
use std::fmt::Write;

/// The mirrors of a scope's enums and records, the generated code's at `path`.
pub fn mirrors(api: &Api, scope: &Scope, path: &str, status: &str, out: &mut String) {
    for e in &scope.enums {
        enumeration(api, scope, path, e, out);
    }
    for r in &scope.records {
        mirror(api, scope, path, status, r, out);
    }
}

/// A C enum and its conversion.
fn enumeration(api: &Api, scope: &Scope, path: &str, e: &Enumeration, out: &mut String) {
    let c_name = record(&prefix(&api.model, scope), &e.name);
    let name = camel(&c_name);
    let _ = writeln!(
        out,
        "/// [`{path}::{}`] as C holds it, `{c_name}_t`.\n#[repr(C)]\n\
         #[derive(Clone, Copy, Debug, PartialEq, Eq)]\npub enum {name} {{",
        e.name
    );
    for (i, (variant, doc)) in e.variants.iter().enumerate() {
        let _ = writeln!(out, "    /// {}\n    {variant} = {i},", doc.join(" "));
    }
    let _ = writeln!(
        out,
        "}}\n\nimpl From<{path}::{0}> for {name} {{\n    fn from(value: {path}::{0}) -> Self {{\n        \
         match value {{",
        e.name
    );
    for (variant, _) in &e.variants {
        let _ = writeln!(
            out,
            "            {path}::{}::{variant} => {name}::{variant},",
            e.name
        );
    }
    let _ = writeln!(out, "        }}\n    }}\n}}\n");
}

/// A C struct and its conversion.
fn mirror(api: &Api, scope: &Scope, path: &str, status: &str, r: &Record, out: &mut String) {
    let c_name = record(&prefix(&api.model, scope), &r.name);
    let name = camel(&c_name);
    let Some(size) = r.c_size(scope.scalar) else {
        return;
    };
    let _ = writeln!(
        out,
        "/// [`{path}::{}`] as C receives it, `{c_name}_t`.\n#[repr(C)]\n\
         #[derive(Clone, Copy, Debug)]\npub struct {name} {{",
        r.name
    );
    let mut conversions = Vec::new();
    for (field, kind, doc) in &r.fields {
        let (ty, conversion) = match kind {
            Field::Status => (
                "u8".to_owned(),
                format!("{status}::from(value.{field}) as u8"),
            ),
            Field::Enum(e) => (
                "u8".to_owned(),
                format!(
                    "{}::from(value.{field}) as u8",
                    camel(&record(&prefix(&api.model, scope), e))
                ),
            ),
            Field::Flag => ("bool".to_owned(), format!("value.{field}")),
            Field::Count { usize: true } => (
                "u32".to_owned(),
                format!("u32::try_from(value.{field}).unwrap_or(u32::MAX)"),
            ),
            Field::Count { usize: false } => ("u32".to_owned(), format!("value.{field}")),
            Field::Value(v) => (
                v.rust(scope.scalar, &|name| name.to_owned()),
                format!("value.{field}"),
            ),
        };
        let _ = writeln!(out, "    /// {}\n    pub {field}: {ty},", doc.join(" "));
        conversions.push(format!("{field}: {conversion}"));
    }
    let _ = writeln!(
        out,
        "}}\n\nimpl From<{path}::{0}> for {name} {{\n    fn from(value: {path}::{0}) -> Self {{\n        \
         {name} {{ {1} }}\n    }}\n}}\n\n\
         // The mirror has the size the header states: checked when this crate builds.\n\
         const _: () = assert!(core::mem::size_of::<{name}>() == {size});\n",
        r.name,
        conversions.join(", ")
    );
}
