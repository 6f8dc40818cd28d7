//! A model file's expressions: `meval` text to the compiler's surface expressions, each
//! node placed at its first token and each mistake under the token it is about, with what
//! to write there.

use crate::expression_dots::{self, Dotted};
use crate::expression_places;
use meval::tokenizer::{Operation, Token};
use proc_macro2::Span;
use stateforge_compiler::ast::{BinaryOp, Comparison, Name, SurfaceExpr, SurfaceKind};
use stateforge_compiler::diagnostics::Diagnostics;
use std::str::FromStr;

/// Parses one `meval` expression into a surface expression. `at(i)` is where byte `i` of
/// `text` stands in the file: each node is placed at its first token, as the macro's are,
/// and each mistake under the token it is about. A mistake is recorded in `diag`, naming
/// `field`, and the expression read as `0`.
pub(crate) fn parse_expression(
    text: &str,
    field: &str,
    at: &dyn Fn(usize) -> Span,
    diag: &mut Diagnostics,
) -> SurfaceExpr {
    let start = at(0);
    let zero = SurfaceExpr {
        kind: SurfaceKind::Number(0.0),
        span: start,
    };
    if let Err(message) = stateforge_compiler::front::limits::check_expression_text(text) {
        let (place, message) = refused(text, &message);
        diag.error(place.map_or(start, at), format!("{field}: {message}"));
        return zero;
    }
    let dotted = match expression_dots::rewrite(text) {
        Ok(dotted) => dotted,
        Err(mistakes) => {
            for (place, message) in mistakes {
                diag.error(at(place), format!("{field}: {message}"));
            }
            return zero;
        }
    };
    let parsed = match meval::Expr::from_str(&dotted.text) {
        Ok(parsed) => parsed,
        Err(e) => {
            let (offset, message) = parse_error(&dotted, &e);
            diag.error(at(offset), format!("{field}: {message}"));
            return zero;
        }
    };
    let Some(offsets) = expression_places::rpn_offsets(&dotted.text, &parsed) else {
        if dotted.rewritten() {
            // Without the tokens' places, `v_x` cannot be told from `v.x`.
            diag.error(
                start,
                format!(
                    "{field}: cannot read the `.`s of `{text}`: write `norm(a)` for `a.norm()`"
                ),
            );
            return zero;
        }
        return read_tokens(
            &parsed,
            &|_| None,
            Written {
                text,
                field,
                dotted: &dotted,
                at,
            },
            diag,
        );
    };
    let place = |i: usize| offsets.get(i).map(|&o| dotted.origin(o));
    read_tokens(
        &parsed,
        &place,
        Written {
            text,
            field,
            dotted: &dotted,
            at,
        },
        diag,
    )
}

/// The surface expression of `meval`'s reverse Polish notation `parsed`, each token `i`
/// placed at byte `place(i)` of the written text (at its start if unknown).
fn read_tokens(
    parsed: &[Token],
    place: &dyn Fn(usize) -> Option<usize>,
    written: Written,
    diag: &mut Diagnostics,
) -> SurfaceExpr {
    let start = (written.at)(0);
    let zero = SurfaceExpr {
        kind: SurfaceKind::Number(0.0),
        span: start,
    };
    // `meval` gives reverse Polish notation: operands come before their operator.
    let mut stack: Vec<SurfaceExpr> = Vec::new();
    for (i, token) in parsed.iter().enumerate() {
        match written.apply(token, place(i), &mut stack, diag) {
            Ok(()) => {}
            Err(Stop::Malformed) => break,
            Err(Stop::Reported) => return zero,
        }
    }
    match (stack.pop(), stack.is_empty()) {
        (Some(e), true) => e,
        _ => {
            let (text, field) = (written.text, written.field);
            diag.error(
                start,
                format!("{field}: cannot read `{text}` as one expression"),
            );
            zero
        }
    }
}

