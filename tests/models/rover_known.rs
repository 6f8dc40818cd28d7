stateforge::model! {
    /// The rover with its wheelbase known only at run time (test model of `known`): position, heading and
    /// speed with an unknown drag, a steering input saturated at its stop and a throttle
    /// that only pushes; the bearing and the range of a beacon at the origin are measured.
    pub mod rover_known {
        scalar f32, f64;
        /// Sample time [s].
        const TS = 0.01;
        /// Steering stop [rad].
        const STEER_MAX = 0.5;
        /// Top speed [m/s].
        const V_MAX = 4.0;
        state px, py, heading, speed;
        param drag;
        input throttle, steer;
        /// Wheelbase [m], measured on each rover at start-up.
        known wheelbase;
        output
            /// bearing of the rover seen from the beacon [rad]
            bearing = atan2(py, px),
            /// range of the rover from the beacon [m]
            range = sqrt(px * px + py * py);
        dynamics discrete {
            let delta = clamp(steer, -STEER_MAX, STEER_MAX);
            let push = throttle.max(0.0);
            px = px + TS * speed * cos(heading);
            py = py + TS * speed * sin(heading);
            heading = heading + TS * speed * tanh(delta / STEER_MAX) * STEER_MAX / wheelbase;
            speed = min(speed + TS * (push - drag * speed), V_MAX);
        }
        generate ekf, lqr(horizon = 50, states = [heading, speed], inputs = [throttle, steer]);
    }
}
