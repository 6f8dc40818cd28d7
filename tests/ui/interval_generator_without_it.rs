stateforge::model! {
    /// A controller designed for a fixed sample time, of a model with an interval.
    pub mod m {
        scalar f32;
        interval DT = 0.01;
        state x1, x2;
        input u;
        output y = x1;
        generate ekf, lqr(horizon = 10, states = [x1, x2], input = u);
        dynamics discrete {
            x1 = x1 + DT * x2;
            x2 = x2 + DT * u;
        }
    }
}

fn main() {}
