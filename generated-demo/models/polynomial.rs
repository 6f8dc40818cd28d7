stateforge::model! {
    /// Polynomial (kinematic) signal model for a Kalman filter estimating the
    /// position of a flexible arm and its first three time derivatives
    /// (Shults, Brubaker, Lee, "A fast algorithm for control and
    /// estimation using a polynomial state-space structure", NASA N91-22312).
    ///
    /// The measured signal z(t) is modelled locally as a polynomial of order
    /// m = 3 ("a polynomial model of order 3 was required", design example),
    /// so the state has m + 1 = 4 components.  They are the Taylor-scaled
    /// derivatives of eq. (2): x_k = T^k / k! * d^k z / dt^k, k = 0..3, and the
    /// one-step transition is Phi(1) of eq. (4), entries C(j, i) h^(j-i) with
    /// h = 1 (an upper-triangular Pascal matrix); T does not appear in it.
    /// Physical derivatives: dz/dt = z1 / T, d2z/dt2 = 2 z2 / T^2,
    /// d3z/dt3 = 6 z3 / T^3.
    /// No input: the filter only tracks the sensor signal (Fig. 1).
    /// Units: those of the position sensor (hub/tip position; not stated).
    pub mod polynomial {
        scalar f32, f64;
        /// Sample period T [s]: data "sampled at a rate of 100 samples per second".
        const TS = 0.01;
        /// Measurement-noise variance sigma^2 used in both tests (design example).
        const SIGMA2 = 1e-4;
        /// Fading factor f, Q = f I (hub data test: 1e-9; closed-loop
        /// simulation test: 5e-12).
        const FADE = 1e-9;
        state
            /// x_0 = z: position
            z0,
            /// x_1 = T dz/dt: scaled velocity
            z1,
            /// x_2 = (T^2 / 2) d2z/dt2: scaled acceleration
            z2,
            /// x_3 = (T^3 / 6) d3z/dt3: scaled jerk
            z3;
        output
            /// measured position, M = \[1 0 0 0\] ("Data Measurement Vector of one")
            y = z0;
        /// Samples of the least-squares window that re-initialises the filter (the paper
        /// does not give its length; 25 samples = 0.25 s, a quarter of the period).
        const FIT_WINDOW = 25;
        /// Samples between re-initialisations: "reinitialized every 100 samples, 1 second".
        const REINIT_EVERY = 100;
        generate ekf,
            polynomial_kf(order = 3, dt = TS, fading = FADE, noise_variance = SIGMA2,
                reinit_every = REINIT_EVERY, window = FIT_WINDOW);
        // x[n+1] = Phi(1) x[n], eqs. (3)-(5), with Phi(1) for m = 3:
        //   [1 1 1 1; 0 1 2 3; 0 0 1 3; 0 0 0 1]
        // (OCR of eq. (4) shows only its first row 1 h .. h^m and second row
        // 0 1 .. m h^(m-1); the remaining rows follow from the Taylor series.)
        dynamics discrete {
            z0 = z0 + z1 + z2 + z3;
            z1 = z1 + 2.0 * z2 + 3.0 * z3;
            z2 = z2 + 3.0 * z3;
            z3 = z3;
        }
    }
}
