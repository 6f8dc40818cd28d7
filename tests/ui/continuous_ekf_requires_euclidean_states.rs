stateforge::model! {
    /// A model with one mistake: `continuous_ekf` treats the estimate's entries as a vector, and
    /// the mounting is a rotation.
    pub mod m {
        scalar f32;
        const TS = 0.001;
        state x1, x2;
        param
            /// mounting of the sensor
            #[allow(unused)]
            mount: Rot3;
        input u;
        output y = x1;
        generate continuous_ekf(alpha = 0.5);
        dynamics continuous(rk4, dt = TS) {
            der(x1) = x2;
            der(x2) = -4.0 * x1.sin() - 0.5 * x2 + u;
        }
    }
}

fn main() {}
