//! The window transform's generated method (eqs. 8-12): the window's parameter system
//! solved by Cramer's rule (eq. 9; a longer window's by least squares, Cramer's rule on
//! its normal equations) when its excitation passes the threshold (else Case 1
//! keeps the last solved parameters), the reduced systems of Case 2 when inputs were zero
//! over the window, and the states reconstructed at the window's end.

use super::window::{column_norms_product, cramer, WindowTransform};
use super::window_noise;
use crate::emit::code::{destructure, var_idents};
use crate::emit::filter::{model_names, packed_vars};
use crate::emit::lower::{literal, Lowered, Lowerer, OpCount};
use crate::emit::names::{ident, TempNamer};
use crate::model::{Model, Scalar};
use crate::symbolic::linalg::{packed_index, Matrix};
use crate::symbolic::{Graph, ModelGraph, NodeId, VarId};
use proc_macro2::{Ident, Literal, TokenStream};
use quote::quote;
use std::collections::BTreeSet;

/// `fn transform(&self, u) -> (phi, WindowStatus, [det_sq, column_norms], parameters)`:
/// eqs. (8)-(12), and the arithmetic of its costliest path (the full solve).
pub fn transform_fn(
    model: &Model,
    mg: &ModelGraph,
    wt: &WindowTransform,
    scalar: Scalar,
) -> (TokenStream, OpCount) {
    let mut g = mg.clone();
    let avoid = model_names(model);
    let solve = WindowSolve::new(&mut g.graph, wt, model.params.len(), &avoid);
    let namer = TempNamer::new(avoid.iter().map(String::as_str));
    let mut base = Lowerer::new(&g.graph, scalar, namer, &solve.roots(wt));
    let det = base.bind(solve.full.det, "det");
    let det_sq = base.bind(solve.full.det_sq, "det_sq");
    let column_norms = base.bind(solve.full.norms, "column_norms");
    // The excitation test (`det_sq > threshold * column_norms`) and `1 / det`.
    base.count_extra(OpCount {
        div: 1,
        compare: 1,
        mul: 1,
        ..OpCount::default()
    });
    let head = base.take_statements();
    let at_fork = base.ops();
    let last: Vec<Ident> = model
        .params
        .iter()
        .map(|p| ident(&format!("last_{}", p.name)))
        .collect();

    // Full solve, in a fork of the lowering so its temporaries stay in its branch.
    let mut full = base.clone();
    let full_values = full.segment(&solve.full.solution);
    let full_body = full.take_statements();
    let full_ops = full.ops();

    let case2_branches = solve
        .reduced
        .iter()
        .map(|reduced| case2_branch(base.clone(), wt, reduced, &last, scalar))
        .collect();
    let phi_states = base.segment(&wt.phi_states);
    let tail = base.take_statements();
    let covariance = solve.covariance.as_ref().map(|c| covariance_code(&base, c));
    let Lowered {
        mut used_vars,
        mut ops,
        ..
    } = base.finish();
    if let Some((_, covariance_vars, covariance_ops)) = &covariance {
        used_vars.extend(covariance_vars);
        ops = *covariance_ops;
    }
    let code = TransformCode {
        head,
        excitation: [det, det_sq, column_norms],
        phi_params: var_idents(&g.graph, &wt.phi_params),
        last,
        full_values,
        full_body,
        case2_branches,
        tail,
        phi_states,
        covariance: covariance.map(|(code, ..)| code),
    };
    let tokens = code.method(model, &g, wt, used_vars, scalar);
    // The costliest path: the common code plus the full solve's branch.
    (tokens, ops.plus(full_ops.minus(at_fork)))
}

/// A least-squares window's parameter covariance, `(r_vars, covariance)`, lowered in a
/// fork of `base` (it is computed only for a solved window): its code, the variables it
/// reads and what it computes.
fn covariance_code(
    base: &Lowerer,
    (r_vars, covariance): &(Vec<NodeId>, Vec<NodeId>),
) -> (CovarianceCode, BTreeSet<VarId>, OpCount) {
    let mut fork = base.clone();
    let values = fork.segment(covariance);
    let body = fork.take_statements();
    let Lowered { used_vars, ops, .. } = fork.finish();
    let code = CovarianceCode {
        r_vars: r_vars.clone(),
        body,
        values,
    };
    (code, used_vars, ops)
}

