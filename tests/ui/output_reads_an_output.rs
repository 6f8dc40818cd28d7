stateforge::model! {
    /// An output that reads another output: the error says how to share the value.
    pub mod m {
        scalar f32;
        state x1, x2;
        output speed = x1 * x1 + x2 * x2, speed_twice = 2.0 * speed;
        dynamics discrete {
            x1 = x2;
            x2 = -x1;
        }
    }
}

fn main() {}
