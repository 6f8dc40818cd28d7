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

/// The step's working names: the trailing matrix (packed), `L` below the diagonal, the
/// pivots' reciprocals and the forward substitution's values.
struct Work {
    trailing: Vec<Ident>,
    l: Vec<Vec<Ident>>,
    inv_d: Vec<Ident>,
    forward: Vec<Ident>,
}

impl Work {
    fn new(m: usize, names: &Names) -> Work {
        let takes = |name: &str| names.takes(name);
        let trailing = packed_names("trailing", m, &takes)
            .iter()
            .map(|n| ident(n))
            .collect();
        let l = (0..m)
            .map(|i| {
                (0..i)
                    .map(|k| ident(&names.fresh(&format!("l_{}_{}", i + 1, k + 1))))
                    .collect()
            })
            .collect();
        let inv_d = (1..=m)
            .map(|k| ident(&names.fresh(&format!("inv_d{k}"))))
            .collect();
        let forward = (1..=m)
            .map(|k| ident(&names.fresh(&format!("forward{k}"))))
            .collect();
        Work {
            trailing,
            l,
            inv_d,
            forward,
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
    let substitution = substitution(n, &work, &zero);
    let code = quote! {
        // The Newton step on the free moves: L D L' over the free pivots only.
        #(let #free = !(#lower || #upper);)*
        #start
        #(#pivots)*
        #substitution
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

/// The trailing matrix from `H`, `L` and the reciprocals at zero, and the right side
/// `-grad` on the free moves (zero on the held).
fn start(n: &NewtonNames, work: &Work, zero: &TokenStream) -> TokenStream {
    let m = n.free.len();
    let mut trailing = Vec::new();
    for i in 0..m {
        for j in i..m {
            let (t, h) = (work.at(m, i, j), &n.hessian[packed_index(m, i, j)]);
            // Row 1 is never updated: no pivot comes before it.
            trailing.push(if i == 0 {
                quote! { let #t = #h; }
            } else {
                quote! { let mut #t = #h; }
            });
        }
    }
    let l = work.l.iter().flatten();
    let inv_d = &work.inv_d;
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
        #(let mut #l = #zero;)*
        #(let mut #inv_d = #zero;)*
        #(#rhs)*
    }
}

/// Pivot `k` (from 0), if its move is free: `d_k` checked positive, its column of `L`
/// (zero in held rows), and the rank-one update of the trailing matrix.
fn pivot(n: &NewtonNames, work: &Work, k: usize, scalar: Scalar) -> TokenStream {
    let m = n.free.len();
    let (zero, one) = (literal(0.0, scalar), literal(1.0, scalar));
    let (free, d, inv_d) = (&n.free[k], work.at(m, k, k), &work.inv_d[k]);
    let on_failure = failure(quote! { Status::NonPositiveControlWeight });
    let column = (k + 1..m).map(|i| {
        let (l, f, t) = (&work.l[i][k], &n.free[i], work.at(m, k, i));
        quote! { #l = if #f { #t * #inv_d } else { #zero }; }
    });
    let mut updates = Vec::new();
    for i in k + 1..m {
        for j in i..m {
            let (t, l, u) = (work.at(m, i, j), &work.l[i][k], work.at(m, k, j));
            updates.push(quote! { #t -= #l * #u; });
        }
    }
    quote! {
        if #free {
            if #d > #zero {
                #inv_d = #one / #d;
            } else {
                #on_failure
            }
            #(#column)*
            #(#updates)*
        }
    }
}

/// Forward substitution `L w = rhs` column by column over the free pivots, then back
/// substitution `L' p = D^-1 w`, zero on the held moves.
fn substitution(n: &NewtonNames, work: &Work, zero: &TokenStream) -> TokenStream {
    let m = n.free.len();
    let forward = (0..m.saturating_sub(1)).map(|k| {
        let (f, wk) = (&n.free[k], &work.forward[k]);
        let updates = (k + 1..m).map(|i| {
            let (wi, l) = (&work.forward[i], &work.l[i][k]);
            quote! { #wi -= #l * #wk; }
        });
        quote! {
            if #f {
                #(#updates)*
            }
        }
    });
    let back = (0..m).rev().map(|k| {
        let (s, f, w, inv) = (&n.step[k], &n.free[k], &work.forward[k], &work.inv_d[k]);
        let later = (k + 1..m).map(|i| {
            let (l, si) = (&work.l[i][k], &n.step[i]);
            quote! { - #l * #si }
        });
        quote! {
            let #s = if #f { #w * #inv #(#later)* } else { #zero };
        }
    });
    quote! {
        #(#forward)*
        #(#back)*
    }
}
