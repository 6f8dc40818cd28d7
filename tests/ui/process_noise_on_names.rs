stateforge::model! {
    /// Process noise on states that are not the model's, or listed twice.
    pub mod m {
        scalar f32;
        const TS = 0.01;
        state x1, x2;
        param k;
        output y = x1;
        generate ekf(process_noise_on = [x3, k, k, xx2]), hybrid_ekf(process_noise_on = []),
            continuous_ekf(process_noise_on = [TS]);
        dynamics continuous(euler, dt = TS, substeps = 10) {
            der(x1) = x2;
            der(x2) = -k * x1;
        }
    }
}

fn main() {}
