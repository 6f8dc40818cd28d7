//! The filter's claims about itself, checked against the truth over a seeded Monte-Carlo
//! run: its covariance describes its errors (NEES), each sensor's innovations are as
//! large as it predicts (NIS), the attitude error stays within its own 3-sigma, and the
//! quaternion stays a unit quaternion.
//!
//! Every run starts from an error drawn from the filter's initial covariance (5 degrees
//! per axis of attitude, 0.02 rad/s of bias), so a consistent filter's NEES has mean 6
//! from the first sample, not only after it has converged.

use ahrs::simulation::{self, Sample, RATE};

/// Runs of the Monte-Carlo set, each with its own seed.
const RUNS: u64 = 100;
/// Samples of each run: 30 s.
const SAMPLES: usize = 30 * RATE;

/// What the runs measured.
#[derive(Default)]
struct Totals {
    nees: f64,
    samples: usize,
    accel_nis: f64,
    accel_updates: usize,
    mag_nis: f64,
    mag_updates: usize,
    /// Samples whose attitude error exceeded 3 sigma, per axis.
    beyond_three_sigma: [usize; 3],
    /// The largest `|norm(q) - 1|` of the estimate.
    worst_norm: f64,
}

impl Totals {
    fn add(&mut self, s: &Sample) {
        self.nees += s.nees().expect("the covariance stays positive definite");
        self.samples += 1;
        self.accel_nis += f64::from(s.accel_nis);
        self.accel_updates += 1;
        if let Some(nis) = s.mag_nis {
            self.mag_nis += f64::from(nis);
            self.mag_updates += 1;
        }
        let (error, sigma) = (s.error(), s.sigma());
        for axis in 0..3 {
            if error[axis].abs() > 3.0 * sigma[axis] {
                self.beyond_three_sigma[axis] += 1;
            }
        }
        let norm = s.estimate[..4]
            .iter()
            .map(|c| f64::from(*c).powi(2))
            .sum::<f64>();
        self.worst_norm = self.worst_norm.max((norm.sqrt() - 1.0).abs());
    }
}

fn monte_carlo() -> Totals {
    let mut totals = Totals::default();
    for seed in 1..=RUNS {
        simulation::run(seed, SAMPLES, |s| totals.add(s)).expect("every step succeeds");
    }
    totals
}

#[test]
fn the_filter_is_consistent_with_its_errors_and_its_sensors() {
    let totals = monte_carlo();
    assert_eq!(totals.samples, RUNS as usize * SAMPLES);
    let nees = totals.nees / totals.samples as f64;
    let accel_nis = totals.accel_nis / totals.accel_updates as f64;
    let mag_nis = totals.mag_nis / totals.mag_updates as f64;
    println!("mean NEES {nees:.3} (of 6), NIS accelerometer {accel_nis:.3}, magnetometer {mag_nis:.3} (of 3)");
    assert!((nees - 6.0).abs() < 0.6, "mean NEES {nees} (6 expected)");
    assert!(
        (accel_nis - 3.0).abs() < 0.3,
        "accelerometer NIS {accel_nis}"
    );
    assert!((mag_nis - 3.0).abs() < 0.3, "magnetometer NIS {mag_nis}");
    // A Gaussian error is beyond 3 sigma 0.27 % of the time; allow 1 %.
    for (axis, beyond) in totals.beyond_three_sigma.iter().enumerate() {
        let fraction = *beyond as f64 / totals.samples as f64;
        println!(
            "attitude axis {axis}: beyond 3 sigma {:.3} % of the samples",
            100.0 * fraction
        );
        assert!(fraction < 0.01, "axis {axis}: beyond 3 sigma {fraction}");
    }
    assert!(
        totals.worst_norm < 1e-6,
        "|norm(q) - 1| up to {}",
        totals.worst_norm
    );
}
