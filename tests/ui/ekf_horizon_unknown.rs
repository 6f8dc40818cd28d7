stateforge::model! {
    /// A horizon that is neither `delayed` nor `current`.
    pub mod m {
        scalar f32;
        state x1, x2;
        output pair_a = x1, pair_b = x2;
        sensor pair(delay = 3) = [pair_a, pair_b];
        generate ekf(horizon = 3);
        dynamics discrete {
            x1 = x1 + x2;
            x2 = x2;
        }
    }
}

fn main() {}
