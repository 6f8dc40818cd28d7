//! The generated error-state EKF of a model with a rotation (the AHRS test model,
//! `tests/models/ahrs.rs`) against the independent `nalgebra` filter of
//! `tests/src/error_state_reference.rs`, on seeded random sequences of every call
//! (`predict`, `update`, `update_accel`, `update_mag`, `step`, `reset`) from random
//! rotations, rates, biases, covariances and measurements near the prediction. Before each
//! call the reference takes the generated filter's estimate, so each call is compared
//! from one starting point and a difference cannot hide in a drift.
//!
//! Tolerance: the reference's Jacobians are central differences whose error is about
//! 2e-11 of their scale (1.8e-11 against an exact derivative in the reference's own
//! tests); `F P F' + Q` carries `F`'s twice, an update `H`'s through the gain, more where
//! the innovation covariance is ill-conditioned (the accelerometer's outputs 20 times the
//! magnetometer's). `R` is random per sensor, zero between the two (each sensor keeps its
//! own block). Measured over the 2400 calls: the states within 5e-12 of their scale, the
//! covariances within 7.4e-11 of their largest entry, the normalised innovations squared
//! within 1e-10 (printed with `--nocapture`). [`TOLERANCE`], 1e-8, is a hundred times that; the faults it is there to
//! find are a million times it: with the reset's skew part of the wrong sign a covariance
//! is 1.5e-2 off, with the retraction's Jacobian of the local convention a state 3.4e-2,
//! with the local Jacobian's a predicted covariance 0.87 (each tried on the generator).
//!
//! Beside it: the `f32` filter keeps its quaternion's norm within 1e-6 of one over 1e5
//! samples of a simulated flight (1.3e-7 measured), `new` and `reset` refuse a rotation
//! whose norm is more than 1 % from one (1.5, 0.5, 1.011, 0.989) and normalise one within
//! (1.005, 0.995), and `reset` takes back the filter's own state and covariance, in `f64`
//! and in `f32`.

use nalgebra::{DMatrix, DVector, UnitQuaternion, Vector3};
use tests::compare::largest_relative_difference;
use tests::error_state_reference::{self as reference, Eskf, Layout};
use tests::rng::Lcg;

include!("../models/ahrs.rs");

use ahrs::in_f64::Ekf;
use ahrs::Status;

/// The model's sample time [s], written again for the reference.
const DT: f64 = 0.01;
/// Gravity [m/s^2].
const GRAVITY: f64 = 9.80665;
/// The earth field, NED [gauss].
const EARTH_FIELD: [f64; 3] = [0.21, 0.0, 0.45];

/// The outputs of each sensor, and all of them.
const ACCEL: [usize; 3] = [0, 1, 2];
const MAG: [usize; 3] = [3, 4, 5];
const ALL: [usize; 6] = [0, 1, 2, 3, 4, 5];

/// How far a call's state and covariance may be from the reference's, relative to the
/// largest entry of each (see the module's documentation).
const TOLERANCE: f64 = 1e-8;

/// Random sequences, and calls in each.
const SEEDS: u64 = 40;
const CALLS: usize = 60;

/// The AHRS's state vector: the rotation at 0, the gyro bias at 4.
fn layout() -> Layout {
    Layout {
        n_x: 7,
        rotations: vec![0],
    }
}

/// The model's `f` with the gyro rate `gyro`: `q ⊗ Exp((gyro - bias) DT)`.
fn model_f(gyro: Vector3<f64>) -> impl Fn(&DVector<f64>) -> DVector<f64> {
    move |x| {
        let turn = UnitQuaternion::from_scaled_axis((gyro - reference::vector(x, 4)) * DT);
        let mut next = x.clone();
        reference::store_rotation(&mut next, 0, &(reference::rotation(x, 0) * turn));
        next
    }
}

/// The model's `h`: gravity's specific force and the earth field, in the body.
fn model_h(x: &DVector<f64>) -> DVector<f64> {
    let q = reference::rotation(x, 0);
    let accel = q.inverse_transform_vector(&Vector3::new(0.0, 0.0, -GRAVITY));
    let mag = q.inverse_transform_vector(&Vector3::from(EARTH_FIELD));
    DVector::from_iterator(6, accel.iter().chain(mag.iter()).copied())
}

