stateforge::model! {
    /// An attitude filter scheduled as it runs (the gyro at 1 kHz, the accelerometer at
    /// 200 Hz, the magnetometer at 50 Hz) on a core too slow for it: the load is an error
    /// naming each call's share.
    pub mod ahrs {
        scalar f32;
        const DT = 0.001;
        state q: Rot3;
        param gyro_bias: Vec3;
        input gyro: Vec3;
        output accel = q.inverse() * vec3(0.0, 0.0, -9.81), mag = q.inverse() * vec3(0.21, 0.0, 0.45);
        generate ekf(process_noise = diagonal,
            schedule = [predict = 1000, update_accel = 200, update_mag = 50], mhz = 1);
        dynamics discrete {
            q = q * exp((gyro - gyro_bias) * DT);
        }
    }
}

fn main() {}
