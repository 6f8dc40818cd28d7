stateforge::model! {
    /// Wrong budgets are reported under the value, several at once.
    pub mod m {
        scalar f32;
        const TS = 0.01;
        state x1, x2;
        param k;
        input u;
        output y = x1;
        generate ekf(max_cycles = 0),
            ekf(max_cycles = -5, name = Negative),
            ekf(max_cycles = fast, name = NotANumber),
            ekf(max_cycles = 1.5, name = Fraction),
            ekf(max_us = 10, name = NoClock),
            ekf(mhz = 168, name = NoTime),
            ekf(max_cycles = 1000, max_us = 10, mhz = 168, name = Twice),
            lqr(horizon = 10, states = [x1, x2], input = u, max_us = 0.001, mhz = 168);
        dynamics discrete {
            x1 = x1 + TS * x2;
            x2 = x2 + TS * (k * x1 + u);
        }
    }
}

fn main() {}
