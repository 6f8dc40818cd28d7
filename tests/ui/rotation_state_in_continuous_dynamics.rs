stateforge::model! {
    /// A rotation given a derivative.
    pub mod m {
        scalar f32;
        state
            /// attitude
            q: Rot3;
        input
            /// rate
            w: Vec3;
        output y = log(q).x;
        dynamics continuous(rk4, dt = 0.01) {
            der(q) = exp(w);
        }
    }
}

fn main() {}
