stateforge::model! {
    /// The paper's cantilever whose EKF and LQR fit their budgets: it compiles, and the
    /// estimates the budgets were checked against are its `*_CYCLES` constants.
    pub mod cantilever {
        scalar f32, f64;
        const TS = 0.015;
        state x1, x2;
        param x3, x4, x5;
        input u;
        output y = x1;
        generate ekf(process_noise = diagonal, max_cycles = 100000),
            lqr(horizon = 50, states = [x1, x2], input = u, max_us = 100, mhz = 168);
        dynamics discrete {
            x1 = x1 + TS * x2;
            x2 = TS * x1 * x3 + (1.0 + TS * x4) * x2 + TS * x5 * u;
        }
    }
}

const _: () = assert!(cantilever::EKF_STEP_CYCLES <= 100_000);
const _: () = assert!(cantilever::LQR_SOLVE_CYCLES <= 100 * 168);

fn main() {}
