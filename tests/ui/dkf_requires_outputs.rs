stateforge::model! {
    /// A model with one mistake: the double Kalman filter corrects its estimates with
    /// measurements, and the model declares none.
    pub mod m {
        scalar f32;
        const TS = 0.015;
        state x1, x2;
        param x3, x4, x5;
        input u;
        generate dkf(eta = 0.5);
        dynamics discrete {
            x1 = x1 + TS * x2;
            x2 = TS * x1 * x3 + (1.0 + TS * x4) * x2 + TS * x5 * u;
        }
    }
}

fn main() {}
