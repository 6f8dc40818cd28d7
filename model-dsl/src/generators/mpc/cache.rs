//! What one solve keeps for the next: the prediction model, with the terminal weight and
//! the condensed Hessian built on it, and the estimate's values it was built at. While
//! those values stay within `MODEL_TOLERANCE` of them (relative), and the terminal weight
//! had converged, the next solve skips the prediction model, the Riccati steps and the
//! Hessian: only the linear term (eq. 44), which depends on the estimate itself, and the
//! active-set solve run. With the default tolerance, zero, the model is kept only when
//! it would be rebuilt bit for bit the same.

use crate::emit::code::destructure;
use crate::emit::lower::{literal, OpCount};
use crate::emit::names::ident;
use crate::model::Scalar;
use crate::symbolic::{Graph, ModelGraph, Node, NodeId, VarId};
use proc_macro2::{Ident, Literal, TokenStream};
use quote::quote;
use std::collections::BTreeSet;

/// The values the prediction model reads, and the kept values' names.
pub struct Cache {
    /// The estimate's (and operating input's, and time's) entries the prediction model
    /// reads, as the solve names them.
    key: Vec<Ident>,
    /// Statements that bind [`Cache::key`] from `x` and `u`.
    read_key: TokenStream,
    /// What is kept of the condensed Hessian.
    hessian: KeptHessian,
    /// The weighted responses `S_(i+1) B`, flat: names, or literals that stay literals.
    weighted_stored: Vec<TokenStream>,
    /// The same as a pattern: names, or `_` for literals.
    weighted_pattern: Vec<TokenStream>,
}

