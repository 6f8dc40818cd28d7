//! Where the pieces of a model-file expression stand in the file, so that a mistake inside
//! an expression string is reported under the offending token, not under the string's
//! opening quote.
//!
//! Two maps: from a byte of a TOML string's value to its place in the string's source text
//! (escapes and multi-line strings included), and from each token `meval` reads to its
//! byte in the value. `meval` keeps no positions, so the second is our own reading of the
//! text, replayed through `meval`'s shunting-yard and used only if the replay gives
//! `meval`'s own tokens in `meval`'s own order; a caller that gets `None` points at the
//! opening quote, as before.

use meval::tokenizer::{Operation, Token};

/// For each byte of the value of the TOML string written as `raw` (its delimiters
/// included), the offset in `raw` of the character it comes from, and one more entry for
/// the end of the value (the closing delimiter). `None` unless `raw` is a TOML string whose
/// value is `value`.
pub(crate) fn string_offsets(raw: &str, value: &str) -> Option<Vec<usize>> {
    let (delimiter, literal) = if raw.starts_with("\"\"\"") {
        ("\"\"\"", false)
    } else if raw.starts_with("'''") {
        ("'''", true)
    } else if raw.starts_with('"') {
        ("\"", false)
    } else if raw.starts_with('\'') {
        ("'", true)
    } else {
        return None;
    };
    let multi_line = delimiter.len() == 3;
    let end = raw.len().checked_sub(delimiter.len())?;
    if end < delimiter.len() || !raw.ends_with(delimiter) {
        return None;
    }
    let mut at = delimiter.len();
    // A newline right after the opening delimiter of a multi-line string is not content.
    if multi_line {
        if raw[at..].starts_with("\r\n") {
            at += 2;
        } else if raw[at..].starts_with('\n') {
            at += 1;
        }
    }
    let mut decoded = String::with_capacity(value.len());
    let mut offsets = Vec::with_capacity(value.len() + 1);
    while at < end {
        let c = raw[at..].chars().next()?;
        if literal || c != '\\' {
            offsets.extend((0..c.len_utf8()).map(|k| at + k));
            decoded.push(c);
            at += c.len_utf8();
            continue;
        }
        let escape = raw[at + 1..end].chars().next()?;
        let (character, length) = match escape {
            'b' => ('\u{8}', 2),
            't' => ('\t', 2),
            'n' => ('\n', 2),
            'f' => ('\u{c}', 2),
            'r' => ('\r', 2),
            'e' => ('\u{1b}', 2),
            '"' => ('"', 2),
            '\\' => ('\\', 2),
            'x' | 'u' | 'U' => {
                let digits = match escape {
                    'x' => 2,
                    'u' => 4,
                    _ => 8,
                };
                let hex = raw.get(at + 2..at + 2 + digits)?;
                let code = u32::from_str_radix(hex, 16).ok()?;
                (char::from_u32(code)?, 2 + digits)
            }
            // A line-ending backslash: the line break and the blanks around it vanish.
            ' ' | '\t' | '\r' | '\n' if multi_line => {
                let rest = &raw[at + 1..end];
                let blanks = rest.len() - rest.trim_start_matches([' ', '\t']).len();
                let after = &rest[blanks..];
                if !(after.starts_with('\n') || after.starts_with("\r\n")) {
                    return None;
                }
                let skipped = after.len() - after.trim_start_matches([' ', '\t', '\r', '\n']).len();
                at += 1 + blanks + skipped;
                continue;
            }
            _ => return None,
        };
        offsets.extend(std::iter::repeat_n(at, character.len_utf8()));
        decoded.push(character);
        at += length;
    }
    offsets.push(end);
    (decoded == value).then_some(offsets)
}

