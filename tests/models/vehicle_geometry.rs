stateforge::model! {
    /// A vehicle in 3-D (test model of vectors and rotations, written the same way in
    /// `vehicle_geometry.toml`): position and velocity in the earth frame, an accelerometer
    /// bias in the body frame estimated as a parameter, and the attitude given each sample
    /// by an attitude reference and turned by the gyro over the step.
    pub mod vehicle_geometry {
        scalar f32, f64;
        /// Sample time [s].
        const DT = 0.01;
        /// Gravity [m/s^2], down in NED.
        const GRAVITY = 9.80665;
        /// Drag over speed [1/s].
        const DRAG = 0.05;
        state
            /// position, NED [m]
            p: Vec3,
            /// velocity, NED [m/s]
            v: Vec3;
        param
            /// accelerometer bias, body [m/s^2]
            accel_bias: Vec3;
        input
            /// body-to-earth attitude
            attitude: Rot3,
            /// specific force, body [m/s^2]
            accel: Vec3,
            /// body rate [rad/s]
            gyro: Vec3;
        output
            /// position fix [m]
            fix = p,
            /// range to the beacon at the origin [m]
            range = p.norm(),
            /// height above the beacon [m]
            height = -p.z,
            /// velocity in the body frame [m/s]
            body_velocity = attitude.inverse() * v,
            /// speed along the nose [m/s]
            forward = v.dot(attitude * vec3(1.0, 0.0, 0.0)),
            /// heading of the turned attitude's rotation vector [rad]
            turned = turn.z;
        dynamics discrete {
            let q = attitude * exp(gyro * DT);
            let turn = log(q);
            let acceleration = q * (accel - accel_bias) + vec3(0.0, 0.0, GRAVITY);
            let drag = v.normalize() * (DRAG * v.norm_squared());
            let lift = cross(v, vec3(0.0, 0.0, 1.0e-3)) * norm(inverse(q) * v);
            p = p + v * DT + acceleration * (0.5 * DT * DT);
            v = v + (acceleration - drag + lift + vec3(v.x.abs(), 0.0, 0.0) * 1.0e-3) * DT
                + v.cross(q.inverse() * vec3(dot(turn, turn), 0.0, 0.0)) * 1.0e-4;
        }
        generate ekf(process_noise = diagonal, process_noise_on = [accel_bias]);
    }
}
