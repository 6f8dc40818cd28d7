stateforge::model! {
    /// A constant cannot depend on the state.
    pub mod m {
        scalar f32;
        const K = 2.0 * x1;
        state x1;
        dynamics discrete {
            x1 = K * x1;
        }
    }
}

fn main() {}
