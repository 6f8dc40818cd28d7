stateforge::model! {
    /// Limits on what the MPC neither computes nor regulates, on what is not an output,
    /// twice, softened without a limit, and with the primal active set, each reported
    /// under its name.
    pub mod m {
        scalar f64;
        const TS = 0.1;
        state x1, x2, x3;
        input u, w;
        output y = x1;
        dynamics discrete {
            x1 = x1 + TS * x2;
            x2 = x2 + TS * u;
            x3 = x3 + TS * w;
        }
        generate mpc(horizon = 4, states = [x1, x2], input = u, rate_limits = [w],
            state_limits = [x3, x2, x2], output_limits = [x1], soft_limits = [u],
            solver = primal_active_set);
    }
}

fn main() {}
