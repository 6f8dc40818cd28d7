//! The generated switched observers of the piecewise beam (the piecewise-linear beam report) against a dense
//! nalgebra simulation: the regime matrices read back from the generated model function
//! `f` by differences, the gains from the Riccati recursion iterated to convergence and
//! from `K2 = K1 + (A2 - A1) C'`, and the observers run side by side. Then the property
//! the linear-error-dynamics observer is designed for: its error obeys one linear system
//! whatever the switching sequence.

use generated_demo::piecewise_beam::in_f64 as beam;
use nalgebra::{DMatrix, DVector};
use tests::rng::Lcg;

const N: usize = 6;

fn f(x: &DVector<f64>, u: f64) -> DVector<f64> {
    let x: [f64; N] = core::array::from_fn(|i| x[i]);
    DVector::from_row_slice(&beam::f(&x, &[u]))
}

/// `A`, `B`, `c` of the regime containing `x0` (q_mid's sign), by differences of `f`:
/// the model is linear within a regime, so they are exact up to rounding.
fn regime_at(x0: &DVector<f64>) -> (DMatrix<f64>, DVector<f64>, DVector<f64>) {
    let scale = 1e-4;
    let base = f(x0, 0.0);
    let a = DMatrix::from_fn(N, N, |i, j| {
        let mut xp = x0.clone();
        xp[j] += scale;
        (f(&xp, 0.0)[i] - base[i]) / scale
    });
    let b = (f(x0, 1.0) - &base) / 1.0;
    let c = &base - &a * x0;
    (a, b, c)
}

struct Regimes {
    a: [DMatrix<f64>; 2],
    b: [DVector<f64>; 2],
    offset: [DVector<f64>; 2],
    c: DMatrix<f64>,
}

fn regimes() -> Regimes {
    let mut x0 = DVector::zeros(N);
    x0[1] = -1e-3;
    let (a1, b1, c1) = regime_at(&x0);
    x0[1] = 1e-3;
    let (a2, b2, c2) = regime_at(&x0);
    let c = DMatrix::from_fn(2, N, |i, j| if i == j { 1.0 } else { 0.0 });
    Regimes {
        a: [a1, a2],
        b: [b1, b2],
        offset: [c1, c2],
        c,
    }
}

/// The one-step predictor's steady-state Kalman gain by iterating the Riccati recursion.
fn kalman_gain(a: &DMatrix<f64>, c: &DMatrix<f64>) -> DMatrix<f64> {
    let q = DMatrix::from_diagonal(&DVector::from_row_slice(&[
        beam::Q_POS,
        beam::Q_POS,
        beam::Q_POS,
        beam::Q_VEL,
        beam::Q_VEL,
        beam::Q_VEL,
    ]));
    let r = DMatrix::identity(2, 2) * beam::R_LVDT;
    let mut p = q.clone();
    let mut k = DMatrix::zeros(N, 2);
    for _ in 0..20_000 {
        let s = c * &p * c.transpose() + &r;
        k = a * &p * c.transpose() * s.try_inverse().unwrap();
        p = a * &p * a.transpose() + &q - &k * c * &p * a.transpose();
        p = (&p + p.transpose()) * 0.5;
    }
    k
}

fn gains(generated: &[[[f64; 2]; N]; 2]) -> [DMatrix<f64>; 2] {
    [0, 1].map(|i| DMatrix::from_fn(N, 2, |r, c| generated[i][r][c]))
}

fn rel(a: &DMatrix<f64>, b: &DMatrix<f64>) -> f64 {
    (a - b).amax() / b.amax()
}

#[test]
fn regime_matrices_and_gains_match_an_independent_design() {
    let reg = regimes();
    for i in 0..2 {
        let generated = DMatrix::from_fn(N, N, |r, c| beam::REGIME_A[i][r][c]);
        assert!(rel(&generated, &reg.a[i]) < 1e-9, "A{}", i + 1);
    }
    let k1 = kalman_gain(&reg.a[0], &reg.c);
    let k2 = kalman_gain(&reg.a[1], &reg.c);
    let kalman = gains(&beam::SwitchedKalmanObserver::GAINS);
    assert!(rel(&kalman[0], &k1) < 1e-8, "{:e}", rel(&kalman[0], &k1));
    assert!(rel(&kalman[1], &k2) < 1e-8, "{:e}", rel(&kalman[1], &k2));
    let led = gains(&beam::LinearErrorObserver::GAINS);
    assert!(rel(&led[0], &k1) < 1e-8);
    let k2_led = &k1 + (&reg.a[1] - &reg.a[0]) * reg.c.transpose();
    assert!(rel(&led[1], &k2_led) < 1e-8);
    let common = gains(&beam::CommonGainObserver::GAINS);
    assert_eq!(common[0], common[1]);
    assert!(rel(&common[0], &k1) < 1e-8);
    // The point of the design: one error matrix for both regimes.
    let f1 = &reg.a[0] - &led[0] * &reg.c;
    let f2 = &reg.a[1] - &led[1] * &reg.c;
    assert!(rel(&f1, &f2) < 1e-12);
}

