stateforge::model! {
    /// A model with one mistake.
    pub mod m {
        state x1;
        dynamics discrete {
            x1 = x1;
        }
    }
}

fn main() {}
