//! The generated MPC against independent references: the zero-order hold against
//! nalgebra's matrix exponential, the terminal weight against the DARE by doubling, the
//! unconstrained first move against the infinite-horizon LQR, and the plan against the
//! box-constrained QP solved by Clarabel from the explicit prediction matrices.

use blade::{MpcRebuild, Status};
use generated_demo::mass_spring_damper::in_f64 as demo;
use nalgebra::{DMatrix, DVector};
use tests::predictive_reference as reference;
use tests::rng::Lcg;

stateforge::model! {
    /// The demo's control-mode blade (`generated_demo::mass_spring_damper`, eq. 20) with its
    /// MPC unbudgeted, so that every solve may take all its iterations: the algorithm's
    /// tests below need the QP's minimiser from any start, which the demo's cycle budget
    /// may cut short.
    pub mod blade {
        scalar f64;
        const TS = 0.01;
        const K_SPRING = 533.0;
        const B_DAMP = 0.11;
        const C_ACT = 8.0e-4;
        const OMEGA_N = 6.283185307179586 / 0.1;
        const ALPHA_N = 25.0;
        state q, qd, eta1, eta2;
        param inv_m;
        input u;
        output y = q;
        generate mpc(horizon = 10, states = [q, qd], input = u, discretisation = zoh,
            model_tolerance = 1e-3);
        dynamics continuous(euler, dt = TS, substeps = 500) {
            der(q) = qd;
            der(qd) = -inv_m * K_SPRING * q - inv_m * B_DAMP * qd + inv_m * C_ACT * u + eta2;
            der(eta1) = eta2;
            der(eta2) = -OMEGA_N * OMEGA_N * eta1 - 2.0 * ALPHA_N * eta2;
        }
    }
}

stateforge::model! {
    /// A discrete double integrator whose MPC may take one active-set iteration a solve.
    pub mod double_integrator {
        scalar f64;
        const TS = 0.1;
        state x1, x2;
        input u;
        output y = x1;
        dynamics discrete {
            x1 = x1 + TS * x2 + 0.5 * TS * TS * u;
            x2 = x2 + TS * u;
        }
        generate mpc(horizon = 6, states = [x1, x2], input = u, max_iterations = 1);
    }
}

stateforge::model! {
    /// The same integrator with the default iteration bound.
    pub mod double_integrator_full {
        scalar f64;
        const TS = 0.1;
        state x1, x2;
        input u;
        output y = x1;
        dynamics discrete {
            x1 = x1 + TS * x2 + 0.5 * TS * TS * u;
            x2 = x2 + TS * u;
        }
        generate mpc(horizon = 6, states = [x1, x2], input = u);
    }
}

/// The blade's spring, damping and actuator constants and sample time (the model's).
const K: f64 = 533.0;
const B: f64 = 0.11;
const C: f64 = 8.0e-4;
const TS: f64 = 0.01;
/// The paper's weights: `Q = C'C`, `R = 1e-10` (sect. 4.1).
const Q: [[f64; 2]; 2] = [[1.0, 0.0], [0.0, 0.0]];
const R: [[f64; 1]; 1] = [[1e-10]];

fn estimate(q: f64, qd: f64, inv_m: f64) -> [f64; 5] {
    [q, qd, 0.0, 0.0, inv_m]
}

fn controller(limit: f64) -> blade::Mpc {
    blade::Mpc::new(&Q, &R, &[-limit], &[limit]).expect("valid bounds")
}

/// Solves at `x` until the terminal weight has converged; the last status.
fn converge(mpc: &mut blade::Mpc, x: &[f64; 5]) -> blade::MpcStatus {
    for _ in 0..200 {
        let status = mpc.solve(x, &[0.0]);
        assert_eq!(status.status, Status::Ok);
        if status.terminal_weight_converged {
            return status;
        }
    }
    panic!("the terminal weight did not converge in 200 solves");
}

