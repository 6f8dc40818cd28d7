//! The MPC's limit rows as graph nodes: over the moves `v` (deviations from `u_ref`),
//! step by step and in each step the limited input changes, then states, then outputs,
//! each row `lower <= a' v <= upper`. A state's row at step `k` is its row of the
//! prediction `x_k - x_ref = A^k (x - x_ref) + sum_(m<k) A^(k-1-m) B v_m` (the deviations'
//! dynamics when `u_ref` holds `x_ref`), its limits less the reference and the free
//! response `A^k (x - x_ref)`; an output's, `C` times those; an input change's,
//! `v_(k-1) - v_(k-2)`, or for the first move `v_0 - (u - u_ref)`, `u` the input applied
//! now.

use super::names::Names;
use super::spec::MpcSpec;
use crate::emit::names::ident;
use crate::model::{Model, Scalar};
use crate::symbolic::linalg::{matmul, Matrix};
use crate::symbolic::{Graph, ModelGraph, NodeId};
use proc_macro2::{Ident, TokenStream};
use quote::quote;

/// The rows' coefficients `a_r`, one vector over the moves per row.
pub fn coefficients(g: &mut Graph, (a, b): (&Matrix, &Matrix), spec: &MpcSpec) -> Vec<Vec<NodeId>> {
    let (horizon, nu, moves) = (spec.horizon as usize, spec.inputs.len(), spec.moves());
    // responses[d] = A^d B
    let mut responses = vec![b.clone()];
    for _ in 1..horizon {
        let last = responses.last().cloned().unwrap_or_default();
        responses.push(matmul(g, a, &last));
    }
    let (zero, one, minus_one) = (g.zero(), g.one(), g.num(-1.0));
    let state_row = |g: &mut Graph, k: usize, j: usize, weight: NodeId| {
        let mut row = vec![g.zero(); moves];
        for m in 0..k {
            for q in 0..nu {
                row[m * nu + q] = g.mul(weight, responses[k - 1 - m][j][q]);
            }
        }
        row
    };
    let mut rows = Vec::new();
    for k in 1..=horizon {
        for &q in &spec.limits.rates {
            let mut row = vec![zero; moves];
            row[(k - 1) * nu + q] = one;
            if k >= 2 {
                row[(k - 2) * nu + q] = minus_one;
            }
            rows.push(row);
        }
        for &j in &spec.limits.states {
            rows.push(state_row(g, k, j, one));
        }
        for c in &spec.limits.output_rows {
            let mut row = vec![zero; moves];
            for (j, &weight) in c.iter().enumerate().filter(|(_, &w)| w != 0.0) {
                let weight = g.num(weight);
                let part = state_row(g, k, j, weight);
                for (entry, p) in row.iter_mut().zip(part) {
                    *entry = g.add(*entry, p);
                }
            }
            rows.push(row);
        }
    }
    rows
}

/// The run-time values the limits read: per limited quantity its minimum and maximum
/// (the `Mpc`'s fields `rate_min`, `rate_max`, `state_min`, .., destructured by name),
/// and per soft quantity its penalty.
pub struct LimitNames {
    /// Per limited quantity, rates, then states, then outputs: its minimum's and
    /// maximum's names.
    pub minimum: Vec<String>,
    pub maximum: Vec<String>,
    /// Per limited quantity: its penalty's name if soft.
    pub penalty: Vec<Option<String>>,
}

impl LimitNames {
    pub fn new(model: &Model, spec: &MpcSpec, names: &Names) -> LimitNames {
        let limits = &spec.limits;
        let quantities: Vec<(String, &str)> = limits
            .rates
            .iter()
            .map(|&q| (model.inputs[spec.inputs[q]].name.clone(), "rate_"))
            .chain(
                limits
                    .states
                    .iter()
                    .map(|&j| (model.states[spec.states[j]].name.clone(), "")),
            )
            .chain(
                limits
                    .outputs
                    .iter()
                    .map(|&(o, _)| (model.outputs[o].name.clone(), "")),
            )
            .collect();
        let named = |suffix: &str| {
            quantities
                .iter()
                .map(|(name, kind)| names.fresh(&format!("{name}_{kind}{suffix}")))
                .collect()
        };
        LimitNames {
            minimum: named("min"),
            maximum: named("max"),
            penalty: quantities
                .iter()
                .zip(&limits.soft)
                .map(|((name, _), &soft)| soft.then(|| names.fresh(&format!("{name}_penalty"))))
                .collect(),
        }
    }

