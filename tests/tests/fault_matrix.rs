//! The fault matrix: every filter the demo models generate, and the error-state EKF of the
//! AHRS test model (ungated and gated), in `f32` and `f64`, against
//! every fault a sensor or a caller can produce (a NaN, infinite, 1e30 or stuck
//! measurement; a NaN, infinite or 1e30 input; a spike of 30 standard deviations; a NaN,
//! infinite or huge time
//! where the filter takes one; an initial covariance 1e8 times the measurement noise).
//!
//! What must hold, for each filter and fault:
//! - no step returns `Ok` with an exploded estimate: every entry finite and within 1e12 in
//!   magnitude, every variance non-negative (the data are the model's own, of order 1 to
//!   1e4), every rotation a unit quaternion;
//! - a step that does not return `Ok` leaves the estimate as it was, except that an outlier
//!   rejected by a step's gate keeps the prediction;
//! - NaN and infinity are `RejectedInput`; a gated filter rejects the 30-sigma spike as an
//!   outlier, and every filter refuses the 1e30 measurement (`OutlierRejected`,
//!   `Diverged` or `NonFinite`);
//! - afterwards the filter recovers on good data (by itself, or after `reset` where it has
//!   one): its last ten steps are `Ok`.
//!
//! The data are noise-free, produced by each model's own `f64` filter predicting from the
//! prior (its estimate is the truth), so that every step before a fault is `Ok`.
//!
//! An error-state EKF's covariance is over the tangent space, smaller than its state (the
//! AHRS's 6 against 7): covariances and variances here are the filter's, of its own
//! dimension, and a reset's `x0` is a true state, whose rotations are unit quaternions.

use generated_demo::{
    beam_two_actuators, blade_identification, cantilever, duffing_beam, helicopter,
    mass_spring_damper, piecewise_beam, polynomial,
};

include!("../models/ahrs.rs");

/// Entries beyond this are an exploded estimate.
const EXPLODED: f64 = 1e12;
/// How far from one a rotation's quaternion norm may be, in `f32` (measured within 1.3e-7
/// over 1e5 samples of a flight, `tests/error_state_ekf.rs`).
const UNIT_NORM: f64 = 1e-5;
/// Good samples before a fault, and after it before recovery is judged.
const WARM_UP: usize = 40;
const RECOVERY: usize = 80;

/// One sample of the model's data.
#[derive(Clone, Debug)]
struct Sample {
    /// The previous sample's time, which the prediction starts from.
    t: f64,
    /// The input since the previous sample.
    u: Vec<f64>,
    /// The measurement.
    y: Vec<f64>,
    /// The true state at the measurement, which a reset after a fault starts from.
    x: Vec<f64>,
}

/// A filter under test, whatever its type and scalar.
trait Subject: Clone {
    /// The state estimates (a DKF's LKF, then AKF).
    fn states(&self) -> Vec<f64>;
    /// Everything a rejected step must leave as it was: estimates and full covariances.
    fn snapshot(&self) -> Vec<f64>;
    /// The variances (covariance diagonals), as many as the covariance's dimension (for an
    /// error-state EKF the tangent space's, not the state's).
    fn variances(&self) -> Vec<f64>;
    /// Where in the states each rotation's unit quaternion starts (an error-state EKF's).
    fn rotations(&self) -> &'static [usize] {
        &[]
    }
    /// One sample; the status of each stage (one for a filter, two for a DKF).
    fn sample(&mut self, s: &Sample) -> Vec<String>;
    /// The snapshot after the sample's prediction alone, for filters that can predict.
    fn predicted(&self, s: &Sample) -> Option<Vec<f64>>;
    /// Starts again from `x0` with the prior's variances; false when the filter has no
    /// `reset`.
    fn reset(&mut self, x0: &[f64]) -> bool;
    /// Starts again from `x0` with the variances `p0` (of the covariance's dimension);
    /// false when the filter has no `reset`.
    fn reset_with(&mut self, x0: &[f64], p0: &[f64]) -> bool;
    /// Whether an innovation gate below the divergence bound is set.
    fn gated(&self) -> bool;
    /// The measurement noise standard deviations, for the spike.
    fn sigma(&self) -> Vec<f64>;
    /// Whether the filter reads the time.
    fn takes_time(&self) -> bool;
}

/// The scalar of a filter: `f32` or `f64`.
trait Scalar: Copy + Default + core::fmt::Debug {
    fn of(v: f64) -> Self;
    fn to(self) -> f64;
}
impl Scalar for f32 {
    fn of(v: f64) -> Self {
        v as f32
    }
    fn to(self) -> f64 {
        f64::from(self)
    }
}
impl Scalar for f64 {
    fn of(v: f64) -> Self {
        v
    }
    fn to(self) -> f64 {
        self
    }
}

/// `v` as an array of the filter's scalar.
fn arr<S: Scalar, const N: usize>(v: &[f64]) -> [S; N] {
    core::array::from_fn(|i| S::of(v[i]))
}

/// The diagonal matrix of `d`, in the filter's scalar.
fn diag<S: Scalar, const N: usize>(d: &[f64]) -> [[S; N]; N] {
    core::array::from_fn(|i| {
        core::array::from_fn(|j| if i == j { S::of(d[i]) } else { S::default() })
    })
}

fn status_name(s: impl core::fmt::Debug) -> String {
    format!("{s:?}")
}

