stateforge::model! {
    /// A model with one mistake.
    pub mod m {
        scalar f32;
        state x1;
        dynamics discrete {
            x1 = 0.5 * x1;
            x1 = 0.25 * x1;
        }
    }
}

fn main() {}
