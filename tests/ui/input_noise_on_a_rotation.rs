stateforge::model! {
    /// Input noise listing a rotation input, whose noise is not supported.
    pub mod m {
        scalar f32;
        state v: Vec3;
        input turn: Rot3;
        output y = v;
        generate ekf(input_noise = [turn]);
        dynamics discrete {
            v = turn * v;
        }
    }
}

fn main() {}
