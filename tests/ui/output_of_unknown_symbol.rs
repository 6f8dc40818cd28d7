stateforge::model! {
    /// A model with one mistake.
    pub mod m {
        scalar f32;
        state x1;
        output y = x3;
        dynamics discrete {
            x1 = x1;
        }
    }
}

fn main() {}