/// The parameter system of one case solved symbolically by Cramer's rule (eq. 9): each
/// solved parameter is its numerator times `inv_det`.
struct Solve {
    /// Parameters kept at their last values (none for the full system).
    frozen: Vec<usize>,
    /// Parameters solved, in the order of the system's columns.
    free: Vec<usize>,
    det: NodeId,
    det_sq: NodeId,
    /// The product of the squared column norms (the excitation measure's denominator).
    norms: NodeId,
    /// The free parameters, `numerator * inv_det`.
    solution: Vec<NodeId>,
    /// The normal matrix `A' A` of a least-squares system.
    normal: Option<Matrix>,
}

/// The window's full parameter system and its Case 2 reductions, largest first; for a
/// least-squares window, the full solve's parameter covariance (packed) and the
/// measurement noise variables it reads.
struct WindowSolve {
    full: Solve,
    reduced: Vec<Solve>,
    covariance: Option<(Vec<NodeId>, Vec<NodeId>)>,
}

impl WindowSolve {
    /// Solves the full system, then each reduction (the variable `inv_det` standing for
    /// the reciprocal of whichever determinant the taken branch divides by). A square
    /// reduction takes the system's first rows; a least-squares one every row.
    fn new(graph: &mut Graph, wt: &WindowTransform, np: usize, avoid: &[String]) -> WindowSolve {
        let (mut full, numerators) = Solve::cramer(graph, &wt.matrix, &wt.rhs, Vec::new());
        full.free = (0..np).collect();
        let least_squares = wt.matrix.len() > np;
        let mut reduced: Vec<(Solve, Vec<NodeId>)> = frozen_subsets(wt, np)
            .into_iter()
            .map(|frozen| {
                let free: Vec<usize> = (0..np).filter(|p| !frozen.contains(p)).collect();
                let rows = if least_squares {
                    wt.matrix.len()
                } else {
                    free.len()
                };
                let matrix: Matrix = wt.matrix[..rows]
                    .iter()
                    .map(|row| free.iter().map(|&p| row[p]).collect())
                    .collect();
                let (mut solve, numerators) =
                    Solve::cramer(graph, &matrix, &wt.rhs[..rows], frozen);
                solve.free = free;
                (solve, numerators)
            })
            .collect();
        let inv_det = graph.var("inv_det");
        full.solution = times(graph, &numerators, inv_det);
        for (solve, numerators) in &mut reduced {
            solve.solution = times(graph, numerators, inv_det);
        }
        let covariance = full
            .normal
            .as_ref()
            .map(|normal| full_covariance(graph, wt, normal, full.det, avoid));
        WindowSolve {
            full,
            reduced: reduced.into_iter().map(|(solve, _)| solve).collect(),
            covariance,
        }
    }

    /// Every value the transform computes, for the lowering's use counts.
    fn roots(&self, wt: &WindowTransform) -> Vec<NodeId> {
        let mut roots = Vec::new();
        for solve in std::iter::once(&self.full).chain(&self.reduced) {
            roots.extend([solve.det, solve.det_sq, solve.norms]);
            roots.extend(&solve.solution);
        }
        if let Some((_, covariance)) = &self.covariance {
            roots.extend(covariance);
        }
        roots.extend(&wt.phi_states);
        roots
    }
}