/// The byte in `text` where each of `tokens` (what `meval::tokenizer::tokenize` read from
/// `text`, in order) starts; `None` if our reading of `text` disagrees with `tokens`.
pub(crate) fn token_offsets(text: &str, tokens: &[Token]) -> Option<Vec<usize>> {
    let bytes = text.as_bytes();
    let blank = |b: u8| matches!(b, b' ' | b'\t' | b'\r' | b'\n');
    let digits = |from: usize| {
        bytes[from..]
            .iter()
            .take_while(|b| b.is_ascii_digit())
            .count()
    };
    let mut at = 0;
    let mut offsets = Vec::with_capacity(tokens.len());
    for token in tokens {
        while bytes.get(at).copied().is_some_and(blank) {
            at += 1;
        }
        let rest = &text[at..];
        let length = match token {
            Token::Number(_) => {
                // `meval`'s numbers: digits, then `.` and digits, then an exponent.
                let mut end = at + digits(at);
                if end == at {
                    return None;
                }
                if bytes.get(end) == Some(&b'.') {
                    end += 1 + digits(end + 1);
                }
                if matches!(bytes.get(end), Some(b'e' | b'E')) {
                    let sign = usize::from(matches!(bytes.get(end + 1), Some(b'+' | b'-')));
                    let exponent = digits(end + 1 + sign);
                    if exponent > 0 {
                        end += 1 + sign + exponent;
                    }
                }
                end - at
            }
            Token::Var(name) => rest.starts_with(name.as_str()).then_some(name.len())?,
            Token::Func(name, _) => {
                let after = rest.strip_prefix(name.as_str())?;
                let blanks = after.len() - after.trim_start_matches(blank_char).len();
                after[blanks..]
                    .starts_with('(')
                    .then_some(name.len() + blanks + 1)?
            }
            Token::Binary(op) | Token::Unary(op) => {
                let symbol = match op {
                    Operation::Plus => '+',
                    Operation::Minus => '-',
                    Operation::Times => '*',
                    Operation::Div => '/',
                    Operation::Rem => '%',
                    Operation::Pow => '^',
                };
                rest.starts_with(symbol).then_some(1)?
            }
            Token::LParen => rest.starts_with('(').then_some(1)?,
            Token::RParen => rest.starts_with(')').then_some(1)?,
            Token::Comma => rest.starts_with(',').then_some(1)?,
        };
        offsets.push(at);
        at += length;
    }
    text[at..]
        .trim_start_matches(blank_char)
        .is_empty()
        .then_some(offsets)
}

fn blank_char(c: char) -> bool {
    matches!(c, ' ' | '\t' | '\r' | '\n')
}

/// The byte in `text` of each token of `rpn`, `meval`'s reverse Polish notation of `text`
/// (`meval::Expr::from_str(text)`); `None` if it cannot be established.
pub(crate) fn rpn_offsets(text: &str, rpn: &[Token]) -> Option<Vec<usize>> {
    let tokens = meval::tokenizer::tokenize(text).ok()?;
    let offsets = token_offsets(text, &tokens)?;
    let replayed = shunting_yard(&tokens, &offsets)?;
    let same = replayed.len() == rpn.len() && replayed.iter().zip(rpn).all(|((t, _), r)| t == r);
    same.then(|| replayed.into_iter().map(|(_, at)| at).collect())
}