impl Cache {
    /// The cache of a solve whose prediction model reads `used`, whose Hessian entries are
    /// named `hessian` and whose weighted responses are the nodes `weighted`.
    pub fn new(
        mg: &ModelGraph,
        used: &BTreeSet<VarId>,
        hessian: KeptHessian,
        weighted: &[NodeId],
        scalar: Scalar,
    ) -> Cache {
        let g = &mg.graph;
        let mut key: Vec<Ident> = Vec::new();
        let mut inputs = mg.x.clone();
        inputs.extend(&mg.u);
        inputs.push(mg.t);
        for node in inputs {
            if let Node::Var(v) = g.node(node) {
                if used.contains(&v) {
                    key.push(ident(&g.var_info(v).name));
                }
            }
        }
        let read_x = destructure(g, quote! { *x }, &mg.x, used);
        let read_u = destructure(g, quote! { *u }, &mg.u, used);
        Cache {
            key,
            read_key: quote! { #read_x #read_u },
            hessian,
            weighted_stored: weighted.iter().map(|&w| stored(g, w, scalar)).collect(),
            weighted_pattern: weighted.iter().map(|&w| pattern(g, w)).collect(),
        }
    }

    /// The lengths of the kept key and weighted responses, as literals.
    fn field_lengths(&self) -> [Literal; 2] {
        [self.key.len(), self.weighted_stored.len()].map(Literal::usize_unsuffixed)
    }

    /// The fields of `Mpc` that keep the model, in the scalar type `ty`.
    pub fn fields(&self, ty: &Ident) -> TokenStream {
        let [key, weighted] = self.field_lengths();
        let hessian = self.hessian.field(&quote! { #ty });
        let weighted = self
            .keeps_weighted()
            .then(|| quote! { weighted: [#ty; #weighted], });
        quote! {
            model_key: [#ty; #key],
            model: PredictionModel,
            #hessian,
            #weighted
            model_kept: bool,
            terminal_weight_settled: bool,
        }
    }

    /// The fields' values in `new`: nothing kept yet.
    pub fn initial(&self, zero: &TokenStream, ns: &Literal, nu: &Literal) -> TokenStream {
        let [key, weighted] = self.field_lengths();
        let hessian = self.hessian.field(zero);
        let weighted = self
            .keeps_weighted()
            .then(|| quote! { weighted: [#zero; #weighted], });
        quote! {
            model_key: [#zero; #key],
            model: PredictionModel {
                a: [[#zero; #ns]; #ns],
                b: [[#zero; #nu]; #ns],
            },
            #hessian,
            #weighted
            model_kept: false,
            terminal_weight_settled: false,
        }
    }

    /// `let keep_model = ..;`: whether the kept prediction model serves this solve, and
    /// `let reuse = ..;`: whether its terminal weight and Hessian serve too.
    pub fn reuse_test(&self, scalar: Scalar) -> TokenStream {
        let zero = literal(0.0, scalar);
        let read_key = &self.read_key;
        let kept: Vec<Ident> = self
            .key
            .iter()
            .map(|k| ident(&format!("kept_{k}")))
            .collect();
        let close = self.key.iter().zip(&kept).map(|(v, k)| {
            quote! {
                #v - #k <= Self::MODEL_TOLERANCE * (if #k < #zero { -#k } else { #k })
                    && #k - #v <= Self::MODEL_TOLERANCE * (if #k < #zero { -#k } else { #k })
            }
        });
        quote! {
            // The kept model serves while every value it was built at is within
            // MODEL_TOLERANCE of its value now (a NaN never is); its terminal weight and
            // Hessian too once the weight has settled.
            #read_key
            let [#(#kept),*] = self.model_key;
            let keep_model = self.model_kept #(&& (#close))*;
            let reuse = keep_model && self.terminal_weight_settled;
        }
    }

    /// What [`Cache::reuse_test`] does: per value of the key, the kept value read, two
    /// differences, two products with the tolerance and the comparisons.
    pub fn reuse_ops(&self) -> OpCount {
        let key = self.key.len() as u32;
        OpCount {
            add: 2 * key,
            mul: 2 * key,
            compare: 3 * key,
            load: key,
            // MODEL_TOLERANCE
            literal: u32::from(key > 0),
            ..OpCount::default()
        }
    }

    /// What [`Cache::store`] writes when the problem was rebuilt: the key, the model,
    /// the Hessian and the weighted responses.
    pub fn store_ops(&self, model_len: usize) -> OpCount {
        OpCount::stores(
            self.key.len() + model_len + self.hessian.len() + self.weighted_stored.len(),
        )
    }

    /// Whether the weighted responses are kept (the linear term reads them; the dual
    /// active set keeps the gain it built from them instead).
    fn keeps_weighted(&self) -> bool {
        !self.weighted_stored.is_empty()
    }

    /// The pattern of the solve's kept weighted responses in the branches' value: `weighted`,
    /// or nothing.
    pub fn weighted_binding(&self) -> TokenStream {
        match self.keeps_weighted() {
            true => quote! { weighted },
            false => TokenStream::new(),
        }
    }

    /// The name of the kept Hessian's value in the solve (`hessian`, `hessian_inverse`).
    pub fn hessian_name(&self) -> TokenStream {
        self.hessian.binding()
    }

    /// What the solve declares before its branches (see [`KeptHessian`]).
    pub fn declare(&self) -> TokenStream {
        self.hessian.declare()
    }

    /// The model's key and the model: the kept ones, or the values read now and the
    /// prediction model at them (`prediction`, which returns on failure).
    pub fn model(&self, prediction: TokenStream) -> TokenStream {
        let key = &self.key;
        quote! {
            let (model_key, model) = if keep_model {
                (self.model_key, self.model)
            } else {
                ([#(#key),*], #prediction)
            };
        }
    }

    /// The value of the rebuilt branch: the key, then the model, the terminal weight and
    /// gain with whether it converged, the Hessian and the weighted responses, as
    /// [`Cache::kept`] lists them.
    pub fn rebuilt(&self, terminal: &TokenStream) -> TokenStream {
        let hessian = self.hessian.rebuilt();
        let weighted = &self.weighted_stored;
        let weighted = self.keeps_weighted().then(|| quote! { [#(#weighted),*], });
        quote! {
            {
                // The rebuilt values live in the solve's frame; the branches' value
                // refers to them as the kept branch's refers to the controller's.
                fresh_model = model;
                #terminal
                let (terminal_weight, terminal_gain) = &fresh_terminal;
                (
                    model_key,
                    &fresh_model,
                    (
                        terminal_weight,
                        terminal_gain,
                        terminal_weight_converged,
                        terminal_weight_settled,
                    ),
                    #hessian,
                    #weighted
                )
            }
        }
    }

    /// The value of the kept branch, in the order of [`Cache::rebuilt`]: the kept model,
    /// terminal weight and gain (and the dual active set's arrays) read in place, not
    /// copied.
    pub fn kept(&self) -> TokenStream {
        let hessian = self.hessian.kept();
        let weighted = self.keeps_weighted().then(|| quote! { self.weighted, });
        quote! {
            (
                self.model_key,
                &self.model,
                (&self.terminal_weight, &self.terminal_gain, true, true),
                #hessian,
                #weighted
            )
        }
    }

    /// The names the branches' value binds, and the Hessian's and weighted responses'
    /// entries bound from it.
    pub fn unpack(&self) -> TokenStream {
        let (hessian, weighted) = (self.hessian.unpack(), &self.weighted_pattern);
        let weighted = self
            .keeps_weighted()
            .then(|| quote! { let [#(#weighted),*] = weighted; });
        quote! {
            #hessian
            #weighted
        }
    }

    /// The commit of what the next solve may keep, with `rebuilt` (the terminal weight
    /// and gain), which a solve that reused them leaves too.
    pub fn store(&self, rebuilt: &TokenStream) -> TokenStream {
        let hessian = self.hessian.store();
        let weighted = self
            .keeps_weighted()
            .then(|| quote! { self.weighted = weighted; });
        quote! {
            // (A solve that reused them leaves them as they are.)
            if !reuse {
                #rebuilt
                self.model_key = model_key;
                self.model = *model;
                #hessian
                #weighted
                self.model_kept = true;
                self.terminal_weight_settled = terminal_weight_settled;
            }
        }
    }
}

/// What a solve keeps of the condensed Hessian for its QP.
pub enum KeptHessian {
    /// `H` itself, packed (the primal active set's Newton steps): its entries' names.
    Packed(Vec<Ident>),
    /// `G = H^-1`, whole, and the unconstrained plan's gain `K` (the dual active set's):
    /// their sizes, and the statement that binds `K`'s entries from `unconstrained_gain`.
    Inverse {
        /// The moves, `G`'s size.
        moves: usize,
        /// The regulated states, `K`'s columns.
        states: usize,
        /// The limit rows, kept with `G` times each (none: neither kept).
        rows: usize,
        /// `let [[kv_1_1, ..], ..] = *unconstrained_gain;`
        pattern: TokenStream,
    },
}

impl KeptHessian {
    /// The field's name.
    fn name(&self) -> Ident {
        match self {
            KeptHessian::Packed(_) => ident("hessian"),
            KeptHessian::Inverse { .. } => ident("hessian_inverse"),
        }
    }

    /// The pattern of the solve's value: `hessian`, or references to the dual active
    /// set's arrays (the kept ones, read in place: a copy would cost as much as the
    /// solve; or the rebuilt ones, in `fresh_inverse`).
    fn binding(&self) -> TokenStream {
        match self {
            KeptHessian::Packed(_) => quote! { hessian },
            KeptHessian::Inverse { .. } => {
                let kept = self.inverse_parts();
                quote! { (#(#kept),*) }
            }
        }
    }

    /// What the solve declares before its branches: `fresh_inverse`, which the rebuilt
    /// branch fills.
    fn declare(&self) -> TokenStream {
        match self {
            KeptHessian::Packed(_) => quote! { let (fresh_model, fresh_terminal); },
            KeptHessian::Inverse { .. } => {
                quote! { let (fresh_model, fresh_terminal, fresh_inverse); }
            }
        }
    }

    /// The dual active set's kept arrays, by name.
    fn inverse_parts(&self) -> Vec<Ident> {
        let mut parts = vec![ident("hessian_inverse"), ident("unconstrained_gain")];
        if let KeptHessian::Inverse { rows, .. } = self {
            if *rows > 0 {
                parts.extend([ident("limit_rows"), ident("limit_columns")]);
            }
        }
        parts
    }

    /// The entries kept.
    fn len(&self) -> usize {
        match self {
            KeptHessian::Packed(entries) => entries.len(),
            KeptHessian::Inverse {
                moves,
                states,
                rows,
                ..
            } => moves * (moves + states + 2 * rows),
        }
    }

    /// `name: [entry; len]` (`[[entry; m]; m]` for `G`): a field's type, or its value
    /// with `entry` a value.
    fn field(&self, entry: &TokenStream) -> TokenStream {
        let name = self.name();
        match self {
            KeptHessian::Packed(entries) => {
                let len = Literal::usize_unsuffixed(entries.len());
                quote! { #name: [#entry; #len] }
            }
            KeptHessian::Inverse {
                moves,
                states,
                rows,
                ..
            } => {
                let [m, ns, r] = [*moves, *states, *rows].map(Literal::usize_unsuffixed);
                let limits = (*rows > 0).then(|| {
                    quote! {
                        , limit_rows: [[#entry; #m]; #r],
                        limit_columns: [[#entry; #m]; #r]
                    }
                });
                quote! {
                    #name: [[#entry; #m]; #m],
                    unconstrained_gain: [[#entry; #m]; #ns]
                    #limits
                }
            }
        }
    }

    /// Its value in the rebuilt branch: `H`'s entries by name, or `hessian_inverse`.
    fn rebuilt(&self) -> TokenStream {
        match self {
            KeptHessian::Packed(entries) => quote! { [#(#entries),*] },
            KeptHessian::Inverse { .. } => {
                let kept = self.inverse_parts();
                quote! {
                    {
                        fresh_inverse = (#(#kept),*);
                        let (#(#kept),*) = &fresh_inverse;
                        (#(#kept),*)
                    }
                }
            }
        }
    }

    /// Its value in the kept branch.
    fn kept(&self) -> TokenStream {
        match self {
            KeptHessian::Packed(_) => quote! { self.hessian },
            KeptHessian::Inverse { .. } => {
                let kept = self.inverse_parts();
                quote! { (#(&self.#kept),*) }
            }
        }
    }

    /// The statement that stores a rebuilt one.
    fn store(&self) -> TokenStream {
        match self {
            KeptHessian::Packed(_) => quote! { self.hessian = hessian; },
            KeptHessian::Inverse { .. } => {
                let kept = self.inverse_parts();
                quote! { #(self.#kept = *#kept;)* }
            }
        }
    }

    /// The statement that binds its entries' names from the solve's value.
    fn unpack(&self) -> TokenStream {
        match self {
            KeptHessian::Packed(entries) => quote! { let [#(#entries),*] = hessian; },
            KeptHessian::Inverse { pattern, .. } => pattern.clone(),
        }
    }
}

/// A node as stored: its variable's name, or its literal.
fn stored(g: &Graph, node: NodeId, scalar: Scalar) -> TokenStream {
    match g.node(node) {
        Node::Var(v) => {
            let name = ident(&g.var_info(v).name);
            quote! { #name }
        }
        _ => literal(g.literal(node).unwrap_or(0.0), scalar),
    }
}

/// A node as bound by a pattern: its variable's name, or `_`.
fn pattern(g: &Graph, node: NodeId) -> TokenStream {
    match g.node(node) {
        Node::Var(v) => {
            let name = ident(&g.var_info(v).name);
            quote! { #name }
        }
        _ => quote! { _ },
    }
}
