stateforge::model! {
    /// A model with one mistake: the discrete EKF differentiates the unrolled sample
    /// step, and 500 sub-steps are integrated in a loop.
    pub mod m {
        scalar f32;
        const TS = 0.01;
        state x1;
        input u;
        output y = x1;
        generate ekf;
        dynamics continuous(euler, dt = TS, substeps = 500) {
            der(x1) = -x1 + u;
        }
    }
}

fn main() {}