/// The beam driven by the mass unbalance at `freq` Hz (eq. 2.3), simulated with the
/// generated model step, and each generated observer against the same observer written
/// densely with nalgebra.
#[test]
fn generated_observers_match_a_dense_nalgebra_simulation() {
    let reg = regimes();
    let designs = [
        gains(&beam::LinearErrorObserver::GAINS),
        gains(&beam::SwitchedKalmanObserver::GAINS),
        gains(&beam::CommonGainObserver::GAINS),
    ];
    for freq in [20.0, 35.0] {
        let x0 = [5e-4, -1e-3, 2e-4, 0.0, 0.01, 0.0];
        let mut led = beam::LinearErrorObserver::new(&x0).unwrap();
        let mut skf = beam::SwitchedKalmanObserver::new(&x0).unwrap();
        let mut cgo = beam::CommonGainObserver::new(&x0).unwrap();
        let mut dense = [0, 1, 2].map(|_| DVector::from_row_slice(&x0));
        let mut x = DVector::zeros(N);
        let mut worst = 0.0_f64;
        let mut switches = 0;
        let mut last = false;
        for k in 0..4000 {
            let t = k as f64 * beam::TS;
            let w = 2.0 * std::f64::consts::PI * freq;
            let u = beam::C_H * w * w * (w * t).sin();
            let y = [x[0], x[1]];
            let regime = usize::from(y[1] > 0.0);
            switches += usize::from((regime == 1) != last);
            last = regime == 1;
            let mut innovations = Vec::new();
            for (d, k_gain) in dense.iter_mut().zip(&designs) {
                let innovation = DVector::from_row_slice(&y) - &reg.c * &*d;
                // A difference of the measurement and of the estimate's output: compared
                // at the larger of their scales, as the estimate is at its own.
                let scale = (&reg.c * &*d)
                    .amax()
                    .max(y[0].abs())
                    .max(y[1].abs())
                    .max(1e-6);
                innovations.push((innovation.clone(), scale));
                *d = &reg.a[regime] * &*d
                    + &reg.b[regime] * u
                    + &reg.offset[regime]
                    + &k_gain[regime] * innovation;
            }
            assert_eq!(led.step(&[u], &y), beam::Status::Ok);
            assert_eq!(skf.step(&[u], &y), beam::Status::Ok);
            assert_eq!(cgo.step(&[u], &y), beam::Status::Ok);
            let generated = [led.innovation(), skf.innovation(), cgo.innovation()];
            for (generated, (expected, scale)) in generated.iter().zip(&innovations) {
                let diff = (DVector::from_row_slice(generated) - expected).amax() / scale;
                assert!(diff < 1e-9, "{freq} Hz, step {k}: innovation {diff:e}");
            }
            for (generated, d) in [led.state(), skf.state(), cgo.state()].iter().zip(&dense) {
                let diff = (DVector::from_row_slice(generated) - d).amax() / d.amax().max(1e-6);
                worst = worst.max(diff);
                assert!(diff < 1e-9, "{freq} Hz, step {k}: {diff:e}");
            }
            x = f(&x, u);
        }
        assert!(switches > 50, "the run switches regimes ({switches})");
        println!("{freq} Hz: largest relative difference {worst:e}, {switches} switches");
        // `reset` is the observer `new` builds; a NaN start is refused.
        let fresh = beam::LinearErrorObserver::new(&x0).unwrap();
        let before = led;
        assert_eq!(led.reset(&[f64::NAN; N]), beam::Status::RejectedInput);
        assert_eq!(led, before);
        assert_eq!(led.reset(&x0), beam::Status::Ok);
        assert_eq!(led, fresh);
    }
}

