//! `all_finite` against `is_finite` on every kind of value: zeros of both signs,
//! subnormals, the largest finite values, infinities and NaNs (quiet, signalling, with a
//! payload), alone and in every pair.

/// One of each kind of `f32`.
fn f32_cases() -> Vec<f32> {
    vec![
        0.0,
        -0.0,
        f32::from_bits(1),
        -f32::from_bits(1),
        f32::MIN_POSITIVE,
        1.0,
        -3.5,
        f32::MAX,
        f32::MIN,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
        f32::from_bits(0x7F80_0001),
        f32::from_bits(0xFFC0_1234),
    ]
}

fn f64_cases() -> Vec<f64> {
    vec![
        0.0,
        -0.0,
        f64::from_bits(1),
        f64::MIN_POSITIVE,
        -2.25,
        f64::MAX,
        f64::MIN,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NAN,
        f64::from_bits(0x7FF0_0000_0000_0001),
    ]
}

#[test]
fn f32_all_finite_agrees_with_is_finite_on_every_pair_and_triple() {
    let cases = f32_cases();
    assert!(stateforge_math::f32::all_finite([]));
    for &a in &cases {
        assert_eq!(
            stateforge_math::f32::all_finite([a]),
            a.is_finite(),
            "{a:e}"
        );
        for &b in &cases {
            let both = a.is_finite() && b.is_finite();
            assert_eq!(
                stateforge_math::f32::all_finite([a, b]),
                both,
                "{a:e} {b:e}"
            );
            for &c in &cases {
                let all = both && c.is_finite();
                assert_eq!(
                    stateforge_math::f32::all_finite([a, b, c]),
                    all,
                    "{a:e} {b:e} {c:e}"
                );
            }
        }
    }
    // Large finite values do not overflow the test (their differences are exact zeros).
    assert!(stateforge_math::f32::all_finite([f32::MAX; 32]));
}

#[test]
fn f64_all_finite_agrees_with_is_finite_on_every_pair() {
    let cases = f64_cases();
    assert!(stateforge_math::f64::all_finite([]));
    for &a in &cases {
        assert_eq!(
            stateforge_math::f64::all_finite([a]),
            a.is_finite(),
            "{a:e}"
        );
        for &b in &cases {
            let both = a.is_finite() && b.is_finite();
            assert_eq!(
                stateforge_math::f64::all_finite([a, b]),
                both,
                "{a:e} {b:e}"
            );
        }
    }
    assert!(stateforge_math::f64::all_finite([f64::MIN; 32]));
}

/// `upper_triangle_finite` reads the upper triangle and the diagonal, nothing else: every
/// kind of value at every place of a 3 x 3 matrix.
#[test]
fn upper_triangle_finite_tests_the_upper_triangle_only() {
    check_upper_triangle(1.0_f32, &f32_cases(), f32::is_finite, |m| {
        stateforge_math::f32::upper_triangle_finite(m)
    });
    check_upper_triangle(1.0_f64, &f64_cases(), f64::is_finite, |m| {
        stateforge_math::f64::upper_triangle_finite(m)
    });
}

/// Puts each of `cases` at each place of a 3 x 3 matrix of `one`s and checks that `test`
/// finds it finite exactly when it is below the diagonal or `finite`.
fn check_upper_triangle<T: Copy + std::fmt::Debug>(
    one: T,
    cases: &[T],
    finite: fn(T) -> bool,
    test: impl Fn(&[[T; 3]; 3]) -> bool,
) {
    for &value in cases {
        for (i, j) in (0..3).flat_map(|i| (0..3).map(move |j| (i, j))) {
            let mut m = [[one; 3]; 3];
            m[i][j] = value;
            let expected = i > j || finite(value);
            assert_eq!(test(&m), expected, "{value:?} at ({i}, {j})");
        }
    }
}
