//! The `.` of a model-file expression: a vector's component (`v.x`) and a method call
//! (`q.inverse()`, `a.dot(b)`), which `meval` cannot read, rewritten into text it reads.
//!
//! A component keeps its bytes, its `.` becoming `_` (`v.x` is read as the one name
//! `v_x`), and the `.` is recorded, so the name splits back into `v` and `x`. A method call
//! becomes the call of the function with the receiver as first argument (`q.inverse()` is
//! read as `inverse(q)`, `a.dot(b)` as `dot(a,b)`): `meval` reads no call without
//! arguments, so the receiver moves inside the parentheses, and every byte of the text
//! read keeps the byte of the written text it comes from, for the places of tokens and
//! mistakes. A `.` after a `)` (`(q * v).x`, `log(q).norm()`) is refused with the form to
//! write: `meval` reads no name there to join it to.

use stateforge_compiler::front::limits::{MAX_NESTING, MAX_OPERATORS};

/// A model-file expression as written, and the text `meval` reads for it.
pub(crate) struct Dotted<'a> {
    /// The expression as written in the file.
    pub(crate) written: &'a str,
    /// The text `meval` reads: `v.x` as `v_x`, `q.inverse()` as `inverse(q)`.
    pub(crate) text: String,
    /// For each byte of `text`, the byte of `written` it comes from.
    origin: Vec<usize>,
    /// The byte in `written` of each `.` that reads a component, in order.
    fields: Vec<usize>,
    /// Each method call's name and receiver, as their first bytes in `written`, in order.
    methods: Vec<(usize, usize)>,
}

impl Dotted<'_> {
    /// The byte of the written text that byte `i` of the text read comes from; the end of
    /// the written text for the end of the text read.
    pub(crate) fn origin(&self, i: usize) -> usize {
        self.origin.get(i).copied().unwrap_or(self.written.len())
    }

    /// Whether the text read differs from the text written.
    pub(crate) fn rewritten(&self) -> bool {
        !(self.fields.is_empty() && self.methods.is_empty())
    }

    /// The component `.`s in the `len` written bytes from `start`, in order.
    pub(crate) fn field_dots(&self, start: usize, len: usize) -> &[usize] {
        let from = self.fields.partition_point(|&d| d < start);
        let to = self
            .fields
            .partition_point(|&d| d < start.saturating_add(len));
        self.fields.get(from..to).unwrap_or(&[])
    }

    /// The receiver's first byte of the method call whose name starts at byte `name`.
    pub(crate) fn receiver_of(&self, name: usize) -> Option<usize> {
        let i = self.methods.binary_search_by_key(&name, |&(n, _)| n).ok()?;
        self.methods.get(i).map(|&(_, receiver)| receiver)
    }
}

/// `written` rewritten for `meval`, or each `.` it cannot be (after a `)`, or past the
/// operator limit) as its byte and what to write instead.
pub(crate) fn rewrite(written: &str) -> Result<Dotted<'_>, Vec<(usize, String)>> {
    let mut r = Rewriter {
        w: written.as_bytes(),
        out: Vec::with_capacity(written.len() + 8),
        origin: Vec::with_capacity(written.len() + 8),
        fields: Vec::new(),
        methods: Vec::new(),
        errors: Vec::new(),
    };
    let mut i = 0;
    while let Some(&b) = r.w.get(i) {
        i = if is_ident_start(b) {
            r.word(i)
        } else if b.is_ascii_digit() {
            let end = number_end(r.w, i);
            r.copy(i, end, false);
            end
        } else {
            if b == b')' && dot_then_name(r.w, i + 1) {
                r.errors.push((i + 1, after_parenthesis(r.w, i)));
            }
            r.copy(i, i + 1, false);
            i + 1
        };
    }
    r.check_count();
    if !r.errors.is_empty() {
        return Err(r.errors);
    }
    Ok(Dotted {
        written,
        text: String::from_utf8_lossy(&r.out).into_owned(),
        origin: r.origin,
        fields: r.fields,
        methods: r.methods,
    })
}

/// The text read, built from the written one.
struct Rewriter<'a> {
    w: &'a [u8],
    out: Vec<u8>,
    origin: Vec<usize>,
    fields: Vec<usize>,
    methods: Vec<(usize, usize)>,
    errors: Vec<(usize, String)>,
}

