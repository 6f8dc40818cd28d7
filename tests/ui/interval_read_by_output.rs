stateforge::model! {
    /// An output that reads the sample interval.
    pub mod m {
        scalar f32;
        interval DT = 0.01;
        state x1, x2;
        output y = x1 + DT * x2;
        generate ekf;
        dynamics discrete {
            x1 = x1 + DT * x2;
            x2 = x2;
        }
    }
}

fn main() {}
