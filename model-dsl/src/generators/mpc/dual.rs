//! The MPC's box-constrained QP by a dual active-set method (`solver = dual_active_set`):
//! the condensed Hessian's inverse `G = H^-1`, computed when the Hessian is rebuilt and
//! kept with it; at each solve the unconstrained minimiser `v* = -G c`, straight-line on
//! `G`'s upper triangle, then the held bounds' iterations (`stateforge_math`'s `box_qp`:
//! the order of the bounds it holds is known only at run time, so its loops are a
//! library's, written once for both scalars), warm-started from the last solve's held
//! bounds a step on.
//!
//! Chosen for problems with several inputs (TinyMPC's quadrotor: 32 moves): starting from
//! the unconstrained minimiser, a solve whose bounds are all inactive costs one product
//! with `G` and one check of the bounds, and each bound held costs `O(n k)`, where the
//! primal active set refactorises the free moves' Hessian at each step.

use super::names::{failure, Names};
use super::qp::{MoveNames, QpCode};
use crate::emit::lower::{literal, Lowerer, OpCount};
use crate::emit::names::ident;
use crate::emit::scopes::scoped;
use crate::model::Scalar;
use crate::symbolic::linalg::{matmul, symmetric_from_packed, Matrix};
use crate::symbolic::Graph;
use proc_macro2::{Ident, TokenStream};
use quote::quote;

/// The names of `G`'s entries, row by row, each row whole: the upper triangle's names
/// (`g11 ..`, `g_1_1 ..`), `None` below the diagonal.
fn inverse_names(moves: &MoveNames, names: &Names) -> Vec<Vec<Option<Ident>>> {
    let m = moves.count();
    let packed = crate::emit::code::packed_names("g", m, &|name| names.takes(name));
    let mut entries = packed.iter();
    (0..m)
        .map(|i| {
            (0..m)
                .map(|j| (j >= i).then(|| entries.next().map(|n| ident(n))).flatten())
                .collect()
        })
        .collect()
}

/// The rebuild's last statement: `hessian_inverse`, `G = H^-1` of the Hessian's packed
/// entries (bound by name), or the solve's failure when `H` is not positive definite to
/// within rounding (a control weight that is not).
pub fn inverse_code(moves: &MoveNames, scalar: Scalar) -> TokenStream {
    let math = math_module(scalar);
    let hessian = moves.hessian.iter().map(|h| ident(h));
    let not_definite = failure(quote! { Status::NonPositiveControlWeight });
    quote! {
        // G = H^-1, kept with H for the dual active set's iterations.
        let Some(hessian_inverse) =
            #math::symmetric_inverse(&#math::unpack_symmetric(&[#(#hessian),*]))
        else {
            #not_definite
        };
    }
}

/// What [`inverse_code`] costs for `m` moves: `L D L'` (`m^3 / 6`), `L^-1` (`m^3 / 6`) and
/// `L^-T D^-1 L^-1` (`m^3 / 6`) multiply-adds, in loops.
pub fn inverse_ops(m: usize) -> OpCount {
    let m = m as u32;
    let cube = m * m * m / 2;
    OpCount {
        add: cube,
        mul: cube + m * m / 2,
        div: m * m / 2 + m,
        compare: m * m,
        load: 2 * cube,
        store: cube / 3 + m * m,
        branch: m * m,
        ..OpCount::default()
    }
}

