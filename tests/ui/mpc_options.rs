stateforge::model! {
    /// Wrong MPC options are reported under the option, several at once.
    pub mod m {
        scalar f32;
        const TS = 0.01;
        state x1, x2;
        input u;
        output y = x1;
        dynamics discrete {
            x1 = x1 + TS * x2;
            x2 = x2 + TS * u;
        }
        generate mpc(horizon = 50, states = [x1, y], input = u, discretisation = zoh,
            max_iterations = 0, model_tolerance = 1.5);
    }
}

fn main() {}
