stateforge::model! {
    /// The blade of Takacs, Polóni, Rohal'-Ilkiv, "Adaptive predictive control of
    /// transient vibrations of cantilevers with changing weight" in its initial identification mode, eq. (19): the
    /// single-DOF mass-spring-damper m q'' + b q' + k q = c u (eq. 1) with all four
    /// physical parameters unknown, augmented as random walks in the order of eq. (19),
    /// x_I = [q, q', k, b, c, 1/m]. Driven by white noise, without disturbances
    /// (sect. 4.1); its identified k, b, c are then fixed in the control mode
    /// (`mass_spring_damper`).
    ///
    /// Units: SI (m, m/s, N/m, N s/m, N/V, 1/kg, V, s).
    pub mod blade_identification {
        scalar f32, f64;
        /// Sample time T \[s\] (sect. 4.1).
        const TS = 0.01;
        state
            /// x_I1 = q: beam tip position \[m\]
            q,
            /// x_I2 = q': beam tip velocity \[m/s\]
            qd;
        param
            /// x_I3 = k: spring constant \[N/m\]
            k,
            /// x_I4 = b: equivalent viscous damping \[N s/m\]
            b,
            /// x_I5 = c: force conversion constant of the actuators \[N/V\]
            c,
            /// x_I6 = 1/m: inverse equivalent mass \[1/kg\]
            inv_m;
        input
            /// voltage supplied to the piezoceramic actuators u \[V\]
            u;
        output
            /// measured tip position y = q \[m\]
            y = q;
        // The hybrid EKF of sect. 3.2 with the paper's Euler integration at dt = T/500
        // (sect. 4.1), the 500 sub-steps as a loop; its innovation gate open until set at
        // run time (`set_innovation_gate`).
        generate hybrid_ekf(gate = off, process_noise = diagonal);
        dynamics continuous(euler, dt = TS, substeps = 500) {
            // eq. (19)
            der(q) = qd;
            der(qd) = -inv_m * k * q - inv_m * b * qd + inv_m * c * u;
        }
    }
}
