stateforge::model! {
    /// The cantilever of the double Kalman filter paper (the model of `cantilever`) with
    /// a DKF whose window holds 40 output samples instead of the 5 that determine the
    /// parameters: its 38 equations (eq. 8 at every sample the window reaches) are solved
    /// by least squares, which averages the measurement noise the minimum window amplifies
    /// through its finite differences.
    ///
    /// Units: displacement mm, velocity mm/s, input V, time s.
    pub mod cantilever_long_window {
        scalar f32, f64;
        /// Sample time \[s\]; "the sampling period has been set to 15 ms" (sect. 4.1).
        const TS = 0.015;
        state
            /// tip displacement x1 \[mm\]
            x1,
            /// tip velocity x2 \[mm/s\]
            x2;
        param
            /// x3 = -wn^2 \[1/s^2\]
            x3,
            /// x4 = -2 zeta wn \[1/s\]
            x4,
            /// x5 = alpha, input gain [mm/(s^2 V)]
            x5;
        input
            /// actuator voltage u \[V\]
            u;
        output
            /// measured tip displacement y = x1 \[mm\], eq. (3f)
            y = x1;
        generate dkf(eta = 0.5, process_noise = diagonal, gate = off, window = 40);
        dynamics discrete {
            // eq. (3a)
            x1 = x1 + TS * x2;
            // eq. (3b)
            x2 = TS * x1 * x3 + (1.0 + TS * x4) * x2 + TS * x5 * u;
        }
    }
}
