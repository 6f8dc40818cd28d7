//! The adaptive finite-horizon LQR (Alg. 3, eq. 19, with `R` inside the inverse): the
//! physical sub-model is the Jacobian of `f` with respect to the chosen states and inputs
//! at the current estimate; the backward Riccati recursion runs as a loop over the horizon
//! whose body is generated straight-line code.

use super::spec::LqrSpec;
use super::steady_state::{steady_state_step, SteadyStateStep};
use crate::emit::arguments::{Arguments, REJECTS_NON_FINITE};
use crate::emit::code::{
    all_is_finite, destructure, guard_pivots, pivot_names, reject_non_finite, var_idents,
};
use crate::emit::filter::{model_names, packed_vars, time_param};
use crate::emit::known::KnownItems;
use crate::emit::lower::{literal, Lowered, Lowerer, OpCount};
use crate::emit::names::{clear_of, ident, matrix_entry, TempNamer};
use crate::model::{Model, Scalar};
use crate::symbolic::linalg::{packed_len, symmetric_from_packed, Matrix};
use crate::symbolic::riccati::{riccati_step_single_input, RiccatiStep};
use crate::symbolic::{loop_invariant_operands, Graph, ModelGraph, Node, NodeId, VarId};
use proc_macro2::{Ident, Literal, TokenStream};
use quote::quote;
use std::collections::BTreeSet;

/// Generated LQR code and its cost.
pub struct LqrCode {
    /// The `Lqr` type and its methods.
    pub tokens: TokenStream,
    /// Arithmetic of one `solve`, the whole horizon included.
    pub solve_ops: OpCount,
}

/// The LQR of `model` in `scalar`.
pub fn emit_lqr(model: &Model, spec: &LqrSpec, mg: &ModelGraph, scalar: Scalar) -> LqrCode {
    let recursion = Recursion::new(model, spec, mg);
    let code = recursion.lower(model, spec, scalar);
    let laws = ControlLaws::new(model, spec, scalar);
    let solve = solve_method(model, &recursion, &code, &laws, scalar);
    let steady_state = steady_state_input(model, spec, mg, scalar);
    let tokens = lqr_type(model, spec, scalar, &laws, (steady_state, solve));
    LqrCode {
        tokens,
        solve_ops: code.ops,
    }
}

/// The pivot names of the control weight `R + B'PB`.
const WEIGHT: (&str, &str) = ("weight", "inv_weight");

/// The backward Riccati recursion of eq. (19) on the physical sub-model at the estimate, as
/// graph nodes: `A = df_s/ds`, `B = df_s/du` (Alg. 3), the packed variables of `P`, `Q` and
/// `R`, one shared Riccati step, and the step's operands that do not depend on `P`.
struct Recursion {
    g: ModelGraph,
    a: Matrix,
    b: Matrix,
    p_vars: Vec<NodeId>,
    q_vars: Vec<NodeId>,
    r_vars: Vec<NodeId>,
    step: RiccatiStep,
    /// The gain `K`, row by row.
    k_flat: Vec<NodeId>,
    /// Operands of the loop body that do not change between steps, hoisted before it.
    invariant: Vec<NodeId>,
}

/// The lowered recursion: the statements hoisted before the loop, the loop body and the
/// next `P`, the gain's statements after the loop and `K`, and what they read and cost.
struct RecursionCode {
    outside: Vec<TokenStream>,
    body: Vec<TokenStream>,
    p_values: Vec<TokenStream>,
    gain_statements: Vec<TokenStream>,
    k_values: Vec<TokenStream>,
    /// The model and weight variables the whole `solve` reads.
    used_vars: BTreeSet<VarId>,
    /// Those the gain after the loop reads.
    used_after: BTreeSet<VarId>,
    /// Arithmetic of one `solve`, the whole horizon included.
    ops: OpCount,
}

