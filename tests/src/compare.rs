//! Comparisons of two runs' numbers: the largest difference, relative to the scale of the
//! run compared against.

/// The largest entry-wise difference of `got` from `want`, relative to the largest
/// magnitude in `want`; infinite where an entry of either is not finite (`f64::max` would
/// pass over a NaN).
pub fn largest_relative_difference(got: &[f64], want: &[f64]) -> f64 {
    if got.iter().chain(want).any(|v| !v.is_finite()) {
        return f64::INFINITY;
    }
    let scale = want.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    let worst = got
        .iter()
        .zip(want)
        .fold(0.0_f64, |m, (g, w)| m.max((g - w).abs()));
    worst / scale
}

/// An estimate and its covariance, as a filter's `state()` and `covariance()` return them.
pub type Estimate<const N: usize> = ([f64; N], [[f64; N]; N]);

/// The largest difference of the estimate `got` from `want`, state and covariance's upper
/// triangle together, relative to the largest magnitude in `want`.
pub fn estimate_difference<const N: usize>(got: Estimate<N>, want: Estimate<N>) -> f64 {
    let flat = |(x, p): Estimate<N>| -> Vec<f64> {
        let upper = (0..N).flat_map(move |i| (i..N).map(move |j| p[i][j]));
        x.into_iter().chain(upper).collect()
    };
    largest_relative_difference(&flat(got), &flat(want))
}

/// Asserts that each pair of estimates (two ways to the same estimate: a filter's `step`
/// and its `predict` then `update`, say) agree within `1e-12` at `sample`, and returns the
/// largest difference.
pub fn assert_same_estimates<const N: usize>(
    sample: usize,
    pairs: &[(Estimate<N>, Estimate<N>)],
) -> f64 {
    let mut worst = 0.0_f64;
    for &(stepped, split) in pairs {
        let d = estimate_difference(stepped, split);
        assert!(
            d <= 1e-12,
            "sample {sample}: the two estimates differ by {d:e}"
        );
        worst = worst.max(d);
    }
    worst
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_difference_is_relative_to_the_largest_wanted_entry() {
        assert_eq!(largest_relative_difference(&[1.0, 4.5], &[1.5, 4.0]), 0.125);
        let want = ([1.0, 0.0], [[2.0, 0.5], [0.5, 4.0]]);
        // p21 is not read: only the upper triangle counts.
        let got = ([1.0, 0.0], [[2.0, 0.5], [9.0, 3.0]]);
        assert_eq!(estimate_difference(got, want), 0.25);
        assert_eq!(
            largest_relative_difference(&[f64::NAN], &[1.0]),
            f64::INFINITY
        );
    }
}
