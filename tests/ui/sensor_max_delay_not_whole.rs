stateforge::model! {
    /// A sensor's maximum delay that is not a whole number of samples.
    pub mod m {
        scalar f32;
        state x1, x2, x3;
        output pair_a = x1, pair_b = x2;
        sensor pair(max_delay = 2.5) = [pair_a, pair_b];
        generate ekf;
        dynamics discrete {
            x1 = x1 + x2;
            x2 = x2;
            x3 = x3;
        }
    }
}

fn main() {}
