//! The generated MPC with limits besides the inputs' bounds (input changes, states and an
//! output, hard and soft): its plans against Clarabel's solution of the QP the limits
//! define, built here from the explicit prediction matrices, on random states and limits
//! that make many of them active; and its setters' checks.

use nalgebra::{DMatrix, DVector};
use planar::Status;
use tests::predictive_reference::{self as reference, LimitRow};
use tests::rng::Lcg;

// The test model `planar_limits`: a point mass in the plane with every kind of limit (its
// `f64` code tested here).
include!("../models/planar_limits.rs");
use planar_limits::in_f64 as planar;

const NS: usize = 4;
const NU: usize = 2;
const HORIZON: usize = 6;
const REACH: [f64; NS] = [1.0, 0.5, 0.0, 0.0];

/// The limits: per quantity (ax, ay changes; vx, vy; reach) its minimum and maximum,
/// and the penalties of the soft ones (vy, reach).
struct Limits {
    rate: ([f64; 2], [f64; 2]),
    state: ([f64; 2], [f64; 2]),
    output: ([f64; 1], [f64; 1]),
    penalties: [f64; 2],
    inputs: ([f64; NU], [f64; NU]),
}

fn weights() -> ([[f64; NS]; NS], [[f64; NU]; NU]) {
    let q = [
        [1.0, 0.0, 0.0, 0.0],
        [0.0, 1.0, 0.0, 0.0],
        [0.0, 0.0, 0.1, 0.0],
        [0.0, 0.0, 0.0, 0.1],
    ];
    (q, [[0.01, 0.0], [0.0, 0.01]])
}

fn matrix<const R: usize, const C: usize>(m: &[[f64; C]; R]) -> DMatrix<f64> {
    DMatrix::from_fn(R, C, |i, j| m[i][j])
}

/// The limit rows at state `x` with the input `applied` now, in the generator's order
/// (per step: the changes of ax and ay, vx, vy, reach), from the explicit prediction
/// `x_k = A^k x + sum_(m<k) A^(k-1-m) B u_m`.
fn limit_rows(
    (a, b): (&DMatrix<f64>, &DMatrix<f64>),
    x: &[f64; NS],
    applied: &[f64; NU],
    limits: &Limits,
) -> Vec<LimitRow> {
    let moves = HORIZON * NU;
    let x0 = DVector::from_column_slice(x);
    let mut rows = Vec::new();
    for k in 1..=HORIZON {
        for q in 0..NU {
            let mut coefficients = vec![0.0; moves];
            coefficients[(k - 1) * NU + q] = 1.0;
            let offset = if k == 1 {
                applied[q]
            } else {
                coefficients[(k - 2) * NU + q] = -1.0;
                0.0
            };
            rows.push(LimitRow {
                coefficients,
                lower: limits.rate.0[q] + offset,
                upper: limits.rate.1[q] + offset,
                penalty: None,
            });
        }
        let free = a.pow(k as u32) * &x0;
        let prediction = |weights: &[f64; NS]| -> (Vec<f64>, f64) {
            let mut coefficients = vec![0.0; moves];
            for m in 0..k {
                let response = a.pow((k - 1 - m) as u32) * b;
                for q in 0..NU {
                    coefficients[m * NU + q] =
                        (0..NS).map(|j| weights[j] * response[(j, q)]).sum::<f64>();
                }
            }
            (coefficients, (0..NS).map(|j| weights[j] * free[j]).sum())
        };
        for (i, j) in [2, 3].into_iter().enumerate() {
            let mut unit = [0.0; NS];
            unit[j] = 1.0;
            let (coefficients, offset) = prediction(&unit);
            rows.push(LimitRow {
                coefficients,
                lower: limits.state.0[i] - offset,
                upper: limits.state.1[i] - offset,
                // vy is soft.
                penalty: (i == 1).then_some(limits.penalties[0]),
            });
        }
        let (coefficients, offset) = prediction(&REACH);
        rows.push(LimitRow {
            coefficients,
            lower: limits.output.0[0] - offset,
            upper: limits.output.1[0] - offset,
            penalty: Some(limits.penalties[1]),
        });
    }
    rows
}

