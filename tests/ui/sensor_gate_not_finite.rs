stateforge::model! {
    /// A sensor's gate too large to be a number (it overflows to infinity): `off` says an open gate.
    pub mod m {
        scalar f32;
        state x1, x2, x3;
        output pair_a = x1, pair_b = x2, range = x1 + x3;
        sensor pair(gate = 1e400) = [pair_a, pair_b];
        generate ekf;
        dynamics discrete {
            x1 = x1 + x2;
            x2 = x2;
            x3 = x3;
        }
    }
}

fn main() {}
