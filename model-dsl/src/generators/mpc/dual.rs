//! The MPC's QP by a dual active-set method (`solver = dual_active_set`). When the
//! prediction model or the weights change: the condensed Hessian's inverse `G = H^-1` and
//! the unconstrained plan's gain `K = G F` (`F` the linear term's response to the
//! regulated states, eq. 44), both by the Riccati recursion over the horizon (`H` itself
//! is never formed), kept; at each solve the unconstrained minimiser
//! `v* = -K (x - x_ref)`, straight-line on `K`, then the held limits' iterations
//! (`stateforge_math`'s `mpc_qp`: which limits it holds, and in which order, is known
//! only at run time, so its loops are a library's, written once for both scalars),
//! warm-started from the last solve's held limits a step on.
//!
//! Chosen for problems with several inputs (TinyMPC's quadrotor: 32 moves): starting from
//! the unconstrained minimiser, a solve whose limits are all inactive costs one product
//! with `K` and one check of the limits, and each limit held costs `O(n k)`, where the
//! primal active set refactorises the free moves' Hessian at each step.

use super::limit_rows::{self, LimitNames};
use super::names::{failure, Names};
use super::qp::{MoveNames, QpCode};
use super::spec::MpcSpec;
use super::stage::Stage;
use crate::emit::lower::{literal, Lowerer, OpCount};
use crate::emit::names::ident;
use crate::emit::scopes::scoped;
use crate::model::{Model, Scalar};
use crate::symbolic::linalg::Matrix;
use crate::symbolic::{Graph, ModelGraph, NodeId, VarId};
use proc_macro2::{Ident, TokenStream};
use quote::quote;
use std::collections::BTreeSet;

/// The names of `K`'s entries, kept transposed: per regulated state, per move.
fn gain_names(spec: &MpcSpec, moves: &MoveNames, names: &Names) -> Vec<Vec<String>> {
    names.matrix("kv", spec.states.len(), moves.count())
}

