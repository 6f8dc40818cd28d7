stateforge::model! {
    /// A model with one mistake: the continuous-time EKF integrates `dx/dt`, which a
    /// discrete model does not give.
    pub mod m {
        scalar f32;
        const TS = 0.001;
        state x1, x2;
        input u;
        output y = x1;
        generate continuous_ekf(alpha = 0.5);
        dynamics discrete {
            x1 = x1 + TS * x2;
            x2 = x2 + TS * (-4.0 * x1.sin() - 0.5 * x2 + u);
        }
    }
}

fn main() {}
