stateforge::model! {
    /// A step of zero leaves the state where it is; a negative one integrates backwards.
    pub mod zero_step {
        scalar f32;
        const TS = 0.01;
        state x1;
        dynamics continuous(euler, dt = TS - 0.01) {
            der(x1) = -x1;
        }
    }
}

stateforge::model! {
    pub mod negative_step {
        scalar f32;
        const TS = 0.01;
        state x1;
        dynamics continuous(rk4, dt = -TS, substeps = 2) {
            der(x1) = -x1;
        }
    }
}

fn main() {}
