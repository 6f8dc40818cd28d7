//! The data the firmwares run on, as `f32`, taken once from the host's experiments: the
//! cantilever's measured sequence (`generated_demo::sequence`) and the first seconds of
//! the navigation flight (`generated_demo::flight`). Written once for both firmwares:
//! `build.rs` embeds it in the Rust firmware as Rust, and `cargo xtask`'s C firmware
//! (`xtask/src/c_firmware.rs`) as C, so that the two run exactly the same inputs.

/// Samples of the measured sequence (15 s at 15 ms).
pub const SAMPLES: usize = 1000;

/// IMU samples of the navigation flight (4 s at the nominal 250 Hz: 200 magnetometer
/// samples, 20 GNSS fixes).
pub const NAVIGATION_SAMPLES: usize = 1000;

/// The measured sequence: `(u[k], y[k])`.
pub fn sequence() -> Vec<(f32, f32)> {
    generated_demo::sequence::Measured::new()
        .take(SAMPLES)
        .map(|sample| (sample.u, sample.y))
        .collect()
}

/// The navigation flight as the host's experiment flies it, in `f32`.
pub struct Flight {
    /// The filter's initial estimate (`flight::initial_estimate`, from the first
    /// magnetometer sample).
    pub x0: Vec<f32>,
    /// The diagonal of `P0` over the 23 tangent coordinates (`flight::tuning`).
    pub p0: Vec<f32>,
    /// The diagonal of `Q`.
    pub q: Vec<f32>,
    /// The diagonal of `R`.
    pub r: Vec<f32>,
    /// The IMU samples' intervals \[s\], jittered (`Readings::interval`).
    pub interval: Vec<f32>,
    /// The IMU samples as the model's inputs (rates: `Readings::rates`).
    pub imu: Vec<Vec<f32>>,
    /// The magnetometer readings, with the index of the IMU sample they follow.
    pub magnetometer: Vec<(usize, Vec<f32>)>,
    /// The GNSS fixes (NED velocity, position), with the index of the IMU sample they
    /// follow.
    pub gnss: Vec<(usize, Vec<f32>)>,
}

/// `values` as `f32`.
fn single(values: impl IntoIterator<Item = f64>) -> Vec<f32> {
    values.into_iter().map(|v| v as f32).collect()
}

/// The flight's first [`NAVIGATION_SAMPLES`] IMU samples after the first magnetometer
/// sample, which sets the initial estimate.
pub fn flight() -> Flight {
    use generated_demo::flight::{initial_estimate, tuning};
    let mut flight = generated_demo::flight::Flight::new();
    let first_magnetometer = loop {
        if let Some(m) = flight.advance().1.magnetometer {
            break m;
        }
    };
    let (p0, q, r) = tuning();
    let mut data = Flight {
        x0: single(initial_estimate(first_magnetometer)),
        p0: single(p0),
        q: single(q),
        r: single(r),
        interval: Vec::new(),
        imu: Vec::new(),
        magnetometer: Vec::new(),
        gnss: Vec::new(),
    };
    for k in 0..NAVIGATION_SAMPLES {
        let readings = flight.advance().1;
        data.interval.push(readings.interval as f32);
        data.imu.push(single(readings.rates()));
        if let Some(m) = readings.magnetometer {
            data.magnetometer.push((k, single(m)));
        }
        if let Some(g) = readings.gnss {
            data.gnss.push((k, single(g)));
        }
    }
    data
}
