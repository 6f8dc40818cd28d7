stateforge::model! {
    /// Dead reckoning in the plane with a late position fix (test model of the delayed
    /// fusion horizon, `sensor fix(delay = 3)`): the odometer's speed and the gyro's yaw
    /// rate drive the position and the heading; the fix describes the position three
    /// samples before it arrives, the compass the heading as it is given (it waits in a
    /// buffer for the horizon).
    pub mod delayed_fix {
        scalar f32, f64;
        /// Sample time [s].
        const DT = 0.1;
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
        /// A satellite fix, three samples late.
        sensor fix(delay = 3) = [fix_x, fix_y];
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
