stateforge::model! {
    /// A delayed sensor beside an output in no sensor.
    pub mod m {
        scalar f32;
        state x1, x2, x3;
        output pair_a = x1, pair_b = x2, range = x1 + x3;
        sensor pair(delay = 3) = [pair_a, pair_b];
        generate ekf;
        dynamics discrete {
            x1 = x1 + x2;
            x2 = x2;
            x3 = x3;
        }
    }
}

fn main() {}
