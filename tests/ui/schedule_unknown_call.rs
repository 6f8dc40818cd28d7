stateforge::model! {
    /// A schedule naming a call the filter does not have (a sensor misspelt).
    pub mod ahrs {
        scalar f32;
        const DT = 0.001;
        state q: Rot3;
        param gyro_bias: Vec3;
        input gyro: Vec3;
        output accel = q.inverse() * vec3(0.0, 0.0, -9.81), mag = q.inverse() * vec3(0.21, 0.0, 0.45);
        generate ekf(process_noise = diagonal,
            schedule = [predict = 1000, update_magnetometer = 50], mhz = 168);
        dynamics discrete {
            q = q * exp((gyro - gyro_bias) * DT);
        }
    }
}

fn main() {}