impl Recursion {
    /// The physical sub-model at the estimate: A = df_s/ds, B = df_s/du (Alg. 3), and the
    /// Riccati step on it.
    fn new(model: &Model, spec: &LqrSpec, mg: &ModelGraph) -> Recursion {
        let mut g = mg.clone();
        let (ns, nu) = (spec.states.len(), spec.inputs.len());
        let avoid = model_names(model);
        let rows: Vec<NodeId> = spec.states.iter().map(|&i| g.f[i]).collect();
        let states: Vec<NodeId> = spec.states.iter().map(|&i| g.x[i]).collect();
        let inputs: Vec<NodeId> = spec.inputs.iter().map(|&i| g.u[i]).collect();
        let a = g.jacobian(&rows, &states);
        let b = g.jacobian(&rows, &inputs);
        let graph = &mut g.graph;
        let p_vars = packed_vars(graph, "p", ns, &avoid);
        let q_vars = packed_vars(graph, "q", ns, &avoid);
        let r_vars = packed_vars(graph, "r", nu, &avoid);
        let p = symmetric_from_packed(&p_vars, ns);
        let q = symmetric_from_packed(&q_vars, ns);
        let r = symmetric_from_packed(&r_vars, nu);
        // eq. (19): K = (R + B'PB)^-1 B'PA; P = A'PA - A'PB K + Q.
        let step = riccati_step_single_input(graph, (&a, &b), &p, (&q, &r), |g, j| {
            g.var(&pivot_names(nu, j, WEIGHT, "").1)
        });
        let k_flat: Vec<NodeId> = step.gain.iter().flatten().copied().collect();
        let loop_vars: Vec<NodeId> = p_vars.iter().chain(&step.reciprocals).copied().collect();
        let invariant = loop_invariant_operands(graph, &body_roots(&step, &k_flat), &loop_vars);
        Recursion {
            g,
            a,
            b,
            p_vars,
            q_vars,
            r_vars,
            step,
            k_flat,
            invariant,
        }
    }

    /// Lowers the loop body, `P <- A'PA - A'PB K + Q` (eq. 19) `HORIZON` times from
    /// `P = Q`, and after the loop the gain `F = (R + B'PB)^-1 B'PA` from the final `P`
    /// (Alg. 3), both behind the checked pivots of `R + B'PB`.
    fn lower(&self, model: &Model, spec: &LqrSpec, scalar: Scalar) -> RecursionCode {
        let mut lowerer = self.hoisted(model, spec, scalar);
        // P is carried from one iteration to the next in registers.
        lowerer.hold_in_registers(&self.p_vars);
        lowerer.hoist_leaves(&self.step.p_next);
        let before_loop = lowerer.ops();
        let outside = lowerer.take_statements();
        // The gain after the loop comes from a fork taken here, so it does not rely on
        // temporaries scoped inside the loop body.
        let mut after = lowerer.clone();
        self.guard_weight(&mut lowerer, scalar);
        let p_values = lowerer.segment(&self.step.p_next);
        let body = lowerer.take_statements();
        let per_step = lowerer.ops().minus(before_loop);
        let Lowered { used_vars, .. } = lowerer.finish();
        self.guard_weight(&mut after, scalar);
        let k_values = after.segment(&self.k_flat);
        let gain_statements = after.take_statements();
        let gain_ops = after.ops().minus(before_loop);
        let Lowered {
            used_vars: used_after,
            ..
        } = after.finish();
        RecursionCode {
            outside,
            body,
            p_values,
            gain_statements,
            k_values,
            used_vars: used_vars.union(&used_after).copied().collect(),
            used_after,
            ops: before_loop
                .plus(per_step.looped(spec.horizon))
                .plus(gain_ops),
        }
    }

