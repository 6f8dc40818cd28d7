stateforge::model! {
    /// A sample interval for continuous dynamics.
    pub mod m {
        scalar f32;
        interval DT = 0.01;
        state x1, x2;
        output y = x1;
        generate ekf;
        dynamics continuous(euler, dt = DT) {
            der(x1) = x2;
            der(x2) = -x1;
        }
    }
}

fn main() {}
