//! Integration sub-steps as a loop: the body is one sub-step, lowered straight-line with
//! its structural zeros skipped; what does not change from one sub-step to the next is
//! computed once before the loop. The continuous filters use it for their propagation
//! between samples, and `f` for models with more sub-steps than are worth unrolling.

use super::lower::{Lowerer, OpCount};
use super::model_fns::{argument_names, integration_rule_name};
use super::names::ident;
use crate::model::{Method, Model, Scalar};
use crate::symbolic::continuous::{integrate_substep, AtPoint};
use crate::symbolic::loop_invariant_operands;
use crate::symbolic::{ModelGraph, NodeId, VarId};
use proc_macro2::TokenStream;
use quote::quote;
use std::collections::BTreeSet;

/// Name of the loop's running state vector in generated code.
pub const X_SUB: &str = "x_sub";
/// Name of the loop's running packed covariance in generated code.
pub const P_SUB: &str = "p_sub";
/// Name of the loop's running time in generated code.
pub const T_SUB: &str = "t_sub";

/// A value the loop carries from one sub-step to the next.
pub struct Carried<'a> {
    /// Its name in generated code: an array destructured into `vars`, or (`scalar`) the
    /// one variable itself.
    pub name: &'static str,
    /// Its value before the first sub-step (`self.x`, `t_prev`).
    pub initial: TokenStream,
    /// The variables the body reads.
    pub vars: &'a [NodeId],
    /// Their values after one sub-step.
    pub next: &'a [NodeId],
    /// Whether it is a single variable rather than an array.
    pub scalar: bool,
}

/// A lowered loop of sub-steps.
pub struct SubstepLoop {
    /// The loop-invariant statements, then the loop itself.
    pub code: TokenStream,
    /// What one sub-step computes.
    pub per_substep: OpCount,
    /// What the code before the loop computes (guards, invariants), from the lowerer's
    /// state when it was called.
    pub before: OpCount,
    /// Variables the body reads.
    pub used_vars: BTreeSet<VarId>,
}

