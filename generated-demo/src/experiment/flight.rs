//! The navigation experiment: the generated 24-state EKF (`generated-demo/models/navigation.rs`)
//! on a simulated multirotor flight ([`generated_demo::flight`]): the IMU at 250 Hz
//! (`predict`), the magnetometer at 50 Hz (`update_magnetometer`), the GNSS at 5 Hz
//! (`update_gnss`) with a 10 s outage. Errors of attitude, velocity, position and IMU
//! biases against the truth, with the filter's own 3-sigma bounds, and each sensor's
//! normalised innovation squared, for the `f32` filter (what the MCU runs) and the `f64`
//! one.

use super::report::{self, Line, Trace};
use generated_demo::flight::{
    conjugate, initial_estimate, quaternion_product, rotation_vector, tuning, Flight, Truth,
    ACCEL_BIAS, DT, END, GNSS_OUTAGE, GYRO_BIAS, MAGNETOMETER_GATE,
};
use generated_demo::navigation;
use std::error::Error;
use std::path::Path;

/// What the experiment reports of a quantity: its name, how to read its error and
/// standard deviation from a sample, and its unit's scale.
struct Quantity {
    name: &'static str,
    unit: &'static str,
    /// Index into the error vector ([`errors`]).
    index: usize,
    /// Multiplies the error and sigma for printing (degrees, per second).
    scale: f64,
}

/// The reported quantities, in the order of [`errors`].
const QUANTITIES: [Quantity; 15] = {
    const fn q(name: &'static str, unit: &'static str, index: usize, scale: f64) -> Quantity {
        Quantity {
            name,
            unit,
            index,
            scale,
        }
    }
    let deg = 180.0 / core::f64::consts::PI;
    [
        q("roll", "deg", 0, deg),
        q("pitch", "deg", 1, deg),
        q("yaw", "deg", 2, deg),
        q("velocity N", "m/s", 3, 1.0),
        q("velocity E", "m/s", 4, 1.0),
        q("velocity D", "m/s", 5, 1.0),
        q("position N", "m", 6, 1.0),
        q("position E", "m", 7, 1.0),
        q("position D", "m", 8, 1.0),
        q("gyro bias x", "deg/s", 9, deg / DT),
        q("gyro bias y", "deg/s", 10, deg / DT),
        q("gyro bias z", "deg/s", 11, deg / DT),
        q("accel bias x", "m/s^2", 12, 1.0 / DT),
        q("accel bias y", "m/s^2", 13, 1.0 / DT),
        q("accel bias z", "m/s^2", 14, 1.0 / DT),
    ]
};

/// The estimate's errors against the truth and their standard deviations from `p`:
/// attitude as the body-frame rotation vector of `conj(q_est) q_true` (its covariance
/// `4 G P_qq G'`, `G` the vector part of `conj(q_est) dq`), then velocity, position and the
/// IMU biases (per sample) as differences.
fn errors(x: &[f64; 24], p: &[[f64; 24]; 24], truth: &Truth) -> ([f64; 15], [f64; 15]) {
    let q_est = [x[0], x[1], x[2], x[3]];
    let q_true = [truth.x[0], truth.x[1], truth.x[2], truth.x[3]];
    let norm = q_est.iter().map(|v| v * v).sum::<f64>().sqrt();
    let attitude = rotation_vector(quaternion_product(
        conjugate(q_est.map(|v| v / norm)),
        q_true,
    ));
    let [w, a, b, c] = q_est;
    let g = [[-a, w, c, -b], [-b, -c, w, a], [-c, b, -a, w]];
    let mut error = [0.0; 15];
    let mut sigma = [0.0; 15];
    for i in 0..3 {
        error[i] = attitude[i];
        let variance: f64 = (0..4)
            .flat_map(|j| (0..4).map(move |k| (j, k)))
            .map(|(j, k)| 4.0 * g[i][j] * p[j][k] * g[i][k])
            .sum();
        sigma[i] = variance.max(0.0).sqrt();
    }
    for (slot, state) in (3..15).zip(4..16) {
        error[slot] = x[state] - truth.x[state];
        sigma[slot] = p[state][state].max(0.0).sqrt();
    }
    (error, sigma)
}

