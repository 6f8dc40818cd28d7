//! The sample interval given at run time to the filters of continuous dynamics
//! (`interval DT = 0.02;` with `dynamics continuous(.., dt = DT)`): the EKF of the
//! discretised model, the hybrid EKF and the continuous-time EKF each integrate over each
//! sample's own interval `dt`, in sub-steps of `dt / substeps`. Checked against the dense
//! nalgebra references of `tests::continuous_reference` (the discrete EKF's: the model's
//! step and its Jacobian through the variational equation, written here) over intervals
//! jittered by a third, a dropped sample doubling one now and then, to 1e-12 in `f64`; with
//! every interval the nominal one, each filter agrees with the same filter of the model
//! whose sample time is a `const`; a model of more sub-steps than `f` unrolls takes the
//! interval in its looped `f` and the hybrid EKF's loop alike; and the intervals each
//! filter refuses.

use nalgebra::{SMatrix, SVector};
use tests::continuous_reference::{
    diagonal, relative_difference, ContinuousEkf, HybridEkf, Model, Rule, WHOLE_STEP_STIFFNESS,
};

include!("../models/jittered_pendulum.rs");

stateforge::model! {
    /// The jittered pendulum of forward Euler in three sub-steps a sample: the filters'
    /// propagation runs as a loop of sub-steps of `dt / 3`.
    pub mod jittered_euler {
        scalar f64;
        interval DT = 0.02;
        const G_L = 9.81;
        const DAMPING = 0.3;
        state theta, omega;
        input torque;
        output sway = sin(theta);
        generate ekf, hybrid_ekf, continuous_ekf(alpha = 0.5);
        dynamics continuous(euler, dt = DT, substeps = 3) {
            der(theta) = omega;
            der(omega) = -G_L * sin(theta) - DAMPING * omega + torque;
        }
    }
}

stateforge::model! {
    /// The jittered pendulum with its sample time a `const`: what the interval's filters
    /// are when every interval is the nominal one.
    pub mod fixed_pendulum {
        scalar f64;
        const DT = 0.02;
        const G_L = 9.81;
        const DAMPING = 0.3;
        state theta, omega;
        input torque;
        output sway = sin(theta);
        generate ekf, hybrid_ekf(gate = 10.83), continuous_ekf;
        dynamics continuous(rk4, dt = DT) {
            der(theta) = omega;
            der(omega) = -G_L * sin(theta) - DAMPING * omega + torque;
        }
    }
}

stateforge::model! {
    /// The jittered pendulum in more RK4 sub-steps than `f` unrolls: `f` is a loop too.
    pub mod jittered_looped {
        scalar f64;
        interval DT = 0.02;
        const G_L = 9.81;
        const DAMPING = 0.3;
        state theta, omega;
        input torque;
        output sway = sin(theta);
        generate hybrid_ekf;
        dynamics continuous(rk4, dt = DT, substeps = 101) {
            der(theta) = omega;
            der(omega) = -G_L * sin(theta) - DAMPING * omega + torque;
        }
    }
}

use jittered_pendulum::in_f64 as rk4;

/// Agreement required of generated and reference filters (relative, at the scale of the
/// vector or matrix).
const RTOL: f64 = 1e-12;

/// The nominal sample interval [s].
const NOMINAL: f64 = rk4::DT;

/// The pendulum's rates, written out.
fn rate(_t: f64, x: &SVector<f64, 2>, u: &[f64; 1]) -> SVector<f64, 2> {
    SVector::<f64, 2>::new(x[1], -rk4::G_L * x[0].sin() - rk4::DAMPING * x[1] + u[0])
}

/// Their Jacobian `df/dx`.
fn rate_jacobian(_t: f64, x: &SVector<f64, 2>, _u: &[f64; 1]) -> SMatrix<f64, 2, 2> {
    SMatrix::<f64, 2, 2>::new(0.0, 1.0, -rk4::G_L * x[0].cos(), -rk4::DAMPING)
}

fn sway(_t: f64, x: &SVector<f64, 2>) -> SVector<f64, 1> {
    SVector::<f64, 1>::new(x[0].sin())
}

fn sway_jacobian(_t: f64, x: &SVector<f64, 2>) -> SMatrix<f64, 1, 2> {
    SMatrix::<f64, 1, 2>::new(x[0].cos(), 0.0)
}

