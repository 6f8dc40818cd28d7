//! The companion crate's `lib.rs`: per generated type, the storage C reserves (its size
//! and alignment asserted against the Rust type's at compile time), and one `extern "C"`
//! function per method, which checks every pointer before it reads or writes through it
//! and returns the status as a C enum. Its `unsafe` blocks are the crate's only ones,
//! each with the reason it is sound.

use super::mirrors::mirrors;
use super::names::{camel, prefix, record, snake, REFUSALS};
use super::reading::{Api, Method, Output, Param, Scope, Type, Value};
use super::storage;
use std::fmt::Write;

/// The code of `lib.rs`.
pub fn lib(api: &Api, provenance: &str) -> String {
    let mut out = format!(
        "{provenance}\n//! The C API of the `{model}` model: `extern \"C\"` functions over its \
         generated filters and controllers (`model`), declared in `include/{model}.h`.\n\n\
         #![no_std]\n#![deny(unsafe_op_in_unsafe_fn, clippy::undocumented_unsafe_blocks)]\n\n\
         #[macro_use]\nmod support;\n\n\
         /// The model's generated code: its own crate, `forbid(unsafe_code)`.\n\
         pub use {model}_model as model;\n\n\
         use support::Slot;\n\n",
        model = api.model
    );
    status(api, &mut out);
    let status = status_type(api);
    for scope in &api.scopes {
        let path = format!("model::{}", scope.module);
        mirrors(api, scope, &path, &status, &mut out);
        for ty in &scope.types {
            generated_type(api, scope, &path, ty, &mut out);
        }
        let prefix = prefix(&api.model, scope);
        for function in &scope.functions {
            let wrapped = Wrapped {
                c_name: format!("{prefix}_{}", function.name),
                status: &status,
                this: None,
                call: format!("{path}::{}", function.name),
                prefix: prefix.clone(),
                scope,
            };
            method(&wrapped, function, &mut out);
        }
    }
    out.push_str(PANIC_HANDLER);
    out
}

/// Never called: no panic is reachable from a wrapper (the generated code has no
/// indexing and no arithmetic that checks, `stateforge_math`'s loops index within their
/// bounds, every refusal is a status, and the tests find no panic in the release
/// library's symbols), but a `no_std` library must name a handler.
const PANIC_HANDLER: &str =
    "\n/// Never called: no panic is reachable from a function of this crate (the \
    generated code has no indexing, and every refusal is a status), but a `no_std` library \
    names a handler.\n\
    #[cfg(not(test))]\n#[panic_handler]\nfn panic(_: &core::panic::PanicInfo) -> ! {\n    \
    loop {}\n}\n";

/// The Rust name of the C status enum (`CantileverStatus`).
fn status_type(api: &Api) -> String {
    format!("{}Status", camel(&api.model))
}

/// The C status enum, and its conversions from the model's `Status` and a refusal.
fn status(api: &Api, out: &mut String) {
    let name = status_type(api);
    let _ = writeln!(
        out,
        "/// What a C function did: the model's `Status`, or why it refused a pointer.\n\
         #[repr(C)]\n#[derive(Clone, Copy, Debug, PartialEq, Eq)]\npub enum {name} {{"
    );
    for (i, (variant, doc)) in api.statuses.iter().enumerate() {
        let _ = writeln!(out, "    /// {}\n    {variant} = {i},", doc.join(" "));
    }
    for (i, (variant, _, doc)) in REFUSALS.iter().enumerate() {
        let _ = writeln!(out, "    /// {doc}\n    {variant} = {},", 100 + i);
    }
    let status_path = format!("model::{}::Status", api.model);
    let _ = writeln!(
        out,
        "}}\n\nimpl From<{status_path}> for {name} {{\n    \
         fn from(status: {status_path}) -> Self {{\n        match status {{"
    );
    for (variant, _) in &api.statuses {
        let _ = writeln!(
            out,
            "            {status_path}::{variant} => {name}::{variant},"
        );
    }
    let _ = writeln!(
        out,
        "        }}\n    }}\n}}\n\nimpl From<support::Refused> for {name} {{\n    \
         fn from(refused: support::Refused) -> Self {{\n        match refused {{"
    );
    for (variant, refused, _) in REFUSALS {
        let _ = writeln!(
            out,
            "            support::Refused::{refused} => {name}::{variant},"
        );
    }
    let _ = writeln!(out, "        }}\n    }}\n}}\n");
}

