stateforge::model! {
    /// A rotation as an output, as a known value, and a vector as a constant.
    pub mod m {
        scalar f32;
        const G = vec3(0.0, 0.0, 9.81);
        state
            /// attitude
            q: Rot3;
        known
            /// mounting
            mount: Rot3;
        input
            /// rate
            w: Vec3;
        output y = q;
        dynamics discrete {
            q = q * exp(w * 0.01);
        }
    }
}

fn main() {}
