stateforge::model! {
    /// A budget for each scheduled call: the magnetometer's update is over it, and the
    /// error names that call (the prediction, within it, is not reported).
    pub mod ahrs {
        scalar f32;
        const DT = 0.001;
        state q: Rot3;
        param gyro_bias: Vec3;
        input gyro: Vec3;
        output accel = q.inverse() * vec3(0.0, 0.0, -9.81), mag = q.inverse() * vec3(0.21, 0.0, 0.45);
        generate ekf(process_noise = diagonal, max_cycles = 1200,
            schedule = [predict = 1000, update_mag = 50], mhz = 168);
        dynamics discrete {
            q = q * exp((gyro - gyro_bias) * DT);
        }
    }
}

fn main() {}
