//! The simulated body: a rigid body tumbling about its centre, whose true attitude is
//! integrated independently of the generated code (nalgebra's `UnitQuaternion` turned by
//! the exact exponential of the true rate), and its sensors: a gyro with a drifting bias
//! and white noise, an accelerometer and a magnetometer with white noise. Noise comes from
//! a small deterministic generator, so runs repeat exactly.
//!
//! # The filter's noise, from the sensors'
//!
//! The filter's covariance is over `TANGENT_NAMES`: the attitude error `δθ` in the earth
//! frame (the true attitude is `Exp(δθ) ⊗ q`) and the bias error. The gyro's white noise
//! is noise on the input (`input_noise = [gyro]`): `new` takes its variance per sample on
//! each axis, `GYRO_NOISE^2`, and the filter maps it through the input Jacobian onto the
//! attitude, `G diag(qu) G'` (about `GYRO_NOISE^2 DT^2` per attitude coordinate). The bias
//! is a random walk of `BIAS_WALK` rad/s per square root of a second, process noise on the
//! bias alone (`process_noise_on = [gyro_bias]`): `BIAS_WALK^2 DT` per sample on each bias
//! coordinate.

use crate::ahrs::{index, Ekf, Status, TANGENT_LEN, X_LEN};
use nalgebra::{Matrix6, Quaternion, UnitQuaternion, Vector3, Vector4, Vector6};

/// Samples per second: the gyro's and the accelerometer's rate.
pub const RATE: usize = 100;
/// The magnetometer measures every `MAG_EVERY`-th sample: 25 Hz.
pub const MAG_EVERY: usize = 4;
/// The sample time [s], the model's.
pub const DT: f64 = crate::ahrs::in_f64::DT;
/// Standard deviation of a gyro sample's white noise, per axis [rad/s] (a noise density
/// of 1e-3 rad/s per square root of a hertz at 100 Hz).
pub const GYRO_NOISE: f64 = 0.01;
/// The gyro bias's random walk [rad/s per square root of a second].
pub const BIAS_WALK: f64 = 1e-4;
/// Standard deviation of the accelerometer's noise, per axis [m/s^2].
pub const ACCEL_NOISE: f64 = 0.05;
/// Standard deviation of the magnetometer's noise, per axis [gauss].
pub const MAG_NOISE: f64 = 0.005;
/// The initial attitude's standard deviation, per axis [rad]: 5 degrees.
pub const INITIAL_ATTITUDE: f64 = 5.0 * core::f64::consts::PI / 180.0;
/// The initial bias's standard deviation, per axis [rad/s] (about 1.1 deg/s).
pub const INITIAL_BIAS: f64 = 0.02;

/// The true body: its attitude and its gyro's bias.
#[derive(Clone, Copy, Debug)]
pub struct Body {
    /// Body-to-earth rotation (NED from FRD).
    pub attitude: UnitQuaternion<f64>,
    /// The gyro's bias, body [rad/s].
    pub gyro_bias: Vector3<f64>,
}

/// The true rate at time `t` [rad/s], body: a tumble through every attitude.
pub fn rate(t: f64) -> Vector3<f64> {
    Vector3::new(
        0.8 * libm::sin(0.7 * t),
        0.6 * libm::sin(1.1 * t + 1.0),
        0.5 * libm::cos(0.4 * t),
    )
}

impl Body {
    /// One sample from time `t`: the rate at `t` is held over the sample and turns the
    /// body by its exact exponential; the bias walks. Returns what the gyro measured over
    /// the sample: rate, bias and white noise.
    pub fn advance(&mut self, t: f64, noise: &mut Noise) -> [f32; 3] {
        let rate = rate(t);
        let gyro = rate + self.gyro_bias + noise.vector(GYRO_NOISE);
        self.attitude *= UnitQuaternion::from_scaled_axis(rate * DT);
        self.gyro_bias += noise.vector(BIAS_WALK * libm::sqrt(DT));
        to_f32(&gyro)
    }