fn to_vector<const N: usize>(a: &[f64; N]) -> DVector<f64> {
    DVector::from_column_slice(a)
}

fn to_matrix<const N: usize>(m: &[[f64; N]; N]) -> DMatrix<f64> {
    DMatrix::from_fn(N, N, |i, j| m[i][j])
}

fn to_array<const N: usize>(v: &DVector<f64>) -> [f64; N] {
    std::array::from_fn(|i| v[i])
}

fn random_vector(rng: &mut Lcg, scale: f64) -> Vector3<f64> {
    Vector3::from_fn(|_, _| scale * rng.uniform())
}

/// A rotation of any angle up to about 180°, and a gyro bias up to 0.05 rad/s.
fn random_state(rng: &mut Lcg) -> [f64; 7] {
    let q = UnitQuaternion::from_scaled_axis(random_vector(rng, 1.8));
    let mut x = DVector::zeros(7);
    reference::store_rotation(&mut x, 0, &q);
    x.fixed_rows_mut::<3>(4)
        .copy_from(&random_vector(rng, 0.05));
    to_array(&x)
}

/// A random covariance `D (B B' / 6 + I / 10) D` with standard deviations of the order
/// of `scales`: correlated, and well enough conditioned.
fn random_covariance(rng: &mut Lcg, scales: [f64; 6]) -> [[f64; 6]; 6] {
    let b = DMatrix::from_fn(6, 6, |_, _| rng.uniform());
    let d = DMatrix::from_diagonal(&to_vector(&scales));
    let m = &d * (&b * b.transpose() / 6.0 + DMatrix::identity(6, 6) / 10.0) * &d;
    std::array::from_fn(|i| std::array::from_fn(|j| (m[(i, j)] + m[(j, i)]) / 2.0))
}

/// A measurement near the prediction: `h` of the estimate moved by up to 0.02 in each
/// tangent coordinate, plus up to twice the sensor's standard deviation.
fn random_measurement(rng: &mut Lcg, x: &[f64; 7], r: &[[f64; 6]; 6]) -> [f64; 6] {
    let delta = DVector::from_fn(6, |_, _| 0.02 * rng.uniform());
    let y = model_h(&layout().retract(&to_vector(x), &delta));
    std::array::from_fn(|i| y[i] + 2.0 * r[i][i].sqrt() * rng.uniform())
}

/// A filter's noise covariances and initial estimate.
struct Setup {
    x0: [f64; 7],
    p0: [[f64; 6]; 6],
    q: [f64; 6],
    r: [[f64; 6]; 6],
}

fn random_setup(rng: &mut Lcg) -> Setup {
    let q = std::array::from_fn(|i| {
        let scale = if i < 3 { 1e-6 } else { 1e-8 };
        scale * (1.5 + rng.uniform())
    });
    Setup {
        x0: random_state(rng),
        p0: random_covariance(rng, [0.05, 0.05, 0.05, 0.01, 0.01, 0.01]),
        q,
        r: per_sensor(random_covariance(rng, [0.3, 0.3, 0.3, 0.01, 0.01, 0.01])),
    }
}

/// `r` with its entries between the accelerometer (outputs 0 to 2) and the magnetometer
/// (3 to 5) zeroed: each sensor's noise is its own (each keeps its block of `R`), and each
/// block, a principal block of a covariance, is one.
fn per_sensor(mut r: [[f64; 6]; 6]) -> [[f64; 6]; 6] {
    for (i, row) in r.iter_mut().enumerate() {
        for (j, entry) in row.iter_mut().enumerate() {
            if (i < 3) != (j < 3) {
                *entry = 0.0;
            }
        }
    }
    r
}

/// One call of the filter, with its arguments (a reset's covariance boxed: the other
/// calls' arguments are a fifth of its size).
#[derive(Clone, Debug)]
enum Call {
    Predict([f64; 3]),
    Update([f64; 6]),
    UpdateAccel([f64; 3]),
    UpdateMag([f64; 3]),
    Step([f64; 3], [f64; 6]),
    Reset([f64; 7], Box<[[f64; 6]; 6]>),
}

/// Names of the calls, in [`Call::index`]'s order.
const CALL_NAMES: [&str; 6] = [
    "predict",
    "update",
    "update_accel",
    "update_mag",
    "step",
    "reset",
];

