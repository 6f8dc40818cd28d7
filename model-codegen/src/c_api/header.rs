//! The C header of the companion crate: the status enum, the model's constants, per
//! generated type its storage (a union of the size and alignment the crate asserts) and
//! its functions, each documented from the model's own docs. C99 and C++ alike.

use super::names::{prefix, record, snake, REFUSALS};
use super::reading::{Api, Method, Output, Param, Scope, Type, Value};
use super::records::{Field, Record};
use super::storage;
use std::fmt::Write;

/// The header's text.
pub fn header(api: &Api, provenance: &str) -> String {
    let guard = format!("{}_H", api.model.to_ascii_uppercase());
    let mut out = format!(
        "/* {} */\n#ifndef {guard}\n#define {guard}\n\n#include <stdbool.h>\n#include <stdint.h>\n\n\
         #ifdef __cplusplus\nextern \"C\" {{\n#endif\n\n",
        comment_text(provenance.trim_start_matches("// "))
    );
    let mut model_doc = api.doc.clone();
    model_doc.extend([
        String::new(),
        "Every function returns a status; it reads and writes only through the pointers it is \
         given, after checking that each is neither null nor misaligned, and never retains one."
            .to_owned(),
        "Arrays are passed as pointers to their first element, matrices row by row.".to_owned(),
    ]);
    doc_block(&model_doc, "", &mut out);
    out.push('\n');
    statuses(api, &mut out);
    for scope in &api.scopes {
        let prefix = prefix(&api.model, scope);
        for constant in &scope.constants {
            doc_block(&translate(&constant.doc, api, scope), "", &mut out);
            let _ = writeln!(
                out,
                "#define {}_{} {}\n",
                prefix.to_ascii_uppercase(),
                constant.name,
                constant.value
            );
        }
        records(api, scope, &mut out);
        for ty in &scope.types {
            generated_type(api, scope, ty, &mut out);
        }
        for function in &scope.functions {
            let c_name = format!("{prefix}_{}", function.name);
            function_declaration(api, scope, &c_name, None, function, &mut out);
        }
    }
    let _ = write!(
        out,
        "#ifdef __cplusplus\n}}\n#endif\n\n#endif /* {guard} */\n"
    );
    out
}

/// The status enum: the model's `Status`, then the wrapper's refusals.
fn statuses(api: &Api, out: &mut String) {
    let name = format!("{}_status", api.model);
    doc_block(
        &["What a function did: the model's status, or why it refused a pointer.".to_owned()],
        "",
        out,
    );
    let _ = writeln!(out, "typedef enum {name} {{");
    let upper = name.to_ascii_uppercase();
    let scope = &api.scopes[0];
    for (i, (variant, doc)) in api.statuses.iter().enumerate() {
        doc_block(&translate(doc, api, scope), "    ", out);
        let _ = writeln!(
            out,
            "    {upper}_{} = {i},",
            snake(variant).to_ascii_uppercase()
        );
    }
    for (i, (variant, _, doc)) in REFUSALS.iter().enumerate() {
        doc_block(&[(*doc).to_owned()], "    ", out);
        let comma = if i + 1 < REFUSALS.len() { "," } else { "" };
        let _ = writeln!(
            out,
            "    {upper}_{} = {}{comma}",
            snake(variant).to_ascii_uppercase(),
            100 + i
        );
    }
    let _ = writeln!(out, "}} {name}_t;\n");
}

/// The enums and records a scope's functions return, as C types.
fn records(api: &Api, scope: &Scope, out: &mut String) {
    let prefix = prefix(&api.model, scope);
    for e in &scope.enums {
        let c_name = record(&prefix, &e.name);
        let upper = c_name.to_ascii_uppercase();
        doc_block(&translate(&e.doc, api, scope), "", out);
        let _ = writeln!(out, "typedef enum {c_name} {{");
        for (i, (variant, doc)) in e.variants.iter().enumerate() {
            doc_block(&translate(doc, api, scope), "    ", out);
            let comma = if i + 1 < e.variants.len() { "," } else { "" };
            let _ = writeln!(
                out,
                "    {upper}_{} = {i}{comma}",
                snake(variant).to_ascii_uppercase()
            );
        }
        let _ = writeln!(out, "}} {c_name}_t;\n");
    }
    for r in &scope.records {
        record_struct(api, scope, &prefix, r, out);
    }
}

