stateforge::model! {
    /// Equations whose value has another type than their state.
    pub mod m {
        scalar f32;
        const DT = 0.01;
        state
            /// attitude
            q: Rot3,
            /// velocity
            v: Vec3,
            /// a number
            s;
        input
            /// rate
            w: Vec3;
        output y = s;
        dynamics discrete {
            q = w * DT;
            v = 1.0;
            s = v;
        }
    }
}

fn main() {}