impl Call {
    fn index(&self) -> usize {
        match self {
            Call::Predict(_) => 0,
            Call::Update(_) => 1,
            Call::UpdateAccel(_) => 2,
            Call::UpdateMag(_) => 3,
            Call::Step(..) => 4,
            Call::Reset(..) => 5,
        }
    }
}

/// A random call at the estimate `x`: rates up to 2 rad/s, measurements near its
/// prediction, a reset to a random estimate.
fn random_call(rng: &mut Lcg, x: &[f64; 7], r: &[[f64; 6]; 6]) -> Call {
    let gyro: [f64; 3] = random_vector(rng, 2.0).into();
    let y = random_measurement(rng, x, r);
    let [a0, a1, a2, m0, m1, m2] = y;
    // Map [-1, 1) onto the six calls.
    match ((rng.uniform() + 1.0) * 3.0) as usize {
        0 => Call::Predict(gyro),
        1 => Call::Update(y),
        2 => Call::UpdateAccel([a0, a1, a2]),
        3 => Call::UpdateMag([m0, m1, m2]),
        4 => Call::Step(gyro, y),
        _ => Call::Reset(
            random_state(rng),
            Box::new(random_covariance(rng, [0.05, 0.05, 0.05, 0.01, 0.01, 0.01])),
        ),
    }
}

/// What a call of the generated filter saw: its status, innovation and normalised
/// innovation squared (for an update).
fn call_generated(ekf: &mut Ekf, call: &Call) -> (Status, Vec<f64>, f64) {
    let status = match call {
        Call::Predict(u) => ekf.predict(u),
        Call::Update(y) => ekf.update(y),
        Call::UpdateAccel(y) => ekf.update_accel(y),
        Call::UpdateMag(y) => ekf.update_mag(y),
        Call::Step(u, y) => ekf.step(u, y),
        Call::Reset(x, p) => ekf.reset(x, p),
    };
    let (innovation, nis) = match call {
        Call::Update(_) | Call::Step(..) => (
            ekf.innovation().to_vec(),
            ekf.normalised_innovation_squared(),
        ),
        Call::UpdateAccel(_) => (
            ekf.accel_innovation().to_vec(),
            ekf.accel_normalised_innovation_squared(),
        ),
        Call::UpdateMag(_) => (
            ekf.mag_innovation().to_vec(),
            ekf.mag_normalised_innovation_squared(),
        ),
        Call::Predict(_) | Call::Reset(..) => (Vec::new(), 0.0),
    };
    (status, innovation, nis)
}

/// The same call of the reference, and its innovation (none for `predict` and `reset`).
fn call_reference(eskf: &mut Eskf, call: &Call) -> Option<reference::Innovation> {
    match call {
        Call::Predict(u) => {
            eskf.predict(&model_f(Vector3::from(*u)));
            None
        }
        Call::Update(y) => Some(eskf.update(&model_h, &to_vector(y), &ALL)),
        Call::UpdateAccel(y) => Some(eskf.update(&model_h, &to_vector(y), &ACCEL)),
        Call::UpdateMag(y) => Some(eskf.update(&model_h, &to_vector(y), &MAG)),
        Call::Step(u, y) => {
            eskf.predict(&model_f(Vector3::from(*u)));
            Some(eskf.update(&model_h, &to_vector(y), &ALL))
        }
        Call::Reset(x, p) => {
            eskf.reset(&to_vector(x), &to_matrix(p))
                .expect("a unit rotation");
            None
        }
    }
}

/// The differences of a call's results from the reference's: state, covariance (upper
/// triangle), innovation, normalised innovation squared; each relative to the largest
/// entry of the reference's.
fn differences(
    ekf: &Ekf,
    (innovation, nis): (&[f64], f64),
    eskf: &Eskf,
    seen: Option<&reference::Innovation>,
) -> [f64; 4] {
    let upper = |p: &DMatrix<f64>| -> Vec<f64> {
        (0..6)
            .flat_map(|i| (i..6).map(move |j| (i, j)))
            .map(|(i, j)| p[(i, j)])
            .collect()
    };
    let state = largest_relative_difference(&ekf.state(), eskf.x.as_slice());
    let covariance =
        largest_relative_difference(&upper(&to_matrix(&ekf.covariance())), &upper(&eskf.p));
    let (residual, nis) = match seen {
        Some(want) => (
            largest_relative_difference(innovation, want.residual.as_slice()),
            largest_relative_difference(&[nis], &[want.nis]),
        ),
        None => (0.0, 0.0),
    };
    [state, covariance, residual, nis]
}

