stateforge::model! {
    /// An output limited over the horizon must be linear in the regulated states: no
    /// offset, no product, no input; each reported.
    pub mod m {
        scalar f64;
        const TS = 0.1;
        state x1, x2;
        input u;
        output offset = x1 + 1.0, square = x1 * x2, driven = x2 + u;
        dynamics discrete {
            x1 = x1 + TS * x2;
            x2 = x2 + TS * u;
        }
        generate mpc(horizon = 4, states = [x1, x2], input = u,
            output_limits = [offset, square, driven]);
    }
}

fn main() {}