impl Rewriter<'_> {
    /// Copies the written bytes `from..to`, each `.` as `_` if `joined`.
    fn copy(&mut self, from: usize, to: usize, joined: bool) {
        for i in from..to.min(self.w.len()) {
            let b = self.w[i];
            self.push(if joined && b == b'.' { b'_' } else { b }, i);
        }
    }

    fn push(&mut self, byte: u8, origin: usize) {
        self.out.push(byte);
        self.origin.push(origin);
    }

    /// The name at `start` and the components and method joined to it by `.`s; the byte
    /// after what it read.
    fn word(&mut self, start: usize) -> usize {
        let mut dots = Vec::new();
        let mut end = ident_end(self.w, start);
        while dot_then_name(self.w, end) {
            dots.push(end);
            end = ident_end(self.w, end + 1);
        }
        // Each `.` nests the value read once more, as a `(` does.
        if let Some(&dot) = dots.get(MAX_NESTING) {
            self.errors.push((
                dot,
                format!(
                    "this chain of `.`s nests deeper than {MAX_NESTING} levels: a vector's \
                     component is a number, which has no components"
                ),
            ));
        }
        match (dots.split_last(), call_parenthesis(self.w, end)) {
            // `a.f(..)`: `f(a, ..)`, the receiver a name or a component.
            (Some((&dot, components)), Some(open)) => {
                self.fields.extend_from_slice(components);
                self.methods.push((dot + 1, start));
                self.copy(dot + 1, end, false);
                self.push(b'(', open);
                self.copy(start, dot, true);
                let rest = self.w.get(open + 1..).unwrap_or(&[]);
                let next = rest.iter().find(|b| !b.is_ascii_whitespace());
                if next.is_some_and(|&b| b != b')') {
                    self.push(b',', open);
                }
                open + 1
            }
            _ => {
                self.fields.extend_from_slice(&dots);
                self.copy(start, end, true);
                end
            }
        }
    }

    /// The macro counts a `.` as an operator: so does a model file, which keeps the
    /// expression's depth within what the checks read.
    fn check_count(&mut self) {
        let operators = self
            .w
            .iter()
            .filter(|b| matches!(b, b'+' | b'-' | b'*' | b'/' | b'^'))
            .count();
        let mut dots: Vec<usize> = self.fields.clone();
        dots.extend(self.methods.iter().map(|&(name, _)| name - 1));
        dots.sort_unstable();
        if let Some(&dot) = dots.get(MAX_OPERATORS.saturating_sub(operators)) {
            self.errors.push((
                dot,
                format!(
                    "more than {MAX_OPERATORS} operators and `.`s in one expression: name \
                     parts of it in `[[dynamics.let]]`"
                ),
            ));
        }
    }
}

fn is_ident_start(b: u8) -> bool {
    b.is_ascii_alphabetic() || b == b'_'
}

/// The end of the name that starts at `start` (`meval`'s names: `[A-Za-z_][A-Za-z0-9_]*`).
fn ident_end(w: &[u8], start: usize) -> usize {
    let rest = w.get(start + 1..).unwrap_or(&[]);
    start
        + 1
        + rest
            .iter()
            .take_while(|b| b.is_ascii_alphanumeric() || **b == b'_')
            .count()
}

/// Whether byte `i` is a `.` followed by a name.
fn dot_then_name(w: &[u8], i: usize) -> bool {
    w.get(i) == Some(&b'.') && w.get(i + 1).copied().is_some_and(is_ident_start)
}

/// The `(` of a call after a name ending at `end`, past blanks, as `meval` reads one.
fn call_parenthesis(w: &[u8], end: usize) -> Option<usize> {
    let rest = w.get(end..)?;
    let blanks = rest.iter().take_while(|b| b.is_ascii_whitespace()).count();
    (rest.get(blanks) == Some(&b'(')).then_some(end + blanks)
}

/// The end of the number at `start`, as `meval` reads one: digits, a `.` and digits, an
/// exponent (`1.5`, `1.`, `2.5e-3`). A `.` after a digit is a number's.
fn number_end(w: &[u8], start: usize) -> usize {
    let digits = |from: usize| {
        w.get(from..)
            .unwrap_or(&[])
            .iter()
            .take_while(|b| b.is_ascii_digit())
            .count()
    };
    let mut end = start + digits(start);
    if w.get(end) == Some(&b'.') {
        end += 1 + digits(end + 1);
    }
    if matches!(w.get(end), Some(b'e' | b'E')) {
        let sign = usize::from(matches!(w.get(end + 1), Some(b'+' | b'-')));
        let exponent = digits(end + 1 + sign);
        if exponent > 0 {
            end += 1 + sign + exponent;
        }
    }
    end
}

