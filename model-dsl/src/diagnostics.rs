//! Collects every error found in a model so the user sees all of them in one compile.

use proc_macro2::Span;
use std::fmt::Display;

/// An error collector: record spanned errors and keep going; [`Diagnostics::finish`]
/// combines them into one `syn::Error` that renders as several compile errors.
#[derive(Default)]
pub struct Diagnostics {
    errors: Vec<syn::Error>,
}

impl Diagnostics {
    /// Records an error under `span`.
    pub fn error(&mut self, span: Span, message: impl Display) {
        self.errors.push(syn::Error::new(span, message));
    }

    /// Records an error produced elsewhere (for example by `syn` while parsing).
    pub fn push(&mut self, error: syn::Error) {
        self.errors.push(error);
    }

    /// Whether any error was recorded.
    pub fn has_errors(&self) -> bool {
        !self.errors.is_empty()
    }

    /// `Ok(value)` when nothing was recorded, else every recorded error combined.
    pub fn finish<T>(self, value: T) -> syn::Result<T> {
        let mut errors = self.errors.into_iter();
        match errors.next() {
            None => Ok(value),
            Some(mut first) => {
                for error in errors {
                    first.combine(error);
                }
                Err(first)
            }
        }
    }
}

/// A warning about a valid model (a declaration nothing reads): where, and what to do.
#[derive(Clone, Debug)]
pub struct Warning {
    /// The offending token.
    pub span: Span,
    /// What is wrong and what to write.
    pub message: String,
}

impl Warning {
    /// The warning as items that make rustc warn under [`Warning::span`]: a procedural
    /// macro has no warning of its own on stable Rust, so this is a `#[deprecated]`
    /// constant carrying the message, used there (rustc then prints "use of deprecated
    /// constant `_::model_warning`: " and the message). For the macro's output only: a
    /// generated file gets its warnings from the tool, printed.
    pub fn to_tokens(&self) -> proc_macro2::TokenStream {
        let message = &self.message;
        let used_here = proc_macro2::Ident::new("model_warning", self.span);
        quote::quote! {
            const _: () = {
                #[deprecated(note = #message)]
                #[allow(non_upper_case_globals)]
                const model_warning: () = ();
                #used_here
            };
        }
    }
}

/// `a, b and c` (with `conjunction` between the last two), for a message's list.
pub fn phrase(items: &[String], conjunction: &str) -> String {
    match items.split_last() {
        None => String::new(),
        Some((last, [])) => last.clone(),
        Some((last, rest)) => format!("{} {conjunction} {last}", rest.join(", ")),
    }
}

/// The candidate a misspelt `name` most likely meant: one that differs only in case, else
/// the nearest by edits (insertions, deletions, substitutions, a swap of neighbours) if at
/// most a third of its letters (at least one) differ and it has three or more (`x3` is
/// one edit from `x1`, and more likely a name not declared yet); ties go to the first
/// candidate. For "did you mean `omega`?".
pub fn closest<'a>(name: &str, candidates: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
    // Names are identifiers; a long one (pasted by mistake) gets no suggestion, which
    // keeps the table below small.
    const LONGEST: usize = 64;
    let name: Vec<char> = name.chars().collect();
    if name.is_empty() || name.len() > LONGEST {
        return None;
    }
    let allowed = if name.len() < 3 {
        0
    } else {
        (name.len() / 3).max(1)
    };
    let mut best: Option<(usize, &str)> = None;
    for candidate in candidates {
        let other: Vec<char> = candidate.chars().collect();
        if other == name || other.len() > LONGEST {
            continue;
        }
        let same_but_case = other.len() == name.len()
            && other
                .iter()
                .zip(&name)
                .all(|(a, b)| a.to_lowercase().eq(b.to_lowercase()));
        let d = if same_but_case {
            0
        } else {
            edits(&name, &other)
        };
        if d <= allowed && best.is_none_or(|(b, _)| d < b) {
            best = Some((d, candidate));
        }
    }
    best.map(|(_, candidate)| candidate)
}

/// Edits between `a` and `b` (optimal string alignment: a swap of neighbours is one).
fn edits(a: &[char], b: &[char]) -> usize {
    let mut table = vec![vec![0usize; b.len() + 1]; a.len() + 1];
    for (i, row) in table.iter_mut().enumerate() {
        row[0] = i;
    }
    for (j, cell) in table[0].iter_mut().enumerate() {
        *cell = j;
    }
    for i in 1..=a.len() {
        for j in 1..=b.len() {
            let substitution = usize::from(a[i - 1] != b[j - 1]);
            let mut d = (table[i - 1][j] + 1)
                .min(table[i][j - 1] + 1)
                .min(table[i - 1][j - 1] + substitution);
            if i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1] {
                d = d.min(table[i - 2][j - 2] + 1);
            }
            table[i][j] = d;
        }
    }
    table[a.len()][b.len()]
}

#[cfg(test)]
mod tests {
    use super::closest;

    #[test]
    fn a_misspelt_name_gets_the_nearest_candidate() {
        let names = ["theta", "omega", "torque", "TS"];
        assert_eq!(closest("omgea", names), Some("omega"));
        assert_eq!(closest("thetta", names), Some("theta"));
        assert_eq!(closest("Ts", names), Some("TS"));
        assert_eq!(closest("x3", ["x1", "x2"]), None);
        assert_eq!(
            closest("proces_noise", ["process_noise", "gate"]),
            Some("process_noise")
        );
        // Too far from every candidate, or the name itself: no suggestion.
        assert_eq!(closest("velocity", names), None);
        assert_eq!(closest("omega", names), None);
        assert_eq!(closest(&"x".repeat(10_000), names), None);
    }
}
