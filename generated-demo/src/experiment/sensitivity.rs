//! How the cantilever's estimates depend on the measurement noise, for the EKF, the DKF of
//! the paper (its window the 5 samples that determine the parameters) and the DKF whose
//! window holds 40 samples, solved by least squares (`cantilever_long_window`).
//!
//! The minimum window differentiates y twice through the fewest samples, so its
//! parameters are noise once sigma nears 1e-2 mm (the notes, "Simulating the cantilever");
//! the longer window averages that noise over its 38 equations.
//!
//! - [`table`]: mean wn over 2-15 s, from the paper's close and wrong guesses, for noise
//!   sigma from 1e-4 to 0.03 mm and an exactly sampled beam.
//! - [`monte_carlo`]: 500 random wrong guesses at sigma 1e-3 and 1e-2 mm: how many runs
//!   converge, and the wn error of those that do.

use super::excitation::Prbs;
use super::metrics::mean;
use super::plant::{Plant, PlantConfig, PlantKind};
use super::report::{self, Trace};
use super::tuning::{p0, Q_DIAG, R, X0_CLOSE, X0_WRONG};
use super::TS;
use generated_demo::cantilever::in_f64::{Dkf, Ekf};
use generated_demo::cantilever_long_window::in_f64::Dkf as LongWindowDkf;
use generated_demo::noise::{uniform, GaussianNoise};

/// Why the filters' constructors cannot fail here.
const FINITE_TUNING: &str = "the tuning is finite";
/// The simulated beam's natural frequency (with the tip mass) \[rad/s\].
const WN_TRUE: f64 = 20.0;
/// Length of each run \[s\].
const RUN_END: f64 = 15.0;
/// The filters compared, as labelled in the tables.
const LABELS: [&str; 4] = ["EKF", "AKF", "DKF", "DKF (window 40)"];

/// The three filters of one run, from one initial guess and its initial covariance.
struct Filters {
    ekf: Ekf,
    dkf: Dkf,
    long: LongWindowDkf,
}

impl Filters {
    fn new(x0: &[f64; 5], p3: f64) -> Self {
        let p = p0(p3);
        Self {
            ekf: Ekf::new(x0, &p, &Q_DIAG, &[[R]]).expect(FINITE_TUNING),
            dkf: Dkf::new(x0, &p, &Q_DIAG, &p, &Q_DIAG, &[[R]]).expect(FINITE_TUNING),
            long: LongWindowDkf::new(x0, &p, &Q_DIAG, &p, &Q_DIAG, &[[R]]).expect(FINITE_TUNING),
        }
    }

    /// One sample for every filter; a step that fails leaves its filter as it was.
    fn step(&mut self, u_prev: f64, y: f64) {
        let _ = self.ekf.step(&[u_prev], &[y]);
        let _ = self.dkf.step(&[u_prev], &[y]);
        let _ = self.long.step(&[u_prev], &[y]);
    }

    /// The estimates in the order of [`LABELS`].
    fn estimates(&self) -> [[f64; 5]; 4] {
        [
            self.ekf.state(),
            self.dkf.akf_state(),
            self.dkf.state(),
            self.long.state(),
        ]
    }
}

/// Runs `filters` on the Euler beam (or `kind`) with noise `sigma` (seed `seed`) under the
/// paper's PRBS for [`RUN_END`] seconds, recording every estimate.
fn run(mut filters: Filters, kind: PlantKind, sigma: f64, seed: u64) -> Trace {
    let mut plant = Plant::new(PlantConfig {
        kind,
        noise: GaussianNoise::new(sigma, seed),
        ..PlantConfig::default()
    });
    let mut prbs = Prbs::paper();
    let mut trace = Trace::new();
    let mut u_prev = 0.0;
    for _ in 0..=(RUN_END / TS).round() as usize {
        let y = plant.output();
        trace.begin(plant.time());
        filters.step(u_prev, y);
        for (label, x) in LABELS.iter().zip(filters.estimates()) {
            trace.set_estimate(label, &x);
        }
        u_prev = prbs.next().unwrap_or(0.0);
        plant.step(u_prev);
    }
    for label in LABELS {
        trace.add_readout(label);
    }
    trace
}

/// The mean pole read-out wn of `label` over `from..RUN_END`, with the share of samples
/// that have one (an estimate without an oscillating mode has no wn); None if it diverged.
fn mean_wn(trace: &Trace, label: &str, from: f64) -> Option<(f64, f64)> {
    if report::divergence_time(trace, label).is_some() {
        return None;
    }
    let wn = trace.column(&format!("{label} wn")).unwrap_or(&[]);
    let defined: Vec<f64> = wn
        .iter()
        .map(|&v| f64::from(u8::from(v.is_finite())))
        .collect();
    let share = mean(trace.time(), &defined, from, RUN_END);
    let finite: Vec<f64> = wn
        .iter()
        .map(|&v| if v.is_finite() { v } else { 0.0 })
        .collect();
    Some((mean(trace.time(), &finite, from, RUN_END) / share, share))
}

