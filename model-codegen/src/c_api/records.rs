//! The types one scope of the generated code defines, read from its items: the plain
//! structs C receives as results (a step's or solve's outcome, `DkfStatus`, `MpcStatus`;
//! a value, `PredictionModel`), the fieldless enums their fields hold (`WindowStatus`,
//! `MpcRebuild`), and every struct's field types, which a storage that holds one is sized
//! by. Their C forms are the wrapper's and the header's.

use super::values::{array, Scalar, Value};
use crate::generated_api::{doc, public, type_text};
use syn::Item;

/// What a field of a record holds, as C receives it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Field {
    /// The model's `Status`.
    Status,
    /// One of the scope's fieldless enums, by its Rust name.
    Enum(String),
    /// `bool`.
    Flag,
    /// `usize` or `u32`, as a `uint32_t` (a `usize` beyond it saturates).
    Count {
        /// Whether the Rust field is a `usize`.
        usize: bool,
    },
    /// The scalar or an array of it.
    Value(Value),
}

/// A plain struct of the generated code: public, every field public and of a kind C
/// receives.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Record {
    /// Its Rust name (`DkfStatus`).
    pub name: String,
    /// Its doc comment's lines.
    pub doc: Vec<String>,
    /// Its fields: each name, kind and doc comment's lines.
    pub fields: Vec<(String, Field, Vec<String>)>,
}

impl Record {
    /// The size of its C form, as C and `#[repr(C)]` lay it out: a status or an enum is
    /// a `uint8_t` (an enum's size is the C compiler's choice: `-fshort-enums` and its
    /// opposite would disagree), a flag a `bool`, a count a `uint32_t`; `None` if it
    /// overflows.
    pub fn c_size(&self, scalar: Scalar) -> Option<usize> {
        let bytes = match scalar {
            Scalar::F32 => 4,
            Scalar::F64 => 8,
        };
        let mut end: usize = 0;
        let mut largest = 1;
        for (_, field, _) in &self.fields {
            let (size, align) = match field {
                Field::Status | Field::Enum(_) | Field::Flag => (1, 1),
                Field::Count { .. } => (4, 4),
                Field::Value(Value::Vector(n)) => (bytes * n, bytes),
                Field::Value(Value::Matrix(rows, cols)) => (bytes * rows * cols, bytes),
                Field::Value(_) => (bytes, bytes),
            };
            end = end.checked_next_multiple_of(align)?.checked_add(size)?;
            largest = largest.max(align);
        }
        end.checked_next_multiple_of(largest)
    }

    /// The fields that hold a `Status`, which make it an outcome: its C function returns
    /// the first of them that is not `Ok`.
    pub fn statuses(&self) -> Vec<&str> {
        self.fields
            .iter()
            .filter(|(_, field, _)| *field == Field::Status)
            .map(|(name, _, _)| name.as_str())
            .collect()
    }
}

/// A public fieldless enum of the generated code other than `Status`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Enumeration {
    /// Its Rust name (`WindowStatus`).
    pub name: String,
    /// Its doc comment's lines.
    pub doc: Vec<String>,
    /// Its variants and their docs, in order.
    pub variants: Vec<(String, Vec<String>)>,
}

/// What one scope's items define that C can receive, and the field types of every struct
/// (for the size of a storage that holds one).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Known {
    /// The scalar of the scope's code.
    pub scalar: Scalar,
    /// The plain structs C can receive.
    pub records: Vec<Record>,
    /// The fieldless enums.
    pub enums: Vec<Enumeration>,
    /// Every struct's name and its fields' types, as the code writes them.
    pub structs: Vec<(String, Vec<String>)>,
}

impl Known {
    /// The record named `name`.
    pub fn record(&self, name: &str) -> Option<&Record> {
        self.records.iter().find(|r| r.name == name)
    }

    /// The enum named `name`.
    pub fn enumeration(&self, name: &str) -> Option<&Enumeration> {
        self.enums.iter().find(|e| e.name == name)
    }