/// Runs one seeded sequence, asserting each call's differences; adds, per call, the
/// worst of each difference to `worst` and the calls compared to `counts`.
fn run_sequence(seed: u64, worst: &mut [[f64; 4]; 6], counts: &mut [usize; 6]) {
    let mut rng = Lcg(seed);
    let setup = random_setup(&mut rng);
    let mut ekf = Ekf::new(&setup.x0, &setup.p0, &setup.q, &setup.r).expect("a valid setup");
    let mut eskf = Eskf {
        layout: layout(),
        x: to_vector(&setup.x0),
        p: to_matrix(&setup.p0),
        q: DMatrix::from_diagonal(&to_vector(&setup.q)),
        r: to_matrix(&setup.r),
    };
    for k in 0..CALLS {
        // The reference starts each call where the generated filter is.
        eskf.x = to_vector(&ekf.state());
        eskf.p = to_matrix(&ekf.covariance());
        let call = random_call(&mut rng, &ekf.state(), &setup.r);
        let (status, innovation, nis) = call_generated(&mut ekf, &call);
        assert_eq!(status, Status::Ok, "seed {seed}, call {k}: {call:?}");
        let seen = call_reference(&mut eskf, &call);
        let d = differences(&ekf, (&innovation, nis), &eskf, seen.as_ref());
        let i = call.index();
        for (w, d) in worst[i].iter_mut().zip(d) {
            assert!(
                d <= TOLERANCE,
                "seed {seed}, call {k} ({}): differences {d:e} (state, covariance, \
                 innovation, NIS: {:?})",
                CALL_NAMES[i],
                differences(&ekf, (&innovation, nis), &eskf, seen.as_ref()),
            );
            *w = w.max(d);
        }
        counts[i] += 1;
    }
}

#[test]
fn every_call_agrees_with_the_nalgebra_error_state_filter() {
    let mut worst = [[0.0_f64; 4]; 6];
    let mut counts = [0_usize; 6];
    for seed in 1..=SEEDS {
        run_sequence(seed, &mut worst, &mut counts);
    }
    for (i, name) in CALL_NAMES.iter().enumerate() {
        eprintln!(
            "{name:>12}: {:>4} calls, worst state {:.1e}, covariance {:.1e}, innovation \
             {:.1e}, NIS {:.1e}",
            counts[i], worst[i][0], worst[i][1], worst[i][2], worst[i][3]
        );
        // Each call is compared often enough to matter.
        assert!(counts[i] >= 200, "{name}: {} calls", counts[i]);
    }
}

/// A simulated flight: the true attitude turning at slowly varying rates, the gyro's true
/// bias, and noisy gyro, accelerometer and magnetometer samples.
struct Flight {
    rng: Lcg,
    k: usize,
    attitude: UnitQuaternion<f64>,
    bias: Vector3<f64>,
}

/// The flight's sensor noise, standard deviations: gyro [rad/s], accelerometer
/// [m/s^2], magnetometer [gauss].
const GYRO_NOISE: f64 = 0.005;
const ACCEL_NOISE: f64 = 0.1;
const MAG_NOISE: f64 = 0.005;

impl Flight {
    fn new(seed: u64) -> Flight {
        Flight {
            rng: Lcg(seed),
            k: 0,
            attitude: UnitQuaternion::from_scaled_axis(Vector3::new(0.2, -0.3, 2.0)),
            bias: Vector3::new(0.01, -0.02, 0.015),
        }
    }

    /// Noise of standard deviation `sigma` (uniform).
    fn noise(&mut self, sigma: f64) -> f64 {
        3.0_f64.sqrt() * sigma * self.rng.uniform()
    }

