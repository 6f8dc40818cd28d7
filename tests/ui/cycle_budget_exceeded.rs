stateforge::model! {
    /// The paper's cantilever (one mode, three unknown coefficients) with an EKF whose
    /// step must fit in 100 cycles: it does not, and the error says by how much and why.
    pub mod cantilever {
        scalar f32, f64;
        const TS = 0.015;
        state x1, x2;
        param x3, x4, x5;
        input u;
        output y = x1;
        generate ekf(process_noise = diagonal, max_cycles = 100),
            lqr(horizon = 50, states = [x1, x2], input = u, max_us = 1.0, mhz = 168);
        dynamics discrete {
            x1 = x1 + TS * x2;
            x2 = TS * x1 * x3 + (1.0 + TS * x4) * x2 + TS * x5 * u;
        }
    }
}

stateforge::model! {
    /// An MPC bounds its iterations within its budget, which must leave room for one
    /// after rebuilding everything.
    pub mod double_integrator {
        scalar f32;
        const TS = 0.1;
        state x1, x2;
        input u;
        output y = x1;
        dynamics discrete {
            x1 = x1 + TS * x2 + 0.5 * TS * TS * u;
            x2 = x2 + TS * u;
        }
        generate mpc(horizon = 6, states = [x1, x2], input = u, max_cycles = 1000);
    }
}

fn main() {}
