//! Checks of the hand-written reference implementation (`tests::reference`) on its own:
//! the model's Jacobians, the exactness of the window transform on noise-free data, the
//! index alignment of the DKF, the EKF's covariance, the degenerate windows, the LQR and
//! the Euler-equivalent parameters.

use nalgebra::{Matrix2, SMatrix};
use tests::reference::*;

/// `a` and `b` agree to `rtol` relative to the larger of `|a|`, `|b|` and `scale`.
fn close(a: f64, b: f64, rtol: f64, scale: f64) -> bool {
    (a - b).abs() <= rtol * (a.abs().max(b.abs()).max(scale))
}

/// Every pair agrees to 1e-9 relative (absolute below magnitude 1e-6).
fn assert_all_close(a: &[f64], b: &[f64], context: &str) {
    assert_eq!(a.len(), b.len(), "{context}: lengths");
    for (i, (&ai, &bi)) in a.iter().zip(b).enumerate() {
        assert!(close(ai, bi, 1e-9, 1e-6), "{context}[{i}]: {ai} vs {bi}");
    }
}

/// The beam with the 400 g tip mass: wn = 20 rad/s, zeta = 0.026, alpha = 0.5.
fn true_state() -> State {
    let [x3, x4, x5] = euler_equivalent(20.0, 0.026, 0.5);
    State::from([0.05, -0.3, x3, x4, x5])
}

/// A varied, never-zero input in [-100, 100] V (deterministic).
fn input(k: usize) -> f64 {
    let k = k as f64;
    let u = 70.0 * (0.7 * k).sin() + 30.0 * (2.3 * k + 1.0).cos();
    if u.abs() < 1.0 {
        5.0
    } else {
        u
    }
}

/// States `x[0..=n]` of the noise-free model from `x0` with inputs `u[k]`.
fn simulate(x0: State, u: &[f64]) -> Vec<State> {
    let mut xs = vec![x0];
    for &uk in u {
        let next = f(xs.last().unwrap(), uk);
        xs.push(next);
    }
    xs
}

#[test]
fn jacobians_match_finite_differences() {
    let x = State::from([0.3, -1.2, -390.0, -7.0, 0.45]);
    let u = 42.0;
    let a = jacobian_f_x(&x, u);
    let bu = jacobian_f_u(&x);
    for j in 0..NX {
        let step = 1e-6 * x[j].abs().max(1.0);
        let mut plus = x;
        let mut minus = x;
        plus[j] += step;
        minus[j] -= step;
        let column = (f(&plus, u) - f(&minus, u)) / (2.0 * step);
        for i in 0..NX {
            assert!(close(a[(i, j)], column[i], 1e-6, 1e-6), "df/dx ({i},{j})");
        }
        let c = (h(&plus) - h(&minus)) / (2.0 * step);
        assert!(close(jacobian_h_x()[(0, j)], c, 1e-6, 1e-6), "dh/dx {j}");
    }
    let column = (f(&x, u + 1e-3) - f(&x, u - 1e-3)) / 2e-3;
    for i in 0..NX {
        assert!(close(bu[i], column[i], 1e-6, 1e-6), "df/du {i}");
    }
}

#[test]
fn window_transform_is_exact_on_noise_free_data() {
    let n = 50;
    let u: Vec<f64> = (0..n).map(input).collect();
    let xs = simulate(true_state(), &u);
    // The window's own initial guess is wrong on purpose: it must not matter once full.
    let guess = State::from([0.0, 0.0, -50000.0, -10.0, 0.01]);
    for eta in [0.0, 0.3, 0.5, 1.0] {
        let mut w = WindowTransform::new(&guess);
        let mut full = 0;
        for k in 0..n {
            let u_prev = if k == 0 { 0.0 } else { u[k - 1] };
            w.push(u_prev, h(&xs[k]));
            if !w.is_full() {
                assert_eq!(
                    w.transform(u[k], eta, &State::zeros()).status,
                    WindowStatus::Filling
                );
                continue;
            }
            full += 1;
            let m = w.transform(u[k], eta, &State::zeros());
            assert_eq!(m.status, WindowStatus::Solved, "k = {k}");
            assert!(m.excitation > 0.0 && m.excitation <= 1.0);
            assert_all_close(&m.phi, xs[k].as_slice(), &format!("eta {eta}, k {k}: phi"));
            let ltv = m.f * xs[k] + m.g * u[k];
            let exact = f(&xs[k], u[k]);
            assert_all_close(
                ltv.as_slice(),
                exact.as_slice(),
                &format!("eta {eta}, k {k}: F x + G u vs f(x, u)"),
            );
            assert_eq!(w.last_params(), [m.phi[2], m.phi[3], m.phi[4]]);
        }
        assert_eq!(full, n - (WINDOW_OUTPUTS - 1));
    }
}

