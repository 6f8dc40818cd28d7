//! The simulated flight of the navigation experiment: a multirotor's true attitude,
//! velocity and position as smooth functions of time (on the ground, take-off, a
//! 5 m/s cruise with two turns and a climb, hover), and what its sensors read: the IMU's
//! delta angle and delta velocity over each sample (integrated from the truth at four
//! steps per sample, with constant biases and white noise), the GNSS fix and the
//! magnetometer. The IMU's samples are 4 ms apart nominally, but their intervals jitter
//! by up to a fifth, and now and then a sample is dropped, so the next covers two
//! intervals ([`interval`]): what a flight controller's IMU driver delivers.
//! Independent of the filter's model: the truth's attitude increments are exact relative
//! rotations, its delta velocity an integral of the specific force, not the model's
//! first-order steps. The filter's initial estimate and tuning are here too
//! ([`initial_estimate`], [`tuning`]).
//!
//! In the `no_std` library, its functions of `f64` from `libm`, so that the host's
//! navigation experiment and the firmware's build script (which embeds a few seconds of
//! these readings for the Cortex-M4F) fly the same flight.

use crate::noise::GaussianNoise;

/// The IMU's nominal sample interval \[s\], the model's.
pub const DT: f64 = crate::navigation::in_f64::DT;
/// The IMU's interval jitter: each interval is `DT` times a uniform number in
/// `1 - JITTER ..= 1 + JITTER`.
pub const JITTER: f64 = 0.2;
/// The chance that the IMU driver drops a sample, so that the next one covers two
/// intervals (about one in two seconds).
pub const DROPPED: f64 = 0.002;
/// Gravity \[m/s^2\], down, the model's.
const GRAVITY: f64 = crate::navigation::in_f64::GRAVITY;
/// Truth integration steps per IMU sample (1 kHz at the nominal interval).
const SUBSTEPS: usize = 4;
/// The flight's length \[s\].
pub const END: f64 = 90.0;
/// The GNSS outage \[s\]: no fix from 50 to 60 s, in the second turn.
pub const GNSS_OUTAGE: (f64, f64) = (50.0, 60.0);
/// Heading at start \[rad\].
const HEADING0: f64 = 0.5;
/// The earth magnetic field \[gauss\], NED (a mid-latitude field, 65 degrees dip).
pub const EARTH_FIELD: [f64; 3] = [0.21, 0.01, 0.45];
/// The magnetometer's body bias \[gauss\] (hard iron).
pub const BODY_FIELD_BIAS: [f64; 3] = [0.02, -0.015, 0.03];
/// Gyro bias \[rad/s\] and accelerometer bias \[m/s^2\], body axes.
pub const GYRO_BIAS: [f64; 3] = [0.003, -0.004, 0.002];
/// Accelerometer bias \[m/s^2\].
pub const ACCEL_BIAS: [f64; 3] = [0.08, -0.06, 0.12];
/// Gyro white noise \[rad/s\] on a sample of the nominal interval: a density of
/// `GYRO_NOISE sqrt(DT)` \[rad/sqrt(s)\], so that a sample's delta angle has a variance of
/// `GYRO_NOISE^2 DT dt` over an interval `dt`.
pub const GYRO_NOISE: f64 = 0.015;
/// Accelerometer white noise \[m/s^2\] on a sample of the nominal interval (a density,
/// like the gyro's).
pub const ACCEL_NOISE: f64 = 0.35;
/// GNSS noise: NED velocity \[m/s\], then NED position \[m\].
pub const GNSS_NOISE: [f64; 6] = [0.15, 0.15, 0.2, 0.5, 0.5, 0.8];
/// Magnetometer noise \[gauss\].
pub const MAG_NOISE: f64 = 0.005;

/// `0` before `a`, `1` after `b`, a smooth (cubic) step between.
fn smoothstep(t: f64, a: f64, b: f64) -> f64 {
    let s = ((t - a) / (b - a)).clamp(0.0, 1.0);
    s * s * (3.0 - 2.0 * s)
}

/// Yaw rate \[rad/s\]: a left turn at 20-32 s, a right turn at 48-62 s.
fn yaw_rate(t: f64) -> f64 {
    0.25 * (smoothstep(t, 20.0, 22.0) - smoothstep(t, 30.0, 32.0))
        - 0.2 * (smoothstep(t, 48.0, 50.0) - smoothstep(t, 60.0, 62.0))
}

