stateforge::model! {
    /// A piecewise-linear model whose second state the output never sees.
    pub mod m {
        scalar f32;
        const Q = 1e-6;
        const R = 1e-4;
        state x1, x2;
        output y = x1;
        generate switched_observer(process_noise = [Q, Q], measurement_noise = [R]);
        dynamics discrete {
            x1 = 0.9 * x1 + if x1 > 0.0 { 0.05 * x1 } else { 0.0 };
            x2 = 0.5 * x2;
        }
    }
}

fn main() {}
