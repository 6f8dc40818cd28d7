stateforge::model! {
    /// A model with one mistake: the continuous-time EKF corrects its estimate with
    /// measurements, and the model declares none.
    pub mod m {
        scalar f32;
        const TS = 0.001;
        state x1, x2;
        input u;
        generate continuous_ekf(alpha = 0.5);
        dynamics continuous(rk4, dt = TS) {
            der(x1) = x2;
            der(x2) = -4.0 * x1.sin() - 0.5 * x2 + u;
        }
    }
}

fn main() {}
