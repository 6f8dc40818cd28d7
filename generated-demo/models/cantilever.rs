stateforge::model! {
    /// Vibrating cantilever beam, first bending mode, with augmented unknown
    /// parameters for joint state and parameter estimation (from the paper on the double
    /// Kalman filter (DKF) vs EKF for adaptive vibration attenuation of a
    /// cantilever beam on an STM32F407 MCU).
    ///
    /// Continuous model, eqs. (1)-(2): x1' = x2, x2' = x3*x1 + x4*x2 + x5*u,
    /// with x3 = -wn^2, x4 = -2*zeta*wn, x5 = alpha (input gain), y = x1.
    /// Discretised with forward Euler at the paper's sample time Ts = 15 ms,
    /// eq. (3) of the double Kalman filter paper.
    /// The parameters are augmented states following a random walk (eqs. 2c-2e).
    ///
    /// Units (paper: laser 10 mm/V, actuator voltage; the restatement uses):
    /// displacement mm, velocity mm/s, input V, time s.
    /// Note: at Ts = 15 ms the Euler model of a 20 rad/s, zeta = 0.026 mode is
    /// unstable (Ts > 2 zeta / wn), so estimated x3, x4 are "Euler-equivalent"
    /// values; map the discrete poles back (s = ln z / Ts) to report wn, zeta.
    pub mod cantilever {
        scalar f32, f64;
        /// Sample time \[s\]; "the sampling period has been set to 15 ms" (sect. 4.1).
        const TS = 0.015;
        state
            /// tip displacement x1 \[mm\]
            x1,
            /// tip velocity x2 \[mm/s\]
            x2;
        param
            /// x3 = -wn^2 \[1/s^2\] (wn: first natural frequency, about 20-50 rad/s)
            x3,
            /// x4 = -2 zeta wn \[1/s\] (zeta: proportional damping ratio)
            x4,
            /// x5 = alpha, input gain [mm/(s^2 V)]
            x5;
        input
            /// actuator (piezo amplifier) voltage u \[V\]
            u;
        output
            /// measured tip displacement y = x1 \[mm\], eq. (3f)
            y = x1;
        // Forward Euler of eq. (2), i.e. eqs. (3a)-(3b); x3, x4, x5 are held
        // (eqs. 3c-3e): params get no equation, they are random-walk states.
        // The filters and controller of the paper: Alg. 1 (EKF), Alg. 2 (DKF), Alg. 3 (LQR);
        // and the EKF with an innovation gate at the chi-square 99.9% quantile, which
        // rejects a measurement spike instead of being thrown off by it. The DKF's gate is
        // open (at the divergence bound) until an application sets it.
        generate ekf(process_noise = diagonal, max_us = 15000, mhz = 168),
            dkf(eta = 0.5, process_noise = diagonal, gate = off),
            lqr(horizon = 50, states = [x1, x2], input = u),
            ekf(process_noise = diagonal, gate = 10.83, name = GatedEkf);
        dynamics discrete {
            // eq. (3a)
            x1 = x1 + TS * x2;
            // eq. (3b)
            x2 = TS * x1 * x3 + (1.0 + TS * x4) * x2 + TS * x5 * u;
        }
    }
}
