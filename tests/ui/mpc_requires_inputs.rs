stateforge::model! {
    /// A model with one mistake: the MPC computes inputs, and the model declares none.
    pub mod m {
        scalar f64;
        const TS = 0.1;
        state x1, x2;
        output y = x1;
        generate mpc(horizon = 8, states = [x1, x2], input = u);
        dynamics discrete {
            x1 = x1 + TS * x2;
            x2 = x2 - TS * x1;
        }
    }
}

fn main() {}