/// Whatever the regime sequence (random states each step, so random switching) and
/// whatever the error (a fresh random one each step, so its size stays well above the
/// rounding of the state it is the difference of), the linear-error-dynamics observer's
/// error follows `e[k+1] = (A1 - K1 C) e[k]`; the common-gain observer's does not.
#[test]
fn linear_error_dynamics_hold_under_arbitrary_switching() {
    let reg = regimes();
    let led = gains(&beam::LinearErrorObserver::GAINS);
    let error_matrix = &reg.a[0] - &led[0] * &reg.c;
    let common = gains(&beam::CommonGainObserver::GAINS);
    let mut rng = Lcg(17);
    let mut worst = 0.0_f64;
    let mut common_departure = 0.0_f64;
    let mut regimes_seen = [0; 2];
    for _ in 0..500 {
        let x = DVector::from_fn(N, |i, _| if i < 3 { 2e-3 } else { 0.1 } * rng.uniform());
        let e = DVector::from_fn(N, |i, _| if i < 3 { 1e-3 } else { 1e-2 } * rng.uniform());
        let u = 40.0 * rng.uniform();
        regimes_seen[usize::from(x[1] > 0.0)] += 1;
        let x_next = f(&x, u);
        let y = [x[0], x[1]];
        let estimate: [f64; N] = core::array::from_fn(|i| x[i] - e[i]);
        let mut obs = beam::LinearErrorObserver::new(&estimate).unwrap();
        assert_eq!(obs.step(&[u], &y), beam::Status::Ok);
        let e_next = &x_next - DVector::from_row_slice(&obs.state());
        let predicted = &error_matrix * &e;
        let diff = (&e_next - &predicted).amax() / predicted.amax();
        worst = worst.max(diff);
        assert!(diff < 1e-9, "error left the linear system: {diff:e}");

        let estimate: [f64; N] = core::array::from_fn(|i| x[i] - e[i]);
        let mut obs = beam::CommonGainObserver::new(&estimate).unwrap();
        assert_eq!(obs.step(&[u], &y), beam::Status::Ok);
        let e_next = &x_next - DVector::from_row_slice(&obs.state());
        let predicted = (&reg.a[0] - &common[0] * &reg.c) * &e;
        common_departure = common_departure.max((&e_next - &predicted).amax() / predicted.amax());
    }
    assert!(
        regimes_seen[0] > 100 && regimes_seen[1] > 100,
        "{regimes_seen:?}"
    );
    assert!(
        common_departure > 1e-3,
        "the check can fail: {common_departure:e}"
    );
    println!(
        "linear error dynamics: largest departure {worst:e}; common gain {common_departure:e}"
    );
}

/// The `k1` option: a given gain is used for regime 1 and `K2 = K1 + A_s C^+` follows, on
/// a small model whose second output measures a combination of states (so `C^+` is not
/// `C'`).
#[test]
fn a_given_k1_is_used_and_k2_follows_through_the_pseudo_inverse() {
    let source = r#"
        stateforge::model! {
            /// Two masses; a one-sided spring on the first.
            pub mod given {
                scalar f64;
                const Q = 1e-6;
                const R = 1e-4;
                const K11 = 0.3;
                const K12 = 0.0;
                const K21 = 0.1;
                const K22 = 0.2;
                state x1, x2;
                output y1 = x1, y2 = x1 + x2;
                generate switched_observer(process_noise = [Q, Q], measurement_noise = [R, R],
                    k1 = [K11, K12, K21, K22]);
                dynamics discrete {
                    x1 = 0.9 * x1 + 0.1 * x2 - if x1 > 0.0 { 0.2 * x1 } else { 0.0 };
                    x2 = -0.1 * x1 + 0.8 * x2;
                }
            }
        }
    "#;
    let checked = stateforge_compiler::parse_macro_source(source).expect("a valid model");
    let model = &checked.model;
    let mg = stateforge_compiler::symbolic::ModelGraph::build(model);
    let regimes = stateforge_compiler::generators::switched_observer::design::regimes(model, &mg)
        .expect("piecewise linear");
    let spec = checked
        .options::<stateforge_compiler::generators::switched_observer::SwitchedObserverSpec>()
        .expect("asked for");
    let designs =
        stateforge_compiler::generators::switched_observer::design::design(&regimes, spec)
            .expect("designable");
    let to_na = |m: &stateforge_compiler::numerics::Mat| {
        DMatrix::from_fn(m.rows(), m.cols(), |i, j| m[(i, j)])
    };
    let k1 = DMatrix::from_row_slice(2, 2, &[0.3, 0.0, 0.1, 0.2]);
    let led = &designs.linear_error;
    assert_eq!(to_na(&led.k[0]), k1);
    let c = DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 1.0, 1.0]);
    let a1 = DMatrix::from_row_slice(2, 2, &[0.9, 0.1, -0.1, 0.8]);
    let a2 = DMatrix::from_row_slice(2, 2, &[0.7, 0.1, -0.1, 0.8]);
    assert!((to_na(&regimes.a[0]) - &a1).amax() < 1e-15);
    assert!((to_na(&regimes.a[1]) - &a2).amax() < 1e-15);
    let k2 = &k1 + (&a2 - &a1) * c.clone().try_inverse().unwrap();
    assert!((to_na(&led.k[1]) - &k2).amax() < 1e-14);
    let f1 = &a1 - &k1 * &c;
    let f2 = &a2 - &k2 * &c;
    assert!(
        (f1 - f2).amax() < 1e-14,
        "one error matrix for both regimes"
    );
    // The generated code compiles from the same source (checked by expanding it).
    let _ = stateforge_compiler::expand_macro_source(source).expect("expands");
}