/// The message of the language check that refused `text` before `meval` read it, with a
/// hint for a comparison, and the byte of the stray character it names, if it names one.
fn refused(text: &str, message: &str) -> (Option<usize>, String) {
    let stray = message
        .strip_prefix('`')
        .and_then(|m| m.split_once("` has no meaning"))
        .map(|(c, _)| c);
    let comparison = stray.is_some_and(|c| matches!(c, "<" | ">" | "=" | "!"));
    let hint = if comparison {
        "; a comparison is written as a piecewise function, `if_gt(a, b, then, else)` \
         (also `if_ge`, `if_lt`, `if_le`)"
    } else {
        ""
    };
    (stray.and_then(|c| text.find(c)), format!("{message}{hint}"))
}

/// Why reading an expression's tokens stopped before the end.
enum Stop {
    /// The tokens do not make one expression (an operator without its operands): the
    /// caller reports it.
    Malformed,
    /// A mistake already reported under its token.
    Reported,
}

/// The expression being read and the field it is written in, for messages.
struct Written<'a> {
    text: &'a str,
    field: &'a str,
    /// Its `.`s, and the text `meval` read.
    dotted: &'a Dotted<'a>,
    /// Where byte `i` of `text` stands in the file.
    at: &'a dyn Fn(usize) -> Span,
}

