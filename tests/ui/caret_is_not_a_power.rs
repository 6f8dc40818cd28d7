stateforge::model! {
    /// A model with one mistake.
    pub mod m {
        scalar f32;
        state x1;
        dynamics discrete {
            x1 = x1 ^ 2;
        }
    }
}

fn main() {}