impl Solve {
    /// The determinant, its square and the column norms' product of `matrix`, with the
    /// numerators of Cramer's rule (the solution is filled in once `inv_det` exists). An
    /// over-determined `matrix` (`A`, more rows than columns) is solved by least squares
    /// through its normal equations `A' A theta = A' b`: then the determinant is that of
    /// `A' A`, which is also its "square" (for a square `A`, `det(A' A) = det(A)^2`), and
    /// the column norms' product is that of `A` (the diagonal of `A' A`), so the excitation
    /// measure `det / prod` is the same ratio in `0..=1`, generalised.
    fn cramer(
        graph: &mut Graph,
        matrix: &Matrix,
        rhs: &[NodeId],
        frozen: Vec<usize>,
    ) -> (Solve, Vec<NodeId>) {
        let square = matrix.len() <= matrix.first().map_or(0, Vec::len);
        let (det, det_sq, norms, numerators, normal) = if square {
            let (det, numerators) = cramer(graph, matrix, rhs);
            let norms = column_norms_product(graph, matrix);
            (det, graph.mul(det, det), norms, numerators, None)
        } else {
            let (normal, normal_rhs) = normal_equations(graph, matrix, rhs);
            let (det, numerators) = cramer(graph, &normal, &normal_rhs);
            let mut norms = graph.one();
            for (p, row) in normal.iter().enumerate() {
                norms = graph.mul(norms, row[p]);
            }
            (det, det, norms, numerators, Some(normal))
        };
        let solve = Solve {
            frozen,
            free: Vec::new(),
            det,
            det_sq,
            norms,
            solution: Vec::new(),
            normal,
        };
        (solve, numerators)
    }
}

/// The normal equations of the least-squares problem `A theta ~ b`: `A' A` (symmetric,
/// each entry built once) and `A' b`, sums over the equations whose terms are not
/// structurally zero.
fn normal_equations(graph: &mut Graph, a: &Matrix, b: &[NodeId]) -> (Matrix, Vec<NodeId>) {
    let np = a.first().map_or(0, Vec::len);
    let mut normal: Matrix = vec![Vec::with_capacity(np); np];
    for p in 0..np {
        for q in 0..np {
            let entry = if q < p {
                normal[q][p]
            } else {
                sum_of_products(graph, a.iter().map(|row| (row[p], row[q])))
            };
            normal[p].push(entry);
        }
    }
    let normal_rhs = (0..np)
        .map(|p| sum_of_products(graph, a.iter().zip(b).map(|(row, &rhs)| (row[p], rhs))))
        .collect();
    (normal, normal_rhs)
}

/// `sum x y` over `pairs`, skipping the structurally zero terms.
fn sum_of_products(graph: &mut Graph, pairs: impl Iterator<Item = (NodeId, NodeId)>) -> NodeId {
    let mut sum = graph.zero();
    for (x, y) in pairs {
        if graph.is_zero(x) || graph.is_zero(y) {
            continue;
        }
        let term = graph.mul(x, y);
        sum = graph.add(sum, term);
    }
    sum
}

/// The full least-squares solve's parameter covariance ([`window_noise`]) over the solved
/// parameters' variables and the measurement noise's variances: those variables, and the
/// packed covariance.
fn full_covariance(
    graph: &mut Graph,
    wt: &WindowTransform,
    normal: &Matrix,
    det: NodeId,
    avoid: &[String],
) -> (Vec<NodeId>, Vec<NodeId>) {
    let m = wt.outputs.len();
    let r_vars = packed_vars(graph, "r", m, avoid);
    let r_diagonal: Vec<NodeId> = (0..m).map(|i| r_vars[packed_index(m, i, i)]).collect();
    let covariance = window_noise::parameter_covariance(graph, wt, normal, det, &r_diagonal);
    (r_vars, covariance)
}

/// Each of `values` times `factor`.
fn times(graph: &mut Graph, values: &[NodeId], factor: NodeId) -> Vec<NodeId> {
    values.iter().map(|&v| graph.mul(v, factor)).collect()
}

/// Case 2 variants: the nonempty subsets of the input-only parameters, each frozen when
/// its inputs were zero over the window, largest first.
fn frozen_subsets(wt: &WindowTransform, np: usize) -> Vec<Vec<usize>> {
    let input_only: Vec<usize> = (0..np).filter(|&p| wt.input_only[p].is_some()).collect();
    let mut subsets: Vec<Vec<usize>> = (1..(1u32 << input_only.len()))
        .map(|mask| {
            input_only
                .iter()
                .enumerate()
                .filter(|(bit, _)| mask & (1 << bit) != 0)
                .map(|(_, &p)| p)
                .collect()
        })
        .collect();
    subsets.sort_by_key(|s: &Vec<usize>| std::cmp::Reverse(s.len()));
    subsets
}