/// A Kalman filter of the EKF family (`new`, `step`, `predict`, `reset`, `state`,
/// `covariance`): its type, scalar, whether it has a gate to set (`set_innovation_gate`),
/// whether it reads time, and how to build it, step it and predict with it.
macro_rules! ekf_subject {
    (
        $name:ident: $ty:ty, $s:ty, gate = $gate:tt, time = $time:expr, noise_time = $noise_time:expr,
        rotations = $rotations:expr, new = $new:expr, step = $step:expr, predict = $predict:expr
        $(,)?
    ) => {
        #[derive(Clone)]
        struct $name {
            filter: $ty,
            prior: (Vec<f64>, Vec<f64>),
            sigma: Vec<f64>,
            gated: bool,
        }

        impl $name {
            #[allow(unused_mut)]
            fn new(x0: &[f64], p0: &[f64], q: &[f64], r: &[f64], gate: Option<f64>) -> Self {
                let new: fn(&[f64], &[f64], &[f64], &[f64]) -> $ty = $new;
                let mut filter = new(x0, p0, q, r);
                ekf_subject!(@gate filter, gate, $s, $gate);
                $name {
                    filter,
                    prior: (x0.to_vec(), p0.to_vec()),
                    // A density `R` over the sample time: the variance of a sample is `R / T`.
                    sigma: r.iter().map(|r| (r / $noise_time).sqrt()).collect(),
                    gated: gate.is_some(),
                }
            }
        }

        impl Subject for $name {
            fn states(&self) -> Vec<f64> {
                self.filter.state().iter().map(|&v| Scalar::to(v)).collect()
            }
            fn snapshot(&self) -> Vec<f64> {
                let mut all = self.states();
                all.extend(self.filter.covariance().iter().flatten().map(|&v| Scalar::to(v)));
                all
            }
            fn variances(&self) -> Vec<f64> {
                let p = self.filter.covariance();
                (0..p.len()).map(|i| Scalar::to(p[i][i])).collect()
            }
            fn rotations(&self) -> &'static [usize] { $rotations }
            fn sample(&mut self, s: &Sample) -> Vec<String> {
                let step: fn(&mut $ty, &Sample) -> String = $step;
                vec![step(&mut self.filter, s)]
            }
            fn predicted(&self, s: &Sample) -> Option<Vec<f64>> {
                let predict: fn(&mut $ty, &Sample) -> String = $predict;
                let mut predicted = self.clone();
                (predict(&mut predicted.filter, s) == "Ok").then(|| predicted.snapshot())
            }
            fn reset(&mut self, x0: &[f64]) -> bool {
                let p0 = self.prior.1.clone();
                self.reset_with(x0, &p0)
            }
            fn reset_with(&mut self, x0: &[f64], p0: &[f64]) -> bool {
                status_name(self.filter.reset(&arr::<$s, _>(x0), &diag::<$s, _>(p0))) == "Ok"
            }
            fn gated(&self) -> bool {
                self.gated
            }
            fn sigma(&self) -> Vec<f64> {
                self.sigma.clone()
            }
            fn takes_time(&self) -> bool {
                $time
            }
        }
    };
    (@gate $filter:ident, $gate:ident, $s:ty, true) => {
        if let Some(g) = $gate {
            assert_eq!(status_name($filter.set_innovation_gate(g as $s)), "Ok");
        }
    };
    (@gate $filter:ident, $gate:ident, $s:ty, false) => {
        assert!($gate.is_none(), "a filter generated without a gate");
    };
}

/// [`ekf_subject!`] for a filter type of `$module`, in `f32` and in `f64`: `q` says whether
/// its process noise is a vector of variances or a matrix, `call` how its methods take
/// their arguments (`plain`: `(u_prev, y)`; `no_input`: `(y)`; `timed`: `(t, u_prev, y)`),
/// `rotations` where its unit quaternions start in the state (none unless given).
macro_rules! ekf_family {
    (
        $n32:ident, $n64:ident, $module:ident :: $ty:ident, gate = $gate:tt, q = $q:tt,
        call = $call:tt $(, density = $dt:expr)? $(, rotations = [$($at:expr),*])?
    ) => {
        ekf_family!(
            @one $n32, $module::$ty, f32, $gate, $q, $call, 1.0 $(* $dt)?, &[$($($at),*)?]
        );
        ekf_family!(
            @one $n64, $module::in_f64::$ty, f64, $gate, $q, $call, 1.0 $(* $dt)?, &[$($($at),*)?]
        );
    };
    (
        @one $name:ident, $path:path, $s:ty, $gate:tt, $q:tt, $call:tt, $noise_time:expr,
        $rotations:expr
    ) => {
        ekf_subject!(
            $name: $path, $s, gate = $gate, time = ekf_family!(@timed $call), noise_time = $noise_time,
            rotations = $rotations, new = |x0, p0, q, r| {
                <$path>::new(&arr(x0), &diag(p0), &ekf_family!(@q $q, q), &diag(r)).unwrap()
            },
            step = |f, s| status_name(ekf_family!(@step $call, f, s, $s)),
            predict = |f, s| status_name(ekf_family!(@predict $call, f, s, $s)),
        );
    };
    (@timed timed) => { true };
    (@timed $other:tt) => { false };
    (@q vector, $q:ident) => { arr($q) };
    (@q matrix, $q:ident) => { diag($q) };
    (@step plain, $f:ident, $s:ident, $sc:ty) => { $f.step(&arr(&$s.u), &arr(&$s.y)) };
    (@step no_input, $f:ident, $s:ident, $sc:ty) => { $f.step(&arr(&$s.y)) };
    (@step timed, $f:ident, $s:ident, $sc:ty) => {
        $f.step(<$sc>::of($s.t), &arr(&$s.u), &arr(&$s.y))
    };
    (@predict plain, $f:ident, $s:ident, $sc:ty) => { $f.predict(&arr(&$s.u)) };
    (@predict no_input, $f:ident, $s:ident, $sc:ty) => {{ let _ = $s; $f.predict() }};
    (@predict timed, $f:ident, $s:ident, $sc:ty) => { $f.predict(<$sc>::of($s.t), &arr(&$s.u)) };
}

