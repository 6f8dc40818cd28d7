stateforge::model! {
    /// A model with one mistake.
    pub mod m {
        scalar f32;
        state x1;
        dynamics continuous {
            der(x1) = -x1;
        }
    }
}

fn main() {}