    /// The gyro's sample over the next step, which the true attitude then turns by, and
    /// the measurement at the new attitude.
    fn sample(&mut self) -> ([f64; 3], [f64; 6]) {
        let t = self.k as f64 * DT;
        self.k += 1;
        let rate = Vector3::new(
            0.5 * (0.3 * t).sin(),
            0.4 * (0.2 * t).cos(),
            0.3 * (0.1 * t + 1.0).sin(),
        );
        let gyro = std::array::from_fn(|i| rate[i] + self.bias[i] + self.noise(GYRO_NOISE));
        self.attitude *= UnitQuaternion::from_scaled_axis(rate * DT);
        let mut x = DVector::zeros(7);
        reference::store_rotation(&mut x, 0, &self.attitude);
        let h = model_h(&x);
        let y = std::array::from_fn(|i| {
            let sigma = if i < 3 { ACCEL_NOISE } else { MAG_NOISE };
            h[i] + self.noise(sigma)
        });
        (gyro, y)
    }
}

/// The flight's filter setup: a prior 0.1 rad and 0.01 rad/s off, the process noise of
/// the gyro's noise over a sample and a slow bias walk, the sensors' noise.
fn flight_setup(flight: &Flight) -> Setup {
    let guess = UnitQuaternion::from_scaled_axis(Vector3::new(0.05, -0.05, 0.07)) * flight.attitude;
    let mut x0 = DVector::zeros(7);
    reference::store_rotation(&mut x0, 0, &guess);
    let p0 = [0.01, 0.01, 0.01, 1e-4, 1e-4, 1e-4];
    let q = [(GYRO_NOISE * DT).powi(2); 3];
    let r = [ACCEL_NOISE.powi(2), MAG_NOISE.powi(2)];
    Setup {
        x0: to_array(&x0),
        p0: std::array::from_fn(|i| std::array::from_fn(|j| if i == j { p0[i] } else { 0.0 })),
        q: [q[0], q[1], q[2], 1e-10, 1e-10, 1e-10],
        r: std::array::from_fn(|i| std::array::from_fn(|j| if i == j { r[i / 3] } else { 0.0 })),
    }
}

fn to_f32<const N: usize>(a: &[f64; N]) -> [f32; N] {
    a.map(|v| v as f32)
}

fn matrix_to_f32<const N: usize>(m: &[[f64; N]; N]) -> [[f32; N]; N] {
    m.map(|row| to_f32(&row))
}

/// `|norm(q) - 1|` of the rotation stored in `x`, computed in `f64`.
fn norm_error(x: &[f32; 7]) -> f64 {
    let squared: f64 = x[..4].iter().map(|&v| f64::from(v) * f64::from(v)).sum();
    (squared.sqrt() - 1.0).abs()
}

/// The attitude error of the estimate `x` from `truth` [rad].
fn attitude_error(x: &[f32; 7], truth: &UnitQuaternion<f64>) -> f64 {
    let x = DVector::from_iterator(7, x.iter().map(|&v| f64::from(v)));
    (reference::rotation(&x, 0) * truth.inverse()).angle()
}

/// The `f32` filter of `setup`.
fn f32_filter(setup: &Setup) -> ahrs::Ekf {
    ahrs::Ekf::new(
        &to_f32(&setup.x0),
        &matrix_to_f32(&setup.p0),
        &to_f32(&setup.q),
        &matrix_to_f32(&setup.r),
    )
    .expect("a valid setup")
}

#[test]
fn the_f32_filter_keeps_a_unit_quaternion_over_1e5_samples() {
    let mut flight = Flight::new(7);
    let setup = flight_setup(&flight);
    let mut ekf = f32_filter(&setup);
    let (mut worst, mut worst_attitude) = (0.0_f64, 0.0_f64);
    for k in 0..100_000 {
        let (gyro, y) = flight.sample();
        assert_eq!(ekf.predict(&to_f32(&gyro)), Status::Ok, "sample {k}");
        worst = worst.max(norm_error(&ekf.state()));
        assert_eq!(ekf.update(&to_f32(&y)), Status::Ok, "sample {k}");
        worst = worst.max(norm_error(&ekf.state()));
        if k >= 1000 {
            worst_attitude = worst_attitude.max(attitude_error(&ekf.state(), &flight.attitude));
        }
    }
    eprintln!(
        "largest |norm(q) - 1| {worst:.1e}, attitude error after 10 s {worst_attitude:.1e} rad"
    );
    assert!(worst < 1e-6, "|norm(q) - 1| reached {worst:e}");
    // The filter followed the flight: its corrections were real ones.
    assert!(worst_attitude < 0.02, "attitude error {worst_attitude} rad");
}

