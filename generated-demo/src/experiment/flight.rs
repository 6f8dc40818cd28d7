//! The navigation experiment: the generated 24-state error-state EKF
//! (`generated-demo/models/navigation.rs`, a 23-dimensional covariance) on a simulated
//! multirotor flight ([`generated_demo::flight`]): the IMU at a nominal 250 Hz, its
//! intervals jittered (`predict(dt, u)`), the magnetometer at 50 Hz
//! (`update_magnetometer`), the GNSS at 5 Hz (`update_gnss`) with a 10 s outage. Errors
//! of attitude, velocity, position and IMU biases against the truth, with the filter's own
//! 3-sigma bounds, each sensor's normalised innovation squared and the quaternion's
//! largest departure from unit norm, for the `f32` filter (what the MCU runs) and the
//! `f64` one.

use super::report::{self, Line, Trace};
use generated_demo::flight::{
    conjugate, initial_estimate, quaternion_product, rotate, rotation_vector, tuning, Flight,
    Truth, ACCEL_BIAS, DROPPED, DT, END, GNSS_OUTAGE, GYRO_BIAS, JITTER,
};
use generated_demo::navigation::{self, TANGENT_LEN, X_LEN};
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
const QUANTITIES: [Quantity; 18] = {
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
        q("attitude N", "deg", 3, deg),
        q("attitude E", "deg", 4, deg),
        q("attitude D", "deg", 5, deg),
        q("velocity N", "m/s", 6, 1.0),
        q("velocity E", "m/s", 7, 1.0),
        q("velocity D", "m/s", 8, 1.0),
        q("position N", "m", 9, 1.0),
        q("position E", "m", 10, 1.0),
        q("position D", "m", 11, 1.0),
        q("gyro bias x", "deg/s", 12, deg),
        q("gyro bias y", "deg/s", 13, deg),
        q("gyro bias z", "deg/s", 14, deg),
        q("accel bias x", "m/s^2", 15, 1.0),
        q("accel bias y", "m/s^2", 16, 1.0),
        q("accel bias z", "m/s^2", 17, 1.0),
    ]
};

/// A state's quaternion `[x, y, z, w]` (the model's order) as `[w, x, y, z]` (the
/// flight's helpers').
fn w_first(x: &[f64; X_LEN]) -> [f64; 4] {
    [x[3], x[0], x[1], x[2]]
}

/// The estimate's errors against the truth and their standard deviations from `p` (over
/// the tangent coordinates): the attitude error about the body axes (roll, pitch, yaw:
/// `Log(conj(q_est) q_true)`, the earth-frame error turned into the body, its covariance
/// `R' P_θθ R`), the filter's own attitude error about N, E, D (`δθ = Log(q_true
/// conj(q_est))`, so that the truth is `Exp(δθ) q_est`; its covariance the attitude block),
/// then velocity, position and the IMU biases as differences.
fn errors(
    x: &[f64; X_LEN],
    p: &[[f64; TANGENT_LEN]; TANGENT_LEN],
    truth: &Truth,
) -> ([f64; 18], [f64; 18]) {
    let (q_est, q_true) = (w_first(x), w_first(&truth.x));
    let body = rotation_vector(quaternion_product(conjugate(q_est), q_true));
    let earth = rotation_vector(quaternion_product(q_true, conjugate(q_est)));
    let mut error = [0.0; 18];
    let mut sigma = [0.0; 18];
    for i in 0..3 {
        let mut axis = [0.0; 3];
        axis[i] = 1.0;
        let r = rotate(q_est, axis, false);
        let variance: f64 = (0..3)
            .flat_map(|j| (0..3).map(move |k| (j, k)))
            .map(|(j, k)| r[j] * p[j][k] * r[k])
            .sum();
        (error[i], sigma[i]) = (body[i], variance.max(0.0).sqrt());
        (error[3 + i], sigma[3 + i]) = (earth[i], p[i][i].max(0.0).sqrt());
    }
    // After the quaternion's four entries, an entry of `x` is a tangent coordinate one
    // place earlier.
    for (slot, entry) in (6..18).zip(4..16) {
        error[slot] = x[entry] - truth.x[entry];
        sigma[slot] = p[entry - 1][entry - 1].max(0.0).sqrt();
    }
    (error, sigma)
}

/// What a filter did with a sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Outcome {
    Used,
    Rejected,
}

/// The `f32` and `f64` filters behind one interface, so that one loop runs both.
pub(super) trait NavigationFilter: Sized {
    fn create(
        x0: &[f64; X_LEN],
        p0: &[f64; TANGENT_LEN],
        q: &[f64; TANGENT_LEN],
        r: &[f64; 9],
    ) -> Result<Self, String>;
    /// A prediction over the IMU sample's interval `dt` \[s\].
    fn predict(&mut self, dt: f64, imu: &[f64; 6]) -> Result<Outcome, String>;
    fn update_gnss(&mut self, y: &[f64; 6]) -> Result<Outcome, String>;
    fn update_magnetometer(&mut self, y: &[f64; 3]) -> Result<Outcome, String>;
    fn estimate(&self) -> ([f64; X_LEN], [[f64; TANGENT_LEN]; TANGENT_LEN]);
    /// The state at the current sample: the estimate, or a delayed filter's output
    /// predictor's.
    fn current(&self) -> [f64; X_LEN];
    fn nis(&self) -> (f64, f64);
}

/// A status as an outcome: used, rejected as an outlier, or a failure named (one `Status`
/// serves the module's filters of both scalar types).
fn outcome(status: navigation::Status) -> Result<Outcome, String> {
    use navigation::Status;
    match status {
        Status::Ok => Ok(Outcome::Used),
        Status::OutlierRejected => Ok(Outcome::Rejected),
        other => Err(format!("{other:?}")),
    }
}

