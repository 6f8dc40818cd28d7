//! The DKF's window longer than the minimum (`dkf(window = 40)`, `cantilever_long_window`):
//! its least-squares parameters agree with an independent dense solve (nalgebra's SVD) of
//! the paper's eq. (8) at every sample of the window, on random windows, in `f64` and
//! `f32`; its parameter covariance is the measurement noise carried to first order
//! through the finite differences and the solve, and is of the size of the parameters'
//! scatter on noisy data; a non-finite sample empties the whole window, which refills before it is solved.
//! (Its noise-free exactness is in `window_transform.rs`.)

use generated_demo::cantilever_long_window as in_f32;
use generated_demo::cantilever_long_window::in_f64::{self, TS};
use generated_demo::cantilever_long_window::WINDOW_OUTPUTS;
use nalgebra::{DMatrix, DVector};
use tests::cantilever_sim;
use tests::rng::Lcg;

/// A random window: outputs `y[0..WINDOW_OUTPUTS]` (oldest first) and the inputs before
/// each of them, `u[j]` applied from sample `j` to `j + 1`.
fn random_window(seed: u64) -> (Vec<f64>, Vec<f64>) {
    let mut uniform = Lcg(seed);
    let y = (0..WINDOW_OUTPUTS).map(|_| uniform.uniform()).collect();
    let u = (0..WINDOW_OUTPUTS)
        .map(|_| 100.0 * uniform.uniform())
        .collect();
    (y, u)
}

/// The paper's eq. (8) at every sample the window reaches, written from the paper's
/// eqs. (4)-(8): with `dy[j] = (y[j] - y[j-1]) / TS`,
/// `(dy[j] - dy[j-1]) / TS = y[j-2] x3 + dy[j-1] x4 + u[j-2] x5`: the matrix and
/// right-hand side.
fn reference_system(y: &[f64], u: &[f64]) -> (DMatrix<f64>, DVector<f64>) {
    let dy = |j: usize| (y[j] - y[j - 1]) / TS;
    let rows: Vec<usize> = (2..y.len()).collect();
    let a = DMatrix::from_fn(rows.len(), 3, |e, p| {
        let j = rows[e];
        [y[j - 2], dy(j - 1), u[j - 2]][p]
    });
    let b = DVector::from_fn(rows.len(), |e, _| {
        let j = rows[e];
        (dy(j) - dy(j - 1)) / TS
    });
    (a, b)
}

/// [`reference_system`] solved by SVD.
fn reference_parameters(y: &[f64], u: &[f64]) -> [f64; 3] {
    let (a, b) = reference_system(y, u);
    let theta = a
        .svd(true, true)
        .solve(&b, 1e-300)
        .expect("the SVD has both factors");
    [theta[0], theta[1], theta[2]]
}

/// The `f64` DKF from `x0` with unit prior covariances, no process noise and the
/// measurement noise `r`.
fn dkf_f64(x0: &[f64; 5], r: f64) -> in_f64::Dkf {
    let identity: [[f64; 5]; 5] =
        std::array::from_fn(|i| std::array::from_fn(|j| if i == j { 1.0 } else { 0.0 }));
    in_f64::Dkf::new(x0, &identity, &[0.0; 5], &identity, &[0.0; 5], &[[r]])
        .expect("the tuning is finite")
}

/// A measurement noise so large that no sample is refused, so the window holds exactly
/// the data it is given.
const R_WIDE: f64 = 1e12;

