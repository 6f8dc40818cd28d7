stateforge::model! {
    /// A model with one mistake.
    pub mod m {
        scalar f32;
        state x1;
        param k;
        dynamics discrete {
            x1 = k * x1;
            k = 0.9 * k;
        }
    }
}

fn main() {}