    /// The fields' types of the struct named `name`.
    pub fn struct_fields(&self, name: &str) -> Option<&[String]> {
        self.structs
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, fields)| fields.as_slice())
    }
}

/// The structs and enums of a scope's `items`, whose code is in `scalar`.
pub fn read(items: &[Item], scalar: Scalar) -> Known {
    let mut known = Known {
        scalar,
        records: Vec::new(),
        enums: Vec::new(),
        structs: Vec::new(),
    };
    for item in items {
        match item {
            Item::Enum(e)
                if public(&e.vis)
                    && e.ident != "Status"
                    && e.variants.iter().all(|v| v.fields.is_empty()) =>
            {
                known.enums.push(Enumeration {
                    name: e.ident.to_string(),
                    doc: doc(&e.attrs),
                    variants: e
                        .variants
                        .iter()
                        .map(|v| (v.ident.to_string(), doc(&v.attrs)))
                        .collect(),
                });
            }
            Item::Struct(s) => {
                let types = s.fields.iter().map(|f| type_text(&f.ty)).collect();
                known.structs.push((s.ident.to_string(), types));
            }
            _ => {}
        }
    }
    for item in items {
        if let Item::Struct(s) = item {
            if let Some(record) = record(s, scalar, &known) {
                known.records.push(record);
            }
        }
    }
    known
}

/// A struct as a record, if it is one.
fn record(s: &syn::ItemStruct, scalar: Scalar, known: &Known) -> Option<Record> {
    if !public(&s.vis) || s.fields.is_empty() {
        return None;
    }
    let fields = s
        .fields
        .iter()
        .map(|f| {
            let name = f.ident.as_ref()?.to_string();
            public(&f.vis).then_some(())?;
            Some((
                name,
                field(&type_text(&f.ty), scalar, known)?,
                doc(&f.attrs),
            ))
        })
        .collect::<Option<Vec<_>>>()?;
    Some(Record {
        name: s.ident.to_string(),
        doc: doc(&s.attrs),
        fields,
    })
}

/// A field's kind, from its type's text.
fn field(ty: &str, scalar: Scalar, known: &Known) -> Option<Field> {
    match ty {
        "Status" => Some(Field::Status),
        "bool" => Some(Field::Flag),
        "usize" => Some(Field::Count { usize: true }),
        "u32" => Some(Field::Count { usize: false }),
        _ if known.enumeration(ty).is_some() => Some(Field::Enum(ty.to_owned())),
        _ if ty == scalar.rust() => Some(Field::Value(Value::Scalar)),
        _ => array(ty, scalar).map(Field::Value),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn outcomes_values_and_enums_are_read_from_the_code() {
        let file: syn::File = syn::parse_str(
            "pub enum WindowStatus { Solved, Skipped }
             pub enum Carrying { One(f32) }
             pub struct DkfStatus { pub window: WindowStatus, pub akf: Status, pub lkf: Status }
             pub struct PredictionModel { pub a: [[f32; 2]; 2], pub b: [[f32; 1]; 2] }
             pub struct MpcStatus { pub status: Status, pub optimal: bool, pub iterations: usize }
             pub struct Private { a: f32 }
             pub struct Foreign { pub a: Carrying }",
        )
        .expect("parses");
        let known = read(&file.items, Scalar::F32);
        let names: Vec<&str> = known.records.iter().map(|r| r.name.as_str()).collect();
        assert_eq!(names, ["DkfStatus", "PredictionModel", "MpcStatus"]);
        assert_eq!(known.enums.len(), 1);
        assert_eq!(
            known.record("DkfStatus").map(Record::statuses),
            Some(vec!["akf", "lkf"])
        );
        assert_eq!(
            known
                .record("PredictionModel")
                .map(|r| r.fields[0].1.clone()),
            Some(Field::Value(Value::Matrix(2, 2)))
        );
        assert_eq!(
            known.record("MpcStatus").map(|r| r.fields[2].1.clone()),
            Some(Field::Count { usize: true })
        );
        assert_eq!(
            known.struct_fields("Private"),
            Some(&["f32".to_owned()][..])
        );
    }
}
