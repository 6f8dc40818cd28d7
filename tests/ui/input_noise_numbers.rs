stateforge::model! {
    /// Input noise given as numbers: its variances are given at run time.
    pub mod m {
        scalar f32;
        const TS = 0.01;
        state x1, x2;
        input u;
        output y = x1;
        generate ekf(input_noise = [1e-4]);
        dynamics discrete {
            x1 = x1 + TS * x2;
            x2 = x2 + TS * u;
        }
    }
}

fn main() {}
