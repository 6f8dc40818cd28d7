stateforge::model! {
    /// The first model.
    pub mod first {
        scalar f32;
        state x1;
        dynamics discrete {
            x1 = x1;
        }
    }
    /// A second model needs its own invocation.
    pub mod second {
        scalar f32;
        state x1;
        dynamics discrete {
            x1 = x1;
        }
    }
}

fn main() {}
