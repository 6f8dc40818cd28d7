//! A DC motor, as a user of `stateforge` declares it: armature current and speed,
//! with the viscous friction and the load torque unknown, integrated by RK4 over the
//! 1 ms sample. The generated EKF estimates all four from the measured current and
//! speed; the generated LQR brakes the motor using the estimated model.
//!
//! The library is `no_std`, as firmware would use it; [`plant`] is the simulated motor
//! the host program and the tests run the generated code against.

#![no_std]
#![forbid(unsafe_code)]

pub mod experiment;
pub mod plant;

stateforge::model! {
    /// Permanent-magnet DC motor with a load: armature circuit and rotor.
    ///
    /// `L di/dt = v - R i - K_E w`, `J dw/dt = K_T i - b w - tau_L`, with the viscous
    /// friction `b` and the load torque `tau_L` unknown (random-walk parameters).
    pub mod motor {
        scalar f32, f64;
        /// Sample time [s].
        const TS = 0.001;
        /// Armature resistance [ohm].
        const R = 1.0;
        /// Armature inductance [H].
        const L = 0.002;
        /// Torque constant [N m/A], equal to the back-EMF constant [V s/rad] in SI units.
        const K_T = 0.05;
        /// Rotor and load inertia [kg m^2].
        const J = 1.0e-4;
        state
            /// armature current [A]
            i,
            /// rotor speed [rad/s]
            w;
        param
            /// viscous friction coefficient [mN m s/rad]
            b,
            /// load torque [mN m]
            tau_load;
        input
            /// armature voltage [V]
            v;
        output
            /// measured current [A]
            y_i = i,
            /// measured speed [rad/s]
            y_w = w;
        generate ekf(process_noise = diagonal), lqr(horizon = 200, states = [i, w], input = v);
        dynamics continuous(rk4, dt = TS) {
            der(i) = (v - R * i - K_T * w) / L;
            // friction and load in mN m
            der(w) = (K_T * i - 0.001 * (b * w + tau_load)) / J;
        }
    }
}
