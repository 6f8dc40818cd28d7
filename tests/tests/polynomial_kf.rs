//! The generated polynomial Kalman filter (the polynomial Kalman filter paper) against a dense nalgebra reference
//! written from the paper's equations: prediction with `Phi(1)` (eq. 5-6), gain and update
//! with `S = (I - K M) S1` (eq. 7-9), and re-initialisation by a least-squares fit solved
//! with nalgebra's SVD, with covariance `sigma^2 (H'H)^-1`.

use generated_demo::polynomial::in_f64::{PolynomialKf, Status};
use nalgebra::{DMatrix, DVector};

const N: usize = 4;

/// `Phi(1)`: entry `(i, j)` is the binomial coefficient `C(j, i)`.
fn phi() -> DMatrix<f64> {
    DMatrix::from_fn(N, N, |i, j| {
        if j < i {
            0.0
        } else {
            (0..i).fold(1.0, |c, k| c * (j - k) as f64 / (k + 1) as f64)
        }
    })
}

/// The design matrix of the window fit in raw samples, `H[i][j] = h_i^j`, `h_i` from
/// `-(window - 1)` to 0.
fn design(window: usize) -> DMatrix<f64> {
    DMatrix::from_fn(window, N, |i, j| {
        (i as f64 - (window - 1) as f64).powi(j as i32)
    })
}

struct Reference {
    x: DVector<f64>,
    s: DMatrix<f64>,
    window: Vec<f64>,
    since: usize,
}

impl Reference {
    fn step(&mut self, y: f64) {
        self.window.push(y);
        if self.window.len() > PolynomialKf::WINDOW {
            self.window.remove(0);
        }
        self.since += 1;
        if self.since >= PolynomialKf::REINIT_EVERY && self.window.len() == PolynomialKf::WINDOW {
            let h = design(PolynomialKf::WINDOW);
            let svd = h.clone().svd(true, true);
            self.x = svd
                .solve(&DVector::from_vec(self.window.clone()), 1e-14)
                .unwrap();
            let sigma2 = generated_demo::polynomial::in_f64::SIGMA2;
            self.s = (h.transpose() * h).try_inverse().unwrap() * sigma2;
            self.since = 0;
            return;
        }
        let phi = phi();
        let fade = generated_demo::polynomial::in_f64::FADE;
        let x1 = &phi * &self.x;
        let s1 = &phi * &self.s * phi.transpose() + DMatrix::identity(N, N) * fade;
        let m = DMatrix::from_fn(1, N, |_, j| if j == 0 { 1.0 } else { 0.0 });
        let sigma2 = generated_demo::polynomial::in_f64::SIGMA2;
        let k = &s1 * m.transpose() / (sigma2 + s1[(0, 0)]);
        self.s = (DMatrix::identity(N, N) - &k * &m) * &s1;
        self.x = &x1 + &k * (y - x1[0]);
    }
}

/// A hub-like signal: a damped oscillation on a slow swing, plus deterministic noise.
fn signal(k: usize) -> f64 {
    let t = k as f64 * 0.01;
    let noise = ((k as f64 * 12.9898).sin() * 43_758.545).fract() - 0.5;
    (2.0 * t).sin() + 0.3 * (-0.2 * t).exp() * (9.0 * t).cos() + 0.02 * noise
}

#[test]
fn generated_polynomial_kf_matches_the_dense_reference_at_every_step() {
    let x0 = [0.0, 0.0, 0.0, 0.0];
    let p0_diag = [1.0, 1e-2, 1e-4, 1e-6];
    let p0 =
        core::array::from_fn(|i| core::array::from_fn(|j| if i == j { p0_diag[i] } else { 0.0 }));
    let mut kf = PolynomialKf::new(&x0, &p0).unwrap();
    let mut reference = Reference {
        x: DVector::from_row_slice(&x0),
        s: DMatrix::from_diagonal(&DVector::from_row_slice(&p0_diag)),
        window: Vec::new(),
        since: 0,
    };
    let mut worst = (0.0_f64, 0.0_f64);
    let mut reinitialised = 0;
    for k in 0..1500 {
        let y = signal(k);
        assert_eq!(kf.step(y), Status::Ok);
        reference.step(y);
        if reference.since == 0 {
            reinitialised += 1;
        }
        let x_scale = reference.x.amax().max(1e-3);
        let x_err = (DVector::from_row_slice(&kf.state()) - &reference.x).amax() / x_scale;
        let p = DMatrix::from_fn(N, N, |i, j| kf.covariance()[i][j]);
        let p_err = (p - &reference.s).amax() / reference.s.amax();
        worst = (worst.0.max(x_err), worst.1.max(p_err));
        assert!(
            x_err < 1e-9 && p_err < 1e-9,
            "step {k}: state {x_err:e}, covariance {p_err:e}"
        );
    }
    assert_eq!(reinitialised, 15, "re-initialised every 100 samples");
    println!(
        "largest relative difference: state {:e}, covariance {:e}",
        worst.0, worst.1
    );
}

