stateforge::model! {
    /// A parameter named as a state, and a state declared twice (which needs no equation
    /// of its own).
    pub mod m {
        scalar f32;
        state x1, x2;
        param x1;
        state x2;
        dynamics discrete {
            x1 = x1;
            x2 = x2;
        }
    }
}

fn main() {}
