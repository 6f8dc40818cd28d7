stateforge::model! {
    /// Attitude and heading reference (test model of the error-state EKF): the body-to-earth
    /// rotation integrated from a gyro whose bias the filter estimates, corrected by the
    /// accelerometer (gravity, at low acceleration) and the magnetometer, each its own
    /// sensor. NED earth, FRD body. `GatedEkf` is the same filter gated at the chi-square
    /// 99.9 % quantile of its six outputs, a gate per sensor generated at that threshold.
    pub mod ahrs {
        scalar f32, f64;
        /// Sample time [s].
        const DT = 0.01;
        /// Gravity [m/s^2].
        const GRAVITY = 9.80665;
        /// Earth field, north component [gauss].
        const MAG_N = 0.21;
        /// Earth field, down component [gauss].
        const MAG_D = 0.45;
        state
            /// body-to-earth rotation
            q: Rot3;
        param
            /// gyro bias [rad/s]
            gyro_bias: Vec3;
        input
            /// gyro rate [rad/s]
            gyro: Vec3;
        output
            /// specific force at rest [m/s^2]
            accel = q.inverse() * vec3(0.0, 0.0, -GRAVITY),
            /// earth field in the body [gauss]
            mag = q.inverse() * vec3(MAG_N, 0.0, MAG_D);
        generate ekf(process_noise = diagonal),
            ekf(process_noise = diagonal, gate = 22.46, name = GatedEkf);
        dynamics discrete {
            q = q * exp((gyro - gyro_bias) * DT);
        }
    }
}