/// The pendulum of `rule` in `substeps` sub-steps over the nominal interval.
fn pendulum(rule: Rule, substeps: u32) -> Model<2, 1, 1> {
    Model {
        rate,
        jacobian: rate_jacobian,
        h: sway,
        jacobian_h: sway_jacobian,
        rule,
        dt: NOMINAL,
        substeps,
    }
}

/// The model's discrete step over `dt` (its rule in its sub-steps of `dt / substeps`) and
/// the step's Jacobian, by the same rule on the variational equation `Φ' = (df/dx) Φ`
/// (the derivative of an explicit Runge-Kutta step is that step of the variational
/// equation).
fn discrete_step(
    model: &Model<2, 1, 1>,
    dt: f64,
    x: &SVector<f64, 2>,
    u: &[f64; 1],
) -> (SVector<f64, 2>, SMatrix<f64, 2, 2>) {
    let h = dt / f64::from(model.substeps);
    let identity = SMatrix::<f64, 2, 2>::identity();
    let (f, a) = (model.rate, model.jacobian);
    let (mut x, mut phi) = (*x, identity);
    for _ in 0..model.substeps {
        let (next, d) = match model.rule {
            Rule::Euler => (x + f(0.0, &x, u) * h, identity + a(0.0, &x, u) * h),
            Rule::Rk4 => {
                let (k1, d1) = (f(0.0, &x, u), a(0.0, &x, u));
                let (x2, dx2) = (x + k1 * (0.5 * h), identity + d1 * (0.5 * h));
                let (k2, d2) = (f(0.0, &x2, u), a(0.0, &x2, u) * dx2);
                let (x3, dx3) = (x + k2 * (0.5 * h), identity + d2 * (0.5 * h));
                let (k3, d3) = (f(0.0, &x3, u), a(0.0, &x3, u) * dx3);
                let (x4, dx4) = (x + k3 * h, identity + d3 * h);
                let (k4, d4) = (f(0.0, &x4, u), a(0.0, &x4, u) * dx4);
                (
                    x + (k1 + (k2 + k3) * 2.0 + k4) * (h / 6.0),
                    identity + (d1 + (d2 + d3) * 2.0 + d4) * (h / 6.0),
                )
            }
        };
        (x, phi) = (next, d * phi);
    }
    (x, phi)
}

type Estimate = (SVector<f64, 2>, SMatrix<f64, 2, 2>);

/// The three reference filters' estimates, each over its own sample's interval.
struct References {
    model: Model<2, 1, 1>,
    ekf: Estimate,
    hybrid: Estimate,
    continuous: Estimate,
    q: SMatrix<f64, 2, 2>,
    r: SMatrix<f64, 1, 1>,
    alpha: f64,
    /// The continuous-time EKF's samples integrated whole, and split.
    whole_and_split: (usize, usize),
}

impl References {
    /// One sample of interval `dt` with the input `u` held and the measurement `y`: the
    /// discrete EKF (`F P F' + Q dt`, then the Joseph update), the hybrid EKF and the
    /// continuous-time EKF, each from its own estimate.
    fn step(&mut self, dt: f64, u: &[f64; 1], y: f64) {
        let model = Model { dt, ..self.model };
        let y = SVector::<f64, 1>::new(y);
        let (x, p) = self.ekf;
        let (x, a) = discrete_step(&model, dt, &x, u);
        let mut ekf = HybridEkf {
            model: &model,
            estimate: (x, a * p * a.transpose() + self.q * dt),
            q: self.q,
            r: self.r,
        };
        ekf.update(0.0, &y);
        self.ekf = ekf.estimate;
        let mut hybrid = HybridEkf {
            model: &model,
            estimate: self.hybrid,
            q: self.q,
            r: self.r,
        };
        hybrid.predict(0.0, u);
        hybrid.update(0.0, &y);
        self.hybrid = hybrid.estimate;
        let mut continuous = ContinuousEkf {
            model: &model,
            estimate: self.continuous,
            q: self.q,
            r: self.r,
            alpha: self.alpha,
        };
        let (x, p) = self.continuous;
        let c = sway_jacobian(0.0, &x);
        let stiffness = dt * (c * p * c.transpose())[(0, 0)] / self.r[(0, 0)];
        let whole = matches!(model.rule, Rule::Rk4) && stiffness <= WHOLE_STEP_STIFFNESS;
        if whole {
            self.whole_and_split.0 += 1;
        } else {
            self.whole_and_split.1 += 1;
        }
        continuous.step(0.0, u, &y);
        self.continuous = continuous.estimate;
    }
}