#[test]
fn input_free_window_freezes_x5_and_solves_for_x3_x4() {
    // Excited for 10 samples, then free: windows whose inputs u[k-4..=k-2] are all zero.
    let n = 30;
    let u: Vec<f64> = (0..n)
        .map(|k| if k < 10 { input(k) } else { 0.0 })
        .collect();
    let x_true = true_state();
    let xs = simulate(x_true, &u);
    let mut w = WindowTransform::new(&x_true);
    let mut seen = 0;
    for k in 0..n {
        w.push(if k == 0 { 0.0 } else { u[k - 1] }, h(&xs[k]));
        if !w.is_full() {
            continue;
        }
        let before = w.last_params();
        let m = w.transform(u[k], 0.5, &State::zeros());
        if k >= 14 {
            seen += 1;
            assert_eq!(m.status, WindowStatus::InputFree, "k = {k}");
            assert_eq!(m.phi[4], before[2], "phi5 frozen");
            assert!(close(m.phi[2], x_true[2], 1e-7, 1.0), "phi3 at {k}");
            assert!(close(m.phi[3], x_true[3], 1e-7, 1.0), "phi4 at {k}");
            assert!(close(m.phi[1], xs[k][1], 1e-7, 1e-3), "phi2 at {k}");
        } else {
            assert_eq!(m.status, WindowStatus::Solved, "k = {k}");
        }
    }
    assert_eq!(seen, n - 14);
}

#[test]
fn degenerate_window_keeps_last_valid_parameters_without_nan() {
    let x0 = State::from([0.0, 0.0, -400.0, -1.0, 0.01]);
    let mut w = WindowTransform::new(&x0);
    // Rest, no input: every column of the system is zero.
    for _ in 0..WINDOW_OUTPUTS {
        w.push(0.0, 0.0);
    }
    let m = w.transform(0.0, 0.5, &State::zeros());
    assert_eq!(m.status, WindowStatus::Degenerate);
    assert_eq!(m.excitation, 0.0);
    assert_eq!([m.phi[2], m.phi[3], m.phi[4]], [-400.0, -1.0, 0.01]);
    assert!(m.phi.iter().all(|v| v.is_finite()));
    assert!(m.f.iter().chain(m.g.iter()).all(|v| v.is_finite()));
    // A constant non-zero input with a constant output: rank-deficient 3x3 system.
    for _ in 0..WINDOW_OUTPUTS {
        w.push(3.0, 0.2);
    }
    let m = w.transform(3.0, 0.5, &State::zeros());
    assert_eq!(m.status, WindowStatus::Degenerate);
    assert!(m.excitation < DEFAULT_EXCITATION_THRESHOLD);
    assert_eq!(w.last_params(), [-400.0, -1.0, 0.01]);
}

#[test]
fn dkf_follows_noise_free_data_exactly_with_zero_covariances() {
    // With Pbar = P = Qbar = Q = 0 the gains are 0, so both stages are pure predictions:
    // once the window is full, xbar[k] = F xbar[k-1] + G u[k-1] must be the true x[k].
    let n = 40;
    let u: Vec<f64> = (0..n).map(input).collect();
    let xs = simulate(true_state(), &u);
    let zero = Mat5::zeros();
    let mut dkf = Dkf::new(xs[0], zero, zero, zero, Mat1::new(1e-3), 0.5);
    for k in 0..n {
        let u_prev = if k == 0 { 0.0 } else { u[k - 1] };
        if k == WINDOW_OUTPUTS {
            // The window ends at k-1 = 4 from now on: restart both stages at the truth.
            dkf.xbar = xs[k - 1];
            dkf.x = xs[k - 1];
        }
        let status = dkf.step(u_prev, h(&xs[k]));
        assert_eq!((status.akf, status.lkf), (StepStatus::Ok, StepStatus::Ok));
        if k >= WINDOW_OUTPUTS {
            assert_eq!(status.window, Some(WindowStatus::Solved));
            assert_all_close(
                dkf.xbar.as_slice(),
                xs[k].as_slice(),
                &format!("k {k}: AKF"),
            );
            assert_all_close(dkf.x.as_slice(), xs[k].as_slice(), &format!("k {k}: LKF"));
        } else {
            assert_eq!(status.window, Some(WindowStatus::Filling));
        }
    }
}

