//! `step` is `predict` then `update` in one pass: on every input both return the same
//! status, and their results agree to rounding. Checked on a diverging trace, the EKF's
//! from the double Kalman filter paper's wrong initial guess, where the prediction alone
//! leaves the divergence bound before a correction would bring it back (the EKF in `f32`
//! and `f64`, and the hybrid EKF of the same Euler model).

use generated_demo::cantilever;
use tests::cantilever_sim::{run, Sample};
use tests::tuning::{p0, Q_DIAG, R, X0_WRONG};

stateforge::model! {
    /// The cantilever's Euler model (as `cantilever`) written as continuous dynamics with
    /// one Euler sub-step per sample: the hybrid EKF then predicts as the discrete EKF does.
    mod cantilever_hybrid {
        scalar f64;
        const TS = 0.015;
        state x1, x2;
        param x3, x4, x5;
        input u;
        output y = x1;
        generate hybrid_ekf(process_noise = diagonal);
        dynamics continuous(euler, dt = TS) {
            der(x1) = x2;
            der(x2) = x3 * x1 + x4 * x2 + x5 * u;
        }
    }
}

/// The trace: the paper's plant, sensor noise of 1e-4 mm, 20 s.
fn trace() -> Vec<Sample> {
    run(1334, 1e-4, 3)
}

/// The largest difference between two results, relative to the larger entry of each
/// (and to 1, so that a zero entry compares absolutely).
fn difference(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(a, b)| (a - b).abs() / a.abs().max(b.abs()).max(1.0))
        .fold(0.0, f64::max)
}

/// What a filter's comparison found: the samples whose statuses differ (with both
/// statuses), the largest difference of the results where both were `Ok`, and the
/// samples that were not `Ok`.
#[derive(Default)]
struct Agreement {
    disagreements: Vec<(usize, String, String)>,
    largest_difference: f64,
    refused: Vec<(usize, String)>,
}

/// Runs a filter over the trace: at each sample, from the same filter, `step` on one copy
/// and `predict` then (if it is `Ok`) `update` on another; compares their statuses and
/// results, and goes on from the step's filter.
macro_rules! compare {
    ($filter:expr, $flatten:expr) => {{
        let mut filter = $filter;
        let mut found = Agreement::default();
        let samples = trace();
        for k in 1..samples.len() {
            let (u, y) = (samples[k - 1].u as _, samples[k].y as _);
            let mut split = filter;
            let stepped = filter.step(&[u], &[y]);
            let predicted = split.predict(&[u]);
            let split_status = if predicted == Status::Ok {
                split.update(&[y])
            } else {
                predicted
            };
            if stepped != split_status {
                found
                    .disagreements
                    .push((k, format!("{stepped:?}"), format!("{split_status:?}")));
            } else if stepped == Status::Ok {
                let d = difference(&$flatten(&filter), &$flatten(&split));
                found.largest_difference = found.largest_difference.max(d);
            }
            if stepped != Status::Ok {
                found.refused.push((k, format!("{stepped:?}")));
            }
        }
        found
    }};
}

/// A filter's estimate and covariance, in `f64`.
macro_rules! flatten {
    ($filter:ty) => {
        |f: &$filter| -> Vec<f64> {
            let (x, p) = (f.state(), f.covariance());
            x.iter()
                .chain(p.iter().flatten())
                .map(|&v| f64::from(v))
                .collect()
        }
    };
}

/// The statuses agree on every sample, the trace diverges (a prediction is refused), and
/// the results agree to rounding.
fn check(name: &str, found: &Agreement, rounding: f64) {
    eprintln!(
        "{name}: {} refused, first {:?}; disagreements {:?}; largest difference {:e}",
        found.refused.len(),
        found.refused.first(),
        &found.disagreements[..found.disagreements.len().min(5)],
        found.largest_difference
    );
    assert!(
        found.disagreements.is_empty(),
        "{name}: step and predict + update disagree at {} samples, first {:?}",
        found.disagreements.len(),
        found.disagreements.first()
    );
    assert!(
        found.refused.iter().any(|(_, s)| s == "Diverged"),
        "{name}: the trace must diverge"
    );
    assert!(
        found.largest_difference < rounding,
        "{name}: {:e}",
        found.largest_difference
    );
}

#[test]
fn the_ekfs_step_is_its_predict_then_update_on_a_diverging_trace() {
    {
        use cantilever::in_f64::{Ekf, Status};
        let ekf = Ekf::new(&X0_WRONG, &p0(2e6), &Q_DIAG, &[[R]]).unwrap();
        let found = compare!(ekf, flatten!(Ekf));
        check("EKF f64", &found, 1e-9);
    }
    {
        use cantilever::{Ekf, Status};
        let to_f32 = |v: [f64; 5]| v.map(|v| v as f32);
        let p0 = p0(2e6).map(to_f32);
        let ekf = Ekf::new(&to_f32(X0_WRONG), &p0, &to_f32(Q_DIAG), &[[R as f32]]).unwrap();
        let found = compare!(ekf, flatten!(Ekf));
        check("EKF f32", &found, 1e-3);
    }
}

#[test]
fn the_hybrid_ekfs_step_is_its_predict_then_update_on_a_diverging_trace() {
    use cantilever_hybrid::{HybridEkf, Status, TS};
    // A density: the discrete process noise over the sample time.
    let q = Q_DIAG.map(|q| q / TS);
    let hybrid = HybridEkf::new(&X0_WRONG, &p0(2e6), &q, &[[R]]).unwrap();
    let found = compare!(hybrid, flatten!(HybridEkf));
    check("hybrid EKF", &found, 1e-9);
}
