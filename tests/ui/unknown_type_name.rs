stateforge::model! {
    /// Types named as in nalgebra or as a number: each error says what to write.
    pub mod m {
        scalar f32;
        state
            /// velocity
            v: Vector3,
            /// attitude
            q: UnitQuaternion,
            /// a number
            s: f32;
        output y = s;
        dynamics discrete {
            v = v;
            q = q;
            s = s;
        }
    }
}

fn main() {}
