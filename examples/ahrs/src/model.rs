//! The AHRS model: everything the generated filter knows about the body, in 40 lines.

stateforge::model! {
    /// Attitude and heading reference: the gyro, less its bias, turns the attitude each
    /// sample; the accelerometer (gravity, at low acceleration) and the magnetometer (the
    /// earth's field) correct it. Earth frame NED (north, east, down), body frame FRD
    /// (forward, right, down); `q` turns body vectors into earth vectors.
    pub mod ahrs {
        scalar f32, f64;
        /// Sample time [s]: the gyro's and the accelerometer's rate, 100 Hz.
        const DT = 0.01;
        /// Gravity [m/s^2], down in NED.
        const GRAVITY = 9.80665;
        /// Earth field's north component [gauss].
        const MAG_N = 0.21;
        /// Earth field's down component [gauss] (inclination 65 deg).
        const MAG_D = 0.45;
        state
            /// body-to-earth attitude (NED from FRD)
            q: Rot3;
        param
            /// gyro bias, body [rad/s]: a random walk
            gyro_bias: Vec3;
        input
            /// gyro rate, body [rad/s]
            gyro: Vec3;
        output
            /// accelerometer, body [m/s^2]: the specific force at rest, minus gravity
            accel = q.inverse() * vec3(0.0, 0.0, -GRAVITY),
            /// magnetometer, body [gauss]: the earth's field
            mag = q.inverse() * vec3(MAG_N, 0.0, MAG_D);
        generate ekf(input_noise = [gyro], process_noise = diagonal,
            process_noise_on = [gyro_bias]);
        dynamics discrete {
            // The exact exponential: the rate held over the sample turns the body.
            q = q * exp((gyro - gyro_bias) * DT);
        }
    }
}
