//! Emitters: lower a checked model to Rust tokens. One emitter per generated item;
//! [`emit_model`] assembles them into the model's module.

pub mod code;
pub mod continuous_filter;
pub mod filter;
pub mod interop;
pub mod known;
pub mod lower;
pub mod model_fns;
pub mod names;
pub mod scopes;
pub mod status;
pub mod substeps;
pub mod tuning;

use crate::emit::lower::literal;
use crate::emit::model_fns::{
    emit_function, model_functions, named_ops_item, nonzero_item, ops_item,
};
use crate::emit::names::{ident, index_const};
use crate::generators::continuous_ekf::lower as ct_ekf;
use crate::generators::dkf::lower as dkf;
use crate::generators::ekf::lower as ekf;
use crate::generators::hybrid_ekf::lower as hybrid_ekf;
use crate::generators::lqr::lower as lqr;
use crate::generators::mpc::lower as mpc;
use crate::generators::polynomial_kf::lower as polynomial_kf;
use crate::generators::switched_observer::lower as switched_observer;
use crate::model::{Model, Scalar, Symbol};
use crate::symbolic::ModelGraph;
use proc_macro2::{Literal, TokenStream};
use quote::quote;

/// The whole generated module of `model`, or an error pointing at the generator the model
/// does not support (the window transform's class, say).
pub fn emit_model(model: &Model) -> syn::Result<TokenStream> {
    emit_model_with(model, &Options::default())
}

/// What the generated module holds beyond what the model asks for.
#[derive(Clone, Copy, Debug, Default)]
pub struct Options {
    /// An `interop` module converting the generated arrays to and from `nalgebra`
    /// matrices (the user's crate then depends on `nalgebra`).
    pub nalgebra: bool,
}

