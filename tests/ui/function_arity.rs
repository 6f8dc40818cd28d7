stateforge::model! {
    /// A model calling the two-argument functions with the wrong number of arguments.
    pub mod m {
        scalar f32;
        state x1, x2;
        dynamics discrete {
            x1 = atan2(x1) + x2.min(1.0, 2.0);
            x2 = x2.clamp(1.0) + tanh(x1, x2);
        }
    }
}

fn main() {}
