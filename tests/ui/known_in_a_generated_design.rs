stateforge::model! {
    /// A constant known only at run time where the design needs a number.
    pub mod m {
        scalar f32;
        const TS = 0.01;
        state x1, x2;
        param k;
        input u;
        known gain;
        output y = x1;
        dynamics discrete {
            x1 = x1 + TS * x2;
            x2 = x2 - TS * k * x1 + TS * gain * u;
        }
        generate ekf, dkf;
    }
}

fn main() {}
