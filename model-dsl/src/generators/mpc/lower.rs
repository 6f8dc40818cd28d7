//! The adaptive model predictive controller with input bounds (Takacs, Polóni,
//! Rohal'-Ilkiv, "Adaptive predictive control of transient vibrations of cantilevers with
//! changing weight", sect. 3.3-3.5): at each solve, the prediction model at the estimate,
//! the terminal weight by warm-started Riccati steps, the condensed problem of eqs.
//! (42)-(44), and a primal active-set solve of its box-constrained QP. Each stage is a
//! symbolic stage lowered to straight-line code; stages hand over through named values.

use super::cache::{Cache, KeptHessian};
use super::dual;
use super::limit_api;
use super::names::{failure, Names};
use super::predictive::{
    column_norm, condensed_hessian, condensed_linear, scale, zoh_square, zoh_taylor,
};
use super::qp::{active_set_loop, MoveNames, QpCode};
use super::spec::MpcSpec;
use super::spec::{MpcDiscretisation, MpcSolver};
use super::stage::Stage;
use super::target;
use super::work_bound::SolveOps;
use crate::emit::arguments::Arguments;
use crate::emit::code::{
    all_is_finite, doc_attributes, guard_pivots, pivot_names, unpack_symmetric, var_idents,
};
use crate::emit::filter::{packed_vars, time_param};
use crate::emit::lower::{literal, Lowerer, OpCount};
use crate::emit::names::ident;
use crate::emit::scopes::scoped;
use crate::model::{Model, Scalar};
use crate::symbolic::linalg::{add, matmul, packed_len, symmetric_from_packed, Matrix};
use crate::symbolic::loop_invariant_operands;
use crate::symbolic::riccati::{riccati_step, RiccatiStep};
use crate::symbolic::{Graph, ModelGraph, NodeId, VarId};
use proc_macro2::{Ident, Literal, TokenStream};
use quote::quote;
use std::collections::BTreeSet;

/// Generated MPC code and its cost.
pub struct MpcCode {
    /// The `Mpc` and `MpcStatus` types and their methods.
    pub tokens: TokenStream,
    /// The arithmetic of its solve's parts: the prediction model with the hold's squarings
    /// at their bound; all `RICCATI_ITERATIONS` steps towards the terminal weight and its
    /// gain; the condensed Hessian and weighted responses, eqs. (42)-(43), with storing
    /// what the next solve may keep; the plan, what every solve runs besides the rebuilds
    /// and the iterations (the test of the kept model, the estimate's reading, the linear
    /// term of eq. 44, the warm start with its tail, the gradient at it and the commit);
    /// and one active-set iteration with the loop's branch back.
    pub ops: SolveOps,
}

/// The variables later stages read for `values`, one per entry named by `names`; entries
/// that are literals (a structural zero, a constant step) stay literals downstream.
fn declare_matrix(g: &mut Graph, values: &Matrix, names: &[Vec<String>]) -> Matrix {
    values
        .iter()
        .zip(names)
        .map(|(row, names)| {
            row.iter()
                .zip(names)
                .map(|(&v, name)| match g.literal(v) {
                    Some(_) => v,
                    None => g.var(name),
                })
                .collect()
        })
        .collect()
}

/// Lowers each non-literal entry of `values` and binds it to its name (`let a11 = ..;`).
fn bind_matrix(lowerer: &mut Lowerer, values: &Matrix, names: &[Vec<String>]) {
    for (values, names) in values.iter().zip(names) {
        for (&value, name) in values.iter().zip(names) {
            bind_as(lowerer, value, name);
        }
    }
}

