//! Lays out generated code with `prettyplease` one item at a time, so that the syntax
//! tree of only one item is held at once: a 300-state EKF's module is some 30 MB of
//! code, whose whole tree took a gigabyte.
//!
//! The text is the same as `prettyplease::unparse` of the whole file. Its printer breaks
//! the line after every item of a module and of an `impl` block, and an item begins at
//! the start of a line, so how an item is laid out depends only on how deeply it is
//! indented, not on the items around it. Each item is printed alone inside stand-in
//! containers as deep as its real ones (`mod m {` and `impl M {`, one line each), and
//! its lines are taken from between theirs. A module or an `impl` block is printed with a
//! stand-in item (`fn z() {}`) in place of its items: the lines before the stand-in's are
//! its opening, those after are its close.

use proc_macro2::{Delimiter, Group, TokenStream, TokenTree};
use quote::quote;

/// What an item's place is inside of: each holds items printed one level deeper.
#[derive(Clone, Copy)]
enum Container {
    /// A module, `mod name { .. }`.
    Module,
    /// An `impl` block, whose items are associated items.
    Impl,
}

/// The one-line stand-in for the `items` of an item's body, as laid out at depth
/// `depth`: `fn z() {}`, indented.
fn stand_in_line(depth: usize) -> String {
    format!("\n{}fn z() {{}}\n", "    ".repeat(depth))
}

/// `tokens`, a sequence of items, laid out as `prettyplease::unparse` lays out the file
/// they make.
pub fn format(tokens: TokenStream) -> syn::Result<String> {
    let mut out = String::new();
    items(tokens, &mut Vec::new(), &mut out)?;
    Ok(out)
}

/// Lays out the items `tokens` at the place `within` (their containers, outermost first)
/// onto `out`, each alone.
fn items(tokens: TokenStream, within: &mut Vec<Container>, out: &mut String) -> syn::Result<()> {
    for item in split_items(tokens) {
        match container_of(&item) {
            Some(kind) => container(item, kind, within, out)?,
            None => out.push_str(&alone(item.into_iter().collect(), within)?),
        }
    }
    Ok(())
}

/// `tokens` cut into items: each ends at a `;` or at a body in braces not followed by
/// more of the item (`use a::{b, c};`, `S { .. }.f()`, `if a { .. } else { .. }`). Each
/// piece is then parsed as one whole item, so a cut in the wrong place would be an error,
/// not a wrong layout.
fn split_items(tokens: TokenStream) -> Vec<Vec<TokenTree>> {
    let mut items = Vec::new();
    let mut item = Vec::new();
    let mut tokens = tokens.into_iter().peekable();
    while let Some(token) = tokens.next() {
        let ends = match &token {
            TokenTree::Punct(p) => p.as_char() == ';',
            TokenTree::Group(g) => g.delimiter() == Delimiter::Brace && !continues(tokens.peek()),
            _ => false,
        };
        item.push(token);
        if ends {
            items.push(std::mem::take(&mut item));
        }
    }
    if !item.is_empty() {
        items.push(item);
    }
    items
}

/// Whether `next`, the token after a body in braces, continues its item: an operator,
/// `.`, `;` or `?` (an attribute's `#` begins the next item), `else` or `as`.
fn continues(next: Option<&TokenTree>) -> bool {
    match next {
        Some(TokenTree::Punct(p)) => p.as_char() != '#',
        Some(TokenTree::Ident(word)) => word == "else" || word == "as",
        _ => false,
    }
}

/// Whether `item` is a module or an `impl` block with a body in braces: its first word
/// past its attributes and visibility (`pub`, `unsafe`) is `mod` or `impl`.
fn container_of(item: &[TokenTree]) -> Option<Container> {
    if !matches!(item.last(), Some(TokenTree::Group(g)) if g.delimiter() == Delimiter::Brace) {
        return None;
    }
    let word = item.iter().find_map(|token| match token {
        TokenTree::Ident(word) if word != "pub" && word != "unsafe" => Some(word.to_string()),
        _ => None,
    })?;
    match word.as_str() {
        "mod" => Some(Container::Module),
        "impl" => Some(Container::Impl),
        _ => None,
    }
}