macro_rules! window_parameters {
    ($module:ident, $ty:ty, $y:expr, $u:expr) => {{
        let (y, u): (&[f64], &[f64]) = ($y, $u);
        let identity: [[$ty; 5]; 5] =
            std::array::from_fn(|i| std::array::from_fn(|j| if i == j { 1.0 } else { 0.0 }));
        let x0: [$ty; 5] = [0.0, 0.0, -400.0, -1.0, 0.5];
        let mut dkf = $module::Dkf::new(
            &x0,
            &identity,
            &[0.0; 5],
            &identity,
            &[0.0; 5],
            &[[R_WIDE as $ty]],
        )
        .unwrap();
        for j in 0..y.len() {
            let u_prev = if j == 0 { 0.0 } else { u[j - 1] };
            let status = dkf.step(&[u_prev as $ty], &[y[j] as $ty]);
            assert!(status.is_ok(), "sample {j}: {status:?}");
        }
        let (phi, window) = dkf.window_estimate(&[u[y.len() - 1] as $ty]);
        assert_eq!(window, $module::WindowStatus::Solved);
        [phi[2] as f64, phi[3] as f64, phi[4] as f64]
    }};
}

/// Entry-wise agreement at the parameters' scale (they differ by orders of magnitude).
fn assert_agree(what: &str, got: [f64; 3], want: [f64; 3], rtol: f64) {
    for (p, (g, w)) in got.iter().zip(want).enumerate() {
        assert!(
            (g - w).abs() <= rtol * w.abs().max(1e-12),
            "{what}, parameter {p}: {g:e} vs {w:e}"
        );
    }
}

#[test]
fn least_squares_window_agrees_with_a_dense_svd_solve() {
    assert_eq!(WINDOW_OUTPUTS, 40);
    for seed in 0..50 {
        let (y, u) = random_window(seed);
        let want = reference_parameters(&y, &u);
        let got = window_parameters!(in_f64, f64, &y, &u);
        assert_agree(&format!("f64, window {seed}"), got, want, 1e-9);
        // In f32 the normal equations square the system's condition number, so the bound
        // is single precision's times that (the largest error over these windows: 1.4e-4).
        let got = window_parameters!(in_f32, f32, &y, &u);
        assert_agree(&format!("f32, window {seed}"), got, want, 2e-4);
    }
}

/// The first-order covariance of the least-squares parameters for measurement noise of
/// variance `r` on each output sample: `M^-1 (r sum_s w_s w_s') M^-1`, `M = A' A`, where
/// `w_s = sum_e a_e d(error_e)/dy_s` and an equation's error
/// `(y[j] - 2 y[j-1] + y[j-2]) / TS^2 - x3 y[j-2] - x4 (y[j-1] - y[j-2]) / TS - x5 u[j-2]`
/// moves with its three outputs by the gains below.
fn reference_covariance(y: &[f64], u: &[f64], theta: [f64; 3], r: f64) -> DMatrix<f64> {
    let (a, _) = reference_system(y, u);
    let [x3, x4, _] = theta;
    let ts2 = TS * TS;
    let gains = [1.0 / ts2 + x4 / TS - x3, -2.0 / ts2 - x4 / TS, 1.0 / ts2];
    // Row e is the equation at j = e + 2, reading y[j-2], y[j-1], y[j].
    let mut w = DMatrix::<f64>::zeros(3, y.len());
    for e in 0..a.nrows() {
        for (offset, gain) in gains.iter().enumerate() {
            for p in 0..3 {
                w[(p, e + offset)] += a[(e, p)] * gain;
            }
        }
    }
    let m_inv = (a.transpose() * &a)
        .try_inverse()
        .expect("a random window's normal matrix is regular");
    &m_inv * (&w * w.transpose() * r) * &m_inv
}

