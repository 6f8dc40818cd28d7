//! Runs one minute of a tumbling body and prints the attitude error against the filter's
//! own 3-sigma bound, the gyro bias it estimated, and each sensor's mean normalised
//! innovation squared (NIS) and the mean normalised estimation error squared (NEES).

use ahrs::simulation::{self, Sample, RATE};

/// Samples of the run: one minute.
const SAMPLES: usize = 60 * RATE;

fn main() {
    println!(
        "  time   attitude error (N, E, D) [deg]   3-sigma [deg]         bias (true, est.) [deg/s]"
    );
    let (mut accel_nis, mut mag_nis, mut nees) =
        (Mean::default(), Mean::default(), Mean::default());
    let mut worst_norm = 0.0_f64;
    let outcome = simulation::run(1, SAMPLES, |s: &Sample| {
        accel_nis.add(f64::from(s.accel_nis));
        if let Some(nis) = s.mag_nis {
            mag_nis.add(f64::from(nis));
        }
        nees.add(s.nees().unwrap_or(f64::INFINITY));
        let norm = s.estimate[..4]
            .iter()
            .map(|c| f64::from(*c).powi(2))
            .sum::<f64>();
        worst_norm = worst_norm.max((norm.sqrt() - 1.0).abs());
        if s.k.is_multiple_of(5 * RATE) || s.k == 1 {
            print_sample(s);
        }
    });
    if let Err(status) = outcome {
        eprintln!("the generated filter stopped: {status:?}");
        std::process::exit(1);
    }
    println!(
        "mean NIS: accelerometer {:.2} (of 3), magnetometer {:.2} (of 3); mean NEES {:.2} (of 6)",
        accel_nis.value(),
        mag_nis.value(),
        nees.value(),
    );
    println!("largest |norm(q) - 1| of the f32 estimate: {worst_norm:.1e}");
}

fn print_sample(s: &Sample) {
    let deg = 180.0 / std::f64::consts::PI;
    let (error, sigma) = (s.error() * deg, s.sigma() * deg);
    let (truth, estimate) = (s.truth.gyro_bias * deg, s.gyro_bias() * deg);
    println!(
        "{:5.1} s {:7.3} {:7.3} {:7.3}   {:6.3} {:6.3} {:6.3}   {:6.3} {:6.3}  {:6.3} {:6.3}  {:6.3} {:6.3}",
        s.k as f64 / RATE as f64,
        error[0],
        error[1],
        error[2],
        3.0 * sigma[0],
        3.0 * sigma[1],
        3.0 * sigma[2],
        truth.x,
        estimate.x,
        truth.y,
        estimate.y,
        truth.z,
        estimate.z,
    );
}

/// A running mean.
#[derive(Default)]
struct Mean {
    sum: f64,
    count: usize,
}

impl Mean {
    fn add(&mut self, value: f64) {
        self.sum += value;
        self.count += 1;
    }

    fn value(&self) -> f64 {
        self.sum / self.count as f64
    }
}
