stateforge::model! {
    /// Every constant must be finite in the model's scalar types.
    pub mod m {
        scalar f32, f64;
        const BIG = 1e300;
        const TINY = 1e-60;
        const Z = 0.0;
        state x1, x2, x3;
        input u;
        dynamics discrete {
            x1 = ln(0.0) * x1;
            x2 = u / Z;
            x3 = 2.0 * x3;
        }
    }
}

fn main() {}