#[test]
fn window_fit_gain_is_nalgebras_pseudo_inverse() {
    let h = design(PolynomialKf::WINDOW);
    let pinv = h.clone().pseudo_inverse(1e-14).unwrap();
    let gain = DMatrix::from_fn(N, PolynomialKf::WINDOW, |i, j| PolynomialKf::FIT_GAIN[i][j]);
    let diff = (&gain - &pinv).amax() / pinv.amax();
    assert!(diff < 1e-10, "{diff:e}");
    let sigma2 = generated_demo::polynomial::in_f64::SIGMA2;
    let cov = (h.transpose() * h).try_inverse().unwrap() * sigma2;
    let ours = DMatrix::from_fn(N, N, |i, j| PolynomialKf::FIT_COVARIANCE[i][j]);
    assert!((ours - &cov).amax() / cov.amax() < 1e-10);
}

#[test]
fn a_cubic_is_reconstructed_exactly_in_physical_units_after_a_fit() {
    let (a, b, c, d) = (0.3, -1.2, 4.0, 2.5);
    let ts = PolynomialKf::SAMPLE_PERIOD;
    let mut kf = PolynomialKf::new(&[0.0; N], &[[0.0; N]; N]).unwrap();
    let steps = PolynomialKf::REINIT_EVERY;
    for k in 0..steps {
        let t = k as f64 * ts;
        assert_eq!(kf.step(a + b * t + c * t * t + d * t * t * t), Status::Ok);
    }
    let t = (steps - 1) as f64 * ts;
    let truth = [
        a + b * t + c * t * t + d * t * t * t,
        b + 2.0 * c * t + 3.0 * d * t * t,
        2.0 * c + 6.0 * d * t,
        6.0 * d,
    ];
    let got = kf.derivatives();
    for (g, w) in got.iter().zip(truth) {
        assert!(
            (g - w).abs() < 1e-7 * w.abs().max(1.0),
            "{got:?} vs {truth:?}"
        );
    }
}

#[test]
fn a_rejected_measurement_leaves_the_filter_unchanged() {
    let mut kf = PolynomialKf::new(&[1.0, 0.0, 0.0, 0.0], &[[1e-3; N]; N]).unwrap();
    for k in 0..10 {
        assert_eq!(kf.step(signal(k)), Status::Ok);
    }
    let before = kf;
    assert_eq!(kf.step(f64::NAN), Status::RejectedInput);
    assert_eq!(kf.step(f64::INFINITY), Status::RejectedInput);
    assert_eq!(kf, before);
}

/// The innovation and its normalised square of a recursive step against the reference's
/// prediction: `r = y - (Phi x)[0]`, `NIS = r^2 / ((Phi S Phi' + f I)[0][0] + sigma^2)`; and
/// `reset` starts again as `new` does.
#[test]
fn innovation_nis_and_reset_match_the_reference() {
    use generated_demo::polynomial::in_f64::{FADE, SIGMA2};
    let x0 = [0.5, 0.1, -0.02, 0.003];
    let p0 = core::array::from_fn(|i| {
        core::array::from_fn(|j| {
            if i == j {
                [1.0, 1e-2, 1e-4, 1e-6][i]
            } else {
                0.0
            }
        })
    });
    let mut kf = PolynomialKf::new(&x0, &p0).unwrap();
    assert_eq!(
        (kf.innovation(), kf.normalised_innovation_squared()),
        ([0.0], 0.0)
    );
    let x = DVector::from_row_slice(&x0);
    let s = DMatrix::from_fn(N, N, |i, j| p0[i][j]);
    let predicted = phi() * &x;
    let s1 = phi() * s * phi().transpose() + DMatrix::identity(N, N) * FADE;
    let y = 0.9;
    assert_eq!(kf.step(y), Status::Ok);
    let r = y - predicted[0];
    let nis = r * r / (s1[(0, 0)] + SIGMA2);
    assert!(
        (kf.innovation()[0] - r).abs() <= 1e-14,
        "{:?} against {r}",
        kf.innovation()
    );
    let got = kf.normalised_innovation_squared();
    assert!((got - nis).abs() <= 1e-12 * nis, "{got} against {nis}");
    // A measurement 1e5 standard deviations out is beyond the divergence bound.
    let before = kf;
    assert_eq!(
        kf.step(y + 1e5 * (s1[(0, 0)] + SIGMA2).sqrt()),
        Status::Diverged
    );
    assert_eq!(kf, before);
    assert_eq!(kf.reset(&x0, &p0), Status::Ok);
    assert_eq!(kf, PolynomialKf::new(&x0, &p0).unwrap());
}

