//! Limits on the size of what a front end reads, checked before anything recursive sees it.
//!
//! Parsers, `syn`'s and ours, and the passes after them recurse through an expression:
//! 1,000 nested parentheses or 10,000 chained operators overflow a compiler thread's stack
//! and crash rustc, where the user should get an error under the offending token. No model
//! comes near these limits; one that does is told to name a part of its expression with
//! `let`.

use proc_macro2::{Delimiter, Span, TokenStream, TokenTree};

/// The deepest nesting of brackets, and the longest run of prefix operators (`- - x`).
pub const MAX_NESTING: usize = 64;

/// The most operators (and `.` of method calls) one statement may hold.
pub const MAX_OPERATORS: usize = 512;

/// The most plain `=` one statement may hold: a valid statement has one (or one per
/// option of a `generate` item, between commas), but `syn` parses `a = b = c` by
/// recursion, and a chain of hundreds overflows a thread's stack.
pub const MAX_ASSIGNMENTS: usize = 64;

/// The longest expression text a model file may hold, in bytes.
pub const MAX_EXPRESSION_TEXT: usize = 16_384;

/// Checks the whole body of a `model!` invocation, without recursion: bracket nesting,
/// runs of prefix operators, and operators per statement (counted up to a `;`).
pub fn check_tokens(tokens: &TokenStream) -> syn::Result<()> {
    let mut stack = vec![tokens.clone().into_iter()];
    let mut operators = 0usize;
    let mut assignments = 0usize;
    let mut prefix_run = 0usize;
    let mut after_operand = false;
    // Whether the previous token was a punctuation joined to the next (`<` of `<=`).
    let mut joined = false;
    while let Some(level) = stack.last_mut() {
        let Some(token) = level.next() else {
            stack.pop();
            after_operand = true;
            continue;
        };
        let follows_joined = std::mem::replace(
            &mut joined,
            matches!(&token, TokenTree::Punct(p) if p.spacing() == proc_macro2::Spacing::Joint),
        );
        match token {
            TokenTree::Group(group) => {
                if stack.len() > MAX_NESTING {
                    return Err(too_deep(group.span_open()));
                }
                if group.delimiter() != Delimiter::None {
                    after_operand = false;
                }
                prefix_run = 0;
                stack.push(group.stream().into_iter());
            }
            TokenTree::Punct(punct) => match punct.as_char() {
                ';' => {
                    operators = 0;
                    assignments = 0;
                    prefix_run = 0;
                    after_operand = false;
                }
                '=' if !follows_joined && punct.spacing() == proc_macro2::Spacing::Alone => {
                    assignments += 1;
                    if assignments > MAX_ASSIGNMENTS {
                        return Err(syn::Error::new(
                            punct.span(),
                            "a statement holds one `=`: end the one before with `;`",
                        ));
                    }
                    operators += 1;
                    after_operand = false;
                }
                ',' => {
                    prefix_run = 0;
                    after_operand = false;
                }
                c => {
                    operators += 1;
                    if operators > MAX_OPERATORS {
                        return Err(too_long(punct.span()));
                    }
                    if !after_operand && matches!(c, '-' | '!' | '*' | '&') {
                        prefix_run += 1;
                        if prefix_run > MAX_NESTING {
                            return Err(too_deep(punct.span()));
                        }
                    } else {
                        prefix_run = 0;
                    }
                    after_operand = false;
                }
            },
            TokenTree::Ident(_) | TokenTree::Literal(_) => {
                prefix_run = 0;
                after_operand = true;
            }
        }
    }
    Ok(())
}

