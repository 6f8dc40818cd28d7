//! Constants known at run time (`known`) and the LQR tracking a reference.
//!
//! The rover written with its wheelbase as `known` (`tests/models/rover_known.rs`) against
//! the same model with it as a `const` (`tests/models/rover.rs`): the model functions, an
//! EKF run and the LQR's gain agree to rounding (the `const` model folds
//! `STEER_MAX / WHEELBASE` into one literal, the `known` one divides at run time), and a
//! new calibration changes them. The cantilever's LQR holds the beam at a set-point with
//! `u = u_ref - K (x - x_ref)` and `u_ref` from `steady_state_input`, checked against the
//! equilibrium of the model's equations solved by hand.

use generated_demo::cantilever::in_f64 as cantilever;
use generated_demo::cantilever::Status;
use tests::rng::Lcg;

include!("../models/rover.rs");
include!("../models/rover_known.rs");

use rover::in_f64 as with_const;
use rover_known::in_f64 as with_known;

const WHEELBASE: [f64; 1] = [0.3];

/// Relative difference at the vector's scale.
fn assert_agree(what: &str, got: &[f64], want: &[f64], rtol: f64) {
    let scale = want.iter().fold(1e-12_f64, |m, v| m.max(v.abs()));
    for (i, (g, w)) in got.iter().zip(want).enumerate() {
        assert!(
            (g - w).abs() <= rtol * scale,
            "{what}[{i}]: {g:e} vs {w:e} (scale {scale:e})"
        );
    }
}

#[test]
fn a_known_wheelbase_gives_the_const_models_functions() {
    let mut rng = Lcg(21);
    for _ in 0..200 {
        let x = [
            3.0 * rng.uniform(),
            3.0 * rng.uniform(),
            3.0 * rng.uniform(),
            2.0 + rng.uniform(),
            0.5,
        ];
        let u = [rng.uniform(), 0.4 * rng.uniform()];
        assert_agree(
            "f",
            &with_known::f(&x, &u, &WHEELBASE),
            &with_const::f(&x, &u),
            1e-15,
        );
        assert_eq!(with_known::h(&x, &WHEELBASE), with_const::h(&x));
        let (a_known, a_const) = (
            with_known::jacobian_f_wrt_x(&x, &u, &WHEELBASE),
            with_const::jacobian_f_wrt_x(&x, &u),
        );
        let (b_known, b_const) = (
            with_known::jacobian_f_wrt_u(&x, &u, &WHEELBASE),
            with_const::jacobian_f_wrt_u(&x, &u),
        );
        for i in 0..5 {
            assert_agree("df/dx", &a_known[i], &a_const[i], 1e-15);
            assert_agree("df/du", &b_known[i], &b_const[i], 1e-15);
        }
        // Another rover: a longer wheelbase turns less.
        let longer = with_known::f(&x, &u, &[0.6])[2] - x[2];
        let turned = with_const::f(&x, &u)[2] - x[2];
        // (Both differences cancel the heading, so their rounding is at its scale.)
        assert!((2.0 * longer - turned).abs() <= 1e-14 * x[2].abs().max(1.0));
    }
    assert_eq!(rover_known::KNOWN_LEN, 1);
    assert_eq!(rover_known::KNOWN_NAMES, ["wheelbase"]);
    assert_eq!(rover_known::index::WHEELBASE, 0);
}

fn identity<const N: usize>(scale: f64) -> [[f64; N]; N] {
    let mut m = [[0.0; N]; N];
    for (i, row) in m.iter_mut().enumerate() {
        row[i] = scale;
    }
    m
}

#[test]
fn an_ekf_with_a_known_wheelbase_runs_as_the_const_models() {
    let x0 = [1.0, 1.0, 0.2, 1.0, 0.4];
    let (p0, q, r) = (identity::<5>(0.1), identity::<5>(1e-4), identity::<2>(1e-3));
    let mut known = with_known::Ekf::new(&x0, &p0, &q, &r, &WHEELBASE).unwrap();
    let mut constant = with_const::Ekf::new(&x0, &p0, &q, &r).unwrap();
    let mut truth = [1.2, 0.9, 0.1, 1.5, 0.5];
    let mut rng = Lcg(22);
    for _ in 0..300 {
        let u = [0.5 + 0.5 * rng.uniform(), 0.6 * rng.uniform()];
        truth = with_const::f(&truth, &u);
        let y = with_const::h(&truth);
        let y = [y[0] + 0.01 * rng.uniform(), y[1] + 0.01 * rng.uniform()];
        assert_eq!(known.step(&u, &y), rover_known::Status::Ok);
        assert_eq!(constant.step(&u, &y), rover::Status::Ok);
        assert_agree("x", &known.state(), &constant.state(), 1e-12);
        let flat = |p: [[f64; 5]; 5]| p.concat();
        assert_agree(
            "P",
            &flat(known.covariance()),
            &flat(constant.covariance()),
            1e-12,
        );
    }
    assert_eq!(known.known(), WHEELBASE);
    assert_eq!(
        known.set_known(&[f64::NAN]),
        rover_known::Status::RejectedInput
    );
    assert_eq!(known.known(), WHEELBASE);
    assert_eq!(known.set_known(&[0.6]), rover_known::Status::Ok);
    assert_eq!(known.known(), [0.6]);
}