/// What a filter did with a sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Outcome {
    Used,
    Rejected,
}

/// The `f32` and `f64` filters behind one interface, so that one loop runs both.
trait NavigationFilter: Sized {
    fn create(x0: &[f64; 24], p0: &[f64; 24], q: &[f64; 24], r: &[f64; 9]) -> Result<Self, String>;
    fn predict(&mut self, imu: &[f64; 6]) -> Result<Outcome, String>;
    fn update_gnss(&mut self, y: &[f64; 6]) -> Result<Outcome, String>;
    fn update_magnetometer(&mut self, y: &[f64; 3]) -> Result<Outcome, String>;
    fn estimate(&self) -> ([f64; 24], [[f64; 24]; 24]);
    fn nis(&self) -> (f64, f64);
}

/// Implements [`NavigationFilter`] for the filter of one scalar type's module.
macro_rules! navigation_filter {
    ($module:ident $(:: $inner:ident)*, $scalar:ty, $outcome:ident) => {
        /// A status as an outcome: used, rejected as an outlier, or a failure named.
        fn $outcome(status: $module $(:: $inner)*::Status) -> Result<Outcome, String> {
            use $module $(:: $inner)*::Status;
            match status {
                Status::Ok => Ok(Outcome::Used),
                Status::OutlierRejected => Ok(Outcome::Rejected),
                other => Err(format!("{other:?}")),
            }
        }

        impl NavigationFilter for $module $(:: $inner)*::Ekf {
            fn create(
                x0: &[f64; 24],
                p0: &[f64; 24],
                q: &[f64; 24],
                r: &[f64; 9],
            ) -> Result<Self, String> {
                let cast = |v: f64| v as $scalar;
                let mut ekf = <$module $(:: $inner)*::Ekf>::new(
                    &x0.map(cast),
                    &super::diag(p0.map(cast)),
                    &q.map(cast),
                    &super::diag(r.map(cast)),
                )
                .map_err(|status| format!("tuning rejected: {status:?}"))?;
                let gate = ekf.set_magnetometer_innovation_gate(cast(MAGNETOMETER_GATE));
                $outcome(gate).map(|_| ekf)
            }
            fn predict(&mut self, imu: &[f64; 6]) -> Result<Outcome, String> {
                $outcome(<$module $(:: $inner)*::Ekf>::predict(self, &imu.map(|v| v as $scalar)))
            }
            fn update_gnss(&mut self, y: &[f64; 6]) -> Result<Outcome, String> {
                $outcome(<$module $(:: $inner)*::Ekf>::update_gnss(self, &y.map(|v| v as $scalar)))
            }
            fn update_magnetometer(&mut self, y: &[f64; 3]) -> Result<Outcome, String> {
                $outcome(<$module $(:: $inner)*::Ekf>::update_magnetometer(self, &y.map(|v| v as $scalar)))
            }
            fn estimate(&self) -> ([f64; 24], [[f64; 24]; 24]) {
                let p = self.covariance();
                let x = self.state();
                (
                    std::array::from_fn(|i| f64::from(x[i])),
                    std::array::from_fn(|i| std::array::from_fn(|j| f64::from(p[i][j]))),
                )
            }
            fn nis(&self) -> (f64, f64) {
                (
                    f64::from(self.gnss_normalised_innovation_squared()),
                    f64::from(self.magnetometer_normalised_innovation_squared()),
                )
            }
        }
    };
}

navigation_filter!(navigation, f32, outcome_f32);
navigation_filter!(navigation::in_f64, f64, outcome_f64);

