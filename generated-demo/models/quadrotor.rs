stateforge::model! {
    /// TinyMPC's quadrotor hover benchmark (Nguyen, Schoedel, Alavilli, Plancher and
    /// Manchester, "TinyMPC: Model-Predictive Control on Resource-Constrained
    /// Microcontrollers"): a Crazyflie linearised about hover and discretised at 20 Hz,
    /// 12 states (position, attitude as Rodrigues parameters, their rates) and 4 inputs
    /// (the motors' thrusts, as a fraction of full thrust, less the hover thrust).
    ///
    /// The matrices are TinyMPC's own, to the digits it publishes them with: the rows of
    /// `Adyn` and `Bdyn` in `examples/problem_data/quadrotor_20hz_params.hpp` of its C++
    /// library (the same numbers as `examples/quadrotor_hover_code_generation.py` of its
    /// Python package), each row one equation below. Its weights (`Q_data`, `R_data`)
    /// and limits (`|u| <= 0.5` in `examples/quadrotor_hovering.cpp`) are the
    /// benchmark's (`cargo xtask peers`, `xtask/src/peers_quadrotor.rs`), handed to
    /// `Mpc::new`.
    pub mod quadrotor {
        scalar f32, f64;
        state
            /// position \[m\]
            x, y, z,
            /// attitude, Rodrigues parameters (not Euler angles)
            phi, theta, psi,
            /// velocity \[m/s\]
            dx, dy, dz,
            /// rates of the attitude parameters
            dphi, dtheta, dpsi;
        input
            /// the four motors' thrusts less the hover thrust (Crazyflie's order)
            u1, u2, u3, u4;
        output
            /// the position
            px = x, py = y, pz = z;
        // TinyMPC's `examples/quadrotor_hovering.cpp` runs NHORIZON = 10 knot points: 9
        // moves (36 unknowns), every peer at the same horizon (this `horizon` is the one
        // number that sets it).
        generate mpc(horizon = 9,
            states = [x, y, z, phi, theta, psi, dx, dy, dz, dphi, dtheta, dpsi],
            inputs = [u1, u2, u3, u4]);
        dynamics discrete {
            x = x + 0.0245250 * theta + 0.0500000 * dx + 0.0002044 * dtheta - 0.0007069 * u1 + 0.0007773 * u2 + 0.0007091 * u3 - 0.0007795 * u4;
            y = y - 0.0245250 * phi + 0.0500000 * dy - 0.0002044 * dphi + 0.0007034 * u1 + 0.0007747 * u2 - 0.0007042 * u3 - 0.0007739 * u4;
            z = z + 0.0500000 * dz + 0.0052554 * u1 + 0.0052554 * u2 + 0.0052554 * u3 + 0.0052554 * u4;
            phi = phi + 0.0250000 * dphi - 0.1720966 * u1 - 0.1895213 * u2 + 0.1722891 * u3 + 0.1893288 * u4;
            theta = theta + 0.0250000 * dtheta - 0.1729419 * u1 + 0.1901740 * u2 + 0.1734809 * u3 - 0.1907131 * u4;
            psi = psi + 0.0250000 * dpsi + 0.0123423 * u1 - 0.0045148 * u2 - 0.0174024 * u3 + 0.0095748 * u4;
            dx = 0.9810000 * theta + dx + 0.0122625 * dtheta - 0.0565520 * u1 + 0.0621869 * u2 + 0.0567283 * u3 - 0.0623632 * u4;
            dy = -0.9810000 * phi + dy - 0.0122625 * dphi + 0.0562756 * u1 + 0.0619735 * u2 - 0.0563386 * u3 - 0.0619105 * u4;
            dz = dz + 0.2102143 * u1 + 0.2102143 * u2 + 0.2102143 * u3 + 0.2102143 * u4;
            dphi = dphi - 13.7677303 * u1 - 15.1617018 * u2 + 13.7831318 * u3 + 15.1463003 * u4;
            dtheta = dtheta - 13.8353509 * u1 + 15.2139209 * u2 + 13.8784751 * u3 - 15.2570451 * u4;
            dpsi = dpsi + 0.9873856 * u1 - 0.3611820 * u2 - 1.3921880 * u3 + 0.7659845 * u4;
        }
    }
}