/// A wild value on a re-initialising sample is refused like any other (the recursive step
/// runs first and its bound decides), so it never enters the window the fit reads.
#[test]
fn a_wild_value_on_a_re_initialising_sample_is_refused() {
    let mut kf = PolynomialKf::new(&[0.0; N], &[[0.0; N]; N]).unwrap();
    let every = PolynomialKf::REINIT_EVERY;
    for k in 0..every - 1 {
        assert_eq!(kf.step(signal(k)), Status::Ok);
    }
    let before = kf;
    assert_eq!(kf.step(1e30), Status::Diverged);
    assert_eq!(kf, before);
    // The good sample re-initialises from the window as it would have.
    let mut reference = before;
    assert_eq!(kf.step(signal(every - 1)), Status::Ok);
    assert_eq!(reference.step(signal(every - 1)), Status::Ok);
    assert_eq!(kf, reference);
    let fitted = kf.state();
    assert!(fitted.iter().all(|v| v.abs() < 10.0), "{fitted:?}");
}

stateforge::model! {
    /// The demo's polynomial model of order 1 (a position and its scaled velocity), with a
    /// gated polynomial Kalman filter.
    mod gated {
        scalar f64;
        state z0, z1;
        output y = z0;
        generate polynomial_kf(order = 1, dt = 0.01, fading = 1e-9, noise_variance = 1e-4,
            reinit_every = 20, window = 5, gate = 10.83);
        dynamics discrete {
            z0 = z0 + z1;
            z1 = z1;
        }
    }
}

/// A gated polynomial Kalman filter rejects a spike of 30 standard deviations: the
/// prediction is kept (what `predict` gives), the innovation recorded, and the window
/// emptied, so the outlier never reaches the fit: the re-initialisation due at sample 19
/// waits until the window holds 5 samples after the spike again. `reset` keeps the gate.
#[test]
fn a_gated_polynomial_kf_keeps_its_prediction_and_empties_its_window() {
    use gated::{PolynomialKf, Status};
    let ramp = |k: usize| 0.1 + 0.002 * k as f64;
    let prior = [[1e-2, 0.0], [0.0, 1e-4]];
    let mut kf = PolynomialKf::new(&[0.1, 0.0], &prior).unwrap();
    assert_eq!(kf.innovation_gate(), 10.83);
    for k in 0..17 {
        assert_eq!(kf.step(ramp(k)), Status::Ok, "sample {k}");
    }
    let mut predicted = kf;
    assert_eq!(predicted.predict(), Status::Ok);
    // The prediction of eq. (5-6), `x = Phi x`, `S1 = Phi S Phi' + f I`, with `Phi(1)` of
    // order 1.
    let phi = nalgebra::Matrix2::new(1.0, 1.0, 0.0, 1.0);
    let x = nalgebra::Vector2::from(kf.state());
    let s = nalgebra::Matrix2::from_fn(|i, j| kf.covariance()[i][j]);
    let (x_pred, s1) = (
        phi * x,
        phi * s * phi.transpose() + nalgebra::Matrix2::identity() * 1e-9,
    );
    for i in 0..2 {
        assert!((predicted.state()[i] - x_pred[i]).abs() <= 1e-12, "x{i}");
        for j in 0..2 {
            assert!((predicted.covariance()[i][j] - s1[(i, j)]).abs() <= 1e-12 * s1.amax());
        }
    }
    let spike = ramp(17) + 30.0 * 1e-2;
    assert_eq!(kf.step(spike), Status::OutlierRejected);
    assert_eq!(
        (kf.state(), kf.covariance()),
        (predicted.state(), predicted.covariance())
    );
    assert!((kf.innovation()[0] - (spike - predicted.state()[0])).abs() < 1e-12);
    assert!(kf.normalised_innovation_squared() > 10.83);
    for k in 18..22 {
        assert_eq!(kf.step(ramp(k)), Status::Ok, "sample {k}");
        assert_ne!(kf.covariance(), PolynomialKf::FIT_COVARIANCE, "sample {k}");
    }
    // The fifth sample after the spike fills the window with the ramp: the fit is exact.
    assert_eq!(kf.step(ramp(22)), Status::Ok);
    assert_eq!(kf.covariance(), PolynomialKf::FIT_COVARIANCE);
    let fitted = kf.state();
    assert!(
        (fitted[0] - ramp(22)).abs() < 1e-9 && (fitted[1] - 0.002).abs() < 1e-9,
        "{fitted:?}"
    );
    assert_eq!(kf.reset(&[0.1, 0.0], &prior), Status::Ok);
    assert_eq!(kf, PolynomialKf::new(&[0.1, 0.0], &prior).unwrap());
    // A rejected sample counts towards the period: after a spike at sample 5 (the window
    // full again by sample 10) the re-initialisation is still the 20th sample's.
    for k in 0..19 {
        let expected = if k == 5 {
            Status::OutlierRejected
        } else {
            Status::Ok
        };
        let y = if k == 5 { ramp(k) + 1.0 } else { ramp(k) };
        assert_eq!(kf.step(y), expected, "sample {k}");
        assert_ne!(kf.covariance(), PolynomialKf::FIT_COVARIANCE, "sample {k}");
    }
    assert_eq!(kf.step(ramp(19)), Status::Ok);
    assert_eq!(kf.covariance(), PolynomialKf::FIT_COVARIANCE);
}
