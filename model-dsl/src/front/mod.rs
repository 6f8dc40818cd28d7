//! Front ends: each reads one way of writing a model into a [`crate::ast::ModelDecl`].

pub mod limits;
pub mod macro_syntax;
pub mod model_file;