    /// The statements that bind the names from the `Mpc`'s fields.
    pub fn reads(&self, spec: &MpcSpec) -> TokenStream {
        let limits = &spec.limits;
        let (rates, states) = (limits.rates.len(), limits.states.len());
        let groups = [
            ("rate", 0..rates),
            ("state", rates..rates + states),
            ("output", rates + states..self.minimum.len()),
        ];
        let mut reads = TokenStream::new();
        for (kind, range) in groups {
            if range.is_empty() {
                continue;
            }
            let (min_field, max_field) =
                (ident(&format!("{kind}_min")), ident(&format!("{kind}_max")));
            let min = self.minimum[range.clone()].iter().map(|n| ident(n));
            let max = self.maximum[range].iter().map(|n| ident(n));
            reads.extend(quote! {
                let [#(#min),*] = self.#min_field;
                let [#(#max),*] = self.#max_field;
            });
        }
        let penalties: Vec<Ident> = self.penalty.iter().flatten().map(|n| ident(n)).collect();
        if !penalties.is_empty() {
            reads.extend(quote! { let [#(#penalties),*] = self.limit_penalties; });
        }
        reads
    }
}

/// The rows' lower and upper limits at this solve, as nodes, and each row's penalty
/// (the quantity's, or infinite for a hard row), from the deviation `x - x_ref` of the
/// regulated states and the names of their references (`<state>_ref`).
pub fn bounds(
    mg: &mut ModelGraph,
    (spec, limit_names, a): (&MpcSpec, &LimitNames, &Matrix),
    (deviation, references): (&[NodeId], &[String]),
    input_references: &[Ident],
    scalar: Scalar,
) -> (Vec<NodeId>, Vec<NodeId>, Vec<TokenStream>) {
    let limits = &spec.limits;
    let g = &mut mg.graph;
    let refs: Vec<NodeId> = references.iter().map(|r| g.var(r)).collect();
    let (mut lower, mut upper, mut penalty) = (Vec::new(), Vec::new(), Vec::new());
    let infinite = {
        let ty = ident(scalar.type_name());
        quote! { #ty::INFINITY }
    };
    let mut free: Matrix = deviation.iter().map(|&d| vec![d]).collect();
    for k in 1..=spec.horizon as usize {
        free = matmul(g, a, &free);
        // Per quantity: the value its limits are offset by at this step.
        let mut offsets = Vec::new();
        for &q in &limits.rates {
            let offset = if k == 1 {
                // The first move's change is from the input applied now.
                let applied = mg.u[spec.inputs[q]];
                let reference = g.var(&input_references[q].to_string());
                let change = g.sub(applied, reference);
                g.neg(change)
            } else {
                g.zero()
            };
            offsets.push(offset);
        }
        for &j in &limits.states {
            offsets.push(g.add(refs[j], free[j][0]));
        }
        for c in &limits.output_rows {
            let mut sum = g.zero();
            for (j, &weight) in c.iter().enumerate().filter(|(_, &w)| w != 0.0) {
                let value = g.add(refs[j], free[j][0]);
                let weight = g.num(weight);
                let term = g.mul(weight, value);
                sum = g.add(sum, term);
            }
            offsets.push(sum);
        }
        for (i, offset) in offsets.into_iter().enumerate() {
            let (min, max) = (
                g.var(&limit_names.minimum[i]),
                g.var(&limit_names.maximum[i]),
            );
            lower.push(g.sub(min, offset));
            upper.push(g.sub(max, offset));
            penalty.push(match &limit_names.penalty[i] {
                Some(name) => {
                    let name = ident(name);
                    quote! { #name }
                }
                None => infinite.clone(),
            });
        }
    }
    (lower, upper, penalty)
}