fn matrix<const R: usize, const C: usize>(m: &[[f64; C]; R]) -> DMatrix<f64> {
    DMatrix::from_fn(R, C, |i, j| m[i][j])
}

fn relative(a: &DMatrix<f64>, b: &DMatrix<f64>) -> f64 {
    (a - b).amax() / b.amax()
}

fn prediction(inv_m: f64) -> (DMatrix<f64>, DMatrix<f64>) {
    let model = blade::Mpc::prediction_model(&estimate(0.0, 0.0, inv_m), &[0.0]).expect("finite");
    (matrix(&model.a), matrix(&model.b))
}

#[test]
fn the_zero_order_hold_matches_the_matrix_exponential() {
    // From a heavy, slow beam to a light, stiff one: at 1/m = 5000 the hold squares 16
    // times, and each squaring can double the rounding of the one before.
    for inv_m in [0.5, 2.0, 5.0, 1.0 / 0.254, 50.0, 5000.0] {
        let (a, b) = prediction(inv_m);
        let phi = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, -K * inv_m, -B * inv_m]);
        let gamma = DMatrix::from_row_slice(2, 1, &[0.0, C * inv_m]);
        let (a_ref, b_ref) = reference::zero_order_hold(&phi, &gamma, TS);
        assert!(
            relative(&a, &a_ref) < 1e-11,
            "A at 1/m = {inv_m}: {a} vs {a_ref}"
        );
        assert!(
            relative(&b, &b_ref) < 1e-11,
            "B at 1/m = {inv_m}: {b} vs {b_ref}"
        );
    }
}

#[test]
fn the_terminal_weight_solves_the_dare_and_its_gain_is_the_lqr() {
    for inv_m in [5.0, 1.0 / 0.254, 2.0] {
        let mut mpc = controller(100.0);
        let status = converge(&mut mpc, &estimate(0.0, 0.0, inv_m));
        assert!(status.optimal);
        let (a, b) = prediction(inv_m);
        let (q, r) = (matrix(&Q), matrix(&R));
        let p_ref = reference::dare(&a, &b, &q, &r);
        let p = matrix(&mpc.terminal_weight());
        assert!(
            relative(&p, &p_ref) < 1e-8,
            "1/m = {inv_m}: P {p} vs {p_ref}"
        );
        let k_ref = reference::gain(&a, &b, &r, &p_ref);
        let k = matrix(&mpc.terminal_gain());
        assert!(
            relative(&k, &k_ref) < 1e-8,
            "1/m = {inv_m}: K {k} vs {k_ref}"
        );
    }
}

#[test]
fn without_active_bounds_the_first_move_is_the_infinite_horizon_lqr() {
    let x = estimate(1e-4, -2e-3, 5.0);
    let mut mpc = controller(100.0);
    let status = converge(&mut mpc, &x);
    assert!(status.optimal);
    let plan = mpc.plan();
    assert!(
        plan.iter().all(|u| u[0].abs() < 99.0),
        "a bound is active: {plan:?}"
    );
    let (a, b) = prediction(5.0);
    let p_ref = reference::dare(&a, &b, &matrix(&Q), &matrix(&R));
    let k_ref = reference::gain(&a, &b, &matrix(&R), &p_ref);
    let lqr = -(k_ref[(0, 0)] * x[0] + k_ref[(0, 1)] * x[1]);
    let first = mpc.control()[0];
    assert!(
        (first - lqr).abs() < 1e-8 * lqr.abs(),
        "MPC {first} vs LQR {lqr}"
    );
}

