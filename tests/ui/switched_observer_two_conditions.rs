stateforge::model! {
    /// Two different switching conditions: the observers take one.
    pub mod m {
        scalar f32;
        const Q = 1e-6;
        const R = 1e-4;
        state x1, x2;
        output y1 = x1, y2 = x2;
        generate switched_observer(process_noise = [Q, Q], measurement_noise = [R, R]);
        dynamics discrete {
            x1 = 0.9 * x1 + if x1 > 0.0 { 0.05 * x1 } else { 0.0 };
            x2 = 0.5 * x2 + if x2 < 1.0 { 0.1 * x1 } else { 0.0 };
        }
    }
}

fn main() {}
