stateforge::model! {
    /// A planar rover (test model of the language's functions): position, heading and
    /// speed with an unknown drag, a steering input saturated at its stop and a throttle
    /// that only pushes; the bearing and the range of a beacon at the origin are measured,
    /// together, by one sensor.
    pub mod rover {
        scalar f32, f64;
        /// Sample time [s].
        const TS = 0.01;
        /// Steering stop [rad].
        const STEER_MAX = 0.5;
        /// Wheelbase [m].
        const WHEELBASE = 0.3;
        /// Top speed [m/s].
        const V_MAX = 4.0;
        state px, py, heading, speed;
        param drag;
        input throttle, steer;
        output
            /// bearing of the rover seen from the beacon [rad]
            bearing = atan2(py, px),
            /// range of the rover from the beacon [m]
            range = sqrt(px * px + py * py);
        /// the beacon's direction finder, which measures both at once, gated at the chi-square
        /// 99.9 % quantile for its two outputs
        sensor beacon(gate = 13.82) = [bearing, range];
        dynamics discrete {
            let delta = clamp(steer, -STEER_MAX, STEER_MAX);
            let push = throttle.max(0.0);
            px = px + TS * speed * cos(heading);
            py = py + TS * speed * sin(heading);
            heading = heading + TS * speed * tanh(delta / STEER_MAX) * STEER_MAX / WHEELBASE;
            speed = min(speed + TS * (push - drag * speed), V_MAX);
        }
        generate ekf, lqr(horizon = 50, states = [heading, speed], inputs = [throttle, steer]);
    }
}
