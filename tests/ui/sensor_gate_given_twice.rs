stateforge::model! {
    /// A sensor's gate given twice.
    pub mod m {
        scalar f32;
        state x1, x2, x3;
        output pair_a = x1, pair_b = x2, range = x1 + x3;
        sensor pair(gate = 13.82, gate = 9.21) = [pair_a, pair_b];
        generate ekf;
        dynamics discrete {
            x1 = x1 + x2;
            x2 = x2;
            x3 = x3;
        }
    }
}

fn main() {}
