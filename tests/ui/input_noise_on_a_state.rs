stateforge::model! {
    /// Input noise listing a state: noise on a state is `process_noise_on`.
    pub mod m {
        scalar f32;
        const TS = 0.01;
        state x1, x2;
        input u;
        output y = x1;
        generate ekf(input_noise = [x1]);
        dynamics discrete {
            x1 = x1 + TS * x2;
            x2 = x2 + TS * u;
        }
    }
}

fn main() {}
