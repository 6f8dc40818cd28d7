stateforge::model! {
    /// A model with one mistake: `polynomial_kf` treats the estimate's entries as a vector, and
    /// the attitude is a rotation.
    pub mod m {
        scalar f64;
        const TS = 0.01;
        state z0, z1;
        state
            /// attitude, constant
            attitude: Rot3;
        output y = z0;
        generate polynomial_kf(order = 1, dt = TS, fading = 1e-6, noise_variance = 1e-4,
            reinit_every = 50, window = 10);
        dynamics discrete {
            z0 = z0 + z1;
            z1 = z1;
            attitude = attitude;
        }
    }
}

fn main() {}
