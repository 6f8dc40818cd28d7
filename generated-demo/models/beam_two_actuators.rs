stateforge::model! {
    /// The cantilever of the double Kalman filter paper driven by two actuators, each with its own unknown gain:
    /// four parameters, two inputs. It shows the window transform on a model whose
    /// parameter system is 4 x 4 and which has two input-only parameters (Case 2 freezes
    /// the gain of whichever actuator was idle over the window).
    pub mod beam_two_actuators {
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
            /// gain of the first actuator [mm/(s^2 V)]
            b1,
            /// gain of the second actuator [mm/(s^2 V)]
            b2;
        input
            /// first actuator voltage \[V\]
            u1,
            /// second actuator voltage \[V\]
            u2;
        output
            /// measured tip displacement \[mm\]
            y = x1;
        generate ekf, dkf(eta = 0.5);
        // Forward Euler of x1' = x2, x2' = k x1 + c x2 + b1 u1 + b2 u2, as eq. (3).
        dynamics discrete {
            x1 = x1 + TS * x2;
            x2 = x2 + TS * (k * x1 + c * x2 + b1 * u1 + b2 * u2);
        }
    }
}
