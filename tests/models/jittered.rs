stateforge::model! {
    /// Dead reckoning in the plane with a jittered sample interval (test model of
    /// `interval DT = ..`): the odometer's speed and the gyro's yaw rate drive the position
    /// and the heading over each sample's own interval, which each prediction takes.
    pub mod jittered {
        scalar f32, f64;
        /// Sample interval [s], nominally 0.1 s; each prediction is given its own.
        interval DT = 0.1;
        state px, py, heading;
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
            let turned = heading + DT * yaw_rate;
            px = px + DT * speed * cos(turned);
            py = py + DT * speed * sin(turned);
            heading = turned;
        }
        generate ekf(gate = 13.82);
    }
}