/// A record as a C struct.
fn record_struct(api: &Api, scope: &Scope, prefix: &str, r: &Record, out: &mut String) {
    let c_name = record(prefix, &r.name);
    let upper = c_name.to_ascii_uppercase();
    let scalar = scope.scalar.c();
    let Some(size) = r.c_size(scope.scalar) else {
        return;
    };
    let _ = writeln!(
        out,
        "/** Bytes of {c_name}_t (checked here and when the library builds). */\n\
         #define {upper}_SIZE {size}u\n"
    );
    doc_block(&translate(&r.doc, api, scope), "", out);
    let _ = writeln!(out, "typedef struct {c_name} {{");
    for (field, kind, doc) in &r.fields {
        let mut doc = translate(doc, api, scope);
        // A byte, whatever size the C compiler gives its enums (`-fshort-enums`).
        match kind {
            Field::Status => doc.push(format!("A {}_status_t.", api.model)),
            Field::Enum(e) => doc.push(format!("A {}_t.", record(prefix, e))),
            _ => {}
        }
        doc_block(&doc, "    ", out);
        let declaration = match kind {
            Field::Status | Field::Enum(_) => format!("uint8_t {field}"),
            Field::Flag => format!("bool {field}"),
            Field::Count { .. } => format!("uint32_t {field}"),
            Field::Value(Value::Vector(n)) => format!("{scalar} {field}[{n}]"),
            Field::Value(Value::Matrix(rows, cols)) => format!("{scalar} {field}[{rows}][{cols}]"),
            Field::Value(_) => format!("{scalar} {field}"),
        };
        let _ = writeln!(out, "    {declaration};");
    }
    let _ = writeln!(
        out,
        "}} {c_name}_t;\n\n\
         /* The struct's size as the header states it (a negative array size otherwise). */\n\
         typedef char {c_name}_size_check[(sizeof({c_name}_t) == {upper}_SIZE) ? 1 : -1];\n"
    );
}

/// A type's storage, its size and alignment, and its functions.
fn generated_type(api: &Api, scope: &Scope, ty: &Type, out: &mut String) {
    let c_name = format!("{}_{}", prefix(&api.model, scope), snake(&ty.name));
    let Some(size) = ty.storage else {
        let _ = writeln!(
            out,
            "/* {c_name}: not in the C API (the Rust type `{}` has a field whose layout the \
             tool cannot bound yet). */\n",
            ty.name
        );
        return;
    };
    let upper = c_name.to_ascii_uppercase();
    let mut doc = translate(&ty.doc, api, scope);
    doc.extend([
        String::new(),
        format!(
            "Storage for one, which the program reserves zeroed (a static, or an automatic \
             variable initialised with {{0}}: a method reads its tag first) and \
             {c_name}_new writes; its contents are private."
        ),
    ]);
    if !ty.left_out.is_empty() {
        doc.push(format!(
            "Not in the C API (an argument or result C cannot pass): {}.",
            ty.left_out.join(", ")
        ));
    }
    let _ = writeln!(
        out,
        "/** Bytes of {c_name}_t: at least the Rust type's (checked when the library builds). */\n\
         #define {upper}_SIZE {size}u\n\n\
         /** Alignment of {c_name}_t: at least the Rust type's (checked when the library builds). */\n\
         #define {upper}_ALIGN {}u\n",
        storage::ALIGN
    );
    doc_block(&doc, "", out);
    let _ = writeln!(
        out,
        "typedef union {c_name} {{\n    unsigned char bytes[{upper}_SIZE];\n    \
         uint64_t align_u64;\n    double align_double;\n}} {c_name}_t;\n\n\
         /* The storage's size as the header states it (a negative array size otherwise). */\n\
         typedef char {c_name}_size_check[(sizeof({c_name}_t) == {upper}_SIZE) ? 1 : -1];\n"
    );
    let this = snake(&ty.name);
    for m in &ty.methods {
        let name = format!("{c_name}_{}", m.name);
        let storage = m
            .takes_storage()
            .then_some((this.as_str(), c_name.as_str()));
        function_declaration(api, scope, &name, storage, m, out);
    }
}

/// A function's declaration and its documentation.
fn function_declaration(
    api: &Api,
    scope: &Scope,
    c_name: &str,
    this: Option<(&str, &str)>,
    m: &Method,
    out: &mut String,
) {
    let scalar = scope.scalar.c();
    let mut params = Vec::new();
    let mut doc = translate(&m.doc, api, scope);
    doc.push(String::new());
    if let Some((name, type_name)) = this {
        let constness = if m.receiver == Some(false) {
            "const "
        } else {
            ""
        };
        params.push(format!("{constness}{type_name}_t *{name}"));
        doc.push(match m.receiver {
            None => {
                format!("`{name}`: the storage to write; left as it was unless the status is OK.")
            }
            Some(_) => format!("`{name}`: storage {type_name}_new wrote."),
        });
    }
    for param in &m.params {
        let (name, value, optional) = match param {
            Param::Required(name, value) => (name, value, false),
            Param::Optional(name, value) => (name, value, true),
        };
        params.push(c_param(
            name,
            value,
            scalar,
            true,
            &prefix(&api.model, scope),
        ));
        if optional {
            doc.push(format!("`{name}`: may be NULL (none)."));
        }
    }
    output_param(api, scope, &m.output, &mut params, &mut doc);
    let status = format!("{}_STATUS", api.model.to_ascii_uppercase());
    doc.push(format!(
        "Returns {status}_NULL_POINTER or {status}_MISALIGNED_POINTER if a pointer is null or \
         misaligned{}, without reading or writing anything.",
        match m.receiver {
            Some(_) => format!(
                ", {status}_NOT_INITIALISED if `{}` was not written by a successful constructor",
                this.map_or("", |(name, _)| name)
            ),
            None => String::new(),
        }
    ));
    doc_block(&doc, "", out);
    let _ = writeln!(
        out,
        "{}_status_t {c_name}({});\n",
        api.model,
        params.join(", ")
    );
}

