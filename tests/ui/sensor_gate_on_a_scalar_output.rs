stateforge::model! {
    /// A gate on a scalar output, which no sensor groups: it has its own update, judged by the filter's gate.
    pub mod m {
        scalar f32;
        state x1, x2, x3;
        output pair_a = x1, pair_b = x2, range = x1 + x3;
        sensor range(gate = 6.63) = [range];
        generate ekf;
        dynamics discrete {
            x1 = x1 + x2;
            x2 = x2;
            x3 = x3;
        }
    }
}

fn main() {}
