stateforge::model! {
    /// A model with one mistake.
    pub mod m {
        scalar f32;
        const TS = 0.01;
        state x1, x2;
        param k;
        input u;
        output y = x1;
        generate dkf;
        dynamics discrete {
            x1 = x1 * x2;
            x2 = x2 + TS * (k * x1 + u);
        }
    }
}

fn main() {}
