//! How the generated filters behave where it matters on a bench: from the paper's wrong
//! initial guess, on windows that carry no information, and on NaN input.

use generated_demo::cantilever::in_f64::{Dkf, Ekf, Lqr, Status, WindowStatus};
use tests::cantilever_sim::run;
use tests::reference::poles_readout;
use tests::tuning::{p0, Q_DIAG, R, X0_CLOSE, X0_WRONG};

const TRUE_WN: f64 = 20.0;

/// wn read from the Euler model's poles (generated-demo's notes, "Simulating the cantilever").
fn wn(x: &[f64; 5]) -> f64 {
    poles_readout(x[2], x[3]).0
}

/// A non-finite estimate, or one beyond any physical meaning (|entry| > 1e7: mm, mm/s,
/// 1/s^2, 1/s, mm/(s^2 V)).
fn diverged(x: &[f64; 5]) -> bool {
    x.iter().any(|v| v.is_nan() || v.abs() > 1e7)
}

#[test]
fn from_the_wrong_guess_the_dkf_converges_and_the_ekf_does_not() {
    let mut ekf = Ekf::new(&X0_WRONG, &p0(2e6), &Q_DIAG, &[[R]]).unwrap();
    let mut dkf = Dkf::new(&X0_WRONG, &p0(2e6), &Q_DIAG, &p0(2e6), &Q_DIAG, &[[R]]).unwrap();
    let samples = run(1001, 1e-4, 3);
    let ten_seconds = (10.0 / 0.015) as usize;
    let mut ekf_diverged_at = None;
    for k in 1..samples.len() {
        let (u_prev, y) = (samples[k - 1].u, samples[k].y);
        let ekf_status = ekf.step(&[u_prev], &[y]);
        if ekf_diverged_at.is_none() && (ekf_status != Status::Ok || diverged(&ekf.state())) {
            ekf_diverged_at = Some(k as f64 * 0.015);
        }
        assert!(dkf.step(&[u_prev], &[y]).is_ok(), "DKF step {k}");
        if k == ten_seconds {
            let dkf_wn = wn(&dkf.state());
            assert!(
                (dkf_wn / TRUE_WN - 1.0).abs() < 0.02,
                "DKF wn at 10 s: {dkf_wn} (truth {TRUE_WN})"
            );
            let ekf_wn = wn(&ekf.state());
            // No oscillatory mode at all (NaN) is off too.
            let ekf_off = ekf_wn.is_nan() || (ekf_wn / TRUE_WN - 1.0).abs() > 0.5;
            match ekf_diverged_at {
                Some(t) => println!("EKF from the wrong guess diverged at t = {t:.2} s"),
                None => println!(
                    "EKF from the wrong guess at 10 s: wn from poles {ekf_wn:.2} (NaN: no \
                     oscillatory mode), estimate {:?}",
                    ekf.state()
                ),
            }
            assert!(
                ekf_diverged_at.is_some() || ekf_off,
                "EKF neither diverged nor is off by more than 50%: wn {ekf_wn}"
            );
        }
    }
}

#[test]
fn windows_without_excitation_produce_no_nan() {
    // Case 1: the beam at rest, no input: every window is degenerate.
    let mut dkf = Dkf::new(&X0_CLOSE, &p0(2e4), &Q_DIAG, &p0(2e4), &Q_DIAG, &[[R]]).unwrap();
    for k in 0..50 {
        let status = dkf.step(&[0.0], &[0.0]);
        assert!(status.is_ok(), "step {k}: {status:?}");
        if k >= 5 {
            assert_eq!(status.window, WindowStatus::Degenerate, "step {k}");
        }
        assert!(dkf
            .state()
            .iter()
            .chain(&dkf.akf_state())
            .all(|v| v.is_finite()));
    }
    assert_eq!(dkf.window_parameters(), [-400.0, -1.0, 0.01]);
    // Case 1 again: a constant input holding the beam still at its deflection.
    let mut dkf = Dkf::new(&X0_CLOSE, &p0(2e4), &Q_DIAG, &p0(2e4), &Q_DIAG, &[[R]]).unwrap();
    for _ in 0..50 {
        let status = dkf.step(&[10.0], &[0.0125]);
        assert_ne!(status.window, WindowStatus::Solved);
        assert!(dkf.state().iter().all(|v| v.is_finite()));
    }
}

#[test]
fn an_input_free_window_freezes_the_input_gain() {
    let mut dkf = Dkf::new(&X0_CLOSE, &p0(2e4), &Q_DIAG, &p0(2e4), &Q_DIAG, &[[R]]).unwrap();
    // Excite, then let the beam ring down with no input (Case 2).
    let excited = run(200, 0.0, 1);
    for k in 1..excited.len() {
        let status = dkf.step(&[excited[k - 1].u], &[excited[k].y]);
        assert!(status.is_ok(), "{status:?}");
    }
    let mut solved_gain = dkf.window_parameters()[2];
    let mut x = excited[excited.len() - 1].truth;
    let mut input_free = 0;
    for _ in 0..60 {
        x = tests::reference::f(&x, 0.0);
        let status = dkf.step(&[0.0], &[x[0]]);
        assert!(status.is_ok(), "{status:?}");
        if status.window == WindowStatus::Solved {
            // Windows still holding the last inputs solve the gain as usual.
            solved_gain = dkf.window_parameters()[2];
        }
        if status.window == WindowStatus::InputFree {
            input_free += 1;
            let [x3, x4, x5] = dkf.window_parameters();
            assert_eq!(x5, solved_gain, "the gain is frozen");
            assert!((x3 / x[2] - 1.0).abs() < 1e-6, "x3 {x3} vs {}", x[2]);
            assert!((x4 / x[3] - 1.0).abs() < 1e-6, "x4 {x4} vs {}", x[3]);
        }
        assert!(dkf.state().iter().all(|v| v.is_finite()));
    }
    assert!(input_free > 50, "{input_free} input-free windows");
}

