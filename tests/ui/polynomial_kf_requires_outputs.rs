stateforge::model! {
    /// A model with one mistake: the polynomial Kalman filter corrects its estimate with
    /// the measured signal, and the model declares no measurement.
    pub mod m {
        scalar f64;
        const TS = 0.01;
        state z0, z1;
        generate polynomial_kf(order = 1, dt = TS, fading = 1e-6, noise_variance = 1e-4,
            reinit_every = 50, window = 10);
        dynamics discrete {
            z0 = z0 + z1;
            z1 = z1;
        }
    }
}

fn main() {}