/// `x` with its quaternion scaled by `norm`.
fn scaled_rotation(x: &[f64; 7], norm: f64) -> [f64; 7] {
    std::array::from_fn(|i| if i < 4 { norm * x[i] } else { x[i] })
}

#[test]
fn a_rotation_off_unit_norm_by_more_than_1_percent_is_refused_and_within_normalised() {
    let setup = flight_setup(&Flight::new(3));
    let new = |x0: &[f64; 7]| Ekf::new(x0, &setup.p0, &setup.q, &setup.r);
    let mut ekf = new(&setup.x0).expect("a unit rotation");
    for norm in [1.5, 0.5, 1.011, 0.989] {
        let x0 = scaled_rotation(&setup.x0, norm);
        assert_eq!(new(&x0), Err(Status::RejectedInput), "norm {norm}");
        let f32_new = ahrs::Ekf::new(
            &to_f32(&x0),
            &matrix_to_f32(&setup.p0),
            &to_f32(&setup.q),
            &matrix_to_f32(&setup.r),
        );
        assert_eq!(f32_new, Err(Status::RejectedInput), "f32, norm {norm}");
        let before = ekf;
        assert_eq!(ekf.reset(&x0, &setup.p0), Status::RejectedInput);
        assert_eq!(ekf, before, "a refused reset leaves the filter as it was");
    }
    for norm in [1.005, 0.995] {
        let x0 = scaled_rotation(&setup.x0, norm);
        let from_new = new(&x0).expect("within 1 % of unit norm").state();
        assert_eq!(ekf.reset(&x0, &setup.p0), Status::Ok);
        for x in [from_new, ekf.state()] {
            let difference = largest_relative_difference(&x, &setup.x0);
            assert!(difference < 1e-15, "norm {norm}: {x:?} from {:?}", setup.x0);
        }
    }
}

#[test]
fn reset_takes_back_the_filters_own_state_and_covariance() {
    let mut flight = Flight::new(11);
    let setup = flight_setup(&flight);
    let mut ekf = Ekf::new(&setup.x0, &setup.p0, &setup.q, &setup.r).expect("a valid setup");
    for k in 0..2000 {
        let (gyro, y) = flight.sample();
        assert_eq!(ekf.step(&gyro, &y), Status::Ok, "sample {k}");
        let mut again = ekf;
        assert_eq!(
            again.reset(&ekf.state(), &ekf.covariance()),
            Status::Ok,
            "sample {k}"
        );
        assert_eq!(again.covariance(), ekf.covariance(), "sample {k}");
        // A unit quaternion divided by its norm, one to an ulp or two (the sum of
        // squares and the square root round), and the division rounds: a few ulps.
        let difference = largest_relative_difference(&again.state(), &ekf.state());
        assert!(
            difference <= 4.0 * f64::EPSILON,
            "sample {k}: {difference:e}"
        );
    }
}

/// [`reset_takes_back_the_filters_own_state_and_covariance`] in `f32`: its covariance
/// checks, in the scalar's rounding, accept what its own updates leave.
#[test]
fn the_f32_filter_takes_back_its_own_state_and_covariance() {
    let mut flight = Flight::new(13);
    let setup = flight_setup(&flight);
    let mut ekf = f32_filter(&setup);
    for k in 0..2000 {
        let (gyro, y) = flight.sample();
        assert_eq!(
            ekf.step(&to_f32(&gyro), &to_f32(&y)),
            Status::Ok,
            "sample {k}"
        );
        let mut again = ekf;
        assert_eq!(
            again.reset(&ekf.state(), &ekf.covariance()),
            Status::Ok,
            "sample {k}"
        );
        assert_eq!(again.covariance(), ekf.covariance(), "sample {k}");
        let difference =
            largest_relative_difference(&again.state().map(f64::from), &ekf.state().map(f64::from));
        assert!(
            difference <= 4.0 * f64::from(f32::EPSILON),
            "sample {k}: {difference:e}"
        );
    }
}