/// Lowers `value` and binds it to `name`, unless it is a literal.
fn bind_as(lowerer: &mut Lowerer, value: NodeId, name: &str) {
    if lowerer.graph().literal(value).is_some() {
        return;
    }
    lowerer.prefer_name(value, name);
    let expr = lowerer.force_let(value);
    if expr.to_string() != name {
        let id = ident(name);
        lowerer.statement(quote! { let #id = #expr; });
    }
}

/// Variables named `names`, entry by entry.
fn matrix_vars(g: &mut Graph, names: &[Vec<String>]) -> Matrix {
    names
        .iter()
        .map(|row| row.iter().map(|n| g.var(n)).collect())
        .collect()
}

/// The MPC of `model` in `scalar`.
pub fn emit_mpc(model: &Model, spec: &MpcSpec, mg: &ModelGraph, scalar: Scalar) -> MpcCode {
    let mut mg = mg.clone();
    let (ns, nu) = (spec.states.len(), spec.inputs.len());
    let names = Names::new(model);
    let moves = MoveNames::new(model, spec, &names);
    let prediction = prediction_model(model, spec, &mut mg, &names, scalar);
    let (a, b) = (&prediction.a, &prediction.b);
    let terminal = terminal_weight(&mut mg.graph, (a, b), spec, &names, scalar);
    let (solver, allowed) = solver(
        model,
        (spec, &moves, &names),
        &mut mg,
        (a, b, &terminal),
        scalar,
    );
    let cache = Cache::new(&mg, &prediction.used, solver.kept, &solver.weighted, scalar);

    let (head_code, qp_code) = (&solver.head.code, &solver.qp.code);
    let plan_ops = cache
        .reuse_ops()
        .plus(read_estimate_ops(&mg, &solver.used))
        .plus(solver.head.ops)
        .plus(solver.qp.setup_ops)
        .plus(solver.warm_start_ops)
        .plus(commit_ops(&moves));
    let commit = commit(&moves, &terminal, &cache, &solver.kept_state);
    let plan = quote! {
        #head_code
        #allowed
        #qp_code
        #commit
    };
    let rebuild = [&terminal.stage.code, &solver.rebuild.code];
    let rebuild = quote! { #(#rebuild)* };
    let prediction_method = prediction_method(model, &mg, &prediction, scalar);
    let solve = SolveParts {
        prediction: &prediction,
        used: &solver.used,
        cache: &cache,
        terminal: &terminal,
        budgeted: spec.iterations_within_budget.is_some(),
        dual: spec.solver == MpcSolver::DualActiveSet,
        free_response: !(spec.limits.states.is_empty() && spec.limits.outputs.is_empty()),
    };
    let solve = solve_method(model, &mg, &solve, (rebuild, plan), scalar);
    let methods = quote! {
        #prediction_method

        #solve
    };
    let tokens = type_tokens(
        model,
        spec,
        methods,
        (&moves, &cache),
        scalar,
        prediction.holds,
    );
    let ops = SolveOps {
        plan: plan_ops,
        prediction: prediction.stage.ops,
        riccati: terminal.stage.ops.plus(terminal_store_ops(&terminal)),
        // The kept prediction model is stored whole: `A` and `B`.
        condense: solver.rebuild.ops.plus(cache.store_ops(ns * (ns + nu))),
        iteration: solver.qp.iteration_ops.looped(1),
    };
    MpcCode { tokens, ops }
}

/// The QP's solve as `spec.solver` chooses, and what it needs besides.
struct Solver {
    /// What the plan starts with: the linear term (eq. 44), or the unconstrained minimiser.
    head: Stage,
    /// The model variables `head` reads.
    used: BTreeSet<VarId>,
    qp: QpCode,
    /// The primal active set's warm start's new last move (the dual mode's tail).
    warm_start_ops: OpCount,
    /// What the rebuild adds after the terminal weight: `H` and the weighted responses
    /// for the primal active set, `G = H^-1`, `K` and the limit rows for the dual.
    rebuild: Stage,
    /// What the cache keeps of the Hessian.
    kept: KeptHessian,
    /// The weighted responses' variables the cache keeps (the primal active set's linear
    /// term reads them; the dual active set keeps `K` instead).
    weighted: Vec<NodeId>,
    /// What the commit stores besides the plan: the dual active set's held limits.
    kept_state: TokenStream,
}

/// The QP's solve, and the statement binding `allowed_iterations` when a cycle budget
/// bounds them.
fn solver(
    model: &Model,
    (spec, moves, names): (&MpcSpec, &MoveNames, &Names),
    mg: &mut ModelGraph,
    (a, b, terminal): (&Matrix, &Matrix, &Terminal),
    scalar: Scalar,
) -> (Solver, TokenStream) {
    let (last_pass, allowed) = last_pass(spec);
    let solver = match spec.solver {
        MpcSolver::PrimalActiveSet => {
            let g = &mut mg.graph;
            let condensed = condense_model(spec, g, (a, b, &terminal.p), moves, names);
            let lowered = condensed.lower(g, moves, names, scalar);
            let linear = linear_term(model, spec, mg, (a, &condensed), moves, names, scalar);
            let tail = dual_mode_tail(model, spec, mg, (a, b), moves, names, scalar);
            let qp = active_set_loop(
                &mut mg.graph,
                moves,
                (names, &tail.code, &last_pass),
                scalar,
            );
            Solver {
                head: linear.stage,
                used: linear.used,
                qp,
                warm_start_ops: tail.ops,
                rebuild: lowered,
                kept: KeptHessian::Packed(moves.hessian.iter().map(|h| ident(h)).collect()),
                weighted: condensed.weighted_vars(),
                kept_state: TokenStream::new(),
            }
        }
        MpcSolver::DualActiveSet => {
            let limit = match spec.iterations_within_budget {
                None => quote! { Self::MAX_ITERATIONS },
                Some(_) => quote! { allowed_iterations },
            };
            let (head, used) = dual::unconstrained(model, (spec, moves, names), mg, (a, scalar));
            let rebuild = dual::rebuild(
                &mut mg.graph,
                (a, b, &terminal.p_idents),
                (spec, moves, names),
                scalar,
            );
            Solver {
                head,
                used,
                qp: dual::dual_active_set((spec, moves), &limit, scalar),
                warm_start_ops: OpCount::default(),
                rebuild,
                kept: KeptHessian::Inverse {
                    moves: moves.count(),
                    states: spec.states.len(),
                    rows: spec.limit_rows(),
                    pattern: dual::gain_pattern(spec, moves, names),
                },
                weighted: Vec::new(),
                kept_state: quote! { self.held = held; },
            }
        }
    };
    (solver, allowed)
}

/// The condition that ends the active-set loop before a pass's step, and the statement
/// it needs: after `MAX_ITERATIONS` steps (`pass == Self::PASSES`) without a cycle budget;
/// within one, after the iterations `ITERATIONS_WITHIN_BUDGET` allows the kind of solve
/// this one is (what it rebuilt).
fn last_pass(spec: &MpcSpec) -> (TokenStream, TokenStream) {
    match spec.iterations_within_budget {
        None => (quote! { pass == Self::PASSES }, TokenStream::new()),
        Some(_) => (
            quote! { pass > allowed_iterations },
            quote! {
                // The iterations within the cycle budget after what this solve rebuilt.
                let [kept, problem, model_and_problem] = Self::ITERATIONS_WITHIN_BUDGET;
                let allowed_iterations = if reuse {
                    kept
                } else if keep_model {
                    problem
                } else {
                    model_and_problem
                };
            },
        ),
    }
}

/// `fn prediction_model`: the prediction stage on its own, returning `A` and `B`.
fn prediction_method(
    model: &Model,
    mg: &ModelGraph,
    prediction: &Prediction,
    scalar: Scalar,
) -> TokenStream {
    let ty = ident(scalar.type_name());
    let (a, b) = (&prediction.a, &prediction.b);
    let signature = signature(model, mg, &prediction.used, &ty);
    let read = read_estimate(
        mg,
        &prediction.used,
        &reject(quote! { Status::RejectedInput }),
    );
    let code = &prediction.stage.code;
    let (a_values, b_values) = (
        returned(&mg.graph, a, scalar),
        returned(&mg.graph, b, scalar),
    );
    quote! {
        /// The prediction model `x+ = A x + B u` (eq. 30) of the regulated states at the
        /// estimate `x` and operating input `u`, as [`Mpc::solve`] takes it.
        ///
        /// # Errors
        ///
        /// [`Status::RejectedInput`] if an entry it reads of `x` or `u` is not finite,
        /// [`Status::NonFinite`] if the hold would not be finite.
        pub fn prediction_model(#signature) -> Result<PredictionModel, Status> {
            #read
            #code
            Ok(PredictionModel {
                a: [#(#a_values),*],
                b: [#(#b_values),*],
            })
        }
    }
}

/// What `solve` is built of besides its plan.
struct SolveParts<'a> {
    prediction: &'a Prediction,
    /// The model variables the linear term reads.
    used: &'a BTreeSet<VarId>,
    cache: &'a Cache,
    terminal: &'a Terminal,
    /// Whether a cycle budget bounds the iterations (`ITERATIONS_WITHIN_BUDGET`).
    budgeted: bool,
    /// Whether the dual active set solves the QP.
    dual: bool,
    /// Whether its limits read the free response (state or output limits).
    free_response: bool,
}

/// `fn solve`: the kept model, or the prediction model and `rebuild` (the terminal
/// weight and the condensed Hessian) on it; then the estimate's reading for the linear
/// term and `plan` (the linear term, the active-set loop and the commit).
fn solve_method(
    model: &Model,
    mg: &ModelGraph,
    parts: &SolveParts,
    (rebuild, plan): (TokenStream, TokenStream),
    scalar: Scalar,
) -> TokenStream {
    let ty = ident(scalar.type_name());
    let [n, m] = [model.state_len(), model.inputs.len()].map(Literal::usize_unsuffixed);
    let (a, b) = (&parts.prediction.a, &parts.prediction.b);
    let (a_pattern, b_pattern) = (received(&mg.graph, a), received(&mg.graph, b));
    // What the plan reads of the model after the branches: the primal active set's tail
    // reads `A` and `B`; the dual active set's limits read `A` (their free response), and
    // only with state or output limits.
    let (a_after, b_after) = match (parts.dual, parts.free_response) {
        (false, _) => (a_pattern.clone(), b_pattern.clone()),
        (true, true) => (a_pattern.clone(), quote! { _ }),
        (true, false) => (quote! { _ }, quote! { _ }),
    };
    let solve_read = read_estimate(mg, parts.used, &failure(quote! { Status::RejectedInput }));
    let time = model.uses_time().then(|| quote! { t: #ty, });
    let time_arg = model.uses_time().then(|| quote! { t, });
    let failed = failure(quote! { rejected });
    let reuse_test = parts.cache.reuse_test(scalar);
    let model = parts.cache.model(quote! {
        match Self::prediction_model(#time_arg x, u) {
            Ok(model) => model,
            Err(rejected) => {
                #failed
            }
        }
    });
    let (p, gain) = (&parts.terminal.p_idents, &parts.terminal.gain_idents);
    let gain_rows: Vec<TokenStream> = gain.iter().map(|row| quote! { [#(#row),*] }).collect();
    let rebuilt = parts.cache.rebuilt(&quote! {
        fresh_terminal = ([#(#p),*], [#(#gain_rows),*]);
    });
    let kept = parts.cache.kept();
    let hessian = parts.cache.hessian_name();
    let weighted = parts.cache.weighted_binding();
    let declare = parts.cache.declare();
    let unpack = parts.cache.unpack();
    let doc = solve_doc(parts);
    quote! {
        #doc
        pub fn solve(&mut self, #time x: &[#ty; #n], u: &[#ty; #m]) -> MpcStatus {
            #reuse_test
            #declare
            let (model_key, model, (terminal_weight, terminal_gain, terminal_weight_converged, terminal_weight_settled), #hessian, #weighted) = if reuse {
                #kept
            } else {
                #model
                let PredictionModel { a: #a_pattern, b: #b_pattern } = model;
                #rebuild
                #rebuilt
            };
            let PredictionModel { a: #a_after, b: #b_after } = *model;
            let [#(#p),*] = *terminal_weight;
            let [#(#gain_rows),*] = *terminal_gain;
            #unpack
            #solve_read
            #plan
        }
    }
}

/// `solve`'s doc: what it rebuilds, and how it plans.
fn solve_doc(parts: &SolveParts) -> TokenStream {
    let bound = match parts.budgeted {
        false => "`MAX_ITERATIONS` active-set iterations",
        true => {
            "the active-set iterations that `ITERATIONS_WITHIN_BUDGET` allows after what it rebuilt"
        }
    };
    let plan_doc = match parts.dual {
        false => format!(
            "the linear term (eq. 44) at `x` and at most {bound}, from the last plan shifted \
             by one move"
        ),
        true => format!(
            "the unconstrained plan at `x` and at most {bound}, from the limits the last \
             solve held, a step on (a plan cut short is clipped to the input bounds)"
        ),
    };
    doc_attributes(&format!(
        "Recomputes the plan for the estimate `x`: the prediction model at `x` (and the \
         operating input `u`), kept from the last solve while the values it reads stay \
         within `MODEL_TOLERANCE` of those it was built at; unless the terminal weight had \
         converged on that kept model, `RICCATI_ITERATIONS` Riccati steps from the last \
         terminal weight and the condensed Hessian (eqs. 42-43); then {plan_doc}. Leaves the \
         controller unchanged unless the status is [`Status::Ok`]."
    ))
}

/// The prediction model's code, `A` and `B` as the variables (or literals) it binds.
struct Prediction {
    stage: Stage,
    a: Matrix,
    b: Matrix,
    /// The model variables the code reads.
    used: BTreeSet<VarId>,
    /// Whether `A` and `B` are the zero-order hold (with its `MAX_SQUARINGS`).
    holds: bool,
}

/// Most squarings of the hold: the scaling brings `|| [Phi Gamma] T ||_1` to 1/2, so
/// models up to `2^29` times stiffer than the sample rate are held exactly.
const MAX_SQUARINGS: u32 = 30;

/// `A` and `B` at the estimate (eq. 30): the Jacobians of the sample step, or the exact
/// zero-order hold of `Phi = d(dx/dt)/dx`, `Gamma = d(dx/dt)/du` (sect. 3.3) by scaling
/// and squaring around a Taylor core.
fn prediction_model(
    model: &Model,
    spec: &MpcSpec,
    mg: &mut ModelGraph,
    names: &Names,
    scalar: Scalar,
) -> Prediction {
    let (ns, nu) = (spec.states.len(), spec.inputs.len());
    let states: Vec<NodeId> = spec.states.iter().map(|&i| mg.x[i]).collect();
    let inputs: Vec<NodeId> = spec.inputs.iter().map(|&i| mg.u[i]).collect();
    let holds = spec.discretisation == MpcDiscretisation::ZeroOrderHold;
    let rows: Vec<NodeId> = if holds {
        let (t, x) = (mg.t, mg.x.clone());
        let rates = mg.derivative(model, t, &x);
        spec.states.iter().map(|&i| rates[i]).collect()
    } else {
        spec.states.iter().map(|&i| mg.f[i]).collect()
    };
    let jac_x = mg.jacobian(&rows, &states);
    let jac_u = mg.jacobian(&rows, &inputs);
    let period = holds.then(|| sample_period(model, mg));
    let (x_prefix, u_prefix) = if holds { ("phi", "gamma") } else { ("a", "b") };
    let (x_names, u_names) = (
        names.matrix(x_prefix, ns, ns),
        names.matrix(u_prefix, ns, nu),
    );
    let g = &mut mg.graph;
    let a = declare_matrix(g, &jac_x, &x_names);
    let b = declare_matrix(g, &jac_u, &u_names);
    let mut roots: Vec<NodeId> = jac_x.iter().chain(&jac_u).flatten().copied().collect();
    roots.extend(period);
    let mut lowerer = Lowerer::new(g, scalar, names.namer(), &roots);
    bind_matrix(&mut lowerer, &jac_x, &x_names);
    bind_matrix(&mut lowerer, &jac_u, &u_names);
    let period = period.map(|node| lowerer.segment(&[node]).remove(0));
    let ops = lowerer.ops();
    let jacobians = lowerer.take_statements();
    let used = lowerer.finish().used_vars;
    let Some(period) = period else {
        let stage = Stage {
            code: quote! { #(#jacobians)* },
            ops,
        };
        return Prediction {
            stage,
            a,
            b,
            used,
            holds,
        };
    };
    let hold = zero_order_hold(g, (&a, &b), &period, names, scalar);
    let hold_code = &hold.stage.code;
    let stage = Stage {
        code: quote! { #(#jacobians)* #hold_code },
        ops: ops.plus(hold.stage.ops),
    };
    Prediction {
        stage,
        a: hold.a,
        b: hold.b,
        used,
        holds,
    }
}

/// The sample period `T` of continuous dynamics: the sub-step times their number.
fn sample_period(model: &Model, mg: &mut ModelGraph) -> NodeId {
    match mg.substep(model) {
        Some((_, h, n)) => {
            let n = mg.graph.num(f64::from(n));
            mg.graph.mul(h, n)
        }
        None => mg.graph.one(),
    }
}

/// `let [q, qd, ..] = *x;` for the entries the solve reads, and the check that they (and
/// the operating input) are finite.
fn read_estimate(mg: &ModelGraph, used: &BTreeSet<VarId>, rejected: &TokenStream) -> TokenStream {
    let g = &mg.graph;
    let unpack_x = crate::emit::code::destructure(g, quote! { *x }, &mg.x, used);
    let unpack_u = crate::emit::code::destructure(g, quote! { *u }, &mg.u, used);
    let checked: Vec<Ident> = entries_read(mg, used)
        .map(|v| ident(&g.var_info(v).name))
        .collect();
    let check = (!checked.is_empty()).then(|| {
        let finite = all_is_finite(&checked);
        quote! {
            if !(#finite) {
                #rejected
            }
        }
    });
    quote! {
        #unpack_x
        #unpack_u
        #check
    }
}

/// What [`read_estimate`] does: a finiteness test per entry read (about two integer
/// operations, counted as a comparison each).
fn read_estimate_ops(mg: &ModelGraph, used: &BTreeSet<VarId>) -> OpCount {
    OpCount {
        compare: 2 * entries_read(mg, used).count() as u32,
        ..OpCount::default()
    }
}

/// The entries of `x` and `u` among `used`, the ones [`read_estimate`] reads and tests.
fn entries_read<'a>(
    mg: &'a ModelGraph,
    used: &'a BTreeSet<VarId>,
) -> impl Iterator<Item = VarId> + 'a {
    mg.x.iter()
        .chain(&mg.u)
        .map(|&v| mg.var_id(v))
        .filter(|v| used.contains(v))
}

/// `return Err(status);`, how the prediction model gives up.
fn reject(status: TokenStream) -> TokenStream {
    quote! { return Err(#status); }
}

/// The rows of `A` or `B` as returned: variables by name, literals as literals.
fn returned(g: &Graph, m: &Matrix, scalar: Scalar) -> Vec<TokenStream> {
    m.iter()
        .map(|row| {
            let entries = row.iter().map(|&v| match g.literal(v) {
                Some(value) => literal(value, scalar),
                None => match g.node(v) {
                    crate::symbolic::Node::Var(id) => {
                        let name = ident(&g.var_info(id).name);
                        quote! { #name }
                    }
                    _ => literal(0.0, scalar),
                },
            });
            quote! { [#(#entries),*] }
        })
        .collect()
}

/// `[[a11, _], ..]`: the pattern that receives `A` or `B`, naming the entries later
/// stages read as variables (literal entries stay literals there).
fn received(g: &Graph, m: &Matrix) -> TokenStream {
    let rows = m.iter().map(|row| {
        let entries = row.iter().map(|&v| match g.node(v) {
            crate::symbolic::Node::Var(id) => {
                let name = ident(&g.var_info(id).name);
                quote! { #name }
            }
            _ => quote! { _ },
        });
        quote! { [#(#entries),*] }
    });
    quote! { [#(#rows),*] }
}

/// The hold's code, and `A`, `B` as the variables it binds.
struct Hold {
    stage: Stage,
    a: Matrix,
    b: Matrix,
}

/// Scaling and squaring: halve `T` until `|| [Phi Gamma] h ||_1 <= 1/2` (at most
/// `MAX_SQUARINGS` times), take the Taylor core of the hold over `h`, and square it back
/// up to `T`. Halving and doubling by two are exact in floating point.
fn zero_order_hold(
    g: &mut Graph,
    (phi, gamma): (&Matrix, &Matrix),
    period: &TokenStream,
    names: &Names,
    scalar: Scalar,
) -> Hold {
    let step_name = names.fresh("hold_step");
    let hold = HoldGraph::new(g, (phi, gamma), &step_name, names);
    let lowered = HoldCode::new(g, &hold, names, scalar);
    let code = hold_code(&hold, &lowered, (&step_name, period), scalar);
    Hold {
        stage: Stage {
            code,
            ops: lowered.ops,
        },
        a: hold.a,
        b: hold.b,
    }
}

/// The hold as nodes: the 1-norm of `[Phi Gamma]`, the Taylor core over the scaled step
/// `h`, and one squaring of the hold held in the variables `a11 ..`, `b11 ..`.
struct HoldGraph {
    norm: NodeId,
    /// The core's `A`, then its `B`, row by row.
    core: Vec<NodeId>,
    /// The squared `A`, then `B`, row by row.
    squared: Vec<NodeId>,
    a_names: Vec<Vec<String>>,
    b_names: Vec<Vec<String>>,
    a: Matrix,
    b: Matrix,
}

impl HoldGraph {
    fn new(
        g: &mut Graph,
        (phi, gamma): (&Matrix, &Matrix),
        step_name: &str,
        names: &Names,
    ) -> HoldGraph {
        let (ns, nu) = (phi.len(), gamma.first().map_or(0, Vec::len));
        let step = g.var(step_name);
        let norm = column_norm(g, phi, gamma);
        let (f, gh) = (scale(g, phi, step), scale(g, gamma, step));
        let (a_core, b_core) = zoh_taylor(g, &f, &gh);
        let (a_names, b_names) = (names.matrix("a", ns, ns), names.matrix("b", ns, nu));
        let (a, b) = (matrix_vars(g, &a_names), matrix_vars(g, &b_names));
        let (a_squared, b_squared) = zoh_square(g, &a, &b);
        let flat = |a: &Matrix, b: &Matrix| a.iter().chain(b).flatten().copied().collect();
        HoldGraph {
            norm,
            core: flat(&a_core, &b_core),
            squared: flat(&a_squared, &b_squared),
            a_names,
            b_names,
            a,
            b,
        }
    }
}

/// The hold's pieces lowered: the norm, the Taylor core, and one squaring (run up to
/// `MAX_SQUARINGS` times, as its cost counts).
struct HoldCode {
    norm_statements: Vec<TokenStream>,
    norm_value: TokenStream,
    core_statements: Vec<TokenStream>,
    core_values: Vec<TokenStream>,
    square_statements: Vec<TokenStream>,
    squared_values: Vec<TokenStream>,
    ops: OpCount,
}

impl HoldCode {
    fn new(g: &Graph, hold: &HoldGraph, names: &Names, scalar: Scalar) -> HoldCode {
        let roots = [&[hold.norm][..], &hold.core].concat();
        let mut lowerer = Lowerer::new(g, scalar, names.namer(), &roots);
        let norm_value = lowerer.segment(&[hold.norm]).remove(0);
        let norm_ops = lowerer.ops();
        let norm_statements = lowerer.take_statements();
        let core_values = lowerer.segment(&hold.core);
        let core_ops = lowerer.ops().minus(norm_ops);
        let core_statements = lowerer.take_statements();

        let mut lowerer = Lowerer::new(g, scalar, names.namer(), &hold.squared);
        let squared_values = lowerer.segment(&hold.squared);
        let square_ops = lowerer.ops();
        let square_statements = lowerer.take_statements();
        HoldCode {
            norm_statements,
            norm_value,
            core_statements,
            core_values,
            square_statements,
            squared_values,
            ops: norm_ops
                .plus(core_ops)
                .plus(square_ops.times(MAX_SQUARINGS)),
        }
    }
}

/// The hold over the sample `period` (sect. 3.3), the step named `step_name`: scaling,
/// the Taylor core, and the squarings back up, leaving `a11 ..`, `b11 ..` bound.
fn hold_code(
    hold: &HoldGraph,
    code: &HoldCode,
    (step_name, period): (&str, &TokenStream),
    scalar: Scalar,
) -> TokenStream {
    let ns = hold.a.len();
    let nu = hold.b.first().map_or(0, Vec::len);
    let [half, two] = [0.5, 2.0].map(|v| literal(v, scalar));
    let step = ident(step_name);
    let (a_pattern, b_pattern) = (matrix_pattern(&hold.a_names), matrix_pattern(&hold.b_names));
    let (a_core, b_core) = code.core_values.split_at(ns * ns);
    let (a_core, b_core) = (rows(a_core, ns), rows(b_core, nu));
    let (a_squared, b_squared) = code.squared_values.split_at(ns * ns);
    let (a_squared, b_squared) = (rows(a_squared, ns), rows(b_squared, nu));
    let too_stiff = reject(quote! { Status::NonFinite });
    let (norm_statements, norm_value) = (&code.norm_statements, &code.norm_value);
    let (core_statements, square_statements) = (&code.core_statements, &code.square_statements);
    quote! {
        // The zero-order hold over the sample (sect. 3.3): halve the step until the 1-norm
        // of [Phi Gamma] times it is at most 1/2 ...
        #(#norm_statements)*
        let mut scaled_norm = #norm_value * #period;
        let mut #step = #period;
        for _ in 0..Self::MAX_SQUARINGS {
            if scaled_norm <= #half {
                break;
            }
            scaled_norm *= #half;
            #step *= #half;
        }
        if !scaled_norm.is_finite() || scaled_norm > #half {
            #too_stiff
        }
        // ... hold over that step by the Taylor series (the paper's j = 10 terms) ...
        #(#core_statements)*
        let mut hold_a = [#(#a_core),*];
        let mut hold_b = [#(#b_core),*];
        // ... and square back up to the whole sample: A <- A A, B <- A B + B.
        for _ in 0..Self::MAX_SQUARINGS {
            if #step >= #period {
                break;
            }
            #step *= #two;
            let #a_pattern = hold_a;
            let #b_pattern = hold_b;
            #(#square_statements)*
            hold_a = [#(#a_squared),*];
            hold_b = [#(#b_squared),*];
        }
        let #a_pattern = hold_a;
        let #b_pattern = hold_b;
    }
}

/// `[[a11, a12], [a21, a22]]` as a pattern.
fn matrix_pattern(names: &[Vec<String>]) -> TokenStream {
    let rows = names.iter().map(|row| {
        let row = row.iter().map(|n| ident(n));
        quote! { [#(#row),*] }
    });
    quote! { [#(#rows),*] }
}

/// Values grouped into rows of `cols`.
fn rows(values: &[TokenStream], cols: usize) -> Vec<TokenStream> {
    values
        .chunks(cols.max(1))
        .map(|row| quote! { [#(#row),*] })
        .collect()
}

/// The terminal weight's code and the variables holding its converged value.
struct Terminal {
    stage: Stage,
    /// `P_f`, packed, as the variables the condensed stage reads.
    p: Vec<NodeId>,
    /// `p11 ..` and the gain's names, for the commit.
    p_idents: Vec<Ident>,
    gain_idents: Vec<Vec<Ident>>,
}

/// The pivot names of the control weight `R + B'PB`.
const WEIGHT: (&str, &str) = ("weight", "inv_weight");

/// `RICCATI_ITERATIONS` steps of `P <- A'PA - A'PB (R + B'PB)^-1 B'PA + Q` (the fixed
/// point is eq. 35's `P_f`) from the last solve's terminal weight, which so tracks `P_f`
/// as the model changes; then the gain `K` of eq. (41). Converged when the last step
/// changed `P` by at most `RICCATI_TOLERANCE` of its size (sums of magnitudes).
fn terminal_weight(
    g: &mut Graph,
    (a, b): (&Matrix, &Matrix),
    spec: &MpcSpec,
    names: &Names,
    scalar: Scalar,
) -> Terminal {
    let recursion = Recursion::new(g, (a, b), spec, names);
    let lowered = RecursionCode::new(g, &recursion, names, scalar);
    let p_idents = var_idents(g, &recursion.p_vars);
    let (ns, nu) = (spec.states.len(), spec.inputs.len());
    let gain_idents: Vec<Vec<Ident>> = names
        .matrix("k", nu, ns)
        .iter()
        .map(|row| row.iter().map(|n| ident(n)).collect())
        .collect();
    let code = terminal_code(g, &recursion, &lowered, (&p_idents, &gain_idents), scalar);
    let riccati = lowered.per_step.looped(spec.riccati_iterations);
    let ops = lowered.before.plus(riccati).plus(lowered.gain_ops);
    Terminal {
        stage: Stage { code, ops },
        p: recursion.p_vars,
        p_idents,
        gain_idents,
    }
}

/// The Riccati recursion towards `P_f` as nodes: the packed variables of `P`, `Q` and
/// `R`, one shared Riccati step (eq. 35's map), the gain, and the step's operands that do
/// not depend on `P`.
struct Recursion {
    p_vars: Vec<NodeId>,
    q_vars: Vec<NodeId>,
    r_vars: Vec<NodeId>,
    step: RiccatiStep,
    /// The gain `K` of eq. (41), row by row.
    gain: Vec<NodeId>,
    /// What the loop body computes: the next `P` and the pivots of `R + B'PB`.
    body_roots: Vec<NodeId>,
    /// Operands of the loop body that do not change between steps, hoisted before it.
    invariant: Vec<NodeId>,
}

impl Recursion {
    fn new(g: &mut Graph, (a, b): (&Matrix, &Matrix), spec: &MpcSpec, names: &Names) -> Self {
        let (ns, nu) = (spec.states.len(), spec.inputs.len());
        let p_vars = packed_vars(g, "p", ns, &names.taken);
        let q_vars = packed_vars(g, "q", ns, &names.taken);
        let r_vars = packed_vars(g, "r", nu, &names.taken);
        let p = symmetric_from_packed(&p_vars, ns);
        let (q, r) = (
            symmetric_from_packed(&q_vars, ns),
            symmetric_from_packed(&r_vars, nu),
        );
        let step = riccati_step(g, (a, b), &p, (&q, &r), |g, j| {
            g.var(&pivot_names(nu, j, WEIGHT, "").1)
        });
        let gain: Vec<NodeId> = step.gain.iter().flatten().copied().collect();
        let loop_vars: Vec<NodeId> = p_vars.iter().chain(&step.reciprocals).copied().collect();
        let body_roots: Vec<NodeId> = step.p_next.iter().chain(&step.pivots).copied().collect();
        let invariant = loop_invariant_operands(g, &body_roots, &loop_vars);
        Recursion {
            p_vars,
            q_vars,
            r_vars,
            step,
            gain,
            body_roots,
            invariant,
        }
    }
}

/// The lowered recursion: the statements hoisted before the loop, the loop body and the
/// next `P`, the gain's statements after the loop and its values, and their costs.
struct RecursionCode {
    hoisted: Vec<TokenStream>,
    body: Vec<TokenStream>,
    p_next: Vec<TokenStream>,
    gain_statements: Vec<TokenStream>,
    gain_values: Vec<TokenStream>,
    /// The hoisted statements', one step's, and the gain's arithmetic.
    before: OpCount,
    per_step: OpCount,
    gain_ops: OpCount,
}

impl RecursionCode {
    /// The loop body and, after the loop, the gain from the final `P`, both behind the
    /// checked pivots of `R + B'PB`.
    fn new(g: &Graph, recursion: &Recursion, names: &Names, scalar: Scalar) -> Self {
        let roots = [
            &recursion.body_roots[..],
            &recursion.gain,
            &recursion.invariant,
        ]
        .concat();
        let mut lowerer = Lowerer::new(g, scalar, names.namer(), &roots);
        for &node in &recursion.invariant {
            lowerer.force_let(node);
        }
        // P is carried from one step to the next in registers, with what the step reads
        // and does not change where they fit.
        lowerer.hold_in_registers(&recursion.p_vars);
        lowerer.hoist_leaves(&recursion.body_roots);
        let before = lowerer.ops();
        let hoisted = lowerer.take_statements();
        // The gain after the loop comes from a fork taken here, so it does not rely on
        // temporaries scoped inside the loop body.
        let mut after = lowerer.clone();
        let on_failure = failure(quote! { Status::NonPositiveControlWeight });
        let (pivots, reciprocals) = (&recursion.step.pivots, &recursion.step.reciprocals);
        let guard = (WEIGHT, "");
        guard_pivots(
            &mut lowerer,
            pivots,
            reciprocals,
            guard,
            &|_| on_failure.clone(),
            scalar,
        );
        let p_next = lowerer.segment(&recursion.step.p_next);
        let body = lowerer.take_statements();
        let per_step = lowerer.ops().minus(before);
        guard_pivots(
            &mut after,
            pivots,
            reciprocals,
            guard,
            &|_| on_failure.clone(),
            scalar,
        );
        let gain_values = after.segment(&recursion.gain);
        let gain_statements = after.take_statements();
        let gain_ops = after.ops().minus(before);
        RecursionCode {
            hoisted,
            body,
            p_next,
            gain_statements,
            gain_values,
            before,
            per_step,
            gain_ops,
        }
    }
}

/// The terminal weight's code: the steps from `self.terminal_weight`, the convergence
/// test on the last one, and the gain bound as `gain_idents`.
fn terminal_code(
    g: &Graph,
    recursion: &Recursion,
    code: &RecursionCode,
    (p_idents, gain_idents): (&[Ident], &[Vec<Ident>]),
    scalar: Scalar,
) -> TokenStream {
    let (q_idents, r_idents) = (
        var_idents(g, &recursion.q_vars),
        var_idents(g, &recursion.r_vars),
    );
    let gain_flat = gain_idents.iter().flatten();
    let previous: Vec<Ident> = p_idents
        .iter()
        .map(|p| ident(&format!("previous_{p}")))
        .collect();
    let abs = abs_fn(scalar);
    let changes = p_idents
        .iter()
        .zip(&previous)
        .map(|(p, prev)| quote! { #abs(#p - #prev) });
    let sizes: Vec<TokenStream> = p_idents.iter().map(|p| quote! { #abs(#p) }).collect();
    let first: Vec<Ident> = p_idents
        .iter()
        .map(|p| ident(&format!("first_{p}")))
        .collect();
    let settled = p_idents
        .iter()
        .zip(&first)
        .map(|(p, first)| quote! { #abs(#p - #first) });
    let (body, p_next) = (&code.body, &code.p_next);
    let gain_values = &code.gain_values;
    let read_later = quote! { #(#body)* #(#p_next)* #(#gain_values)* };
    // Long runs in blocks (`scoped`), each handing on what the code after it reads.
    let gain_statements = scoped(code.gain_statements.clone(), &read_later);
    let hoisted = scoped(
        code.hoisted.clone(),
        &quote! { #read_later #(#gain_statements)* },
    );
    let body = scoped(body.clone(), &quote! { #(#p_next)* });
    quote! {
        // The terminal weight P_f (eq. 35) by Riccati steps from the last solve's.
        let [#(#q_idents),*] = self.q;
        let [#(#r_idents),*] = self.r;
        #(#hoisted)*
        let mut p = self.terminal_weight;
        let first_p = p;
        let mut previous_p = p;
        for _ in 0..Self::RICCATI_ITERATIONS {
            let [#(#p_idents),*] = p;
            #(#body)*
            previous_p = p;
            p = [#(#p_next),*];
        }
        let [#(#p_idents),*] = p;
        let [#(#previous),*] = previous_p;
        let terminal_weight_converged =
            #(#changes)+* <= Self::RICCATI_TOLERANCE * (#(#sizes)+*);
        // Settled: the whole solve's steps moved it by at most the tolerance too. The last
        // step alone can be small far from the fixed point when the closed loop has a pole
        // near -1 (a sampling zero), whose error alternates and decays slowly.
        let [#(#first),*] = first_p;
        let terminal_weight_settled = terminal_weight_converged
            && #(#settled)+* <= Self::RICCATI_TOLERANCE * (#(#sizes)+*);
        // The gain of the fixed feedback after the horizon (eq. 41).
        #(#gain_statements)*
        #(let #gain_flat = #gain_values;)*
    }
}

/// `stateforge_math::f32::abs` or `stateforge_math::f64::abs`.
fn abs_fn(scalar: Scalar) -> TokenStream {
    crate::emit::names::math_fn(scalar, "abs")
}

/// The model's part of the condensed problem as nodes: `H` (packed), and the weighted
/// responses `S_(i+1) B` as nodes, and as the variables (or literals) the linear term
/// reads.
struct CondensedNodes {
    hessian: Vec<NodeId>,
    weighted_nodes: Vec<Matrix>,
    weighted: Vec<Matrix>,
    weighted_names: Vec<Vec<Vec<String>>>,
}

/// Eqs. (42)-(43): `H` and the weighted responses from `A`, `B`, `Q`, `R` and `P_f`.
fn condense_model(
    spec: &MpcSpec,
    g: &mut Graph,
    (a, b, p): (&Matrix, &Matrix, &[NodeId]),
    moves: &MoveNames,
    names: &Names,
) -> CondensedNodes {
    let (ns, nu) = (spec.states.len(), spec.inputs.len());
    let q = symmetric_from_packed(&packed_vars(g, "q", ns, &names.taken), ns);
    let r = symmetric_from_packed(&packed_vars(g, "r", nu, &names.taken), nu);
    let terminal = symmetric_from_packed(p, ns);
    let horizon = spec.horizon as usize;
    let model = condensed_hessian(g, (a, b), (&q, &r, &terminal), horizon);
    let weighted_names: Vec<Vec<Vec<String>>> = (1..=horizon)
        .map(|step| names.matrix(&format!("s{step}b"), ns, nu))
        .collect();
    let weighted = model
        .weighted
        .iter()
        .zip(&weighted_names)
        .map(|(w, names)| declare_matrix(g, w, names))
        .collect();
    debug_assert_eq!(model.hessian.len(), moves.hessian.len());
    CondensedNodes {
        hessian: model.hessian,
        weighted_nodes: model.weighted,
        weighted,
        weighted_names,
    }
}

impl CondensedNodes {
    /// The variables that name the weighted responses, every entry of every step.
    fn weighted_vars(&self) -> Vec<NodeId> {
        self.weighted.iter().flatten().flatten().copied().collect()
    }

    /// The code that binds `H` and the weighted responses by name.
    fn lower(&self, g: &Graph, moves: &MoveNames, names: &Names, scalar: Scalar) -> Stage {
        let mut roots = self.hessian.clone();
        roots.extend(self.weighted_nodes.iter().flatten().flatten());
        let mut lowerer = Lowerer::new(g, scalar, names.namer(), &roots);
        for (&node, name) in self.hessian.iter().zip(&moves.hessian) {
            bind_as(&mut lowerer, node, name);
        }
        for (w, names) in self.weighted_nodes.iter().zip(&self.weighted_names) {
            bind_matrix(&mut lowerer, w, names);
        }
        let ops = lowerer.ops();
        // What the solve reads later: H and the weighted responses, by name.
        let handed: Vec<Ident> = moves
            .hessian
            .iter()
            .chain(self.weighted_names.iter().flatten().flatten())
            .map(|n| ident(n))
            .collect();
        let statements = scoped(lowerer.take_statements(), &quote! { #(#handed)* });
        Stage {
            code: quote! {
                // The condensed Hessian (eqs. 42-43) and the weighted responses of eq. 44.
                #(#statements)*
            },
            ops,
        }
    }
}

/// The linear term's code, which binds `c` by name, and the model variables it reads.
struct Linear {
    stage: Stage,
    used: BTreeSet<VarId>,
}

/// Eq. (44) on the deviation `x - x_ref` of the regulated states.
fn linear_term(
    model: &Model,
    spec: &MpcSpec,
    mg: &mut ModelGraph,
    (a, condensed): (&Matrix, &CondensedNodes),
    moves: &MoveNames,
    names: &Names,
    scalar: Scalar,
) -> Linear {
    let references: Vec<String> = spec
        .states
        .iter()
        .map(|&i| names.fresh(&format!("{}_ref", model.states[i].name)))
        .collect();
    let g = &mut mg.graph;
    let deviation: Vec<NodeId> = spec
        .states
        .iter()
        .zip(&references)
        .map(|(&i, name)| {
            let reference = g.var(name);
            g.sub(mg.x[i], reference)
        })
        .collect();
    let linear = condensed_linear(g, a, &condensed.weighted, &deviation);
    let mut lowerer = Lowerer::new(g, scalar, names.namer(), &linear);
    for (&node, name) in linear.iter().zip(&moves.linear) {
        bind_as(&mut lowerer, node, name);
    }
    let ops = lowerer.ops();
    let handed = moves.linear.iter().map(|n| ident(n));
    let statements = scoped(lowerer.take_statements(), &quote! { #(#handed)* });
    let used = lowerer.finish().used_vars;
    let references = references.iter().map(|n| ident(n));
    let code = quote! {
        // The linear term (eq. 44) on the deviation from the reference.
        let [#(#references),*] = self.x_ref;
        #(#statements)*
    };
    Linear {
        stage: Stage { code, ops },
        used,
    }
}

/// The warm start's new last move (the dual mode's control after the horizon, eq. 41):
/// `u_tail = -K x`, `x` the deviation the shifted plan's other moves lead to from the
/// estimate's, through `x+ = A x + B u` (the deviations' dynamics when `u_ref` holds
/// `x_ref`). Binds `<input>_tail`; reads the warm start's moves `warm_<move>`.
fn dual_mode_tail(
    model: &Model,
    spec: &MpcSpec,
    mg: &mut ModelGraph,
    (a, b): (&Matrix, &Matrix),
    moves: &MoveNames,
    names: &Names,
    scalar: Scalar,
) -> Stage {
    let (ns, nu) = (spec.states.len(), spec.inputs.len());
    let g = &mut mg.graph;
    let mut state: Matrix = spec
        .states
        .iter()
        .map(|&i| {
            let reference = g.var(&names.fresh(&format!("{}_ref", model.states[i].name)));
            vec![g.sub(mg.x[i], reference)]
        })
        .collect();
    let warm = moves.per_move("warm");
    for step in warm.chunks(nu.max(1)).take(spec.horizon as usize - 1) {
        let u: Matrix = step.iter().map(|w| vec![g.var(&w.to_string())]).collect();
        let (free, forced) = (matmul(g, a, &state), matmul(g, b, &u));
        state = add(g, &free, &forced);
    }
    let gain = matrix_vars(g, &names.matrix("k", nu, ns));
    let feedback = matmul(g, &gain, &state);
    let tail: Vec<NodeId> = feedback.iter().map(|row| g.neg(row[0])).collect();
    let mut lowerer = Lowerer::new(g, scalar, names.namer(), &tail);
    let values = lowerer.segment(&tail);
    let statements = lowerer.take_statements();
    let tail_names = spec
        .inputs
        .iter()
        .map(|&i| ident(&format!("{}_tail", model.inputs[i].name)));
    let code = quote! {
        // The new last move: the terminal feedback at the state the others lead to.
        #(#statements)*
        #(let #tail_names = #values;)*
    };
    Stage {
        code,
        ops: lowerer.ops(),
    }
}

/// What [`commit`] does at every solve: each move back to an absolute input, clipped and
/// tested for finiteness, and stored.
fn commit_ops(moves: &MoveNames) -> OpCount {
    let moves_len = moves.absolute_names().len();
    let m = moves_len as u32;
    OpCount {
        add: m,
        // the clip's two, the finiteness test's two
        compare: 4 * m,
        ..OpCount::stores(moves_len)
    }
}

/// What the commit stores of the terminal weight and gain, when the solve rebuilt them.
fn terminal_store_ops(terminal: &Terminal) -> OpCount {
    OpCount::stores(terminal.p_idents.len() + terminal.gain_idents.iter().flatten().count())
}

/// The plan's commit: moves back to absolute inputs, clipped to the bounds (so rounding
/// never puts one outside), then the finiteness check of everything stored (the kept
/// terminal weight and gain were checked when they were stored).
fn commit(
    moves: &MoveNames,
    terminal: &Terminal,
    cache: &Cache,
    kept_state: &TokenStream,
) -> TokenStream {
    let plan = moves.absolute_plan();
    let (p, gain) = (&terminal.p_idents, &terminal.gain_idents);
    let gain_rows = gain.iter().map(|row| quote! { [#(#row),*] });
    let terminal_values: Vec<Ident> = p
        .iter()
        .cloned()
        .chain(gain.iter().flatten().cloned())
        .collect();
    let (plan_finite, terminal_finite) = (
        all_is_finite(&moves.absolute_names()),
        all_is_finite(&terminal_values),
    );
    let finite = quote! { #plan_finite && (reuse || #terminal_finite) };
    let non_finite = failure(quote! { Status::NonFinite });
    let plan_rows = moves.plan_rows();
    let keep = cache.store(&quote! {
        self.terminal_weight = [#(#p),*];
        self.terminal_gain = [#(#gain_rows),*];
    });
    quote! {
        #plan
        if !(#finite) {
            #non_finite
        }
        self.plan = [#(#plan_rows),*];
        #kept_state
        #keep
        MpcStatus {
            status: Status::Ok,
            optimal,
            iterations: steps,
            terminal_weight_converged,
            rebuilt: if reuse {
                MpcRebuild::Nothing
            } else if keep_model {
                MpcRebuild::Problem
            } else {
                MpcRebuild::ModelAndProblem
            },
        }
    }
}

/// `t: f32, x: &[f32; N], u: &[f32; M]`, naming unread arguments `_x`, `_u`.
fn signature(
    model: &Model,
    mg: &ModelGraph,
    used: &std::collections::BTreeSet<crate::symbolic::VarId>,
    ty: &Ident,
) -> TokenStream {
    let reads = |vars: &[NodeId]| vars.iter().any(|&v| used.contains(&mg.var_id(v)));
    let x_name = ident(if reads(&mg.x) { "x" } else { "_x" });
    let u_name = ident(if reads(&mg.u) { "u" } else { "_u" });
    let n = Literal::usize_unsuffixed(model.state_len());
    let m = Literal::usize_unsuffixed(model.inputs.len());
    let time = model.uses_time().then(|| {
        let t = time_param(&mg.graph, mg.t, used, ty, "t");
        quote! { #t, }
    });
    quote! { #time #x_name: &[#ty; #n], #u_name: &[#ty; #m] }
}

/// The lengths in the generated types' signatures, and their scalar type.
struct Dims {
    ty: Ident,
    /// Regulated states, the MPC's inputs, and the packed weights' lengths.
    ns_len: Literal,
    nu_len: Literal,
    nsp: Literal,
    nup: Literal,
    /// Moves in the plan.
    horizon: Literal,
}

impl Dims {
    fn new(spec: &MpcSpec, scalar: Scalar) -> Dims {
        let (ns, nu) = (spec.states.len(), spec.inputs.len());
        let [ns_len, nu_len, nsp, nup, horizon] = [
            ns,
            nu,
            packed_len(ns),
            packed_len(nu),
            spec.horizon as usize,
        ]
        .map(Literal::usize_unsuffixed);
        Dims {
            ty: ident(scalar.type_name()),
            ns_len,
            nu_len,
            nsp,
            nup,
            horizon,
        }
    }
}

/// The `Mpc` and `MpcStatus` types around `solve`.
fn type_tokens(
    model: &Model,
    spec: &MpcSpec,
    solve: TokenStream,
    (moves, cache): (&MoveNames, &Cache),
    scalar: Scalar,
    holds: bool,
) -> TokenStream {
    let dims = Dims::new(spec, scalar);
    let results = result_types(&dims, spec.iterations_within_budget.is_some());
    let doc = mpc_doc(model, spec, holds);
    let constants = constants(spec, &dims, scalar, holds);
    let constructor = constructor((model, spec), (moves, cache), &dims, scalar);
    let kept = cache.fields(&dims.ty);
    let set_reference = set_reference(model, spec, moves, &dims);
    let set_output_reference = target::set_output_reference(model, spec, scalar);
    let setters = setters(spec, moves, &dims);
    let accessors = accessors(&dims);
    let held = held_field(spec, false);
    let limit_fields = limit_api::fields(model, spec, scalar, false);
    let limit_setters = limit_api::setters(model, spec, scalar);
    let Dims {
        ty,
        ns_len,
        nu_len,
        nsp,
        nup,
        horizon,
    } = &dims;
    quote! {
        #results

        #[doc = #doc]
        #[derive(Clone, Copy, Debug, PartialEq)]
        pub struct Mpc {
            q: [#ty; #nsp],
            r: [#ty; #nup],
            u_min: [#ty; #nu_len],
            u_max: [#ty; #nu_len],
            x_ref: [#ty; #ns_len],
            u_ref: [#ty; #nu_len],
            terminal_weight: [#ty; #nsp],
            terminal_gain: [[#ty; #ns_len]; #nu_len],
            plan: [[#ty; #nu_len]; #horizon],
            #held
            #limit_fields
            #kept
        }

        impl Mpc {
            #constants

            #constructor

            #set_reference

            #set_output_reference

            #setters

            #limit_setters

            #solve

            #accessors
        }
    }
}

/// The dual active set's held limits, a field of `Mpc`: its type, or (`value`) its
/// value in `new`, nothing held.
fn held_field(spec: &MpcSpec, value: bool) -> Option<TokenStream> {
    let moves = Literal::usize_unsuffixed((spec.horizon as usize) * spec.inputs.len());
    let rows = Literal::usize_unsuffixed(spec.limit_rows());
    let entry = match value {
        false => quote! { stateforge_math::HeldLimits<#moves, #rows> },
        true => quote! { stateforge_math::HeldLimits::NONE },
    };
    (spec.solver == MpcSolver::DualActiveSet).then(|| quote! { held: #entry, })
}

/// `PredictionModel`, which `prediction_model` returns, and `MpcStatus`, which `solve`
/// returns.
fn result_types(dims: &Dims, budgeted: bool) -> TokenStream {
    let Dims {
        ty, ns_len, nu_len, ..
    } = dims;
    let bound = match budgeted {
        false => "`MAX_ITERATIONS` ran out",
        true => "the iterations its cycle budget allows (`ITERATIONS_WITHIN_BUDGET`) ran out",
    };
    let optimal_doc = doc_attributes(&format!(
        "Whether the plan is the problem's minimiser (no bound held has a negative \
         multiplier). If not, {bound}: the plan is the last iterate, within the bounds and \
         no costlier than the shifted last plan."
    ));
    quote! {
        /// The MPC's prediction model `x+ = A x + B u` (eq. 30) of the regulated states.
        #[derive(Clone, Copy, Debug, PartialEq)]
        pub struct PredictionModel {
            /// `A`, regulated states by regulated states.
            pub a: [[#ty; #ns_len]; #ns_len],
            /// `B`, regulated states by the MPC's inputs.
            pub b: [[#ty; #nu_len]; #ns_len],
        }

        /// What an [`Mpc::solve`] did.
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        #[must_use = "a solve that did not return `Status::Ok` left the controller unchanged"]
        pub struct MpcStatus {
            /// [`Status::Ok`] when the new plan was stored; otherwise nothing changed.
            pub status: Status,
            #optimal_doc
            pub optimal: bool,
            /// Active-set iterations (Newton steps on the free moves) used.
            pub iterations: usize,
            /// Whether the last Riccati step changed the terminal weight by at most
            /// `RICCATI_TOLERANCE` of its size: the weight then solves the discrete
            /// algebraic Riccati equation (eq. 35) of the current model, and without
            /// active bounds the first move is the infinite-horizon LQR's.
            pub terminal_weight_converged: bool,
            /// What the solve recomputed besides its plan, which decides its cost;
            /// [`MpcRebuild::Nothing`] unless the status is [`Status::Ok`].
            pub rebuilt: MpcRebuild,
        }

        /// What an [`Mpc::solve`] recomputed besides its plan (the linear term and the
        /// active-set iterations, which every solve runs).
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        pub enum MpcRebuild {
            /// The kept prediction model, terminal weight and condensed Hessian served.
            Nothing,
            /// The kept prediction model served; the terminal weight's Riccati steps and
            /// the condensed Hessian ran (the weight had not settled): in an `f32` model,
            /// `MPC_RICCATI_CYCLES + MPC_CONDENSE_CYCLES` of the solve's estimate.
            Problem,
            /// The prediction model was recomputed at the estimate (a value it reads had
            /// moved by more than `MODEL_TOLERANCE`), then the Riccati steps and the
            /// condensed Hessian: `MPC_PREDICTION_CYCLES` more.
            ModelAndProblem,
        }
    }
}

/// The type's doc: the dual-mode controller of Takacs, Polóni and Rohal'-Ilkiv on the
/// regulated states and inputs, and which prediction model it takes.
fn mpc_doc(model: &Model, spec: &MpcSpec, holds: bool) -> String {
    let state_names = model.states_named(&spec.states);
    let input_names = model.inputs_named(&spec.inputs);
    let limits = match spec.limit_rows() {
        0 => "input bounds",
        _ => "input bounds and the limits its setters give",
    };
    let method = match spec.solver {
        MpcSolver::PrimalActiveSet => "a primal active-set method warm-started from the last plan",
        MpcSolver::DualActiveSet => {
            "a dual active-set method (Goldfarb and Idnani's, as Arnström, Bemporad and \
             Axehill's DAQP has it) from the unconstrained plan, warm-started from the \
             limits the last solve held"
        }
    };
    format!(
        " Adaptive model predictive control of `[{}]` with `[{}]` within {limits}: \
         the dual-mode, infinite-horizon constrained controller of Takacs, Polóni and \
         Rohal'-Ilkiv, \"Adaptive predictive control of transient vibrations of \
         cantilevers with changing weight\" (sect. 3.4). [`Mpc::solve`] takes the model \
         at the estimate ({}), moves the terminal weight towards the solution of the \
         discrete algebraic Riccati equation, condenses the cost over `HORIZON` moves and \
         minimises it within the limits by {method}; [`Mpc::control`] is the plan's first \
         move.",
        state_names.join(", "),
        input_names.join(", "),
        if holds {
            "the exact zero-order hold of its continuous linearisation"
        } else {
            "the Jacobians of its sample step"
        }
    )
}

/// The horizon, the iteration bounds and the tolerances (and `MAX_SQUARINGS` for the
/// hold).
fn constants(spec: &MpcSpec, dims: &Dims, scalar: Scalar, holds: bool) -> TokenStream {
    let Dims { ty, horizon, .. } = dims;
    let [passes, riccati_iterations] = [spec.max_iterations + 1, spec.riccati_iterations]
        .map(|count| Literal::usize_unsuffixed(count as usize));
    // Both tolerances sit well above the scalar's rounding of the sums they compare.
    let tolerance = literal(
        match scalar {
            Scalar::F32 => 1e-5,
            Scalar::F64 => 1e-12,
        },
        scalar,
    );
    let model_tolerance = literal(spec.model_tolerance, scalar);
    let within_budget = spec.iterations_within_budget.map(|limits| {
        let limits = limits.map(|n| Literal::usize_unsuffixed(n as usize));
        let budget = spec.cycle_budget.map_or(0, |(cycles, _)| cycles);
        let doc = doc_attributes(&format!(
            "Active-set iterations a solve may take within the cycle budget of {budget} \
             cycles (the static estimate of the solve, `f32` on a Cortex-M4F, stays within \
             it), by what it rebuilt ([`MpcRebuild`]): nothing, the terminal \
             weight and Hessian, the model as well. A solve that reaches its bound stops \
             with `optimal = false` and the best feasible plan found, from which the next \
             solve is warm-started."
        ));
        quote! {
            #doc
            pub const ITERATIONS_WITHIN_BUDGET: [usize; 3] = [#(#limits),*];
        }
    });
    let squarings = holds.then(|| {
        let max = Literal::usize_unsuffixed(MAX_SQUARINGS as usize);
        quote! {
            /// Most squarings of the zero-order hold (scaling and squaring).
            pub const MAX_SQUARINGS: usize = #max;
        }
    });
    let solver_constants = solver_constants(spec, &passes, &tolerance, scalar);
    quote! {
        /// Moves optimised over, `n`.
        pub const HORIZON: usize = #horizon;
        /// Riccati steps per solve towards the terminal weight.
        pub const RICCATI_ITERATIONS: usize = #riccati_iterations;
        /// Largest change, relative to each value, of the values the prediction model
        /// reads under which a solve keeps the last solve's model, terminal weight and
        /// condensed Hessian (once the terminal weight has converged).
        pub const MODEL_TOLERANCE: #ty = #model_tolerance;
        /// Relative change of the terminal weight under which it counts as converged.
        pub const RICCATI_TOLERANCE: #ty = #tolerance;
        #solver_constants
        #squarings
        #within_budget
    }
}

/// The active-set iterations' bound and tolerances, as `spec.solver` has them.
fn solver_constants(
    spec: &MpcSpec,
    passes: &Literal,
    release_tolerance: &TokenStream,
    scalar: Scalar,
) -> TokenStream {
    let max_iterations = Literal::usize_unsuffixed(spec.max_iterations as usize);
    let ty = ident(scalar.type_name());
    match spec.solver {
        MpcSolver::PrimalActiveSet => quote! {
            /// Bound on the active-set iterations (Newton steps) of one solve.
            pub const MAX_ITERATIONS: usize = #max_iterations;
            /// Passes of the active-set loop: one per iteration, and one more that only
            /// checks the multipliers after the last step.
            const PASSES: usize = #passes;
            /// A bound stays held unless releasing it would move its input by more than
            /// this fraction of the input's range (its multiplier is below
            /// `-RELEASE_TOLERANCE (u_max - u_min) H_ii`), so rounding cannot cycle the
            /// active set.
            pub const RELEASE_TOLERANCE: #ty = #release_tolerance;
        },
        MpcSolver::DualActiveSet => {
            let tolerance = dual::violation_tolerance(scalar);
            quote! {
                /// Bound on the dual active set's iterations (bounds held or released) in
                /// one solve, besides those its warm start holds.
                pub const MAX_ITERATIONS: usize = #max_iterations;
                /// A move outside its bounds by more than this fraction of its input's
                /// range violates them: the dual active set then holds the bound (a
                /// smaller excess is rounding, and the plan is clipped).
                pub const VIOLATION_TOLERANCE: #ty = #tolerance;
            }
        }
    }
}

/// `fn new`: every entry read checked finite and the bounds ordered, the weights packed,
/// the terminal weight at `q`, and the plan at zero clipped to the bounds.
fn constructor(
    (model, spec): (&Model, &MpcSpec),
    (moves, cache): (&MoveNames, &Cache),
    dims: &Dims,
    scalar: Scalar,
) -> TokenStream {
    let Dims {
        ty,
        ns_len,
        nu_len,
        horizon,
        ..
    } = dims;
    let (ns, nu) = (spec.states.len(), spec.inputs.len());
    let zero = literal(0.0, scalar);
    let mut arguments = Arguments::default();
    let q = arguments.weight("q", ns, ty);
    let r = arguments.weight("r", nu, ty);
    let (min, max) = moves.bounds();
    arguments.array("u_min", min.clone(), ty);
    arguments.array("u_max", max.clone(), ty);
    let bounds_order_check = moves.bounds_order_check(&quote! { Err(Status::RejectedInput) });
    let start_move = moves.start_move(&zero);
    let nothing_kept = cache.initial(&zero, ns_len, nu_len);
    let held = held_field(spec, true);
    let limit_fields = limit_api::fields(model, spec, scalar, true);
    arguments.constructor(
        &quote! {
            /// A controller with state weight `q` and input weight `r` (symmetric: upper
            /// triangles are read; each positive semi-definite, checked, and `r` positive
            /// definite, which the solve's Riccati steps check) and the input bounds
            /// `u_min < u_max`, regulating to zero until [`Mpc::set_reference`]. The
            /// terminal weight starts at `q` and converges over the first solves; the plan
            /// starts at zero, clipped to the bounds.
        },
        " [`Status::RejectedInput`] if an entry it reads is not finite (of a symmetric \
         matrix, the upper triangle), or if the bounds leave no room (not `u_min < u_max`).",
        quote! {
            #bounds_order_check
            let q = [#(#q),*];
            Ok(Mpc {
                q,
                r: [#(#r),*],
                u_min: [#(#min),*],
                u_max: [#(#max),*],
                x_ref: [#zero; #ns_len],
                u_ref: [#zero; #nu_len],
                terminal_weight: q,
                terminal_gain: [[#zero; #ns_len]; #nu_len],
                plan: [#start_move; #horizon],
                #held
                #limit_fields
                #nothing_kept
            })
        },
    )
}

/// `fn set_weights` and `fn set_input_limits`: the values a user tunes on a running
/// controller, checked as `new` checks them. New weights change the terminal weight and
/// the condensed Hessian the controller keeps, so the next solve rebuilds them (on the
/// kept prediction model, from the last terminal weight); the limits are read afresh by
/// every solve, which clips its warm start to them.
fn setters(spec: &MpcSpec, moves: &MoveNames, dims: &Dims) -> TokenStream {
    let ty = &dims.ty;
    let (ns, nu) = (spec.states.len(), spec.inputs.len());
    let mut weights = Arguments::default();
    let q = weights.weight("q", ns, ty);
    let r = weights.weight("r", nu, ty);
    let set_weights = weights.method(
        &ident("set_weights"),
        &quote! {
            /// Replaces the state weight `q` and the input weight `r` (symmetric: upper
            /// triangles are read; each positive semi-definite, and `r` positive
            /// definite). The next solve takes its Riccati steps from the last terminal
            /// weight towards the new one and rebuilds the condensed Hessian.
            /// [`Status::RejectedInput`] if an entry read is not finite,
            /// [`Status::InvalidWeight`] if a weight is not positive semi-definite, the
            /// weights then as they were.
        },
        quote! {
            self.q = [#(#q),*];
            self.r = [#(#r),*];
            self.terminal_weight_settled = false;
            Status::Ok
        },
    );
    let mut limits = Arguments::default();
    let (min, max) = moves.bounds();
    limits.array("u_min", min.clone(), ty);
    limits.array("u_max", max.clone(), ty);
    let order = moves.bounds_order_check(&quote! { Status::RejectedInput });
    let set_limits = limits.method(
        &ident("set_input_limits"),
        &quote! {
            /// Replaces the input bounds `u_min < u_max`, from the next solve on (which
            /// clips its warm start to them). [`Status::RejectedInput`] if an entry is not
            /// finite or the bounds leave no room, the bounds then as they were.
        },
        quote! {
            #order
            self.u_min = [#(#min),*];
            self.u_max = [#(#max),*];
            Status::Ok
        },
    );
    quote! {
        #set_weights

        #set_limits
    }
}

/// `fn set_reference`: a finite set-point `x_ref` and input `u_ref` stored.
fn set_reference(model: &Model, spec: &MpcSpec, moves: &MoveNames, dims: &Dims) -> TokenStream {
    let Dims {
        ty, ns_len, nu_len, ..
    } = dims;
    let state_refs: Vec<Ident> = model
        .states_named(&spec.states)
        .iter()
        .map(|n| ident(&format!("{n}_ref")))
        .collect();
    let reference_check = moves.reference_check(&state_refs);
    quote! {
        /// Regulates the states to `x_ref` with the inputs around `u_ref`: the plan
        /// `u = u_ref + du` minimises the cost of `x - x_ref` and `du`. For a set-point
        /// of the linear model, `u_ref` is the input that holds it
        /// (`x_ref = A x_ref + B u_ref`). Rejects non-finite values, leaving the
        /// reference as it was.
        pub fn set_reference(&mut self, x_ref: &[#ty; #ns_len], u_ref: &[#ty; #nu_len]) -> Status {
            #reference_check
            self.x_ref = *x_ref;
            self.u_ref = *u_ref;
            Status::Ok
        }
    }
}

/// `control`, `plan`, `terminal_weight` and `terminal_gain`.
fn accessors(dims: &Dims) -> TokenStream {
    let Dims {
        ty,
        ns_len,
        nu_len,
        horizon,
        ..
    } = dims;
    let terminal_weight = unpack_symmetric("terminal_weight", ty);
    quote! {
        /// The first move of the last plan: the input to apply now.
        #[must_use]
        pub fn control(&self) -> [#ty; #nu_len] {
            let [first, ..] = self.plan;
            first
        }

        /// The last plan: `HORIZON` moves, all within the bounds.
        #[must_use]
        pub fn plan(&self) -> [[#ty; #nu_len]; #horizon] {
            self.plan
        }

        /// The prediction model `x+ = A x + B u` the last solve used: built at its
        /// estimate, or kept from an earlier one within `MODEL_TOLERANCE` (all zero before
        /// the first solve). With the terminal weight, the weights, the bounds, the
        /// reference and the estimate, it is the whole problem the plan minimises.
        #[must_use]
        pub fn model(&self) -> PredictionModel {
            self.model
        }

        /// The terminal weight `P_f` of the last solve.
        #[must_use]
        pub fn terminal_weight(&self) -> [[#ty; #ns_len]; #ns_len] {
            #terminal_weight
        }

        /// The gain `K` of the last solve's terminal weight (eq. 41), `u = -K x`: the
        /// infinite-horizon LQR of the current model once the weight has converged.
        #[must_use]
        pub fn terminal_gain(&self) -> [[#ty; #ns_len]; #nu_len] {
            self.terminal_gain
        }
    }
}