/// How one quantity's error behaved over the flight.
#[derive(Clone, Copy, Debug, Default)]
struct ErrorStats {
    squares: f64,
    samples: usize,
    inside: usize,
    worst_ratio: f64,
}

impl ErrorStats {
    fn add(&mut self, error: f64, sigma: f64) {
        self.squares += error * error;
        self.samples += 1;
        let ratio = error.abs() / sigma;
        self.inside += usize::from(ratio <= 3.0);
        self.worst_ratio = self.worst_ratio.max(ratio);
    }

    fn rms(&self) -> f64 {
        (self.squares / self.samples.max(1) as f64).sqrt()
    }

    fn inside_fraction(&self) -> f64 {
        self.inside as f64 / self.samples.max(1) as f64
    }
}

/// What one run gave: the error statistics, each sensor's NIS, its rejections, and the
/// largest departure of the quaternion's norm from 1.
#[derive(Debug, Default)]
struct Summary {
    stats: [ErrorStats; 15],
    gnss_nis: Vec<f64>,
    magnetometer_nis: Vec<f64>,
    rejected: [usize; 2],
    worst_norm_error: f64,
}

/// Flies the flight with a filter of type `F`; records errors and 3-sigma bounds at 10 Hz
/// into `trace` under `tag`.
fn fly<F: NavigationFilter>(tag: &str, trace: &mut Trace) -> Result<Summary, String> {
    let mut flight = Flight::new();
    let first_magnetometer = loop {
        if let Some(m) = flight.advance().1.magnetometer {
            break m;
        }
    };
    let (p0, q, r) = tuning();
    let mut filter = F::create(&initial_estimate(first_magnetometer), &p0, &q, &r)?;
    let mut summary = Summary::default();
    let samples = (END / DT).round() as usize;
    for k in 0..samples {
        let (truth, readings) = flight.advance();
        let at = |what: &str, e: String| format!("{tag} {what} at {:.3} s: {e}", truth.t);
        filter
            .predict(&readings.imu)
            .map_err(|e| at("predict", e))?;
        if let Some(y) = readings.magnetometer {
            let outcome = filter
                .update_magnetometer(&y)
                .map_err(|e| at("magnetometer", e))?;
            summary.rejected[1] += usize::from(outcome == Outcome::Rejected);
            summary.magnetometer_nis.push(filter.nis().1);
        }
        if let Some(y) = readings.gnss {
            let outcome = filter.update_gnss(&y).map_err(|e| at("GNSS", e))?;
            summary.rejected[0] += usize::from(outcome == Outcome::Rejected);
            summary.gnss_nis.push(filter.nis().0);
        }
        let (x, p) = filter.estimate();
        let norm = (x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + x[3] * x[3]).sqrt();
        summary.worst_norm_error = summary.worst_norm_error.max((norm - 1.0).abs());
        if k.is_multiple_of(25) {
            record(tag, trace, &truth, &x, &p, &mut summary);
        }
    }
    Ok(summary)
}

/// One 10 Hz row: every quantity's error and 3-sigma bound into `trace`, and into the
/// statistics.
fn record(
    tag: &str,
    trace: &mut Trace,
    truth: &Truth,
    x: &[f64; 24],
    p: &[[f64; 24]; 24],
    summary: &mut Summary,
) {
    let (error, sigma) = errors(x, p, truth);
    trace.begin(truth.t);
    for quantity in &QUANTITIES {
        let (e, s) = (error[quantity.index], sigma[quantity.index]);
        summary.stats[quantity.index].add(e, s);
        trace.set(
            &format!("{tag} {} error", quantity.name),
            e * quantity.scale,
        );
        trace.set(
            &format!("{tag} {} 3 sigma", quantity.name),
            3.0 * s * quantity.scale,
        );
        trace.set(
            &format!("{tag} {} -3 sigma", quantity.name),
            -3.0 * s * quantity.scale,
        );
    }
}

