//! How ill-conditioned the generated `f32` EKF's covariance becomes over a long run of the
//! simulated cantilever, and whether that costs the `f32` filter accuracy: the `f32` and
//! `f64` EKFs run side by side on the same data, with the tuning of `tests/tests/filters.rs`
//! (close guess, `P0` with `p3 = 2e4`, `Q_DIAG`, `R`; noise 1e-4 mm). Every 1000 steps it
//! takes the eigenvalues of both covariances (in `f64`, from the `f32` entries) and tries a
//! Cholesky factorisation of the `f32` one in `f32`; at checkpoints it prints:
//!
//! - `cond32 now/max`: the 2-norm condition number `max|eig| / min|eig|` of the `f32` `P`,
//!   and its largest value so far; `cond64` the same for the `f64` filter's `P`;
//! - `corr32`: the condition number of the `f32` correlation matrix `D^-1/2 P D^-1/2`
//!   (`D = diag P`), the part of `cond` that scaling the states cannot remove;
//! - `mineig32`, `mineig64`: the smallest eigenvalue of each `P` now; `chol!` the number of
//!   sampled `f32` covariances that were not positive definite (Cholesky failed or an
//!   eigenvalue <= 0);
//! - `dx12`, `dpar`: the largest difference so far between the two filters' estimates,
//!   relative to the largest magnitude the `f64` estimate has had, for the physical states
//!   (`x1`, `x2`) and for the parameters (`x3`-`x5`);
//! - `dP`: the largest so far of `|eig(L^-1 (P32 - P64) L^-T)|` with `P64 = L L'`: the
//!   `f32` covariance's error in the `f64` covariance's own metric (1e-3 means every
//!   direction's variance is right to 0.1 %, however small that variance is);
//! - `bad32`, `bad64`: how many steps of each filter did not return `Status::Ok`.
//!
//! The input is the simulation's PRBS (periodic, so one period is taken from
//! `cantilever_sim::run` and repeated); plant and noise are stepped here so that ten
//! million samples are never held in memory. A measurement, not a test.
//!
//! ```text
//! cargo run --release -p tests --example covariance_conditioning [-- STEPS]
//! ```

use generated_demo::cantilever::{in_f64, Ekf, Status};
use nalgebra::{Cholesky, Matrix5, SymmetricEigen};
use std::process::ExitCode;
use std::time::Instant;
use tests::cantilever_sim::run;
use tests::reference::{euler_equivalent, f, State};
use tests::rng::Lcg;
use tests::tuning::{p0, Q_DIAG, R, X0_CLOSE};

/// Samples of one period of the PRBS: a 9-bit maximal-length LFSR, each bit held 4 samples.
const PRBS_PERIOD: usize = 511 * 4;
/// Standard deviation of the measurement noise [mm], as in `tests/tests/filters.rs`.
const SIGMA: f64 = 1e-4;
/// Steps between two eigenvalue samples of the covariances.
const SAMPLE_EVERY: usize = 1000;

fn main() -> ExitCode {
    let steps = match std::env::args().nth(1).map(|a| a.replace('_', "").parse()) {
        None => 10_000_000,
        Some(Ok(steps)) => steps,
        Some(Err(_)) => {
            eprintln!("usage: covariance_conditioning [STEPS]");
            return ExitCode::FAILURE;
        }
    };
    let start = Instant::now();
    measure(steps);
    println!("wall time {:.2} s", start.elapsed().as_secs_f64());
    ExitCode::SUCCESS
}

/// Eigen-analysis of one covariance, in `f64`.
struct Spectrum {
    cond: f64,
    min_eig: f64,
    corr_cond: f64,
}

fn spectrum(p: &Matrix5<f64>) -> Spectrum {
    let cond = |m: &Matrix5<f64>| {
        let eig = SymmetricEigen::new(*m).eigenvalues;
        (eig.abs().max() / eig.abs().min(), eig.min())
    };
    let (cond_p, min_eig) = cond(p);
    let scale = p.diagonal().map(|d| 1.0 / d.abs().sqrt());
    let (corr_cond, _) = cond(&Matrix5::from_fn(|i, j| p[(i, j)] * scale[i] * scale[j]));
    Spectrum {
        cond: cond_p,
        min_eig,
        corr_cond,
    }
}

/// The largest `|eig(L^-1 (p - reference) L^-T)|`, `reference = L L'`; infinite when
/// `reference` is not positive definite.
fn relative_error(p: &Matrix5<f64>, reference: &Matrix5<f64>) -> f64 {
    let Some(cholesky) = Cholesky::new(*reference) else {
        return f64::INFINITY;
    };
    let l = cholesky.l();
    let half = l
        .solve_lower_triangular(&(p - reference))
        .unwrap_or(Matrix5::zeros());
    let whitened = l
        .solve_lower_triangular(&half.transpose())
        .unwrap_or(Matrix5::zeros());
    SymmetricEigen::new(whitened).eigenvalues.abs().max()
}

/// Standard normal numbers by Box-Muller from the tests' LCG.
fn gaussian(lcg: &mut Lcg) -> f64 {
    // (1 - [-1, 1)) / 2 lies in (0, 1], so the logarithm is finite.
    let a = (1.0 - lcg.uniform()) / 2.0;
    (-2.0 * a.ln()).sqrt() * (std::f64::consts::PI * lcg.uniform()).cos()
}

/// One period of the simulation's PRBS, checked to repeat in the next period.
fn repeating_prbs() -> Vec<f64> {
    let period = run(2 * PRBS_PERIOD, 0.0, 0);
    let prbs: Vec<f64> = period[..PRBS_PERIOD].iter().map(|s| s.u).collect();
    assert!(
        period[PRBS_PERIOD..]
            .iter()
            .zip(&prbs)
            .all(|(s, &u)| s.u == u),
        "the simulation's PRBS repeats every {PRBS_PERIOD} samples"
    );
    prbs
}