/// What to write for the `.` after the `)` at `close`: the function of a method, the
/// projection of a component.
fn after_parenthesis(w: &[u8], close: usize) -> String {
    let text = |from: usize, to: usize| String::from_utf8_lossy(w.get(from..to).unwrap_or(&[]));
    let name_end = ident_end(w, close + 2);
    let name = text(close + 2, name_end);
    // The value before the `.`: a parenthesised expression (its inside), or a call.
    let value = opening(w, close).map(|open| {
        let called = w[..open]
            .iter()
            .rev()
            .take_while(|b| b.is_ascii_alphanumeric() || matches!(b, b'_' | b'.'))
            .count();
        match called {
            0 => text(open + 1, close).trim().to_owned(),
            _ => text(open - called, close + 1).into_owned(),
        }
    });
    let Some(open) = call_parenthesis(w, name_end) else {
        let unit = match &*name {
            "x" => "1.0, 0.0, 0.0",
            "y" => "0.0, 1.0, 0.0",
            "z" => "0.0, 0.0, 1.0",
            _ => "",
        };
        let projection = match value {
            Some(value) if !unit.is_empty() => {
                format!("write `dot({value}, vec3({unit}))`, or ")
            }
            _ => String::new(),
        };
        return format!(
            "in a model file a component is read from a name, as in `v.{name}`, not after \
             a `)`: {projection}name the vector in a `[[dynamics.let]]` table and read \
             `.{name}` of that name (an output may read it too)"
        );
    };
    let arguments = closing(w, open).map(|end| text(open + 1, end).trim().to_owned());
    let example = match &arguments {
        Some(arguments) if arguments.is_empty() => "",
        _ => "b",
    };
    let call = match (value, arguments) {
        (Some(value), Some(arguments)) if arguments.is_empty() => format!("`{name}({value})`"),
        (Some(value), Some(arguments)) => format!("`{name}({value}, {arguments})`"),
        _ => format!("`{name}(..)`, the value before the `.` its first argument"),
    };
    format!(
        "in a model file a method is called on a name, as in `a.{name}({example})`, not \
         after a `)`: write the function, {call}"
    )
}

/// The `(` that the `)` at `close` closes.
fn opening(w: &[u8], close: usize) -> Option<usize> {
    let mut depth = 0usize;
    for i in (0..close).rev() {
        match w[i] {
            b')' => depth += 1,
            b'(' if depth == 0 => return Some(i),
            b'(' => depth -= 1,
            _ => {}
        }
    }
    None
}

/// The `)` that closes the `(` at `open`.
fn closing(w: &[u8], open: usize) -> Option<usize> {
    let mut depth = 0usize;
    for (i, &b) in w.iter().enumerate().skip(open + 1) {
        match b {
            b'(' => depth += 1,
            b')' if depth == 0 => return Some(i),
            b')' => depth -= 1,
            _ => {}
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(written: &str) -> String {
        rewrite(written).map(|d| d.text).unwrap_or_default()
    }

    #[test]
    fn components_and_methods_become_names_and_calls() {
        assert_eq!(read("v.x + 1.5"), "v_x + 1.5");
        assert_eq!(read("q.inverse() * v"), "inverse(q) * v");
        assert_eq!(read("a.dot( b )"), "dot(a, b )");
        assert_eq!(read("v.x.abs()"), "abs(v_x)");
        assert_eq!(read("1. + 2.5e-3 * x1"), "1. + 2.5e-3 * x1");
        // Not a component: left for `meval` to refuse, under the `.`.
        assert_eq!(read("x1.5"), "x1.5");
    }

    #[test]
    fn each_byte_read_keeps_its_place() {
        let dotted = rewrite("a.dot(b)").expect("rewritten");
        // d o t ( a , b ): the name from 2, the receiver at 0, the comma at the `(`.
        let places: Vec<usize> = (0..=dotted.text.len()).map(|i| dotted.origin(i)).collect();
        assert_eq!(places, [2, 3, 4, 5, 0, 5, 6, 7, 8]);
        assert_eq!(dotted.receiver_of(2), Some(0));
        let dotted = rewrite("p.y * v.x.y").expect("rewritten");
        assert_eq!(dotted.field_dots(0, 3), [1]);
        assert_eq!(dotted.field_dots(6, 5), [7, 9]);
    }

    #[test]
    fn a_dot_after_a_parenthesis_says_what_to_write() {
        let errors = |w: &str| rewrite(w).err().unwrap_or_default();
        let [(at, message)] = &errors("2 * (q * v).x")[..] else {
            panic!("one error")
        };
        assert_eq!(*at, 11);
        assert!(
            message.contains("`dot(q * v, vec3(1.0, 0.0, 0.0))`"),
            "{message}"
        );
        let [(_, message)] = &errors("log(q).norm()")[..] else {
            panic!("one error")
        };
        assert!(
            message.ends_with("write the function, `norm(log(q))`"),
            "{message}"
        );
        let [(_, message)] = &errors("(a + b).dot(c)")[..] else {
            panic!("one error")
        };
        assert!(message.ends_with("`dot(a + b, c)`"), "{message}");
    }
}
