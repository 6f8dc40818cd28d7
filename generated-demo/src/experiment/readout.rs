//! Physical parameters (wn, zeta, alpha) from an estimate of the Euler model's (x3, x4, x5).
//!
//! At TS = 15 ms the Euler model cannot hold the physical parameters (it is unstable for
//! TS > 2 zeta / wn), so a filter on it converges to Euler-equivalent values. The naive
//! read-out of those gives wn = 19.85, zeta = 0.175 for a 20 rad/s, zeta = 0.026 beam;
//! mapping the model's discrete poles back to continuous time gives 20 and 0.026
//! (the notes, "Simulating the cantilever"). Both are offered so reports can show both.

use super::plant::Physical;
use super::TS;

/// All three parameters NaN: the value of an undefined read-out in tables and series.
pub const UNDEFINED: Physical = Physical {
    wn: f64::NAN,
    zeta: f64::NAN,
    alpha: f64::NAN,
};

/// The read-out, or [`UNDEFINED`] when there is none.
pub fn or_nan(readout: Option<Physical>) -> Physical {
    readout.unwrap_or(UNDEFINED)
}

/// The paper's definitions read literally: wn = sqrt(-x3), zeta = -x4 / (2 wn), alpha = x5.
/// None if an input is not finite or x3 >= 0 (no oscillating mode).
pub fn naive(x3: f64, x4: f64, x5: f64) -> Option<Physical> {
    if !(x3.is_finite() && x4.is_finite() && x5.is_finite()) || x3 >= 0.0 {
        return None;
    }
    let wn = (-x3).sqrt();
    Some(Physical {
        wn,
        zeta: -x4 / (2.0 * wn),
        alpha: x5,
    })
}

/// The continuous mode whose exactly sampled poles are the poles of the Euler model
/// [[1, TS], [TS x3, 1 + TS x4]]: s = ln z / TS, wn = |s|, zeta = -Re s / |s| (for real
/// poles wn^2 = s1 s2, zeta = -(s1 + s2) / (2 wn)), and alpha from the DC gain match
/// alpha / wn^2 = -x5 / x3. The inverse of [`super::plant::euler_equivalent`].
///
/// None if an input is not finite, a real pole is <= 0 (no continuous counterpart), the
/// continuous poles are real with opposite signs (no wn), or x3 = 0 (no DC gain).
pub fn from_poles(x3: f64, x4: f64, x5: f64) -> Option<Physical> {
    if !(x3.is_finite() && x4.is_finite() && x5.is_finite()) || x3 == 0.0 {
        return None;
    }
    let trace = 2.0 + TS * x4;
    let det = 1.0 + TS * x4 - TS * TS * x3;
    let disc = trace * trace - 4.0 * det;
    let (wn, zeta) = if disc < 0.0 {
        // Complex pair z = r e^{+-j theta} with r^2 = det > 0: s = (ln r +- j theta) / TS.
        let re = 0.5 * det.ln() / TS;
        let im = (0.5 * (-disc).sqrt()).atan2(0.5 * trace) / TS;
        let wn = re.hypot(im);
        (wn, -re / wn)
    } else {
        let root = disc.sqrt();
        let (z1, z2) = (0.5 * (trace - root), 0.5 * (trace + root));
        if z1 <= 0.0 || z2 <= 0.0 {
            return None;
        }
        let (s1, s2) = (z1.ln() / TS, z2.ln() / TS);
        let wn2 = s1 * s2;
        if wn2 <= 0.0 {
            return None;
        }
        let wn = wn2.sqrt();
        (wn, -(s1 + s2) / (2.0 * wn))
    };
    let alpha = -x5 / x3 * wn * wn;
    [wn, zeta, alpha]
        .iter()
        .all(|v| v.is_finite())
        .then_some(Physical { wn, zeta, alpha })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::experiment::plant::euler_equivalent;

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol * b.abs().max(1.0)
    }

    #[test]
    fn from_poles_inverts_euler_equivalent() {
        for (wn, zeta, alpha) in [
            (20.0, 0.026, 0.5),
            (50.0, 0.026, 3.125),
            (30.0, 0.7, -0.2),
            (10.0, 1.5, 1.0),
        ] {
            let [x3, x4, x5] = euler_equivalent(wn, zeta, alpha);
            let p = from_poles(x3, x4, x5).unwrap();
            assert!(close(p.wn, wn, 1e-9), "{p:?}");
            assert!(close(p.zeta, zeta, 1e-9), "{p:?}");
            assert!(close(p.alpha, alpha, 1e-9), "{p:?}");
        }
    }

    #[test]
    fn naive_readout_is_biased_as_the_note_says() {
        let [x3, x4, x5] = euler_equivalent(20.0, 0.026, 0.5);
        let p = naive(x3, x4, x5).unwrap();
        assert!((p.wn - 19.85).abs() < 0.01, "{p:?}");
        assert!((p.zeta - 0.175).abs() < 0.001, "{p:?}");
        assert_eq!(p.alpha, x5);
        // Exact on the paper's definitions.
        let p = naive(-400.0, -1.04, 0.5).unwrap();
        assert!(close(p.wn, 20.0, 1e-12) && close(p.zeta, 0.026, 1e-12));
    }

    #[test]
    fn invalid_estimates_give_none() {
        assert!(from_poles(f64::NAN, -1.0, 0.5).is_none());
        assert!(from_poles(-400.0, f64::INFINITY, 0.5).is_none());
        assert!(from_poles(0.0, -1.0, 0.5).is_none());
        assert!(naive(f64::NAN, -1.0, 0.5).is_none());
        assert!(naive(400.0, -1.0, 0.5).is_none());
        // x3 > 0: real continuous poles of opposite sign (a saddle).
        assert!(from_poles(400.0, -1.0, 0.5).is_none());
        // A negative real pole z has no continuous counterpart.
        assert!(from_poles(-400.0, -300.0, 0.5).is_none());
        // The paper's wrong initial guess reads out as an unstable mode (zeta < 0).
        assert!(from_poles(-50000.0, -10.0, 0.01).unwrap().zeta < 0.0);
        assert!(or_nan(None).wn.is_nan());
    }
}