#[test]
fn dkf_rejects_non_finite_samples_and_restarts_its_window() {
    let x0 = true_state();
    let p0 = Mat5::from_diagonal(&State::from([0.1, 1.0, 2e4, 1000.0, 0.1]));
    let q = Mat5::from_diagonal(&State::from([0.0, 0.0, 100.0, 300.0, 1e-3]));
    let mut dkf = Dkf::new(x0, p0, q, q, Mat1::new(1e-3), 0.5);
    for k in 0..8 {
        dkf.step(input(k), 0.01 * k as f64);
    }
    assert!(dkf.window.is_full());
    let before = dkf.clone();
    let s = dkf.step(f64::NAN, 0.1);
    assert_eq!((s.akf, s.lkf), (StepStatus::Rejected, StepStatus::Rejected));
    assert_eq!(
        (dkf.x, dkf.p, dkf.xbar, dkf.pbar),
        (before.x, before.p, before.xbar, before.pbar)
    );
    assert!(dkf.window.is_empty());
    assert_eq!(dkf.step(1.0, f64::INFINITY).lkf, StepStatus::Rejected);
    // A negative R makes S <= 0 in both stages: both estimates unchanged.
    dkf.r = Mat1::new(-1e9);
    let before = dkf.clone();
    let s = dkf.step(1.0, 0.1);
    assert_eq!(
        (s.akf, s.lkf),
        (
            StepStatus::NonPositiveInnovation,
            StepStatus::NonPositiveInnovation
        )
    );
    assert_eq!(
        (dkf.x, dkf.p, dkf.xbar, dkf.pbar),
        (before.x, before.p, before.xbar, before.pbar)
    );
}

#[test]
fn ekf_keeps_covariance_symmetric_and_finite() {
    let n = 300;
    let u: Vec<f64> = (0..n).map(input).collect();
    let xs = simulate(true_state(), &u);
    let x0 = State::from([0.01, 0.0, -400.0, -1.0, 0.01]);
    let p0 = Mat5::from_diagonal(&State::from([0.1, 1.0, 2e4, 1000.0, 0.1]));
    let q = Mat5::from_diagonal(&State::from([0.0, 0.0, 100.0, 300.0, 1e-3]));
    let mut ekf = Ekf::new(x0, p0, q, Mat1::new(1e-3));
    for k in 0..n {
        let u_prev = if k == 0 { 0.0 } else { u[k - 1] };
        assert_eq!(ekf.step(u_prev, h(&xs[k])), StepStatus::Ok);
        assert!(
            ekf.x.iter().chain(ekf.p.iter()).all(|v| v.is_finite()),
            "k {k}"
        );
        let asym = (ekf.p - ekf.p.transpose()).norm() / ekf.p.norm();
        assert!(asym < 1e-12, "k {k}: asymmetry {asym:e}");
        assert!(
            (0..NX).all(|i| ekf.p[(i, i)] >= 0.0),
            "k {k}: negative variance"
        );
    }
}

