stateforge::model! {
    /// A model with one mistake.
    pub mod m {
        scalar f32;
        state x1, x2;
        dynamics discrete {
            x1 = sin(x1, x2);
            x2 = x2;
        }
    }
}

fn main() {}
