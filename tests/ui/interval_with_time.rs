stateforge::model! {
    /// A sample interval in a model that reads the time.
    pub mod m {
        scalar f32;
        interval DT = 0.01;
        state x1, x2;
        output y = x1;
        generate hybrid_ekf;
        dynamics continuous(rk4, dt = DT) {
            der(x1) = x2;
            der(x2) = -x1 + sin(t);
        }
    }
}

fn main() {}