/// An MPC with `limits`, its terminal weight converged at `x` with `applied` the input
/// applied now.
fn converged(limits: &Limits, x: &[f64; NS], applied: &[f64; NU]) -> planar::Mpc {
    let (q, r) = weights();
    let mut mpc = planar::Mpc::new(&q, &r, &limits.inputs.0, &limits.inputs.1).expect("valid");
    assert_eq!(
        mpc.set_rate_limits(&limits.rate.0, &limits.rate.1),
        Status::Ok
    );
    assert_eq!(
        mpc.set_state_limits(&limits.state.0, &limits.state.1),
        Status::Ok
    );
    assert_eq!(
        mpc.set_output_limits(&limits.output.0, &limits.output.1),
        Status::Ok
    );
    assert_eq!(mpc.set_limit_penalties(&limits.penalties), Status::Ok);
    for _ in 0..500 {
        let status = mpc.solve(x, applied);
        assert_eq!(status.status, Status::Ok);
        if status.terminal_weight_converged && status.optimal {
            return mpc;
        }
    }
    panic!("the terminal weight did not converge in 500 solves");
}

/// The plan's largest difference from Clarabel's, relative to the input range, and how
/// many limit rows Clarabel's plan holds or violates.
fn compare(mpc: &planar::Mpc, limits: &Limits, x: &[f64; NS], applied: &[f64; NU]) -> (f64, usize) {
    let model = planar::Mpc::prediction_model(&[0.0; NS], &[0.0; NU]).expect("finite");
    let (a, b) = (matrix(&model.a), matrix(&model.b));
    let (q, r) = weights();
    let p = matrix(&mpc.terminal_weight());
    let x0 = DVector::from_column_slice(x);
    let (h, c) = reference::condensed((&a, &b), (&matrix(&q), &matrix(&r), &p), &x0, HORIZON);
    let low: Vec<f64> = (0..HORIZON * NU).map(|k| limits.inputs.0[k % NU]).collect();
    let high: Vec<f64> = (0..HORIZON * NU).map(|k| limits.inputs.1[k % NU]).collect();
    let rows = limit_rows((&a, &b), x, applied, limits);
    let expected = reference::limited_qp(&h, &c, (&low, &high), &rows);
    let plan: Vec<f64> = mpc.plan().iter().flatten().copied().collect();
    let worst = plan
        .iter()
        .zip(expected.iter())
        .enumerate()
        .map(|(k, (u, v))| (u - v).abs() / (high[k] - low[k]))
        .fold(0.0, f64::max);
    let active = rows
        .iter()
        .filter(|row| {
            let value: f64 = row
                .coefficients
                .iter()
                .zip(expected.iter())
                .map(|(a, v)| a * v)
                .sum();
            value <= row.lower + 1e-7 || value >= row.upper - 1e-7
        })
        .count();
    (worst, active)
}

#[test]
fn plans_with_every_kind_of_limit_agree_with_clarabel() {
    let mut rng = Lcg(71);
    let (mut worst, mut active) = (0.0_f64, 0);
    for case in 0..30 {
        let x: [f64; NS] = [
            2.0 * rng.uniform(),
            2.0 * rng.uniform(),
            0.4 * rng.uniform(),
            0.4 * rng.uniform(),
        ];
        let applied = [0.3 * rng.uniform(), 0.3 * rng.uniform()];
        let speed = 0.5 + 0.1 * rng.uniform().abs();
        let limits = Limits {
            rate: ([-0.6, -0.8], [0.6, 0.8]),
            state: ([-speed, -speed], [speed, speed]),
            output: ([-1.0 - 0.3 * rng.uniform().abs()], [1.2]),
            penalties: [
                5.0 + 20.0 * rng.uniform().abs(),
                5.0 + 20.0 * rng.uniform().abs(),
            ],
            inputs: ([-2.0, -1.5], [2.0, 1.5]),
        };
        let mpc = converged(&limits, &x, &applied);
        let (error, held) = compare(&mpc, &limits, &x, &applied);
        assert!(error < 1e-6, "case {case}: {error:e} of the input range");
        worst = worst.max(error);
        active += held;
    }
    println!("largest difference from Clarabel: {worst:.2e}; {active} rows active");
    assert!(
        active >= 60,
        "only {active} limit rows active over the cases"
    );
}

