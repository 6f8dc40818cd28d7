stateforge::model! {
    /// `horizon = current` where no sensor is late.
    pub mod m {
        scalar f32;
        state x1, x2;
        output pair_a = x1, pair_b = x2;
        sensor pair = [pair_a, pair_b];
        generate ekf(horizon = current);
        dynamics discrete {
            x1 = x1 + x2;
            x2 = x2;
        }
    }
}

fn main() {}
