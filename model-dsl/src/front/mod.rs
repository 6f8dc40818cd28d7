//! The `model!` front end: reads the macro's tokens (or a Rust file's `model!` invocation,
//! [`source_file`]) into a [`crate::ast::ModelDecl`]
//! within the [`limits`] every front end keeps (the model-file front end, in
//! `model-codegen`, checks its expression text with them too).

pub mod limits;
pub mod macro_syntax;
pub mod source_file;
