stateforge::model! {
    /// A delayed sensor whose output reads an input.
    pub mod m {
        scalar f32;
        state x1, x2;
        input u;
        output pair_a = x1 + u, pair_b = x2;
        sensor pair(delay = 3) = [pair_a, pair_b];
        generate ekf;
        dynamics discrete {
            x1 = x1 + x2;
            x2 = x2 + 0.1 * u;
        }
    }
}

fn main() {}
