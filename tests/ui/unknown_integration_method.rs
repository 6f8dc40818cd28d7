stateforge::model! {
    /// A model with one mistake.
    pub mod m {
        scalar f32;
        const TS = 0.01;
        state x1;
        dynamics continuous(rk5, dt = TS) {
            der(x1) = -x1;
        }
    }
}

fn main() {}