/// Checks the text of a model-file expression before `meval` reads it: not empty, of the
/// characters the language uses, and within the limits above.
pub fn check_expression_text(text: &str) -> Result<(), String> {
    if text.trim().is_empty() {
        return Err("the expression is empty: write a value such as `0.0` or `x1`".into());
    }
    if text.len() > MAX_EXPRESSION_TEXT {
        return Err(format!(
            "the expression is {} bytes long, over the limit of {MAX_EXPRESSION_TEXT}: name \
             parts of it in `[[dynamics.let]]`",
            text.len()
        ));
    }
    if let Some(c) = text.chars().find(|c| !allowed_in_expression(*c)) {
        return Err(format!(
            "`{c}` has no meaning in an expression: use numbers, names, `+ - * / ^`, \
             parentheses and function calls"
        ));
    }
    let (mut depth, mut operators) = (0usize, 0usize);
    for c in text.chars() {
        match c {
            '(' => {
                depth += 1;
                if depth > MAX_NESTING {
                    return Err(format!(
                        "parentheses nest deeper than {MAX_NESTING}: name the inner part in \
                         `[[dynamics.let]]`"
                    ));
                }
            }
            ')' => depth = depth.saturating_sub(1),
            '+' | '-' | '*' | '/' | '^' => {
                operators += 1;
                if operators > MAX_OPERATORS {
                    return Err(format!(
                        "more than {MAX_OPERATORS} operators in one expression: name parts of \
                         it in `[[dynamics.let]]`"
                    ));
                }
            }
            _ => {}
        }
    }
    Ok(())
}

fn allowed_in_expression(c: char) -> bool {
    c.is_ascii_alphanumeric() || " \t\r\n_.+-*/^(),".contains(c)
}

fn too_deep(span: Span) -> syn::Error {
    syn::Error::new(
        span,
        format!(
            "this nests deeper than {MAX_NESTING} levels: name the inner part with `let` in \
             `dynamics`, or simplify it"
        ),
    )
}

fn too_long(span: Span) -> syn::Error {
    syn::Error::new(
        span,
        format!(
            "more than {MAX_OPERATORS} operators in one statement: name parts of the \
             expression with `let` in `dynamics`"
        ),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::str::FromStr;

    fn check(source: &str) -> Result<(), String> {
        check_tokens(&TokenStream::from_str(source).unwrap()).map_err(|e| e.to_string())
    }

    #[test]
    fn ordinary_models_pass() {
        check("pub mod m { state x; dynamics discrete { x = -(x * -2.0) - -x.sin(); } }").unwrap();
        check_expression_text("-(x1 * -2) - sin(-x2)^2").unwrap();
    }

    #[test]
    fn deep_nesting_and_long_chains_are_refused() {
        let parens = format!("x = {}x{};", "(".repeat(100), ")".repeat(100));
        assert!(check(&parens).unwrap_err().contains("nests deeper"));
        let minus = format!("x = {}x;", "- ".repeat(100));
        assert!(check(&minus).unwrap_err().contains("nests deeper"));
        let sum = format!("x = x{};", " + x".repeat(600));
        assert!(check(&sum).unwrap_err().contains("operators"));
        let methods = format!("x = x{};", ".sin()".repeat(600));
        assert!(check(&methods).unwrap_err().contains("operators"));
        // Operators are counted per statement.
        let many = format!("x = x{};", " + x".repeat(400)).repeat(3);
        check(&many).unwrap();
        // `a = "s"b = "s"b ..`: a literal's suffix makes the chain one assignment after
        // another, which syn parses by recursion (found by the front ends' fuzzing).
        let chain = format!("x = x + {} x;", "v = \"s\"".repeat(300));
        assert!(check(&chain).unwrap_err().contains("one `=`"));
        // Comparisons are not assignments.
        let compares = format!("x = {} 0.0;", "if x <= 1.0 { x } else ".repeat(100));
        check(&compares).unwrap();
    }

    #[test]
    fn model_file_text_is_checked_before_meval() {
        assert!(check_expression_text(" ").unwrap_err().contains("empty"));
        assert!(check_expression_text("x % 2").unwrap_err().contains("`%`"));
        let parens = format!("{}x{}", "(".repeat(100), ")".repeat(100));
        assert!(check_expression_text(&parens).unwrap_err().contains("nest"));
        let sum = format!("x{}", "+x".repeat(600));
        assert!(check_expression_text(&sum)
            .unwrap_err()
            .contains("operators"));
    }
}
