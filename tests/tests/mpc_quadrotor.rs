//! The generated MPC on a problem of TinyMPC's quadrotor hover size (12 states, 4 inputs,
//! 10 moves: 40 unknowns), its plans against the box-constrained QP solved by Clarabel
//! from the explicit prediction matrices, on random states that saturate several inputs,
//! and after its weights and input limits are changed on the running controller.

use nalgebra::{DMatrix, DVector};
use quadrotor::Status;
use tests::predictive_reference as reference;
use tests::rng::Lcg;

stateforge::model! {
    /// A quadrotor linearised at hover (small angles; thrusts as deviations from the
    /// hover thrust), by explicit Euler at 50 Hz: positions, tilt angles, velocities and
    /// body rates, driven by the four motors' thrusts (a Crazyflie's mass, arm and
    /// inertias).
    pub mod quadrotor {
        scalar f64;
        const TS = 0.02;
        const G = 9.81;
        const MASS = 0.027;
        const ARM = 0.0325;
        const IXX = 1.66e-5;
        const IYY = 1.66e-5;
        const IZZ = 2.93e-5;
        const YAW_PER_THRUST = 0.006;
        state px, py, pz, roll, pitch, yaw, vx, vy, vz, wx, wy, wz;
        input t1, t2, t3, t4;
        output height = pz;
        dynamics discrete {
            px = px + TS * vx;
            py = py + TS * vy;
            pz = pz + TS * vz;
            roll = roll + TS * wx;
            pitch = pitch + TS * wy;
            yaw = yaw + TS * wz;
            vx = vx + TS * G * pitch;
            vy = vy - TS * G * roll;
            vz = vz + TS * (t1 + t2 + t3 + t4) / MASS;
            wx = wx + TS * ARM * (t2 + t3 - t1 - t4) / IXX;
            wy = wy + TS * ARM * (t3 + t4 - t1 - t2) / IYY;
            wz = wz + TS * YAW_PER_THRUST * (t1 - t2 + t3 - t4) / IZZ;
        }
        generate mpc(horizon = 10, inputs = [t1, t2, t3, t4],
            states = [px, py, pz, roll, pitch, yaw, vx, vy, vz, wx, wy, wz]);
    }
}

const NS: usize = 12;
const NU: usize = 4;
const HORIZON: usize = 10;

/// Position and attitude weighted over velocities and rates, as TinyMPC's hover example.
fn weights() -> ([[f64; NS]; NS], [[f64; NU]; NU]) {
    let diagonal = [
        100.0, 100.0, 100.0, 4.0, 4.0, 400.0, 4.0, 4.0, 4.0, 2.0, 2.0, 4.0,
    ];
    let mut q = [[0.0; NS]; NS];
    for (i, row) in q.iter_mut().enumerate() {
        row[i] = diagonal[i];
    }
    let mut r = [[0.0; NU]; NU];
    for (i, row) in r.iter_mut().enumerate() {
        row[i] = 4.0;
    }
    (q, r)
}

fn matrix<const R: usize, const C: usize>(m: &[[f64; C]; R]) -> DMatrix<f64> {
    DMatrix::from_fn(R, C, |i, j| m[i][j])
}

/// Solves at `x` until the terminal weight has converged; the last status.
fn converge(mpc: &mut quadrotor::Mpc, x: &[f64; NS]) -> quadrotor::MpcStatus {
    for _ in 0..500 {
        let status = mpc.solve(x, &[0.0; NU]);
        assert_eq!(status.status, Status::Ok);
        if status.terminal_weight_converged && status.optimal {
            return status;
        }
    }
    panic!("the terminal weight did not converge in 500 solves");
}

/// The plan of `mpc` (converged at `x`) against Clarabel's solution of the QP its model,
/// weights, terminal weight and bounds define: the largest difference relative to the
/// input range, and how many moves hold a bound.
fn compare_with_clarabel(
    mpc: &quadrotor::Mpc,
    (q, r): ([[f64; NS]; NS], [[f64; NU]; NU]),
    (u_min, u_max): ([f64; NU], [f64; NU]),
    x: &[f64; NS],
) -> (f64, usize) {
    let model = quadrotor::Mpc::prediction_model(&[0.0; NS], &[0.0; NU]).expect("finite");
    let (a, b) = (matrix(&model.a), matrix(&model.b));
    let p = matrix(&mpc.terminal_weight());
    let x0 = DVector::from_column_slice(x);
    let (h, c) = reference::condensed((&a, &b), (&matrix(&q), &matrix(&r), &p), &x0, HORIZON);
    let low: Vec<f64> = (0..HORIZON * NU).map(|k| u_min[k % NU]).collect();
    let high: Vec<f64> = (0..HORIZON * NU).map(|k| u_max[k % NU]).collect();
    let expected = reference::box_qp(&h, &c, &low, &high);
    let plan: Vec<f64> = mpc.plan().iter().flatten().copied().collect();
    let mut worst = 0.0_f64;
    for (k, (u, v)) in plan.iter().zip(expected.iter()).enumerate() {
        assert!(*u >= low[k] && *u <= high[k], "move {k} outside: {u}");
        worst = worst.max((u - v).abs() / (high[k] - low[k]));
    }
    let held = (0..HORIZON * NU)
        .filter(|&k| (expected[k] - low[k]).abs() < 1e-9 || (expected[k] - high[k]).abs() < 1e-9)
        .count();
    (worst, held)
}