ekf_family!(
    CantileverEkf32,
    CantileverEkf64,
    cantilever::Ekf,
    gate = false,
    q = vector,
    call = plain
);
ekf_family!(
    CantileverGated32,
    CantileverGated64,
    cantilever::GatedEkf,
    gate = true,
    q = vector,
    call = plain
);
ekf_family!(
    TwoActuatorsEkf32,
    TwoActuatorsEkf64,
    beam_two_actuators::Ekf,
    gate = false,
    q = matrix,
    call = plain
);
ekf_family!(
    DuffingEkf32,
    DuffingEkf64,
    duffing_beam::Ekf,
    gate = false,
    q = matrix,
    call = plain
);
ekf_family!(
    BladeHybrid32,
    BladeHybrid64,
    blade_identification::HybridEkf,
    gate = true,
    q = vector,
    call = plain
);
ekf_family!(
    SpringHybrid32,
    SpringHybrid64,
    mass_spring_damper::HybridEkf,
    gate = false,
    q = vector,
    call = plain
);
ekf_family!(
    PolynomialEkf32,
    PolynomialEkf64,
    polynomial::Ekf,
    gate = false,
    q = matrix,
    call = no_input
);
ekf_family!(
    PiecewiseEkf32,
    PiecewiseEkf64,
    piecewise_beam::Ekf,
    gate = false,
    q = matrix,
    call = plain
);
ekf_family!(
    HelicopterEkf32,
    HelicopterEkf64,
    helicopter::Ekf,
    gate = true,
    q = matrix,
    call = timed
);
ekf_family!(
    HelicopterContinuous32,
    HelicopterContinuous64,
    helicopter::ContinuousEkf,
    gate = true,
    q = vector,
    call = timed,
    density = helicopter::in_f64::TS
);
ekf_family!(
    AhrsEkf32,
    AhrsEkf64,
    ahrs::Ekf,
    gate = false,
    q = vector,
    call = plain,
    rotations = [ahrs::index::Q_X]
);
ekf_family!(
    AhrsGated32,
    AhrsGated64,
    ahrs::GatedEkf,
    gate = true,
    q = vector,
    call = plain,
    rotations = [ahrs::index::Q_X]
);

/// A filter outside the EKF family: how to read, step and build it, and where it has them,
/// how to set its gate (`set_gate`: whether it took the threshold) and how to predict a
/// sample without its measurement (`predict`: whether it did).
macro_rules! other_subject {
    (
        $name:ident: $ty:ty, new = $new:expr, sample = $sample:expr,
        snapshot = $snapshot:expr, states = $states:expr, variances = $variances:expr,
        reset = $reset:expr $(, set_gate = $set_gate:expr, predict = $predict:expr)? $(,)?
    ) => {
        #[derive(Clone)]
        struct $name {
            filter: $ty,
            sigma: Vec<f64>,
            prior_variances: Vec<f64>,
            gated: bool,
        }

        impl $name {
            fn new(x0: &[f64], p0: &[f64], q: &[f64], r: &[f64], gate: Option<f64>) -> Self {
                let new: fn(&[f64], &[f64], &[f64], &[f64]) -> $ty = $new;
                let mut filter = new(x0, p0, q, r);
                let set_gate: fn(&mut $ty, f64) -> bool = other_subject!(@or $($set_gate)?);
                if let Some(g) = gate {
                    assert!(set_gate(&mut filter, g), "the gate of {}", stringify!($name));
                }
                $name {
                    filter,
                    sigma: r.iter().map(|r| r.sqrt()).collect(),
                    prior_variances: p0.to_vec(),
                    gated: gate.is_some(),
                }
            }
        }

        impl Subject for $name {
            fn states(&self) -> Vec<f64> {
                let states: fn(&$ty) -> Vec<f64> = $states;
                states(&self.filter)
            }
            fn snapshot(&self) -> Vec<f64> {
                let snapshot: fn(&$ty) -> Vec<f64> = $snapshot;
                snapshot(&self.filter)
            }
            fn variances(&self) -> Vec<f64> {
                let variances: fn(&$ty) -> Vec<f64> = $variances;
                variances(&self.filter)
            }
            fn sample(&mut self, s: &Sample) -> Vec<String> {
                let sample: fn(&mut $ty, &Sample) -> Vec<String> = $sample;
                sample(&mut self.filter, s)
            }
            fn predicted(&self, s: &Sample) -> Option<Vec<f64>> {
                let predict: fn(&mut $ty, &Sample) -> bool = other_subject!(@or $($predict)?);
                let mut predicted = self.clone();
                predict(&mut predicted.filter, s).then(|| predicted.snapshot())
            }
            fn reset(&mut self, x0: &[f64]) -> bool {
                let p0 = self.prior_variances.clone();
                self.reset_with(x0, &p0)
            }
            fn reset_with(&mut self, x0: &[f64], p0: &[f64]) -> bool {
                let reset: fn(&mut $ty, &[f64], &[f64]) -> bool = $reset;
                reset(&mut self.filter, x0, p0)
            }
            fn gated(&self) -> bool {
                self.gated
            }
            fn sigma(&self) -> Vec<f64> {
                self.sigma.clone()
            }
            fn takes_time(&self) -> bool {
                false
            }
        }
    };
    (@or $given:expr) => { $given };
    (@or) => { |_, _| false };
}

/// Entries of a matrix as `f64`, row by row.
fn flat<S: Scalar, const N: usize>(m: &[[S; N]; N]) -> Vec<f64> {
    m.iter().flatten().map(|&v| v.to()).collect()
}

fn to_f64<S: Scalar>(v: &[S]) -> Vec<f64> {
    v.iter().map(|&v| v.to()).collect()
}

fn diagonal_of<S: Scalar, const N: usize>(m: &[[S; N]; N]) -> Vec<f64> {
    (0..N).map(|i| m[i][i].to()).collect()
}

