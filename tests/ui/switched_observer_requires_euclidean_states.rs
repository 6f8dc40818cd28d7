stateforge::model! {
    /// A model with one mistake: `switched_observer` treats the estimate's entries as a vector, and
    /// the attitude is a rotation.
    pub mod m {
        scalar f64;
        const TS = 0.001;
        const Q_POS = 1e-8;
        const Q_VEL = 1e-4;
        const R_POS = 1e-6;
        state x, v;
        state
            /// attitude, constant
            attitude: Rot3;
        output y = x;
        input u;
        generate switched_observer(process_noise = [Q_POS, Q_VEL], measurement_noise = [R_POS]);
        dynamics discrete {
            let spring = if x > 0.0 { 400.0 * x } else { 100.0 * x };
            v = v + TS * (u - spring - 0.5 * v);
            x = x + TS * v;
            attitude = attitude;
        }
    }
}

fn main() {}
