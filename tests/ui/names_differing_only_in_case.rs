stateforge::model! {
    /// `x2` and `X2` would both be `index::X2`.
    pub mod m {
        scalar f32;
        state x2, X2;
        dynamics discrete {
            x2 = X2;
            X2 = x2;
        }
    }
}

fn main() {}
