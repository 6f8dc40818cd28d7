stateforge::model! {
    /// A model with one mistake.
    pub mod m {
        scalar f32;
        state x1;
        dynamics discrete {
            x1 = if x1 > 0.0 { x1 };
        }
    }
}

fn main() {}
