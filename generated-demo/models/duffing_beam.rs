stateforge::model! {
    /// The cantilever of the double Kalman filter paper with an unknown cubic stiffness (a hardening spring, as
    /// in large-amplitude vibration): the parameter `kc` multiplies the nonlinear term
    /// `x1^3`. It shows the window transform where a parameter's coefficient is nonlinear
    /// in the state, so the transformed model has a known affine term `d` (eq. 12 extended).
    pub mod duffing_beam {
        scalar f32, f64;
        /// Sample time \[s\].
        const TS = 0.015;
        state
            /// tip displacement \[mm\]
            x1,
            /// tip velocity \[mm/s\]
            x2;
        param
            /// -wn^2 \[1/s^2\]
            k,
            /// -2 zeta wn \[1/s\]
            c,
            /// cubic stiffness [1/(mm^2 s^2)]
            kc,
            /// input gain [mm/(s^2 V)]
            b;
        input
            /// actuator voltage \[V\]
            u;
        output
            /// measured tip displacement \[mm\]
            y = x1;
        generate ekf, dkf(eta = 0.5);
        // Forward Euler of x1' = x2, x2' = k x1 + c x2 + kc x1^3 + b u.
        dynamics discrete {
            x1 = x1 + TS * x2;
            x2 = x2 + TS * (k * x1 + c * x2 + kc * powi(x1, 3) + b * u);
        }
    }
}