/// The branch of Case 2 that freezes `reduced.frozen`: taken when their inputs were all
/// zero over the window; solves the reduced system if its excitation passes the threshold
/// (Case 1 otherwise). Lowered in `fork`, so its temporaries stay in the branch.
fn case2_branch(
    mut fork: Lowerer<'_>,
    wt: &WindowTransform,
    reduced: &Solve,
    last: &[Ident],
    scalar: Scalar,
) -> TokenStream {
    let (zero, one) = (literal(0.0, scalar), literal(1.0, scalar));
    let conditions: Vec<Ident> = reduced
        .frozen
        .iter()
        .flat_map(|&p| wt.input_only[p].clone().unwrap_or_default())
        .map(|node| var_idents(fork.graph(), &[node]).remove(0))
        .collect();
    let det_r = fork.bind(reduced.det, "reduced_det");
    let det_sq_r = fork.bind(reduced.det_sq, "reduced_det_sq");
    let norms_r = fork.bind(reduced.norms, "reduced_column_norms");
    let guard = fork.take_statements();
    let values = fork.segment(&reduced.solution);
    let body = fork.take_statements();
    let mut entries: Vec<TokenStream> = last.iter().map(|l| quote! { #l }).collect();
    for (&p, v) in reduced.free.iter().zip(values) {
        entries[p] = v;
    }
    quote! {
        else if #(#conditions == #zero)&&* {
            #(#guard)*
            if #det_sq_r > threshold * #norms_r {
                let inv_det = #one / #det_r;
                #(#body)*
                ([#(#entries),*], WindowStatus::InputFree)
            } else {
                (self.phi_params, WindowStatus::Degenerate)
            }
        }
    }
}

/// The lowered pieces of the transform, assembled into its method.
struct TransformCode {
    /// The full system's determinant, its square and the column norms' product.
    head: Vec<TokenStream>,
    /// The names bound to `det`, `det_sq` and `column_norms`.
    excitation: [TokenStream; 3],
    /// The variables of the solved parameters.
    phi_params: Vec<Ident>,
    /// The variables of the last solved parameters.
    last: Vec<Ident>,
    full_values: Vec<TokenStream>,
    full_body: Vec<TokenStream>,
    case2_branches: Vec<TokenStream>,
    /// The propagation of the states to the window's end.
    tail: Vec<TokenStream>,
    phi_states: Vec<TokenStream>,
    /// A least-squares window's parameter covariance.
    covariance: Option<CovarianceCode>,
}

/// The lowered parameter covariance of a least-squares window ([`window_noise`]): the
/// measurement noise variables it reads, its statements and its packed entries.
struct CovarianceCode {
    r_vars: Vec<NodeId>,
    body: Vec<TokenStream>,
    values: Vec<TokenStream>,
}

impl TransformCode {
    /// `fn transform`: reads the window and the input, and returns the reconstructed
    /// `phi` with the window's status and excitation terms.
    fn method(
        &self,
        model: &Model,
        g: &ModelGraph,
        wt: &WindowTransform,
        used_vars: BTreeSet<VarId>,
        scalar: Scalar,
    ) -> TokenStream {
        let (u_param, unpack) = window_reads(g, wt, &used_vars, scalar);
        let ty = ident(scalar.type_name());
        let zero = literal(0.0, scalar);
        let n = Literal::usize_unsuffixed(model.state_len());
        let np_len = Literal::usize_unsuffixed(model.params.len());
        let solve = self.solve(scalar);
        let covariance = self.covariance.as_ref().map(|c| c.tokens(g, &used_vars));
        let Self {
            tail,
            phi_states,
            phi_params,
            excitation: [_, det_sq_e, norms_e],
            ..
        } = self;
        let packed_len =
            Literal::usize_unsuffixed(model.params.len() * (model.params.len() + 1) / 2);
        let covariance_type = covariance
            .is_some()
            .then(|| quote! { , [#ty; #packed_len] });
        let covariance_kept = covariance
            .is_some()
            .then(|| quote! { , self.phi_covariance });
        let covariance_doc = covariance.is_some().then(|| {
            quote! {
                /// Last, the least-squares parameters' covariance (packed): the solved
                /// window's, else the last solved.
            }
        });
        quote! {
            /// The window transform: the reconstructed `phi` (states, then parameters), the
            /// window's status, the squared determinant and product of squared column norms
            /// of its parameter system (whose ratio is the squared excitation measure), and
            /// the parameters to keep: those solved, else the last solved (eqs. 8-12).
            #covariance_doc
            #[allow(clippy::type_complexity)]
            fn transform(&self, #u_param) -> ([#ty; #n], WindowStatus, [#ty; 2], [#ty; #np_len] #covariance_type) {
                let [.., full] = self.filled;
                if !full {
                    return (self.xbar, WindowStatus::Filling, [#zero, #zero], self.phi_params #covariance_kept);
                }
                #unpack
                #solve
                #(#tail)*
                (
                    [#(#phi_states,)* #(#phi_params),*],
                    window,
                    [#det_sq_e, #norms_e],
                    [#(#phi_params),*],
                    #covariance
                )
            }
        }
    }

    /// The parameters and the window's status: the full solve if the window is excited
    /// enough, else a Case 2 reduction if its inputs were zero, else the last parameters
    /// (Case 1).
    fn solve(&self, scalar: Scalar) -> TokenStream {
        let Self {
            head,
            excitation: [det_e, det_sq_e, norms_e],
            phi_params,
            last,
            full_values,
            full_body,
            case2_branches,
            ..
        } = self;
        let one = literal(1.0, scalar);
        quote! {
            #(#head)*
            let threshold = self.min_excitation_sq;
            let [#(#last),*] = self.phi_params;
            let ([#(#phi_params),*], window) = if #det_sq_e > threshold * #norms_e {
                let inv_det = #one / #det_e;
                #(#full_body)*
                ([#(#full_values),*], WindowStatus::Solved)
            }
            #(#case2_branches)*
            else {
                ([#(#last),*], WindowStatus::Degenerate)
            };
        }
    }
}

impl CovarianceCode {
    /// The covariance's entries if the window was solved, else the last (eq. in
    /// [`window_noise`]), reading the measurement noise's variances.
    fn tokens(&self, g: &ModelGraph, used: &BTreeSet<VarId>) -> TokenStream {
        let Self { body, values, .. } = self;
        let unpack_r = destructure(&g.graph, quote! { self.r }, &self.r_vars, used);
        quote! {
            if window == WindowStatus::Solved {
                #unpack_r
                #(#body)*
                [#(#values),*]
            } else {
                self.phi_covariance
            }
        }
    }
}

/// The transform's input parameter and the `let` patterns unpacking the window variables
/// and the input it reads; the Case 2 branches read window variables too, so every window
/// variable is unpacked.
fn window_reads(
    g: &ModelGraph,
    wt: &WindowTransform,
    used: &BTreeSet<VarId>,
    scalar: Scalar,
) -> (Option<TokenStream>, TokenStream) {
    let mut used = used.clone();
    for node in wt
        .outputs
        .iter()
        .flatten()
        .chain(wt.inputs.iter().flatten())
    {
        if let crate::symbolic::Node::Var(v) = g.graph.node(*node) {
            used.insert(v);
        }
    }
    let unpack_window = window_unpack(&g.graph, wt, &used);
    let unpack_u = destructure(&g.graph, quote! { *u }, &g.u, &used);
    let ty = ident(scalar.type_name());
    let u_param = (!g.u.is_empty()).then(|| {
        let len = Literal::usize_unsuffixed(g.u.len());
        let name = if unpack_u.is_some() {
            ident("u")
        } else {
            ident("_u")
        };
        quote! { #name: &[#ty; #len] }
    });
    (u_param, quote! { #unpack_u #unpack_window })
}

/// The window variables as `let` patterns over the stored history.
fn window_unpack(graph: &Graph, wt: &WindowTransform, used: &BTreeSet<VarId>) -> TokenStream {
    let outputs: Vec<NodeId> = wt.outputs.iter().flatten().copied().collect();
    let inputs: Vec<NodeId> = wt.inputs.iter().flatten().copied().collect();
    let y = destructure(graph, quote! { self.outputs }, &outputs, used);
    let u = destructure(graph, quote! { self.inputs }, &inputs, used);
    quote! { #y #u }
}
