stateforge::model! {
    /// `solver` names one of the two active-set methods.
    pub mod m {
        scalar f64;
        const TS = 0.1;
        state x1, x2;
        input u;
        dynamics discrete {
            x1 = x1 + TS * x2;
            x2 = x2 + TS * u;
        }
        generate mpc(horizon = 4, states = [x1, x2], input = u, solver = admm);
    }
}

fn main() {}