/// A type's storage, its size check and its functions.
fn generated_type(api: &Api, scope: &Scope, path: &str, ty: &Type, out: &mut String) {
    let Some(size) = ty.storage else {
        let _ = writeln!(
            out,
            "// `{}` has a field of a type whose layout the tool cannot bound: no C API.\n",
            ty.name
        );
        return;
    };
    let c_name = format!("{}_{}", prefix(&api.model, scope), snake(&ty.name));
    let storage_name = camel(&c_name);
    let rust_type = format!("{path}::{}", ty.name);
    let align = storage::ALIGN;
    let _ = writeln!(
        out,
        "/// The storage of a [`{rust_type}`], `{c_name}_t` in C: {size} bytes aligned to \
         {align}, which a C program reserves zeroed (a `static`, or an automatic variable \
         initialised with `{{0}}`) and `{c_name}_new` writes.\n\
         #[repr(C, align({align}))]\npub struct {storage_name} {{\n    bytes: [u8; {size}],\n}}\n\n\
         // The storage holds the Rust type with its tag: checked when this crate builds.\n\
         const _: () = assert!(\n    \
         core::mem::size_of::<Slot<{rust_type}>>() <= core::mem::size_of::<{storage_name}>()\n        \
         && core::mem::align_of::<Slot<{rust_type}>>() <= core::mem::align_of::<{storage_name}>()\n        \
         && core::mem::size_of::<{storage_name}>() == {size}\n);\n"
    );
    let status = status_type(api);
    for m in &ty.methods {
        let wrapped = Wrapped {
            c_name: format!("{c_name}_{}", m.name),
            status: &status,
            this: m
                .takes_storage()
                .then(|| (snake(&ty.name), storage_name.as_str(), rust_type.as_str())),
            call: format!("{rust_type}::{}", m.name),
            prefix: prefix(&api.model, scope),
            scope,
        };
        method(&wrapped, m, out);
    }
}

/// What one `extern "C"` function wraps.
struct Wrapped<'a> {
    /// Its C name (`cantilever_ekf_step`).
    c_name: String,
    /// The Rust name of the status enum.
    status: &'a str,
    /// The storage argument's name, its Rust type and the generated type's path; `None`
    /// for a free function.
    this: Option<(String, &'a str, &'a str)>,
    /// The path of the wrapped function (`model::cantilever::Ekf::step`).
    call: String,
    /// Its scope's C prefix (`cantilever`, `cantilever_f64`), which its records' names
    /// start with.
    prefix: String,
    /// Its scope.
    scope: &'a Scope,
}

/// One `extern "C"` function.
fn method(w: &Wrapped, m: &Method, out: &mut String) {
    let (params, body, args) = arguments(w, m);
    let receiver = w.this.as_ref().map(|(name, _, _)| name.as_str());
    let invocation = match (receiver, m.receiver) {
        (Some(name), Some(_)) => format!("{name}.{}({})", m.name, args.join(", ")),
        _ => format!("{}({})", w.call, args.join(", ")),
    };
    let statuses = match &m.output {
        Output::Outcome(name) => w.scope.outcome_statuses(name),
        _ => Vec::new(),
    };
    let tail = tail(
        &invocation,
        receiver.unwrap_or("out"),
        w.status,
        &m.output,
        &statuses,
    );
    let _ = writeln!(
        out,
        "/// The C form of [`{call}`]: its status, or why it refused a pointer; see the \
         header.\n///\n/// # Safety\n///\n/// Each pointer is null or valid for reading (a \
         `const` one) or writing what it points to during the call, and none overlaps \
         another.\n#[no_mangle]\npub unsafe extern \"C\" fn {c_name}({}) -> {status} {{\n{body}    {tail}\n}}\n",
        params.join(", "),
        call = w.call,
        c_name = w.c_name,
        status = w.status,
    );
}

