//! The blade's first two bending modes (Takács et al., sect. 2: an aluminium blade
//! 550 x 40 x 3 mm clamped at one end, piezo patches "close to the fixed end", the laser
//! at the free end), from Euler-Bernoulli theory of a uniform cantilever, in the paper's
//! equivalent scale: each mode is normalised to a unit tip deflection, so the tip's
//! position is the sum of the modal coordinates and the first mode is the paper's
//! identified `m q'' + b q' + k q = c u` (sect. 4.1).
//!
//! What the theory gives (derived here, checked in the tests):
//! - the modes' wavenumbers `beta_i L`, roots of `cos x cosh x = -1` (1.8751, 4.6941), so
//!   the second natural frequency is `(beta_2 / beta_1)^2 = 6.267` times the first;
//! - a uniform cantilever's tip-normalised modal masses are equal (`int phi_i^2 dx =
//!   L phi_i(L)^2 / 4` for every mode), so both modes carry the paper's `m`;
//! - a patch bonded over `[x_a, x_b]` bends the blade by equal and opposite moments at its
//!   ends, whose work on mode `i` is proportional to `phi_i'(x_b) - phi_i'(x_a)` (the
//!   integral of the curvature under the patch); the second mode's input gain is the
//!   first's times the ratio of these, per unit tip deflection: -5.2 for a patch over the
//!   first 50.8 mm (opposite sign: the sensor at the tip and the actuator at the root are
//!   not collocated).
//!
//! The paper's `k/m = 2665 s^-2` (51.6 rad/s, 8.22 Hz) agrees with the first mode of the
//! bare blade for aluminium's typical `E = 70 GPa`, `rho = 2700 kg/m^3` (51.3 rad/s;
//! `first_mode_of_bare_blade`): the equivalent model's frequencies are the blade's.

/// The blade's free length \[m\] (sect. 2: 550 x 40 x 3 mm).
pub const LENGTH: f64 = 0.55;
/// Width and thickness \[m\] (sect. 2).
pub const WIDTH: f64 = 0.040;
pub const THICKNESS: f64 = 0.003;
/// Aluminium's typical Young's modulus \[Pa\] and density \[kg/m^3\]: not in the paper,
/// used only to check its identified frequency against the blade's dimensions.
pub const YOUNGS_MODULUS: f64 = 70e9;
pub const DENSITY: f64 = 2700.0;
/// Where the piezo patches sit \[m from the clamp\]: "close to the fixed end" (sect. 2);
/// the span, one QP16n's length of 2 in from the clamp, is our assumption (the coupling
/// ratio is -5.5 for a patch ending at 40 mm, -4.1 at 100 mm).
pub const PATCH: (f64, f64) = (0.0, 0.0508);

/// `beta_i L` of bending mode `mode` (0-based) of a clamped-free beam: the root of
/// `cos x cosh x + 1 = 0` within 1 of `(mode + 1/2) pi`, by bisection.
pub fn wavenumber(mode: usize) -> f64 {
    let centre = (mode as f64 + 0.5) * std::f64::consts::PI;
    bisection(|x| x.cos() * x.cosh() + 1.0, centre - 1.0, centre + 1.0)
}

