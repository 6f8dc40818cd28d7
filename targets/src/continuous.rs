//! The continuous filters on the target: the helicopter's continuous-time EKF (Kulkarni and Purwar's helicopter paper)
//! and the blade's hybrid EKF with 500 Euler sub-steps (the blade paper) on the deterministic
//! sequences of `generated_demo::continuous_sequence`, printed for the host to check, and
//! their cost per call.
//!
//! Output: `continuous k <x1..x6>` every 50th sample, `hybrid k <x1..x5>` every 10th,
//! then `cost`/`stack` lines for `continuous_ekf_step` and `hybrid_ekf_step` (no nalgebra
//! baseline: printed as 0).

use crate::lines::estimate_line;
use crate::matrix::diag;
use crate::measure::{per_call, report, stack_depth, Clock};
use core::hint::black_box;
use generated_demo::continuous_sequence::{blade_tuning, helicopter_tuning, Blade, Helicopter};
use generated_demo::helicopter::{ContinuousEkf, Status};
use generated_demo::mass_spring_damper::{HybridEkf, Status as BladeStatus};

/// Samples of each run, and how many of them are measured for cost.
pub const HELICOPTER_SAMPLES: usize = 1000;
pub const BLADE_SAMPLES: usize = 300;
const MEASURED_HELICOPTER: usize = 400;
const MEASURED_BLADE: usize = 40;

fn continuous_ekf() -> ContinuousEkf {
    let r = [
        [helicopter_tuning::R[0], 0.0],
        [0.0, helicopter_tuning::R[1]],
    ];
    ContinuousEkf::new(
        &helicopter_tuning::X0,
        &diag(helicopter_tuning::P0),
        &helicopter_tuning::Q,
        &r,
    )
    .expect("the continuous EKF's tuning is finite")
}

fn hybrid_ekf() -> HybridEkf {
    HybridEkf::new(
        &blade_tuning::X0,
        &diag(blade_tuning::P0),
        &blade_tuning::Q,
        &[[blade_tuning::R]],
    )
    .expect("the hybrid EKF's tuning is finite")
}

#[inline(never)]
fn generated_continuous_ekf_step(
    filter: &mut ContinuousEkf,
    t_prev: f32,
    u: &[f32; 2],
    y: &[f32; 2],
) -> Status {
    filter.step(t_prev, u, y)
}

#[inline(never)]
fn generated_hybrid_ekf_step(filter: &mut HybridEkf, u: &[f32; 1], y: &[f32; 1]) -> BladeStatus {
    filter.step(u, y)
}

/// Runs both filters over their sequences, printing their estimates; panics if a step
/// is rejected (a panic exits non-zero).
pub fn estimates() {
    let mut filter = continuous_ekf();
    for (k, sample) in Helicopter::new().take(HELICOPTER_SAMPLES).enumerate() {
        let status =
            generated_continuous_ekf_step(&mut filter, sample.t_prev, &sample.u_prev, &sample.y);
        assert!(
            status == Status::Ok,
            "continuous EKF at {}: {:?}",
            k + 1,
            status
        );
        if (k + 1) % 50 == 0 {
            estimate_line("continuous", k + 1, &filter.state());
        }
    }
    let mut filter = hybrid_ekf();
    for (k, sample) in Blade::new().take(BLADE_SAMPLES).enumerate() {
        let status = generated_hybrid_ekf_step(&mut filter, &sample.u_prev, &sample.y);
        assert!(
            status == BladeStatus::Ok,
            "hybrid EKF at {}: {:?}",
            k + 1,
            status
        );
        if (k + 1) % 10 == 0 {
            estimate_line("hybrid", k + 1, &filter.state());
        }
    }
}

/// Measures `step` on `filter` in steady state: after the first `warm_up` samples of
/// `sequence`, over the next `N`; prints its `cost` and `stack` lines as `kernel`.
fn measure<S: Copy, F, const N: usize>(
    clock: &Clock,
    kernel: &str,
    mut sequence: impl Iterator<Item = S>,
    warm_up: usize,
    mut filter: F,
    step: impl Fn(&mut F, S),
) {
    for sample in sequence.by_ref().take(warm_up) {
        step(&mut filter, sample);
    }
    let Some(first) = sequence.next() else {
        panic!("{} sequence too short", kernel);
    };
    let mut samples = [first; N];
    for slot in samples.iter_mut().skip(1) {
        *slot = sequence.next().unwrap_or(first);
    }
    let cost = per_call(clock, samples.iter().copied(), |s| step(&mut filter, s));
    let stack = stack_depth(|| step(&mut filter, first));
    report(kernel, (cost, 0), (stack, 0));
}

/// Measures both kernels in steady state (after the first half of each sequence).
pub fn costs(clock: &Clock) {
    measure::<_, _, MEASURED_HELICOPTER>(
        clock,
        "continuous_ekf_step",
        Helicopter::new(),
        HELICOPTER_SAMPLES / 2,
        continuous_ekf(),
        |filter, s| {
            let _ = black_box(generated_continuous_ekf_step(
                filter, s.t_prev, &s.u_prev, &s.y,
            ));
        },
    );
    measure::<_, _, MEASURED_BLADE>(
        clock,
        "hybrid_ekf_step",
        Blade::new(),
        BLADE_SAMPLES / 2,
        hybrid_ekf(),
        |filter, s| {
            let _ = black_box(generated_hybrid_ekf_step(filter, &s.u_prev, &s.y));
        },
    );
}
