//! The compile-time designed observers on the target: the piecewise beam's
//! linear-error-dynamics observer (the piecewise-linear beam report) and the polynomial Kalman filter (the polynomial Kalman filter paper),
//! run on embedded sequences and checked against the host, then measured per call beside
//! plain nalgebra versions of the same algorithms.
//!
//! Output: `observer k <x1..x6>` and `polykf k <x0..x3>` every tenth sample, then `cost`
//! and `stack` lines for `switched_observer_step` and `polynomial_kf_step`.

use crate::lines::estimate_line;
use crate::measure::{per_call, report, stack_depth, Clock};
use crate::observers_baseline as baseline;
use core::hint::black_box;
use generated_demo::piecewise_beam::LinearErrorObserver;
use generated_demo::polynomial::PolynomialKf;

include!(concat!(env!("OUT_DIR"), "/observer_sequences.rs"));

/// The polynomial filter's prior, scaled to the state of eq. (2), `x_j = T^j/j! z^(j)`:
/// standard deviations of 1 rad, 1 rad/s, 10 rad/s^2 and 100 rad/s^3. (A prior of `I`
/// would claim 1e4 to 1e12 times that for the higher states, and its first updates then
/// cancel catastrophically in `f32`.)
pub const POLY_P0: [[f32; 4]; 4] = [
    [1.0, 0.0, 0.0, 0.0],
    [0.0, 1e-4, 0.0, 0.0],
    [0.0, 0.0, 2.5e-7, 0.0],
    [0.0, 0.0, 0.0, 2.78e-10],
];

/// Both observers over their sequences, every tenth estimate printed.
pub fn estimates() {
    let mut observer = LinearErrorObserver::new(&[0.0; 6]).expect("the start is finite");
    for (k, (u, y)) in BEAM_SEQUENCE.iter().enumerate() {
        let _ = observer.step(&[*u], y);
        if k % 10 == 9 {
            estimate_line("observer", k, &observer.state());
        }
    }
    let mut kf = PolynomialKf::new(&[0.0; 4], &POLY_P0).expect("the prior is finite");
    for (k, y) in HUB_SEQUENCE.iter().enumerate() {
        let _ = kf.step(*y);
        if k % 10 == 9 {
            estimate_line("polykf", k, &kf.state());
        }
    }
}

#[inline(never)]
fn generated_switched_observer_step(observer: &mut LinearErrorObserver, u: f32, y: &[f32; 2]) {
    let _ = observer.step(&[u], y);
}

#[inline(never)]
fn baseline_switched_observer_step(
    observer: &mut baseline::SwitchedObserver,
    u: f32,
    y: &[f32; 2],
) {
    observer.step(u, y);
}

#[inline(never)]
fn generated_polynomial_kf_step(kf: &mut PolynomialKf, y: f32) {
    let _ = kf.step(y);
}

#[inline(never)]
fn baseline_polynomial_kf_step(kf: &mut baseline::PolynomialKf, y: f32) {
    kf.step(y);
}

/// Per-call cost of one switched-observer step and one polynomial-KF step (averaged over
/// 800 samples, so over 8 re-initialisations of the polynomial filter).
pub fn costs(clock: &Clock) {
    let mut generated = LinearErrorObserver::new(&[0.0; 6]).expect("the start is finite");
    let mut plain = baseline::SwitchedObserver::new();
    for (u, y) in &BEAM_SEQUENCE[..100] {
        generated_switched_observer_step(black_box(&mut generated), *u, y);
        baseline_switched_observer_step(black_box(&mut plain), *u, y);
    }
    let costs = (
        per_call(clock, BEAM_SEQUENCE[100..900].iter().copied(), |(u, y)| {
            generated_switched_observer_step(black_box(&mut generated), u, &y);
        }),
        per_call(clock, BEAM_SEQUENCE[100..900].iter().copied(), |(u, y)| {
            baseline_switched_observer_step(black_box(&mut plain), u, &y);
        }),
    );
    let stacks = (
        stack_depth(|| {
            generated_switched_observer_step(black_box(&mut generated), 1.0, &[1e-4, 1e-4]);
        }),
        stack_depth(|| {
            baseline_switched_observer_step(black_box(&mut plain), 1.0, &[1e-4, 1e-4]);
        }),
    );
    report("switched_observer_step", costs, stacks);

    let mut generated = PolynomialKf::new(&[0.0; 4], &POLY_P0).expect("the prior is finite");
    let mut plain = baseline::PolynomialKf::new(&POLY_P0);
    for y in &HUB_SEQUENCE[..100] {
        generated_polynomial_kf_step(black_box(&mut generated), *y);
        baseline_polynomial_kf_step(black_box(&mut plain), *y);
    }
    let costs = (
        per_call(clock, HUB_SEQUENCE[100..900].iter().copied(), |y| {
            generated_polynomial_kf_step(black_box(&mut generated), y);
        }),
        per_call(clock, HUB_SEQUENCE[100..900].iter().copied(), |y| {
            baseline_polynomial_kf_step(black_box(&mut plain), y);
        }),
    );
    let stacks = (
        stack_depth(|| generated_polynomial_kf_step(black_box(&mut generated), 0.1)),
        stack_depth(|| baseline_polynomial_kf_step(black_box(&mut plain), 0.1)),
    );
    report("polynomial_kf_step", costs, stacks);
}
