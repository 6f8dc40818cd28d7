//! The active-set iteration's Newton step on the free moves, `H_FF p_F = -grad_F` with
//! `p = 0` on the held moves, by an `L D L'` factorisation that visits the free moves only.
//!
//! The factorisation is right-looking (outer-product form, Golub and Van Loan, "Matrix
//! Computations", sect. 4.2): pivot `k` takes `d_k` from the trailing matrix, forms the
//! column `l_ik = F_ki / d_k` and subtracts `l_ik F_kj` from the trailing entries. A held
//! move's pivot is skipped whole, and its row of `L` stays zero, which is the factorisation
//! of `H` with the held rows and columns replaced by the identity's. A solve that holds most
//! moves (a saturated plan) so pays for its few free ones only, instead of a dense
//! factorisation of the whole masked matrix each iteration.

use super::names::{failure, Names};
use crate::emit::code::packed_names;
use crate::emit::lower::{literal, OpCount};
use crate::emit::names::ident;
use crate::model::Scalar;
use crate::symbolic::linalg::packed_index;
use proc_macro2::{Ident, TokenStream};
use quote::quote;

/// The names of the step's values, per move `1..=m` (index `k - 1`).
pub struct NewtonNames {
    /// Whether each move is free (neither bound held).
    pub free: Vec<Ident>,
    /// The gradient's entries, which the step reads.
    pub grad: Vec<Ident>,
    /// The step's entries, which it binds.
    pub step: Vec<Ident>,
    /// The held flags, lower and upper.
    pub lower: Vec<Ident>,
    pub upper: Vec<Ident>,
    /// `H`'s packed entries.
    pub hessian: Vec<Ident>,
}

/// The step's working names: the trailing matrix (packed; row `k` of it holds column `k`
/// of `L`, and its diagonal `1 / d_k`, once pivot `k` is done), the column being formed,
/// and the forward substitution's values.
struct Work {
    trailing: Vec<Ident>,
    column: Vec<Ident>,
    forward: Vec<Ident>,
}

impl Work {
    fn new(m: usize, names: &Names) -> Work {
        let takes = |name: &str| names.takes(name);
        let trailing = packed_names("trailing", m, &takes)
            .iter()
            .map(|n| ident(n))
            .collect();
        let fresh = |prefix: &str| -> Vec<Ident> {
            (1..=m)
                .map(|k| ident(&names.fresh(&format!("{prefix}{k}"))))
                .collect()
        };
        Work {
            trailing,
            column: fresh("column"),
            forward: fresh("forward"),
        }
    }

    /// The trailing entry `(i, j)`, either order.
    fn at(&self, m: usize, i: usize, j: usize) -> &Ident {
        &self.trailing[packed_index(m, i.min(j), i.max(j))]
    }
}

/// The step's code, binding `step_<move>`, and its arithmetic with every move free.
pub fn newton_step(n: &NewtonNames, names: &Names, scalar: Scalar) -> (TokenStream, OpCount) {
    let m = n.free.len();
    let work = Work::new(m, names);
    let zero = literal(0.0, scalar);
    let (free, lower, upper) = (&n.free, &n.lower, &n.upper);
    let start = start(n, &work, &zero);
    let pivots: Vec<TokenStream> = (0..m).map(|k| pivot(n, &work, k, scalar)).collect();
    let back = back_substitution(n, &work, &zero);
    let code = quote! {
        // The Newton step on the free moves: L D L' over the free pivots only, with the
        // forward substitution L w = -grad alongside.
        #(let #free = !(#lower || #upper);)*
        #start
        #(#pivots)*
        #back
    };
    let (m32, pairs) = (m as u32, (m * (m - 1) / 2) as u32);
    let trailing_updates = ((m * m * m - m) / 6) as u32;
    let ops = OpCount {
        // rank-one updates, forward and back substitution, the right side's negation
        add: trailing_updates + 2 * pairs + m32,
        mul: trailing_updates + pairs + 2 * pairs + m32,
        div: m32,
        compare: 2 * m32 + pairs,
        ..Default::default()
    };
    (code, ops)
}

/// The trailing matrix from `H`, and the right side `-grad` on the free moves (zero on
/// the held).
fn start(n: &NewtonNames, work: &Work, zero: &TokenStream) -> TokenStream {
    let m = n.free.len();
    let mut trailing = Vec::new();
    for i in 0..m {
        for j in i..m {
            let (t, h) = (work.at(m, i, j), &n.hessian[packed_index(m, i, j)]);
            trailing.push(quote! { let mut #t = #h; });
        }
    }
    let rhs = (0..m).map(|k| {
        let (w, f, g) = (&work.forward[k], &n.free[k], &n.grad[k]);
        // The first is never updated: no pivot comes before it.
        let binding = if k == 0 {
            quote! { let #w }
        } else {
            quote! { let mut #w }
        };
        quote! { #binding = if #f { -#g } else { #zero }; }
    });
    quote! {
        #(#trailing)*
        #(#rhs)*
    }
}

/// Pivot `k` (from 0), if its move is free: `d_k` checked positive and replaced by its
/// reciprocal, its column of `L` (zero in held rows), the rank-one update of the trailing
/// matrix and of the forward substitution, and the column stored in row `k`.
fn pivot(n: &NewtonNames, work: &Work, k: usize, scalar: Scalar) -> TokenStream {
    let m = n.free.len();
    let (zero, one) = (literal(0.0, scalar), literal(1.0, scalar));
    let (free, d) = (&n.free[k], work.at(m, k, k));
    let on_failure = failure(quote! { Status::NonPositiveControlWeight });
    let column = (k + 1..m).map(|i| {
        let (l, f, t) = (&work.column[i], &n.free[i], work.at(m, k, i));
        quote! { let #l = if #f { #t * #d } else { #zero }; }
    });
    let mut updates = Vec::new();
    for i in k + 1..m {
        for j in i..m {
            let (t, l, u) = (work.at(m, i, j), &work.column[i], work.at(m, k, j));
            updates.push(quote! { #t -= #l * #u; });
        }
    }
    let wk = &work.forward[k];
    let forward = (k + 1..m).map(|i| {
        let (wi, l) = (&work.forward[i], &work.column[i]);
        quote! { #wi -= #l * #wk; }
    });
    let store = (k + 1..m).map(|i| {
        let (t, l) = (work.at(m, k, i), &work.column[i]);
        quote! { #t = #l; }
    });
    quote! {
        if #free {
            if #d > #zero {
                #d = #one / #d;
            } else {
                #on_failure
            }
            #(#column)*
            #(#updates)*
            #(#forward)*
            #(#store)*
        }
    }
}

/// Back substitution `L' p = D^-1 w`, zero on the held moves.
fn back_substitution(n: &NewtonNames, work: &Work, zero: &TokenStream) -> TokenStream {
    let m = n.free.len();
    let back = (0..m).rev().map(|k| {
        let (s, f, w, inv) = (&n.step[k], &n.free[k], &work.forward[k], work.at(m, k, k));
        let later = (k + 1..m).map(|i| {
            let (l, si) = (work.at(m, k, i), &n.step[i]);
            quote! { - #l * #si }
        });
        quote! {
            let #s = if #f { #w * #inv #(#later)* } else { #zero };
        }
    });
    quote! {
        #(#back)*
    }
}