fn to_array(m: &SMatrix<f64, 2, 2>) -> [[f64; 2]; 2] {
    std::array::from_fn(|i| std::array::from_fn(|j| m[(i, j)]))
}

/// Asserts a generated estimate within [`RTOL`] of the reference's.
fn assert_agrees(what: &str, k: usize, generated: ([f64; 2], [[f64; 2]; 2]), reference: &Estimate) {
    let (x, p) = reference;
    let dx = relative_difference(&generated.0, x.as_slice(), x.amax());
    let reference_p: Vec<f64> = to_array(p).iter().flatten().copied().collect();
    let generated_p: Vec<f64> = generated.1.iter().flatten().copied().collect();
    let dp = relative_difference(&generated_p, &reference_p, p.amax());
    assert!(
        dx <= RTOL && dp <= RTOL,
        "{what} at sample {k}: x differs by {dx:e}, P by {dp:e} relative"
    );
}

/// Sample `k`'s interval: the nominal one jittered by up to a third, doubled every 17th
/// sample (one dropped).
fn interval(k: usize) -> f64 {
    let jittered = NOMINAL * (1.0 + 0.33 * (1.7 * k as f64).sin());
    if k.is_multiple_of(17) {
        2.0 * jittered
    } else {
        jittered
    }
}

/// The torque applied over sample `k`.
fn torque(t: f64) -> [f64; 1] {
    [0.8 * (1.3 * t).sin() + 0.3 * (3.1 * t).cos()]
}

/// A pendulum's truth over the intervals, and its measurements: the sway with a
/// deterministic stand-in for noise (incommensurate sines, 0.02 at most).
struct Truth {
    x: SVector<f64, 2>,
    t: f64,
}

impl Truth {
    fn advance(&mut self, dt: f64) -> ([f64; 1], f64) {
        let u = torque(self.t);
        // Fine RK4 steps: the truth is not any filter's discretisation.
        self.x = discrete_step(&pendulum(Rule::Rk4, 20), dt, &self.x, &u).0;
        self.t += dt;
        let noise = 0.012 * (7.1 * self.t).sin() + 0.008 * (17.3 * self.t + 0.4).cos();
        (u, self.x[0].sin() + noise)
    }
}

/// The three generated filters of a model, run side by side with the references over
/// `samples` jittered intervals; returns the continuous-time EKF's samples integrated
/// whole and split.
macro_rules! agree_over_jittered_intervals {
    ($module:ident, $rule:expr, $substeps:expr, $alpha:expr, $samples:expr) => {{
        use $module::{ContinuousEkf as Ct, Ekf, HybridEkf as Hybrid, Status};
        let x0 = [0.6, -0.4];
        let p0 = [[0.5, 0.05], [0.05, 1.0]];
        // Densities: per second.
        let q = [[0.004, 0.001], [0.001, 0.02]];
        let r = [[0.002]];
        let mut ekf = Ekf::new(&x0, &p0, &q, &r).unwrap();
        let mut hybrid = Hybrid::new(&x0, &p0, &q, &r).unwrap();
        let mut continuous = Ct::new(&x0, &p0, &q, &r).unwrap();
        let start = (
            SVector::from(x0),
            SMatrix::<f64, 2, 2>::from_fn(|i, j| p0[i][j]),
        );
        let mut references = References {
            model: pendulum($rule, $substeps),
            ekf: start,
            hybrid: start,
            continuous: start,
            q: SMatrix::<f64, 2, 2>::from_fn(|i, j| q[i][j]),
            r: diagonal(r[0]),
            alpha: $alpha,
            whole_and_split: (0, 0),
        };
        let mut truth = Truth {
            x: SVector::<f64, 2>::new(0.5, -0.2),
            t: 0.0,
        };
        for k in 1..=$samples {
            let dt = interval(k);
            let (u, y) = truth.advance(dt);
            assert_eq!(ekf.step(dt, &u, &[y]), Status::Ok, "EKF, sample {k}");
            assert_eq!(hybrid.step(dt, &u, &[y]), Status::Ok, "hybrid, sample {k}");
            assert_eq!(
                continuous.step(dt, &u, &[y]),
                Status::Ok,
                "continuous, sample {k}"
            );
            references.step(dt, &u, y);
            assert_agrees("EKF", k, (ekf.state(), ekf.covariance()), &references.ekf);
            let hybrid_estimate = (hybrid.state(), hybrid.covariance());
            assert_agrees("hybrid EKF", k, hybrid_estimate, &references.hybrid);
            let continuous_estimate = (continuous.state(), continuous.covariance());
            let reference = &references.continuous;
            assert_agrees("continuous-time EKF", k, continuous_estimate, reference);
        }
        references.whole_and_split
    }};
}

