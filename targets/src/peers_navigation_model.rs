//! SymForce's peer's own copy of the navigation model it was written for: the additive
//! 24-state filter (`q0..q3` a `w`-first quaternion in the covariance, the IMU's delta
//! angle and delta velocity as inputs, the biases per IMU sample), the navigation model of
//! `generated-demo/models/navigation.rs` before its error-state rewrite on `Rot3` (issue
//! 40). `peers/symforce_codegen.py` derives this filter, so the peers' build compares
//! SymForce's code with this one's; the main job and the firmware's cost table run the
//! error-state filter. Built with the `symforce` feature only, in `f32` only.

stateforge::model! {
    /// A 24-state strapdown inertial navigation model for a multirotor's EKF, in the
    /// formulation of the PX4 autopilot's `ecl` EKF2 before 2022 (P. Riseborough,
    /// "GenerateNavFilterEquations", the 24-state delta-angle / delta-velocity derivation):
    /// attitude quaternion, NED velocity and position, IMU delta-angle and delta-velocity
    /// biases, earth magnetic field, body magnetic bias and horizontal wind.
    ///
    /// The IMU's delta angle and delta velocity over the sample are the inputs (IMU at
    /// 250 Hz); the sensors are the GNSS receiver (NED position and velocity, 5 Hz) and the
    /// three-axis magnetometer (50 Hz), each declared as a `sensor` so that the filter has
    /// an update per sensor.
    ///
    /// Prediction: the attitude by the small-angle delta quaternion `[1, da/2]` (first
    /// order in the corrected delta angle `da = da_meas - da_bias`), the velocity by the
    /// corrected delta velocity rotated to NED plus gravity, the position by the previous
    /// velocity (forward Euler); the biases, fields and wind are random walks. The filter
    /// takes a constant diagonal process noise: the IMU noise mapped through the rotation
    /// is isotropic in velocity (exactly constant) and, in the quaternion, `(s^2/4)(I - q
    /// q')`, taken as `(s^2/4) I` (its part along `q` changes the norm only).
    /// Units: m, m/s, rad, gauss; NED earth frame, FRD body frame.
    pub mod navigation_additive {
        scalar f32;
        /// IMU sample time \[s\] (250 Hz).
        const DT = 0.004;
        /// Gravity \[m/s^2\] (down positive in NED).
        const GRAVITY = 9.80665;
        state
            /// attitude quaternion, scalar part (body to NED)
            q0,
            /// attitude quaternion, x part
            q1,
            /// attitude quaternion, y part
            q2,
            /// attitude quaternion, z part
            q3,
            /// velocity north \[m/s\]
            vn,
            /// velocity east \[m/s\]
            ve,
            /// velocity down \[m/s\]
            vd,
            /// position north \[m\]
            pn,
            /// position east \[m\]
            pe,
            /// position down \[m\]
            pd;
        param
            /// delta-angle bias, body x \[rad\] (per IMU sample)
            dax_b,
            /// delta-angle bias, body y \[rad\]
            day_b,
            /// delta-angle bias, body z \[rad\]
            daz_b,
            /// delta-velocity bias, body x \[m/s\] (per IMU sample)
            dvx_b,
            /// delta-velocity bias, body y \[m/s\]
            dvy_b,
            /// delta-velocity bias, body z \[m/s\]
            dvz_b,
            /// earth magnetic field, north \[gauss\]
            mag_n,
            /// earth magnetic field, east \[gauss\]
            mag_e,
            /// earth magnetic field, down \[gauss\]
            mag_d,
            /// body magnetic bias, x \[gauss\]
            mag_bx,
            /// body magnetic bias, y \[gauss\]
            mag_by,
            /// body magnetic bias, z \[gauss\]
            mag_bz,
            /// wind velocity, north \[m/s\]
            // The wind is carried for the 24-state layout of EKF2 (and SymForce's peer):
            // it enters airspeed and drag fusion, which this model does not have.
            #[allow(unused)]
            wind_n,
            /// wind velocity, east \[m/s\]
            #[allow(unused)]
            wind_e;
        input
            /// IMU delta angle over the sample, body x \[rad\]
            dax,
            /// IMU delta angle, body y \[rad\]
            day,
            /// IMU delta angle, body z \[rad\]
            daz,
            /// IMU delta velocity over the sample, body x \[m/s\]
            dvx,
            /// IMU delta velocity, body y \[m/s\]
            dvy,
            /// IMU delta velocity, body z \[m/s\]
            dvz;
        output
            /// GNSS velocity north \[m/s\]
            gnss_vn = vn,
            /// GNSS velocity east \[m/s\]
            gnss_ve = ve,
            /// GNSS velocity down \[m/s\]
            gnss_vd = vd,
            /// GNSS position north \[m\]
            gnss_pn = pn,
            /// GNSS position east \[m\]
            gnss_pe = pe,
            /// GNSS position down \[m\]
            gnss_pd = pd,
            /// magnetometer, body x: the earth field rotated to the body plus the bias
            /// \[gauss\]
            mag_x = (q0 * q0 + q1 * q1 - q2 * q2 - q3 * q3) * mag_n
                + 2.0 * (q1 * q2 + q0 * q3) * mag_e
                + 2.0 * (q1 * q3 - q0 * q2) * mag_d
                + mag_bx,
            /// magnetometer, body y \[gauss\]
            mag_y = 2.0 * (q1 * q2 - q0 * q3) * mag_n
                + (q0 * q0 - q1 * q1 + q2 * q2 - q3 * q3) * mag_e
                + 2.0 * (q2 * q3 + q0 * q1) * mag_d
                + mag_by,
            /// magnetometer, body z \[gauss\]
            mag_z = 2.0 * (q1 * q3 + q0 * q2) * mag_n
                + 2.0 * (q2 * q3 - q0 * q1) * mag_e
                + (q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3) * mag_d
                + mag_bz;
        /// The GNSS receiver's NED velocity and position fix (5 Hz).
        sensor gnss = [gnss_vn, gnss_ve, gnss_vd, gnss_pn, gnss_pe, gnss_pd];
        /// The three-axis magnetometer (50 Hz).
        sensor magnetometer = [mag_x, mag_y, mag_z];
        generate ekf(process_noise = diagonal, gate = 22.46);
        dynamics discrete {
            // The corrected delta angle and delta velocity.
            let da_x = dax - dax_b;
            let da_y = day - day_b;
            let da_z = daz - daz_b;
            let dv_x = dvx - dvx_b;
            let dv_y = dvy - dvy_b;
            let dv_z = dvz - dvz_b;
            // q [x] [1, da/2]: the quaternion product with the delta quaternion.
            q0 = q0 - 0.5 * (q1 * da_x + q2 * da_y + q3 * da_z);
            q1 = q1 + 0.5 * (q0 * da_x + q2 * da_z - q3 * da_y);
            q2 = q2 + 0.5 * (q0 * da_y - q1 * da_z + q3 * da_x);
            q3 = q3 + 0.5 * (q0 * da_z + q1 * da_y - q2 * da_x);
            // v + Tbn dv + g dt, Tbn the body-to-NED rotation of q.
            vn = vn
                + (q0 * q0 + q1 * q1 - q2 * q2 - q3 * q3) * dv_x
                + 2.0 * (q1 * q2 - q0 * q3) * dv_y
                + 2.0 * (q1 * q3 + q0 * q2) * dv_z;
            ve = ve
                + 2.0 * (q1 * q2 + q0 * q3) * dv_x
                + (q0 * q0 - q1 * q1 + q2 * q2 - q3 * q3) * dv_y
                + 2.0 * (q2 * q3 - q0 * q1) * dv_z;
            vd = vd
                + 2.0 * (q1 * q3 - q0 * q2) * dv_x
                + 2.0 * (q2 * q3 + q0 * q1) * dv_y
                + (q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3) * dv_z
                + GRAVITY * DT;
            pn = pn + DT * vn;
            pe = pe + DT * ve;
            pd = pd + DT * vd;
        }
    }
}