/// Implements [`NavigationFilter`] for a filter type of the navigation module, whose
/// current state `current` gives.
macro_rules! navigation_filter {
    ($filter:ty, $scalar:ty, $current:ident) => {
        impl NavigationFilter for $filter {
            fn create(
                x0: &[f64; X_LEN],
                p0: &[f64; TANGENT_LEN],
                q: &[f64; TANGENT_LEN],
                r: &[f64; 9],
            ) -> Result<Self, String> {
                let cast = |v: f64| v as $scalar;
                // Each sensor's gate is the model's (`sensor gnss(gate = 22.46)`,
                // `sensor magnetometer(gate = 16.27)`).
                <$filter>::new(
                    &x0.map(cast),
                    &super::diag(p0.map(cast)),
                    &q.map(cast),
                    &super::diag(r.map(cast)),
                )
                .map_err(|status| format!("tuning rejected: {status:?}"))
            }
            fn predict(&mut self, dt: f64, imu: &[f64; 6]) -> Result<Outcome, String> {
                outcome(<$filter>::predict(
                    self,
                    dt as $scalar,
                    &imu.map(|v| v as $scalar),
                ))
            }
            fn update_gnss(&mut self, y: &[f64; 6]) -> Result<Outcome, String> {
                outcome(<$filter>::update_gnss(self, &y.map(|v| v as $scalar)))
            }
            fn update_magnetometer(&mut self, y: &[f64; 3]) -> Result<Outcome, String> {
                outcome(<$filter>::update_magnetometer(
                    self,
                    &y.map(|v| v as $scalar),
                ))
            }
            fn estimate(&self) -> ([f64; X_LEN], [[f64; TANGENT_LEN]; TANGENT_LEN]) {
                let p = self.covariance();
                let x = self.state();
                (
                    std::array::from_fn(|i| f64::from(x[i])),
                    std::array::from_fn(|i| std::array::from_fn(|j| f64::from(p[i][j]))),
                )
            }
            fn current(&self) -> [f64; X_LEN] {
                self.$current().map(f64::from)
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

navigation_filter!(navigation::Ekf, f32, state);
navigation_filter!(navigation::in_f64::Ekf, f64, state);
navigation_filter!(navigation::DelayedEkf, f32, current_state);

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
    stats: [ErrorStats; 18],
    gnss_nis: Vec<f64>,
    magnetometer_nis: Vec<f64>,
    rejected: [usize; 2],
    worst_norm_error: f64,
}

/// Flies the flight with a filter of type `F`; records errors and 3-sigma bounds at 10 Hz
/// into `trace` under `tag`.
fn fly<F: NavigationFilter>(tag: &str, trace: &mut Trace) -> Result<Summary, String> {
    let (mut flight, mut filter) = start::<F>()?;
    let mut summary = Summary::default();
    let samples = (END / DT).round() as usize;
    for k in 0..samples {
        let (truth, readings) = flight.advance();
        let at = |what: &str, e: String| format!("{tag} {what} at {:.3} s: {e}", truth.t);
        filter
            .predict(readings.interval, &readings.rates())
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

/// The flight up to its first magnetometer sample, and a filter of type `F` started there
/// from the experiment's initial estimate and tuning.
pub(super) fn start<F: NavigationFilter>() -> Result<(Flight, F), String> {
    let mut flight = Flight::new();
    let first_magnetometer = loop {
        if let Some(m) = flight.advance().1.magnetometer {
            break m;
        }
    };
    let (p0, q, r) = tuning();
    let filter = F::create(&initial_estimate(first_magnetometer), &p0, &q, &r)?;
    Ok((flight, filter))
}

/// One 10 Hz row: every quantity's error and 3-sigma bound into `trace`, and into the
/// statistics.
fn record(
    tag: &str,
    trace: &mut Trace,
    truth: &Truth,
    x: &[f64; X_LEN],
    p: &[[f64; TANGENT_LEN]; TANGENT_LEN],
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
    let rms_3d = |first: usize| {
        let squares: f64 = (first..first + 3)
            .map(|i| summary.stats[i].rms().powi(2))
            .sum();
        (squares / 3.0).sqrt()
    };
    println!(
        "RMS over the three axes: velocity {:.4} m/s, position {:.4} m",
        rms_3d(6),
        rms_3d(9)
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
    println!("\nNavigation: the generated error-state EKF (PX4 EKF2's formulation: 24 entries, a");
    println!(
        "23-dimensional covariance) on a simulated multirotor flight of about {END:.0} s: take-off, cruise at"
    );
    println!(
        "5 m/s with two turns and a climb, GNSS outage {:.0}-{:.0} s. IMU nominally 250 Hz (gyro bias {:?} rad/s,",
        GNSS_OUTAGE.0, GNSS_OUTAGE.1, GYRO_BIAS
    );
    println!("accelerometer bias {ACCEL_BIAS:?} m/s^2), magnetometer 50 Hz (update_magnetometer), GNSS 5 Hz");
    println!(
        "(update_gnss); errors against the truth at 10 Hz, sigma from the filter's covariance."
    );
    println!(
        "The IMU's intervals jitter by up to {:.0} % about {:.0} ms, and about one sample in {:.0} \
         is dropped (the next covers two): predict(dt, u) takes each sample's own.",
        100.0 * JITTER,
        1e3 * DT,
        1.0 / DROPPED
    );
    println!("Attitude errors about the body axes (roll, pitch, yaw) and about N, E, D (the filter's own");
    println!(
        "error, true = Exp(dtheta) q_est). The quaternion stays a unit quaternion (the last line)."
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