    /// A lowerer that names the entries of `A` and `B` after their states and inputs
    /// (`a_<state>_<state>`, `b_<state>_<input>`) and has bound the loop-invariant operands.
    fn hoisted(&self, model: &Model, spec: &LqrSpec, scalar: Scalar) -> Lowerer<'_> {
        let mut all_roots = body_roots(&self.step, &self.k_flat);
        all_roots.extend(&self.invariant);
        let avoid = model_names(model);
        let namer = TempNamer::new(avoid.iter().map(String::as_str));
        let mut lowerer = Lowerer::new(&self.g.graph, scalar, namer, &all_roots);
        for (row, name) in self.a.iter().zip(spec.states.iter()) {
            for (&entry, col) in row.iter().zip(&spec.states) {
                let name = format!("a_{}_{}", model.states[*name].name, model.states[*col].name);
                lowerer.prefer_name(entry, &name);
            }
        }
        for (row, state) in self.b.iter().zip(&spec.states) {
            for (&entry, input) in row.iter().zip(&spec.inputs) {
                let name = format!(
                    "b_{}_{}",
                    model.states[*state].name, model.inputs[*input].name
                );
                lowerer.prefer_name(entry, &name);
            }
        }
        for &node in &self.invariant {
            lowerer.force_let(node);
        }
        lowerer
    }

    /// Binds each pivot of `R + B'PB`, returning `NonPositiveControlWeight` unless it is
    /// positive, and its reciprocal.
    fn guard_weight(&self, lowerer: &mut Lowerer, scalar: Scalar) {
        let failure = quote! { return Status::NonPositiveControlWeight; };
        let (pivots, reciprocals) = (&self.step.pivots, &self.step.reciprocals);
        guard_pivots(
            lowerer,
            pivots,
            reciprocals,
            (WEIGHT, ""),
            &|_| failure.clone(),
            scalar,
        );
    }
}

/// What the loop body computes: `K`, the next `P` and the pivots of `R + B'PB`; the rest
/// of what it needs is hoisted before the loop.
fn body_roots(step: &RiccatiStep, k_flat: &[NodeId]) -> Vec<NodeId> {
    k_flat
        .iter()
        .chain(&step.p_next)
        .chain(&step.pivots)
        .copied()
        .collect()
}

/// The identifiers of those of `vars` the code reads.
fn used_idents(g: &Graph, vars: &[NodeId], used: &BTreeSet<VarId>) -> Vec<Ident> {
    vars.iter()
        .filter(|&&v| matches!(g.node(v), Node::Var(id) if used.contains(&id)))
        .map(|&v| var_idents(g, &[v]).remove(0))
        .collect()
}

/// `name`, or `_name` for an argument the code does not read.
fn argument(name: &str, read: bool) -> Ident {
    if read {
        ident(name)
    } else {
        ident(&format!("_{name}"))
    }
}

