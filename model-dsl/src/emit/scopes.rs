//! Groups a long run of generated statements into blocks.
//!
//! Every `let` opens a scope nested in the one before it. rustc's debug information walks
//! those scopes recursively (LLVM's `DwarfCompileUnit::createAndAddScopeChildren`), so a
//! function of some five thousand `let`s (the step of a 100-state EKF) overflows the
//! compiler's stack in a debug build. Grouping the statements into blocks of at most
//! [`BLOCK_LEN`], each handing on the names later code reads,
//! `let [a, b] = { let t = ..; let a = ..; let b = ..; [a, b] };`, keeps the nesting
//! near `BLOCK_LEN + statements / BLOCK_LEN`. Every name handed on is a scalar, so an
//! array carries them (rustc checks a 250-element tuple far more slowly). Short functions
//! are left exactly as they are.

use crate::fast_hash::FastSet;
use proc_macro2::{Delimiter, Group, Ident, TokenStream, TokenTree};
use quote::quote;

/// The most statements one block holds, and the longest run left ungrouped.
pub const BLOCK_LEN: usize = 1024;

/// A statement binding more names than this is never put in a block.
const WIDE_STATEMENT: usize = 16;

/// `statements` as they are when there are at most [`BLOCK_LEN`] of them, else grouped into
/// blocks that hand on every name a later statement or `tail` (the rest of the function
/// body) reads.
pub fn scoped(statements: Vec<TokenStream>, tail: &TokenStream) -> Vec<TokenStream> {
    if statements.len() <= BLOCK_LEN {
        return statements;
    }
    // Each statement taken apart and put together again, its tokens moved (a copy of
    // every statement's identifiers was most of this pass's time on large models).
    let (parts, mut statements): (Vec<Parts>, Vec<TokenStream>) =
        statements.into_iter().map(Parts::of).unzip();
    let mut tail_reads = Vec::new();
    read_names(tail.clone(), &mut tail_reads);
    let mut read_later: FastSet<&str> = tail_reads.iter().map(String::as_str).collect();
    // Walking backwards, a block hands on what it defines that is read after it. A
    // statement binding many names at once (reading a whole covariance) stays outside any
    // block: handing its thousands of names on through an array costs rustc far more
    // than the one scope it opens.
    let mut blocks = Vec::new();
    let mut end = statements.len();
    while end > 0 {
        if parts[end - 1].bound.len() > WIDE_STATEMENT {
            blocks.extend(statements.pop());
            live_before(&parts[end - 1], &mut read_later);
            end -= 1;
            continue;
        }
        let floor = end.saturating_sub(BLOCK_LEN);
        let start = (floor..end)
            .rev()
            .find(|&i| parts[i].bound.len() > WIDE_STATEMENT)
            .map_or(floor, |wide| wide + 1);
        // A name bound twice in the block (a covariance entry read again after the
        // tests) is handed on once, as its last binding.
        let mut seen = FastSet::default();
        let mut exported: Vec<&Ident> = parts[start..end]
            .iter()
            .rev()
            .flat_map(|part| part.bound.iter().zip(&part.bound_text).rev())
            .filter(|(_, text)| read_later.contains(text.as_str()))
            .filter(|(_, text)| seen.insert(text.as_str()))
            .map(|(name, _)| name)
            .collect();
        exported.reverse();
        blocks.push(block(statements.split_off(start), &exported));
        for part in parts[start..end].iter().rev() {
            live_before(part, &mut read_later);
        }
        end = start;
    }
    blocks.reverse();
    blocks
}

