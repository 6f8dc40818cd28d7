stateforge::model! {
    /// An EKF needs a measurement.
    pub mod m {
        scalar f32;
        state x1;
        dynamics discrete {
            x1 = 0.5 * x1;
        }
        generate ekf;
    }
}

fn main() {}