/// The pattern that binds `G`'s upper triangle from `hessian_inverse`.
pub fn inverse_pattern(moves: &MoveNames, names: &Names) -> TokenStream {
    let rows = inverse_names(moves, names).into_iter().map(|row| {
        let entries = row.into_iter().map(|entry| match entry {
            Some(name) => quote! { #name },
            None => quote! { _ },
        });
        quote! { [#(#entries),*] }
    });
    quote! { let [#(#rows),*] = *hessian_inverse; }
}

/// The solve: the bounds as deviations from `u_ref`, `v* = -G c`, the warm start (the last
/// held bounds a step on) and the iterations, at most `limit`; binds the moves, `optimal`,
/// `steps` and `held` (which the commit stores).
pub fn dual_active_set(
    g: &mut Graph,
    moves: &MoveNames,
    (names, limit): (&Names, &TokenStream),
    scalar: Scalar,
) -> QpCode {
    let m = moves.count();
    let (statements, values, ops) = unconstrained(g, moves, names, scalar);
    let bounds = moves.deviation_bounds();
    let (move_low, move_high) = (moves.per_move_input("low"), moves.per_move_input("high"));
    let warm = warm_start(moves);
    let math = math_module(scalar);
    let move_ids = moves.move_idents();
    let code = quote! {
        #bounds
        // The unconstrained minimiser v* = -G c.
        #(#statements)*
        let unconstrained = [#(#values),*];
        #warm
        let solution = #math::mpc_qp(
            &stateforge_math::MpcQp {
                inverse: hessian_inverse,
                unconstrained: &unconstrained,
                low: &[#(#move_low),*],
                high: &[#(#move_high),*],
                rows: stateforge_math::LimitRows {
                    coefficients: &[],
                    columns: &[],
                    lower: &[],
                    upper: &[],
                    penalty: &[],
                },
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
    let setup = OpCount {
        // the deviations' bounds; the final check of the bounds
        add: 2 * nu + 3 * m32,
        compare: 3 * m32,
        load: 3 * nu + m32,
        store: 4 * m32,
        branch: 2 * m32,
        ..OpCount::default()
    };
    QpCode {
        code,
        iteration_ops: iteration_ops(m),
        setup_ops: ops.plus(setup),
    }
}

/// One iteration at its worst, `k = m` bounds held: the held set's multipliers (`k^2`),
/// the moves (`m k`), the check of the bounds, and a row of the factor held (`k^2 / 2`)
/// or released (a rank-one update, `k^2`), in loops.
fn iteration_ops(m: usize) -> OpCount {
    let m = m as u32;
    let square = m * m;
    let macs = square + square + square;
    OpCount {
        add: macs + 3 * m,
        mul: macs + m,
        div: 3 * m,
        compare: 4 * m,
        load: 2 * macs,
        store: square + 2 * m,
        branch: 2 * square + 2 * m,
        ..OpCount::default()
    }
}

/// `v* = -G c` on `G`'s upper triangle: statements, values and their cost.
fn unconstrained(
    g: &mut Graph,
    moves: &MoveNames,
    names: &Names,
    scalar: Scalar,
) -> (Vec<TokenStream>, Vec<TokenStream>, OpCount) {
    let packed: Vec<_> = inverse_names(moves, names)
        .iter()
        .flatten()
        .flatten()
        .map(|name| g.var(&name.to_string()))
        .collect();
    let inverse = symmetric_from_packed(&packed, moves.count());
    let linear: Matrix = moves.linear.iter().map(|c| vec![g.var(c)]).collect();
    let product = matmul(g, &inverse, &linear);
    let minimiser: Vec<_> = product.iter().map(|row| g.neg(row[0])).collect();
    let mut lowerer = Lowerer::new(g, scalar, names.namer(), &minimiser);
    let values = lowerer.segment(&minimiser);
    let statements = scoped(lowerer.take_statements(), &quote! { #(#values)* });
    (statements, values, lowerer.ops())
}

/// The warm start: the bounds the last solve held, a step on (the first step's were
/// applied; the last step starts free).
fn warm_start(moves: &MoveNames) -> TokenStream {
    let nu = moves.input_count().max(1);
    let held = moves.per_move("held");
    let (first, rest) = held.split_at(nu.min(held.len()));
    let unread = first.iter().map(|_| quote! { _ });
    let free = first.iter().map(|_| quote! { 0 });
    quote! {
        // Warm start: the limits the last solve held, a step on.
        let [#(#unread,)* #(#rest),*] = self.held.moves;
        let mut held = stateforge_math::HeldLimits {
            moves: [#(#rest,)* #(#free),*],
            rows: [],
        };
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
