stateforge::model! {
    /// A budget on a model whose first scalar type is `f64`: the estimate is of `f32`
    /// code on a Cortex-M4F.
    pub mod m {
        scalar f64;
        const TS = 0.01;
        state x1, x2;
        input u;
        output y = x1;
        generate ekf(max_cycles = 100000);
        dynamics discrete {
            x1 = x1 + TS * x2;
            x2 = x2 + TS * u;
        }
    }
}

fn main() {}
