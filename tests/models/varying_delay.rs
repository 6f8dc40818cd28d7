stateforge::model! {
    /// Dead reckoning in the plane with measurements whose delay varies (test model of a
    /// sensor's delay given at run time, `sensor fix(max_delay = 4)`): the odometer's speed
    /// and the gyro's yaw rate drive the position and the heading; each fix describes the
    /// position up to four samples before it arrives, each compass heading up to two, and
    /// each update takes its measurement's own delay.
    pub mod varying_delay {
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
        /// A satellite fix, up to four samples late: at four, it describes the horizon's sample.
        sensor fix(max_delay = 4) = [fix_x, fix_y];
        /// A compass, up to two samples late.
        sensor compass_sensor(max_delay = 2) = [compass];
        dynamics discrete {
            let turned = heading + DT * yaw_rate;
            px = px + DT * speed * cos(turned);
            py = py + DT * speed * sin(turned);
            heading = turned;
        }
        generate ekf;
    }
}
