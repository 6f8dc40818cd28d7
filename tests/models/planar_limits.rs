stateforge::model! {
    /// A point mass in the plane (a double integrator per axis, 10 Hz), driven by its
    /// accelerations, held by an MPC with every kind of limit: on the accelerations'
    /// changes, on the speeds (one soft) and on how far it reaches along a diagonal
    /// (soft), which it also tracks.
    pub mod planar_limits {
        scalar f32, f64;
        const TS = 0.1;
        state px, py, vx, vy;
        input ax, ay;
        output reach = px + 0.5 * py;
        dynamics discrete {
            px = px + TS * vx + 0.5 * TS * TS * ax;
            py = py + TS * vy + 0.5 * TS * TS * ay;
            vx = vx + TS * ax;
            vy = vy + TS * ay;
        }
        generate mpc(horizon = 6, states = [px, py, vx, vy], inputs = [ax, ay],
            rate_limits = [ax, ay], state_limits = [vx, vy], output_limits = [reach],
            soft_limits = [vy, reach], tracked_outputs = [reach]);
    }
}