#[test]
fn the_plan_agrees_with_clarabel_on_random_problems() {
    let mut rng = Lcg(2026);
    let (mut several_active, mut worst) = (0, 0.0_f64);
    for case in 0..120 {
        let inv_m = 5.0 * (1.0 + 0.5 * rng.uniform());
        let x = estimate(0.02 * rng.uniform(), 2.0 * rng.uniform(), inv_m);
        let limit = 100.0 * (0.2 + 0.8 * rng.uniform().abs());
        let (x_ref, u_ref) = ([0.002 * rng.uniform(), 0.0], [0.3 * limit * rng.uniform()]);
        let mut mpc = controller(limit);
        assert_eq!(mpc.set_reference(&x_ref, &u_ref), Status::Ok);
        let status = converge(&mut mpc, &x);
        let status = if status.optimal {
            status
        } else {
            mpc.solve(&x, &[0.0])
        };
        assert!(status.optimal, "case {case}: {status:?}");

        let (a, b) = prediction(inv_m);
        let p = matrix(&mpc.terminal_weight());
        let x0 = DVector::from_vec(vec![x[0] - x_ref[0], x[1] - x_ref[1]]);
        let (h, c) = reference::condensed((&a, &b), (&matrix(&Q), &matrix(&R), &p), &x0, 10);
        let (low, high) = ([-limit - u_ref[0]; 10], [limit - u_ref[0]; 10]);
        let expected = reference::box_qp(&h, &c, &low, &high);
        let plan = mpc.plan();
        for (k, (u, v)) in plan.iter().zip(expected.iter()).enumerate() {
            assert!(
                u[0] >= -limit && u[0] <= limit,
                "case {case}: move {k} outside"
            );
            let error = (u[0] - u_ref[0] - v).abs();
            worst = worst.max(error);
            if error >= 1e-6 {
                let cost = |v: &DVector<f64>| (v.transpose() * &h * v)[0] / 2.0 + c.dot(v);
                let ours = DVector::from_iterator(10, plan.iter().map(|u| u[0] - u_ref[0]));
                panic!(
                    "case {case}, move {k}: {} vs {v}; cost {:e} vs Clarabel {:e}",
                    u[0] - u_ref[0],
                    cost(&ours),
                    cost(&expected)
                );
            }
        }
        let active = expected
            .iter()
            .filter(|v| (*v - low[0]).abs() < 1e-6 || (*v - high[0]).abs() < 1e-6)
            .count();
        several_active += usize::from(active >= 2);
    }
    println!("largest difference from Clarabel: {worst:.2e} V; {several_active} of 120 cases hold 2+ bounds");
    assert!(
        several_active >= 30,
        "only {several_active} cases with several active bounds"
    );
}

#[test]
fn the_model_is_kept_within_its_tolerance_and_rebuilt_beyond_it() {
    // The blade keeps its model while 1/m moves by less than 1e-3 of itself, as the demo's.
    assert_eq!(blade::Mpc::MODEL_TOLERANCE, 1e-3);
    let x = estimate(2e-3, 0.1, 5.0);
    let mut settled = controller(100.0);
    // The first solve builds everything; the next ones keep the model and step the
    // terminal weight until it settles.
    let first = settled.solve(&x, &[0.0]);
    assert_eq!(first.rebuilt, MpcRebuild::ModelAndProblem);
    let second = settled.solve(&x, &[0.0]);
    assert_eq!(second.rebuilt, MpcRebuild::Problem);
    for _ in 0..300 {
        assert_eq!(settled.solve(&x, &[0.0]).status, Status::Ok);
    }
    let solve_at = |inv_m: f64| {
        let mut mpc = settled;
        let status = mpc.solve(&estimate(x[0], x[1], inv_m), &[0.0]);
        assert!(status.optimal, "{status:?}");
        (mpc, status)
    };
    let (same, kept) = solve_at(5.0);
    assert_eq!(kept.rebuilt, MpcRebuild::Nothing);
    // Within the tolerance the kept model (and terminal weight) serve: the same plan and
    // weight, bit for bit.
    let (near, status) = solve_at(5.0 * (1.0 + 5e-4));
    assert_eq!(status.rebuilt, MpcRebuild::Nothing);
    assert_eq!(near.plan(), same.plan());
    assert_eq!(near.terminal_weight(), same.terminal_weight());
    // Beyond it the model is rebuilt at the estimate, and the terminal weight moves.
    let (far, status) = solve_at(5.0 * (1.0 + 2e-3));
    assert_eq!(status.rebuilt, MpcRebuild::ModelAndProblem);
    assert_ne!(far.terminal_weight(), same.terminal_weight());
    let (a, b) = prediction(5.0 * (1.0 + 2e-3));
    let p_ref = reference::dare(&a, &b, &matrix(&Q), &matrix(&R));
    let (p_far, p_same) = (
        matrix(&far.terminal_weight()),
        matrix(&same.terminal_weight()),
    );
    assert!(
        relative(&p_far, &p_ref) < relative(&p_same, &p_ref),
        "the rebuilt weight moves towards the new model's DARE"
    );
}