/// A function's parameters, the checks of its pointers, and the arguments of the call.
///
/// Every pointer that may not be null is checked first, all together (one branch for any
/// null, one for any misaligned), and a method's storage's tag with them; only then is
/// each read. A method's checks are `support::value` (`value_mut`), the others'
/// `support::checked`.
fn arguments(w: &Wrapped, m: &Method) -> (Vec<String>, String, Vec<String>) {
    let mut params = Vec::new();
    let mut checked = Vec::new();
    let mut reads = String::new();
    let mut args = Vec::new();
    for param in &m.params {
        let (name, value, optional) = match param {
            Param::Required(name, value) => (name, value, false),
            Param::Optional(name, value) => (name, value, true),
        };
        let ty = rust_value(value, w);
        args.push(name.clone());
        if *value == Value::Scalar {
            params.push(format!("{name}: {ty}"));
            continue;
        }
        params.push(format!("{name}: *const {ty}"));
        let _ = if optional {
            writeln!(
                reads,
                "    // SAFETY: `{name}` is null or valid for reads of `{ty}` during the call, \
                 as `# Safety` requires; `support::read_optional` checks the rest.\n    \
                 let {name} = take!(unsafe {{ support::read_optional({name}) }});"
            )
        } else {
            checked.push(format!("({name} as usize, core::mem::align_of::<{ty}>())"));
            writeln!(
                reads,
                "    // SAFETY: `{name}` is valid for reads of `{ty}` during the call, as \
                 `# Safety` requires, and neither null nor misaligned (checked above).\n    \
                 let {name} = unsafe {{ support::read({name}) }};"
            )
        };
    }
    if let Some(out) = output_pointer(w, &m.output, &mut checked, &mut reads) {
        params.push(out);
    }
    let body = match &w.this {
        Some((name, storage_name, rust_type)) => {
            let (param, checks) = storage(name, storage_name, rust_type, m.receiver, checked);
            params.insert(0, param);
            checks + &reads
        }
        None if checked.is_empty() => reads,
        None => format!(
            "    take!(support::checked([{}]));\n{reads}",
            checked.join(", ")
        ),
    };
    (params, body, args)
}

/// The parameter of the pointer a result is written through, if one is: its entry in the
/// checks (an outcome's may be null, and is checked on its own), and its read.
fn output_pointer(
    w: &Wrapped,
    output: &Output,
    checked: &mut Vec<String>,
    reads: &mut String,
) -> Option<String> {
    let ty = match output {
        Output::Value(v) | Output::Fallible(v) => rust_value(v, w),
        Output::Outcome(name) => rust_value(&Value::Record(name.clone()), w),
        _ => return None,
    };
    let _ = if matches!(output, Output::Outcome(_)) {
        writeln!(
            reads,
            "    // SAFETY: `out` is null or valid for writes of `{ty}`, unaliased, during the \
             call, as `# Safety` requires; `support::out_optional` checks the rest.\n    \
             let out = take!(unsafe {{ support::out_optional(out) }});"
        )
    } else {
        checked.push(format!("(out as usize, core::mem::align_of::<{ty}>())"));
        writeln!(
            reads,
            "    // SAFETY: `out` is valid for writes of `{ty}`, unaliased, during the call, as \
             `# Safety` requires, and neither null nor misaligned (checked above).\n    \
             let out = unsafe {{ support::out(out) }};"
        )
    };
    Some(format!("out: *mut {ty}"))
}

