//! Generated code is straight-line float arithmetic: no heap, no `unsafe`, nothing that can
//! panic. Checked on the syntax tree of every demo and test model's generated module, in both
//! scalar types: any construct outside an allow-list fails the test. The loops allowed run
//! over a constant range with no counter: the LQR's `for _ in 0..Self::HORIZON` and the
//! integration sub-steps, `for _ in 0..Self::SUBSTEPS` or `0..F_SUBSTEPS`; the only method
//! calls are `is_finite`, `is_nan` and the generated type's own methods on `self`; the
//! only function calls the runtime crate's, the type's own (`Self::..`) and the module's
//! model function `f`.

use syn::visit::Visit;
use tests::{demo_model_code, test_model_code, DEMO_MODELS, TEST_MODELS};

/// What the walk found that generated code must not contain.
#[derive(Default)]
struct Findings {
    problems: Vec<String>,
}

impl<'ast> Visit<'ast> for Findings {
    fn visit_expr(&mut self, e: &'ast syn::Expr) {
        use syn::Expr;
        let problem = match e {
            // Indexing can panic: generated code destructures arrays instead.
            Expr::Index(_) => Some("indexing"),
            Expr::MethodCall(m) => {
                let on_self = matches!(&*m.receiver, Expr::Path(p) if p.path.is_ident("self"));
                match m.method.to_string().as_str() {
                    "unwrap" | "expect" => Some("unwrap/expect"),
                    "is_finite" | "is_nan" if m.args.is_empty() => None,
                    _ if on_self => None,
                    _ => Some("a method call"),
                }
            }
            Expr::ForLoop(f) if is_horizon_loop(f) => {
                // Only the body is code of interest; the header is a constant range.
                syn::visit::visit_block(self, &f.body);
                return;
            }
            Expr::Unsafe(_) => Some("unsafe"),
            Expr::Loop(_) | Expr::While(_) | Expr::ForLoop(_) => Some("a loop"),
            Expr::Cast(_) => Some("a cast"),
            Expr::Range(_) => Some("a range (slicing)"),
            Expr::Call(call) => match &*call.func {
                // The only calls are the runtime crate's functions of floats.
                Expr::Path(p)
                    if p.path
                        .segments
                        .first()
                        .is_some_and(|s| s.ident == "stateforge_math") =>
                {
                    None
                }
                // `Some(..)`, `Ok(..)` and `Err(..)` build a value (the LQR's
                // `steady_state_input`, the MPC's results); they call nothing.
                Expr::Path(p) if ["Some", "Ok", "Err"].iter().any(|c| p.path.is_ident(c)) => None,
                // The generated type's own associated functions (`Self::prediction_model`).
                Expr::Path(p) if p.path.segments.first().is_some_and(|s| s.ident == "Self") => None,
                // The module's own model function `f` (itself walked as generated code),
                // which a delayed horizon's output predictor runs on the buffered inputs.
                Expr::Path(p) if p.path.is_ident("f") => None,
                _ => Some("a call of something other than stateforge_math"),
            },
            Expr::Lit(lit) => match &lit.lit {
                syn::Lit::Float(f) if matches!(f.suffix(), "f32" | "f64") => None,
                // The DKF window's fill flags.
                syn::Lit::Bool(_) => None,
                // Integer arithmetic could overflow; integers appear only in consts.
                _ => Some("an untyped or non-float literal in code"),
            },
            _ => None,
        };
        if let Some(problem) = problem {
            self.problems
                .push(format!("{problem}: `{}`", quote_expr(e)));
        }
        syn::visit::visit_expr(self, e);
    }

    fn visit_macro(&mut self, m: &'ast syn::Macro) {
        let name = m.path.segments.last().map(|s| s.ident.to_string());
        self.problems.push(format!(
            "a macro (panic!, assert!, vec!, ...): `{}!`",
            name.unwrap_or_default()
        ));
    }

    fn visit_attribute(&mut self, _: &'ast syn::Attribute) {
        // Doc comments and `#[inline]`: no code.
    }

    fn visit_type_array(&mut self, a: &'ast syn::TypeArray) {
        // The length is a compile-time constant; only the element type is of interest.
        self.visit_type(&a.elem);
    }

    fn visit_generic_argument(&mut self, a: &'ast syn::GenericArgument) {
        // A const generic argument (`HeldLimits<12, 30>`) is a compile-time constant, as
        // an array's length is.
        if !matches!(a, syn::GenericArgument::Const(_)) {
            syn::visit::visit_generic_argument(self, a);
        }
    }

    fn visit_impl_item_const(&mut self, _: &'ast syn::ImplItemConst) {
        // An associated constant (the LQR horizon): evaluated at compile time.
    }

    fn visit_expr_struct(&mut self, s: &'ast syn::ExprStruct) {
        // A whole number stored in a field (the MPC status's `iterations: 0`) is data, not
        // integer arithmetic; every other field value is code.
        for field in &s.fields {
            let stored =
                matches!(&field.expr, syn::Expr::Lit(l) if matches!(l.lit, syn::Lit::Int(_)));
            if !stored {
                self.visit_expr(&field.expr);
            }
        }
        if let Some(rest) = &s.rest {
            self.visit_expr(rest);
        }
    }

