stateforge::model! {
    /// A constant-velocity model whose step is not Phi(1) of the stated order.
    pub mod m {
        scalar f32;
        state z0, z1;
        output y = z0;
        generate polynomial_kf(order = 1, dt = 0.01, fading = 1e-9, noise_variance = 1e-4,
            reinit_every = 100, window = 10);
        dynamics discrete {
            z0 = z0 + 0.5 * z1;
            z1 = z1;
        }
    }
}

fn main() {}
