//! The names the MPC's generated `solve` gives its values, and its early return: shared
//! by the prediction, condensing and active-set stages.

use crate::emit::filter::model_names;
use crate::emit::names::{clear_of, matrix_entry, TempNamer};
use crate::model::Model;
use proc_macro2::TokenStream;
use quote::quote;

/// Names the generated `solve` gives its values, kept clear of the model's names.
pub struct Names {
    /// The model's names, which generated names avoid.
    pub taken: Vec<String>,
}

impl Names {
    pub fn new(model: &Model) -> Names {
        Names {
            taken: model_names(model),
        }
    }

    /// A namer for temporaries that avoids the model's names.
    pub fn namer(&self) -> TempNamer {
        TempNamer::new(self.taken.iter().map(String::as_str))
    }

    /// Whether a model name takes `name`.
    pub fn takes(&self, name: &str) -> bool {
        self.taken.iter().any(|t| t == name)
    }

    /// `base`, with `_` appended while a model name takes it.
    pub fn fresh(&self, base: &str) -> String {
        clear_of(base, |name| self.takes(name))
    }

    /// Names as [`Names::fresh`] for the entries of a `rows x cols` matrix
    /// ([`matrix_entry`]: `a12`, or `a_1_12` when an index has two digits).
    pub fn matrix(&self, prefix: &str, rows: usize, cols: usize) -> Vec<Vec<String>> {
        (1..=rows)
            .map(|i| {
                (1..=cols)
                    .map(|j| self.fresh(&matrix_entry(prefix, (rows, cols), (i, j))))
                    .collect()
            })
            .collect()
    }
}

/// `return MpcStatus { status, .. };` for a solve that changed nothing.
pub fn failure(status: TokenStream) -> TokenStream {
    quote! {
        return MpcStatus {
            status: #status,
            optimal: false,
            iterations: 0,
            terminal_weight_converged: false,
            rebuilt: MpcRebuild::Nothing,
        };
    }
}
