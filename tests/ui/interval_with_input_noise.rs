stateforge::model! {
    /// Noise on inputs with a sample interval.
    pub mod m {
        scalar f32;
        interval DT = 0.01;
        state x1, x2;
        input u;
        output y = x1;
        generate ekf(input_noise = [u]);
        dynamics discrete {
            x1 = x1 + DT * x2;
            x2 = x2 + DT * u;
        }
    }
}

fn main() {}
