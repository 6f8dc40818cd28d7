//! Scalar summaries of a time series over a time interval (Table 1 averages over 2-15 s).
//!
//! A series is a pair of equal-length slices (times, values); the interval [from, to] is
//! closed. Non-finite values propagate (a diverged filter must not look converged), and an
//! interval without samples gives NaN.

/// Values of `v` whose time in `t` lies in [from, to].
fn window<'a>(t: &'a [f64], v: &'a [f64], from: f64, to: f64) -> impl Iterator<Item = f64> + 'a {
    debug_assert_eq!(t.len(), v.len(), "times and values differ in length");
    t.iter()
        .zip(v)
        .filter(move |(t, _)| (from..=to).contains(*t))
        .map(|(_, v)| *v)
}

/// Mean of `v` over the samples with time in [from, to]; NaN if there are none.
pub fn mean(t: &[f64], v: &[f64], from: f64, to: f64) -> f64 {
    let (sum, n) = window(t, v, from, to).fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
    if n == 0 {
        f64::NAN
    } else {
        sum / n as f64
    }
}

/// Root mean square of `v` over the samples with time in [from, to]; NaN if there are none.
pub fn rms(t: &[f64], v: &[f64], from: f64, to: f64) -> f64 {
    let (sum, n) = window(t, v, from, to).fold((0.0, 0usize), |(s, n), v| (s + v * v, n + 1));
    if n == 0 {
        f64::NAN
    } else {
        (sum / n as f64).sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mean_and_rms_over_a_closed_interval() {
        let t = [0.0, 1.0, 2.0, 3.0, 4.0];
        let v = [100.0, 3.0, -4.0, 3.0, 100.0];
        assert_eq!(mean(&t, &v, 1.0, 3.0), 2.0 / 3.0);
        assert_eq!(rms(&t, &v, 1.0, 2.0), 12.5f64.sqrt());
        assert!(mean(&t, &v, 5.0, 6.0).is_nan());
        assert!(rms(&t, &[0.0, f64::NAN, 0.0, 0.0, 0.0], 0.0, 4.0).is_nan());
    }
}
