//! Bad models fail to compile with errors under the offending tokens. Each case in
//! `tests/ui/` holds one mistake (one holds several, all reported at once); its `.stderr`
//! is the expected compiler output.

#[test]
fn bad_models_are_compile_errors_at_the_offending_token() {
    let cases = trybuild::TestCases::new();
    cases.compile_fail("ui/*.rs");
    // Models at the edges of what a generator accepts compile and run.
    cases.pass("ui-pass/*.rs");
}
