stateforge::model! {
    /// A run-time delay with an output left out of every sensor.
    pub mod m {
        scalar f32;
        state x1, x2, x3;
        output pair_a = x1, pair_b = x2;
        sensor late(max_delay = 3) = [pair_a];
        generate ekf;
        dynamics discrete {
            x1 = x1 + x2;
            x2 = x2;
            x3 = x3;
        }
    }
}

fn main() {}
