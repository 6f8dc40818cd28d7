//! The generated EKF, DKF and LQR (cantilever, f64) against the independent nalgebra
//! reference in `tests/src/reference.rs`, over a 2000-step run of the simulated beam; and
//! their behaviour on bad input and degenerate windows.

use generated_demo::cantilever::in_f64::{Dkf, Ekf, Lqr, Status, WindowStatus};
use nalgebra::{Matrix2, SMatrix};
use tests::cantilever_sim::{run, Sample};
use tests::reference::{self, State};
use tests::tuning::{diag, p0, Q_DIAG, R, X0_CLOSE};

/// Relative agreement required between generated code and the reference.
const RTOL: f64 = 1e-9;

fn mat(m: &[[f64; 5]; 5]) -> SMatrix<f64, 5, 5> {
    SMatrix::from_fn(|i, j| m[i][j])
}

/// Entries agree to `RTOL` relative to the larger of the two, with a floor at `RTOL` times
/// the vector's largest entry (so entries near zero are compared at the vector's scale).
fn assert_agree(what: &str, k: usize, generated: &[f64], reference: &[f64]) {
    let scale = reference.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for (i, (&g, &r)) in generated.iter().zip(reference).enumerate() {
        let tolerance = RTOL * g.abs().max(r.abs()).max(scale);
        assert!(
            (g - r).abs() <= tolerance,
            "{what} at step {k}, entry {i}: generated {g:e}, reference {r:e}"
        );
    }
}

fn flat(m: &[[f64; 5]; 5]) -> Vec<f64> {
    m.iter().flatten().copied().collect()
}

fn flat_na(m: &SMatrix<f64, 5, 5>) -> Vec<f64> {
    (0..5)
        .flat_map(|i| (0..5).map(move |j| m[(i, j)]))
        .collect()
}

fn data() -> Vec<Sample> {
    run(2001, 1e-4, 7)
}

#[test]
fn ekf_agrees_with_the_reference_over_2000_steps() {
    let q = diag(Q_DIAG);
    let mut ekf = Ekf::new(&X0_CLOSE, &p0(2e4), &Q_DIAG, &[[R]]).unwrap();
    let mut reference = reference::Ekf::new(
        State::from(X0_CLOSE),
        mat(&p0(2e4)),
        mat(&q),
        SMatrix::from([[R]]),
    );
    let samples = data();
    for k in 1..samples.len() {
        let (u_prev, y) = (samples[k - 1].u, samples[k].y);
        let status = ekf.step(&[u_prev], &[y]);
        let expected = reference.step(u_prev, y);
        assert_eq!(status, Status::Ok, "step {k}");
        assert_eq!(expected, reference::StepStatus::Ok, "step {k}");
        assert_agree("EKF x", k, &ekf.state(), reference.x.as_slice());
        assert_agree("EKF P", k, &flat(&ekf.covariance()), &flat_na(&reference.p));
    }
}

#[test]
fn dkf_agrees_with_the_reference_over_2000_steps() {
    let q = diag(Q_DIAG);
    let mut dkf = Dkf::new(&X0_CLOSE, &p0(2e4), &Q_DIAG, &p0(2e4), &Q_DIAG, &[[R]]).unwrap();
    let mut reference = reference::Dkf::new(
        State::from(X0_CLOSE),
        mat(&p0(2e4)),
        mat(&q),
        mat(&q),
        SMatrix::from([[R]]),
        0.5,
    );
    reference.window.threshold = Dkf::DEFAULT_MIN_EXCITATION;
    let samples = data();
    let mut solved = 0;
    for k in 1..samples.len() {
        let (u_prev, y) = (samples[k - 1].u, samples[k].y);
        let status = dkf.step(&[u_prev], &[y]);
        let expected = reference.step(u_prev, y);
        assert!(status.is_ok(), "step {k}: {status:?}");
        let window = match expected.window {
            Some(reference::WindowStatus::Filling) => WindowStatus::Filling,
            Some(reference::WindowStatus::Solved) => WindowStatus::Solved,
            Some(reference::WindowStatus::InputFree) => WindowStatus::InputFree,
            Some(reference::WindowStatus::Degenerate) => WindowStatus::Degenerate,
            None => WindowStatus::Skipped,
        };
        assert_eq!(status.window, window, "step {k}");
        solved += usize::from(window == WindowStatus::Solved);
        assert_agree("AKF x", k, &dkf.akf_state(), reference.xbar.as_slice());
        assert_agree(
            "AKF P",
            k,
            &flat(&dkf.akf_covariance()),
            &flat_na(&reference.pbar),
        );
        assert_agree("DKF x", k, &dkf.state(), reference.x.as_slice());
        assert_agree("DKF P", k, &flat(&dkf.covariance()), &flat_na(&reference.p));
        assert_innovation_agrees("LKF", k, y, &dkf_lkf(&dkf), reference.innovation);
        assert_innovation_agrees("AKF", k, y, &dkf_akf(&dkf), reference.akf_innovation);
    }
    assert!(
        solved > 1900,
        "the PRBS excites the windows: {solved} solved"
    );
}