/// The DKF of `$module` in `f32` and `f64` (`q`: its process noises' shape; `gate`: whether
/// it has one to set): both filter stages are judged, the LKF's (the DKF's estimate) and the
/// AKF's.
macro_rules! dkf_family {
    ($n32:ident, $n64:ident, $module:ident, q = $q:tt, gate = $gate:tt) => {
        dkf_family!(@one $n32, $module::Dkf, f32, $q, $gate);
        dkf_family!(@one $n64, $module::in_f64::Dkf, f64, $q, $gate);
    };
    (@one $name:ident, $path:path, $s:ty, $q:tt, $gate:tt) => {
        other_subject!(
            $name: $path,
            new = |x0, p0, q, r| {
                let q = ekf_family!(@q $q, q);
                <$path>::new(&arr(x0), &diag(p0), &q, &diag(p0), &q, &diag(r)).unwrap()
            },
            sample = |f, s| {
                let status = f.step(&arr(&s.u), &arr(&s.y));
                vec![status_name(status.lkf), status_name(status.akf)]
            },
            snapshot = |f| {
                let mut all = to_f64(&f.state());
                all.extend(flat(&f.covariance()));
                all.extend(to_f64(&f.akf_state()));
                all.extend(flat(&f.akf_covariance()));
                all
            },
            states = |f| {
                let mut all = to_f64(&f.state());
                all.extend(to_f64(&f.akf_state()));
                all
            },
            variances = |f| {
                let mut all = diagonal_of(&f.covariance());
                all.extend(diagonal_of(&f.akf_covariance()));
                all
            },
            reset = |f, x0, p0| {
                status_name(f.reset(&arr(x0), &diag(p0), &diag(p0))) == "Ok"
            },
            set_gate = dkf_family!(@gate $gate, $s),
            predict = |f, s| f.predict(&arr(&s.u)).is_ok(),
        );
    };
    (@gate true, $s:ty) => { |f, g| status_name(f.set_innovation_gate(g as $s)) == "Ok" };
    (@gate false, $s:ty) => { |_, _| false };
}

dkf_family!(
    CantileverDkf32,
    CantileverDkf64,
    cantilever,
    q = vector,
    gate = true
);
dkf_family!(
    TwoActuatorsDkf32,
    TwoActuatorsDkf64,
    beam_two_actuators,
    q = matrix,
    gate = false
);
dkf_family!(
    DuffingDkf32,
    DuffingDkf64,
    duffing_beam,
    q = matrix,
    gate = false
);

/// The polynomial Kalman filter and the switched observers, in `f32` and `f64`.
macro_rules! polynomial_kf {
    ($name:ident, $path:path, $s:ty) => {
        other_subject!(
            $name: $path,
            new = |x0, p0, _, _| <$path>::new(&arr(x0), &diag(p0)).unwrap(),
            sample = |f, s| vec![status_name(f.step(<$s>::of(s.y[0])))],
            snapshot = |f| {
                let mut all = to_f64(&f.state());
                all.extend(flat(&f.covariance()));
                all
            },
            states = |f| to_f64(&f.state()),
            variances = |f| diagonal_of(&f.covariance()),
            reset = |f, x0, p0| status_name(f.reset(&arr(x0), &diag(p0))) == "Ok",
        );
    };
}

polynomial_kf!(PolynomialKf32, polynomial::PolynomialKf, f32);
polynomial_kf!(PolynomialKf64, polynomial::in_f64::PolynomialKf, f64);

macro_rules! observer {
    ($name:ident, $path:path) => {
        other_subject!(
            $name: $path,
            new = |x0, _, _, _| <$path>::new(&arr(x0)).unwrap(),
            sample = |f, s| vec![status_name(f.step(&arr(&s.u), &arr(&s.y)))],
            snapshot = |f| to_f64(&f.state()),
            states = |f| to_f64(&f.state()),
            variances = |_| Vec::new(),
            reset = |f, x0, _| status_name(f.reset(&arr(x0))) == "Ok",
        );
    };
}

observer!(LinearError32, piecewise_beam::LinearErrorObserver);
observer!(LinearError64, piecewise_beam::in_f64::LinearErrorObserver);
observer!(SwitchedKalman32, piecewise_beam::SwitchedKalmanObserver);
observer!(
    SwitchedKalman64,
    piecewise_beam::in_f64::SwitchedKalmanObserver
);

/// A fault: the samples it replaces from the fault's sample on, and what it expects.
struct Fault {
    name: &'static str,
    samples: Vec<Sample>,
    expect: Expect,
}

/// What a fault's samples must return (besides never leaving an exploded estimate).
#[derive(Clone, Copy, PartialEq, Debug)]
enum Expect {
    /// Every stage `RejectedInput`.
    Rejected,
    /// Every stage something else than `Ok`.
    NotOk,
    /// Every stage `OutlierRejected`.
    Outlier,
    /// Anything that does not explode.
    Anything,
}

/// `good` with `f` applied to it, as the one sample of a fault.
fn altered(good: &Sample, f: &dyn Fn(&mut Sample)) -> Vec<Sample> {
    let mut s = good.clone();
    f(&mut s);
    vec![s]
}

/// The faults of the measurement: NaN, infinite, 1e30 and stuck from sample `k0`.
fn measurement_faults(data: &[Sample], k0: usize) -> Vec<Fault> {
    let good = &data[k0];
    let with = |f: &dyn Fn(&mut Sample)| altered(good, f);
    vec![
        Fault {
            name: "NaN measurement",
            samples: with(&|s| s.y[0] = f64::NAN),
            expect: Expect::Rejected,
        },
        Fault {
            name: "infinite measurement",
            samples: with(&|s| s.y[0] = f64::INFINITY),
            expect: Expect::Rejected,
        },
        Fault {
            name: "last output's measurement minus infinity",
            samples: with(&|s| {
                let last = s.y.len() - 1;
                s.y[last] = f64::NEG_INFINITY;
            }),
            expect: Expect::Rejected,
        },
        Fault {
            name: "measurement of 1e30",
            samples: with(&|s| s.y[0] = 1e30),
            expect: Expect::NotOk,
        },
        Fault {
            name: "stuck measurement",
            samples: data[k0..k0 + 50]
                .iter()
                .map(|s| Sample {
                    y: good.y.clone(),
                    ..s.clone()
                })
                .collect(),
            expect: Expect::Anything,
        },
    ]
}

