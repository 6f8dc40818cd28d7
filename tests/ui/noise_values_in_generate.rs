stateforge::model! {
    /// Noise values are given at run time (`process_noise` is the covariance's shape), and
    /// a list of numbers where model constants go names what to write instead.
    pub mod m {
        scalar f32;
        const Q = 1e-6;
        state x1, x2;
        output y = x1;
        dynamics discrete {
            x1 = x1 + 0.01 * x2;
            x2 = 0.9 * x2 - if x1 > 0.0 { 0.2 * x1 } else { 0.0 };
        }
        generate ekf(process_noise = [1e-6, 1e-4]),
            switched_observer(process_noise = [Q, Q], measurement_noise = [1e-4]);
    }
}

fn main() {}
