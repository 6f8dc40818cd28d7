stateforge::model! {
    /// A model with one mistake: the LQR linearises the unrolled sample step, and 500
    /// sub-steps are integrated in a loop.
    pub mod m {
        scalar f32;
        const TS = 0.01;
        state x1, x2;
        input u;
        output y = x1;
        generate lqr(horizon = 50, states = [x1, x2], input = u);
        dynamics continuous(euler, dt = TS, substeps = 500) {
            der(x1) = x2;
            der(x2) = -x1 + u;
        }
    }
}

fn main() {}