/// A root of `f` between `lo` and `hi`, where `f` changes sign, by 200 bisections (to the
/// last bit of an `f64` of the size of a wavenumber).
pub fn bisection(f: impl Fn(f64) -> f64, mut lo: f64, mut hi: f64) -> f64 {
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if f(lo).signum() == f(mid).signum() {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The second mode's natural frequency over the first's, `(beta_2 / beta_1)^2` (6.267).
pub fn frequency_ratio() -> f64 {
    (wavenumber(1) / wavenumber(0)).powi(2)
}

/// Mode `mode`'s shape and its first two derivatives at `x` \[m\], in the classical
/// normalisation `cosh - cos - sigma (sinh - sin)` (tip value +-2).
pub fn shape(mode: usize, x: f64) -> [f64; 3] {
    let bl = wavenumber(mode);
    let beta = bl / LENGTH;
    let sigma = (bl.cosh() + bl.cos()) / (bl.sinh() + bl.sin());
    let z = beta * x;
    let (ch, c, sh, s) = (z.cosh(), z.cos(), z.sinh(), z.sin());
    [
        ch - c - sigma * (sh - s),
        beta * (sh + s - sigma * (ch - c)),
        beta * beta * (ch + c - sigma * (sh + s)),
    ]
}

/// Mode `mode`'s coupling to the patch, per unit tip deflection: `(phi'(x_b) -
/// phi'(x_a)) / phi(L)`, the work of the patch's end moments.
pub fn patch_coupling(mode: usize, (x_a, x_b): (f64, f64)) -> f64 {
    (shape(mode, x_b)[1] - shape(mode, x_a)[1]) / shape(mode, LENGTH)[0]
}

/// The second mode's input gain over the first's, both per unit tip deflection.
pub fn coupling_ratio() -> f64 {
    patch_coupling(1, PATCH) / patch_coupling(0, PATCH)
}

/// The first natural frequency \[rad/s\] of the bare blade from its dimensions and
/// aluminium's typical constants: `(beta_1 L)^2 sqrt(E I / (rho A L^4))`.
pub fn first_mode_of_bare_blade() -> f64 {
    let inertia = WIDTH * THICKNESS.powi(3) / 12.0;
    let per_length = DENSITY * WIDTH * THICKNESS;
    wavenumber(0).powi(2) * (YOUNGS_MODULUS * inertia / (per_length * LENGTH.powi(4))).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The integral of `f` over `[0, L]` by Simpson's rule on 20000 intervals.
    fn integral(f: impl Fn(f64) -> f64) -> f64 {
        let n = 20_000;
        let h = LENGTH / n as f64;
        let sum: f64 = (0..=n)
            .map(|i| {
                let weight = if i == 0 || i == n {
                    1.0
                } else if i % 2 == 1 {
                    4.0
                } else {
                    2.0
                };
                weight * f(i as f64 * h)
            })
            .sum();
        sum * h / 3.0
    }

    #[test]
    fn wavenumbers_are_the_clamped_free_roots() {
        // The tabulated roots of cos x cosh x = -1 (e.g. Inman, "Engineering Vibration").
        assert!((wavenumber(0) - 1.875_104).abs() < 1e-6);
        assert!((wavenumber(1) - 4.694_091).abs() < 1e-6);
        assert!((frequency_ratio() - 6.2669).abs() < 1e-4);
    }

    #[test]
    fn shapes_meet_the_clamped_free_conditions_and_have_equal_tip_normalised_masses() {
        for mode in 0..2 {
            let [w0, slope0, _] = shape(mode, 0.0);
            assert!(w0.abs() < 1e-12 && slope0.abs() < 1e-12);
            // Free end: no bending moment (curvature).
            let [tip, _, curvature] = shape(mode, LENGTH);
            let scale = wavenumber(mode).powi(2) / LENGTH.powi(2);
            assert!(curvature.abs() < 1e-9 * scale, "{curvature}");
            assert!((tip.abs() - 2.0).abs() < 1e-9);
            let mass = integral(|x| shape(mode, x)[0].powi(2)) / (LENGTH * tip * tip);
            assert!((mass - 0.25).abs() < 1e-9, "mode {mode}: {mass}");
        }
    }

    #[test]
    fn patch_coupling_is_the_integral_of_the_curvature() {
        for mode in 0..2 {
            let (x_a, x_b) = PATCH;
            let n = 2000;
            let h = (x_b - x_a) / n as f64;
            let trapezoid: f64 = (0..n)
                .map(|i| {
                    let x = x_a + i as f64 * h;
                    0.5 * h * (shape(mode, x)[2] + shape(mode, x + h)[2])
                })
                .sum();
            let expected = trapezoid / shape(mode, LENGTH)[0];
            assert!((patch_coupling(mode, PATCH) - expected).abs() < 1e-6 * expected.abs());
        }
        let ratio = coupling_ratio();
        assert!((-5.3..-5.1).contains(&ratio), "{ratio}");
    }

    #[test]
    fn the_papers_frequency_is_the_bare_blades_first_mode() {
        let paper = (533.0f64 / 0.20).sqrt();
        let blade = first_mode_of_bare_blade();
        assert!((blade / paper - 1.0).abs() < 0.01, "{blade} vs {paper}");
    }
}