    /// The accelerometer's measurement: gravity's reaction (up, `-g` down) in the body.
    pub fn accel(&self, noise: &mut Noise) -> [f32; 3] {
        let specific_force = Vector3::new(0.0, 0.0, -crate::ahrs::in_f64::GRAVITY);
        to_f32(&(self.attitude.inverse() * specific_force + noise.vector(ACCEL_NOISE)))
    }

    /// The magnetometer's measurement: the earth's field in the body.
    pub fn mag(&self, noise: &mut Noise) -> [f32; 3] {
        use crate::ahrs::in_f64::{MAG_D, MAG_N};
        let field = Vector3::new(MAG_N, 0.0, MAG_D);
        to_f32(&(self.attitude.inverse() * field + noise.vector(MAG_NOISE)))
    }
}

fn to_f32(v: &Vector3<f64>) -> [f32; 3] {
    [v.x as f32, v.y as f32, v.z as f32]
}

/// One sample of a run, after the filter's updates.
#[derive(Clone, Copy, Debug)]
pub struct Sample {
    /// Sample index `k` (10 ms apart).
    pub k: usize,
    /// The true body at `k`.
    pub truth: Body,
    /// The filter's estimate `x` at `k`: the quaternion `[x, y, z, w]`, then the bias.
    pub estimate: [f32; X_LEN],
    /// The filter's covariance over `TANGENT_NAMES` at `k`.
    pub covariance: [[f32; TANGENT_LEN]; TANGENT_LEN],
    /// The accelerometer's normalised innovation squared at `k` (it measures every sample).
    pub accel_nis: f32,
    /// The magnetometer's, at the samples where it measured.
    pub mag_nis: Option<f32>,
}

impl Sample {
    /// The estimated attitude.
    pub fn attitude(&self) -> UnitQuaternion<f64> {
        let coords: [f64; 4] = core::array::from_fn(|i| f64::from(self.estimate[index::Q_X + i]));
        UnitQuaternion::from_quaternion(Quaternion::from(Vector4::from(coords)))
    }

    /// The estimated gyro bias [rad/s].
    pub fn gyro_bias(&self) -> Vector3<f64> {
        Vector3::from_fn(|i, _| f64::from(self.estimate[index::GYRO_BIAS_X + i]))
    }

    /// The estimate's error in the filter's coordinates: the attitude error in the earth
    /// frame, `Log(q_true ⊗ q⁻¹)` (so that the truth is `Exp(δθ) ⊗ q`), then the bias error.
    pub fn error(&self) -> Vector6<f64> {
        let attitude = (self.truth.attitude * self.attitude().inverse()).scaled_axis();
        let bias = self.truth.gyro_bias - self.gyro_bias();
        Vector6::new(attitude.x, attitude.y, attitude.z, bias.x, bias.y, bias.z)
    }

    /// The filter's standard deviations of the same coordinates.
    pub fn sigma(&self) -> Vector6<f64> {
        Vector6::from_fn(|i, _| libm::sqrt(f64::from(self.covariance[i][i])))
    }

    /// The normalised estimation error squared, `e' P⁻¹ e`: chi-square with 6 degrees of
    /// freedom (mean 6) while the filter's covariance is right. `None` if the covariance
    /// is not positive definite.
    pub fn nees(&self) -> Option<f64> {
        let p = Matrix6::from_fn(|i, j| f64::from(self.covariance[i][j]));
        let e = self.error();
        Some(e.dot(&p.cholesky()?.solve(&e)))
    }
}