/// `fn solve`: `HORIZON` Riccati steps from `P = Q` (eq. 19), then the gain `K` from the
/// final `P` (Alg. 3), stored only if it is finite.
fn solve_method(
    model: &Model,
    recursion: &Recursion,
    code: &RecursionCode,
    laws: &ControlLaws,
    scalar: Scalar,
) -> TokenStream {
    let (graph, used) = (&recursion.g.graph, &code.used_vars);
    let arguments = SolveArguments::new(model, &recursion.g, used, scalar);
    let (doc, params, reads) = (arguments.doc, arguments.params, arguments.reads);
    let unpack_p = destructure(graph, quote! { p }, &recursion.p_vars, used);
    // The gain reads fewer entries of the final `P` than a Riccati step does.
    let unpack_p_for_gain = destructure(graph, quote! { p }, &recursion.p_vars, &code.used_after);
    let unpack_q = destructure(graph, quote! { self.q }, &recursion.q_vars, used);
    let unpack_r = destructure(graph, quote! { self.r }, &recursion.r_vars, used);
    let ns = recursion.a.len();
    let k_rows = code.k_values.chunks(ns).map(|row| quote! { [#(#row),*] });
    let (outside, body, p_values) = (&code.outside, &code.body, &code.p_values);
    let gain_statements = &code.gain_statements;
    let gain_pattern = &laws.gain_pattern;
    let gain_rows_flat = laws.gain_rows.iter().flatten();
    quote! {
        #[doc = #doc]
        pub fn solve(&mut self, #params) -> Status {
            #reads
            #unpack_q
            #unpack_r
            #(#outside)*
            let mut p = self.q;
            for _ in 0..Self::HORIZON {
                #unpack_p
                #(#body)*
                p = [#(#p_values),*];
            }
            #unpack_p_for_gain
            #(#gain_statements)*
            let gain = [#(#k_rows),*];
            let [#(#gain_pattern),*] = gain;
            if !(#(#gain_rows_flat)+*).is_finite() {
                return Status::NonFinite;
            }
            self.gain = gain;
            Status::Ok
        }
    }
}

/// The arguments of `solve` and their reading.
struct SolveArguments {
    /// The method's doc, which says whether `A` and `B` depend on the input.
    doc: &'static str,
    /// `t` if the model uses time, the estimate `x` and the operating input `u` (`_x`,
    /// `_u` if unread: `A` and `B` need not depend on them).
    params: TokenStream,
    /// The entries read unpacked (the known constants too) and checked finite.
    reads: TokenStream,
}

impl SolveArguments {
    fn new(model: &Model, g: &ModelGraph, used: &BTreeSet<VarId>, scalar: Scalar) -> Self {
        let graph = &g.graph;
        let ty = ident(scalar.type_name());
        let unpack_x = destructure(graph, quote! { *x }, &g.x, used);
        let unpack_u = destructure(graph, quote! { *u }, &g.u, used);
        let unpack_known = destructure(graph, quote! { self.known }, &g.known, used);
        let x_idents = used_idents(graph, &g.x, used);
        let u_idents = used_idents(graph, &g.u, used);
        let checked: Vec<_> = x_idents.iter().chain(&u_idents).cloned().collect();
        let check = reject_non_finite(&checked, &[], &ty);
        let time = model.uses_time().then(|| {
            let t = time_param(graph, g.t, used, &ty, "t");
            quote! { #t, }
        });
        let x_name = argument("x", !x_idents.is_empty());
        // The linearisation's input, an argument whether or not `A` and `B` depend on it.
        let u_name = argument("u", !u_idents.is_empty());
        let u_len = Literal::usize_unsuffixed(g.u.len());
        let doc = if !u_idents.is_empty() {
            " Recomputes the gain for the estimate `x` and the input `u` the model is \
             linearised at (the operating input: `A` and `B` depend on it): `HORIZON` Riccati \
             steps from `P = Q`, then `K` from the final `P`. Leaves the gain \
             unchanged unless it returns [`Status::Ok`]."
        } else {
            " Recomputes the gain for the estimate `x` (`A` and `B` do not depend on the \
             input, so the operating input is not read): `HORIZON` Riccati steps from \
             `P = Q`, then `K` from the final `P`. Leaves the gain unchanged unless it \
             returns [`Status::Ok`]."
        };
        let n = Literal::usize_unsuffixed(model.state_len());
        SolveArguments {
            doc,
            params: quote! { #time #x_name: &[#ty; #n], #u_name: &[#ty; #u_len] },
            reads: quote! {
                #unpack_x
                #unpack_u
                #unpack_known
                #check
            },
        }
    }
}

/// The names the control laws bind, shared by `solve` (which checks the new gain) and the
/// methods `control`, `track` and `saturate`.
struct ControlLaws {
    ty: Ident,
    /// The state vector's length and the LQR's inputs'.
    n: Literal,
    nu_len: Literal,
    /// The regulated states, in the order of the gain's columns.
    regulated: Vec<Ident>,
    /// `[x1, _, x3]`: the regulated states in the whole state vector.
    regulated_pattern: Vec<TokenStream>,
    /// `[x1_ref, _, x3_ref]`: the same in the set-point.
    reference_pattern: Vec<TokenStream>,
    /// `k11 k12 ..`, the gain's entries row by row, and `[[k11, k12], ..]` as a pattern.
    gain_rows: Vec<Vec<Ident>>,
    gain_pattern: Vec<TokenStream>,
    /// The inputs the LQR computes, their references `<input>_ref` and limits
    /// `<input>_limit`.
    controls: Vec<Ident>,
    reference_inputs: Vec<Ident>,
    limits: Vec<Ident>,
}

impl ControlLaws {
    fn new(model: &Model, spec: &LqrSpec, scalar: Scalar) -> ControlLaws {
        let (ns, nu) = (spec.states.len(), spec.inputs.len());
        let state_names = model.states_named(&spec.states);
        let input_names = model.inputs_named(&spec.inputs);
        // `k12`, or `k_1_12` past nine states or inputs (`k112` would be ambiguous), clear
        // of the model's names: `control` binds the states' names beside the gain's.
        let taken = model_names(model);
        let gain_rows: Vec<Vec<Ident>> = (1..=nu)
            .map(|i| {
                (1..=ns)
                    .map(|j| {
                        let name = matrix_entry("k", (nu, ns), (i, j));
                        ident(&clear_of(&name, |n| taken.iter().any(|t| t == n)))
                    })
                    .collect()
            })
            .collect();
        let suffixed = |names: &[&str], suffix: &str| -> Vec<Ident> {
            names
                .iter()
                .map(|n| ident(&format!("{n}{suffix}")))
                .collect()
        };
        ControlLaws {
            ty: ident(scalar.type_name()),
            n: Literal::usize_unsuffixed(model.state_len()),
            nu_len: Literal::usize_unsuffixed(nu),
            regulated: suffixed(&state_names, ""),
            regulated_pattern: regulated_entries(model, &state_names, ""),
            reference_pattern: regulated_entries(model, &state_names, "_ref"),
            gain_pattern: gain_rows.iter().map(|row| quote! { [#(#row),*] }).collect(),
            gain_rows,
            controls: suffixed(&input_names, ""),
            reference_inputs: suffixed(&input_names, "_ref"),
            limits: suffixed(&input_names, "_limit"),
        }
    }

    /// `control`, `track` and `saturate`.
    fn methods(&self) -> TokenStream {
        let (control, track, saturate) = (self.control(), self.track(), self.saturate());
        quote! {
            #control

            #track

            #saturate
        }
    }

    /// `fn control`: `u = -K x`, saturated.
    fn control(&self) -> TokenStream {
        let (ty, n, nu_len) = (&self.ty, &self.n, &self.nu_len);
        let (regulated_pattern, gain_pattern) = (&self.regulated_pattern, &self.gain_pattern);
        let control_names = &self.controls;
        let regulated = &self.regulated;
        let controls = self.gain_rows.iter().zip(control_names).map(|(row, u)| {
            quote! { let #u = -(#(#row * #regulated)+*); }
        });
        quote! {
            /// The control `u = -K x` for the estimate `x`, saturated to the limits: the
            /// regulator to zero ([`Lqr::track`] with a zero reference).
            #[must_use]
            pub fn control(&self, x: &[#ty; #n]) -> [#ty; #nu_len] {
                let [#(#regulated_pattern),*] = *x;
                let [#(#gain_pattern),*] = self.gain;
                #(#controls)*
                self.saturate([#(#control_names),*])
            }
        }
    }

    /// `fn track`: `u = u_ref - K (x - x_ref)`, saturated.
    fn track(&self) -> TokenStream {
        let (ty, n, nu_len) = (&self.ty, &self.n, &self.nu_len);
        let (regulated_pattern, gain_pattern) = (&self.regulated_pattern, &self.gain_pattern);
        let (reference_pattern, reference_inputs) =
            (&self.reference_pattern, &self.reference_inputs);
        let control_names = &self.controls;
        let tracking = self
            .gain_rows
            .iter()
            .zip(control_names)
            .zip(reference_inputs)
            .map(|((row, u), u_ref)| {
                let errors = self.regulated.iter().map(|s| {
                    let s_ref = ident(&format!("{s}_ref"));
                    quote! { (#s - #s_ref) }
                });
                quote! { let #u = #u_ref - (#(#row * #errors)+*); }
            });
        quote! {
            /// The control tracking a reference, `u = u_ref - K (x - x_ref)`, saturated to
            /// the limits: `x` the estimate, `x_ref` the set-point (only the regulated
            /// states are read), `u_ref` the input that holds the plant there, such as
            /// [`Lqr::steady_state_input`] gives.
            #[must_use]
            pub fn track(&self, x: &[#ty; #n], x_ref: &[#ty; #n], u_ref: &[#ty; #nu_len]) -> [#ty; #nu_len] {
                let [#(#regulated_pattern),*] = *x;
                let [#(#reference_pattern),*] = *x_ref;
                let [#(#reference_inputs),*] = *u_ref;
                let [#(#gain_pattern),*] = self.gain;
                #(#tracking)*
                self.saturate([#(#control_names),*])
            }
        }
    }

    /// `fn saturate`: each input clipped to `[-limit, limit]` if limits were given.
    fn saturate(&self) -> TokenStream {
        let (ty, nu_len) = (&self.ty, &self.nu_len);
        let (control_names, limit_names) = (&self.controls, &self.limits);
        let saturations = control_names.iter().zip(limit_names).map(|(u, limit)| {
            quote! {
                if #u > #limit {
                    #limit
                } else if #u < -#limit {
                    -#limit
                } else {
                    #u
                }
            }
        });
        quote! {
            /// `u` limited to `u_max`, if limits were given.
            fn saturate(&self, unsaturated: [#ty; #nu_len]) -> [#ty; #nu_len] {
                let [#(#control_names),*] = unsaturated;
                match self.u_max {
                    None => unsaturated,
                    Some([#(#limit_names),*]) => [#(#saturations),*],
                }
            }
        }
    }
}

/// `[x1<suffix>, _, x3<suffix>]`'s entries: the regulated states among all the states and
/// parameters, the others `_`.
fn regulated_entries(model: &Model, regulated: &[&str], suffix: &str) -> Vec<TokenStream> {
    model
        .state_names()
        .map(|name| {
            if regulated.contains(&name) {
                let name = ident(&format!("{name}{suffix}"));
                quote! { #name }
            } else {
                quote! { _ }
            }
        })
        .collect()
}

/// The `Lqr` type: its fields, `HORIZON`, the constructor and the gain's accessor, around
/// the steady-state input, `solve` and the control laws (`laws`).
fn lqr_type(
    model: &Model,
    spec: &LqrSpec,
    scalar: Scalar,
    laws: &ControlLaws,
    (steady_state, solve): (TokenStream, TokenStream),
) -> TokenStream {
    let ty = ident(scalar.type_name());
    let (ns, nu) = (spec.states.len(), spec.inputs.len());
    let (ns_len, nu_len) = (Literal::usize_unsuffixed(ns), Literal::usize_unsuffixed(nu));
    let (nsp, nup) = (
        Literal::usize_unsuffixed(packed_len(ns)),
        Literal::usize_unsuffixed(packed_len(nu)),
    );
    let horizon = Literal::usize_unsuffixed(spec.horizon as usize);
    let doc = lqr_doc(model, spec);
    let known = crate::emit::known::known_items(model, &ty);
    let (known_field, known_methods) = (&known.field, &known.methods);
    let constructor = constructor(spec, scalar, &laws.limits, &known);
    let laws = laws.methods();
    quote! {
        #[doc = #doc]
        #[derive(Clone, Copy, Debug, PartialEq)]
        pub struct Lqr {
            q: [#ty; #nsp],
            r: [#ty; #nup],
            u_max: Option<[#ty; #nu_len]>,
            gain: [[#ty; #ns_len]; #nu_len],
            #known_field
        }

        impl Lqr {
            /// Steps of the backward Riccati recursion.
            pub const HORIZON: usize = #horizon;

            #constructor

            #known_methods

            #steady_state

            /// The gain `K` of the last successful [`Lqr::solve`].
            #[must_use]
            pub fn gain(&self) -> [[#ty; #ns_len]; #nu_len] {
                self.gain
            }

            #solve

            #laws
        }
    }
}

/// The type's doc: Algorithm 3 of the double Kalman filter paper on the regulated states
/// and inputs.
fn lqr_doc(model: &Model, spec: &LqrSpec) -> String {
    let state_names = model.states_named(&spec.states);
    let input_names = model.inputs_named(&spec.inputs);
    format!(
        " Adaptive finite-horizon LQR (Algorithm 3 of the double Kalman filter paper) regulating `[{}]` with `[{}]`. At each \
         [`Lqr::solve`] the physical sub-model `A = df/d[{0}]`, `B = df/d[{1}]` is taken at \
         the current estimate, and the backward Riccati recursion (eq. (19) of that paper, `R` inside the \
         inverse) runs over the horizon; [`Lqr::control`] then gives `u = -K x`, saturated.",
        state_names.join(", "),
        input_names.join(", ")
    )
}

/// `fn new`: the weights' upper triangles packed, the limits, a zero gain; every entry
/// read checked finite, the limits' when given, and the weights positive semi-definite.
fn constructor(
    spec: &LqrSpec,
    scalar: Scalar,
    limits: &[Ident],
    known: &KnownItems,
) -> TokenStream {
    let ty = ident(scalar.type_name());
    let (ns, nu) = (spec.states.len(), spec.inputs.len());
    let (ns_len, nu_len) = (Literal::usize_unsuffixed(ns), Literal::usize_unsuffixed(nu));
    let zero = literal(0.0, scalar);
    let mut arguments = Arguments::default();
    let q = arguments.weight("q", ns, &ty);
    let r = arguments.weight("r", nu, &ty);
    arguments.plain(quote! { u_max: Option<&[#ty; #nu_len]> });
    let known_init = known.argument(&mut arguments);
    let limits_finite = all_is_finite(limits);
    arguments.constructor(
        &quote! {
            /// A controller with state weight `q` and input weight `r` (symmetric: upper
            /// triangles are read; each positive semi-definite, checked, and `R + B' P B`
            /// positive definite at each solve) and, if given, the symmetric input limits
            /// `u_max`. The gain is zero until the first [`Lqr::solve`].
        },
        REJECTS_NON_FINITE,
        quote! {
            let u_max = match u_max {
                None => None,
                Some(&[#(#limits),*]) if #limits_finite => Some([#(#limits),*]),
                Some(_) => return Err(Status::RejectedInput),
            };
            Ok(Lqr {
                q: [#(#q),*],
                r: [#(#r),*],
                u_max,
                gain: [[#zero; #ns_len]; #nu_len],
                #known_init
            })
        },
    )
}

/// The pivot names of the Gram matrix `B'B`.
const GRAM: (&str, &str) = ("gram", "inv_gram");

/// `fn steady_state_input(&self, x_ref, u)`: the input holding the regulated states at a
/// set-point, `u_ref = u + (B'B)^-1 B' (x_ref - f(x_ref, u))` over the regulated states and
/// inputs, with `B = df/d[inputs]` at `(x_ref, u)`: one Gauss-Newton step on the fixed
/// point `f(x_ref, u_ref) = x_ref`, exact for a model affine in its inputs (the least-
/// squares input when the set-point is not an equilibrium any input reaches).
fn steady_state_input(
    model: &Model,
    spec: &LqrSpec,
    mg: &ModelGraph,
    scalar: Scalar,
) -> TokenStream {
    let mut g = mg.clone();
    let rows: Vec<NodeId> = spec.states.iter().map(|&i| g.f[i]).collect();
    let inputs: Vec<NodeId> = spec.inputs.iter().map(|&i| g.u[i]).collect();
    let b = g.jacobian(&rows, &inputs);
    let states: Vec<NodeId> = spec.states.iter().map(|&i| mg.x[i]).collect();
    let nu = spec.inputs.len();
    let step = steady_state_step(&mut g.graph, (&states, &rows), (&inputs, &b), |g, j| {
        g.var(&pivot_names(nu, j, GRAM, "").1)
    });
    let lowered = lower_steady_state(model, &g, &step, scalar);
    steady_state_method(model, spec, &g, lowered, scalar)
}

/// The step's statements, behind the checked pivots of `B'B`, and `u_ref`'s values.
fn lower_steady_state(
    model: &Model,
    g: &ModelGraph,
    step: &SteadyStateStep,
    scalar: Scalar,
) -> (Vec<TokenStream>, Lowered) {
    let mut roots = step.input.clone();
    roots.extend(&step.pivots);
    let avoid = model_names(model);
    let namer = TempNamer::new(avoid.iter().map(String::as_str));
    let mut lowerer = Lowerer::new(&g.graph, scalar, namer, &roots);
    lowerer.read_lazily(&quote! { self.known }, &g.known);
    guard_pivots(
        &mut lowerer,
        &step.pivots,
        &step.reciprocals,
        (GRAM, ""),
        &|_| quote! { return Err(Status::NonFinite); },
        scalar,
    );
    let values = lowerer.segment(&step.input);
    (values, lowerer.finish())
}

/// The method around the lowered step: its arguments (`t` if the model uses time, the
/// set-point `x_ref`, the starting input `u`), their check, and the check of the result.
fn steady_state_method(
    model: &Model,
    spec: &LqrSpec,
    g: &ModelGraph,
    (values, lowered): (Vec<TokenStream>, Lowered),
    scalar: Scalar,
) -> TokenStream {
    let Lowered {
        statements,
        used_vars,
        ..
    } = lowered;
    let graph = &g.graph;
    let ty = ident(scalar.type_name());
    let n = Literal::usize_unsuffixed(model.state_len());
    let nu_len = Literal::usize_unsuffixed(spec.inputs.len());
    let x_idents = used_idents(graph, &g.x, &used_vars);
    let u_idents = used_idents(graph, &g.u, &used_vars);
    let unpack_x = destructure(graph, quote! { *x_ref }, &g.x, &used_vars);
    let unpack_u = destructure(graph, quote! { *u }, &g.u, &used_vars);
    let checked: Vec<_> = x_idents.iter().chain(&u_idents).cloned().collect();
    let finite = all_is_finite(&checked);
    let check = (!checked.is_empty())
        .then(|| quote! { if !(#finite) { return Err(Status::RejectedInput); } });
    let time = model.uses_time().then(|| {
        let t = time_param(graph, g.t, &used_vars, &ty, "t");
        quote! { #t, }
    });
    let x_name = argument("x_ref", !x_idents.is_empty());
    let u_len = Literal::usize_unsuffixed(g.u.len());
    let u_name = argument("u", !u_idents.is_empty());
    let result: Vec<Ident> = spec
        .inputs
        .iter()
        .map(|&i| ident(&format!("{}_ref", model.inputs[i].name)))
        .collect();
    let finite_result = all_is_finite(&result);
    quote! {
        /// The input `u_ref` that holds the regulated states at the set-point `x_ref` (a
        /// whole state vector: the other states and the parameters at the values to
        /// linearise at, such as the estimate's), for [`Lqr::track`]: `u_ref = u + (B'B)^-1
        /// B' (x_ref - f(x_ref, u))` over the regulated states and inputs, `B = df/du` at
        /// `(x_ref, u)`, starting from the input `u` (the inputs not computed by the LQR
        /// stay as given). Exact for a model affine in its inputs; otherwise one
        /// Gauss-Newton step, repeated from its result to converge.
        ///
        /// # Errors
        ///
        /// [`Status::RejectedInput`] if an entry it reads of `x_ref` or `u` is not finite,
        /// [`Status::NonFinite`] if the inputs cannot move the regulated states (`B'B`
        /// singular: `u_ref` would not be finite) or `u_ref` is not finite.
        pub fn steady_state_input(&self, #time #x_name: &[#ty; #n], #u_name: &[#ty; #u_len]) -> Result<[#ty; #nu_len], Status> {
            #unpack_x
            #unpack_u
            #check
            #(#statements)*
            let [#(#result),*] = [#(#values),*];
            if !(#finite_result) {
                return Err(Status::NonFinite);
            }
            Ok([#(#result),*])
        }
    }
}
