stateforge::model! {
    /// Piecewise-linear beam: a steel beam supported at both ends by leaf
    /// springs, excited at its middle by a rotating mass unbalance, with a
    /// one-sided spring (a second clamped beam) that acts only when the middle
    /// of the beam moves upward (from a study of observer design for a piecewise
    /// linear beam system; linear-error-dynamics observer and switched Kalman
    /// filter, dSPACE implementation).
    ///
    /// 3-DOF reduced finite-element model, eqs. (2.1)-(2.2):
    ///   M q'' + B q' + K q + h f_nl(h' q) = h u,   h = \[0 1 0\]',
    ///   f_nl = k_nl q_mid if q_mid > 0, else 0,
    /// q = [q_act, q_mid, xi]: displacement at a quarter of the beam, at the
    /// middle, and one generalized DOF for the first eigenmode.  State
    /// x = [q; q'] (eq. 2.4; sect. 5.1 writes x2 = q_mid and switches on x2 > 0).
    /// Measured outputs: the two LVDT displacements q_act and q_mid (y = C x).
    ///
    /// RECONSTRUCTED: the numeric M, B, K of Appendix 1 were lost in the OCR (the
    /// appendix is empty).  The M_*, K_*, and Rayleigh constants below are a
    /// reconstruction chosen to be physically consistent with what survives
    /// (checked in tests/tests/piecewise_beam_model.rs):
    /// linear first mode 15.9 Hz, 26.0 Hz with the one-sided spring engaged
    /// (bilinear 19.7 Hz, so a 1-periodic mm-size response at 20 Hz and a
    /// 2-periodic region around 30-50 Hz, Figs. 2.2-2.4), second mode 56 Hz
    /// (matching the lightly damped observer pole -8 +- 358i of sect. 5.2, which
    /// the small gain K1 barely moves), and a high generalized mode of about
    /// 200 Hz ("more high frequent", Appendix 4); Rayleigh damping of 1 % at
    /// 16 Hz, 2 % at 56 Hz, 6 % at 200 Hz.  Also reconstructed: the exponent of
    /// C_H, the noise variances Q_POS, Q_VEL, R_LVDT, and the observers' discrete
    /// step (below).  Kept from the seed: k_nl = 1.98e5 N/m, TS = 0.5 ms, the
    /// structure of eq. (2.1)-(2.2), which states are measured and the switch on
    /// q_mid > 0.  Replace with the real Appendix 1 values when available.
    /// Units: SI (m, m/s, kg, N, s).
    pub mod piecewise_beam {
        scalar f32, f64;
        /// Sample time [s]: "A sampling time of 0.0005 \[s\] is chosen" (sect. 5.2).
        const TS = 0.0005;
        /// Stiffness of the one-sided spring k_nl \[N/m\] (sect. 2.2: 1.98e5 N/m).
        const K_NL = 1.98e5;
        /// Excitation constant c_h \[kg m\] of the mass unbalance, eq. (2.3):
        /// u(t) = c_h (2 pi f_exc)^2 sin(2 pi f_exc t).  Only used to simulate u;
        /// the filter takes the force-transducer measurement as input.
        /// RECONSTRUCTED exponent: the OCR reads "9.4 10^?"; 9.4e-4 gives 15 N at
        /// 20 Hz and 45 N at 35 Hz, i.e. mm-size responses as in Figs. 2.3-2.4.
        const C_H = 9.4e-4;
        /// Mass matrix entry M(1,1) \[kg\]. Value lost in OCR (Appendix 1); reconstructed.
        const M11 = 4.0;
        /// Mass matrix entry M(1,2) \[kg\]. Value lost in OCR (Appendix 1); reconstructed.
        const M12 = 1.5;
        /// Mass matrix entry M(1,3) \[kg\]. Value lost in OCR (Appendix 1); reconstructed.
        const M13 = -0.06;
        /// Mass matrix entry M(2,2) \[kg\] (includes the exciter at mid-span).
        /// Value lost in OCR (Appendix 1); reconstructed.
        const M22 = 7.0;
        /// Mass matrix entry M(2,3) \[kg\]. Value lost in OCR (Appendix 1); reconstructed.
        const M23 = 0.12;
        /// Mass matrix entry M(3,3) \[kg\] (generalized DOF). Value lost in OCR
        /// (Appendix 1); reconstructed.
        const M33 = 0.05;
        /// Stiffness matrix entry K(1,1) \[N/m\]. Value lost in OCR (Appendix 1); reconstructed.
        const K11 = 3.2e5;
        /// Stiffness matrix entry K(1,2) \[N/m\]. Value lost in OCR (Appendix 1); reconstructed.
        const K12 = -1.65e5;
        /// Stiffness matrix entry K(1,3) \[N/m\]; zero (component-mode-synthesis
        /// structure, physical and generalized DOFs uncoupled in K). Value lost
        /// in OCR (Appendix 1); reconstructed.
        const K13 = 0.0;
        /// Stiffness matrix entry K(2,2) \[N/m\] (beam and leaf springs only; the
        /// one-sided spring is K_NL). Value lost in OCR (Appendix 1); reconstructed.
        const K22 = 1.85e5;
        /// Stiffness matrix entry K(2,3) \[N/m\]; zero as K13. Value lost in OCR
        /// (Appendix 1); reconstructed.
        const K23 = 0.0;
        /// Stiffness matrix entry K(3,3) \[N/m\] = M33 (2 pi 190 Hz)^2. Value lost
        /// in OCR (Appendix 1); reconstructed.
        const K33 = 7.126e4;
        /// Rayleigh mass coefficient \[1/s\] for the reconstructed damping
        /// B = RAY_A M + RAY_B K (damping ratio about 1 % at 16 Hz, 2 % at 56 Hz).
        /// The paper's B (Appendix 1) was lost in OCR; reconstructed.
        const RAY_A = 1.0;
        /// Rayleigh stiffness coefficient \[s\]; see RAY_A. Reconstructed.
        const RAY_B = 1.0e-4;
        /// Damping matrix B(1,1) \[N s/m\] (reconstructed, Rayleigh).
        const B11 = RAY_A * M11 + RAY_B * K11;
        /// Damping matrix B(1,2) \[N s/m\] (reconstructed, Rayleigh).
        const B12 = RAY_A * M12 + RAY_B * K12;
        /// Damping matrix B(1,3) \[N s/m\] (reconstructed, Rayleigh).
        const B13 = RAY_A * M13 + RAY_B * K13;
        /// Damping matrix B(2,2) \[N s/m\] (reconstructed, Rayleigh).
        const B22 = RAY_A * M22 + RAY_B * K22;
        /// Damping matrix B(2,3) \[N s/m\] (reconstructed, Rayleigh).
        const B23 = RAY_A * M23 + RAY_B * K23;
        /// Damping matrix B(3,3) \[N s/m\] (reconstructed, Rayleigh).
        const B33 = RAY_A * M33 + RAY_B * K33;
        /// det(M) \[kg^3\], for the inverse of the symmetric mass matrix.
        const M_DET = M11 * (M22 * M33 - M23 * M23) - M12 * (M12 * M33 - M23 * M13) + M13 * (M12 * M23 - M22 * M13);
        /// inv(M)(1,1) \[1/kg\] (cofactor / det).
        const MI11 = (M22 * M33 - M23 * M23) / M_DET;
        /// inv(M)(1,2) = inv(M)(2,1) \[1/kg\].
        const MI12 = (M13 * M23 - M12 * M33) / M_DET;
        /// inv(M)(1,3) = inv(M)(3,1) \[1/kg\].
        const MI13 = (M12 * M23 - M13 * M22) / M_DET;
        /// inv(M)(2,2) \[1/kg\].
        const MI22 = (M11 * M33 - M13 * M13) / M_DET;
        /// inv(M)(2,3) = inv(M)(3,2) \[1/kg\].
        const MI23 = (M12 * M13 - M11 * M23) / M_DET;
        /// inv(M)(3,3) \[1/kg\].
        const MI33 = (M11 * M22 - M12 * M12) / M_DET;
        state
            /// q_act: displacement at a quarter of the beam \[m\] (x1)
            q_act,
            /// q_mid: displacement of the middle of the beam \[m\] (x2)
            q_mid,
            /// xi: generalized DOF of the first eigenmode \[m\] (x3; not measured)
            xi,
            /// velocity of q_act \[m/s\] (x4)
            v_act,
            /// velocity of q_mid \[m/s\] (x5)
            v_mid,
            /// velocity of xi \[m/s\] (x6)
            v_xi;
        input
            /// excitation force u at the middle of the beam \[N\] (mass unbalance,
            /// measured by the piezo-electric force transducer)
            u;
        output
            /// LVDT displacement at a quarter of the beam \[m\]
            y_act = q_act,
            /// LVDT displacement at the middle of the beam \[m\]
            y_mid = q_mid;
        /// Process noise variance of the displacements per sample \[m^2\]
        /// (switched observers' design; the seed's Q was lost in the OCR).
        const Q_POS = 1e-14;
        /// Process noise variance of the velocities per sample [(m/s)^2]: the model is
        /// trusted less than the LVDTs ("the measurements are quite reliable compared to
        /// the model", sect. 6.2). Reconstructed.
        const Q_VEL = 1e-8;
        /// LVDT noise variance \[m^2\] (standard deviation 5 um). Reconstructed: the
        /// accuracy figure of sect. 2.4 was lost in the OCR.
        const R_LVDT = 2.5e-11;
        generate ekf,
            switched_observer(process_noise = [Q_POS, Q_POS, Q_POS, Q_VEL, Q_VEL, Q_VEL],
                measurement_noise = [R_LVDT, R_LVDT]);
        // The observers' discrete model: the equations of motion (2.1) stepped by
        // semi-implicit (symplectic) Euler over one sample, v[k+1] = v + TS a(q, v, u),
        // q[k+1] = q + TS v[k+1]; stable for the 190 Hz mode (omega TS = 0.6 < 2) where
        // explicit Euler is not, and 1.6 % off in that mode's frequency, far less in the
        // 16-56 Hz modes. The contact force is evaluated at the sample, so the two regimes
        // differ only in the column of q_mid, a measured state: what linear error
        // dynamics (K2 = K1 + A_s C', sect. 5.1) need. The experiment simulates the
        // true beam with a fine RK4 (the paper's integrator), not with this step.
        dynamics discrete {
            // one-sided spring, eq. (2.2); E(x2) = 1 if x2 > 0 (sect. 5.1)
            let f_nl = if q_mid > 0.0 { K_NL * q_mid } else { 0.0 };
            // generalized forces h u - h f_nl - B q' - K q, eq. (2.1)
            let f_act = -(B11 * v_act + B12 * v_mid + B13 * v_xi) - (K11 * q_act + K12 * q_mid + K13 * xi);
            let f_mid = u - f_nl - (B12 * v_act + B22 * v_mid + B23 * v_xi) - (K12 * q_act + K22 * q_mid + K23 * xi);
            let f_xi = -(B13 * v_act + B23 * v_mid + B33 * v_xi) - (K13 * q_act + K23 * q_mid + K33 * xi);
            // accelerations M^-1 (...), eq. (2.4)
            let a_act = MI11 * f_act + MI12 * f_mid + MI13 * f_xi;
            let a_mid = MI12 * f_act + MI22 * f_mid + MI23 * f_xi;
            let a_xi = MI13 * f_act + MI23 * f_mid + MI33 * f_xi;
            q_act = q_act + TS * (v_act + TS * a_act);
            q_mid = q_mid + TS * (v_mid + TS * a_mid);
            xi = xi + TS * (v_xi + TS * a_xi);
            v_act = v_act + TS * a_act;
            v_mid = v_mid + TS * a_mid;
            v_xi = v_xi + TS * a_xi;
        }
    }
}
