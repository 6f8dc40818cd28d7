stateforge::model! {
    /// A sample interval whose parameter name a state has.
    pub mod m {
        scalar f32;
        interval DT = 0.01;
        state x1, dt;
        output y = x1;
        generate ekf;
        dynamics discrete {
            x1 = x1 + DT * dt;
            dt = dt;
        }
    }
}

fn main() {}
