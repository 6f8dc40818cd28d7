stateforge::model! {
    /// Dead reckoning in the plane (test model of noise on inputs, `input_noise`): the
    /// odometer's speed and the gyro's yaw rate drive the position and the heading, and
    /// their noise enters the state through the input Jacobian; the gyro's bias is a random
    /// walk, noise on a parameter. A position fix corrects it.
    pub mod dead_reckoning {
        scalar f32, f64;
        /// Sample time [s].
        const DT = 0.1;
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
        // The variances `qu` in the order listed: the gyro's, then the odometer's.
        generate ekf(input_noise = [yaw_rate, speed], process_noise = diagonal,
            process_noise_on = [yaw_rate_bias]);
    }
}
