stateforge::model! {
    /// Out-of-range values are reported under the value.
    pub mod m {
        scalar f32;
        state x1;
        param a;
        input u;
        output y = x1;
        dynamics discrete {
            x1 = a * x1 + u;
        }
        generate dkf(eta = 1.5, window = 2.5), lqr(horizon = 0, states = [x1], input = u);
    }
}

fn main() {}
