stateforge::model! {
    /// A model with several mistakes, all reported in one compile.
    pub mod m {
        scalar f32;
        state x1, x2;
        param k;
        dynamics discrete {
            x1 = x1 + gain;
            k = 2.0 * k;
            x2 = cosh(x2);
        }
    }
}

fn main() {}