/// `meval::shunting_yard::to_rpn` (meval 0.2), carrying each token's offset along. A
/// function's place is its name's, an operator's its own.
pub(crate) fn shunting_yard(tokens: &[Token], offsets: &[usize]) -> Option<Vec<(Token, usize)>> {
    #[derive(Clone, Copy, PartialEq)]
    enum Associativity {
        Left,
        Right,
        None,
    }
    let precedence = |token: &Token| match token {
        Token::Binary(Operation::Plus | Operation::Minus) => (1, Associativity::Left),
        Token::Binary(Operation::Pow) => (4, Associativity::Right),
        Token::Binary(_) => (2, Associativity::Left),
        Token::Unary(_) => (3, Associativity::None),
        _ => (0, Associativity::None),
    };
    let mut output = Vec::with_capacity(tokens.len());
    let mut stack: Vec<(Token, usize)> = Vec::new();
    for (token, &at) in tokens.iter().zip(offsets) {
        match token {
            Token::Number(_) | Token::Var(_) => output.push((token.clone(), at)),
            Token::Unary(_) | Token::LParen | Token::Func(..) => stack.push((token.clone(), at)),
            Token::Binary(_) => {
                let (p1, a1) = precedence(token);
                while let Some((top, _)) = stack.last() {
                    let (p2, _) = precedence(top);
                    let pops = match a1 {
                        Associativity::Left => p1 <= p2,
                        Associativity::Right => p1 < p2,
                        Associativity::None => false,
                    };
                    if !pops {
                        break;
                    }
                    output.extend(stack.pop());
                }
                stack.push((token.clone(), at));
            }
            Token::RParen => loop {
                match stack.pop()? {
                    (Token::LParen, _) => break,
                    (Token::Func(name, n), place) => {
                        output.push((Token::Func(name, Some(n.unwrap_or(0) + 1)), place));
                        break;
                    }
                    other => output.push(other),
                }
            },
            Token::Comma => loop {
                match stack.pop()? {
                    (Token::LParen, _) => return None,
                    (Token::Func(name, n), place) => {
                        stack.push((Token::Func(name, Some(n.unwrap_or(0) + 1)), place));
                        break;
                    }
                    other => output.push(other),
                }
            },
        }
    }
    while let Some((token, at)) = stack.pop() {
        match token {
            Token::Unary(_) | Token::Binary(_) => output.push((token, at)),
            _ => return None,
        }
    }
    Some(output)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::str::FromStr;

    #[test]
    fn string_offsets_follow_escapes_and_multi_line_strings() {
        let at = |raw: &str, value: &str| string_offsets(raw, value);
        assert_eq!(at("\"a b\"", "a b"), Some(vec![1, 2, 3, 4]));
        assert_eq!(at("'a\\b'", "a\\b"), Some(vec![1, 2, 3, 4]));
        // `\t` is two characters of source for one of value.
        assert_eq!(at("\"a\\tb\"", "a\tb"), Some(vec![1, 2, 4, 5]));
        assert_eq!(at("\"\\u00e9x\"", "éx"), Some(vec![1, 1, 7, 8]));
        assert_eq!(at("\"\"\"\nab\"\"\"", "ab"), Some(vec![4, 5, 6]));
        assert_eq!(at("'''\r\nab'''", "ab"), Some(vec![5, 6, 7]));
        assert_eq!(
            at("\"\"\"a \\\n   b\"\"\"", "a b"),
            Some(vec![3, 4, 10, 11])
        );
        // Not the string it claims to be: no map.
        assert_eq!(at("\"ab\"", "abc"), None);
        assert_eq!(at("12", "12"), None);
    }

    #[test]
    fn rpn_offsets_place_every_token() {
        let text = "x1 + sin( x2 ) * -K^2";
        let rpn = meval::Expr::from_str(text).expect("parses");
        let offsets = rpn_offsets(text, &rpn).expect("placed");
        let pieces: Vec<&str> = offsets.iter().map(|&o| &text[o..o + 1]).collect();
        // x1 x2 sin K 2 ^ - * +: each token's first character.
        assert_eq!(pieces, ["x", "x", "s", "K", "2", "^", "-", "*", "+"]);
    }

    #[test]
    fn rpn_offsets_of_numbers_and_nested_calls() {
        let text = "if_gt(x, 1.5e-3, max(x, 2.), 0)";
        let rpn = meval::Expr::from_str(text).expect("parses");
        let offsets = rpn_offsets(text, &rpn).expect("placed");
        let starts: Vec<usize> = offsets.to_vec();
        // x 1.5e-3 x 2. max 0 if_gt
        assert_eq!(starts, [6, 9, 21, 24, 17, 29, 0]);
    }
}
