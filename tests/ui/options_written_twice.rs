stateforge::model! {
    /// An option written under two of its names, and a regulated state listed twice, are
    /// each one error; a negative measurement variance is reported at its own list.
    pub mod m {
        scalar f32;
        const TS = 0.01;
        const Q = 1e-6;
        const R = -1e-4;
        state x1, x2;
        input u;
        output y = x1;
        dynamics discrete {
            x1 = x1 + TS * x2;
            x2 = x2 + TS * u - if x1 > 0.0 { 0.2 * x1 } else { 0.0 };
        }
        generate lqr(state = x1, states = [x1, x2], input = u),
            mpc(horizon = 5, states = [x1, x1], input = u),
            switched_observer(process_noise = [Q, Q], measurement_noise = [R]);
    }
}

fn main() {}
