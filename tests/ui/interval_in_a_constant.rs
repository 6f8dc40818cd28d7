stateforge::model! {
    /// A constant computed from the sample interval.
    pub mod m {
        scalar f32;
        interval DT = 0.01;
        const HALF = 0.5 * DT;
        state x1, x2;
        output y = x1;
        generate ekf;
        dynamics discrete {
            x1 = x1 + HALF * x2;
            x2 = x2;
        }
    }
}

fn main() {}