/// Runs `samples` samples with the noise and initial errors of `seed`, handing each to
/// `observe`. Returns the first status of the filter (its construction included) that was
/// not `Ok`, if any.
pub fn run(seed: u64, samples: usize, mut observe: impl FnMut(&Sample)) -> Result<(), Status> {
    let mut noise = Noise::new(seed);
    let (mut body, mut ekf) = start(&mut noise)?;
    for k in 1..=samples {
        let gyro = body.advance((k - 1) as f64 * DT, &mut noise);
        check(ekf.predict(&gyro))?;
        check(ekf.update_accel(&body.accel(&mut noise)))?;
        let mag_nis = if k.is_multiple_of(MAG_EVERY) {
            check(ekf.update_mag(&body.mag(&mut noise)))?;
            Some(ekf.mag_normalised_innovation_squared())
        } else {
            None
        };
        observe(&Sample {
            k,
            truth: body,
            estimate: ekf.state(),
            covariance: ekf.covariance(),
            accel_nis: ekf.accel_normalised_innovation_squared(),
            mag_nis,
        });
    }
    Ok(())
}

/// The filter and the true body at the start. The filter starts level, facing north,
/// with no bias (as after a coarse alignment); the truth differs from it by an error drawn
/// from the filter's initial covariance.
fn start(noise: &mut Noise) -> Result<(Body, Ekf), Status> {
    let body = Body {
        attitude: UnitQuaternion::from_scaled_axis(noise.vector(INITIAL_ATTITUDE)),
        gyro_bias: noise.vector(INITIAL_BIAS),
    };
    let mut x0 = [0.0; X_LEN];
    x0[index::Q_W] = 1.0;
    let (attitude, bias) = (
        INITIAL_ATTITUDE * INITIAL_ATTITUDE,
        INITIAL_BIAS * INITIAL_BIAS,
    );
    let p0 = diagonal([attitude, attitude, attitude, bias, bias, bias]);
    let walk = (BIAS_WALK * BIAS_WALK * DT) as f32;
    let gyro = (GYRO_NOISE * GYRO_NOISE) as f32;
    let (accel, mag) = (ACCEL_NOISE * ACCEL_NOISE, MAG_NOISE * MAG_NOISE);
    let r = diagonal([accel, accel, accel, mag, mag, mag]);
    Ok((body, Ekf::new(&x0, &p0, &[walk; 3], &[gyro; 3], &r)?))
}

fn diagonal(variances: [f64; 6]) -> [[f32; 6]; 6] {
    core::array::from_fn(|i| {
        core::array::from_fn(|j| if i == j { variances[i] as f32 } else { 0.0 })
    })
}

fn check(status: Status) -> Result<(), Status> {
    match status {
        Status::Ok => Ok(()),
        other => Err(other),
    }
}

/// Gaussian noise from a xorshift generator (Box-Muller), seeded for repeatable runs.
pub struct Noise {
    state: u64,
}

impl Noise {
    /// A generator from a seed. The seed is scrambled first (SplitMix64's finaliser):
    /// xorshift started from a small number gives small numbers for its first draws, and
    /// the first draws are a run's initial errors.
    pub fn new(seed: u64) -> Noise {
        let mut z = seed.wrapping_add(0x9e37_79b9_7f4a_7c15);
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        Noise {
            state: (z ^ (z >> 31)).max(1),
        }
    }

    fn uniform(&mut self) -> f64 {
        self.state ^= self.state << 13;
        self.state ^= self.state >> 7;
        self.state ^= self.state << 17;
        // 53 random bits in (0, 1].
        ((self.state >> 11) + 1) as f64 / (1u64 << 53) as f64
    }

    /// A sample of the normal distribution with standard deviation `sigma`.
    pub fn normal(&mut self, sigma: f64) -> f64 {
        let (u1, u2) = (self.uniform(), self.uniform());
        sigma * libm::sqrt(-2.0 * libm::log(u1)) * libm::cos(2.0 * core::f64::consts::PI * u2)
    }

    /// Three independent samples of the normal distribution with standard deviation `sigma`.
    pub fn vector(&mut self, sigma: f64) -> Vector3<f64> {
        Vector3::new(self.normal(sigma), self.normal(sigma), self.normal(sigma))
    }
}