/// What the rebuild adds after the terminal weight (`p_idents`, packed):
/// `hessian_inverse`, `G = H^-1`, and `unconstrained_gain`, `K'`, by the Riccati
/// recursion over the horizon from `A`, `B`, `Q`, `R` and `P_f`, never forming `H`
/// (`stateforge_math`'s `condensed_inverse`: in `f32` the rounding of `H`'s sums,
/// amplified by its condition number, would decide the plan's accuracy), or the solve's
/// failure when a `R + B'PB` is not positive definite to within rounding; then the limit
/// rows and `G` times each.
pub fn rebuild(
    g: &mut Graph,
    (a, b, p_idents): (&Matrix, &Matrix, &[Ident]),
    (spec, moves, names): (&MpcSpec, &MoveNames, &Names),
    scalar: Scalar,
) -> Stage {
    let math = math_module(scalar);
    let not_definite = failure(quote! { Status::NonPositiveControlWeight });
    let (ns, nu) = (spec.states.len(), spec.inputs.len());
    let limit_rows = limit_rows::coefficients(g, (a, b), spec);
    let mut roots: Vec<NodeId> = a.iter().chain(b).flatten().copied().collect();
    roots.extend(limit_rows.iter().flatten());
    let mut lowerer = Lowerer::new(g, scalar, names.namer(), &roots);
    let values = lowerer.segment(&roots);
    let m = moves.count();
    let (model_values, row_values) = values.split_at(ns * (ns + nu));
    let (a_values, b_values) = model_values.split_at(ns * ns);
    let a_rows = a_values.chunks(ns.max(1)).map(|row| quote! { [#(#row),*] });
    let b_rows = b_values.chunks(nu.max(1)).map(|row| quote! { [#(#row),*] });
    let limits = (!limit_rows.is_empty()).then(|| {
        let limit_rows = row_values
            .chunks(m.max(1))
            .map(|row| quote! { [#(#row),*] });
        quote! {
            // The limit rows, and G times each.
            let limit_rows = [#(#limit_rows),*];
            let limit_columns = #math::limit_columns(&hessian_inverse, &limit_rows);
        }
    });
    let statements = scoped(lowerer.take_statements(), &quote! { #(#values)* });
    let code = quote! {
        // G = H^-1 and K = G F, the unconstrained plan's gain, by the Riccati recursion
        // over the horizon from P_f.
        #(#statements)*
        let Some(stateforge_math::CondensedInverse {
            inverse: hessian_inverse,
            gain: unconstrained_gain,
        }) = #math::condensed_inverse(&stateforge_math::PredictionProblem {
            a: &[#(#a_rows),*],
            b: &[#(#b_rows),*],
            q: &#math::unpack_symmetric(&self.q),
            r: &#math::unpack_symmetric(&self.r),
            terminal: &#math::unpack_symmetric(&[#(#p_idents),*]),
        }) else {
            #not_definite
        };
        #limits
    };
    Stage {
        code,
        ops: lowerer
            .ops()
            .plus(condensed_inverse_ops(ns, nu, spec.horizon as usize))
            .plus(columns_ops(m, spec.limit_rows())),
    }
}

/// What `condensed_inverse` costs (loops), in multiply-adds: per step of the backward
/// recursion `B'P`, `B'PB`, `B'PA`, `K_k` and `P_k`'s upper triangle (`2 ns^3 + ..`); the
/// gain's `K_k X` and `X`'s step; the closed loop's responses `T` (`N^2 / 2` blocks); and
/// `G = T D^-1 T'` (`m^3 / 6`).
fn condensed_inverse_ops(ns: usize, nu: usize, horizon: usize) -> OpCount {
    let (ns, nu, n) = (ns as u32, nu as u32, horizon as u32);
    let m = n * nu;
    let backward =
        n * (2 * nu * ns * ns + 2 * nu * nu * ns + ns * ns * ns + ns * ns * (ns + nu) / 2);
    let gain = n * (nu * ns * ns + ns * ns * (ns + nu));
    let responses = n * n.saturating_sub(1) / 2 * (nu * ns * nu + ns * nu * (ns + nu));
    let inverse = m * m * m / 6 + m * m * nu / 2;
    let macs = backward + gain + responses + inverse;
    OpCount {
        add: macs,
        mul: macs,
        div: n * nu * nu,
        compare: m * m / 2 + n * nu,
        load: 2 * macs,
        store: macs / ns.max(1) + m * m,
        branch: macs / 4,
        ..OpCount::default()
    }
}

/// What `G a` costs for each of `rows` limit rows: `m^2` multiply-adds each, in loops.
fn columns_ops(m: usize, rows: usize) -> OpCount {
    let macs = (m * m * rows) as u32;
    OpCount {
        add: macs,
        mul: macs,
        load: 2 * macs,
        store: (m * rows) as u32,
        branch: macs / 4,
        ..OpCount::default()
    }
}

/// The pattern that binds `K`'s entries from `unconstrained_gain`.
pub fn gain_pattern(spec: &MpcSpec, moves: &MoveNames, names: &Names) -> TokenStream {
    let rows = gain_names(spec, moves, names).into_iter().map(|row| {
        let entries = row.iter().map(|n| ident(n));
        quote! { [#(#entries),*] }
    });
    quote! { let [#(#rows),*] = *unconstrained_gain; }
}

/// `v* = -K (x - x_ref)` on `K`'s entries: its code (with the reference's reading), its
/// cost and the model variables it reads.
pub fn unconstrained(
    model: &Model,
    (spec, moves, names): (&MpcSpec, &MoveNames, &Names),
    mg: &mut ModelGraph,
    (a, scalar): (&Matrix, Scalar),
) -> (Stage, BTreeSet<VarId>) {
    let references: Vec<String> = spec
        .states
        .iter()
        .map(|&i| names.fresh(&format!("{}_ref", model.states[i].name)))
        .collect();
    let gain = gain_names(spec, moves, names);
    let deviation: Vec<NodeId> = spec
        .states
        .iter()
        .zip(&references)
        .map(|(&i, name)| {
            let reference = mg.graph.var(name);
            mg.graph.sub(mg.x[i], reference)
        })
        .collect();
    let g = &mut mg.graph;
    let minimiser: Vec<NodeId> = (0..moves.count())
        .map(|i| {
            let terms: Vec<NodeId> = deviation
                .iter()
                .zip(&gain)
                .map(|(&d, row)| {
                    let k = g.var(&row[i]);
                    g.mul(k, d)
                })
                .collect();
            let sum = terms.into_iter().fold(g.zero(), |sum, t| g.add(sum, t));
            g.neg(sum)
        })
        .collect();
    let limit_names = LimitNames::new(model, spec, names);
    let input_references = moves.per_input("ref");
    let (lower, upper, penalty) = limit_rows::bounds(
        mg,
        (spec, &limit_names, a),
        (&deviation, &references),
        &input_references,
        scalar,
    );
    let mut roots = minimiser.clone();
    roots.extend(lower.iter().chain(&upper));
    let mut lowerer = Lowerer::new(&mg.graph, scalar, names.namer(), &roots);
    let values = lowerer.segment(&roots);
    let statements = scoped(lowerer.take_statements(), &quote! { #(#values)* });
    let ops = lowerer.ops();
    let used = lowerer.finish().used_vars;
    let (minimiser, limits) = values.split_at(moves.count());
    let (lower, upper) = limits.split_at(limits.len() / 2);
    let references = references.iter().map(|n| ident(n));
    let bounds = moves.deviation_bounds();
    let limit_reads = limit_names.reads(spec);
    let limits = (!lower.is_empty()).then(|| {
        quote! {
            let limit_lower = [#(#lower),*];
            let limit_upper = [#(#upper),*];
            let limit_penalty = [#(#penalty),*];
        }
    });
    let code = quote! {
        #bounds
        // The unconstrained minimiser v* = -K (x - x_ref), and the limits at this solve.
        let [#(#references),*] = self.x_ref;
        #limit_reads
        #(#statements)*
        let unconstrained = [#(#minimiser),*];
        #limits
    };
    (Stage { code, ops }, used)
}

/// The solve: the bounds as deviations from `u_ref`, `v* = -G c`, the warm start (the last
/// held bounds a step on) and the iterations, at most `limit`; binds the moves, `optimal`,
/// `steps` and `held` (which the commit stores).
pub fn dual_active_set(
    (spec, moves): (&MpcSpec, &MoveNames),
    limit: &TokenStream,
    scalar: Scalar,
) -> QpCode {
    let m = moves.count();
    let (move_low, move_high) = (moves.per_move_input("low"), moves.per_move_input("high"));
    let warm = warm_start();
    let rows = match spec.limit_rows() {
        0 => quote! {
            stateforge_math::LimitRows {
                coefficients: &[],
                columns: &[],
                lower: &[],
                upper: &[],
                penalty: &[],
            }
        },
        _ => quote! {
            stateforge_math::LimitRows {
                coefficients: limit_rows,
                columns: limit_columns,
                lower: &limit_lower,
                upper: &limit_upper,
                penalty: &limit_penalty,
            }
        },
    };
    let math = math_module(scalar);
    let move_ids = moves.move_idents();
    let code = quote! {
        #warm
        let solution = #math::mpc_qp(
            &stateforge_math::MpcQp {
                inverse: hessian_inverse,
                unconstrained: &unconstrained,
                low: &[#(#move_low),*],
                high: &[#(#move_high),*],
                rows: #rows,
            },
            &mut held,
            #limit,
            Self::VIOLATION_TOLERANCE,
        );
        let optimal = solution.optimal;
        let steps = solution.iterations;
        let [#(#move_ids),*] = solution.moves;
    };
    let (m32, nu) = (m as u32, moves.input_count() as u32);
    let r = spec.limit_rows() as u32;
    let setup = OpCount {
        // the deviations' bounds; the final check of the bounds, and of the rows (a
        // product over the moves each)
        add: 2 * nu + 3 * m32 + r * m32 + 2 * r,
        mul: r * m32,
        compare: 3 * m32 + 2 * r,
        load: 3 * nu + m32 + 2 * r * m32,
        store: 4 * m32,
        branch: 2 * (m32 + r),
        ..OpCount::default()
    };
    QpCode {
        code,
        iteration_ops: iteration_ops(m, spec.limit_rows()),
        setup_ops: setup,
    }
}

/// One iteration at its worst, `k = m` limits held: the held set's multipliers (`k^2`),
/// the moves (`m k`), the check of the limits, and a row of the factor held (`k^2 / 2`)
/// or released (a rank-one update, `k^2`), in loops; with `r` limit rows, each row's value
/// is a product over the moves (`m` multiply-adds): in the check (`r m`), and for each held
/// row in the multipliers' right-hand side and in a new row of the factor (`2 m k`).
fn iteration_ops(m: usize, r: usize) -> OpCount {
    let (m, r) = (m as u32, r as u32);
    let square = m * m;
    let rows = if r > 0 { 2 * square + r * m } else { 0 };
    let macs = 3 * square + rows;
    OpCount {
        add: macs + 3 * m,
        mul: macs + m,
        div: 3 * m,
        compare: 4 * (m + r),
        load: 2 * macs,
        store: square + 2 * m,
        branch: 2 * square + 2 * (m + r),
        ..OpCount::default()
    }
}

/// The warm start: the limits the last solve held, a step on (the first step's were
/// applied; the last step's start free).
fn warm_start() -> TokenStream {
    quote! {
        // Warm start: the limits the last solve held, a step on.
        let mut held = stateforge_math::HeldLimits::shifted(&self.held, Self::HORIZON);
    }
}

/// `stateforge_math::f32` or `stateforge_math::f64`.
fn math_module(scalar: Scalar) -> TokenStream {
    let ty = ident(scalar.type_name());
    quote! { stateforge_math::#ty }
}

/// The tolerance of a violated bound, as a fraction of its input's range.
pub fn violation_tolerance(scalar: Scalar) -> TokenStream {
    literal(
        match scalar {
            Scalar::F32 => 1e-6,
            Scalar::F64 => 1e-12,
        },
        scalar,
    )
}