#[test]
fn each_filter_integrates_over_each_sample_s_own_interval_by_rk4() {
    let (whole, split) = agree_over_jittered_intervals!(rk4, Rule::Rk4, 1, 0.0, 400);
    // The uncertain start is stiff (split), what follows is not (whole equations).
    assert!(whole > 100 && split > 0, "whole {whole}, split {split}");
}

#[test]
fn each_filter_integrates_over_each_sample_s_own_interval_in_euler_substeps() {
    assert_eq!(jittered_euler::HybridEkf::SUBSTEPS, 3);
    let (whole, split) = agree_over_jittered_intervals!(jittered_euler, Rule::Euler, 3, 0.5, 400);
    assert_eq!((whole, split), (0, 400));
}

#[test]
fn at_the_nominal_interval_each_filter_is_the_fixed_sample_time_s() {
    use fixed_pendulum::{ContinuousEkf, Ekf, HybridEkf};
    let x0 = [0.6, -0.4];
    let p0 = [[0.5, 0.05], [0.05, 1.0]];
    let q = [[0.004, 0.001], [0.001, 0.02]];
    let r = [[0.002]];
    // The fixed EKF's process noise is a sample's; the interval's a density.
    let q_sample = q.map(|row| row.map(|q| q * NOMINAL));
    let mut fixed = (
        Ekf::new(&x0, &p0, &q_sample, &r).unwrap(),
        HybridEkf::new(&x0, &p0, &q, &r).unwrap(),
        ContinuousEkf::new(&x0, &p0, &q, &r).unwrap(),
    );
    let mut jittered = (
        rk4::Ekf::new(&x0, &p0, &q, &r).unwrap(),
        rk4::HybridEkf::new(&x0, &p0, &q, &r).unwrap(),
        rk4::ContinuousEkf::new(&x0, &p0, &q, &r).unwrap(),
    );
    let mut truth = Truth {
        x: SVector::<f64, 2>::new(0.5, -0.2),
        t: 0.0,
    };
    for k in 1..=300_usize {
        let (u, y) = truth.advance(NOMINAL);
        // A sensor dropout now and then: the prediction alone.
        if k.is_multiple_of(7) {
            assert_eq!(fixed.0.predict(&u), fixed_pendulum::Status::Ok);
            assert_eq!(fixed.1.predict(&u), fixed_pendulum::Status::Ok);
            assert_eq!(fixed.2.predict(&u), fixed_pendulum::Status::Ok);
            assert_eq!(jittered.0.predict(NOMINAL, &u), rk4::Status::Ok);
            assert_eq!(jittered.1.predict(NOMINAL, &u), rk4::Status::Ok);
            assert_eq!(jittered.2.predict(NOMINAL, &u), rk4::Status::Ok);
        } else {
            assert_eq!(fixed.0.step(&u, &[y]), fixed_pendulum::Status::Ok);
            assert_eq!(fixed.1.step(&u, &[y]), fixed_pendulum::Status::Ok);
            assert_eq!(fixed.2.step(&u, &[y]), fixed_pendulum::Status::Ok);
            assert_eq!(jittered.0.step(NOMINAL, &u, &[y]), rk4::Status::Ok);
            assert_eq!(jittered.1.step(NOMINAL, &u, &[y]), rk4::Status::Ok);
            assert_eq!(jittered.2.step(NOMINAL, &u, &[y]), rk4::Status::Ok);
        }
        let pairs = [
            (
                "EKF",
                (fixed.0.state(), fixed.0.covariance()),
                (jittered.0.state(), jittered.0.covariance()),
            ),
            (
                "hybrid EKF",
                (fixed.1.state(), fixed.1.covariance()),
                (jittered.1.state(), jittered.1.covariance()),
            ),
            (
                "continuous-time EKF",
                (fixed.2.state(), fixed.2.covariance()),
                (jittered.2.state(), jittered.2.covariance()),
            ),
        ];
        for (what, (x_fixed, p_fixed), (x, p)) in pairs {
            let reference = (
                SVector::from(x_fixed),
                SMatrix::<f64, 2, 2>::from_fn(|i, j| p_fixed[i][j]),
            );
            assert_agrees(what, k, (x, p), &reference);
        }
    }
}

