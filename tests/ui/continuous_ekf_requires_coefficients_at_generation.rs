stateforge::model! {
    /// A model with one mistake: the continuous-time EKF needs every coefficient when the
    /// code is generated, and the input's gain is known only at run time.
    pub mod m {
        scalar f32;
        const TS = 0.001;
        state x1, x2;
        input u;
        known gain;
        output y = x1;
        generate continuous_ekf(alpha = 0.5);
        dynamics continuous(rk4, dt = TS) {
            der(x1) = x2;
            der(x2) = -4.0 * x1.sin() - 0.5 * x2 + gain * u;
        }
    }
}

fn main() {}
