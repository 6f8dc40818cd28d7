//! The pipeline from a checked model to its generated module: the model functions and
//! their Jacobians, then every generator the model asks for, designed once and lowered
//! for each scalar type. It iterates over the generators and knows none by name.

use crate::check::Checked;
use crate::emit::model_fns::{
    cycles_item, emit_function, model_functions, named_ops_item, nonzero_item, ops_item,
    ModelFunction,
};
use crate::emit::module_items::{constants, dimensions, index_module, op_count_struct};
use crate::emit::names::ident;
use crate::emit::{interop, status, substeps};
use crate::generators::{Budget, Cost, Lowering};
use crate::model::{Model, Scalar};
use crate::symbolic::ModelGraph;
use crate::timing::{Estimate, CORTEX_M4F};
use proc_macro2::TokenStream;
use quote::quote;

/// What the generated module holds beyond what the model asks for.
#[derive(Clone, Copy, Debug, Default)]
pub struct Options {
    /// An `interop` module converting the generated arrays to and from `nalgebra`
    /// matrices (the user's crate then depends on `nalgebra`).
    pub nalgebra: bool,
}

/// The whole generated module of `checked`, or an error pointing at the generator the
/// model does not support (the window transform's class, say).
pub fn emit_model(checked: &Checked) -> syn::Result<TokenStream> {
    emit_model_with(checked, &Options::default())
}

/// [`emit_model`], with `options`.
pub fn emit_model_with(checked: &Checked, options: &Options) -> syn::Result<TokenStream> {
    let model = &checked.model;
    let mut mg = ModelGraph::build(model);
    let functions = model_functions(model, &mut mg);
    let Some((&primary, others)) = model.scalars.split_first() else {
        return Ok(TokenStream::new());
    };
    let designs = designs(checked, &mg)?;
    let module = Module {
        model,
        mg: &mg,
        functions: &functions,
        designs: &designs,
        budgets: &checked.budgets,
    };
    let (primary_items, ops_items, over_budget) = module.primary(primary);
    if let Some(error) = over_budget {
        return Err(error);
    }
    let secondary = others.iter().map(|&scalar| module.secondary(scalar));
    let docs = &model.docs;
    let vis = &model.vis;
    let name = ident(&model.name);
    let op_count = op_count_struct();
    let dims = dimensions(model);
    let index = index_module(model);
    let nonzero_items = functions.iter().filter_map(|f| nonzero_item(f, &mg));
    let interop = options.nalgebra.then(interop::nalgebra_module);
    Ok(quote! {
        #(#[doc = #docs])*
        #vis mod #name {
            #op_count
            #dims
            #index
            #(#ops_items)*
            #(#nonzero_items)*
            #primary_items
            #(#secondary)*
            #interop
        }
    })
}

/// Every generator's design, or all their errors at once.
fn designs(checked: &Checked, mg: &ModelGraph) -> syn::Result<Vec<Box<dyn Lowering>>> {
    let mut designs = Vec::new();
    let mut errors: Option<syn::Error> = None;
    for generator in &checked.generators {
        match generator.design(&checked.model, mg) {
            Ok(design) => designs.push(design),
            Err(error) => match &mut errors {
                Some(all) => all.combine(error),
                None => errors = Some(error),
            },
        }
    }
    errors.map_or(Ok(designs), Err)
}

/// What every scalar type's items are made of.
struct Module<'a> {
    model: &'a Model,
    mg: &'a ModelGraph,
    functions: &'a [ModelFunction],
    designs: &'a [Box<dyn Lowering>],
    /// Each design's cycle budget, if its `generate` item gives one.
    budgets: &'a [Option<Budget>],
}