#[test]
fn parameter_covariance_is_the_first_order_sandwich() {
    let r = 1e-3;
    for seed in 0..20 {
        let (y, u) = random_window(100 + seed);
        let mut dkf = dkf_f64(&[0.0, 0.0, -400.0, -1.0, 0.5], r);
        // A wide gate-free run: the measurement noise is r, but P is wide enough that no
        // random sample is refused (NIS far below the divergence bound).
        for j in 0..y.len() {
            let u_prev = if j == 0 { 0.0 } else { u[j - 1] };
            assert!(dkf.step(&[u_prev], &[y[j]]).is_ok());
        }
        // The step after the window fills solves it and stores its covariance.
        let status = dkf.step(&[u[y.len() - 1]], &[y[y.len() - 1]]);
        assert_eq!(status.window, in_f64::WindowStatus::Solved);
        let theta = reference_parameters(&y, &u);
        let want = reference_covariance(&y, &u, theta, r);
        let got = dkf.window_parameter_covariance();
        for p in 0..3 {
            for q in 0..3 {
                let scale = (want[(p, p)] * want[(q, q)]).sqrt();
                assert!(
                    (got[p][q] - want[(p, q)]).abs() <= 1e-8 * scale,
                    "window {seed}, entry ({p}, {q}): {:e} vs {:e}",
                    got[p][q],
                    want[(p, q)]
                );
            }
        }
    }
}

#[test]
fn a_rejected_sample_empties_the_whole_window() {
    let (y, u) = random_window(7);
    let mut dkf = dkf_f64(&[0.0, 0.0, -400.0, -1.0, 0.5], R_WIDE);
    let feed = |dkf: &mut in_f64::Dkf, j: usize| {
        let u_prev = if j == 0 { 0.0 } else { u[j - 1] };
        dkf.step(&[u_prev], &[y[j]])
    };
    for j in 0..WINDOW_OUTPUTS {
        assert!(feed(&mut dkf, j).is_ok());
    }
    assert_eq!(dkf.window_estimate(&[0.0]).1, in_f64::WindowStatus::Solved);
    let status = dkf.step(&[1.0], &[f64::NAN]);
    assert_eq!(status.lkf, in_f64::Status::RejectedInput);
    // The window refills: each step's transform reads the window as it stood before the
    // step's measurement, so all WINDOW_OUTPUTS steps find it filling; once they are in,
    // it is solved again.
    for j in 0..WINDOW_OUTPUTS {
        assert_eq!(dkf.window_estimate(&[0.0]).1, in_f64::WindowStatus::Filling);
        let status = feed(&mut dkf, j);
        assert_eq!(status.window, in_f64::WindowStatus::Filling, "sample {j}");
    }
    assert_eq!(dkf.window_estimate(&[0.0]).1, in_f64::WindowStatus::Solved);
}

/// On the simulated cantilever (`tests::cantilever_sim`: PRBS, 1e-3 mm noise), the
/// covariance the window reports is its parameters' actual scatter (measured: 1.04, 0.96
/// and 1.07 times it). It is of first order in the noise: at 1e-2 mm the scatter of `x4`
/// (whose regressor, a first difference, is itself noisy) is 2.5 times what it reports.
#[test]
fn parameter_covariance_has_the_size_of_the_scatter() {
    let (sigma, r) = (1e-3, 1e-6);
    let samples = cantilever_sim::run(4000, sigma, 5);
    let truth: [f64; 5] = std::array::from_fn(|i| samples[0].truth[i]);
    let mut dkf = dkf_f64(&truth, r);
    let (mut sum, mut sum_sq, mut predicted, mut count) = ([0.0; 3], [0.0; 3], [0.0; 3], 0.0);
    for k in 1..samples.len() {
        let status = dkf.step(&[samples[k - 1].u], &[samples[k].y]);
        if status.window == in_f64::WindowStatus::Solved && k > 100 {
            let theta = dkf.window_parameters();
            let c = dkf.window_parameter_covariance();
            for p in 0..3 {
                sum[p] += theta[p];
                sum_sq[p] += theta[p] * theta[p];
                predicted[p] += c[p][p];
            }
            count += 1.0;
        }
    }
    assert!(count > 3000.0, "{count} windows solved");
    for p in 0..3 {
        let mean = sum[p] / count;
        let scatter = (sum_sq[p] / count - mean * mean).sqrt();
        let reported = (predicted[p] / count).sqrt();
        assert!(
            (0.75..=1.33).contains(&(reported / scatter)),
            "parameter {p}: reported standard deviation {reported:e}, scatter {scatter:e}"
        );
    }
}