impl Written<'_> {
    /// Applies one token, at byte `written_at` of the text, of the reverse Polish notation
    /// to `stack`.
    fn apply(
        &self,
        token: &Token,
        written_at: Option<usize>,
        stack: &mut Vec<SurfaceExpr>,
        diag: &mut Diagnostics,
    ) -> Result<(), Stop> {
        let here = (self.at)(written_at.unwrap_or(0));
        let node = |kind| SurfaceExpr { kind, span: here };
        let made = match token {
            Token::Number(v) if !v.is_finite() => {
                let (text, field) = (self.text, self.field);
                diag.error(
                    here,
                    format!("{field}: `{text}` holds {v}: every number must be finite"),
                );
                return Err(Stop::Reported);
            }
            Token::Number(v) => node(SurfaceKind::Number(*v)),
            Token::Var(v) => self.variable(v, written_at, here),
            Token::Unary(Operation::Minus) => {
                let operand = stack.pop().ok_or(Stop::Malformed)?;
                node(SurfaceKind::Neg(Box::new(operand)))
            }
            Token::Unary(Operation::Plus) => return Ok(()),
            Token::Binary(op) => self.binary(op, here, stack, diag)?,
            Token::Func(f, arity) => {
                let mut call = self.call(f, arity.unwrap_or(0), here, stack, diag)?;
                // A method call is placed at its receiver, as the macro places it.
                let receiver = written_at.and_then(|n| self.dotted.receiver_of(n));
                if let (Some(receiver), SurfaceKind::Call(..)) = (receiver, &call.kind) {
                    call.span = (self.at)(receiver);
                }
                call
            }
            _ => return Err(Stop::Malformed),
        };
        stack.push(made);
        Ok(())
    }

    /// The name `v` read at byte `written_at`: a name, `pi`, or with the `.`s written in it
    /// the components of a name (`v.x`, read as `v_x`).
    fn variable(&self, v: &str, written_at: Option<usize>, here: Span) -> SurfaceExpr {
        let start = written_at.unwrap_or(0);
        let dots = written_at.map_or(&[][..], |s| self.dotted.field_dots(s, v.len()));
        let piece = |from: usize, to: usize| v.get(from..to).unwrap_or("").to_owned();
        let ends: Vec<usize> = dots.iter().map(|d| d.saturating_sub(start)).collect();
        let base = piece(0, ends.first().copied().unwrap_or(v.len()));
        let kind = if base == "pi" {
            SurfaceKind::Number(std::f64::consts::PI)
        } else {
            SurfaceKind::Name(base)
        };
        let mut read = SurfaceExpr { kind, span: here };
        for (k, (&dot, &end)) in dots.iter().zip(&ends).enumerate() {
            let next = ends.get(k + 1).copied().unwrap_or(v.len());
            let component = Name {
                text: piece(end + 1, next),
                span: (self.at)(dot + 1),
            };
            read = SurfaceExpr {
                kind: SurfaceKind::Field(Box::new(read), component),
                span: here,
            };
        }
        read
    }

    /// The binary operation `op` of the two operands on top of `stack`, placed at the
    /// first; `a ^ b` is `powi(a, b)`, whose checks say which exponents it takes.
    fn binary(
        &self,
        op: &Operation,
        here: Span,
        stack: &mut Vec<SurfaceExpr>,
        diag: &mut Diagnostics,
    ) -> Result<SurfaceExpr, Stop> {
        let (Some(b), Some(a)) = (stack.pop(), stack.pop()) else {
            return Err(Stop::Malformed);
        };
        let first = a.span;
        let op = match op {
            Operation::Plus => BinaryOp::Add,
            Operation::Minus => BinaryOp::Sub,
            Operation::Times => BinaryOp::Mul,
            Operation::Div => BinaryOp::Div,
            Operation::Pow => {
                let powi = Name {
                    text: "powi".into(),
                    span: here,
                };
                return Ok(SurfaceExpr {
                    kind: SurfaceKind::Call(powi, vec![a, b]),
                    span: first,
                });
            }
            Operation::Rem => {
                diag.error(
                    here,
                    format!(
                        "{}: `%` (a remainder) is not part of the model language: use \
                         `+ - * /` and `^` for a whole power",
                        self.field
                    ),
                );
                return Err(Stop::Reported);
            }
        };
        Ok(SurfaceExpr {
            kind: SurfaceKind::Binary(op, Box::new(a), Box::new(b)),
            span: first,
        })
    }

    /// The call of `function` with the `n` operands on top of `stack`; a piecewise
    /// function (`if_gt(a, b, then, else)`) becomes the piecewise term.
    fn call(
        &self,
        function: &str,
        n: usize,
        here: Span,
        stack: &mut Vec<SurfaceExpr>,
        diag: &mut Diagnostics,
    ) -> Result<SurfaceExpr, Stop> {
        if stack.len() < n {
            return Err(Stop::Malformed);
        }
        let args = stack.split_off(stack.len() - n);
        if comparison_of(function).is_some() && n != 4 {
            diag.error(
                here,
                format!(
                    "{}: `{function}(a, b, then, else)` takes 4 arguments, found {n}",
                    self.field
                ),
            );
            return Err(Stop::Reported);
        }
        Ok(piecewise(function, &args, here).unwrap_or_else(|| {
            let name = Name {
                text: function.to_owned(),
                span: here,
            };
            SurfaceExpr {
                kind: SurfaceKind::Call(name, args),
                span: here,
            }
        }))
    }
}

/// Where `meval` stopped reading `dotted` (a byte of the written text), and what to write
/// there.
fn parse_error(dotted: &Dotted, error: &meval::Error) -> (usize, String) {
    use meval::tokenizer::ParseError;
    use meval::{Error, RPNError};
    let (text, read) = (dotted.written, dotted.text.as_str());
    let end = text.len();
    // The place of the infix token `k` of `read` (parentheses and commas counted).
    let token_at = |k: usize| {
        meval::tokenizer::tokenize(read)
            .ok()
            .and_then(|tokens| expression_places::token_offsets(read, &tokens))
            .and_then(|offsets| offsets.get(k).map(|&o| dotted.origin(o)))
            .unwrap_or(0)
    };
    match error {
        Error::ParseError(ParseError::UnexpectedToken(i)) => unexpected_token(dotted, *i),
        Error::ParseError(ParseError::MissingRParen(n)) => {
            let n = *n;
            let which = if n == 1 { "a `(`" } else { "`(`s" };
            (end, format!("`{text}` leaves {which} open: add {n} `)`"))
        }
        Error::ParseError(ParseError::MissingArgument) => (
            end,
            format!(
                "`{text}` ends where a value belongs: finish it with a number, a name or a call"
            ),
        ),
        Error::RPNError(RPNError::MismatchedRParen(k)) => (
            token_at(*k),
            format!("`{text}` has a `)` that closes no `(`: remove it, or add the `(`"),
        ),
        Error::RPNError(RPNError::MismatchedLParen(k)) => (
            token_at(*k),
            format!("`{text}` leaves this `(` open: add its `)`"),
        ),
        Error::RPNError(RPNError::UnexpectedComma(k)) => (
            token_at(*k),
            format!(
                "`{text}` has a `,` outside a call: commas separate a function's arguments, \
                 as in `atan2(y, x)`"
            ),
        ),
        _ => (
            0,
            format!("cannot read `{text}` as one expression: {error}"),
        ),
    }
}