/// The storage argument of a generated type's function: its parameter, and the checks of
/// all pointers with it (`checked`: the others'), which end in its read. A method's
/// storage is read by `support::value` (`value_mut`), which also checks its tag; a
/// constructor's is written, its pointer checked with the others.
fn storage(
    name: &str,
    storage_name: &str,
    rust_type: &str,
    receiver: Option<bool>,
    mut checked: Vec<String>,
) -> (String, String) {
    let (mutability, access, what) = match receiver {
        None => ("mut", "slot", "valid for writes of its storage"),
        Some(true) => (
            "mut",
            "value_mut",
            "null or valid for reads and writes of its storage, its tag initialised",
        ),
        Some(false) => (
            "const",
            "value",
            "null or valid for reads of its storage, its tag initialised",
        ),
    };
    let param = format!("{name}: *{mutability} {storage_name}");
    if receiver.is_none() {
        checked.insert(
            0,
            format!("({name} as usize, core::mem::align_of::<{storage_name}>())"),
        );
        let checks = format!(
            "    take!(support::checked([{}]));\n    \
             // SAFETY: `{name}` is {what}, unaliased, as `# Safety` requires, and neither \
             null nor misaligned (checked above).\n    \
             let {name} = unsafe {{ support::{access}::<_, {rust_type}>({name}) }};\n",
            checked.join(", ")
        );
        return (param, checks);
    }
    let checks = format!(
        "    // SAFETY: `{name}` is {what}, unaliased, as `# Safety` requires; \
         `support::{access}` checks it, with the other pointers, before it reads it.\n    \
         let {name} = take!(unsafe {{ support::{access}::<_, {rust_type}, _>({name}, [{}]) }});\n",
        checked.join(", ")
    );
    (param, checks)
}

/// The end of a function: the call, its result written, its status returned (an
/// outcome's: the first of its `statuses` that is not `Ok`).
fn tail(
    invocation: &str,
    storage: &str,
    status: &str,
    output: &Output,
    statuses: &[&str],
) -> String {
    let ok = format!("{status}::Ok");
    let written = |target: &str, value: &str| {
        format!(
            "match {invocation} {{\n        Ok(value) => {{\n            {target}.write({value});\n            \
             {ok}\n        }}\n        Err(status) => status.into(),\n    }}"
        )
    };
    match output {
        Output::Status => format!("{invocation}.into()"),
        Output::Nothing => format!("{invocation};\n    {ok}"),
        Output::Value(Value::Record(_)) => format!("out.write({invocation}.into());\n    {ok}"),
        Output::Value(_) => format!("out.write({invocation});\n    {ok}"),
        Output::Fallible(Value::Record(_)) => written("out", "value.into()"),
        Output::Fallible(_) => written("out", "value"),
        Output::Outcome(_) => outcome(invocation, status, statuses),
        Output::Constructed { fallible: true } => written(storage, "Slot::new(value)"),
        Output::Constructed { fallible: false } => {
            format!("{storage}.write(Slot::new({invocation}));\n    {ok}")
        }
    }
}

/// The end of a function whose result is an outcome: written through `out` if it is not
/// null, and the first of its `statuses` that is not `Ok` returned.
fn outcome(invocation: &str, status: &str, statuses: &[&str]) -> String {
    let fields: Vec<String> = statuses.iter().map(|f| format!("outcome.{f}")).collect();
    let returned = match fields.as_slice() {
        [one] => format!("{one}.into()"),
        _ => format!(
            "[{}]\n        .into_iter()\n        .map({status}::from)\n        \
             .find(|status| *status != {status}::Ok)\n        .unwrap_or({status}::Ok)",
            fields.join(", ")
        ),
    };
    format!(
        "let outcome = {invocation};\n    if let Some(out) = out {{\n        \
         out.write(outcome.into());\n    }}\n    {returned}"
    )
}

/// A value's Rust type.
fn rust_value(value: &Value, w: &Wrapped) -> String {
    value.rust(w.scope.scalar, &|name| camel(&record(&w.prefix, name)))
}
