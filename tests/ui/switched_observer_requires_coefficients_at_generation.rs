stateforge::model! {
    /// A model with one mistake: the observers' gains are designed when the code is
    /// generated, and the input's gain is known only at run time.
    pub mod m {
        scalar f64;
        const TS = 0.001;
        const Q_POS = 1e-8;
        const Q_VEL = 1e-4;
        const R_POS = 1e-6;
        state x, v;
        input u;
        known gain;
        output y = x;
        generate switched_observer(process_noise = [Q_POS, Q_VEL], measurement_noise = [R_POS]);
        dynamics discrete {
            let spring = if x > 0.0 { 400.0 * x } else { 100.0 * x };
            v = v + TS * (gain * u - spring - 0.5 * v);
            x = x + TS * v;
        }
    }
}

fn main() {}
