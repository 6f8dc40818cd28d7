stateforge::model! {
    /// A sample interval of zero.
    pub mod m {
        scalar f32;
        interval DT = 0.0;
        state x1, x2;
        output y = x1;
        generate ekf;
        dynamics discrete {
            x1 = x1 + DT * x2;
            x2 = x2;
        }
    }
}

fn main() {}
