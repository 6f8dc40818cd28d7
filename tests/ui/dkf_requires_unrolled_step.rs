stateforge::model! {
    /// A model with one mistake: the window transform of the double Kalman filter
    /// differentiates the unrolled sample step, and 500 sub-steps are integrated in a loop.
    pub mod m {
        scalar f32;
        const TS = 0.015;
        state x1, x2;
        param x3, x4, x5;
        input u;
        output y = x1;
        generate dkf(eta = 0.5);
        dynamics continuous(euler, dt = TS, substeps = 500) {
            der(x1) = x2;
            der(x2) = x3 * x1 + x4 * x2 + x5 * u;
        }
    }
}

fn main() {}