#[test]
fn every_solve_of_the_blade_run_is_the_qp_its_model_and_weight_define() {
    // The QP each solve of the firmware's run minimises, rebuilt on the host from what the
    // controller exposes (the model it used, its terminal weight, the estimate and the
    // tuning), as a peer solver would take it: Clarabel agrees with every plan the solve
    // finished. The demo's cycle budget cuts a solve short where it needs more iterations
    // than `ITERATIONS_WITHIN_BUDGET` allows after what it rebuilt: that plan is within
    // the bounds and no better than the minimiser, and the next solve finishes again.
    use generated_demo::mpc_sequence::{mpc_tuning, BladeEstimates};
    let limit = f64::from(mpc_tuning::U_MAX);
    let mut mpc = demo::Mpc::new(&Q, &R, &[-limit], &[limit]).expect("valid bounds");
    let (mut worst, mut cut, mut worst_gap) = (0.0_f64, Vec::new(), 0.0_f64);
    let mut last_cut = false;
    for (k, x) in BladeEstimates::new().take(300).enumerate() {
        let x = x.map(f64::from);
        let status = mpc.solve(&x, &[0.0]);
        assert_eq!(status.status, demo::Status::Ok, "{k}: {status:?}");
        assert!(
            status.optimal || !last_cut,
            "{k} follows a cut solve: {status:?}"
        );
        let model = mpc.model();
        let (a, b) = (matrix(&model.a), matrix(&model.b));
        let p = matrix(&mpc.terminal_weight());
        let x0 = DVector::from_vec(vec![x[0], x[1]]);
        let (h, c) = reference::condensed((&a, &b), (&matrix(&Q), &matrix(&R), &p), &x0, 10);
        let expected = reference::box_qp(&h, &c, &[-limit; 10], &[limit; 10]);
        let plan = DVector::from_iterator(10, mpc.plan().iter().map(|u| u[0]));
        assert!(plan.iter().all(|u| u.abs() <= limit), "{k}: {plan}");
        let kind = match status.rebuilt {
            demo::MpcRebuild::Nothing => 0,
            demo::MpcRebuild::Problem => 1,
            demo::MpcRebuild::ModelAndProblem => 2,
        };
        let bound = demo::Mpc::ITERATIONS_WITHIN_BUDGET[kind];
        assert!(status.iterations <= bound, "{k}: {status:?}");
        last_cut = !status.optimal;
        if status.optimal {
            worst = worst.max((&plan - &expected).amax());
            continue;
        }
        assert_eq!(status.iterations, bound, "{k}");
        let cost = |v: &DVector<f64>| (v.transpose() * &h * v)[0] / 2.0 + c.dot(v);
        let gap = (cost(&plan) - cost(&expected)) / cost(&expected).abs();
        assert!(
            gap >= -1e-9,
            "{k}: the cut plan beats the minimiser by {gap:e}"
        );
        worst_gap = worst_gap.max(gap);
        cut.push((k, (plan[0] - expected[0]).abs()));
    }
    println!(
        "the blade run's plans against Clarabel on their QPs: {worst:.2e} V; cut short by the \
         budget (solve, first move's distance from the minimiser's): {cut:?}, cost at most \
         {worst_gap:.1e} above the minimum"
    );
    assert!(worst < 1e-6, "{worst:e} V");
    // The budget is chosen to cut only the rare solve that rebuilds its model and then
    // needs a third iteration; what it cuts stays close to the minimum.
    assert!(cut.len() <= 3, "{} of 300 solves cut short", cut.len());
    assert!(
        worst_gap < 1e-3,
        "a cut plan costs {worst_gap:e} above the minimum"
    );
}

