// The `model!` macro. All the work happens in `stateforge-compiler`; this crate only adapts
// the compiler's types to `proc_macro`'s. The crate's documentation is the guide, in
// `doc/` (a proc-macro crate exports nothing but its macros, so no documentation-only
// modules): using the crates, the generators, model files and the tool, the C API, the
// limits. The language reference is the macro's own documentation, `doc/model.md`.

#![doc = include_str!("../doc/guide.md")]
#![doc = include_str!("../doc/model-files.md")]
#![doc = include_str!("../doc/c-api.md")]
#![doc = include_str!("../doc/robustness.md")]
#![forbid(unsafe_code)]

use proc_macro::TokenStream;

#[doc = include_str!("../doc/model.md")]
#[proc_macro]
pub fn model(input: TokenStream) -> TokenStream {
    let input = proc_macro2::TokenStream::from(input);
    // One token of the invocation, on one line: where the generated code is said to be.
    let anchor = input
        .clone()
        .into_iter()
        .next()
        .map_or_else(proc_macro2::Span::call_site, |t| t.span());
    let options = stateforge_compiler::pipeline::Options {
        // The `nalgebra` feature adds each model's `interop` module.
        nalgebra: cfg!(feature = "nalgebra"),
    };
    match stateforge_compiler::expand_with_warnings(input, &options) {
        Ok((generated, warnings)) => {
            let mut tokens = respan(generated, anchor);
            // Not respanned: each warning stays under the user's token.
            tokens.extend(warnings.iter().map(|w| w.to_tokens()));
            tokens.into()
        }
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
