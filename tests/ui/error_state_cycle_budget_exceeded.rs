stateforge::model! {
    /// The AHRS test model (`tests/models/ahrs.rs`) whose error-state EKF must fit in 1000
    /// cycles: it does not, and the error gives the estimate, what costs most and its parts.
    pub mod ahrs {
        scalar f32, f64;
        const DT = 0.01;
        const GRAVITY = 9.80665;
        const MAG_N = 0.21;
        const MAG_D = 0.45;
        state q: Rot3;
        param gyro_bias: Vec3;
        input gyro: Vec3;
        output
            accel = q.inverse() * vec3(0.0, 0.0, -GRAVITY),
            mag = q.inverse() * vec3(MAG_N, 0.0, MAG_D);
        generate ekf(process_noise = diagonal, max_cycles = 1000);
        dynamics discrete {
            q = q * exp((gyro - gyro_bias) * DT);
        }
    }
}

fn main() {}