#[test]
fn without_limits_set_the_plan_is_the_box_constrained_one() {
    let (q, r) = weights();
    let (low, high) = ([-0.5, -0.5], [0.5, 0.5]);
    let mut mpc = planar::Mpc::new(&q, &r, &low, &high).expect("valid");
    let x = [1.5, -1.0, 0.3, 0.0];
    for _ in 0..500 {
        if mpc.solve(&x, &[0.0; NU]).terminal_weight_converged {
            break;
        }
    }
    let _ = mpc.solve(&x, &[0.0; NU]);
    let model = planar::Mpc::prediction_model(&[0.0; NS], &[0.0; NU]).expect("finite");
    let (a, b) = (matrix(&model.a), matrix(&model.b));
    let p = matrix(&mpc.terminal_weight());
    let x0 = DVector::from_column_slice(&x);
    let (h, c) = reference::condensed((&a, &b), (&matrix(&q), &matrix(&r), &p), &x0, HORIZON);
    let low_moves: Vec<f64> = (0..HORIZON * NU).map(|k| low[k % NU]).collect();
    let high_moves: Vec<f64> = (0..HORIZON * NU).map(|k| high[k % NU]).collect();
    let expected = reference::box_qp(&h, &c, &low_moves, &high_moves);
    for (u, v) in mpc.plan().iter().flatten().zip(expected.iter()) {
        assert!((u - v).abs() < 1e-9, "{u} {v}");
    }
}

#[test]
fn hard_limits_that_cannot_be_met_give_a_plan_that_is_not_optimal() {
    let (q, r) = weights();
    let mut mpc = planar::Mpc::new(&q, &r, &[-1.0; NU], &[1.0; NU]).expect("valid");
    // vx at 2 with |vx| <= 0.5 hard and the acceleration at most 1: not reachable in time.
    assert_eq!(mpc.set_state_limits(&[-0.5, -0.5], &[0.5, 0.5]), Status::Ok);
    let status = mpc.solve(&[0.0, 0.0, 2.0, 0.0], &[0.0; NU]);
    assert_eq!(status.status, Status::Ok);
    assert!(!status.optimal);
    for u in mpc.plan().iter().flatten() {
        assert!(u.abs() <= 1.0, "{u}");
    }
}

#[test]
fn weights_that_are_not_positive_semi_definite_are_refused() {
    let (q, r) = weights();
    let mut negative_q = q;
    negative_q[1][1] = -1.0;
    // A cross weight beyond the geometric mean of its two: an indefinite `q`.
    let mut beyond = q;
    beyond[0][1] = 2.0 * (q[0][0] * q[1][1]).sqrt();
    let mut negative_r = r;
    negative_r[0][0] = -1e-3;
    for (q, r) in [(negative_q, r), (beyond, r), (q, negative_r)] {
        assert_eq!(
            planar::Mpc::new(&q, &r, &[-1.0; NU], &[1.0; NU]).err(),
            Some(Status::InvalidWeight)
        );
        let mut mpc =
            planar::Mpc::new(&weights().0, &weights().1, &[-1.0; NU], &[1.0; NU]).expect("valid");
        let kept = mpc;
        assert_eq!(mpc.set_weights(&q, &r), Status::InvalidWeight);
        assert_eq!(mpc, kept);
    }
    // The lower triangle is not read: a weight written upper-only is one.
    let mut upper_only = q;
    upper_only[1][0] = -7.0;
    assert!(planar::Mpc::new(&upper_only, &r, &[-1.0; NU], &[1.0; NU]).is_ok());
}

