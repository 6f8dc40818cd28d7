stateforge::model! {
    /// Dead reckoning in the plane with a jittered sample interval and a late fix (test
    /// model of `interval DT = ..` on a delayed horizon): the odometer and the gyro drive the
    /// position and heading over each sample's own interval; the fix is two samples late,
    /// the compass current.
    pub mod jittered_late {
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
            fix_y = py,
            /// compass heading [rad]
            compass = heading;
        /// A satellite fix, two samples late.
        sensor fix(delay = 2) = [fix_x, fix_y];
        /// A compass, current.
        sensor compass_sensor = [compass];
        dynamics discrete {
            let turned = heading + DT * yaw_rate;
            px = px + DT * speed * cos(turned);
            py = py + DT * speed * sin(turned);
            heading = turned;
        }
        generate ekf;
    }
}
