stateforge::model! {
    /// The AHRS test model (`tests/models/ahrs.rs`) whose error-state EKF fits its budget:
    /// the estimate it was checked against counts the covariance over the tangent space,
    /// the exact retraction and the covariance reset of every update.
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
        generate ekf(process_noise = diagonal, max_cycles = 8000);
        dynamics discrete {
            q = q * exp((gyro - gyro_bias) * DT);
        }
    }
}

const _: () = assert!(ahrs::EKF_STEP_CYCLES <= 8000);
// The step's parts, and each sensor's update within the joint one.
const _: () = assert!(ahrs::EKF_PREDICT_CYCLES < ahrs::EKF_STEP_CYCLES);
const _: () = assert!(ahrs::EKF_UPDATE_CYCLES < ahrs::EKF_STEP_CYCLES);
const _: () = assert!(ahrs::EKF_UPDATE_ACCEL_CYCLES < ahrs::EKF_UPDATE_CYCLES);
const _: () = assert!(ahrs::EKF_UPDATE_MAG_CYCLES < ahrs::EKF_UPDATE_CYCLES);

fn main() {}
