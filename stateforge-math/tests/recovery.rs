//! The helpers a generated filter's recovery and the DKF's design aid call: the count of
//! refusals in a row, the covariance's inflation, and the window length named for a noise.

use stateforge_math::{refusal_run_complete, NO_REFUSALS};

#[test]
fn a_run_of_refusals_completes_at_its_limit_and_starts_again() {
    let mut count = NO_REFUSALS;
    let completed: Vec<bool> = (0..7)
        .map(|_| refusal_run_complete(&mut count, 3))
        .collect();
    assert_eq!(completed, [false, false, true, false, false, true, false]);
    assert_eq!(count, 1);
    // A count at its largest saturates instead of overflowing.
    let mut full = u32::MAX;
    assert!(refusal_run_complete(&mut full, u32::MAX));
    assert_eq!(full, NO_REFUSALS);
}

#[test]
fn inflation_scales_by_a_factor_above_one_within_the_divergence_bound() {
    // A 2 x 2 covariance packed by its upper triangle: variances 1 and 4, covariance 0.5.
    let mut packed = [1.0_f64, 0.5, 4.0];
    assert!(stateforge_math::f64::inflate_covariance(&mut packed, 3.0));
    assert_eq!(packed, [3.0, 1.5, 12.0]);
    for refused in [0.5, 1.0, f64::NAN, 1e18] {
        let mut kept = [1.0_f64, 0.5, 4.0];
        assert!(
            !stateforge_math::f64::inflate_covariance(&mut kept, refused),
            "{refused}"
        );
        assert_eq!(kept, [1.0, 0.5, 4.0]);
    }
    let mut single = [1.0_f32, 0.5, 4.0];
    assert!(stateforge_math::f32::inflate_covariance(&mut single, 2.0));
    assert_eq!(single, [2.0, 1.0, 8.0]);
}

#[test]
fn the_window_named_averages_the_equation_noise_to_a_tenth_of_the_terms() {
    // Noise 0.024 against terms 0.058: (10 * 0.024 / 0.058)^2 = 17.1 -> 18 equations; a
    // minimum window of 4 outputs solving 2 parameters has 2, so 16 more outputs: 20.
    assert_eq!(
        stateforge_math::f64::window_len_for(0.024, 0.058, 4, 2),
        Some(20)
    );
    assert_eq!(
        stateforge_math::f32::window_len_for(0.024, 0.058, 4, 2),
        Some(20)
    );
    // Quiet enough for the minimum window: never shorter than it.
    assert_eq!(
        stateforge_math::f64::window_len_for(1e-6, 0.058, 4, 2),
        Some(4)
    );
    assert_eq!(
        stateforge_math::f64::window_len_for(0.0, 0.058, 5, 3),
        Some(5)
    );
    // Nothing to say, or beyond 100 000 equations.
    for (noise, terms) in [
        (0.024, 0.0),
        (0.024, -1.0),
        (f64::NAN, 1.0),
        (0.024, f64::INFINITY),
        (-1.0, 1.0),
        (1e3, 1e-3),
    ] {
        assert_eq!(
            stateforge_math::f64::window_len_for(noise, terms, 4, 2),
            None,
            "{noise} {terms}"
        );
    }
}
