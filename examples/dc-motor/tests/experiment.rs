//! The experiment's claims, checked: the EKF identifies the friction and the load torque
//! from noisy current and speed, and the LQR brakes the motor.

use dc_motor::experiment::{self, Sample, IDENTIFICATION, SAMPLES};

/// Every sample of a run with the noise of `seed`.
fn run(seed: u64) -> Vec<Sample> {
    let mut samples = Vec::new();
    experiment::run(seed, |s| samples.push(*s)).expect("every step succeeds");
    assert_eq!(samples.len(), SAMPLES);
    samples
}

#[test]
fn the_ekf_identifies_friction_and_load_torque() {
    for seed in [1, 2, 3] {
        let identified = run(seed)[IDENTIFICATION - 1];
        for (name, i) in [("friction", 2), ("load torque", 3)] {
            let (truth, estimate) = (identified.truth[i], f64::from(identified.estimate[i]));
            assert!(
                (estimate - truth).abs() < 0.05 * truth,
                "seed {seed}: {name} {estimate} against {truth}"
            );
        }
        let speed_error = (f64::from(identified.estimate[1]) - identified.truth[1]).abs();
        assert!(speed_error < 0.5, "seed {seed}: speed off by {speed_error}");
    }
}

#[test]
fn the_lqr_brakes_the_motor() {
    let samples = run(1);
    let start = samples[IDENTIFICATION - 1].truth[1].abs();
    let end = samples[SAMPLES - 1].truth[1].abs();
    assert!(start > 50.0, "the motor was running: {start} rad/s");
    assert!(end < 0.1 * start, "speed {start} -> {end} rad/s");
    let limit = f64::from(experiment::VOLTAGE_LIMIT);
    assert!(samples[IDENTIFICATION..]
        .iter()
        .all(|s| f64::from(s.voltage).abs() <= limit));
}