/// Lays out a module or `impl` block `item` (of kind `kind`) onto `out`: its opening and
/// close around its items, each laid out alone. One without items is laid out whole
/// (`mod m {}` stays on one line).
fn container(
    mut item: Vec<TokenTree>,
    kind: Container,
    within: &mut Vec<Container>,
    out: &mut String,
) -> syn::Result<()> {
    let Some(TokenTree::Group(body)) = item.pop() else {
        unreachable!("a container ends with its body (container_of)");
    };
    let span = body.span();
    let stream = body.stream();
    drop(body); // The body's tokens are then moved out, not copied.
    let (inner_attributes, body_items) = inner_attributes(stream);
    if body_items.is_empty() {
        let mut body = Group::new(Delimiter::Brace, inner_attributes.into_iter().collect());
        body.set_span(span);
        item.push(TokenTree::Group(body));
        out.push_str(&alone(item.into_iter().collect(), within)?);
        return Ok(());
    }
    let mut stand_in: TokenStream = inner_attributes.into_iter().collect();
    stand_in.extend(quote! { fn z() {} });
    item.push(TokenTree::Group(Group::new(Delimiter::Brace, stand_in)));
    let text = alone(item.into_iter().collect(), within)?;
    let line = stand_in_line(within.len() + 1);
    let Some(at) = text.find(&line) else {
        unreachable!("prettyplease prints the stand-in item on a line of its own");
    };
    out.push_str(&text[..=at]);
    within.push(kind);
    let laid_out = items(body_items, within, out);
    within.pop();
    laid_out?;
    out.push_str(&text[at + line.len()..]);
    Ok(())
}

/// A body's inner attributes (`#![allow(..)]`, kept with its opening) and its items.
fn inner_attributes(body: TokenStream) -> (Vec<TokenTree>, TokenStream) {
    let mut tokens: Vec<TokenTree> = body.into_iter().collect();
    let mut end = 0;
    while let [TokenTree::Punct(hash), TokenTree::Punct(bang), TokenTree::Group(_), ..] =
        &tokens[end..]
    {
        if hash.as_char() != '#' || bang.as_char() != '!' {
            break;
        }
        end += 3;
    }
    let rest = tokens.split_off(end);
    (tokens, rest.into_iter().collect())
}

/// The item `item` laid out alone at the place `within`: printed inside one-line
/// stand-ins of its containers, whose lines are then cut off.
fn alone(item: TokenStream, within: &[Container]) -> syn::Result<String> {
    let mut tokens = item;
    for kind in within.iter().rev() {
        let body = Group::new(Delimiter::Brace, tokens);
        tokens = match kind {
            Container::Module => quote! { mod m #body },
            Container::Impl => quote! { impl M #body },
        };
    }
    let file: syn::File = syn::parse2(tokens)?;
    let text = prettyplease::unparse(&file);
    drop(file);
    let depth = within.len();
    if depth == 0 {
        return Ok(text);
    }
    // After the first `depth` lines, before the last `depth` (each ends with a newline).
    let start = text
        .match_indices('\n')
        .nth(depth - 1)
        .map_or(0, |(i, _)| i + 1);
    let end = text[..text.len() - 1]
        .rmatch_indices('\n')
        .nth(depth - 1)
        .map_or(0, |(i, _)| i + 1);
    Ok(text[start..end].to_owned())
}

#[cfg(test)]
mod tests {
    use super::format;
    use proc_macro2::TokenStream;
    use quote::quote;

    /// `prettyplease::unparse` of the whole file, what [`format`] must give.
    fn whole(tokens: TokenStream) -> String {
        prettyplease::unparse(&syn::parse2(tokens).expect("a file"))
    }

    #[test]
    fn items_laid_out_alone_read_as_the_whole_file() {
        let tokens = quote! {
            #![allow(dead_code)]
            //! A crate.
            use core::{fmt, ops::Add};
            /// A module with inner attributes, nested modules and `impl` blocks.
            pub(crate) mod outer {
                #![allow(clippy::all)]
                pub struct S { pub a: f32 }
                const ORIGIN: S = S { a: 0.0 };
                const LEN: usize = { 3 };
                const SIGN: f32 = if LEN > 2 { 1.0 } else { -1.0 };
                const CLOSURE: fn() -> usize = || { LEN } + 1;
                const CAST: u8 = { 3 } as u8;
                mod empty {}
                mod attributes_only { #![allow(unused)] }
                impl S {
                    /// A long signature, broken over lines at any depth of nesting.
                    pub fn step(&mut self, first_argument: &[f64; 5], second_argument: &[f64; 5]) -> f64 {
                        let t = { let a = self.a * first_argument[0]; a + second_argument[1] };
                        if t > 0.0 { t } else { -t }
                    }
                }
                impl core::fmt::Debug for S where S: Sized {
                    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result { Ok(()) }
                }
                impl Empty for S {}
                pub mod in_f64 { pub use super::S; pub fn f() -> usize { super::LEN } }
            }
            mod last;
        };
        assert_eq!(format(tokens.clone()).expect("lays out"), whole(tokens));
    }

    #[test]
    fn a_generated_module_laid_out_alone_reads_as_the_whole_file() {
        let source = "model! { pub mod chain { scalar f32, f64; const TS = 0.01; \
            state x1, x2, x3; input u; output y = x1; dynamics discrete { \
            x1 = x1 + TS * x2; x2 = x2 + TS * x3; x3 = x3 + TS * u; } generate ekf; } }";
        let tokens = stateforge_compiler::expand_macro_source(source).expect("expands");
        assert_eq!(format(tokens.clone()).expect("lays out"), whole(tokens));
    }
}