#[test]
fn an_lqr_with_a_known_wheelbase_solves_the_const_models_gain() {
    let (q, r) = (identity::<2>(1.0), identity::<2>(0.1));
    let mut known = with_known::Lqr::new(&q, &r, None, &WHEELBASE).unwrap();
    let mut constant = with_const::Lqr::new(&q, &r, None).unwrap();
    let x = [1.0, 1.0, 0.2, 1.5, 0.4];
    let u = [0.3, 0.2];
    assert_eq!(known.solve(&x, &u), rover_known::Status::Ok);
    assert_eq!(constant.solve(&x, &u), rover::Status::Ok);
    for (k, c) in known.gain().iter().zip(constant.gain()) {
        assert_agree("K", k, &c, 1e-12);
    }
    // The solve reads the calibration: a longer wheelbase turns less per radian of
    // steering and needs a larger steering gain on the heading (3.05 against 2.96).
    assert_eq!(known.set_known(&[0.6]), rover_known::Status::Ok);
    assert_eq!(known.solve(&x, &u), rover_known::Status::Ok);
    let (longer, shorter) = (known.gain()[1][0], constant.gain()[1][0]);
    assert!(
        longer > 1.02 * shorter && shorter > 0.0,
        "{longer} vs {shorter}"
    );
    assert_eq!(known.set_known(&WHEELBASE), rover_known::Status::Ok);
    assert_eq!(known.solve(&x, &u), rover_known::Status::Ok);
    assert_agree("K again", &known.gain()[1], &constant.gain()[1], 1e-12);
}

/// The cantilever's parameters, Euler-equivalent to wn = 20 rad/s, zeta = 0.026 and an
/// input gain of 0.5 (as the experiment's).
fn cantilever_parameters() -> [f64; 3] {
    tests::reference::euler_equivalent(20.0, 0.026, 0.5)
}

#[test]
fn the_steady_state_input_is_the_models_equilibrium() {
    let [x3, x4, x5] = cantilever_parameters();
    let lqr = cantilever::Lqr::new(&identity::<2>(1.0), &[[1e-3]], None).unwrap();
    for set_point in [-0.3, 0.0, 0.02, 1.5] {
        let x_ref = [set_point, 0.0, x3, x4, x5];
        // x2 = 0 at rest; then x2[k+1] = 0 = TS x1 x3 + TS x5 u: u = -x1 x3 / x5.
        let by_hand = -set_point * x3 / x5;
        for start in [0.0, 37.0] {
            let u_ref = lqr.steady_state_input(&x_ref, &[start]).expect("reachable");
            assert!(
                (u_ref[0] - by_hand).abs() <= 1e-12 * by_hand.abs().max(1.0),
                "{set_point}: {} vs {by_hand}",
                u_ref[0]
            );
            let held = cantilever::f(&x_ref, &u_ref);
            assert_agree("f(x_ref, u_ref)", &held, &x_ref, 1e-13);
        }
    }
    // An input gain of zero cannot hold anything.
    assert_eq!(
        lqr.steady_state_input(&[0.1, 0.0, x3, x4, 0.0], &[0.0]),
        Err(Status::NonFinite)
    );
    assert_eq!(
        lqr.steady_state_input(&[f64::NAN, 0.0, x3, x4, x5], &[0.0]),
        Err(Status::RejectedInput)
    );
}

#[test]
fn the_lqr_tracks_a_set_point() {
    let [x3, x4, x5] = cantilever_parameters();
    let mut lqr = cantilever::Lqr::new(&identity::<2>(1.0), &[[1e-3]], None).unwrap();
    let mut x = [0.0, 0.0, x3, x4, x5];
    assert_eq!(lqr.solve(&x, &[0.0]), Status::Ok);
    let x_ref = [0.25, 0.0, x3, x4, x5];
    let u_ref = lqr.steady_state_input(&x_ref, &[0.0]).expect("reachable");
    // At the set-point the control is the feed-forward alone.
    assert_eq!(lqr.track(&x_ref, &x_ref, &u_ref), u_ref);
    // With a zero reference, tracking is regulation.
    assert_eq!(lqr.track(&x, &[0.0; 5], &[0.0]), lqr.control(&x));
    for _ in 0..2000 {
        let u = lqr.track(&x, &x_ref, &u_ref);
        x = cantilever::f(&x, &u);
    }
    assert!(
        (x[0] - 0.25).abs() < 1e-9 && x[1].abs() < 1e-8,
        "ended at {x:?}"
    );
    // Without the feed-forward the regulator settles elsewhere: the check can fail.
    let mut y = [0.0, 0.0, x3, x4, x5];
    for _ in 0..2000 {
        let u = lqr.track(&y, &x_ref, &[0.0]);
        y = cantilever::f(&y, &u);
    }
    assert!((y[0] - 0.25).abs() > 1e-3, "ended at {y:?}");
}
