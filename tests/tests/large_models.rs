//! Large models generate code whose size grows with the covariance's entries, not faster,
//! and whose shape rustc compiles without deep recursion: expressions nest shallowly and
//! no block holds thousands of `let`s (each opens a scope nested in the last, which
//! rustc's debug information walks recursively). Parenthesised subexpressions nest
//! shallowly too: rustfmt's time grows exponentially with that nesting (a 20-deep sum
//! took it over two minutes), and `stateforge-codegen` formats with rustfmt.
//! `cargo run --release -p tests --example build_scale` measures what building such models
//! costs.

use syn::visit::Visit;
use tests::scale::integrator_chain;

/// The deepest expression nesting, the deepest nesting of parentheses, and the most
/// statements in one block.
#[derive(Default)]
struct Shape {
    depth: usize,
    deepest: usize,
    parens: usize,
    deepest_parens: usize,
    longest_block: usize,
}

impl<'ast> Visit<'ast> for Shape {
    fn visit_expr(&mut self, e: &'ast syn::Expr) {
        let paren = matches!(e, syn::Expr::Paren(_));
        self.depth += 1;
        self.parens += usize::from(paren);
        self.deepest = self.deepest.max(self.depth);
        self.deepest_parens = self.deepest_parens.max(self.parens);
        syn::visit::visit_expr(self, e);
        self.parens -= usize::from(paren);
        self.depth -= 1;
    }

    fn visit_block(&mut self, b: &'ast syn::Block) {
        self.longest_block = self.longest_block.max(b.stmts.len());
        syn::visit::visit_block(self, b);
    }
}

fn generated(n: usize) -> (usize, Shape) {
    let tokens = stateforge_compiler::expand_macro_source(&integrator_chain(n, true))
        .unwrap_or_else(|e| panic!("the {n}-state chain does not expand: {e}"));
    let file: syn::File = syn::parse2(tokens.clone()).expect("generated code parses");
    let mut shape = Shape::default();
    shape.visit_file(&file);
    (tokens.into_iter().count(), shape)
}

#[test]
fn a_100_state_ekf_is_shallow_and_its_size_grows_with_the_covariance() {
    let (small_size, _) = generated(50);
    let (size, shape) = generated(100);
    // A right-nested 100-term sum (the check that the new estimate is finite) was 200
    // levels deep; the lowering now names a part of anything nested past 24 operations.
    assert!(
        shape.deepest <= 64,
        "expressions nest {} deep",
        shape.deepest
    );
    // Balanced trees nest logarithmically: the constructor's finiteness test of the 5050
    // covariance entries, halved 8 times, nests 10 parentheses deep, the step's probe of
    // 200 terms summed pairwise 8. Summed one term after the other, the probe nested 24
    // (the lowering names a part past 24 operations), and rustfmt did not finish the
    // code of a 10-state chain in two minutes.
    assert!(
        shape.deepest_parens <= 12,
        "parentheses nest {} deep",
        shape.deepest_parens
    );
    assert!(
        shape.longest_block <= stateforge_compiler::emit::scopes::BLOCK_LEN + 8,
        "a block holds {} statements",
        shape.longest_block
    );
    // The covariance has n (n + 1) / 2 entries: doubling n multiplies them by about 4.
    // (Reading each entry by a one-name pattern made it 16.)
    let growth = size as f64 / small_size as f64;
    assert!(
        growth < 4.5,
        "code grew {growth:.1} times from 50 to 100 states"
    );
}

#[test]
fn ten_thousand_chained_lets_expand_without_exhausting_the_stack() {
    // Each intermediate uses the last, so the graph is 10,000 operations deep: the passes
    // over it (differentiation, substitution, lowering) must not recurse per level.
    let mut lets = String::new();
    for i in 1..=10_000 {
        lets += &format!("let a{i} = a{} * x1 + 1.0;\n", i - 1);
    }
    let source = format!(
        "model! {{ pub mod chained {{ scalar f64; state x1; input u; output y = x1;
         dynamics discrete {{ let a0 = x1; {lets} x1 = a10000 + u; }} }} }}"
    );
    let tokens = stateforge_compiler::expand_macro_source(&source).expect("the chain expands");
    let file: syn::File = syn::parse2(tokens).expect("generated code parses");
    let mut shape = Shape::default();
    shape.visit_file(&file);
    assert!(
        shape.deepest <= 64,
        "expressions nest {} deep",
        shape.deepest
    );
}

/// Expands `source` on a thread with a 2 MiB stack, a test thread's (the macro runs on
/// rustc's, which is larger): whether it finished without overflowing.
fn expands_in_two_mebibytes(source: String) -> bool {
    let expand = move || stateforge_compiler::expand_macro_source(&source).is_ok();
    let thread = std::thread::Builder::new()
        .stack_size(2 << 20)
        .spawn(expand);
    thread.expect("a thread starts").join().unwrap_or(false)
}

#[test]
fn the_longest_sums_the_front_end_accepts_resolve_on_a_small_stack() {
    // 512 operators, the most one expression may hold, nest 512 deep in the syntax tree:
    // resolving a name, a sum or a vector's sum recurses once per level, each level's
    // frame kept small (a frame of 9 KiB per level overflowed at 250 terms).
    let terms = 511;
    let scalars = vec!["x"; terms].join(" + ");
    let vectors = vec!["v"; terms].join(" + ");
    for (input, rhs) in [("", scalars), ("input v: Vec3;", format!("({vectors}).x"))] {
        let source = format!(
            "model! {{ pub mod long {{ scalar f32; state x; {input} output y = x;
             dynamics discrete {{ x = {rhs}; }} }} }}"
        );
        assert!(expands_in_two_mebibytes(source), "a sum of {terms} terms");
    }
}