/// The sensitivity table: mean wn over 2-15 s per noise level, from the paper's close and
/// wrong guesses.
pub fn table() {
    let cases = [
        ("Euler, sigma 1e-4 mm", PlantKind::Euler, 1e-4),
        ("Euler, sigma 1e-3 mm", PlantKind::Euler, 1e-3),
        ("Euler, sigma 1e-2 mm", PlantKind::Euler, 1e-2),
        ("Euler, sigma 0.03 mm = sqrt(R)", PlantKind::Euler, 0.03),
        (
            "exactly sampled (ZOH), sigma 1e-4",
            PlantKind::ExactZoh,
            1e-4,
        ),
    ];
    for (guess, x0, p3) in [("close", X0_CLOSE, 2e4), ("wrong", X0_WRONG, 2e6)] {
        println!(
            "\nSensitivity, {guess} guess: mean wn from poles over 2-15 s (truth {WN_TRUE} rad/s)"
        );
        let header: String = LABELS.iter().map(|l| format!(" {l:>17}")).collect();
        println!("{:<34}{header}", "plant");
        for (name, kind, sigma) in cases {
            let trace = run(Filters::new(&x0, p3), kind, sigma, 11);
            let mut row = format!("{name:<34}");
            for label in LABELS {
                let value = match mean_wn(&trace, label, 2.0) {
                    None => "diverged".to_owned(),
                    Some((wn, share)) if share < 0.999 => {
                        format!("{wn:.2} ({:.0}% no wn)", 100.0 * (1.0 - share))
                    }
                    Some((wn, _)) => format!("{wn:.2}"),
                };
                row.push_str(&format!(" {value:>17}"));
            }
            println!("{row}");
        }
    }
}

/// Runs in the Monte Carlo per noise level.
const GUESSES: usize = 500;
/// A run has converged when its mean wn over [`SETTLED_FROM`]..15 s is within this
/// relative error of the truth and every sample there has a wn.
const CONVERGED_WITHIN: f64 = 0.05;
const SETTLED_FROM: f64 = 10.0;

/// A wrong initial guess: x3 = -400 * 10^a (a uniform in -1..2: wn from 6 to 630 rad/s),
/// x4 uniform in -20..0, x5 = 0.5 * 10^b (b uniform in -1.5..0.5), from the uniform
/// numbers `r`.
fn wrong_guess(r: [f64; 3]) -> [f64; 5] {
    [
        0.01,
        0.0,
        -400.0 * 10f64.powf(-1.0 + 3.0 * r[0]),
        -20.0 * r[1],
        0.5 * 10f64.powf(-1.5 + 2.0 * r[2]),
    ]
}

/// The stream the wrong guesses are drawn from.
const GUESS_SEED: u64 = 2026;

/// Per filter: runs that converged, and their mean relative wn error.
type Outcome = [(usize, f64); 4];

/// [`GUESSES`] wrong guesses at noise `sigma`, each with its own noise seed.
fn outcomes(sigma: f64) -> Outcome {
    let mut outcome: Outcome = [(0, 0.0); 4];
    for run_index in 0..GUESSES {
        let draw = |i: u64| uniform(GUESS_SEED, 3 * run_index as u64 + i);
        let x0 = wrong_guess([draw(0), draw(1), draw(2)]);
        let trace = run(
            Filters::new(&x0, 2e6),
            PlantKind::Euler,
            sigma,
            100 + run_index as u64,
        );
        for (label, (converged, error)) in LABELS.iter().zip(outcome.iter_mut()) {
            let Some((wn, share)) = mean_wn(&trace, label, SETTLED_FROM) else {
                continue;
            };
            let relative = (wn - WN_TRUE).abs() / WN_TRUE;
            if share >= 0.999 && relative <= CONVERGED_WITHIN {
                *converged += 1;
                *error += relative;
            }
        }
    }
    outcome
}

/// The Monte Carlo of wrong guesses at sigma 1e-3 and 1e-2 mm.
pub fn monte_carlo() {
    println!(
        "\nFrom {GUESSES} wrong guesses (x3 -40 to -40000, x4 -20 to 0, x5 0.016 to 1.6; P0 \
         with p3 = 2e6): runs whose mean wn over {SETTLED_FROM}-{RUN_END} s is within {:.0} % \
         of {WN_TRUE} rad/s, and their mean wn error",
        100.0 * CONVERGED_WITHIN
    );
    let header: String = LABELS.iter().map(|l| format!(" {l:>17}")).collect();
    println!("{:<20}{header}", "noise");
    for sigma in [1e-3, 1e-2] {
        let mut row = format!("{:<20}", format!("sigma {sigma:e} mm"));
        for (converged, error) in outcomes(sigma) {
            let mean_error = if converged > 0 {
                format!("{:.2} %", 100.0 * error / converged as f64)
            } else {
                "-".to_owned()
            };
            row.push_str(&format!(" {:>17}", format!("{converged} ({mean_error})")));
        }
        println!("{row}");
    }
}
