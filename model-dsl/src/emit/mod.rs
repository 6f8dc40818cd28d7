//! Shared lowering stages: a checked model's graph to straight-line Rust. The generators
//! (`crate::generators`) compose these; [`crate::pipeline`] assembles the module.

pub mod arguments;
pub mod code;
pub mod continuous_filter;
pub mod filter;
pub mod in_place;
pub mod interop;
pub mod interval;
pub mod known;
pub mod lower;
pub mod measurement;
pub mod model_fns;
pub mod module_items;
pub mod names;
pub mod noise_blocks;
pub mod recovery;
pub mod registers;
pub mod scopes;
pub mod sensors;
pub mod status;
pub mod substeps;
pub mod tuning;
pub mod typed;
