stateforge::model! {
    /// The dead reckoning of `dead_reckoning.rs` with its sample interval declared as such
    /// (test model of `input_noise` with `interval DT = ..`): `predict(dt, u_prev)` takes
    /// each sample's interval, and the process noise `q` and the input noise `qu` are
    /// densities.
    pub mod dead_reckoning_timed {
        scalar f64;
        /// Sample interval [s], nominally 0.1 s.
        interval DT = 0.1;
        state px, py, heading;
        param
            /// the gyro's bias [rad/s]
            yaw_rate_bias;
        input
            /// odometer speed [m/s]
            speed,
            /// gyro yaw rate [rad/s]
            yaw_rate;
        output
            /// position fix, north [m]
            fix_x = px,
            /// position fix, east [m]
            fix_y = py;
        dynamics discrete {
            let turned = heading + DT * (yaw_rate - yaw_rate_bias);
            px = px + DT * speed * cos(turned);
            py = py + DT * speed * sin(turned);
            heading = turned;
        }
        // The densities `qu` in the order listed: the gyro's, then the odometer's.
        generate ekf(input_noise = [yaw_rate, speed], process_noise = diagonal,
            process_noise_on = [yaw_rate_bias]);
    }
}
