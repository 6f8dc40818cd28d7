stateforge::model! {
    /// A 24-state strapdown inertial navigation model for a multirotor's EKF, in the
    /// error-state formulation of the PX4 autopilot's EKF2 (its SymForce derivation,
    /// `ekf_derivation/derivation.py`): attitude, NED velocity and position, gyro and
    /// accelerometer biases, earth magnetic field, body magnetic bias and horizontal wind;
    /// 24 entries, a 23-dimensional covariance (the attitude's error is a rotation vector).
    ///
    /// The IMU (nominally 250 Hz, its intervals jittering) is the input: its delta angle and
    /// delta velocity over the sample divided by the sample's interval `DT`, which each
    /// prediction takes. The sensors are the GNSS receiver (NED velocity and position, 5 Hz)
    /// and the three-axis magnetometer (50 Hz). The attitude turns by the exact exponential
    /// of the corrected rate, the velocity by the corrected specific force rotated to NED
    /// plus gravity, the position by the previous velocity; the rest are random walks.
    ///
    /// Process noise, a density over `TANGENT_NAMES` (per second; a prediction adds `Q dt`):
    /// the IMU's white noise enters exactly as state noise. The gyro's noise of density
    /// `N_g` turns the body by an angle of variance `N_g^2 dt` per axis more than the filter
    /// believes, in the earth frame too, where the attitude error lives (isotropic noise
    /// stays isotropic under `R(q)`), so `N_g^2` on each attitude coordinate. Likewise the
    /// accelerometer's `N_a^2` on each velocity coordinate.
    /// Units: m, m/s, rad, gauss; NED earth frame, FRD body frame.
    pub mod navigation {
        scalar f32, f64;
        /// IMU sample interval \[s\], nominally 4 ms (250 Hz); each prediction takes the
        /// sample's own.
        interval DT = 0.004;
        /// Gravity \[m/s^2\] (down positive in NED).
        const GRAVITY = 9.80665;
        state
            /// attitude, body (FRD) to earth (NED)
            q: Rot3,
            /// velocity, NED \[m/s\]
            v: Vec3,
            /// position, NED \[m\]
            p: Vec3;
        param
            /// gyro bias, body \[rad/s\]
            gyro_bias: Vec3,
            /// accelerometer bias, body \[m/s^2\]
            accel_bias: Vec3,
            /// earth magnetic field, NED \[gauss\]
            mag_earth: Vec3,
            /// body magnetic bias (hard iron) \[gauss\]
            mag_body: Vec3,
            /// wind velocity, north \[m/s\]
            // Carried for EKF2's 24-entry layout: it enters airspeed and drag fusion,
            // which this model does not have. Nothing couples it to the rest, so the
            // filter keeps its covariance with them zero without computing it
            // (`Ekf::COVARIANCE_BLOCKS`).
            #[allow(unused)]
            wind_n,
            /// wind velocity, east \[m/s\]
            #[allow(unused)]
            wind_e;
        input
            /// gyro: the IMU's delta angle over the sample / its interval, body \[rad/s\]
            gyro: Vec3,
            /// accelerometer: the IMU's delta velocity / its interval, body \[m/s^2\]
            accel: Vec3;
        output
            /// GNSS velocity, NED \[m/s\]
            gnss_v = v,
            /// GNSS position, NED \[m\]
            gnss_p = p,
            /// magnetometer: the earth field in the body plus the bias \[gauss\]
            mag = q.inverse() * mag_earth + mag_body;
        /// The GNSS receiver's NED velocity and position fix (5 Hz), gated at the
        /// chi-square 99.9 % quantile for its 6 outputs. It arrives 38 IMU samples
        /// (152 ms) after the time it describes, as a receiver's fix does.
        sensor gnss(gate = 22.46, delay = 38) = [gnss_v, gnss_p];
        /// The three-axis magnetometer (50 Hz), gated at the 99.9 % quantile for 3.
        sensor magnetometer(gate = 16.27) = [mag];
        // `Ekf` fuses the GNSS fix as if it were current, as a filter without a delayed
        // horizon does (the comparison the flight makes, and the filter SymForce's code is
        // measured against); `DelayedEkf` at the sample it describes, on a horizon 38
        // samples behind, the magnetometer's samples waiting for it there (its updates are
        // the sensors' in turn, each with its own gate). `Ekf`'s joint update's gate: the
        // 99.9 % quantile for all 9 outputs. The calls as the flight
        // runs them on a 168 MHz Cortex-M4F: each within 15000 cycles, the three at their
        // rates within 2 % of the core (about 1.1 % by the static estimates).
        generate ekf(process_noise = diagonal, gate = 27.88, horizon = current,
            max_cycles = 15000,
            schedule = [predict = 250, update_gnss = 5, update_magnetometer = 50],
            mhz = 168, max_load = 2);
        generate ekf(name = DelayedEkf, process_noise = diagonal);
        dynamics discrete {
            q = q * exp((gyro - gyro_bias) * DT);
            v = v + (q * (accel - accel_bias) + vec3(0.0, 0.0, GRAVITY)) * DT;
            p = p + v * DT;
        }
    }
}
