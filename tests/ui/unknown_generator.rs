stateforge::model! {
    /// A model with one mistake.
    pub mod m {
        scalar f32;
        state x1;
        input u;
        generate ukf, lqr(horizon = 10, states = [x1], input = u, weight = 2);
        dynamics discrete {
            x1 = x1 + u;
        }
    }
}

fn main() {}