/// The `f32` EKFs, with and without a gate: every non-finite argument, to every method, is
/// `RejectedInput`, the filter unchanged.
#[test]
fn non_finite_arguments_leave_the_f32_ekfs_unchanged() {
    use generated_demo::cantilever::{Ekf, GatedEkf, Status};
    let samples = run(100, 1e-4, 5);
    let narrow = |v: &[f64]| -> Vec<f32> { v.iter().map(|&e| e as f32).collect() };
    let x0: [f32; 5] = narrow(&X0_CLOSE).try_into().unwrap();
    let q: [f32; 5] = narrow(&Q_DIAG).try_into().unwrap();
    let p0: [[f32; 5]; 5] = p0(2e4).map(|row| narrow(&row).try_into().unwrap());
    let r = [[R as f32]];
    let mut ekf = Ekf::new(&x0, &p0, &q, &r).unwrap();
    let mut gated = GatedEkf::new(&x0, &p0, &q, &r).unwrap();
    for k in 1..samples.len() {
        let (u, y) = ([samples[k - 1].u as f32], [samples[k].y as f32]);
        assert_eq!(ekf.step(&u, &y), Status::Ok);
        assert_eq!(gated.step(&u, &y), Status::Ok);
    }
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        let (ekf_before, gated_before) = (ekf, gated);
        assert_eq!(ekf.step(&[bad], &[0.1]), Status::RejectedInput);
        assert_eq!(ekf.step(&[1.0], &[bad]), Status::RejectedInput);
        assert_eq!(ekf.predict(&[bad]), Status::RejectedInput);
        assert_eq!(ekf.update(&[bad]), Status::RejectedInput);
        assert_eq!(ekf, ekf_before);
        assert_eq!(gated.step(&[bad], &[0.1]), Status::RejectedInput);
        assert_eq!(gated.step(&[1.0], &[bad]), Status::RejectedInput);
        assert_eq!(gated.update(&[bad]), Status::RejectedInput);
        assert_eq!(gated, gated_before);
    }
}

#[test]
fn nan_input_leaves_every_filter_unchanged() {
    let samples = run(100, 1e-4, 5);
    let mut ekf = Ekf::new(&X0_CLOSE, &p0(2e4), &Q_DIAG, &[[R]]).unwrap();
    let mut dkf = Dkf::new(&X0_CLOSE, &p0(2e4), &Q_DIAG, &p0(2e4), &Q_DIAG, &[[R]]).unwrap();
    for k in 1..samples.len() {
        assert_eq!(ekf.step(&[samples[k - 1].u], &[samples[k].y]), Status::Ok);
        let status = dkf.step(&[samples[k - 1].u], &[samples[k].y]);
        assert!(status.is_ok(), "{status:?}");
    }
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        let (ekf_before, dkf_before) = (ekf, dkf);
        assert_eq!(ekf.step(&[bad], &[0.1]), Status::RejectedInput);
        assert_eq!(ekf.step(&[1.0], &[bad]), Status::RejectedInput);
        assert_eq!(ekf.predict(&[bad]), Status::RejectedInput);
        assert_eq!(ekf.update(&[bad]), Status::RejectedInput);
        assert_eq!(ekf, ekf_before);
        let status = dkf.step(&[1.0], &[bad]);
        assert_eq!(
            (status.akf, status.lkf),
            (Status::RejectedInput, Status::RejectedInput)
        );
        assert_eq!(dkf.state(), dkf_before.state());
        assert_eq!(dkf.akf_state(), dkf_before.akf_state());
        assert_eq!(dkf.covariance(), dkf_before.covariance());
        assert_eq!(dkf.akf_covariance(), dkf_before.akf_covariance());
    }
    // After a rejected sample the window refills before it is solved again.
    let status = dkf.step(&[samples[0].u], &[samples[1].y]);
    assert_eq!(status.window, WindowStatus::Filling);

    let mut lqr = Lqr::new(&[[1.0, 0.0], [0.0, 1.0]], &[[0.001]], Some(&[100.0])).unwrap();
    assert_eq!(lqr.solve(&ekf.state(), &[0.0]), Status::Ok);
    let gain = lqr.gain();
    let mut estimate = ekf.state();
    estimate[2] = f64::NAN;
    assert_eq!(lqr.solve(&estimate, &[0.0]), Status::RejectedInput);
    assert_eq!(lqr.gain(), gain);
}