    fn visit_expr_repeat(&mut self, r: &'ast syn::ExprRepeat) {
        // `[v; N]`: the length is a compile-time constant; the value is code.
        self.visit_expr(&r.expr);
    }

    fn visit_item_const(&mut self, c: &'ast syn::ItemConst) {
        // Constants are evaluated at compile time; a panic there is a build error, and
        // they hold the integer and bool tables (dimensions, zero patterns).
        let _ = c;
    }

    fn visit_path(&mut self, p: &'ast syn::Path) {
        for segment in &p.segments {
            let name = segment.ident.to_string();
            if ["alloc", "Vec", "Box", "String", "std"].contains(&name.as_str()) {
                self.problems.push(format!("heap or std: `{name}`"));
            }
        }
        syn::visit::visit_path(self, p);
    }

    fn visit_item_fn(&mut self, f: &'ast syn::ItemFn) {
        if matches!(f.sig.safety, syn::Safety::Unsafe(_)) {
            self.problems.push(format!("unsafe fn `{}`", f.sig.ident));
        }
        syn::visit::visit_item_fn(self, f);
    }
}

/// `for _ in 0..Self::HORIZON { .. }` (the LQR's horizon), `for _ in 0..Self::SUBSTEP_PAIRS`
/// (a continuous filter's sub-steps, two per iteration), `for _ in 0..F_SUBSTEP_PAIRS` (a
/// looped `f`), the MPC's
/// `MAX_SQUARINGS` and `RICCATI_ITERATIONS`: a constant number of iterations, with no
/// counter the body could misuse; or the MPC's `for pass in 1..=Self::PASSES`, whose
/// counter is only recorded and compared (the body has no indexing or integer
/// arithmetic, which the walk checks as everywhere else).
fn is_horizon_loop(f: &syn::ExprForLoop) -> bool {
    if is_iteration_loop(f) {
        return true;
    }
    let constant_end = |p: &syn::ExprPath| {
        p.path.segments.last().is_some_and(|s| {
            [
                "HORIZON",
                "SUBSTEP_PAIRS",
                "F_SUBSTEP_PAIRS",
                "MAX_SQUARINGS",
                "RICCATI_ITERATIONS",
            ]
            .iter()
            .any(|name| s.ident == name)
        })
    };
    let range_ok = match &*f.expr {
        syn::Expr::Range(r) => {
            matches!(r.start.as_deref(), Some(syn::Expr::Lit(l)) if matches!(&l.lit, syn::Lit::Int(i) if i.base10_digits() == "0"))
                && matches!(r.end.as_deref(), Some(syn::Expr::Path(p)) if constant_end(p))
        }
        _ => false,
    };
    matches!(&*f.pat, syn::Pat::Wild(_)) && range_ok
}

/// `for pass in 1..=Self::PASSES`.
fn is_iteration_loop(f: &syn::ExprForLoop) -> bool {
    let pattern_ok = matches!(&*f.pat, syn::Pat::Ident(p) if p.ident == "pass");
    let range_ok = match &*f.expr {
        syn::Expr::Range(r) => {
            matches!(r.limits, syn::RangeLimits::Closed(_))
                && matches!(r.start.as_deref(), Some(syn::Expr::Lit(l)) if matches!(&l.lit, syn::Lit::Int(i) if i.base10_digits() == "1"))
                && matches!(r.end.as_deref(), Some(syn::Expr::Path(p)) if p.path.segments.last().is_some_and(|s| s.ident == "PASSES"))
        }
        _ => false,
    };
    pattern_ok && range_ok
}

fn quote_expr(e: &syn::Expr) -> String {
    use quote::ToTokens;
    e.to_token_stream().to_string()
}

#[test]
fn generated_code_has_no_heap_unsafe_or_panicking_operation() {
    let demo = DEMO_MODELS.iter().map(|name| (name, demo_model_code(name)));
    let test = TEST_MODELS.iter().map(|name| (name, test_model_code(name)));
    for (name, code) in demo.chain(test) {
        let file: syn::File = syn::parse_str(&code).expect("parses");
        let mut findings = Findings::default();
        findings.visit_file(&file);
        assert!(
            findings.problems.is_empty(),
            "{name}: generated code contains {:#?}",
            findings.problems
        );
    }
}

#[test]
fn the_check_rejects_what_it_should() {
    let bad = r#"
        pub fn f(x: &[f32; 2], v: Vec<f32>) -> f32 {
            let a = x[0] + 1;
            let b = v.first().unwrap();
            assert!(a > 0.0);
            for i in 0..v.len() {}
            a + f32::sqrt(b)
        }
    "#;
    let file: syn::File = syn::parse_str(bad).expect("parses");
    let mut findings = Findings::default();
    findings.visit_file(&file);
    let all = findings.problems.join("\n");
    for expected in [
        "indexing",
        "unwrap",
        "a macro",
        "non-float literal",
        "Vec",
        "other than stateforge_math",
    ] {
        assert!(all.contains(expected), "missed {expected} in:\n{all}");
    }
}
