stateforge::model! {
    /// Two sample intervals.
    pub mod m {
        scalar f32;
        interval DT = 0.01;
        interval TS = 0.02;
        state x1, x2;
        output y = x1;
        generate ekf;
        dynamics discrete {
            x1 = x1 + DT * x2 + TS * x2;
            x2 = x2;
        }
    }
}

fn main() {}