#[test]
fn the_setters_refuse_limits_that_leave_no_room_and_bad_penalties() {
    let (q, r) = weights();
    let mut mpc = planar::Mpc::new(&q, &r, &[-1.0; NU], &[1.0; NU]).expect("valid");
    let kept = mpc;
    assert_eq!(
        mpc.set_state_limits(&[0.5, -1.0], &[0.4, 1.0]),
        Status::RejectedInput
    );
    assert_eq!(
        mpc.set_state_limits(&[f64::NAN, -1.0], &[0.4, 1.0]),
        Status::RejectedInput
    );
    assert_eq!(
        mpc.set_rate_limits(&[f64::INFINITY, -1.0], &[f64::INFINITY, 1.0]),
        Status::RejectedInput
    );
    assert_eq!(
        mpc.set_output_limits(&[-1.0], &[f64::NEG_INFINITY]),
        Status::RejectedInput
    );
    assert_eq!(mpc.set_limit_penalties(&[0.0, 1.0]), Status::RejectedInput);
    assert_eq!(
        mpc.set_limit_penalties(&[1.0, f64::INFINITY]),
        Status::RejectedInput
    );
    assert_eq!(mpc, kept);
    // One side open is a limit.
    assert_eq!(
        mpc.set_output_limits(&[f64::NEG_INFINITY], &[1.0]),
        Status::Ok
    );
}

/// The steady states of the point mass (`x = A x + B u`) with `reach = r`, least-norm,
/// by nalgebra's pseudo-inverse of the equations `[A - I, B; C, 0] z = [0; r]`.
fn least_norm_steady_state(reach: f64) -> DVector<f64> {
    let ts = 0.1;
    let mut equations = DMatrix::<f64>::zeros(NS + 1, NS + NU);
    // (A - I) x + B u: the positions integrate the speeds, the speeds the accelerations.
    for axis in 0..2 {
        equations[(axis, 2 + axis)] = ts;
        equations[(axis, NS + axis)] = 0.5 * ts * ts;
        equations[(2 + axis, NS + axis)] = ts;
    }
    for (j, &c) in REACH.iter().enumerate() {
        equations[(NS, j)] = c;
    }
    let mut right = DVector::<f64>::zeros(NS + 1);
    right[NS] = reach;
    equations.pseudo_inverse(1e-12).expect("an SVD") * right
}

#[test]
fn a_tracked_output_is_held_at_its_reference_by_the_least_norm_steady_state() {
    let (q, r) = weights();
    let mut mpc = planar::Mpc::new(&q, &r, &[-1.0; NU], &[1.0; NU]).expect("valid");
    let kept = mpc;
    assert_eq!(mpc.set_output_reference(&[f64::NAN]), Status::RejectedInput);
    assert_eq!(mpc, kept);
    let mut x = [0.3, -0.2, 0.0, 0.1];
    let mut u = [0.0; NU];
    for reach in [0.8, -0.5] {
        assert_eq!(mpc.set_output_reference(&[reach]), Status::Ok);
        // Closed on the model's own step, long enough to settle.
        for _ in 0..600 {
            let status = mpc.solve(&x, &u);
            assert_eq!(status.status, Status::Ok);
            u = mpc.control();
            x = planar::f(&x, &u);
        }
        let target = least_norm_steady_state(reach);
        assert!((planar::h(&x)[0] - reach).abs() < 1e-9, "{x:?}");
        for (i, &x_i) in x.iter().enumerate() {
            assert!((x_i - target[i]).abs() < 1e-9, "{x:?} {target}");
        }
        for (i, &u_i) in u.iter().enumerate() {
            assert!((u_i - target[NS + i]).abs() < 1e-9, "{u:?} {target}");
        }
    }
}
