stateforge::model! {
    /// A model with one mistake: the LQR computes inputs, and the model declares none.
    pub mod m {
        scalar f32;
        const TS = 0.01;
        state x1, x2;
        output y = x1;
        generate lqr(horizon = 50, states = [x1, x2], input = u);
        dynamics discrete {
            x1 = x1 + TS * x2;
            x2 = x2 - TS * x1;
        }
    }
}

fn main() {}