/// `{ body }`, or `let one = { body one };`, or `let [a, b] = { body [a, b] };`: the block
/// of `body` handing on the names `exported`. The statements are moved into it, not copied.
fn block(body: Vec<TokenStream>, exported: &[&Ident]) -> TokenStream {
    let mut inner = TokenStream::new();
    inner.extend(body);
    let handed_on = match exported {
        [] => None,
        [one] => Some(quote! { #one }),
        many => Some(quote! { [#(#many),*] }),
    };
    inner.extend(handed_on.clone());
    let group = Group::new(Delimiter::Brace, inner);
    match handed_on {
        None => quote! { #group },
        Some(names) => quote! { let #names = #group; },
    }
}

/// Turns the names read after a statement (`parts`) into those read after the statement
/// before it: a name it binds is, from there back, another binding (a covariance entry
/// read again after the tests hands nothing on from its first read), and the names it
/// reads are read. A name it both reads and binds (`let a = a * 2.0;`) stays read.
fn live_before<'a>(parts: &'a Parts, live: &mut FastSet<&'a str>) {
    for name in &parts.bound_text {
        live.remove(name.as_str());
    }
    live.extend(parts.reads.iter().map(String::as_str));
}

/// A statement's parts: the names it binds with its top-level `let`s (a guarded
/// reciprocal is an `if` and a `let` in one statement), as identifiers and as text, and
/// the names the rest of its tokens read ([`read_names`] of them, taken as they go by).
struct Parts {
    bound: Vec<Ident>,
    bound_text: Vec<String>,
    reads: Vec<String>,
}

impl Parts {
    /// The parts of `statement`, and the statement, its tokens moved through.
    fn of(statement: TokenStream) -> (Parts, TokenStream) {
        let (mut bound, mut reads) = (Vec::new(), Vec::new());
        let mut tokens = Vec::new();
        let mut reader = Reader::default();
        let mut in_pattern = false;
        for token in statement {
            match &token {
                TokenTree::Ident(ident) if !in_pattern && ident == "let" => {
                    in_pattern = true;
                    reader.read(&token, &mut reads);
                }
                TokenTree::Punct(p) if in_pattern && p.as_char() == '=' => in_pattern = false,
                other if in_pattern => pattern_names(other.clone(), &mut bound),
                other => reader.read(other, &mut reads),
            }
            tokens.push(token);
        }
        let bound_text = bound.iter().map(ToString::to_string).collect();
        let parts = Parts {
            bound,
            bound_text,
            reads,
        };
        (parts, tokens.into_iter().collect())
    }
}

/// Identifiers bound by a pattern: every identifier but `_` and `mut`.
fn pattern_names(token: TokenTree, names: &mut Vec<Ident>) {
    match token {
        TokenTree::Ident(ident) if ident != "mut" && ident != "_" => names.push(ident),
        TokenTree::Group(group) => {
            for inner in group.stream() {
                pattern_names(inner, names);
            }
        }
        _ => {}
    }
}

/// Adds the names `tokens` reads: identifiers that are not a field or method after `.`
/// nor a path segment after `::`.
fn read_names(tokens: TokenStream, names: &mut Vec<String>) {
    let mut reader = Reader::default();
    for token in tokens {
        reader.read(&token, names);
    }
}

/// [`read_names`] one token at a time: whether the last tokens were an accessor.
#[derive(Default)]
struct Reader {
    after_accessor: bool,
    previous_colon: bool,
}

impl Reader {
    /// Adds the names `token` reads, the one after the tokens read before it.
    fn read(&mut self, token: &TokenTree, names: &mut Vec<String>) {
        match token {
            TokenTree::Ident(ident) if !self.after_accessor => names.push(ident.to_string()),
            TokenTree::Group(group) => read_names(group.stream(), names),
            _ => {}
        }
        let (dot, colon) = match token {
            TokenTree::Punct(p) => (p.as_char() == '.', p.as_char() == ':'),
            _ => (false, false),
        };
        self.after_accessor = dot || (colon && self.previous_colon);
        self.previous_colon = colon;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashSet;

    fn statements(n: usize) -> Vec<TokenStream> {
        let mut out = vec![quote! { if !(d > 0.0) { return; } let [a0, _, b0, ..] = self.p; }];
        for i in 1..n {
            let (prev, this) = (
                quote::format_ident!("a{}", i - 1),
                quote::format_ident!("a{i}"),
            );
            out.push(quote! { let #this = #prev * b0; });
        }
        out
    }

    #[test]
    fn short_runs_are_left_alone() {
        let before = statements(BLOCK_LEN);
        let after = scoped(before.clone(), &quote! { a0 });
        assert_eq!(
            before.iter().map(ToString::to_string).collect::<Vec<_>>(),
            after.iter().map(ToString::to_string).collect::<Vec<_>>()
        );
    }

    #[test]
    fn blocks_hand_on_exactly_what_later_code_reads() {
        let n = 3 * BLOCK_LEN + 5;
        let last = quote::format_ident!("a{}", n - 1);
        let blocks = scoped(statements(n), &quote! { self.x = [#last]; });
        assert_eq!(blocks.len(), 4);
        let squeeze = |t: &TokenStream| t.to_string().replace(' ', "");
        // Blocks are cut from the end: the first holds statements 0..5. It defines `b0`,
        // read by every later block, and `a0`..`a4`, of which only `a4` is read after it.
        assert!(squeeze(&blocks[0]).starts_with("let[b0,a4]={if!(d>0.0){return;}let[a0"));
        assert!(squeeze(&blocks[0]).ends_with("[b0,a4]};"));
        // The last block hands on only what the tail reads.
        assert!(squeeze(&blocks[3]).starts_with(&format!("let{last}={{")));
        assert!(squeeze(&blocks[3]).ends_with(&format!("{last}}};")));
        // A name read again later (a covariance entry after the tests) is not handed on
        // from its first binding; bound twice in one block, it is handed on once.
        let mut rebinding = statements(n);
        rebinding.push(quote! { let a0 = *a0_slot; });
        let rebound = scoped(rebinding, &quote! { self.x = [#last, a0]; });
        assert!(squeeze(&rebound[0]).starts_with("let[b0,a5]={"));
        assert!(squeeze(&rebound[3]).ends_with(&format!("[{last},a0]}};")));
        let mut twice = vec![quote! { let z = 0.0; }, quote! { let b0 = z; }];
        twice.push(quote! { let b0 = b0 + 1.0; });
        twice.extend((3..=BLOCK_LEN).map(|i| {
            let filler = quote::format_ident!("f{i}");
            quote! { let #filler = 1.0; }
        }));
        let blocks = scoped(twice, &quote! { self.x = [b0]; });
        assert_eq!(blocks.len(), 2);
        assert!(squeeze(&blocks[1]).starts_with("letb0={letb0=z;"));
        // A name after `.` or `::` is not a read.
        let mut reads = Vec::new();
        read_names(quote! { libm::sinf(self.p) + q }, &mut reads);
        assert_eq!(
            reads.into_iter().collect::<HashSet<String>>(),
            HashSet::from(["libm".into(), "self".into(), "q".into()])
        );
    }
}
