stateforge::model! {
    /// A cart on a track (test model of a covariance in blocks): its position and velocity
    /// from a position fix, and the track's slope, carried for a sensor to come, that
    /// nothing reads yet. Nothing couples the slope to the rest, so its covariance with
    /// them stays zero: the filter neither computes nor stores it.
    pub mod carried_state {
        scalar f32, f64;
        /// Sample time [s].
        const DT = 0.01;
        state
            /// position along the track [m]
            position,
            /// velocity [m/s]
            velocity;
        param
            /// the track's slope [rad], for a tilt sensor to come
            #[allow(unused)]
            slope;
        input
            /// applied acceleration [m/s^2]
            push;
        output
            /// position fix [m]
            fix = position;
        generate ekf(process_noise = diagonal);
        dynamics discrete {
            position = position + DT * velocity;
            velocity = velocity + DT * push;
        }
    }
}
