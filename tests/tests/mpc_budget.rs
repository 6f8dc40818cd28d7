//! The dual active set under a cycle budget (`max_cycles`): the budget bounds each
//! solve's iterations by what the solve rebuilt, the static estimate of the costliest
//! solve stays within it, and a solve cut short still returns a plan within the inputs'
//! bounds, `optimal` false.

stateforge::model! {
    /// The point mass of the test model `planar_limits` (a double integrator per axis,
    /// 10 Hz) with hard limits on its accelerations' changes and speeds, its MPC's
    /// solves bounded by a cycle budget.
    pub mod planar_budget {
        scalar f32, f64;
        const TS = 0.1;
        state px, py, vx, vy;
        input ax, ay;
        dynamics discrete {
            px = px + TS * vx + 0.5 * TS * TS * ax;
            py = py + TS * vy + 0.5 * TS * TS * ay;
            vx = vx + TS * ax;
            vy = vy + TS * ay;
        }
        generate mpc(horizon = 6, states = [px, py, vx, vy], inputs = [ax, ay],
            rate_limits = [ax, ay], state_limits = [vx, vy], max_cycles = 150000);
    }
}

use planar_budget::in_f64::{Mpc, MpcRebuild, Status};

const BUDGET: u32 = 150_000;

// The generator's promise, checked when this file compiles: the costliest solve's static
// estimate is within the budget, and the budget binds (fewer iterations than without it).
const _: () = assert!(planar_budget::MPC_SOLVE_WORST_CYCLES <= BUDGET);
const _: () = assert!(Mpc::ITERATIONS_WITHIN_BUDGET[0] < Mpc::MAX_ITERATIONS);

fn identity<const N: usize>(scale: f64) -> [[f64; N]; N] {
    core::array::from_fn(|i| core::array::from_fn(|j| if i == j { scale } else { 0.0 }))
}

/// The largest change of an acceleration between moves (hard).
const RATE: f64 = 0.05;

#[test]
fn each_solve_takes_at_most_the_iterations_its_kind_of_solve_is_allowed() {
    let mut mpc = Mpc::new(&identity(1.0), &identity(0.01), &[-1.0; 2], &[1.0; 2]).expect("valid");
    assert_eq!(mpc.set_rate_limits(&[-RATE; 2], &[RATE; 2]), Status::Ok);
    assert_eq!(mpc.set_state_limits(&[-0.3; 2], &[0.3; 2]), Status::Ok);
    let [kept, problem, model_and_problem] = Mpc::ITERATIONS_WITHIN_BUDGET;
    let (mut cut_short, mut optimal) = (0, 0);
    let mut u = [0.0; 2];
    // Far from the origin and fast, where many limits bind at once, then near it at rest
    // (the input applied now zero).
    let states = [
        ([3.0, -2.0, 0.9, -0.9], false),
        ([-4.0, 1.0, -1.2, 0.8], false),
        ([2.0, 2.0, 0.0, 0.0], false),
        ([0.1, -0.05, 0.02, 0.0], true),
        ([0.01, 0.0, 0.0, 0.01], false),
    ];
    for (x, at_rest) in states {
        if at_rest {
            u = [0.0; 2];
        }
        let status = mpc.solve(&x, &u);
        assert_eq!(status.status, Status::Ok);
        let allowed = match status.rebuilt {
            MpcRebuild::Nothing => kept,
            MpcRebuild::Problem => problem,
            MpcRebuild::ModelAndProblem => model_and_problem,
        };
        assert!(status.iterations <= allowed, "{status:?} {allowed}");
        // Cut short, the dual method's plan is clipped to the bounds (its limit rows may
        // be violated); an optimal one keeps the rate limits too.
        let plan = mpc.plan();
        assert!(plan.iter().flatten().all(|a| a.abs() <= 1.0), "{plan:?}");
        if status.optimal {
            optimal += 1;
            let mut last = u;
            for move_ in plan {
                for (now, before) in move_.iter().zip(last) {
                    assert!((now - before).abs() <= RATE + 1e-9, "{plan:?} from {u:?}");
                }
                last = move_;
            }
        } else {
            cut_short += 1;
        }
        u = mpc.control();
    }
    assert!(
        cut_short > 0 && optimal > 0,
        "{cut_short} cut short, {optimal} optimal"
    );
}
