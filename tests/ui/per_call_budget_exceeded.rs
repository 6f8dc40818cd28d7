stateforge::model! {
    /// A budget per call, by name: the accelerometer's update is over its own.
    pub mod ahrs {
        scalar f32;
        const DT = 0.001;
        state q: Rot3;
        param gyro_bias: Vec3;
        input gyro: Vec3;
        output accel = q.inverse() * vec3(0.0, 0.0, -9.81), mag = q.inverse() * vec3(0.21, 0.0, 0.45);
        generate ekf(process_noise = diagonal,
            max_cycles = [predict = 5000, update_accel = 100, update_mag = 5000]);
        dynamics discrete {
            q = q * exp((gyro - gyro_bias) * DT);
        }
    }
}

fn main() {}
