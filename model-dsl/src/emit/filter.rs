//! The filter layout every Kalman filter shares: the names generated variables avoid,
//! packed symmetric matrices and their variables, process noise arguments (full or
//! diagonal), the finiteness probe that guards a whole result, and time arguments.

use crate::emit::code::{pack_upper, packed_names};
use crate::emit::names::ident;
use crate::model::Model;
use crate::symbolic::linalg::{packed_len, symmetric_from_packed, Matrix};
use crate::symbolic::{Graph, NodeId, VarId};
use proc_macro2::TokenStream;
use quote::quote;

/// Names already used by the model, which generated variables must avoid.
pub fn model_names(model: &Model) -> Vec<String> {
    model
        .constants
        .iter()
        .map(|c| c.name.clone())
        .chain(model.state_names().map(str::to_owned))
        .chain(model.inputs.iter().map(|s| s.name.clone()))
        .chain(model.known.iter().map(|s| s.name.clone()))
        .chain(model.outputs.iter().map(|o| o.name.clone()))
        .chain(["t", "x", "u", "y", "self", "status", "known"].map(String::from))
        .collect()
}

/// Declares the packed variables of an `n x n` symmetric matrix and returns them.
pub fn packed_vars(graph: &mut Graph, prefix: &str, n: usize, avoid: &[String]) -> Vec<NodeId> {
    let taken = |name: &str| avoid.iter().any(|a| a == name);
    packed_names(prefix, n, &taken)
        .iter()
        .map(|name| graph.var(name))
        .collect()
}

/// A process noise covariance: its variables (the packed upper triangle, or only the
/// diagonal) and the matrix they make (structural zeros off the diagonal if diagonal).
pub fn noise_vars(
    graph: &mut Graph,
    prefix: &str,
    n: usize,
    diagonal: bool,
    avoid: &[String],
) -> (Vec<NodeId>, Matrix) {
    let packed = packed_vars(graph, prefix, n, avoid);
    if !diagonal {
        let matrix = symmetric_from_packed(&packed, n);
        return (packed, matrix);
    }
    let variances: Vec<NodeId> = (0..n)
        .map(|i| packed[crate::symbolic::linalg::packed_index(n, i, i)])
        .collect();
    let zero = graph.zero();
    let matrix = (0..n)
        .map(|i| {
            (0..n)
                .map(|j| if i == j { variances[i] } else { zero })
                .collect()
        })
        .collect();
    (variances, matrix)
}

/// The constructor argument, field type and stored value of a process noise covariance:
/// `q: &[[S; n]; n]` packed to its upper triangle, or `q: &[S; n]`, its variances.
pub fn noise_argument(
    name: &str,
    n: usize,
    diagonal: bool,
    ty: &proc_macro2::Ident,
) -> (TokenStream, TokenStream, TokenStream) {
    let arg = ident(name);
    let n_len = proc_macro2::Literal::usize_unsuffixed(n);
    if diagonal {
        (
            quote! { #arg: &[#ty; #n_len] },
            quote! { [#ty; #n_len] },
            quote! { *#arg },
        )
    } else {
        let packed = proc_macro2::Literal::usize_unsuffixed(packed_len(n));
        (
            quote! { #arg: &[[#ty; #n_len]; #n_len] },
            quote! { [#ty; #packed] },
            pack_upper(name, n),
        )
    }
}

/// The sum of a vector and of a matrix's diagonal: finite exactly when all of them are
/// (a NaN or infinity anywhere makes it non-finite), so one check guards a whole result.
pub fn finiteness_probe(graph: &mut Graph, vector: &[NodeId], matrix: &Matrix) -> NodeId {
    let mut sum = graph.zero();
    let diagonal = (0..matrix.len()).map(|i| matrix[i][i]);
    for v in vector.iter().copied().chain(diagonal) {
        sum = graph.add(sum, v);
    }
    sum
}

/// `t: f32` (named `name`), or `_t: f32` when the code does not read it.
pub fn time_param(
    graph: &Graph,
    t: NodeId,
    used: &std::collections::BTreeSet<VarId>,
    ty: &proc_macro2::Ident,
    name: &str,
) -> TokenStream {
    let reads = matches!(graph.node(t), crate::symbolic::Node::Var(v) if used.contains(&v));
    let name = if reads {
        ident(name)
    } else {
        ident(&format!("_{name}"))
    };
    quote! { #name: #ty }
}