/// Lowers `carried` as `for _ in 0..#pairs { .. }` running two sub-steps per iteration
/// (`pairs` names a constant: `Self::SUBSTEP_PAIRS`, half the sub-steps), then one more
/// if their number is `odd`.
/// Statements already emitted on `lowerer` (guards) come first. On return `lowerer`
/// continues after the loop: what the code computes next reads the carried arrays by
/// their names.
pub fn lower_loop(
    lowerer: &mut Lowerer,
    carried: &[Carried<'_>],
    (pairs, odd): (&TokenStream, bool),
) -> SubstepLoop {
    let graph = lowerer.graph();
    // A carried value a sub-step leaves as it is (a parameter: a random walk has no
    // drift) is loop-invariant: what depends on it alone is computed before the loop,
    // reading it from the initial value.
    let loop_vars: Vec<NodeId> = carried
        .iter()
        .flat_map(|c| c.vars.iter().zip(c.next))
        .filter(|(var, next)| var != next)
        .map(|(&var, _)| var)
        .collect();
    for c in carried.iter().filter(|c| !c.scalar) {
        lowerer.read_lazily(&c.initial, c.vars);
    }
    let roots: Vec<NodeId> = carried.iter().flat_map(|c| c.next).copied().collect();
    for node in loop_invariant_operands(graph, &roots, &loop_vars) {
        lowerer.force_let(node);
    }
    lowerer.hold_in_registers(&loop_vars);
    lowerer.hoist_leaves(&roots);
    let before = lowerer.ops();
    let outside = lowerer.take_statements();

    let mut body = lowerer.clone();
    for c in carried.iter().filter(|c| !c.scalar) {
        let name = ident(c.name);
        body.read_lazily(&quote! { #name }, c.vars);
    }
    let values = body.segment(&roots);
    let statements = body.take_statements();
    let per_substep = body.ops().minus(before);
    let used_vars = body.finish().used_vars;

    let mut start = Vec::new();
    let mut assign = Vec::new();
    let mut values = values.into_iter();
    for c in carried {
        let name = ident(c.name);
        let initial = &c.initial;
        start.push(quote! { let mut #name = #initial; });
        let next: Vec<TokenStream> = values.by_ref().take(c.next.len()).collect();
        if c.scalar {
            assign.push(quote! { #name = #(#next)*; });
        } else {
            assign.push(quote! { #name = [#(#next),*]; });
        }
    }
    // Two sub-steps per iteration: each copy's values stay in registers for the next, where
    // one copy must move every carried value back into the registers the loop began with.
    let substep = quote! {
        {
            #(#statements)*
            #(#assign)*
        }
    };
    let last = odd.then(|| substep.clone());
    let code = quote! {
        #(#outside)*
        #(#start)*
        for _ in 0..#pairs {
            #substep
            #substep
        }
        #last
    };
    SubstepLoop {
        code,
        per_substep,
        before,
        used_vars,
    }
}

/// Name of the constant holding the sub-steps of a looped `f`.
pub const F_SUBSTEPS: &str = "F_SUBSTEPS";
/// Name of the constant holding the iterations of a looped `f`, two sub-steps each.
pub const F_SUBSTEP_PAIRS: &str = "F_SUBSTEP_PAIRS";

/// `f` of a model whose sub-steps are too many to unroll: one sub-step of the model's rule,
/// straight-line, in a loop of `F_SUBSTEPS`; the constant itself; and what `f` computes.
pub fn looped_f(
    model: &Model,
    mg: &ModelGraph,
    scalar: Scalar,
) -> (TokenStream, TokenStream, OpCount) {
    let substep = Substep::new(model, mg);
    let lowered = substep.lower(model, scalar);
    let ops = lowered
        .before
        .plus(lowered.per_substep.times(substep.count))
        .plus(OpCount::branches(substep.count.div_ceil(2)));
    let f = substep.f_tokens(lowered.code, scalar);
    let count = proc_macro2::Literal::usize_unsuffixed(substep.count as usize);
    let pairs = proc_macro2::Literal::usize_unsuffixed(substep.count as usize / 2);
    let constant = quote! {
        /// Integration sub-steps of one sample of [`f`].
        pub const F_SUBSTEPS: usize = #count;
        /// Iterations of [`f`]'s loop, two sub-steps each.
        const F_SUBSTEP_PAIRS: usize = #pairs;
    };
    (f, constant, ops)
}

/// One sub-step of the model's integration rule as nodes, from the running states
/// (and time) to their values a sub-step later: the body of the looped `f`.
struct Substep {
    /// The model's graph with the sub-step's nodes.
    g: ModelGraph,
    /// The integration rule.
    rule: Method,
    /// Sub-steps per sample.
    count: u32,
    /// The running time, [`T_SUB`].
    t_sub: NodeId,
    /// The running physical states (the start of the state vector).
    states: Vec<NodeId>,
    /// The states after one sub-step, then (if the model uses `t`) the time.
    next: Vec<NodeId>,
    /// Whether the model reads `t`, so the loop carries it.
    uses_time: bool,
    /// The sample interval's parameter (`dt`), if the model declares one: the sub-steps
    /// divide it.
    interval: Option<String>,
}

impl Substep {
    /// The sub-step of `model`'s rule: `dx/dt` at the running point, integrated over one
    /// step `h` ([`integrate_substep`]), and `t + h` when the model reads the time.
    fn new(model: &Model, mg: &ModelGraph) -> Substep {
        let mut g = mg.clone();
        let (rule, h, count) = g
            .substep(model)
            .expect("only continuous dynamics have sub-steps");
        let ns = model.states.len();
        let t_sub = g.graph.var(T_SUB);
        let states = g.x[..ns].to_vec();
        let rates = g.derivative(model, t_sub, &g.x.clone());
        let rates = rates[..ns].to_vec();
        let at = AtPoint::new(
            std::iter::once(t_sub)
                .chain(states.iter().copied())
                .map(|v| g.var_id(v))
                .collect(),
        );
        let mut rate = |gr: &mut crate::symbolic::Graph, t: NodeId, z: &[NodeId]| {
            let point: Vec<NodeId> = std::iter::once(t).chain(z.iter().copied()).collect();
            at.eval(gr, &point, &rates)
        };
        let mut next = integrate_substep(&mut g.graph, rule, h, t_sub, &states, &mut rate);
        let uses_time = model.uses_time();
        if uses_time {
            next.push(g.graph.add(t_sub, h));
        }
        Substep {
            g,
            rule,
            count,
            t_sub,
            states,
            next,
            uses_time,
            interval: model.interval_parameter(),
        }
    }

    /// The loop over `F_SUBSTEPS`, carrying [`X_SUB`] (and [`T_SUB`]).
    fn lower(&self, model: &Model, scalar: Scalar) -> SubstepLoop {
        let g = &self.g;
        let interval = model.interval_parameter();
        let reserved = argument_names(model)
            .chain([X_SUB, T_SUB, F_SUBSTEPS, F_SUBSTEP_PAIRS])
            .chain(interval.as_deref());
        let namer = super::names::TempNamer::new(reserved);
        let mut lowerer = Lowerer::new(&g.graph, scalar, namer, &self.next);
        let (state_next, t_next) = self.next.split_at(self.states.len());
        let state_idents = super::code::var_idents(&g.graph, &self.states);
        let mut carried = vec![Carried {
            name: X_SUB,
            initial: quote! { [#(#state_idents),*] },
            vars: &self.states,
            next: state_next,
            scalar: false,
        }];
        let t_vars = [self.t_sub];
        if self.uses_time {
            carried.push(Carried {
                name: T_SUB,
                initial: quote! { t },
                vars: &t_vars,
                next: t_next,
                scalar: true,
            });
        }
        let pairs = ident(F_SUBSTEP_PAIRS);
        lower_loop(
            &mut lowerer,
            &carried,
            (&quote! { #pairs }, self.count % 2 == 1),
        )
    }

    /// `pub fn f(t, x, u)` around the lowered loop `code`: unpacks the arguments, runs
    /// the loop, and returns the states it carried with the parameters as they were.
    fn f_tokens(&self, code: TokenStream, scalar: Scalar) -> TokenStream {
        let g = &self.g;
        let ty = ident(scalar.type_name());
        let state_idents = super::code::var_idents(&g.graph, &self.states);
        let x_idents = super::code::var_idents(&g.graph, &g.x);
        let n = proc_macro2::Literal::usize_unsuffixed(g.x.len());
        let time = self.uses_time.then(|| quote! { t: #ty, });
        // The sample interval, which each sub-step's length `dt / F_SUBSTEPS` reads.
        let interval = self.interval.as_ref().map(|dt| {
            let dt = ident(dt);
            quote! { #dt: #ty, }
        });
        let u_param = (!g.u.is_empty()).then(|| {
            let u_idents = super::code::var_idents(&g.graph, &g.u);
            let len = proc_macro2::Literal::usize_unsuffixed(g.u.len());
            (
                quote! { u: &[#ty; #len] },
                quote! { let [#(#u_idents),*] = *u; },
            )
        });
        let (u_arg, u_unpack) = u_param.unzip();
        let x_sub = ident(X_SUB);
        let doc = format!(
            " One sample of the dynamics, `x[k+1] = f(x[k], u[k])`, integrating the continuous \
             dynamics with {} ({} steps per sample{}, in a loop: too many to \
             unroll, so there are no Jacobians of `f`; the continuous filters differentiate \
             `dx/dt` instead).",
            integration_rule_name(self.rule),
            self.count,
            match &self.interval {
                Some(dt) => format!(" over the sample interval `{dt}`"),
                None => String::new(),
            }
        );
        quote! {
            #[doc = #doc]
            #[doc = ""]
            #[doc = " Cost: see [`F_OPS`]."]
            #[must_use]
            pub fn f(#time #interval x: &[#ty; #n], #u_arg) -> [#ty; #n] {
                let [#(#x_idents),*] = *x;
                #u_unpack
                #code
                let [#(#state_idents),*] = #x_sub;
                [#(#x_idents),*]
            }
        }
    }
}
