//! Outputs that read an input (a feedthrough: an accelerometer on a forced mass reads
//! the force). A correction that does not predict takes the input in effect at the
//! measurement, `update(u, y)`; a step evaluates `h` with `u_prev`, the input held until
//! its measurement, so a step agrees with `predict(u_prev)` then `update(u_prev, y)`. An
//! output that reads no input keeps its update without `u` (`update_position(y)`).

use tests::compare::assert_same_estimates;

stateforge::model! {
    /// A mass on a spring, forced by `u`; a position sensor and an accelerometer.
    mod forced_mass {
        scalar f64;
        const TS = 0.01;
        state x1, x2;
        input u;
        output
            position = x1,
            acceleration = -4.0 * x1 - 0.2 * x2 + u;
        generate ekf, hybrid_ekf;
        dynamics continuous(rk4, dt = TS) {
            der(x1) = x2;
            der(x2) = -4.0 * x1 - 0.2 * x2 + u;
        }
    }
}

const X0: [f64; 2] = [0.3, 0.0];
const P0: [[f64; 2]; 2] = [[0.1, 0.0], [0.0, 0.1]];
const Q: [[f64; 2]; 2] = [[1e-6, 0.0], [0.0, 1e-4]];
const R: [[f64; 2]; 2] = [[1e-4, 0.0], [0.0, 1e-2]];

/// The sample `k`'s input held since the last sample and its measurement (of a truth that
/// is not the filter's: the accelerometer reads the input with a gain of 1.1).
fn sample(k: usize) -> ([f64; 1], [f64; 2]) {
    let t = k as f64 * forced_mass::TS;
    let u = (3.0 * t).sin();
    let x1 = 0.2 * (2.0 * t).cos();
    ([u], [x1, -4.0 * x1 + 1.1 * u])
}

#[test]
fn a_step_corrects_with_the_input_held_until_its_measurement() {
    use forced_mass::{Ekf, HybridEkf, Status};
    let (mut stepped, mut split) = (
        Ekf::new(&X0, &P0, &Q, &R).unwrap(),
        Ekf::new(&X0, &P0, &Q, &R).unwrap(),
    );
    let (mut hybrid, mut hybrid_split) = (
        HybridEkf::new(&X0, &P0, &Q, &R).unwrap(),
        HybridEkf::new(&X0, &P0, &Q, &R).unwrap(),
    );
    let mut worst = 0.0_f64;
    for k in 1..=300 {
        let (u_prev, y) = sample(k);
        assert_eq!(stepped.step(&u_prev, &y), Status::Ok);
        assert_eq!(split.predict(&u_prev), Status::Ok);
        assert_eq!(split.update(&u_prev, &y), Status::Ok);
        assert_eq!(hybrid.step(&u_prev, &y), Status::Ok);
        assert_eq!(hybrid_split.predict(&u_prev), Status::Ok);
        assert_eq!(hybrid_split.update(&u_prev, &y), Status::Ok);
        let pairs = [
            (
                (stepped.state(), stepped.covariance()),
                (split.state(), split.covariance()),
            ),
            (
                (hybrid.state(), hybrid.covariance()),
                (hybrid_split.state(), hybrid_split.covariance()),
            ),
        ];
        worst = worst.max(assert_same_estimates(k, &pairs));
    }
    println!("feedthrough: step and predict/update(u_prev, y) within {worst:.1e}");
}

#[test]
fn the_update_reads_the_input_it_is_given() {
    use forced_mass::{Ekf, Status};
    let mut filter = Ekf::new(&X0, &P0, &Q, &R).unwrap();
    let y = [X0[0], -4.0 * X0[0] + 1.0];
    // With the input that explains the accelerometer, the innovation is zero.
    assert_eq!(filter.update(&[1.0], &y), Status::Ok);
    assert!(filter.innovation().iter().all(|v| v.abs() < 1e-12));
    // With another, the accelerometer's innovation is the difference in force.
    assert_eq!(filter.update(&[0.5], &y), Status::Ok);
    let [_, acceleration] = filter.innovation();
    assert!((acceleration - 0.5).abs() < 1e-3, "{acceleration}");
}

#[test]
fn a_non_finite_input_is_rejected_and_changes_nothing() {
    use forced_mass::{Ekf, HybridEkf, Status};
    let y = [0.3, -1.2];
    let mut filter = Ekf::new(&X0, &P0, &Q, &R).unwrap();
    let mut hybrid = HybridEkf::new(&X0, &P0, &Q, &R).unwrap();
    for u in [f64::NAN, f64::INFINITY] {
        assert_eq!(filter.update(&[u], &y), Status::RejectedInput);
        assert_eq!(hybrid.update(&[u], &y), Status::RejectedInput);
    }
    assert_eq!((filter.state(), filter.covariance()), (X0, P0));
    assert_eq!((hybrid.state(), hybrid.covariance()), (X0, P0));
}

#[test]
fn an_output_that_reads_no_input_is_updated_without_one() {
    use forced_mass::{Ekf, Status};
    let mut filter = Ekf::new(&X0, &P0, &Q, &R).unwrap();
    assert_eq!(filter.update_position(0.25), Status::Ok);
    assert_eq!(filter.update_acceleration(&[1.0], -0.2), Status::Ok);
    assert!(filter.state()[0] < X0[0]);
}
