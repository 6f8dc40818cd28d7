stateforge::model! {
    /// An equation that reads an intermediate defined below it.
    pub mod m {
        scalar f32;
        state x1;
        dynamics discrete {
            x1 = x1 + damping;
            let damping = -0.1 * x1;
        }
    }
}

fn main() {}
