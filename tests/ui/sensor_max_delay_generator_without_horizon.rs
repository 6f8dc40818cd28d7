stateforge::model! {
    /// A run-time delay asked of a generator with no delayed horizon.
    pub mod m {
        scalar f32;
        state x1, x2, x3;
        output pair_a = x1, pair_b = x2;
        sensor pair(max_delay = 3) = [pair_a, pair_b];
        generate dkf;
        dynamics discrete {
            x1 = x1 + x2;
            x2 = x2;
            x3 = x3;
        }
    }
}

fn main() {}