#[test]
fn the_test_blade_is_the_demo_blade_without_its_budget() {
    for inv_m in [2.0, 5.0, 50.0] {
        let x = estimate(1e-3, 0.1, inv_m);
        let ours = blade::Mpc::prediction_model(&x, &[0.0]).expect("finite");
        let demo = demo::Mpc::prediction_model(&x, &[0.0]).expect("finite");
        assert_eq!((ours.a, ours.b), (demo.a, demo.b), "1/m = {inv_m}");
    }
    assert_eq!(blade::Mpc::MODEL_TOLERANCE, demo::Mpc::MODEL_TOLERANCE);
    assert_eq!(blade::Mpc::MAX_ITERATIONS, demo::Mpc::MAX_ITERATIONS);
}

#[test]
fn non_finite_estimates_and_bounds_are_rejected_with_the_controller_unchanged() {
    let mut mpc = controller(100.0);
    assert!(converge(&mut mpc, &estimate(1e-3, 0.0, 5.0)).optimal);
    let before = mpc;
    for bad in [
        estimate(f64::NAN, 0.0, 5.0),
        estimate(0.0, f64::INFINITY, 5.0),
        estimate(0.0, 0.0, f64::NAN),
    ] {
        assert_eq!(mpc.solve(&bad, &[0.0]).status, Status::RejectedInput);
        assert_eq!(mpc, before);
    }
    // A mass so small that the hold would need more than MAX_SQUARINGS squarings.
    let stiff = mpc.solve(&estimate(0.0, 0.0, 1e300), &[0.0]);
    assert_eq!(stiff.status, Status::NonFinite);
    assert_eq!(mpc, before);
    assert_eq!(
        mpc.set_reference(&[f64::NAN, 0.0], &[0.0]),
        Status::RejectedInput
    );
    assert_eq!(mpc, before);
    for (low, high) in [(1.0, 1.0), (f64::NAN, 1.0), (-1.0, f64::INFINITY)] {
        assert!(
            blade::Mpc::new(&Q, &R, &[low], &[high]).is_err(),
            "{low}..{high}"
        );
    }
}

#[test]
fn when_the_iterations_run_out_the_plan_stays_within_the_bounds() {
    let (q, r, x) = ([[1.0, 0.0], [0.0, 1.0]], [[0.01]], [5.0, -3.0]);
    let mut limited = double_integrator::Mpc::new(&q, &r, &[-0.2], &[0.3]).expect("bounds");
    for _ in 0..5 {
        let status = limited.solve(&x, &[0.0]);
        assert_eq!(status.status, double_integrator::Status::Ok);
        assert!(!status.optimal, "one step cannot solve this: {status:?}");
        assert_eq!(status.iterations, 1);
        assert!(limited.plan().iter().all(|u| (-0.2..=0.3).contains(&u[0])));
    }
    // With its iterations, the same problem is solved, holding the bound that slows the
    // integrator down.
    let mut full = double_integrator_full::Mpc::new(&q, &r, &[-0.2], &[0.3]).expect("bounds");
    let status = full.solve(&x, &[0.0]);
    assert!(status.optimal && status.iterations > 1, "{status:?}");
    assert_eq!(full.control(), [-0.2]);
}
