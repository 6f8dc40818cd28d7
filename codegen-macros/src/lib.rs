//! The `model!` macro. All the work happens in `model-dsl`; this crate only adapts the
//! compiler's types to `proc_macro`'s.

#![forbid(unsafe_code)]

use proc_macro::TokenStream;

/// Declares a model and generates, in a module of its name, the discrete step `f`, the
/// measurement `h`, their Jacobians (unrolled, structural zeros never computed), the
/// Jacobians' zero patterns, the model's dimensions and names, and an operation count per
/// function. Generated code is `no_std`, allocation-free and panic-free; it calls `libm`
/// for transcendental functions, so the calling crate depends on `libm`.
///
/// ```
/// codegen_macros::model! {
///     /// Cantilever beam, first mode.
///     pub mod cantilever {
///         scalar f32;
///         const TS = 0.015;
///         state x1, x2;
///         param x3, x4, x5;
///         input u;
///         output y = x1;
///         dynamics discrete {
///             x1 = x1 + TS * x2;
///             x2 = TS * x1 * x3 + (1.0 + TS * x4) * x2 + TS * x5 * u;
///         }
///     }
/// }
///
/// let x = [1.0, 0.0, -400.0, -1.0, 0.5];
/// assert_eq!(cantilever::f(&x, &[2.0]), [1.0, -6.0 + 0.015, -400.0, -1.0, 0.5]);
/// assert_eq!(cantilever::JACOBIAN_F_WRT_X_NONZERO[0], [true, true, false, false, false]);
/// assert_eq!(cantilever::F_OPS.mul, 7);
/// ```
#[proc_macro]
pub fn model(input: TokenStream) -> TokenStream {
    let input = proc_macro2::TokenStream::from(input);
    // One token of the invocation, on one line: where the generated code is said to be.
    let anchor = input
        .clone()
        .into_iter()
        .next()
        .map_or_else(proc_macro2::Span::call_site, |t| t.span());
    match model_dsl::expand(input) {
        Ok(generated) => respan(generated, anchor).into(),
        Err(errors) => errors.to_compile_error().into(),
    }
}

/// Places every generated token at `anchor` with mixed-site hygiene. The default call-site
/// span covers the whole multi-line invocation, and lints that compare the lines of an
/// operator and its operands (`clippy::possible_missing_comma`) misfire on it. Item names
/// still resolve at the call site. Errors keep the user's own spans: they are not respanned.
fn respan(tokens: proc_macro2::TokenStream, anchor: proc_macro2::Span) -> proc_macro2::TokenStream {
    use proc_macro2::{Group, Span, TokenTree};
    let span = Span::mixed_site().located_at(anchor);
    tokens
        .into_iter()
        .map(|mut tree| {
            if let TokenTree::Group(group) = &tree {
                let mut respanned = Group::new(group.delimiter(), respan(group.stream(), anchor));
                respanned.set_span(span);
                tree = TokenTree::Group(respanned);
            } else {
                tree.set_span(span);
            }
            tree
        })
        .collect()
}