/// The integral of [`smoothstep`] from 0 to `t` (`a > 0`): `(b - a)(s^3 - s^4 / 2)`
/// on the ramp, then the area of a unit step.
fn smoothstep_integral(t: f64, a: f64, b: f64) -> f64 {
    let s = ((t - a) / (b - a)).clamp(0.0, 1.0);
    (b - a) * (s * s * s - 0.5 * s * s * s * s) + (t - b).max(0.0)
}

/// Heading \[rad\]: the integral of [`yaw_rate`].
fn heading(t: f64) -> f64 {
    let left = smoothstep_integral(t, 20.0, 22.0) - smoothstep_integral(t, 30.0, 32.0);
    let right = smoothstep_integral(t, 48.0, 50.0) - smoothstep_integral(t, 60.0, 62.0);
    HEADING0 + 0.25 * left - 0.2 * right
}

/// Horizontal speed \[m/s\] along the heading: 5 m/s from 15 to 75 s.
fn speed(t: f64) -> f64 {
    5.0 * (smoothstep(t, 13.0, 17.0) - smoothstep(t, 73.0, 78.0))
}

/// Down velocity \[m/s\]: take-off at 10 s (climb 8 m), a 5 m climb at 38 s.
fn down_velocity(t: f64) -> f64 {
    let take_off = smoothstep(t, 10.0, 11.0) - smoothstep(t, 14.0, 15.0);
    let climb = smoothstep(t, 38.0, 39.0) - smoothstep(t, 43.0, 44.0);
    -2.0 * take_off - 1.0 * climb
}

/// NED velocity \[m/s\].
pub fn velocity(t: f64) -> [f64; 3] {
    let (v, psi) = (speed(t), heading(t));
    [v * libm::cos(psi), v * libm::sin(psi), down_velocity(t)]
}

/// NED acceleration \[m/s^2\], by a central difference of [`velocity`].
fn acceleration(t: f64) -> [f64; 3] {
    let h = 1e-4;
    let (a, b) = (velocity(t + h), velocity(t - h));
    core::array::from_fn(|i| (a[i] - b[i]) / (2.0 * h))
}

/// Roll, pitch, yaw \[rad\]: banked into the turns, pitched against the acceleration, as a
/// multirotor tilts its thrust.
fn euler(t: f64) -> [f64; 3] {
    let along = {
        let h = 1e-3;
        (speed(t + h) - speed(t - h)) / (2.0 * h)
    };
    let roll = libm::atan(speed(t) * yaw_rate(t) / GRAVITY);
    let pitch = -libm::atan(along / GRAVITY) - 0.05 * speed(t) / 5.0;
    [roll, pitch, heading(t)]
}

/// The body-to-NED attitude quaternion `[w, x, y, z]` of roll, pitch, yaw (ZYX).
pub fn attitude(t: f64) -> [f64; 4] {
    let [roll, pitch, yaw] = euler(t).map(|a| 0.5 * a);
    let (cr, sr, cp, sp, cy, sy) = (
        libm::cos(roll),
        libm::sin(roll),
        libm::cos(pitch),
        libm::sin(pitch),
        libm::cos(yaw),
        libm::sin(yaw),
    );
    [
        cr * cp * cy + sr * sp * sy,
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
    ]
}

/// The quaternion product `a b`.
pub fn quaternion_product(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
    [
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    ]
}

/// The conjugate (the inverse of a unit quaternion).
pub fn conjugate(q: [f64; 4]) -> [f64; 4] {
    [q[0], -q[1], -q[2], -q[3]]
}