/// [`emit_model`], with `options`.
pub fn emit_model_with(model: &Model, options: &Options) -> syn::Result<TokenStream> {
    let mut mg = ModelGraph::build(model);
    let functions = model_functions(model, &mut mg);
    let Some((&primary, others)) = model.scalars.split_first() else {
        return Ok(TokenStream::new());
    };
    if let Some(spec) = &model.generate.dkf {
        // Derive once up front so a model outside the class is one clear error.
        let mut probe = mg.clone();
        if let Err(reason) = crate::generators::dkf::window::derive(model, &mut probe, spec.eta) {
            return Err(syn::Error::new(spec.span, format!("`dkf`: {reason}")));
        }
    }

    if let Some(spec) = &model.generate.polynomial_kf {
        let mut probe = mg.clone();
        if let Err(reason) =
            crate::generators::polynomial_kf::design::check_family(model, spec, &mut probe)
        {
            return Err(syn::Error::new(
                spec.span,
                format!("`polynomial_kf`: {reason}"),
            ));
        }
    }

    let switched = match &model.generate.switched_observer {
        Some(spec) => Some(switched_observer::designs(model, spec, &mg)?),
        None => None,
    };

    let mut ops_items = Vec::new();
    let mut primary_fns = Vec::new();
    for function in &functions {
        let (code, ops) = emit_function(model, &mg, function, primary);
        primary_fns.push(code);
        ops_items.push(ops_item(function, ops));
    }
    let looped_f = |scalar: Scalar| {
        model
            .dynamics
            .discretisation
            .is_looped()
            .then(|| substeps::looped_f(model, &mg, scalar))
    };
    if let Some((f, constant, ops)) = looped_f(primary) {
        primary_fns.insert(0, quote! { #constant #f });
        ops_items.insert(0, named_ops_item("F_OPS", "f", ops));
    }
    let nonzero_items = functions.iter().filter_map(|f| nonzero_item(f, &mg));
    let primary_consts = constants(model, primary);
    let filters = |scalar: Scalar, ops_items: &mut Vec<TokenStream>| {
        let mut tokens = TokenStream::new();
        for spec in &model.generate.ekf {
            let ekf = ekf::emit_ekf(model, spec, &mg, scalar);
            // `Ekf` gives `EKF_STEP_OPS`, `GatedEkf` `GATED_EKF_STEP_OPS`.
            let prefix = names::screaming_snake(&spec.type_name);
            for (method, ops) in [
                ("predict", ekf.predict_ops),
                ("update", ekf.update_ops),
                ("step", ekf.step_ops),
            ] {
                let constant = format!("{prefix}_{}_OPS", method.to_uppercase());
                let what = format!("{}::{method}", spec.type_name);
                ops_items.push(named_ops_item(&constant, &what, ops));
            }
            tokens.extend(ekf.tokens);
        }
        if let Some(spec) = &model.generate.dkf {
            if let Ok(dkf) = dkf::emit_dkf(model, spec, &mg, scalar) {
                ops_items.push(named_ops_item(
                    "DKF_TRANSFORM_OPS",
                    "the window transform of Dkf::step",
                    dkf.transform_ops,
                ));
                ops_items.push(named_ops_item(
                    "DKF_FILTERS_OPS",
                    "Dkf::step",
                    dkf.filters_ops,
                ));
                tokens.extend(dkf.tokens);
            }
        }
        if let Some(spec) = &model.generate.polynomial_kf {
            let kf = polynomial_kf::emit_polynomial_kf(model, spec, scalar);
            ops_items.push(named_ops_item(
                "POLYNOMIAL_KF_STEP_OPS",
                "PolynomialKf::step (recursive)",
                kf.step_ops,
            ));
            ops_items.push(named_ops_item(
                "POLYNOMIAL_KF_FIT_OPS",
                "PolynomialKf::step (re-initialising)",
                kf.fit_ops,
            ));
            tokens.extend(kf.tokens);
        }
        if let Some((regimes, designs)) = &switched {
            let code = switched_observer::emit_switched_observers(model, regimes, designs, scalar);
            ops_items.push(named_ops_item(
                "SWITCHED_OBSERVER_STEP_OPS",
                "the switched observers' step",
                code.step_ops,
            ));
            tokens.extend(code.tokens);
        }
        if let Some(spec) = &model.generate.lqr {
            let lqr = lqr::emit_lqr(model, spec, &mg, scalar);
            ops_items.push(named_ops_item("LQR_SOLVE_OPS", "Lqr::solve", lqr.solve_ops));
            tokens.extend(lqr.tokens);
        }
        if let Some(spec) = &model.generate.mpc {
            let mpc = mpc::emit_mpc(model, spec, &mg, scalar);
            for (constant, what, ops) in [
                (
                    "MPC_PREDICTION_OPS",
                    "the prediction model of Mpc::solve (squarings at their bound)",
                    mpc.prediction_ops,
                ),
                (
                    "MPC_RICCATI_OPS",
                    "the terminal weight's Riccati steps of Mpc::solve",
                    mpc.riccati_ops,
                ),
                (
                    "MPC_CONDENSE_OPS",
                    "the condensed problem of Mpc::solve",
                    mpc.condense_ops,
                ),
                (
                    "MPC_ITERATION_OPS",
                    "one active-set iteration of Mpc::solve",
                    mpc.iteration_ops,
                ),
            ] {
                ops_items.push(named_ops_item(constant, what, ops));
            }
            tokens.extend(mpc.tokens);
        }
        if let Some(spec) = &model.generate.hybrid_ekf {
            let hybrid = hybrid_ekf::emit_hybrid_ekf(model, spec, &mg, scalar);
            ops_items.push(named_ops_item(
                "HYBRID_EKF_SUBSTEP_OPS",
                "one sub-step of HybridEkf::step",
                hybrid.substep_ops,
            ));
            ops_items.push(named_ops_item(
                "HYBRID_EKF_STEP_OPS",
                "HybridEkf::step",
                hybrid.step_ops,
            ));
            tokens.extend(hybrid.tokens);
        }
        if let Some(spec) = &model.generate.continuous_ekf {
            let ct = ct_ekf::emit_continuous_ekf(model, spec, &mg, scalar);
            ops_items.push(named_ops_item(
                "CONTINUOUS_EKF_SUBSTEP_OPS",
                "one sub-step of ContinuousEkf::step",
                ct.substep_ops,
            ));
            ops_items.push(named_ops_item(
                "CONTINUOUS_EKF_STEP_OPS",
                "ContinuousEkf::step",
                ct.step_ops,
            ));
            tokens.extend(ct.tokens);
        }
        tokens
    };
    let primary_filters = filters(primary, &mut ops_items);
    let status = model.generate.any().then(status::status_enum);
    let secondary = others.iter().map(|&scalar| {
        let module = ident(&format!("in_{}", scalar.type_name()));
        let doc = format!(
            " The same model functions in `{}` (host-side checks and simulation).",
            scalar.type_name()
        );
        let consts = constants(model, scalar);
        let looped = looped_f(scalar).map(|(f, _, _)| quote! { use super::F_SUBSTEPS; #f });
        let fns = functions
            .iter()
            .map(|f| emit_function(model, &mg, f, scalar).0);
        let filters = filters(scalar, &mut Vec::new());
        let status = model
            .generate
            .any()
            .then(|| quote! { pub use super::Status; });
        quote! {
            #[doc = #doc]
            pub mod #module {
                #status
                #consts
                #looped
                #(#fns)*
                #filters
            }
        }
    });

    let docs = &model.docs;
    let vis = &model.vis;
    let name = ident(&model.name);
    let dims = dimensions(model);
    let op_count = op_count_struct();
    let index = index_module(model);
    let interop = options.nalgebra.then(interop::nalgebra_module);
    Ok(quote! {
        #(#[doc = #docs])*
        #vis mod #name {
            #op_count
            #dims
            #index
            #(#ops_items)*
            #(#nonzero_items)*
            #primary_consts
            #(#primary_fns)*
            #status
            #primary_filters
            #(#secondary)*
            #interop
        }
    })
}

/// The generated twin of [`lower::OpCount`], so generated code needs no support crate.
fn op_count_struct() -> TokenStream {
    quote! {
        /// Arithmetic one call of a generated function performs, counted from its code.
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        pub struct OpCount {
            /// Additions, subtractions and negations.
            pub add: u32,
            /// Multiplications.
            pub mul: u32,
            /// Divisions.
            pub div: u32,
            /// Library calls (`sin cos tan tanh exp ln sqrt abs atan2`, through `libm`).
            pub call: u32,
            /// Comparisons of piecewise terms.
            pub compare: u32,
        }
    }
}

fn dimensions(model: &Model) -> TokenStream {
    let [x_len, state_len, param_len, u_len, y_len] = [
        model.state_len(),
        model.states.len(),
        model.params.len(),
        model.inputs.len(),
        model.outputs.len(),
    ]
    .map(Literal::usize_unsuffixed);
    let x_names = model.state_names();
    let u_names = model.inputs.iter().map(|s| &s.name);
    let y_names = model.outputs.iter().map(|o| &o.name);
    let known = (!model.known.is_empty()).then(|| {
        let len = Literal::usize_unsuffixed(model.known.len());
        let names = model.known.iter().map(|s| &s.name);
        quote! {
            /// Number of constants known at run time (`known`): the model functions take
            /// them as `known`, the filters and the controller store them.
            pub const KNOWN_LEN: usize = #len;
            /// Names of the entries of `known`, in order.
            pub const KNOWN_NAMES: [&str; #len] = [#(#names),*];
        }
    });
    quote! {
        /// Length of the state vector `x`: the physical states, then the parameters.
        pub const X_LEN: usize = #x_len;
        /// Number of physical states, at the front of `x`.
        pub const STATE_LEN: usize = #state_len;
        /// Number of parameters (augmented random-walk states), at the back of `x`.
        pub const PARAM_LEN: usize = #param_len;
        /// Number of inputs `u`.
        pub const U_LEN: usize = #u_len;
        /// Number of outputs `y`.
        pub const Y_LEN: usize = #y_len;
        /// Names of the entries of `x`, in order.
        pub const X_NAMES: [&str; #x_len] = [#(#x_names),*];
        /// Names of the entries of `u`, in order.
        pub const U_NAMES: [&str; #u_len] = [#(#u_names),*];
        /// Names of the entries of `y`, in order.
        pub const Y_NAMES: [&str; #y_len] = [#(#y_names),*];
        #known
    }
}

fn index_module(model: &Model) -> TokenStream {
    let entry = |symbol: &Symbol, position: usize, vector: &str| {
        let position = Literal::usize_unsuffixed(position);
        let name = index_const(&symbol.name);
        let docs = &symbol.docs;
        let place = format!(" Position of `{}` in `{vector}`.", symbol.name);
        let separator = (!docs.is_empty()).then(|| quote! { #[doc = ""] });
        quote! {
            #(#[doc = #docs])*
            #separator
            #[doc = #place]
            pub const #name: usize = #position;
        }
    };
    let states = model
        .states
        .iter()
        .chain(&model.params)
        .enumerate()
        .map(|(i, s)| entry(s, i, "x"));
    let inputs = model
        .inputs
        .iter()
        .enumerate()
        .map(|(i, s)| entry(s, i, "u"));
    let outputs = model.outputs.iter().enumerate().map(|(i, o)| {
        let symbol = Symbol {
            docs: o.docs.clone(),
            name: o.name.clone(),
        };
        entry(&symbol, i, "y")
    });
    let known = model
        .known
        .iter()
        .enumerate()
        .map(|(i, s)| entry(s, i, "known"));
    quote! {
        /// Positions of the named entries of `x`, `u` and `y`, with their documentation.
        pub mod index {
            #(#states)*
            #(#inputs)*
            #(#outputs)*
            #(#known)*
        }
    }
}

fn constants(model: &Model, scalar: Scalar) -> TokenStream {
    let ty = ident(scalar.type_name());
    let items = model.constants.iter().map(|c| {
        let name = ident(&c.name);
        let value = literal(c.value, scalar);
        let fallback = format!(" Model constant `{}`.", c.name);
        let docs = if c.docs.is_empty() {
            vec![fallback]
        } else {
            c.docs.clone()
        };
        quote! {
            #(#[doc = #docs])*
            pub const #name: #ty = #value;
        }
    });
    quote! { #(#items)* }
}
