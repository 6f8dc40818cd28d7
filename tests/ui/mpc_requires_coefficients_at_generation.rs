stateforge::model! {
    /// A model with one mistake: the MPC needs every coefficient when the code is
    /// generated, and the input's gain is known only at run time.
    pub mod m {
        scalar f64;
        const TS = 0.1;
        state x1, x2;
        input u;
        known gain;
        output y = x1;
        generate mpc(horizon = 8, states = [x1, x2], input = u);
        dynamics discrete {
            x1 = x1 + TS * x2;
            x2 = x2 + TS * gain * u;
        }
    }
}

fn main() {}