/// The LKF's innovation and NIS.
fn dkf_lkf(dkf: &Dkf) -> (f64, f64) {
    (dkf.innovation()[0], dkf.normalised_innovation_squared())
}

/// The AKF's.
fn dkf_akf(dkf: &Dkf) -> (f64, f64) {
    (
        dkf.akf_innovation()[0],
        dkf.akf_normalised_innovation_squared(),
    )
}

/// A filter's innovation `r = y - h(x)` and NIS `r^2 / s` agree with the reference's `r`
/// and `s`. `r` is a difference of numbers of `y`'s size, so it is compared at that scale,
/// and the NIS with the error that gives it, `2 |r| dr / s`.
fn assert_innovation_agrees(
    what: &str,
    k: usize,
    y: f64,
    (r, nis): &(f64, f64),
    (r_ref, s_ref): (f64, f64),
) {
    let scale = y.abs().max(r_ref.abs());
    assert!(
        (r - r_ref).abs() <= RTOL * scale,
        "{what} innovation at step {k}: generated {r:e}, reference {r_ref:e}"
    );
    let nis_ref = r_ref * r_ref / s_ref;
    let tolerance = RTOL * (nis_ref + 2.0 * r_ref.abs() * scale / s_ref);
    assert!(
        (nis - nis_ref).abs() <= tolerance,
        "{what} NIS at step {k}: generated {nis:e}, reference {nis_ref:e}"
    );
}

#[test]
fn an_lqr_refuses_weights_that_are_not_positive_semi_definite() {
    // A sign slip in `q` would give a gain that pushes the states away, reported as Ok.
    for (q, r) in [
        ([[1.0, 0.0], [0.0, -1.0]], [[0.001]]),
        ([[1.0, 3.0], [0.0, 1.0]], [[0.001]]),
        ([[1.0, 0.0], [0.0, 1.0]], [[-0.001]]),
    ] {
        assert_eq!(Lqr::new(&q, &r, None).err(), Some(Status::InvalidWeight));
    }
    assert!(Lqr::new(&[[1.0, 0.0], [0.0, 0.0]], &[[0.001]], None).is_ok());
}

#[test]
fn lqr_agrees_with_the_reference() {
    let q = [[1.0, 0.0], [0.0, 1.0]];
    let mut lqr = Lqr::new(&q, &[[0.001]], Some(&[100.0])).unwrap();
    let samples = data();
    for (k, sample) in samples.iter().enumerate().step_by(97) {
        // Gains at the true parameters and at perturbed ones.
        let mut x = [0.0; 5];
        x.copy_from_slice(sample.truth.as_slice());
        x[2] *= 1.0 + 0.1 * (k as f64 / 2000.0);
        assert_eq!(lqr.solve(&x, &[0.0]), Status::Ok);
        let expected = reference::lqr_gain(&x, 50, Matrix2::identity(), 0.001).expect("gain");
        assert_agree(
            "LQR K",
            k,
            &lqr.gain()[0],
            &[expected[(0, 0)], expected[(0, 1)]],
        );
        let u = lqr.control(&x)[0];
        assert_agree(
            "LQR u",
            k,
            &[u],
            &[reference::lqr_control(&expected, &x, 100.0)],
        );
    }
}