#[test]
fn ekf_leaves_itself_unchanged_when_a_step_fails() {
    let x0 = State::from([0.01, 0.0, -400.0, -1.0, 0.01]);
    let mut ekf = Ekf::new(x0, Mat5::identity(), Mat5::identity(), Mat1::new(1e-3));
    let before = ekf.clone();
    assert_eq!(ekf.step(f64::NAN, 0.0), StepStatus::Rejected);
    assert_eq!(ekf.step(0.0, f64::NEG_INFINITY), StepStatus::Rejected);
    assert_eq!(ekf, before);
    ekf.r = Mat1::new(-10.0);
    let before = ekf.clone();
    assert_eq!(ekf.step(1.0, 0.2), StepStatus::NonPositiveInnovation);
    assert_eq!(ekf, before);
    // predict + update is step.
    ekf.r = Mat1::new(1e-3);
    let mut split = ekf.clone();
    assert_eq!(split.predict(1.0), StepStatus::Ok);
    assert_eq!(split.update(0.2), StepStatus::Ok);
    assert_eq!(ekf.step(1.0, 0.2), StepStatus::Ok);
    assert_eq!(ekf, split);
}

#[test]
fn lqr_gain_stabilises_the_true_model() {
    let x = true_state();
    let x_est = [x[0], x[1], x[2], x[3], x[4]];
    let k = lqr_gain(&x_est, 50, Matrix2::identity(), 0.001).expect("gain");
    let (a, b) = lqr_model(&x_est);
    let closed = a - b * k;
    let radius = closed
        .complex_eigenvalues()
        .iter()
        .map(|z| z.norm())
        .fold(0.0, f64::max);
    assert!(radius < 1.0, "spectral radius {radius}");
    // The open loop is (marginally) stable too, but the LQR must damp it more.
    let open = a
        .complex_eigenvalues()
        .iter()
        .map(|z| z.norm())
        .fold(0.0, f64::max);
    assert!(radius < open, "closed {radius} vs open {open}");
    // A horizon of one: one Riccati step from P = Q, then the gain from that P (Alg. 3).
    let k1 = lqr_gain(&x_est, 1, Matrix2::identity(), 0.001).unwrap();
    let q = Matrix2::<f64>::identity();
    let k0: SMatrix<f64, 1, 2> = b.transpose() * q * a / (0.001 + (b.transpose() * q * b)[(0, 0)]);
    let p1 = a.transpose() * q * a - a.transpose() * q * b * k0 + q;
    let s = 0.001 + (b.transpose() * p1 * b)[(0, 0)];
    let expected: SMatrix<f64, 1, 2> = b.transpose() * p1 * a / s;
    assert!((k1 - expected).norm() < 1e-12 * expected.norm());
    assert!(lqr_gain(&x_est, 0, Matrix2::identity(), 0.001).is_none());
    assert!(lqr_gain(&x_est, 5, Matrix2::zeros(), 0.0).is_none());
    // Saturation.
    let big = [1e6, 0.0, x[2], x[3], x[4]];
    let u = lqr_control(&k, &big, 100.0);
    assert_eq!(u.abs(), 100.0);
    let small = [1e-6, 0.0, x[2], x[3], x[4]];
    assert_eq!(lqr_control(&k, &small, 100.0), -k[(0, 0)] * 1e-6);
}

#[test]
fn euler_equivalent_parameters_and_their_readout() {
    let [x3, x4, x5] = euler_equivalent(20.0, 0.026, 0.5);
    assert!((x3 + 393.93).abs() < 0.01, "x3 = {x3}");
    assert!((x4 + 6.941).abs() < 0.001, "x4 = {x4}");
    assert!((x5 - 0.4924).abs() < 1e-4, "x5 = {x5}");
    let (wn, zeta) = poles_readout(x3, x4);
    assert!((wn - 20.0).abs() < 1e-9, "wn = {wn}");
    assert!((zeta - 0.026).abs() < 1e-12, "zeta = {zeta}");
    // The tip-mass change and an over-damped mode round-trip as well.
    for (wn0, zeta0) in [(50.0, 0.026), (30.0, 1.5)] {
        let [x3, x4, _] = euler_equivalent(wn0, zeta0, 1.0);
        let (wn, zeta) = poles_readout(x3, x4);
        assert!(
            (wn - wn0).abs() < 1e-9 * wn0 && (zeta - zeta0).abs() < 1e-9,
            "{wn0} {zeta0}"
        );
    }
    // The naive read-out of the paper's close guess is unstable in Euler: modulus > 1 maps
    // to a negative damping ratio.
    let (_, zeta) = poles_readout(-400.0, -1.04);
    assert!(zeta < 0.0);
}
