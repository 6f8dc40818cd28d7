//! The reconstructed piecewise beam (the piecewise-linear beam report; its Appendix 1 matrices were lost in the
//! OCR) has the modes its documentation states, computed here with nalgebra from the
//! generated constants: first mode 15.9 Hz free and 26.0 Hz with the one-sided spring
//! engaged, second mode near 56 Hz (the lightly damped observer pole -8 +- 358i of
//! sect. 5.2 is 57 Hz), and a generalized mode near 200 Hz; Rayleigh damping of 1 % at 16 Hz, 2 % at 56 Hz, 6 % at
//! 200 Hz.

use generated_demo::piecewise_beam::in_f64 as beam;
use nalgebra::{DMatrix, Matrix3};

/// Natural frequencies [Hz] and damping ratios of the continuous model, lowest first.
fn modes(engaged: bool) -> Vec<(f64, f64)> {
    use beam::*;
    let m = Matrix3::new(M11, M12, M13, M12, M22, M23, M13, M23, M33);
    let mut k = Matrix3::new(K11, K12, K13, K12, K22, K23, K13, K23, K33);
    if engaged {
        k[(1, 1)] += K_NL;
    }
    let b = Matrix3::new(B11, B12, B13, B12, B22, B23, B13, B23, B33);
    let mi = m.try_inverse().unwrap();
    let mut a = DMatrix::zeros(6, 6);
    for i in 0..3 {
        a[(i, i + 3)] = 1.0;
        for j in 0..3 {
            a[(i + 3, j)] = -(mi * k)[(i, j)];
            a[(i + 3, j + 3)] = -(mi * b)[(i, j)];
        }
    }
    let mut modes: Vec<(f64, f64)> = a
        .complex_eigenvalues()
        .iter()
        .filter(|l| l.im > 0.0)
        .map(|l| (l.norm() / (2.0 * std::f64::consts::PI), -l.re / l.norm()))
        .collect();
    modes.sort_by(|x, y| x.0.total_cmp(&y.0));
    modes
}

#[test]
fn reconstructed_beam_has_the_documented_modes() {
    let free = modes(false);
    let engaged = modes(true);
    println!("free: {free:?}\nengaged: {engaged:?}");
    assert_eq!(free.len(), 3);
    let near = |got: f64, want: f64| (got - want).abs() < 0.03 * want;
    assert!(near(free[0].0, 15.9), "{free:?}");
    assert!(near(engaged[0].0, 26.0), "{engaged:?}");
    assert!(near(free[1].0, 56.0), "{free:?}");
    assert!(near(free[2].0, 200.0), "{free:?}");
    assert!(near(free[0].1, 0.01) && near(free[1].1, 0.019), "{free:?}");
    assert!(near(free[2].1, 0.063), "{free:?}");
    // The bilinear frequency 2 f1 f2 / (f1 + f2), where the 1-periodic resonance sits.
    let bilinear = 2.0 * free[0].0 * engaged[0].0 / (free[0].0 + engaged[0].0);
    assert!(near(bilinear, 19.7), "{bilinear}");
}
