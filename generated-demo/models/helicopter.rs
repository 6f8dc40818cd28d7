stateforge::model! {
    /// Twin Rotor MIMO System (TRMS, Feedback Instruments 33-949), a laboratory
    /// helicopter model with pitch (main rotor) and yaw (tail rotor) motion,
    /// for a continuous-time EKF (Kulkarni and Purwar, "Nonlinear
    /// experimental estimation and verification of a MIMO system through EKF").
    ///
    /// State x = [psi, psi', phi, phi', tau1, tau2], input u = [u1, u2],
    /// measurement z = [psi, phi] (eq. 1); dynamics eq. (2), constants as listed
    /// after eq. (2) (from the TRMS manual \[1\]).  The yaw equation contains the
    /// explicit time function exp(-0.5 t): t is the time in seconds since the
    /// start of the experiment (t = 0 at start-up).
    /// Units: angles rad, rates rad/s, tau1/tau2 rotor momentum states in TRMS
    /// manual units, u1/u2 control voltages (normalized units, not stated).
    pub mod helicopter {
        scalar f32, f64;
        /// Sample time [s]: "Advantech PCI 1711 I/O board is used with sample
        /// time of 0.001s" (sect. 6.1).
        const TS = 0.001;
        /// Main rotor thrust-moment coefficient a1 (M1 = a1 tau1^2 + b1 tau1).
        const A1 = 0.0135;
        /// Tail rotor thrust-moment coefficient a2.
        const A2 = 0.02;
        /// Main rotor thrust-moment coefficient b1.
        const B1 = 0.0924;
        /// Tail rotor thrust-moment coefficient b2.
        const B2 = 0.09;
        /// Pitch friction coefficient B1psi.
        const B1_PSI = 0.006;
        /// Yaw friction coefficient B1phi.
        const B1_PHI = 0.1;
        /// Pitch (vertical plane) moment of inertia I1 \[kg m^2\].
        const I1 = 0.068;
        /// Yaw (horizontal plane) moment of inertia I2 \[kg m^2\].
        const I2 = 0.02;
        /// Cross-reaction momentum gain kc.
        const KC = -0.2;
        /// Gyroscopic moment gain kgy.
        const KGY = 0.05;
        /// Main motor gain k1.
        const K1 = 1.1;
        /// Tail motor gain k2.
        const K2 = 0.8;
        /// Gravity moment Mg \[N m\].
        const MG = 0.32;
        /// Main motor time constant T11 \[s\].  Reconstructed: missing from the
        /// paper's constant list; the printed pole -0.833 = -T10/T11 with
        /// T10 = 1 gives T11 = 1.2 (the TRMS manual is often quoted with 1.1).
        const T11 = 1.2;
        /// Tail motor time constant T21 \[s\].  Reconstructed: missing from the
        /// constant list; the printed pole -1 = -T20/T21 with T20 = 1 gives 1.0.
        const T21 = 1.0;
        state
            /// x1 = psi: pitch angle \[rad\] (measured)
            psi,
            /// x2 = psi': pitch rate \[rad/s\]
            dpsi,
            /// x3 = phi: yaw angle \[rad\] (measured)
            phi,
            /// x4 = phi': yaw rate \[rad/s\]
            dphi,
            /// x5 = tau1: main rotor momentum state
            tau1,
            /// x6 = tau2: tail rotor momentum state
            tau2;
        input
            /// u1 = u_a0: main rotor (pitch motor) control signal
            u1,
            /// u2 = u_b0: tail rotor (yaw motor) control signal
            u2;
        output
            /// pitch angle encoder, z1 = x1 \[rad\]
            y_psi = psi,
            /// yaw angle encoder, z2 = x3 \[rad\]
            y_phi = phi;
        generate ekf(gate = off), continuous_ekf(alpha = 0.5, gate = off, process_noise = diagonal);
        // The paper runs a continuous-time EKF (eq. 5) whose state and Riccati
        // ODEs are integrated by Simulink integrators at the 1 ms sample time;
        // it names no explicit scheme and does not use forward Euler, so RK4 is
        // used (dynamics are slow, |eigenvalues| < ~10 rad/s, one substep suffices).
        dynamics continuous(rk4, dt = TS, substeps = 1) {
            // eq. (2), x1' = x2
            der(psi) = dpsi;
            // eq. (2), x2'.  Reconstructed from the OCR:
            // - "sin((2x1)x4^2)" read as sin(2 x1) * x4^2 (centrifugal term
            //   0.0326/2 * phi'^2 * sin(2 psi));
            // - the last term is printed "+ (kgy b1/I1) cos(x1) x4 x5 x2'"; the
            //   trailing x2' is OCR debris and the sign is taken as "-": the
            //   gyroscopic moment is kgy * M1(tau1) * phi' * cos(psi) with
            //   M1 = a1 tau1^2 + b1 tau1, so both of its terms share one sign
            //   (the a1 term is printed with "-").
            der(dpsi) = (A1 / I1) * powi(tau1, 2) + (B1 / I1) * tau1
                - (MG / I1) * sin(psi) - (B1_PSI / I1) * dpsi
                + (0.0326 / (2.0 * I1)) * sin(2.0 * psi) * powi(dphi, 2)
                - (KGY * A1 / I1) * cos(psi) * dphi * powi(tau1, 2)
                - (KGY * B1 / I1) * cos(psi) * dphi * tau1;
            // eq. (2), x3' = x4
            der(phi) = dphi;
            // eq. (2), x4', as printed.  Cross-reaction of the main rotor on
            // yaw: -(kc/I2) M1(tau1) (1.75 - 0.375 exp(-0.5 t)).  The numbers are
            // the coefficients of the impulse response 1.75 delta(t) -
            // 0.375 exp(-0.5 t) of the TRMS cross-coupling transfer function
            // (T0 s + 1)/(Tp s + 1) with Tp = 2 s, T0 = 3.5 s; the paper
            // multiplies M1 by them instead of convolving.  Kept as printed.
            der(dphi) = (A2 / I2) * powi(tau2, 2) + (B2 / I2) * tau2
                - (B1_PHI / I2) * dphi
                - (1.75 * KC * A1 / I2) * powi(tau1, 2)
                - (1.75 * KC * B1 / I2) * tau1
                + (0.375 * KC * A1 / I2) * exp(-0.5 * t) * powi(tau1, 2)
                + (0.375 * B1 * KC / I2) * tau1 * exp(-0.5 * t);
            // eq. (2), main motor: x5' = -0.833 x5 + (k1/T11) u1
            der(tau1) = -0.833 * tau1 + (K1 / T11) * u1;
            // eq. (2), tail motor: x6' = -x6 + (k2/T21) u2
            der(tau2) = -tau2 + (K2 / T21) * u2;
        }
    }
}
