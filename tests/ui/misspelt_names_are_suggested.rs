stateforge::model! {
    /// Misspellings: a state in an equation, an option of a generator.
    pub mod pendulum {
        scalar f32;
        const TS = 0.01;
        state theta, omega;
        output y = theta;
        generate ekf(proces_noise = diagonal), lqr(horizon = 10, states = [theta], input = u, weight = 2);
        input u;
        dynamics discrete {
            theta = theta + TS * omgea;
            omega = omega - TS * sin(theta) + TS * u;
        }
    }
}

fn main() {}