/// The parameter a result is written through, if one is, and its documentation.
fn output_param(
    api: &Api,
    scope: &Scope,
    output: &Output,
    params: &mut Vec<String>,
    doc: &mut Vec<String>,
) {
    let prefix = prefix(&api.model, scope);
    match output {
        Output::Value(v) | Output::Fallible(v) => {
            params.push(c_param("out", v, scope.scalar.c(), false, &prefix));
            doc.push("`out`: where the result is written (only if the status is OK).".to_owned());
        }
        Output::Outcome(name) => {
            let statuses = scope.outcome_statuses(name);
            params.push(format!("{}_t *out", record(&prefix, name)));
            let fields: Vec<String> = statuses.iter().map(|s| format!("`{s}`")).collect();
            let returned = match fields.as_slice() {
                [one] => format!("its {one}"),
                _ => format!(
                    "the first of its {} that is not OK, else OK",
                    fields.join(", ")
                ),
            };
            doc.push(format!(
                "`out`: may be NULL; else where the whole outcome is written. Returns \
                 {returned}."
            ));
        }
        _ => {}
    }
}

/// A parameter's declaration (`const float x0[5]`, `float gate`, `uint32_t *out`); a
/// record's type is named after `prefix`.
fn c_param(name: &str, value: &Value, scalar: &str, input: bool, prefix: &str) -> String {
    let constness = if input { "const " } else { "" };
    match value {
        Value::Record(r) => format!("{constness}{}_t *{name}", record(prefix, r)),
        Value::Scalar if input => format!("{scalar} {name}"),
        Value::Scalar => format!("{scalar} *{name}"),
        Value::Count => format!("uint32_t *{name}"),
        Value::Vector(n) => format!("{constness}{scalar} {name}[{n}]"),
        Value::Matrix(rows, cols) => format!("{constness}{scalar} {name}[{rows}][{cols}]"),
    }
}

/// The model's docs in the header's terms: its statuses, enums and functions by their C
/// names.
fn translate(lines: &[String], api: &Api, scope: &Scope) -> Vec<String> {
    let status = format!("{}_STATUS", api.model.to_ascii_uppercase());
    let prefix = prefix(&api.model, scope);
    lines
        .iter()
        .map(|line| {
            // Rustdoc's escaped brackets (`\[s\]`) are plain ones in C.
            let mut line = line.replace("\\[", "[").replace("\\]", "]");
            for (variant, _) in &api.statuses {
                let c = format!("{status}_{}", snake(variant).to_ascii_uppercase());
                line = line
                    .replace(&format!("[`Status::{variant}`]"), &c)
                    .replace(&format!("`Status::{variant}`"), &c);
            }
            for e in &scope.enums {
                let enum_prefix = record(&prefix, &e.name).to_ascii_uppercase();
                for (variant, _) in &e.variants {
                    let c = format!("{enum_prefix}_{}", snake(variant).to_ascii_uppercase());
                    line = line
                        .replace(&format!("[`{}::{variant}`]", e.name), &c)
                        .replace(&format!("`{}::{variant}`", e.name), &c);
                }
            }
            for ty in &scope.types {
                for m in &ty.methods {
                    let c = format!("{prefix}_{}_{}", snake(&ty.name), m.name);
                    line = line.replace(&format!("[`{}::{}`]", ty.name, m.name), &c);
                }
            }
            line
        })
        .collect()
}

/// `lines` as a `/** .. */` comment indented by `indent`.
fn doc_block(lines: &[String], indent: &str, out: &mut String) {
    let lines: Vec<String> = lines.iter().map(|l| comment_text(l)).collect();
    match lines.as_slice() {
        [] => {}
        [one] => {
            let _ = writeln!(out, "{indent}/** {one} */");
        }
        _ => {
            let _ = writeln!(out, "{indent}/**");
            for line in lines {
                let _ = writeln!(
                    out,
                    "{indent} *{}{line}",
                    if line.is_empty() { "" } else { " " }
                );
            }
            let _ = writeln!(out, "{indent} */");
        }
    }
}

/// Text safe inside a C comment: no `*/` to end it, no `/*` (which `-Wcomment` warns of),
/// no trigraph.
fn comment_text(text: &str) -> String {
    text.replace("*/", "* /")
        .replace("/*", "/ *")
        .replace("??", "? ?")
        .trim_end()
        .to_owned()
}