/// `meval` met a token it did not expect at byte `i` of the text it read: the token's
/// first byte in the written text (past any blanks) and what to write there.
fn unexpected_token(dotted: &Dotted, i: usize) -> (usize, String) {
    use meval::tokenizer::ParseError;
    let (text, read) = (dotted.written, dotted.text.as_str());
    let after = read.get(i..).unwrap_or("");
    let i = i + (after.len() - after.trim_start().len());
    let place = dotted.origin(i);
    let rest = text.get(place..).unwrap_or("");
    let word = rest
        .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_' || c == '.'))
        .unwrap_or(rest.len());
    let token = match rest.chars().next() {
        Some(c) if word == 0 => c.to_string(),
        _ => rest[..word].to_owned(),
    };
    // What `meval` wanted there: a value after an operator, `(` or `,` (the text
    // before is then incomplete), else an operator.
    // (Blanks alone, which `meval`'s tokenizer panics on, want a value too.)
    let before = read.get(..i).unwrap_or("");
    let wants_value = before.trim().is_empty()
        || matches!(
            meval::tokenizer::tokenize(before),
            Err(ParseError::MissingArgument)
        );
    // Characters outside the language were refused before `meval` read the text.
    let message = match token.as_str() {
        ")" => format!("`{text}` has a `)` that closes no `(`: remove it, or add the `(`"),
        "," => format!(
            "`{text}` has a `,` outside a call: commas separate a function's \
             arguments, as in `atan2(y, x)`"
        ),
        _ if token.starts_with('.') && !wants_value => format!(
            "`{text}` has `{token}`: a `.` follows a name, with no blank between, and a \
             component (`v.x`, `v.y`, `v.z`) or a method (`q.inverse()`, `a.dot(b)`) \
             follows it"
        ),
        _ if wants_value => format!(
            "`{text}` has `{token}` where a value belongs: write a number, a name, a \
             call such as `sin(x1)`, or `(` here"
        ),
        _ => format!(
            "`{text}` has `{token}` where an operator belongs: write `+ - * / ^` \
             between two values"
        ),
    };
    (place, message)
}

/// `if_gt(a, b, then, else)` and its siblings as a piecewise term.
fn piecewise(function: &str, args: &[SurfaceExpr], here: Span) -> Option<SurfaceExpr> {
    let cmp = comparison_of(function)?;
    let [lhs, rhs, then, otherwise] = args else {
        return None;
    };
    Some(SurfaceExpr {
        kind: SurfaceKind::If {
            cmp,
            lhs: Box::new(lhs.clone()),
            rhs: Box::new(rhs.clone()),
            then: Box::new(then.clone()),
            otherwise: Box::new(otherwise.clone()),
        },
        span: here,
    })
}

/// The comparison a piecewise function of the model-file language stands for.
pub fn comparison_of(function: &str) -> Option<Comparison> {
    Some(match function {
        "if_gt" => Comparison::Gt,
        "if_ge" => Comparison::Ge,
        "if_lt" => Comparison::Lt,
        "if_le" => Comparison::Le,
        _ => return None,
    })
}