/// The rotation vector \[rad\] of a unit quaternion (its sign chosen for the short way).
pub fn rotation_vector(q: [f64; 4]) -> [f64; 3] {
    let q = if q[0] < 0.0 { q.map(|v| -v) } else { q };
    let s = libm::sqrt(q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    let scale = if s < 1e-12 {
        2.0
    } else {
        2.0 * libm::atan2(s, q[0]) / s
    };
    [q[1] * scale, q[2] * scale, q[3] * scale]
}

/// `v` rotated from the body to NED by `q`, or back with `transpose`.
pub fn rotate(q: [f64; 4], v: [f64; 3], transpose: bool) -> [f64; 3] {
    let [w, x, y, z] = q;
    let r = [
        [
            w * w + x * x - y * y - z * z,
            2.0 * (x * y - w * z),
            2.0 * (x * z + w * y),
        ],
        [
            2.0 * (x * y + w * z),
            w * w - x * x + y * y - z * z,
            2.0 * (y * z - w * x),
        ],
        [
            2.0 * (x * z - w * y),
            2.0 * (y * z + w * x),
            w * w - x * x - y * y + z * z,
        ],
    ];
    core::array::from_fn(|i| {
        (0..3)
            .map(|j| if transpose { r[j][i] } else { r[i][j] } * v[j])
            .sum()
    })
}

/// The interval \[s\] of IMU sample `k` (from 1), since the sample before: the nominal one,
/// jittered, or two of them where the driver dropped the sample between.
#[must_use]
pub fn interval(k: u64) -> f64 {
    let jittered = DT * (1.0 + JITTER * (2.0 * crate::noise::uniform(730, k) - 1.0));
    if crate::noise::uniform(731, k) < DROPPED {
        jittered + DT * (1.0 + JITTER * (2.0 * crate::noise::uniform(732, k) - 1.0))
    } else {
        jittered
    }
}

/// The true state at an IMU sample, in the model's order (the wind is zero).
#[derive(Clone, Copy, Debug)]
pub struct Truth {
    /// Time \[s\].
    pub t: f64,
    /// The 24 entries: the attitude quaternion `[x, y, z, w]`, NED velocity and position,
    /// the gyro \[rad/s\] and accelerometer \[m/s^2\] biases, the earth field, the body
    /// field bias, the wind.
    pub x: [f64; 24],
}

/// What the sensors read over one IMU sample ending at `truth.t`.
#[derive(Clone, Copy, Debug)]
pub struct Readings {
    /// The sample's interval \[s\], since the IMU sample before.
    pub interval: f64,
    /// IMU delta angle \[rad\] and delta velocity \[m/s\] over the sample (the model's
    /// inputs are these divided by the interval: [`Readings::rates`]).
    pub imu: [f64; 6],
    /// The GNSS fix (NED velocity, position) when one arrives (5 Hz, not in the outage).
    pub gnss: Option<[f64; 6]>,
    /// The magnetometer (50 Hz).
    pub magnetometer: Option<[f64; 3]>,
}

impl Readings {
    /// The IMU sample as the model's inputs: the mean rate \[rad/s\] and specific force
    /// \[m/s^2\] over the sample, its delta angle and delta velocity divided by its
    /// interval.
    #[must_use]
    pub fn rates(&self) -> [f64; 6] {
        self.imu.map(|v| v / self.interval)
    }
}

/// The flight, sample by sample: the truth and the sensors.
pub struct Flight {
    position: [f64; 3],
    sample: u64,
    time: f64,
    noise: [GaussianNoise; 6],
    gnss_noise: [GaussianNoise; 6],
    mag_noise: [GaussianNoise; 3],
}

impl Flight {
    /// The flight at its start, on the ground at the origin.
    pub fn new() -> Self {
        Flight {
            position: [0.0; 3],
            sample: 0,
            time: 0.0,
            noise: core::array::from_fn(|i| {
                let sigma = if i < 3 { GYRO_NOISE } else { ACCEL_NOISE };
                GaussianNoise::new(sigma, 700 + i as u64)
            }),
            gnss_noise: core::array::from_fn(|i| GaussianNoise::new(GNSS_NOISE[i], 710 + i as u64)),
            mag_noise: core::array::from_fn(|i| GaussianNoise::new(MAG_NOISE, 720 + i as u64)),
        }
    }

    /// The true state at time `t` (the position as integrated so far).
    fn truth_at(&self, t: f64) -> Truth {
        let [w, qx, qy, qz] = attitude(t);
        let mut x = [0.0; 24];
        x[..4].copy_from_slice(&[qx, qy, qz, w]);
        x[4..7].copy_from_slice(&velocity(t));
        x[7..10].copy_from_slice(&self.position);
        x[10..13].copy_from_slice(&GYRO_BIAS);
        x[13..16].copy_from_slice(&ACCEL_BIAS);
        x[16..19].copy_from_slice(&EARTH_FIELD);
        x[19..22].copy_from_slice(&BODY_FIELD_BIAS);
        Truth { t, x }
    }

    /// Advances one IMU sample: the truth at its end and what the sensors read.
    pub fn advance(&mut self) -> (Truth, Readings) {
        let dt = interval(self.sample + 1);
        let t0 = self.time;
        let h = dt / SUBSTEPS as f64;
        let mut delta_velocity = [0.0; 3];
        for s in 0..SUBSTEPS {
            let (a, b) = (t0 + s as f64 * h, t0 + (s + 1) as f64 * h);
            let (va, vb) = (velocity(a), velocity(b));
            let (fa, fb) = (self.specific_force(a), self.specific_force(b));
            for i in 0..3 {
                self.position[i] += 0.5 * h * (va[i] + vb[i]);
                delta_velocity[i] += 0.5 * h * (fa[i] + fb[i]);
            }
        }
        self.sample += 1;
        self.time += dt;
        let k = self.sample;
        let t1 = self.time;
        // White noise of a density: a delta's deviation grows as the root of the interval.
        let noise_scale = libm::sqrt(DT * dt);
        let turn = quaternion_product(conjugate(attitude(t0)), attitude(t1));
        let angle = rotation_vector(turn);
        let imu: [f64; 6] = core::array::from_fn(|i| {
            let (clean, bias) = if i < 3 {
                (angle[i], GYRO_BIAS[i])
            } else {
                (delta_velocity[i - 3], ACCEL_BIAS[i - 3])
            };
            clean + bias * dt + noise_scale * self.noise[i].sample(k)
        });
        let truth = self.truth_at(t1);
        let readings = Readings {
            interval: dt,
            imu,
            gnss: self.gnss(&truth, k),
            magnetometer: self.magnetometer(&truth, k),
        };
        (truth, readings)
    }

    /// The accelerometer's clean reading \[m/s^2\]: the specific force in the body.
    fn specific_force(&self, t: f64) -> [f64; 3] {
        let a = acceleration(t);
        rotate(attitude(t), [a[0], a[1], a[2] - GRAVITY], true)
    }

    /// A GNSS fix every 50th sample (5 Hz), none in the outage.
    fn gnss(&self, truth: &Truth, k: u64) -> Option<[f64; 6]> {
        let out = (GNSS_OUTAGE.0..GNSS_OUTAGE.1).contains(&truth.t);
        (k.is_multiple_of(50) && !out)
            .then(|| core::array::from_fn(|i| truth.x[4 + i] + self.gnss_noise[i].sample(k)))
    }

    /// A magnetometer sample every 5th sample (50 Hz): the earth field in the body plus
    /// the bias.
    fn magnetometer(&self, truth: &Truth, k: u64) -> Option<[f64; 3]> {
        k.is_multiple_of(5).then(|| {
            let body = rotate(attitude(truth.t), EARTH_FIELD, true);
            core::array::from_fn(|i| body[i] + BODY_FIELD_BIAS[i] + self.mag_noise[i].sample(k))
        })
    }
}

impl Default for Flight {
    fn default() -> Self {
        Self::new()
    }
}

/// The magnetometer's gate: the chi-square 99.9 % quantile for 3 degrees of freedom, as
/// the navigation model declares it (`sensor magnetometer(gate = 16.27)`; the GNSS's is
/// 22.46, for 6). The filter is generated with it; a test checks that the two agree.
pub const MAGNETOMETER_GATE: f64 = 16.27;

/// The initial estimate: level (as the vehicle stands), its heading from the first
/// magnetometer sample (the bias unknown), at rest at the origin, a nominal earth field.
/// The quaternion is `[x, y, z, w]`, the model's order.
#[must_use]
pub fn initial_estimate(magnetometer: [f64; 3]) -> [f64; 24] {
    let yaw = libm::atan2(-magnetometer[1], magnetometer[0]);
    let mut x = [0.0; 24];
    x[2] = libm::sin(0.5 * yaw);
    x[3] = libm::cos(0.5 * yaw);
    x[16] = 0.2;
    x[18] = 0.4;
    x
}

/// The tuning: the diagonals of `P0` and of the process noise density `Q` (per second: a
/// prediction over `dt` adds `Q dt`) over the filter's 23 tangent coordinates (attitude
/// error, velocity, position, gyro and accelerometer biases, earth field, body field bias,
/// wind), and of `R` (the sensors' noise, GNSS then magnetometer).
///
/// `Q` is the IMU's white noise, exactly: the gyro's, of density `GYRO_NOISE sqrt(DT)`,
/// turns the attitude by an angle of variance `GYRO_NOISE^2 DT dt` (isotropic, so in the
/// earth frame too), the accelerometer's changes the velocity likewise; the position has
/// none of its own. The biases, fields and wind are slow random walks, given as their
/// deviation over a nominal interval.
#[must_use]
pub fn tuning() -> ([f64; 23], [f64; 23], [f64; 9]) {
    let mut p0 = [0.0; 23];
    let mut q = [0.0; 23];
    let groups: [(core::ops::Range<usize>, f64, f64); 7] = [
        (0..3, 0.1, GYRO_NOISE * DT),
        (3..6, 0.5, ACCEL_NOISE * DT),
        (6..9, 1.0, 0.0),
        (9..12, 0.01, 2.5e-6),
        (12..15, 0.2, 7.5e-5),
        (15..21, 0.05, 3e-5),
        (21..23, 0.1, 1e-4),
    ];
    for (range, initial_sigma, noise_sigma) in groups {
        for i in range {
            p0[i] = initial_sigma * initial_sigma;
            q[i] = noise_sigma * noise_sigma / DT;
        }
    }
    let mut r = [0.0; 9];
    for (i, sigma) in GNSS_NOISE.iter().enumerate() {
        r[i] = sigma * sigma;
    }
    r[6..].fill(MAG_NOISE * MAG_NOISE);
    (p0, q, r)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The IMU's intervals are within the jitter of the nominal one, or of two where a
    /// sample was dropped, about as often as `DROPPED` says; and its noise has the
    /// density the tuning states: the gyro's reading less the truth and the bias, scaled
    /// by `1 / sqrt(DT dt)`, has the deviation `GYRO_NOISE` over the shorter intervals and
    /// over the longer ones alike (a noise of one deviation per sample would be 6 % over
    /// it on the shorter, 4 % under on the longer).
    #[test]
    fn the_imu_jitters_and_its_noise_has_the_stated_density() {
        let samples = 22_500;
        let mut flight = Flight::new();
        let (mut dropped, mut time) = (0, 0.0);
        // Sums of squares and counts over the intervals shorter than nominal, and the rest.
        let mut squares = [(0.0, 0); 2];
        for k in 1..=samples {
            let t0 = time;
            let (truth, readings) = flight.advance();
            let dt = readings.interval;
            time += dt;
            assert!((truth.t - time).abs() < 1e-9, "sample {k} at {}", truth.t);
            let single = (1.0 - JITTER) * DT..=(1.0 + JITTER) * DT;
            let double = 2.0 * (1.0 - JITTER) * DT..=2.0 * (1.0 + JITTER) * DT;
            assert!(
                single.contains(&dt) || double.contains(&dt),
                "interval {dt}"
            );
            dropped += usize::from(double.contains(&dt));
            // The gyro's clean delta angle is the exact relative rotation over the sample.
            let turn = quaternion_product(conjugate(attitude(t0)), attitude(time));
            let clean = rotation_vector(turn);
            let scale = 1.0 / libm::sqrt(DT * dt);
            let (sum, count) = &mut squares[usize::from(dt >= DT)];
            for (i, angle) in clean.iter().enumerate() {
                let noise = readings.imu[i] - angle - GYRO_BIAS[i] * dt;
                *sum += (noise * scale).powi(2);
                *count += 1;
            }
        }
        let expected = DROPPED * samples as f64;
        assert!(
            (dropped as f64 - expected).abs() < 4.0 * expected.sqrt(),
            "{dropped} dropped, {expected} expected"
        );
        for (sum, count) in squares {
            let deviation = (sum / f64::from(count)).sqrt();
            assert!(
                (deviation / GYRO_NOISE - 1.0).abs() < 0.02,
                "gyro noise {deviation} against {GYRO_NOISE}"
            );
        }
    }
}
