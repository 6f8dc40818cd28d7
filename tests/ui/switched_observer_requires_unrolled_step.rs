stateforge::model! {
    /// A model with one mistake: the observers' regimes are read from the unrolled sample
    /// step, and 500 sub-steps are integrated in a loop.
    pub mod m {
        scalar f64;
        const TS = 0.001;
        const Q_POS = 1e-8;
        const Q_VEL = 1e-4;
        const R_POS = 1e-6;
        state x, v;
        input u;
        output y = x;
        generate switched_observer(process_noise = [Q_POS, Q_VEL], measurement_noise = [R_POS]);
        dynamics continuous(euler, dt = TS, substeps = 500) {
            let spring = if x > 0.0 { 400.0 * x } else { 100.0 * x };
            der(x) = v;
            der(v) = u - spring - 0.5 * v;
        }
    }
}

fn main() {}
