stateforge::model! {
    /// A damped pendulum whose samples jitter (test model of `interval DT = ..` with
    /// continuous dynamics): each filter integrates the dynamics over each sample's own
    /// interval, which each prediction takes.
    pub mod jittered_pendulum {
        scalar f32, f64;
        /// Sample interval [s], nominally 20 ms; each prediction is given its own.
        interval DT = 0.02;
        /// Gravity over length [1/s²].
        const G_L = 9.81;
        /// Damping [1/s].
        const DAMPING = 0.3;
        state
            /// angle [rad]
            theta,
            /// angular rate [rad/s]
            omega;
        input
            /// torque over inertia [rad/s²]
            torque;
        output
            /// the bob's horizontal position over the length
            sway = sin(theta);
        generate ekf, hybrid_ekf(gate = 10.83), continuous_ekf;
        dynamics continuous(rk4, dt = DT) {
            der(theta) = omega;
            der(omega) = -G_L * sin(theta) - DAMPING * omega + torque;
        }
    }
}