/// A spike of 30 measurement standard deviations on every output of `good`: an outlier
/// to a gated `subject`.
fn spike_fault<S: Subject>(subject: &S, good: &Sample) -> Fault {
    let sigma = subject.sigma();
    let spike = altered(good, &|s| {
        s.y.iter_mut()
            .zip(&sigma)
            .for_each(|(y, sd)| *y += 30.0 * sd)
    });
    let expect = if subject.gated() {
        Expect::Outlier
    } else {
        Expect::Anything
    };
    Fault {
        name: "spike of 30 sigma",
        samples: spike,
        expect,
    }
}

/// The faults of the input of `good`: NaN, infinite and 1e30.
fn input_faults(good: &Sample) -> Vec<Fault> {
    let with = |f: &dyn Fn(&mut Sample)| altered(good, f);
    vec![
        Fault {
            name: "NaN input",
            samples: with(&|s| s.u[0] = f64::NAN),
            expect: Expect::Rejected,
        },
        Fault {
            name: "infinite input",
            samples: with(&|s| s.u[0] = f64::INFINITY),
            expect: Expect::Rejected,
        },
        Fault {
            name: "last input minus infinity",
            samples: with(&|s| {
                let last = s.u.len() - 1;
                s.u[last] = f64::NEG_INFINITY;
            }),
            expect: Expect::Rejected,
        },
        Fault {
            name: "input of 1e30",
            samples: with(&|s| s.u[0] = 1e30),
            expect: Expect::Anything,
        },
    ]
}

/// The faults of the time of `good`: NaN, infinite and 1e30.
fn time_faults(good: &Sample) -> Vec<Fault> {
    let with = |f: &dyn Fn(&mut Sample)| altered(good, f);
    vec![
        Fault {
            name: "NaN time",
            samples: with(&|s| s.t = f64::NAN),
            expect: Expect::Rejected,
        },
        Fault {
            name: "infinite time",
            samples: with(&|s| s.t = f64::INFINITY),
            expect: Expect::Rejected,
        },
        Fault {
            name: "time of 1e30",
            samples: with(&|s| s.t = 1e30),
            expect: Expect::Anything,
        },
    ]
}

/// The faults for `subject`, replacing the data from sample `k0`.
fn faults<S: Subject>(subject: &S, data: &[Sample], k0: usize) -> Vec<Fault> {
    let good = &data[k0];
    let mut faults = measurement_faults(data, k0);
    faults.push(spike_fault(subject, good));
    if !good.u.is_empty() {
        faults.extend(input_faults(good));
    }
    if subject.takes_time() {
        faults.extend(time_faults(good));
    }
    faults
}

/// Why the estimate is exploded, if it is.
fn exploded<S: Subject>(subject: &S) -> Option<String> {
    let states = subject.states();
    if let Some(v) = states.iter().find(|v| !v.is_finite() || v.abs() > EXPLODED) {
        return Some(format!("a state of {v:e}"));
    }
    let variances = subject.variances();
    if let Some(v) = variances
        .iter()
        .find(|v| !v.is_finite() || **v < 0.0 || **v > EXPLODED)
    {
        return Some(format!("a variance of {v:e}"));
    }
    for &at in subject.rotations() {
        let norm = states[at..at + 4].iter().map(|v| v * v).sum::<f64>().sqrt();
        if (norm - 1.0).abs() > UNIT_NORM {
            return Some(format!("a rotation of norm {norm}"));
        }
    }
    None
}

/// Feeds `samples`, checking each step against `expect`; the failures, named.
fn feed<S: Subject>(subject: &mut S, samples: &[Sample], expect: Expect) -> Vec<String> {
    let mut failures = Vec::new();
    for (i, s) in samples.iter().enumerate() {
        let before = subject.snapshot();
        let predicted = subject.predicted(s);
        let statuses = subject.sample(s);
        let wrong = match expect {
            Expect::Rejected => statuses.iter().any(|s| s != "RejectedInput"),
            Expect::NotOk => statuses.iter().any(|s| s == "Ok"),
            Expect::Outlier => statuses.iter().any(|s| s != "OutlierRejected"),
            Expect::Anything => false,
        };
        if wrong {
            failures.push(format!("sample {i}: {statuses:?}, expected {expect:?}"));
        }
        if statuses.iter().all(|s| s != "Ok") {
            let after = subject.snapshot();
            let kept_prediction = statuses.iter().all(|s| s == "OutlierRejected")
                && predicted.as_ref() == Some(&after);
            // A stage that recovers scales its covariance (by a factor above 1) and leaves
            // its estimate as the refusal does: as it was, or at its prediction.
            let recovered = statuses.iter().any(|s| s == "Recovering")
                && statuses
                    .iter()
                    .all(|s| s == "Recovering" || s == "OutlierRejected" || s == "Diverged")
                && (scaled(&before, &after)
                    || predicted.as_ref().is_some_and(|p| scaled(p, &after)));
            if after != before && !kept_prediction && !recovered {
                failures.push(format!("sample {i}: {statuses:?} but the estimate changed"));
            }
        }
        if let Some(why) = exploded(subject) {
            failures.push(format!("sample {i}: {statuses:?} left {why}"));
            break;
        }
    }
    failures
}