/// The mean of `values`.
fn mean(values: &[f64]) -> f64 {
    values.iter().sum::<f64>() / values.len().max(1) as f64
}

/// Prints the table of one run.
fn print_summary(title: &str, summary: &Summary) {
    println!("\n{title}:");
    println!(
        "{:<14} {:>7} {:>12} {:>14} {:>15}",
        "quantity", "unit", "RMS error", "max |e|/sigma", "inside 3 sigma"
    );
    for quantity in &QUANTITIES {
        let stats = &summary.stats[quantity.index];
        println!(
            "{:<14} {:>7} {:>12.4} {:>14.2} {:>14.1} %",
            quantity.name,
            quantity.unit,
            stats.rms() * quantity.scale,
            stats.worst_ratio,
            100.0 * stats.inside_fraction()
        );
    }
    println!(
        "NIS: GNSS mean {:.2} over {} fixes (6 expected), {} rejected; magnetometer mean {:.2} over {} samples (3 expected), {} rejected",
        mean(&summary.gnss_nis),
        summary.gnss_nis.len(),
        summary.rejected[0],
        mean(&summary.magnetometer_nis),
        summary.magnetometer_nis.len(),
        summary.rejected[1]
    );
    println!(
        "largest |quaternion norm - 1| over the flight: {:.2e}",
        summary.worst_norm_error
    );
}

/// Runs the flight with the `f32` and the `f64` filter, prints their tables, writes
/// `out/navigation.csv` and the plots.
pub fn run(out: &Path) -> Result<(), Box<dyn Error>> {
    let mut trace = Trace::new();
    let single = fly::<navigation::Ekf>("f32", &mut trace)?;
    let mut trace64 = Trace::new();
    let double = fly::<navigation::in_f64::Ekf>("f64", &mut trace64)?;
    println!(
        "\nNavigation: the generated 24-state EKF (PX4 ecl EKF2's delta-angle formulation) on"
    );
    println!(
        "a simulated {END:.0} s multirotor flight: take-off, cruise at 5 m/s with two turns and a climb,"
    );
    println!(
        "GNSS outage {:.0}-{:.0} s. IMU 250 Hz (gyro bias {:?} rad/s, accelerometer bias {:?} m/s^2),",
        GNSS_OUTAGE.0, GNSS_OUTAGE.1, GYRO_BIAS, ACCEL_BIAS
    );
    println!("magnetometer 50 Hz (update_magnetometer), GNSS 5 Hz (update_gnss); errors against the truth at 10 Hz,");
    println!("sigma from the filter's covariance. The quaternion is not normalised: its norm drifts (the");
    println!(
        "last line), and normalising the state alone, without its covariance, breaks the filter."
    );
    print_summary("f32 filter (the MCU's code)", &single);
    print_summary("f64 filter", &double);
    report::write_csv(&trace, std::fs::File::create(out.join("navigation.csv"))?)?;
    plot(&trace, out)?;
    Ok(())
}

/// The plots: yaw, north position and down velocity errors with their 3-sigma bounds.
fn plot(trace: &Trace, out: &Path) -> Result<(), Box<dyn Error>> {
    for (quantity, file, unit) in [
        ("yaw", "navigation_yaw.svg", "deg"),
        ("position N", "navigation_position.svg", "m"),
        ("velocity D", "navigation_velocity.svg", "m/s"),
        ("gyro bias z", "navigation_gyro_bias.svg", "deg/s"),
    ] {
        let names = [
            format!("f32 {quantity} error"),
            format!("f32 {quantity} 3 sigma"),
            format!("f32 {quantity} -3 sigma"),
        ];
        let lines: Vec<Line> = names.iter().filter_map(|n| trace.line(n)).collect();
        report::plot_lines(
            &out.join(file),
            &format!("Navigation EKF (f32): {quantity} error and its 3-sigma bounds"),
            &format!("{quantity} error [{unit}]"),
            &lines,
            None,
        )?;
    }
    Ok(())
}
