//! Declarations nothing reads. A parameter no equation or output reads is carried by every
//! filter, its variance growing, but no measurement ever moves its estimate; an input or
//! run-time constant nothing reads is most likely a name an equation meant to use. The
//! model is still valid, so these are warnings, as rustc's for unused items. Constants are
//! not among them: the generated module exports each (`m::TS`), for the application to
//! read. A symbol kept on purpose is declared `#[allow(unused)]`.

use crate::ast::{
    ArgValue, DynamicsKind, ModelDecl, Name, Statement, SurfaceExpr, SurfaceKind, SymbolKind,
};
use crate::diagnostics::Warning;
use std::collections::HashSet;

/// A warning under each parameter, input and run-time constant, not declared
/// `#[allow(unused)]`, whose name no expression (constants, outputs, the dynamics and its
/// step) and no generator option reads.
pub fn unused_declarations(decl: &ModelDecl) -> Vec<Warning> {
    let read = names_read(decl);
    let unread = decl
        .symbols
        .iter()
        .filter(|s| !s.allow_unused && !read.contains(s.name.text.as_str()));
    unread
        .filter_map(|symbol| {
            let (noun, what) = match symbol.kind {
                SymbolKind::State => return None,
                SymbolKind::Param => (
                    "parameter",
                    "the filters carry it, but nothing moves its estimate",
                ),
                SymbolKind::Input => ("input", "the generated functions take it and ignore it"),
                SymbolKind::Known => ("run-time constant", "the generated code never reads it"),
            };
            Some(warning(&symbol.name, noun, what))
        })
        .collect()
}

/// The warning under `name`: read nowhere, `what` follows, and what to write.
fn warning(name: &Name, noun: &str, what: &str) -> Warning {
    Warning {
        span: name.span,
        message: format!(
            "the {noun} `{}` is read by no expression and no option; {what}: use it in the \
             dynamics or an output, remove it, or declare it `#[allow(unused)]` if it is kept \
             on purpose",
            name.text
        ),
    }
}

/// Every name an expression or a generator option of `decl` reads.
fn names_read(decl: &ModelDecl) -> HashSet<&str> {
    let mut exprs: Vec<&SurfaceExpr> = decl.constants.iter().map(|c| &c.value).collect();
    exprs.extend(decl.outputs.iter().map(|o| &o.expr));
    for block in &decl.dynamics {
        if let DynamicsKind::Continuous { dt: Some(dt), .. } = &block.kind {
            exprs.push(dt);
        }
        exprs.extend(block.statements.iter().map(|s| match s {
            Statement::Let { value, .. } | Statement::Equation { value, .. } => value,
        }));
    }
    let mut read = HashSet::new();
    // An explicit stack: the front ends bound an expression's depth, but a walk that
    // cannot overflow needs no such promise.
    while let Some(expr) = exprs.pop() {
        match &expr.kind {
            SurfaceKind::Number(_) => {}
            SurfaceKind::Name(name) => {
                read.insert(name.as_str());
            }
            SurfaceKind::Neg(a) | SurfaceKind::Field(a, _) => exprs.push(a),
            SurfaceKind::Binary(_, a, b) => exprs.extend([&**a, &**b]),
            SurfaceKind::Call(_, args) => exprs.extend(args),
            SurfaceKind::If {
                lhs,
                rhs,
                then,
                otherwise,
                ..
            } => exprs.extend([&**lhs, &**rhs, &**then, &**otherwise]),
        }
    }
    for arg in decl.generate.iter().flat_map(|g| &g.args) {
        match &arg.value {
            ArgValue::Name(name) => {
                read.insert(name.text.as_str());
            }
            ArgValue::Names(names, _) => read.extend(names.iter().map(|n| n.text.as_str())),
            ArgValue::Number(..) | ArgValue::Numbers(..) | ArgValue::Table(..) => {}
        }
    }
    read
}

#[cfg(test)]
mod tests {
    use quote::quote;

    fn warned(tokens: proc_macro2::TokenStream) -> Vec<String> {
        let (decl, diag) = crate::front::macro_syntax::parse_model(tokens).expect("parses");
        assert!(!diag.has_errors(), "a valid model");
        super::unused_declarations(&decl)
            .into_iter()
            .map(|w| w.message)
            .collect()
    }

    #[test]
    fn a_symbol_read_anywhere_is_not_warned_about() {
        // `k` only in an output, `g` only through a `let`; `w` nowhere but kept on
        // purpose.
        let model = quote! {
            pub mod m {
                scalar f32;
                const TS = 0.01;
                state x1, x2;
                param k, #[allow(unused)] w;
                input u, v;
                known g;
                output y = x1, z = k * x2;
                generate lqr(horizon = 5, states = [x1, x2], input = v);
                dynamics discrete {
                    let force = g * u + v;
                    x1 = x1 + TS * x2;
                    x2 = x2 + TS * force;
                }
            }
        };
        assert_eq!(warned(model), Vec::<String>::new());
    }

    #[test]
    fn each_symbol_nothing_reads_is_warned_about_by_kind() {
        let model = quote! {
            pub mod m {
                scalar f32;
                state x;
                param k;
                input u;
                known g;
                dynamics discrete {
                    x = x;
                }
            }
        };
        let warnings = warned(model);
        let named = |start: &str| warnings.iter().any(|w| w.starts_with(start));
        assert_eq!(warnings.len(), 3, "{warnings:?}");
        assert!(
            named("the parameter `k` is read by no expression"),
            "{warnings:?}"
        );
        assert!(
            named("the input `u` is read by no expression"),
            "{warnings:?}"
        );
        assert!(named("the run-time constant `g` is read"), "{warnings:?}");
    }
}