/// Whether `after` is `before` with some of its entries (a covariance's) multiplied by a
/// common factor above 1, one per stage (at most two: a DKF's filters), to rounding.
fn scaled(before: &[f64], after: &[f64]) -> bool {
    let mut factors: Vec<f64> = Vec::new();
    for (&b, &a) in before.iter().zip(after) {
        if a == b {
            continue;
        }
        let k = a / b;
        if k.is_nan() || k <= 1.0 {
            return false;
        }
        if !factors.iter().any(|f| (k / f - 1.0).abs() < 1e-5) {
            factors.push(k);
        }
    }
    before.len() == after.len() && factors.len() <= 2
}

/// Whether the last ten of `samples` are all `Ok`.
fn recovers<S: Subject>(subject: &mut S, samples: &[Sample]) -> bool {
    let statuses: Vec<Vec<String>> = samples.iter().map(|s| subject.sample(s)).collect();
    exploded(subject).is_none()
        && statuses[statuses.len() - 10..]
            .iter()
            .flatten()
            .all(|s| s == "Ok")
}

/// The whole matrix for one filter configuration: the failures, named.
fn matrix<S: Subject>(name: &str, base: &S, data: &[Sample], r_max: f64) -> Vec<String> {
    let mut failures = Vec::new();
    let mut warm = base.clone();
    let statuses: Vec<String> = data[..WARM_UP]
        .iter()
        .flat_map(|s| warm.sample(s))
        .collect();
    if statuses.iter().any(|s| s != "Ok") || exploded(&warm).is_some() {
        return vec![format!(
            "{name}: the nominal run fails: {statuses:?} {:?}",
            exploded(&warm)
        )];
    }
    for fault in faults(&warm, data, WARM_UP) {
        let mut filter = warm.clone();
        for f in feed(&mut filter, &fault.samples, fault.expect) {
            failures.push(format!("{name}, {}: {f}", fault.name));
        }
        let resume = WARM_UP + fault.samples.len();
        let after = &data[resume..resume + RECOVERY];
        if !recovers(&mut filter, after) {
            let again = &data[resume + RECOVERY..resume + 2 * RECOVERY];
            let x0 = &data[resume + RECOVERY - 1].x;
            if !(filter.reset(x0) && recovers(&mut filter, again)) {
                failures.push(format!("{name}, {}: no recovery", fault.name));
            }
        }
    }
    let mut wide = warm.clone();
    let (x0, p0) = (
        &data[WARM_UP - 1].x,
        vec![1e8 * r_max; wide.variances().len()],
    );
    if wide.reset_with(x0, &p0) {
        // A filter that cannot carry so wide a prior in its scalar (the f32 polynomial EKF:
        // its covariance loses a positive variance) must say so and recover by a reset.
        let run = &data[WARM_UP..WARM_UP + 2 * RECOVERY];
        let found = feed(&mut wide, run, Expect::Anything);
        let last = WARM_UP + 2 * RECOVERY;
        let after = &data[last..last + RECOVERY];
        let recovered = recovers(&mut wide, after)
            || (wide.reset(&data[last + RECOVERY - 1].x)
                && recovers(&mut wide, &data[last + RECOVERY..last + 2 * RECOVERY]));
        if !found.is_empty() || !recovered {
            failures.push(format!(
                "{name}, P0 = 1e8 R: {found:?}, recovered: {recovered}"
            ));
        }
    }
    failures
}

/// Samples enough for every fault and its recovery.
const SAMPLES: usize = WARM_UP + 50 + 4 * RECOVERY;

/// The model's own data: `truth` (an `f64` filter at the prior) predicts each sample with
/// `input(k)` from `t = k ts`, and `measure` gives the output of its new estimate.
fn data<F: Clone>(
    mut truth: F,
    ts: f64,
    input: impl Fn(f64) -> Vec<f64>,
    predict: impl Fn(&mut F, f64, &[f64]) -> Vec<f64>,
    measure: impl Fn(&F, f64) -> Vec<f64>,
) -> Vec<Sample> {
    (0..SAMPLES)
        .map(|k| {
            let t = k as f64 * ts;
            let u = input(t);
            let x = predict(&mut truth, t, &u);
            let y = measure(&truth, t + ts);
            Sample { t, u, y, x }
        })
        .collect()
}

/// The output of an EKF-family filter's estimate: minus the innovation of a zero
/// measurement (the truth's measurement noise is 1e12, so that no output is beyond its
/// divergence bound).
macro_rules! output_of {
    ($filter:expr, $m:expr $(, $t:expr)?) => {{
        let mut probe = $filter.clone();
        assert_eq!(status_name(probe.update($($t,)? &[0.0; $m])), "Ok");
        probe.innovation().iter().map(|r| -r).collect::<Vec<f64>>()
    }};
}

/// Runs the matrix over both scalars of one configuration and collects the failures.
macro_rules! check {
    ($failures:ident, $data:expr, $r:expr, ($x0:expr, $p0:expr, $q:expr), gate = $gate:expr, $($subject:ident),+) => {
        $(
            let gate: Option<f64> = $gate;
            let subject = $subject::new(&$x0, &$p0, &$q, &$r, gate);
            let name = format!("{} (gate {:?})", stringify!($subject), gate);
            let r_max = $r.iter().copied().fold(0.0_f64, f64::max);
            $failures.extend(matrix(&name, &subject, &$data, r_max));
        )+
    };
}

fn beam_input(t: f64) -> f64 {
    60.0 * (7.0 * t).sin() + 40.0 * (23.0 * t).sin()
}

