//! A stage of the MPC's generated code: statements that bind some values by name, and
//! what they cost.

use crate::emit::lower::OpCount;
use proc_macro2::TokenStream;

/// Code that computes some values under given names, and what it costs.
pub struct Stage {
    /// The statements.
    pub code: TokenStream,
    /// Their arithmetic.
    pub ops: OpCount,
}
