//! The C names of what the C API offers: functions and types after the model, the scalar
//! and the generated type (`cantilever_f64_gated_ekf_new`), their Rust storage types in
//! camel case, and the statuses the wrapper adds to the model's.

use super::reading::Scope;

/// The status variants the wrapper adds to the model's, after them: a pointer refused.
pub const REFUSALS: [(&str, &str, &str); 3] = [
    ("NullPointer", "Null", "A pointer argument was null."),
    (
        "MisalignedPointer",
        "Misaligned",
        "A pointer argument was not aligned for its type (4 bytes for `float`, 8 for \
         `double` and the storage types).",
    ),
    (
        "NotInitialised",
        "NotInitialised",
        "The storage passed was not written by a successful constructor (`*_new`).",
    ),
];

/// `GatedEkf` -> `gated_ekf`: a type's name as the C functions spell it, as the
/// generated code's own names do.
pub use crate::generated_api::snake;

/// `cantilever_f64` -> `CantileverF64`: a C name as a Rust type's.
pub fn camel(name: &str) -> String {
    name.split('_')
        .map(|word| {
            let mut chars = word.chars();
            chars.next().map_or_else(String::new, |first| {
                first.to_ascii_uppercase().to_string() + chars.as_str()
            })
        })
        .collect()
}

/// The prefix of a scope's C names: the model's name, then the scalar for every scalar
/// type but the first (`cantilever`, `cantilever_f64`).
pub fn prefix(model: &str, scope: &Scope) -> String {
    match scope.first {
        true => model.to_owned(),
        false => format!("{model}_{}", scope.scalar.rust()),
    }
}

/// The C name of a record or enum of the scope whose names start with `prefix`
/// (`cantilever_dkf_status`, `cantilever_f64_window_status`), without `_t`; its Rust
/// mirror's is its camel case.
pub fn record(prefix: &str, name: &str) -> String {
    format!("{prefix}_{}", snake(name))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_in_c() {
        assert_eq!(snake("GatedEkf"), "gated_ekf");
        assert_eq!(snake("Lqr"), "lqr");
        assert_eq!(snake("Ekf2"), "ekf2");
        assert_eq!(camel("cantilever_f64_gated_ekf"), "CantileverF64GatedEkf");
    }
}