fn report(failures: &[String]) {
    assert!(
        failures.is_empty(),
        "{} failures:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

#[test]
fn cantilever_filters() {
    use cantilever::in_f64::Ekf;
    let (x0, p0, q, r) = (
        [0.01, 0.0, -400.0, -1.0, 0.01],
        [0.1, 1.0, 2e4, 1000.0, 0.1],
        [0.0, 0.0, 100.0, 300.0, 1e-3],
        [1e-3],
    );
    let truth = Ekf::new(&x0, &diag(&[0.0; 5]), &[0.0; 5], &[[1e12]]).unwrap();
    let data = data(
        truth,
        0.015,
        |t| vec![beam_input(t)],
        |f, _, u| {
            assert_eq!(f.predict(&[u[0]]), cantilever::in_f64::Status::Ok);
            f.state().to_vec()
        },
        |f, _| output_of!(f, 1),
    );
    let mut failures = Vec::new();
    check!(
        failures,
        data,
        r,
        (x0, p0, q),
        gate = None,
        CantileverEkf32,
        CantileverEkf64,
        CantileverDkf32,
        CantileverDkf64
    );
    check!(
        failures,
        data,
        r,
        (x0, p0, q),
        gate = Some(10.83),
        CantileverGated32,
        CantileverGated64,
        CantileverDkf32,
        CantileverDkf64
    );
    report(&failures);
}

/// The truth's prediction of an EKF-family `f64` filter (`$call` as in [`ekf_family!`]),
/// returning the new true state.
macro_rules! truth_predict {
    (plain, $status:path) => {
        |f, _, u| {
            assert_eq!(f.predict(&arr(u)), $status);
            f.state().to_vec()
        }
    };
    (no_input, $status:path) => {
        |f, _, _| {
            assert_eq!(f.predict(), $status);
            f.state().to_vec()
        }
    };
    (timed, $status:path) => {
        |f, t, u| {
            assert_eq!(f.predict(t, &arr(u)), $status);
            f.state().to_vec()
        }
    };
}

#[test]
fn two_actuator_beam_filters() {
    use beam_two_actuators::in_f64::{Ekf, Status};
    let x0 = [0.2, 0.0, -393.93, -6.941, 0.4924, -0.3];
    let (p0, q, r) = (
        [0.1, 1.0, 2e4, 1000.0, 0.1, 0.1],
        [0.0, 0.0, 100.0, 300.0, 1e-3, 1e-3],
        [1e-3],
    );
    let truth = Ekf::new(&x0, &diag(&[0.0; 6]), &diag(&[0.0; 6]), &[[1e12]]).unwrap();
    let input = |t: f64| vec![beam_input(t), beam_input(t + 1.3)];
    let data = data(
        truth,
        0.015,
        input,
        truth_predict!(plain, Status::Ok),
        |f, _| output_of!(f, 1),
    );
    let mut failures = Vec::new();
    check!(
        failures,
        data,
        r,
        (x0, p0, q),
        gate = None,
        TwoActuatorsEkf32,
        TwoActuatorsEkf64,
        TwoActuatorsDkf32,
        TwoActuatorsDkf64
    );
    report(&failures);
}

#[test]
fn duffing_beam_filters() {
    use duffing_beam::in_f64::{Ekf, Status};
    let x0 = [0.2, 0.0, -393.93, -6.941, -50.0, 0.4924];
    let (p0, q, r) = (
        [0.1, 1.0, 2e4, 1000.0, 100.0, 0.1],
        [0.0, 0.0, 100.0, 300.0, 10.0, 1e-3],
        [1e-3],
    );
    let truth = Ekf::new(&x0, &diag(&[0.0; 6]), &diag(&[0.0; 6]), &[[1e12]]).unwrap();
    let input = |t: f64| vec![beam_input(t)];
    let data = data(
        truth,
        0.015,
        input,
        truth_predict!(plain, Status::Ok),
        |f, _| output_of!(f, 1),
    );
    let mut failures = Vec::new();
    check!(
        failures,
        data,
        r,
        (x0, p0, q),
        gate = None,
        DuffingEkf32,
        DuffingEkf64,
        DuffingDkf32,
        DuffingDkf64
    );
    report(&failures);
}

#[test]
fn blade_and_mass_spring_hybrid_filters() {
    let input = |t: f64| vec![(t * 37.0).sin()];
    let mut failures = Vec::new();
    {
        use blade_identification::in_f64::{HybridEkf, Status};
        let x0 = [0.0, 0.0, 450.0, 0.1, 5e-4, 2.0];
        let (p0, q, r) = (
            [1e-5, 1.0, 1e4, 1e-2, 1e-6, 0.1],
            [0.0, 1e-2, 1e3, 1e-3, 1e-9, 1.0],
            [1e-10],
        );
        let truth = HybridEkf::new(&x0, &diag(&[0.0; 6]), &[0.0; 6], &[[1e12]]).unwrap();
        let data = data(
            truth,
            0.01,
            input,
            truth_predict!(plain, Status::Ok),
            |f, _| output_of!(f, 1),
        );
        check!(
            failures,
            data,
            r,
            (x0, p0, q),
            gate = None,
            BladeHybrid32,
            BladeHybrid64
        );
        check!(
            failures,
            data,
            r,
            (x0, p0, q),
            gate = Some(10.83),
            BladeHybrid32,
            BladeHybrid64
        );
    }
    {
        use mass_spring_damper::in_f64::{HybridEkf, Status};
        let x0 = [0.0, 0.0, 0.0, 0.0, 2.0];
        let (p0, q, r) = (
            [1e-5, 1.0, 1e-6, 1e-6, 1e-4],
            // On eta2 and inv_m, the states its process noise enters.
            [1.0, 1e2],
            [1e-6],
        );
        let truth = HybridEkf::new(&x0, &diag(&[0.0; 5]), &[0.0; 2], &[[1e12]]).unwrap();
        let data = data(
            truth,
            0.01,
            input,
            truth_predict!(plain, Status::Ok),
            |f, _| output_of!(f, 1),
        );
        check!(
            failures,
            data,
            r,
            (x0, p0, q),
            gate = None,
            SpringHybrid32,
            SpringHybrid64
        );
    }
    report(&failures);
}

#[test]
fn polynomial_filters() {
    use polynomial::in_f64::{Ekf, Status};
    let x0 = [0.0, 0.1, 0.01, 0.001];
    let (p0, q, r) = ([1e-2; 4], [1e-8; 4], [1e-4]);
    let truth = Ekf::new(&x0, &diag(&[0.0; 4]), &diag(&[0.0; 4]), &[[1e12]]).unwrap();
    let data = data(
        truth,
        0.01,
        |_| Vec::new(),
        truth_predict!(no_input, Status::Ok),
        |f, _| output_of!(f, 1),
    );
    let mut failures = Vec::new();
    check!(
        failures,
        data,
        r,
        (x0, p0, q),
        gate = None,
        PolynomialEkf32,
        PolynomialEkf64,
        PolynomialKf32,
        PolynomialKf64
    );
    report(&failures);
}

#[test]
fn piecewise_beam_filters() {
    use piecewise_beam::in_f64::{Ekf, Status};
    let x0 = [0.0; 6];
    let (p0, q, r) = (
        [1e-6; 6],
        [1e-10, 1e-10, 1e-10, 1e-6, 1e-6, 1e-6],
        [1e-10, 1e-10],
    );
    let truth = Ekf::new(
        &x0,
        &diag(&[0.0; 6]),
        &diag(&[0.0; 6]),
        &diag(&[1e12, 1e12]),
    )
    .unwrap();
    let input = |t: f64| vec![20.0 * (t * 120.0).sin()];
    let data = data(
        truth,
        5e-4,
        input,
        truth_predict!(plain, Status::Ok),
        |f, _| output_of!(f, 2),
    );
    let mut failures = Vec::new();
    check!(
        failures,
        data,
        r,
        (x0, p0, q),
        gate = None,
        PiecewiseEkf32,
        PiecewiseEkf64,
        LinearError32,
        LinearError64,
        SwitchedKalman32,
        SwitchedKalman64
    );
    report(&failures);
}

#[test]
fn helicopter_filters() {
    use helicopter::in_f64::{Ekf, Status};
    let x0 = [0.05, 0.0, -0.05, 0.0, 0.0, 0.0];
    let p0 = [1.05, 0.05, 1.0, 1.0, 1.0, 1.0];
    let q = [0.0099, 0.0022, 0.0894, 0.0017, 1.2678, 1.2700];
    let r = [0.0007, 0.00193];
    let truth = Ekf::new(
        &x0,
        &diag(&[0.0; 6]),
        &diag(&[0.0; 6]),
        &diag(&[1e12, 1e12]),
    )
    .unwrap();
    let input = |t: f64| {
        let u = 0.2 * (0.4 * t).sin() + 0.4 * (0.6 * t).sin() + 0.05 * (0.8 * t).sin();
        vec![u, u]
    };
    let data = data(
        truth,
        0.001,
        input,
        truth_predict!(timed, Status::Ok),
        |f, t| output_of!(f, 2, t),
    );
    let mut failures = Vec::new();
    check!(
        failures,
        data,
        r,
        (x0, p0, q),
        gate = None,
        HelicopterEkf32,
        HelicopterEkf64,
        HelicopterContinuous32,
        HelicopterContinuous64
    );
    check!(
        failures,
        data,
        r,
        (x0, p0, q),
        gate = Some(13.82),
        HelicopterEkf32,
        HelicopterEkf64,
        HelicopterContinuous32,
        HelicopterContinuous64
    );
    report(&failures);
}

/// The AHRS's gyro rates [rad/s]: a slow tumble about every axis.
fn ahrs_gyro(t: f64) -> Vec<f64> {
    vec![
        0.4 * (1.3 * t).sin(),
        0.3 * (0.9 * t).cos(),
        0.5 * (0.7 * t + 1.0).sin(),
    ]
}

/// The error-state EKF of the AHRS test model (`tests/models/ahrs.rs`: a rotation state,
/// its covariance over the 3 coordinates of the rotation's tangent and the gyro bias's 3),
/// ungated and gated (`GatedEkf` of `tests/models/ahrs.rs`).
#[test]
fn ahrs_error_state_filters() {
    use ahrs::in_f64::{Ekf, Status};
    let attitude =
        nalgebra::UnitQuaternion::from_scaled_axis(nalgebra::Vector3::new(0.3, -0.2, 1.1));
    let [qx, qy, qz, qw] = attitude.coords.into();
    let x0 = [qx, qy, qz, qw, 0.01, -0.02, 0.015];
    // 0.1 rad of attitude, 0.01 rad/s of bias; the gyro's noise over a sample and a slow
    // bias walk; the accelerometer's noise (0.1 m/s^2) and the magnetometer's (5 mgauss).
    let (p0, q, r) = (
        [1e-2, 1e-2, 1e-2, 1e-4, 1e-4, 1e-4],
        [2.5e-9, 2.5e-9, 2.5e-9, 1e-10, 1e-10, 1e-10],
        [1e-2, 1e-2, 1e-2, 2.5e-5, 2.5e-5, 2.5e-5],
    );
    let truth = Ekf::new(&x0, &diag(&[0.0; 6]), &[0.0; 6], &diag(&[1e12; 6])).unwrap();
    let data = data(
        truth,
        ahrs::in_f64::DT,
        ahrs_gyro,
        truth_predict!(plain, Status::Ok),
        |f, _| output_of!(f, 6),
    );
    let mut failures = Vec::new();
    check!(
        failures,
        data,
        r,
        (x0, p0, q),
        gate = None,
        AhrsEkf32,
        AhrsEkf64
    );
    check!(
        failures,
        data,
        r,
        (x0, p0, q),
        gate = Some(22.46),
        AhrsGated32,
        AhrsGated64
    );
    report(&failures);
}