impl Module<'_> {
    /// The items in the primary scalar type, at the module's top, the `*_OPS` (and, in
    /// `f32`, `*_CYCLES`) constants that count their arithmetic, and the errors of the
    /// calls over their budgets.
    fn primary(&self, scalar: Scalar) -> (TokenStream, Vec<TokenStream>, Option<syn::Error>) {
        let (model, mg) = (self.model, self.mg);
        let mut ops_items = Vec::new();
        let mut fns = Vec::new();
        for function in self.functions {
            let (code, ops) = emit_function(model, mg, function, scalar);
            fns.push(code);
            ops_items.push(ops_item(function, ops));
        }
        if let Some((f, constant, ops)) = self.looped_f(scalar) {
            fns.insert(0, quote! { #constant #f });
            ops_items.insert(0, named_ops_item("F_OPS", "f", ops));
        }
        let consts = constants(model, scalar);
        let views = crate::emit::typed::typed_views(model, scalar);
        let status = (!self.designs.is_empty()).then(|| status::status_enum(model));
        let mut over_budget = None;
        let generated = self.generated(scalar, &mut ops_items, &mut over_budget);
        let tokens = quote! {
            #consts
            #views
            #(#fns)*
            #status
            #generated
        };
        (tokens, ops_items, over_budget)
    }

    /// The same items in another scalar type, in a module `in_f64` (say).
    fn secondary(&self, scalar: Scalar) -> TokenStream {
        let (model, mg) = (self.model, self.mg);
        let module = ident(&format!("in_{}", scalar.type_name()));
        let doc = format!(
            " The same model functions in `{}` (host-side checks and simulation).",
            scalar.type_name()
        );
        let consts = constants(model, scalar);
        let views = crate::emit::typed::typed_views(model, scalar);
        let looped = self
            .looped_f(scalar)
            .map(|(f, _, _)| quote! { use super::F_SUBSTEP_PAIRS; #f });
        let fns = self
            .functions
            .iter()
            .map(|f| emit_function(model, mg, f, scalar).0);
        let generated = self.generated(scalar, &mut Vec::new(), &mut None);
        let status = (!self.designs.is_empty()).then(|| quote! { pub use super::Status; });
        // A filter may name places in `x` or `y` (`index::Q_X`: a rotation's; a sensor's
        // outputs), as the items at the module's top do.
        let index = names_index(&generated).then(|| quote! { use super::index; });
        quote! {
            #[doc = #doc]
            pub mod #module {
                #status
                #index
                #consts
                #views
                #looped
                #(#fns)*
                #generated
            }
        }
    }

    /// The sample step as a loop over its sub-steps, when they are too many to unroll.
    fn looped_f(
        &self,
        scalar: Scalar,
    ) -> Option<(TokenStream, TokenStream, crate::emit::lower::OpCount)> {
        let looped = self.model.dynamics.discretisation.is_looped();
        looped.then(|| substeps::looped_f(self.model, self.mg, scalar))
    }

    /// Every generator's items in `scalar`; their costs go to `ops_items`, and the
    /// errors of calls over their budgets to `over_budget`.
    fn generated(
        &self,
        scalar: Scalar,
        ops_items: &mut Vec<TokenStream>,
        over_budget: &mut Option<syn::Error>,
    ) -> TokenStream {
        let mut tokens = TokenStream::new();
        for (design, budget) in self.designs.iter().zip(self.budgets) {
            let code = design.lower(self.model, self.mg, scalar);
            let mut errors = cost_items(&code.costs, budget.as_ref(), scalar, ops_items);
            if let (Some(budget), Scalar::F64) = (budget, scalar) {
                errors.push(budget.needs_f32());
            }
            for error in errors {
                match over_budget {
                    Some(all) => all.combine(error),
                    None => *over_budget = Some(error),
                }
            }
            tokens.extend(code.tokens);
        }
        tokens
    }
}

/// Whether `tokens` name a place of the `index` module (`index::Q_X`).
fn names_index(tokens: &TokenStream) -> bool {
    let mut previous_index = false;
    for tree in tokens.clone() {
        match tree {
            proc_macro2::TokenTree::Group(group) if names_index(&group.stream()) => return true,
            proc_macro2::TokenTree::Ident(ident) => {
                previous_index = ident == "index";
                continue;
            }
            proc_macro2::TokenTree::Punct(punct) if previous_index && punct.as_char() == ':' => {
                return true
            }
            _ => {}
        }
        previous_index = false;
    }
    false
}

/// The `*_OPS` items of a generator's costs and, in `f32` (the microcontroller's code),
/// their `*_CYCLES` items; returns the errors of the calls over `budget` (and of its
/// schedule's load).
fn cost_items(
    costs: &[Cost],
    budget: Option<&Budget>,
    scalar: Scalar,
    items: &mut Vec<TokenStream>,
) -> Vec<syn::Error> {
    let estimates: Vec<Estimate> = costs
        .iter()
        .map(|cost| match cost.is_part {
            true => CORTEX_M4F.estimate_part(&cost.ops),
            false => CORTEX_M4F.estimate(&cost.ops),
        })
        .collect();
    for (cost, estimate) in costs.iter().zip(&estimates) {
        items.push(named_ops_item(&cost.constant, &cost.what, cost.ops));
        if scalar == Scalar::F32 {
            items.push(cycles_item(
                (&cost.constant, &cost.what, cost.is_part),
                estimate,
                &CORTEX_M4F,
            ));
        }
    }
    let estimated: Vec<(&Cost, &Estimate)> = costs.iter().zip(&estimates).collect();
    match budget {
        Some(budget) if scalar == Scalar::F32 => budget.check(&estimated, &CORTEX_M4F),
        _ => Vec::new(),
    }
}