/// The `f32` and `f64` EKFs with the tuning of `tests/tests/filters.rs`.
fn new_filters() -> (Ekf, in_f64::Ekf) {
    let to_f32 = |v: f64| v as f32;
    let p0_64 = p0(2e4);
    let ekf32 = Ekf::new(
        &X0_CLOSE.map(to_f32),
        &p0_64.map(|row| row.map(to_f32)),
        &Q_DIAG.map(to_f32),
        &[[R as f32]],
    )
    .unwrap();
    let ekf64 = in_f64::Ekf::new(&X0_CLOSE, &p0_64, &Q_DIAG, &[[R]]).unwrap();
    (ekf32, ekf64)
}

/// The steps at which a row is printed: 1 and 3 times the powers of ten from 1e3 to 1e7
/// below `steps`, and `steps`.
fn checkpoints(steps: usize) -> Vec<usize> {
    (3..8)
        .flat_map(|e| [10usize.pow(e), 3 * 10usize.pow(e)])
        .filter(|&c| c < steps)
        .chain([steps])
        .collect()
}

/// Prints the table's header.
fn print_header() {
    println!(
        "{:>9} {:>17} {:>8} {:>8} {:>9} {:>9} {:>5} {:>8} {:>8} {:>8} {:>5} {:>5}",
        "steps",
        "cond32 now/max",
        "cond64",
        "corr32",
        "mineig32",
        "mineig64",
        "chol!",
        "dx12",
        "dpar",
        "dP",
        "bad32",
        "bad64"
    );
}

/// What the run has found so far: the worst values and the counts of the table's columns.
#[derive(Default)]
struct Tally {
    max_cond32: f64,
    not_pd32: usize,
    dp: f64,
    bad32: usize,
    bad64: usize,
    largest64: [f64; 5],
    dx12: f64,
    dpar: f64,
}

impl Tally {
    /// Takes in the two estimates' differences, relative to the largest `f64` magnitudes.
    fn compare_states(&mut self, x32: &[f32; 5], x64: &[f64; 5]) {
        for i in 0..5 {
            self.largest64[i] = self.largest64[i].max(x64[i].abs());
            let difference = (f64::from(x32[i]) - x64[i]).abs() / self.largest64[i];
            let worst = if i < 2 {
                &mut self.dx12
            } else {
                &mut self.dpar
            };
            *worst = worst.max(difference);
        }
    }

    /// Samples both covariances' spectra and their difference; prints a row at step `k`
    /// if it is a checkpoint.
    fn sample_covariances(&mut self, ekf32: &Ekf, ekf64: &in_f64::Ekf, k: usize, checkpoint: bool) {
        let p32 = Matrix5::from_fn(|i, j| ekf32.covariance()[i][j]);
        let s32 = spectrum(&p32.map(f64::from));
        self.max_cond32 = self.max_cond32.max(s32.cond);
        self.not_pd32 += usize::from(Cholesky::new(p32).is_none() || s32.min_eig <= 0.0);
        let p64 = Matrix5::from_fn(|i, j| ekf64.covariance()[i][j]);
        self.dp = self.dp.max(relative_error(&p32.map(f64::from), &p64));
        if checkpoint {
            self.print_row(k, &s32, &spectrum(&p64));
        }
    }

    /// Prints the row of step `k`, with the spectra of the two covariances now.
    fn print_row(&self, k: usize, s32: &Spectrum, s64: &Spectrum) {
        let Tally {
            max_cond32,
            not_pd32,
            dp,
            bad32,
            bad64,
            dx12,
            dpar,
            ..
        } = *self;
        println!(
            "{k:>9} {:>8.1e}/{:>8.1e} {:>8.1e} {:>8.1e} {:>9.2e} {:>9.2e} {not_pd32:>5} \
             {dx12:>8.1e} {dpar:>8.1e} {dp:>8.1e} {bad32:>5} {bad64:>5}",
            s32.cond, max_cond32, s64.cond, s32.corr_cond, s32.min_eig, s64.min_eig,
        );
    }
}

/// Runs both filters for `steps` samples of the simulated cantilever, printing the table.
fn measure(steps: usize) {
    let prbs = repeating_prbs();
    let [x3, x4, x5] = euler_equivalent(20.0, 0.026, 0.5);
    let mut truth = State::new(0.0, 0.0, x3, x4, x5);
    let mut noise = Lcg(7);
    let (mut ekf32, mut ekf64) = new_filters();
    let checkpoints = checkpoints(steps);
    print_header();
    let mut tally = Tally::default();
    let mut u_prev = 0.0;
    for k in 0..=steps {
        let y = truth[0] + SIGMA * gaussian(&mut noise);
        let u = prbs[k % PRBS_PERIOD];
        truth = f(&truth, u);
        if k == 0 {
            u_prev = u;
            continue;
        }
        tally.bad32 += usize::from(ekf32.step(&[u_prev as f32], &[y as f32]) != Status::Ok);
        tally.bad64 += usize::from(ekf64.step(&[u_prev], &[y]) != Status::Ok);
        u_prev = u;
        tally.compare_states(&ekf32.state(), &ekf64.state());
        let checkpoint = checkpoints.contains(&k);
        if k % SAMPLE_EVERY != 0 && !checkpoint {
            continue;
        }
        tally.sample_covariances(&ekf32, &ekf64, k, checkpoint);
    }
}