fn random_state(rng: &mut Lcg) -> [f64; NS] {
    core::array::from_fn(|i| match i {
        0..=2 => 0.5 * rng.uniform(),
        3..=5 => 0.2 * rng.uniform(),
        _ => 0.5 * rng.uniform(),
    })
}

#[test]
fn the_quadrotor_plan_agrees_with_clarabel_on_random_states() {
    let weights = weights();
    let mut rng = Lcg(43);
    let (mut worst, mut saturated) = (0.0_f64, 0);
    for case in 0..20 {
        // Thrust deviations within about a third of the hover thrust, unequal limits.
        let limit = 0.05 * (1.0 + 0.5 * rng.uniform());
        let limits = ([-limit; NU], [1.5 * limit; NU]);
        let mut mpc =
            quadrotor::Mpc::new(&weights.0, &weights.1, &limits.0, &limits.1).expect("valid");
        let x = random_state(&mut rng);
        let _ = converge(&mut mpc, &x);
        let (error, held) = compare_with_clarabel(&mpc, weights, limits, &x);
        assert!(error < 1e-6, "case {case}: {error:e} of the input range");
        worst = worst.max(error);
        saturated += usize::from(held >= 2);
    }
    println!("largest difference from Clarabel: {worst:.2e} of the input range");
    assert!(
        saturated >= 10,
        "only {saturated} of 20 cases hold 2+ bounds"
    );
}

#[test]
fn new_weights_and_limits_on_a_running_controller_give_the_new_problems_plan() {
    let (q, r) = weights();
    let limits = ([-0.05; NU], [0.08; NU]);
    let mut mpc = quadrotor::Mpc::new(&q, &r, &limits.0, &limits.1).expect("valid");
    let mut rng = Lcg(4301);
    let x = random_state(&mut rng);
    let _ = converge(&mut mpc, &x);
    // Settled: the kept model, terminal weight and Hessian serve the next solve.
    let before = mpc.solve(&x, &[0.0; NU]);
    let before = match before.rebuilt {
        // The terminal weight settles a solve after it converges.
        quadrotor::MpcRebuild::Problem => mpc.solve(&x, &[0.0; NU]),
        _ => before,
    };
    assert_eq!(before.rebuilt, quadrotor::MpcRebuild::Nothing);

    // Heavier inputs and tighter, asymmetric limits, set between two solves.
    let (mut q2, mut r2) = (q, r);
    q2[2][2] = 400.0;
    for (i, row) in r2.iter_mut().enumerate() {
        row[i] = 20.0;
    }
    assert_eq!(mpc.set_weights(&q2, &r2), Status::Ok);
    let tighter = ([-0.02, -0.03, -0.02, -0.03], [0.03, 0.02, 0.03, 0.02]);
    assert_eq!(mpc.set_input_limits(&tighter.0, &tighter.1), Status::Ok);
    let after = mpc.solve(&x, &[0.0; NU]);
    assert_eq!(after.status, Status::Ok);
    // The kept model serves; the terminal weight and Hessian are rebuilt for the weights.
    assert_eq!(after.rebuilt, quadrotor::MpcRebuild::Problem);
    let _ = converge(&mut mpc, &x);
    let (error, held) = compare_with_clarabel(&mpc, (q2, r2), tighter, &x);
    assert!(error < 1e-6, "{error:e} of the input range");
    assert!(held >= 2, "the tighter limits hold only {held} moves");

    // Rejected values leave the controller as it was.
    let kept = mpc;
    let mut bad = r2;
    bad[1][3] = f64::NAN;
    assert_eq!(mpc.set_weights(&q2, &bad), Status::RejectedInput);
    assert_eq!(
        mpc.set_input_limits(&[0.0; NU], &[0.01, 0.01, 0.0, 0.01]),
        Status::RejectedInput
    );
    assert_eq!(
        mpc.set_input_limits(&[f64::NEG_INFINITY; NU], &[0.01; NU]),
        Status::RejectedInput
    );
    assert_eq!(mpc, kept);
}
