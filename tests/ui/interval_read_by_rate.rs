stateforge::model! {
    /// A rate of continuous dynamics that reads the sample interval.
    pub mod m {
        scalar f32;
        interval DT = 0.01;
        state x1, x2;
        output y = x1;
        generate continuous_ekf;
        dynamics continuous(rk4, dt = DT) {
            der(x1) = x2;
            der(x2) = -x1 / DT;
        }
    }
}

fn main() {}
