//! The EKF in the field (cantilever, f64): the innovation and its normalised square against
//! the nalgebra reference, the innovation gate of `GatedEkf` (an outlier rejected, the
//! prediction kept; an open gate the ungated filter exactly), and `reset`.

use generated_demo::cantilever::in_f64::{Ekf, GatedEkf, Status};
use nalgebra::SMatrix;
use tests::cantilever_sim::{run, Sample};
use tests::reference::{self, State};
use tests::tuning::{diag, p0, Q_DIAG, R, X0_CLOSE};

/// The gate the cantilever model generates (chi-square 99.9% quantile, one output).
const GATE: f64 = 10.83;

fn mat(m: &[[f64; 5]; 5]) -> SMatrix<f64, 5, 5> {
    SMatrix::from_fn(|i, j| m[i][j])
}

fn data() -> Vec<Sample> {
    run(601, 1e-4, 5)
}

fn ekf() -> Ekf {
    Ekf::new(&X0_CLOSE, &p0(2e4), &Q_DIAG, &[[R]]).unwrap()
}

fn gated() -> GatedEkf {
    GatedEkf::new(&X0_CLOSE, &p0(2e4), &Q_DIAG, &[[R]]).unwrap()
}

#[test]
fn innovation_and_its_normalised_square_match_the_reference() {
    let mut filter = ekf();
    let mut reference = reference::Ekf::new(
        State::from(X0_CLOSE),
        mat(&p0(2e4)),
        mat(&diag(Q_DIAG)),
        SMatrix::from([[R]]),
    );
    assert_eq!(filter.innovation(), [0.0]);
    assert_eq!(filter.normalised_innovation_squared(), 0.0);
    let samples = data();
    let mut largest = 0.0_f64;
    for k in 1..samples.len() {
        let (u_prev, y) = (samples[k - 1].u, samples[k].y);
        // The reference's innovation: y - h(x) and S = C P C' + R at the prediction.
        let mut predicted = reference.clone();
        predicted.predict(u_prev);
        let innovation = y - reference::h(&predicted.x);
        let c = reference::jacobian_h_x();
        let s = (c * predicted.p * c.transpose())[0] + R;
        let nis = innovation * innovation / s;
        largest = largest.max(nis);

        assert_eq!(filter.step(&[u_prev], &[y]), Status::Ok, "step {k}");
        reference.step(u_prev, y);
        let [got] = filter.innovation();
        assert!(
            (got - innovation).abs() <= 1e-9 * innovation.abs().max(1e-9),
            "innovation at {k}: {got:e} vs {innovation:e}"
        );
        let got = filter.normalised_innovation_squared();
        assert!(
            (got - nis).abs() <= 1e-9 * nis.max(1e-12),
            "NIS at {k}: {got:e} vs {nis:e}"
        );
    }
    // The comparison must not have been of zeros (the simulated noise is a third of the
    // filter's sigma, so the NIS runs well below its mean of 1).
    assert!(largest > 0.1, "largest NIS {largest}");
}

#[test]
fn the_gate_rejects_an_outlier_and_keeps_the_prediction() {
    let samples = data();
    let mut filter = gated();
    assert_eq!(filter.innovation_gate(), GATE);
    let spike_at = 300;
    for k in 1..samples.len() {
        let (u_prev, mut y) = (samples[k - 1].u, samples[k].y);
        if k == spike_at {
            // 1 mm: thirty times the measurement's standard deviation.
            y += 1.0;
            let mut predicted = filter;
            assert_eq!(predicted.predict(&[u_prev]), Status::Ok);
            assert_eq!(filter.step(&[u_prev], &[y]), Status::OutlierRejected);
            assert_eq!(filter.state(), predicted.state(), "the prediction is kept");
            assert_eq!(filter.covariance(), predicted.covariance());
            let [innovation] = filter.innovation();
            assert!(
                innovation > 0.9,
                "the spike's innovation is recorded: {innovation}"
            );
            assert!(filter.normalised_innovation_squared() > GATE);
        } else {
            assert_eq!(filter.step(&[u_prev], &[y]), Status::Ok, "step {k}");
            assert!(filter.normalised_innovation_squared() <= GATE);
        }
    }
    // Rejected by `update` alone too, which then changes nothing.
    let before = filter;
    let y = filter.state()[0] + 1.0;
    assert_eq!(filter.update(&[y]), Status::OutlierRejected);
    assert_eq!(filter.state(), before.state());
    assert_eq!(filter.covariance(), before.covariance());
}

#[test]
fn an_open_gate_is_the_ungated_filter() {
    let samples = data();
    let mut open = gated();
    assert_eq!(open.set_innovation_gate(f64::INFINITY), Status::Ok);
    let mut plain = ekf();
    for k in 1..samples.len() {
        let (u_prev, mut y) = (samples[k - 1].u, samples[k].y);
        if k == 300 {
            y += 1.0;
        }
        assert_eq!(open.step(&[u_prev], &[y]), plain.step(&[u_prev], &[y]));
        assert_eq!(open.state(), plain.state(), "step {k}");
        assert_eq!(open.covariance(), plain.covariance(), "step {k}");
        assert_eq!(open.innovation(), plain.innovation(), "step {k}");
    }
}

#[test]
fn a_gate_must_be_positive() {
    let mut filter = gated();
    for bad in [0.0, -1.0, f64::NAN, f64::NEG_INFINITY] {
        assert_eq!(
            filter.set_innovation_gate(bad),
            Status::RejectedInput,
            "{bad}"
        );
        assert_eq!(filter.innovation_gate(), GATE);
    }
    assert_eq!(filter.set_innovation_gate(3.84), Status::Ok);
    assert_eq!(filter.innovation_gate(), 3.84);
}

#[test]
fn reset_starts_the_filter_again_after_a_fault() {
    let samples = data();
    let mut filter = ekf();
    for k in 1..200 {
        assert_eq!(
            filter.step(&[samples[k - 1].u], &[samples[k].y]),
            Status::Ok
        );
    }
    // A wild value drives the estimate to non-finite values: the filter refuses it (and
    // may refuse the steps after it), leaving its estimate as it was.
    let mut failures = 0;
    for (k, y) in [(200, 1e300), (201, samples[201].y), (202, samples[202].y)] {
        if filter.step(&[samples[k - 1].u], &[y]) != Status::Ok {
            failures += 1;
        }
    }
    assert!(failures > 0, "the wild value was not refused");
    assert_ne!(filter.state(), X0_CLOSE);

    assert_eq!(filter.reset(&X0_CLOSE, &p0(2e4)), Status::Ok);
    let fresh = ekf();
    assert_eq!(
        filter, fresh,
        "a reset filter is a new one with the same noise"
    );
    assert_eq!(filter.innovation(), [0.0]);
    assert_eq!(filter.normalised_innovation_squared(), 0.0);
    for k in 204..samples.len() {
        assert_eq!(
            filter.step(&[samples[k - 1].u], &[samples[k].y]),
            Status::Ok,
            "{k}"
        );
    }
}