#[test]
fn an_interval_that_is_not_positive_and_finite_is_refused_by_each_filter() {
    use rk4::Status;
    let x0 = [0.3, 1.0];
    let p0 = [[0.01, 0.0], [0.0, 1.0]];
    let q = [[0.01, 0.0], [0.0, 0.01]];
    let r = [[0.002]];
    let mut ekf = rk4::Ekf::new(&x0, &p0, &q, &r).unwrap();
    let mut hybrid = rk4::HybridEkf::new(&x0, &p0, &q, &r).unwrap();
    let mut continuous = rk4::ContinuousEkf::new(&x0, &p0, &q, &r).unwrap();
    let mut euler = jittered_euler::HybridEkf::new(&x0, &p0, &q, &r).unwrap();
    let before = (ekf, hybrid, continuous, euler);
    for dt in [0.0, -0.02, f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        assert_eq!(ekf.predict(dt, &[0.0]), Status::RejectedInput, "{dt}");
        assert_eq!(ekf.step(dt, &[0.0], &[0.1]), Status::RejectedInput, "{dt}");
        assert_eq!(hybrid.predict(dt, &[0.0]), Status::RejectedInput, "{dt}");
        assert_eq!(
            hybrid.step(dt, &[0.0], &[0.1]),
            Status::RejectedInput,
            "{dt}"
        );
        assert_eq!(
            continuous.predict(dt, &[0.0]),
            Status::RejectedInput,
            "{dt}"
        );
        assert_eq!(
            continuous.step(dt, &[0.0], &[0.1]),
            Status::RejectedInput,
            "{dt}"
        );
        let refused = jittered_euler::Status::RejectedInput;
        assert_eq!(euler.predict(dt, &[0.0]), refused, "{dt}");
        assert_eq!(euler.step(dt, &[0.0], &[0.1]), refused, "{dt}");
        assert_eq!((ekf, hybrid, continuous, euler), before, "{dt}");
    }
    // A longer interval integrates further: the angle moves on by about the rate over it
    // (less the pull of gravity, 2.9 rad/s²: 0.0377 rad over 40 ms, 0.0099 over 10).
    let (mut short, mut long) = (hybrid, hybrid);
    assert_eq!(short.predict(0.01, &[0.0]), Status::Ok);
    assert_eq!(long.predict(0.04, &[0.0]), Status::Ok);
    assert!(long.state()[0] - x0[0] > 3.0 * (short.state()[0] - x0[0]));
    // And its angle's variance grows with the rate's over a longer time.
    assert!(long.covariance()[0][0] > short.covariance()[0][0]);
}

#[test]
fn a_looped_f_and_the_hybrid_ekf_s_loop_take_the_interval() {
    let model = pendulum(Rule::Rk4, 101);
    let q = [[0.004, 0.001], [0.001, 0.02]];
    let x0 = [0.6, -0.4];
    let p0 = [[0.5, 0.05], [0.05, 1.0]];
    let mut hybrid = jittered_looped::HybridEkf::new(&x0, &p0, &q, &[[0.002]]).unwrap();
    let mut reference = (
        SVector::from(x0),
        SMatrix::<f64, 2, 2>::from_fn(|i, j| p0[i][j]),
    );
    let mut t = 0.0;
    for k in 1..=40 {
        let dt = interval(k);
        let u = torque(t);
        t += dt;
        let x = reference.0;
        let generated = jittered_looped::f(dt, &x.into(), &u);
        let expected = discrete_step(&model, dt, &x, &u).0;
        let difference = relative_difference(&generated, expected.as_slice(), expected.amax());
        assert!(
            difference <= RTOL,
            "f at sample {k}: {difference:e} relative"
        );
        assert_eq!(hybrid.predict(dt, &u), jittered_looped::Status::Ok);
        let model = Model { dt, ..model };
        let mut filter = HybridEkf {
            model: &model,
            estimate: reference,
            q: SMatrix::<f64, 2, 2>::from_fn(|i, j| q[i][j]),
            r: diagonal([0.002]),
        };
        filter.predict(0.0, &u);
        reference = filter.estimate;
        assert_agrees(
            "hybrid EKF",
            k,
            (hybrid.state(), hybrid.covariance()),
            &reference,
        );
    }
}
