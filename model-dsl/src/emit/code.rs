//! Small pieces of generated code that several emitters share.

use super::lower::literal;
use super::names::{clear_of, ident, matrix_entry};
use crate::model::Scalar;
use crate::symbolic::{Graph, Node, NodeId, VarId};
use proc_macro2::TokenStream;
use quote::quote;
use std::collections::BTreeSet;

/// `let [a, _, c] = source;` naming the variables the code reads, or nothing if it reads
/// none of them.
pub fn destructure(
    graph: &Graph,
    source: TokenStream,
    vars: &[NodeId],
    used: &BTreeSet<VarId>,
) -> Option<TokenStream> {
    let is_used = |node: NodeId| matches!(graph.node(node), Node::Var(v) if used.contains(&v));
    if !vars.iter().any(|&v| is_used(v)) {
        return None;
    }
    let pattern = vars.iter().map(|&node| match graph.node(node) {
        Node::Var(v) if used.contains(&v) => {
            let name = ident(&graph.var_info(v).name);
            quote! { #name }
        }
        _ => quote! { _ },
    });
    Some(quote! { let [#(#pattern),*] = #source; })
}

/// The identifiers of some variable nodes.
pub fn var_idents(graph: &Graph, vars: &[NodeId]) -> Vec<proc_macro2::Ident> {
    vars.iter()
        .map(|&node| match graph.node(node) {
            Node::Var(v) => ident(&graph.var_info(v).name),
            other => unreachable!("not a variable: {other:?}"),
        })
        .collect()
}

/// `if !stateforge_math::f32::all_finite([a, b]) { return Status::RejectedInput; }`, or
/// nothing when there is nothing to check: the guard of a method's arguments (a step's
/// inputs and measurements, each sample), tested in floating point (see `all_finite`
/// there: cheaper than `is_finite` on each), with the tests `matrices` (of matrix
/// arguments, `upper_triangle_finite(p0)`).
pub fn reject_non_finite(
    names: &[proc_macro2::Ident],
    matrices: &[TokenStream],
    scalar_type: &proc_macro2::Ident,
) -> TokenStream {
    let Some(finite) = all_finite(names, matrices, scalar_type) else {
        return TokenStream::new();
    };
    quote! {
        if !#finite {
            return Status::RejectedInput;
        }
    }
}

/// The test that `names` and the matrices of the tests `matrices` are all finite
/// (`(all_finite([a, b]) && upper_triangle_finite(p0))`), or `None` when there is nothing
/// to test.
pub fn all_finite(
    names: &[proc_macro2::Ident],
    matrices: &[TokenStream],
    scalar_type: &proc_macro2::Ident,
) -> Option<TokenStream> {
    let tests: Vec<TokenStream> = (!names.is_empty())
        .then(|| all_finite_in_float(names, scalar_type))
        .into_iter()
        .chain(matrices.iter().cloned())
        .collect();
    match tests.as_slice() {
        [] => None,
        [one] => Some(one.clone()),
        _ => Some(quote! { (#(#tests)&&*) }),
    }
}

/// `stateforge_math::f32::all_finite([a, b, ..])` for up to 32 names; past that, the
/// halves' tests joined by `&&`, so that no array on the stack is larger than 32 values
/// (a 100-state covariance's 5050 entries would be 20 KB) and the nesting stays shallow.
fn all_finite_in_float(
    names: &[proc_macro2::Ident],
    scalar_type: &proc_macro2::Ident,
) -> TokenStream {
    const FLAT: usize = 32;
    if names.len() <= FLAT {
        return quote! { stateforge_math::#scalar_type::all_finite([#(#names),*]) };
    }
    let (left, right) = names.split_at(names.len() / 2);
    let left = all_finite_in_float(left, scalar_type);
    let right = all_finite_in_float(right, scalar_type);
    quote! { (#left && #right) }
}

/// `a.is_finite() && b.is_finite() && ..`, grouped in a balanced tree of parenthesised
/// halves past 32 names, so that a 100-state covariance's 5050 entries nest 8 halvings deep,
/// not 5050.
pub fn all_is_finite(names: &[proc_macro2::Ident]) -> TokenStream {
    const FLAT: usize = 32;
    if names.len() <= FLAT {
        return quote! { #(#names.is_finite())&&* };
    }
    let (left, right) = names.split_at(names.len() / 2);
    let (left, right) = (all_is_finite(left), all_is_finite(right));
    quote! { (#left) && (#right) }
}

/// `let inv = if d > 0.0 { 1.0 / d } else { <on_failure> };`: a guarded reciprocal. Only a
/// positive `d` is divided by; NaN fails the comparison and takes `on_failure`, which must
/// return.
pub fn guarded_reciprocal(
    value: &TokenStream,
    reciprocal: &proc_macro2::Ident,
    on_failure: &TokenStream,
    scalar: Scalar,
) -> TokenStream {
    let (zero, one) = (literal(0.0, scalar), literal(1.0, scalar));
    quote! {
        let #reciprocal = if #value > #zero {
            #one / #value
        } else {
            #on_failure
        };
    }
}

/// What a filter does when a pivot of its innovation covariance fails the guard: returns
/// `NonFinite` if it is NaN (an overflow within the step), else `NonPositiveInnovation`.
/// Only the failing branch tests for NaN.
pub fn innovation_pivot_failure(pivot: &TokenStream) -> TokenStream {
    quote! {
        return if #pivot.is_nan() {
            Status::NonFinite
        } else {
            Status::NonPositiveInnovation
        };
    }
}

/// Binds each pivot of an `L D L'` solve under its name ([`pivot_names`] with `prefixes`
/// and `suffix`), checks it is positive (running `on_failure` of the pivot's value if
/// not) and binds its reciprocal, counting the division and comparison.
pub fn guard_pivots(
    lowerer: &mut super::lower::Lowerer,
    pivots: &[NodeId],
    reciprocals: &[NodeId],
    (prefixes, suffix): ((&str, &str), &str),
    on_failure: &dyn Fn(&TokenStream) -> TokenStream,
    scalar: Scalar,
) {
    let m = pivots.len();
    for (j, (&pivot, &reciprocal)) in pivots.iter().zip(reciprocals).enumerate() {
        let name = pivot_names(m, j, prefixes, suffix).0;
        let value = lowerer.bind(pivot, &name);
        lowerer.hold_in_registers(&[reciprocal]);
        let reciprocal = var_idents(lowerer.graph(), &[reciprocal]).remove(0);
        let failure = on_failure(&value);
        lowerer.statement(guarded_reciprocal(&value, &reciprocal, &failure, scalar));
        lowerer.count_extra(super::lower::OpCount {
            div: 1,
            compare: 1,
            ..Default::default()
        });
    }
}

/// Fresh variable names for a packed symmetric matrix: `p11 p12 .. pnn`, or `p_1_10` when
/// an index has two digits ([`matrix_entry`]), skipping names in `taken`.
pub fn packed_names(prefix: &str, n: usize, taken: &dyn Fn(&str) -> bool) -> Vec<String> {
    (1..=n)
        .flat_map(|i| (i..=n).map(move |j| (i, j)))
        .map(|entry| clear_of(&matrix_entry(prefix, (n, n), entry), taken))
        .collect()
}

/// `stateforge_math::f32::pack_upper(name)`: the packed upper triangle of the symmetric
/// matrix argument `name` (its lower triangle is not read), by a library loop.
pub fn pack_upper(name: &str, ty: &proc_macro2::Ident) -> TokenStream {
    let arg = ident(name);
    quote! { stateforge_math::#ty::pack_upper(#arg) }
}

/// `[[a, b], [_, c]]`: the pattern that binds the upper triangle of the `size x size`
/// symmetric matrix `name` to `<name>_<i>_<j>` and skips the lower, and the names it binds,
/// packed (row by row).
pub fn upper_triangle(name: &str, size: usize) -> (TokenStream, Vec<proc_macro2::Ident>) {
    let names: Vec<Vec<proc_macro2::Ident>> = (0..size)
        .map(|i| {
            (0..size)
                .map(|j| ident(&format!("{name}_{i}_{j}")))
                .collect()
        })
        .collect();
    let rows = names.iter().enumerate().map(|(i, row)| {
        let entries = row.iter().enumerate().map(|(j, e)| {
            if j >= i {
                quote! { #e }
            } else {
                quote! { _ }
            }
        });
        quote! { [#(#entries),*] }
    });
    let packed = (0..size).flat_map(|i| (i..size).map(move |j| (i, j)));
    let packed = packed.map(|(i, j)| names[i][j].clone()).collect();
    (quote! { [#(#rows),*] }, packed)
}

/// `state()` and `covariance()` of a filter whose fields `x` (`n` entries) and `p` (packed)
/// hold its estimate.
pub fn estimate_accessors((n, n_p): (usize, usize), ty: &proc_macro2::Ident) -> TokenStream {
    let n_len = proc_macro2::Literal::usize_unsuffixed(n);
    let p_len = proc_macro2::Literal::usize_unsuffixed(n_p);
    let unpack_p = unpack_symmetric("p", ty);
    let covariance_doc = if n == n_p {
        " The estimate's covariance."
    } else {
        " The estimate's covariance, over the tangent space (`TANGENT_NAMES`): a rotation's \
         uncertainty as that of its rotation vector, an error `δθ` in the earth frame \
         (the true rotation is `Exp(δθ) ⊗ q`)."
    };
    quote! {
        /// The state estimate: physical states, then parameters.
        #[must_use]
        pub fn state(&self) -> [#ty; #n_len] {
            self.x
        }

        #[doc = #covariance_doc]
        #[must_use]
        pub fn covariance(&self) -> [[#ty; #p_len]; #p_len] {
            #unpack_p
        }
    }
}

/// The full symmetric matrix of the packed field `self.<field>` (`stateforge_math`'s
/// `unpack_symmetric`, a loop).
pub fn unpack_symmetric(field: &str, ty: &proc_macro2::Ident) -> TokenStream {
    let field = ident(field);
    quote! { stateforge_math::#ty::unpack_symmetric(&self.#field) }
}

/// The test a filter step's result passes before it is stored (the divergence bound):
/// its probe, the sum of the new estimate's entries and variances (see
/// `finiteness_probe`), within `stateforge_math`'s `DIVERGENCE_BOUND` (1e18), and each new
/// variance in `variances` non-negative. A failure returns `NonFinite` when the probe is not
/// finite, else `Diverged`: only the failing branch tells them apart. One test and branch
/// each: joined by `&&`, the tests are combined into flags before one branch, which costs
/// more on the target.
pub fn reject_diverged(
    probe: &TokenStream,
    variances: &[TokenStream],
    scalar: Scalar,
) -> TokenStream {
    let tests = divergence_tests(probe, variances, scalar);
    quote! { #(#tests)* }
}

/// [`reject_diverged`]'s tests, one statement each (the probe's first).
pub fn divergence_tests(
    probe: &TokenStream,
    variances: &[TokenStream],
    scalar: Scalar,
) -> Vec<TokenStream> {
    let ty = ident(scalar.type_name());
    let zero = literal(0.0, scalar);
    // A variance that lowered to a non-negative literal needs no test.
    let literal_non_negative = |v: &TokenStream| {
        let text = v.to_string();
        let number = text.trim_end_matches("_f32").trim_end_matches("_f64");
        number.parse::<f64>().is_ok_and(|v| v >= 0.0)
    };
    let variance_tests = variances
        .iter()
        .filter(|v| !literal_non_negative(v))
        .map(|v| {
            quote! {
                if #v < #zero {
                    return Status::Diverged;
                }
            }
        });
    // The probe is bound to a name; anything else (a literal) is parenthesised.
    let receiver = match syn::parse2::<syn::Ident>(probe.clone()) {
        Ok(name) => quote! { #name },
        Err(_) => quote! { (#probe) },
    };
    let probe_test = quote! {
        if !stateforge_math::#ty::within_divergence_bound(#probe) {
            return if #receiver.is_finite() {
                Status::Diverged
            } else {
                Status::NonFinite
            };
        }
    };
    std::iter::once(probe_test).chain(variance_tests).collect()
}

/// What [`reject_diverged`] costs a step of `n` states: a comparison and branch for the
/// probe and for each variance.
pub fn divergence_test_ops(n: usize) -> crate::emit::lower::OpCount {
    let n = u32::try_from(n).unwrap_or(u32::MAX);
    crate::emit::lower::OpCount {
        compare: n.saturating_add(1),
        ..Default::default()
    }
}

/// The end of a filter step: unless the result passes [`reject_diverged`] the filter is
/// left as it was, else the new estimate and packed covariance are stored, and `also` (more
/// assignments) with them.
pub fn commit_or_non_finite_with(
    probe: &TokenStream,
    x_values: &[TokenStream],
    p_values: &[TokenStream],
    also: &TokenStream,
    scalar: Scalar,
) -> TokenStream {
    let check = reject_diverged(probe, &packed_diagonal(p_values, x_values.len()), scalar);
    quote! {
        #check
        self.x = [#(#x_values),*];
        self.p = [#(#p_values),*];
        #also
        Status::Ok
    }
}

/// The diagonal of a packed (upper triangle, row by row) `n x n` matrix.
pub fn packed_diagonal(packed: &[TokenStream], n: usize) -> Vec<TokenStream> {
    (0..n)
        .map(|i| packed[crate::symbolic::linalg::packed_index(n, i, i)].clone())
        .collect()
}

/// Names in generated code for pivot `j` of a guarded `L D L'` solve of size `m` and for
/// its reciprocal: `(scalar, scalar_reciprocal)` when `m == 1` (`innovation_variance`,
/// `inv_s`), else `d1`, `inv_d1`, ...; `suffix` is appended (`_bar` for the AKF).
pub fn pivot_names(
    m: usize,
    j: usize,
    (scalar, scalar_reciprocal): (&str, &str),
    suffix: &str,
) -> (String, String) {
    if m == 1 {
        (
            format!("{scalar}{suffix}"),
            format!("{scalar_reciprocal}{suffix}"),
        )
    } else {
        (
            format!("d{}{suffix}", j + 1),
            format!("inv_d{}{suffix}", j + 1),
        )
    }
}

/// The pivot names of an innovation covariance (`innovation_variance` / `inv_s`).
pub const INNOVATION: (&str, &str) = ("innovation_variance", "inv_s");

/// `text` as `#[doc]` attributes of at most 80 characters each, broken between words, so
/// that a documentation sentence built at generation time reads like written `///` lines.
pub fn doc_attributes(text: &str) -> TokenStream {
    let mut lines: Vec<String> = Vec::new();
    let mut line = String::new();
    for word in text.split_whitespace() {
        if !line.is_empty() && line.len() + 1 + word.len() > 80 {
            lines.push(std::mem::take(&mut line));
        }
        line.push(' ');
        line.push_str(word);
    }
    if !line.is_empty() {
        lines.push(line);
    }
    quote! { #(#[doc = #lines])* }
}
