stateforge::model! {
    /// Continuous dynamics integrated over a fixed step beside a sample interval.
    pub mod m {
        scalar f32;
        interval DT = 0.01;
        const TS = 0.01;
        state x1, x2;
        output y = x1;
        generate hybrid_ekf;
        dynamics continuous(euler, dt = TS) {
            der(x1) = x2;
            der(x2) = -x1;
        }
    }
}

fn main() {}
